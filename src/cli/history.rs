//! `wheelflat history` and the `--db` of `identify`, `train` and `watch`: storing passes in the
//! results database and reading a wheel's passes back as one joint answer.

use anyhow::{Context, Result};
use clap::Args;
use std::path::{Path, PathBuf};
use wheelflat::history::{fuse, Db, Failure, FailureKind, FusionRule, Window};
use wheelflat::pass::PassError;
use wheelflat::report::history::{draw_trend, HistoryReport};

// `history`.
#[derive(Debug, Args)]
pub(super) struct HistoryArgs {
    /// The results database `identify`, `train` and `watch` wrote with `--db`.
    #[arg(long, required_unless_present = "fleet", conflicts_with = "fleet")]
    pub db: Option<PathBuf>,
    /// Or every site's passes from the fleet store (a reader's login): the wheel across
    /// sites, each pass judged by its own site's bank, a site that disagrees named.
    #[command(flatten)]
    pub fleet: super::fleet::FleetArgs,
    /// The wheel, `<bogie_id>/leading` or `<bogie_id>/trailing`; without it, every wheel the
    /// database knows.
    #[arg(long)]
    pub wheel: Option<String>,
    /// Fuse the newest N passes (1–1000).
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u64).range(1..=1000))]
    pub last: u64,
    /// Only the passes within this many hours of the wheel's newest (flats grow, wheels are
    /// re-profiled).
    #[arg(long, value_parser = parse_hours)]
    pub hours: Option<f64>,
    /// How passes are combined: `robust` (what every pass allows but the few that may have
    /// lost the truth: one of 3–7 passes at φ = 0.95, two of 8–16) or `all`.
    #[arg(long, value_enum, default_value_t = Rule::Robust)]
    pub rule: Rule,
    /// The class limits from this calibration's `[maintenance]` (default: 25 / 40 mm on L0).
    #[arg(long)]
    pub calibration: Option<PathBuf>,
    /// Also write `history.json` and the trend figure `history.png` here.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// The fusion rule on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub(super) enum Rule {
    /// What every pass allows but the few that may have lost the truth (from three passes).
    Robust,
    /// What every pass allows.
    All,
}

/// A window in hours: positive, at most ten years.
// Err(String): a clap value parser: clap names the argument and prints the message.
fn parse_hours(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .parse()
        .map_err(|_| format!("`{s}` is not a number of hours"))?;
    if v > 0.0 && v <= 87_600.0 {
        Ok(v)
    } else {
        Err(format!("{v} hours: the window must lie in (0, 87600]"))
    }
}

/// The line saying where a pass of `bogie` was stored (`new`) or that it was in already.
pub(super) fn stored_line(db: &Path, bogie: Option<&str>, new: bool) -> String {
    let who = bogie.map_or("no bogie id: not in any wheel's history".to_string(), |b| {
        format!("bogie {b}")
    });
    format!(
        "{} {} ({who})",
        if new { "stored in" } else { "already in" },
        db.display()
    )
}

/// Stores a pass that gave no answer (`refused` when wheelflat declined the input, `failed`
/// otherwise) with its reason. The pass's own error stays the one reported: a database that
/// cannot take the note is named on stderr.
pub(super) fn store_failure(db: &mut Db, measurement: &Path, e: &anyhow::Error) {
    let refused = e.chain().any(|c| {
        c.is::<wheelflat::identify::IdentifyError>()
            || c.is::<wheelflat::pass::input::InputError>()
            || c.is::<wheelflat::train::TrainError>()
            || matches!(
                c.downcast_ref::<PassError>(),
                Some(
                    PassError::Input(_)
                        | PassError::NoMember { .. }
                        | PassError::NoMemberForBogie { .. }
                        | PassError::Identify(_)
                        | PassError::Train(_)
                )
            )
    });
    let kind = if refused {
        FailureKind::Refused
    } else {
        FailureKind::Failed
    };
    let failure = Failure::now(measurement.display().to_string(), kind, format!("{e:#}"));
    if let Err(store) = db.insert_failure(&failure) {
        eprintln!(
            "warning: the {} pass was not noted: {store}",
            failure.kind.as_str()
        );
    }
}

/// `wheelflat history`.
pub(super) fn run(a: &HistoryArgs) -> Result<()> {
    if let Some(target) = a.fleet.target()? {
        return across(a, &target);
    }
    let path = a.db.as_deref().expect("clap requires --db or --fleet");
    let db = Db::open_existing(path)?;
    let cal = super::load_calibration(a.calibration.as_deref())?;
    let (inspect, urgent) = (
        cal.identification.inspect_l0_mm,
        cal.identification.urgent_l0_mm,
    );
    let Some(wheel) = &a.wheel else {
        let wheels = db.wheels()?;
        println!(
            "{}: {} passes, {} named wheels",
            path.display(),
            db.pass_count()?,
            wheels.len()
        );
        for w in wheels {
            println!(
                "{:<32} {:>5} passes, newest {} ({})",
                w.wheel_id,
                w.passes,
                w.last_time,
                w.last_severity.map_or("no class".into(), |c| c.words())
            );
        }
        return Ok(());
    };
    let window = Window {
        last: a.last as usize,
        hours: a.hours,
    };
    let passes = db.wheel_passes(wheel, window)?;
    if passes.is_empty() {
        anyhow::bail!(
            "{}: no pass of wheel `{wheel}` (wheels are `<bogie_id>/leading` or `…/trailing`; `wheelflat history --db {}` lists them)",
            path.display(),
            path.display()
        );
    }
    let wheels: Vec<_> = passes.iter().map(|p| p.wheel.clone()).collect();
    let joint = fuse(
        &wheels,
        a.rule.fusion(),
        cal.identification.phi,
        urgent,
        inspect,
    );
    let ratios = [
        cal.identification.inspect_dynamic_ratio,
        cal.identification.urgent_dynamic_ratio,
    ];
    let report = HistoryReport::new(wheel, &passes, joint, [[inspect, urgent], ratios]);
    print!("{}", report.text());
    write_out(a, &report)
}

impl Rule {
    fn fusion(self) -> FusionRule {
        match self {
            Rule::Robust => FusionRule::Robust,
            Rule::All => FusionRule::All,
        }
    }
}

/// `history --fleet`: the wheel's passes at every site, fused; each pass names its site.
fn across(a: &HistoryArgs, target: &wheelflat::fleet::FleetTarget) -> Result<()> {
    let cal = super::load_calibration(a.calibration.as_deref())?;
    let rules = &cal.identification;
    let Some(wheel) = &a.wheel else {
        anyhow::bail!("history --fleet needs --wheel ID (the fleet page lists the wheels: `wheelflat serve --fleet`)");
    };
    let mut reader = wheelflat::fleet::FleetReader::connect(target)?;
    let window = Window {
        last: a.last as usize,
        hours: a.hours,
    };
    let passes = reader.wheel_passes(wheel, window)?;
    if passes.is_empty() {
        anyhow::bail!("{}: no pass of wheel `{wheel}` at any site", target.shown());
    }
    let limits = [
        [rules.inspect_l0_mm, rules.urgent_l0_mm],
        [rules.inspect_dynamic_ratio, rules.urgent_dynamic_ratio],
    ];
    let (report, across) =
        wheelflat::fleet::across_report(wheel, &passes, a.rule.fusion(), rules.phi, limits);
    print!(
        "{}",
        wheelflat::fleet::words::passes_text(wheel, &passes, &across.joint)
    );
    print!("{}", wheelflat::fleet::words::across_text(&across));
    write_out(a, &report)
}

/// `--out`: `history.json` and the trend figure.
fn write_out(a: &HistoryArgs, report: &HistoryReport) -> Result<()> {
    if let Some(out) = &a.out {
        super::create_output_folder(out)?;
        let json = out.join("history.json");
        super::write_file(
            &json,
            serde_json::to_string_pretty(report)
                .expect("a history serialises")
                .as_bytes(),
        )?;
        let png = out.join("history.png");
        draw_trend(report, &png).with_context(|| format!("cannot draw {}", png.display()))?;
        println!("wrote {} and {}", json.display(), png.display());
    }
    Ok(())
}
