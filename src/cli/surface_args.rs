//! The wheel and rail surfaces of `simulate` and `synth`: measured traces, roughness drawn from
//! a class, out-of-round wheels, the contact filter (docs/model.md §5b).

use anyhow::{Context, Result};
use clap::Args;
use std::path::PathBuf;
use wheelflat::model::surface::{parse_trace, Harmonic, RoughnessClass, SurfaceSpec};
use wheelflat::model::{ContactFilter, RailSurface, WheelPosition, WheelSurface};
use wheelflat::pass::input::read_text;

/// The largest trace file read (bytes): 10 million samples of two short columns.
pub(super) const MAX_TRACE_BYTES: u64 = 256 << 20;

// Surfaces.
#[derive(Debug, Args)]
pub(super) struct SurfaceArgs {
    /// A wheel's measured tread: a trace over one revolution, position (mm) and radius
    /// deviation (µm; negative where material is missing), comma, semicolon, tab or space
    /// separated, decimal commas read (the wheel and where it touches the rail from its
    /// `# wheel =` and `# touch_x_m =` lines, or the flags below). Repeat for the other wheel.
    #[arg(long = "wheel-profile")]
    pub wheel_profile: Vec<PathBuf>,
    /// The wheel of a `--wheel-profile` without a `# wheel =` line.
    #[arg(long = "profile-wheel", value_parser = parse_wheel)]
    pub profile_wheel: Option<WheelPosition>,
    /// Where the trace's first point touches the rail (m), for a `--wheel-profile` without a
    /// `# touch_x_m =` line.
    #[arg(long = "touch-x-m")]
    pub touch_x_m: Option<f64>,
    /// The rail head's measured trace: position along the rail and deviation, as a wheel's; it
    /// starts at `--rail-start-m` (default: its first position, in m).
    #[arg(long = "rail-profile")]
    pub rail_profile: Option<PathBuf>,
    /// Rail position of the rail trace's first point (m).
    #[arg(long = "rail-start-m")]
    pub rail_start_m: Option<f64>,
    /// Both wheels' treads drawn from a published roughness class, `CLASS[:SEED]`: `disc`,
    /// `composite`, `cast-iron`, `cast-iron-rough` (CNOSSOS-EU wheel spectra; docs/model.md
    /// §5b), each wheel its own draw.
    #[arg(long, value_parser = parse_class_seed)]
    pub roughness: Option<(RoughnessClass, u64)>,
    /// The rail drawn from a roughness class, `iso3095[:SEED]` (the EN ISO 3095 limit).
    #[arg(long = "rail-roughness", value_parser = parse_rail_seed)]
    pub rail_roughness: Option<(RoughnessClass, u64)>,
    /// An out-of-round wheel: `WHEEL:ORDER:AMPLITUDE_UM[:PHASE_DEG]`, e.g. `leading:12:30`
    /// (order 1: eccentric; repeat for more harmonics).
    #[arg(long = "out-of-round", value_parser = parse_harmonic)]
    pub out_of_round: Vec<(WheelPosition, Harmonic)>,
    /// The contact filter the surfaces go through: `default` (the Hertz patch's average, then
    /// the rolling circle), `none` (the trace as the wheel's drop, as the independent
    /// implementation), `patch`, `circle`.
    #[arg(long = "contact-filter", default_value = "default", value_parser = parse_filter)]
    pub contact_filter: ContactFilter,
}

// Err(String): a clap value parser: clap names the argument and prints the message.
fn parse_wheel(text: &str) -> Result<WheelPosition, String> {
    match text {
        "leading" => Ok(WheelPosition::Leading),
        "trailing" => Ok(WheelPosition::Trailing),
        _ => Err(format!("`{text}` is not a wheel: leading or trailing")),
    }
}

// Err(String): a clap value parser: clap names the argument and prints the message.
fn parse_seed(text: &str, rest: Option<&str>) -> Result<u64, String> {
    rest.map_or(Ok(1), |s| {
        s.parse()
            .map_err(|_| format!("`{text}`: the seed `{s}` is not a whole number"))
    })
}

// Err(String): a clap value parser: clap names the argument and prints the message.
fn parse_class_seed(text: &str) -> Result<(RoughnessClass, u64), String> {
    let (name, seed) = text
        .split_once(':')
        .map_or((text, None), |(a, b)| (a, Some(b)));
    let class = RoughnessClass::from_name(name)
        .filter(|c| !c.is_rail())
        .ok_or_else(|| {
            format!("`{name}` is not a wheel roughness class: disc, composite, cast-iron or cast-iron-rough")
        })?;
    Ok((class, parse_seed(text, seed)?))
}

// Err(String): a clap value parser: clap names the argument and prints the message.
fn parse_rail_seed(text: &str) -> Result<(RoughnessClass, u64), String> {
    let (name, seed) = text
        .split_once(':')
        .map_or((text, None), |(a, b)| (a, Some(b)));
    if name != "iso3095" {
        return Err(format!("`{name}` is not a rail roughness class: iso3095"));
    }
    Ok((RoughnessClass::RailIso3095, parse_seed(text, seed)?))
}

// Err(String): a clap value parser: clap names the argument and prints the message.
fn parse_harmonic(text: &str) -> Result<(WheelPosition, Harmonic), String> {
    let f: Vec<&str> = text.split(':').collect();
    if !(3..=4).contains(&f.len()) {
        return Err(format!(
            "`{text}`: expected WHEEL:ORDER:AMPLITUDE_UM[:PHASE_DEG], e.g. leading:12:30"
        ));
    }
    let wheel = parse_wheel(f[0])?;
    let order: u32 = f[1]
        .parse()
        .ok()
        .filter(|n| (1..=100).contains(n))
        .ok_or_else(|| format!("`{text}`: order `{}` is not a whole number 1 to 100", f[1]))?;
    // Err(String): a clap value parser: clap names the argument and prints the message.
    let num = |s: &str, what: &str, lim: f64| -> Result<f64, String> {
        s.parse::<f64>()
            .ok()
            .filter(|v| v.is_finite() && v.abs() <= lim)
            .ok_or_else(|| format!("`{text}`: {what} `{s}` is not a number within ±{lim}"))
    };
    let amplitude_um = num(f[2], "amplitude (µm)", 5000.0)?;
    let phase_deg = f.get(3).map_or(Ok(0.0), |p| num(p, "phase (°)", 360.0))?;
    Ok((
        wheel,
        Harmonic {
            order,
            amplitude_m: amplitude_um * 1e-6,
            phase_rad: phase_deg.to_radians(),
        },
    ))
}

// Err(String): a clap value parser: clap names the argument and prints the message.
fn parse_filter(text: &str) -> Result<ContactFilter, String> {
    let (patch, rolling_circle) = match text {
        "default" => (true, true),
        "none" => (false, false),
        "patch" => (true, false),
        "circle" => (false, true),
        _ => {
            return Err(format!(
                "`{text}` is not a contact filter: default, none, patch or circle"
            ))
        }
    };
    Ok(ContactFilter {
        patch,
        rolling_circle,
    })
}

impl SurfaceArgs {
    /// The surfaces asked for, the trace files read within their bounds and checked.
    pub(super) fn spec(&self) -> Result<SurfaceSpec> {
        let mut spec = SurfaceSpec {
            wheel_roughness: self.roughness,
            rail_roughness: self.rail_roughness,
            out_of_round: self.out_of_round.clone(),
            filter: self.contact_filter,
            ..SurfaceSpec::default()
        };
        for path in &self.wheel_profile {
            let text = read_text(path, MAX_TRACE_BYTES, "wheel profile")?;
            let name = path.display().to_string();
            let file = parse_trace(&name, &text)?;
            let wheel = file.wheel.or(self.profile_wheel).with_context(|| {
                format!("{name}: which wheel? give `# wheel = leading|trailing` in the file or --profile-wheel")
            })?;
            let touch_x_m = file.touch_x_m.or(self.touch_x_m).with_context(|| {
                format!("{name}: where does its first point touch the rail? give `# touch_x_m = …` in the file or --touch-x-m")
            })?;
            spec.wheel_traces.push((
                WheelSurface {
                    wheel,
                    trace: file.trace,
                    touch_x_m,
                },
                name,
            ));
        }
        if let Some(path) = &self.rail_profile {
            let text = read_text(path, MAX_TRACE_BYTES, "rail profile")?;
            let name = path.display().to_string();
            let file = parse_trace(&name, &text)?;
            spec.rail_trace = Some((
                RailSurface {
                    start_x_m: self.rail_start_m.unwrap_or(file.start_m),
                    trace: file.trace,
                },
                name,
            ));
        }
        Ok(spec)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn harmonics_classes_and_filters_parse_and_refuse_by_name() {
        let (w, h) = parse_harmonic("leading:12:30:45").unwrap();
        assert_eq!((w, h.order), (WheelPosition::Leading, 12));
        assert!((h.amplitude_m - 30e-6).abs() < 1e-15);
        assert!((h.phase_rad - 45f64.to_radians()).abs() < 1e-12);
        assert!(parse_harmonic("left:12:30").unwrap_err().contains("`left`"));
        assert!(parse_harmonic("leading:0:30")
            .unwrap_err()
            .contains("order"));
        assert!(parse_harmonic("leading:3:9e9")
            .unwrap_err()
            .contains("amplitude"));
        assert_eq!(
            parse_class_seed("cast-iron:7").unwrap(),
            (RoughnessClass::CastIron, 7)
        );
        assert!(parse_class_seed("iso3095").is_err());
        assert!(parse_class_seed("disc:x").unwrap_err().contains("seed"));
        assert_eq!(
            parse_rail_seed("iso3095").unwrap(),
            (RoughnessClass::RailIso3095, 1)
        );
        assert_eq!(
            parse_filter("none").unwrap(),
            ContactFilter {
                patch: false,
                rolling_circle: false
            }
        );
        assert!(parse_filter("soft").is_err());
    }
}
