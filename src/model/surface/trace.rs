//! Reading a surface trace from text: the formats roughness trolleys and wheel-profile
//! instruments write (docs/model.md §5b).
//!
//! Two numeric columns, position then deviation, one sample a line, at a uniform spacing:
//!
//! - separated by a comma, a semicolon, a tab or spaces; with a semicolon, a tab or spaces
//!   between the columns a comma inside a number is a **decimal comma** (`12,5;-3,25`);
//! - an optional header line naming the columns with their units: the position in `mm`
//!   (default) or `m`, the deviation in `um`/`µm`/`micron` (default), `mm` or `nm`
//!   (`s_mm,radius_deviation_um`, `Distance [m];Roughness [µm]`);
//! - `#` comment lines, among them `# wheel = leading|trailing` and where the trace's first
//!   point touches the rail, `# touch_x_m = 14.25` or the independent implementation's
//!   `# s = 0 touches the rail at x = 14.2508 m`.
//!
//! Every line is checked: a refusal names the file, the line and the value.

use super::{Trace, MAX_SAMPLES};
use crate::model::WheelPosition;
use thiserror::Error;

/// A trace file that cannot be read, with where.
#[derive(Debug, Clone, PartialEq, Error)]
#[error("{file}, line {line}: {reason}")]
pub struct TraceError {
    /// The file (as given).
    pub file: String,
    /// Line number (1-based; 0 for the file as a whole).
    pub line: usize,
    /// What is wrong, with the value.
    pub reason: String,
}

/// A trace as read, with what its comments say.
#[derive(Debug, Clone, PartialEq)]
pub struct TraceFile {
    /// The samples, in SI units.
    pub trace: Trace,
    /// Position of the first sample (m).
    pub start_m: f64,
    /// The wheel the file names (`# wheel = …`), if any.
    pub wheel: Option<WheelPosition>,
    /// Where the first sample touches the rail (m), if the file says.
    pub touch_x_m: Option<f64>,
}

/// Units of the two columns, as factors to metres.
#[derive(Debug, Clone, Copy)]
struct Units {
    position: f64,
    deviation: f64,
}

/// How a data line's columns are separated.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Separator {
    Comma,
    Semicolon,
    Tab,
    Spaces,
}

/// Reads `text` (the contents of `file`) as a trace.
pub fn parse_trace(file: &str, text: &str) -> Result<TraceFile, TraceError> {
    let err = |line: usize, reason: String| TraceError {
        file: file.to_string(),
        line,
        reason,
    };
    let mut units = Units {
        position: 1e-3,
        deviation: 1e-6,
    };
    let mut wheel = None;
    let mut touch = None;
    let mut positions: Vec<f64> = Vec::new();
    let mut values: Vec<f64> = Vec::new();
    let mut lines_read: Vec<usize> = Vec::new();
    let mut header_seen = false;
    for (k, raw) in text.lines().enumerate() {
        let no = k + 1;
        let line = raw.trim().trim_start_matches('\u{feff}');
        if line.is_empty() {
            continue;
        }
        if let Some(comment) = line.strip_prefix('#') {
            read_comment(comment, &mut wheel, &mut touch).map_err(|r| err(no, r))?;
            continue;
        }
        let sep = separator(line);
        let cells = split(line, sep);
        if cells.len() < 2 {
            return Err(err(
                no,
                format!("`{line}`: two columns expected (position, deviation)"),
            ));
        }
        let parsed: Vec<Option<f64>> = cells.iter().take(2).map(|c| number(c, sep)).collect();
        match (parsed[0], parsed[1]) {
            (Some(p), Some(v)) => {
                if positions.len() == MAX_SAMPLES {
                    return Err(err(
                        no,
                        format!("more than {MAX_SAMPLES} samples: not a trace this tool reads"),
                    ));
                }
                positions.push(p);
                values.push(v);
                lines_read.push(no);
            }
            _ if positions.is_empty() && !header_seen => {
                units = header_units(&cells[0], &cells[1]).map_err(|r| err(no, r))?;
                header_seen = true;
            }
            _ => {
                let bad = if parsed[0].is_none() {
                    &cells[0]
                } else {
                    &cells[1]
                };
                return Err(err(no, format!("`{bad}` is not a number")));
            }
        }
    }
    if positions.len() < 2 {
        return Err(err(
            0,
            format!("{} samples: a trace needs at least 2", positions.len()),
        ));
    }
    for (i, (&p, &v)) in positions.iter().zip(&values).enumerate() {
        if !(p.is_finite() && v.is_finite()) {
            return Err(err(lines_read[i], "not a finite number".into()));
        }
    }
    // A uniform spacing: every step within 5 % of the median step.
    let mut steps: Vec<f64> = positions.windows(2).map(|w| w[1] - w[0]).collect();
    let mut sorted = steps.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    if median <= 0.0 {
        return Err(err(
            lines_read[1],
            "positions must increase line by line".into(),
        ));
    }
    for (i, s) in steps.iter_mut().enumerate() {
        if (*s / median - 1.0).abs() > 0.05 {
            return Err(err(
                lines_read[i + 1],
                format!(
                    "position {} after {}: the samples must be evenly spaced (the median step is {})",
                    positions[i + 1],
                    positions[i],
                    median
                ),
            ));
        }
    }
    let spacing_m = (positions[positions.len() - 1] - positions[0]) / (positions.len() - 1) as f64
        * units.position;
    let deviation_m: Vec<f64> = values.iter().map(|v| v * units.deviation).collect();
    let trace = Trace::new(file, spacing_m, deviation_m).map_err(|e| err(0, e.to_string()))?;
    Ok(TraceFile {
        trace,
        start_m: positions[0] * units.position,
        wheel,
        touch_x_m: touch,
    })
}

/// `# key = value` comments wheelflat understands; others are skipped.
// Err(String): the reason of the caller's `SurfaceError` (file and line).
fn read_comment(
    comment: &str,
    wheel: &mut Option<WheelPosition>,
    touch: &mut Option<f64>,
) -> Result<(), String> {
    let c = comment.trim();
    if let Some(rest) = c.strip_prefix("wheel") {
        let v = rest.trim_start().trim_start_matches(['=', ':']).trim();
        *wheel = Some(match v {
            "leading" => WheelPosition::Leading,
            "trailing" => WheelPosition::Trailing,
            _ => return Err(format!("`wheel = {v}`: leading or trailing")),
        });
    } else if let Some(rest) = c.strip_prefix("touch_x_m") {
        let v = rest.trim_start().trim_start_matches('=').trim();
        *touch = Some(
            v.parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| format!("`touch_x_m = {v}` is not a position in m"))?,
        );
    } else if let Some(at) = c.find("touches the rail at x =") {
        let v = c[at + "touches the rail at x =".len()..].trim();
        let num: String = v
            .chars()
            .take_while(|ch| ch.is_ascii_digit() || matches!(ch, '.' | '-' | '+' | 'e' | 'E'))
            .collect();
        *touch = Some(
            num.parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| format!("`{v}` is not a position in m"))?,
        );
    }
    Ok(())
}

/// The separator of a data or header line.
fn separator(line: &str) -> Separator {
    if line.contains(';') {
        Separator::Semicolon
    } else if line.contains('\t') {
        Separator::Tab
    } else if line.split_whitespace().count() >= 2 {
        Separator::Spaces
    } else {
        Separator::Comma
    }
}

fn split(line: &str, sep: Separator) -> Vec<String> {
    let cells: Vec<&str> = match sep {
        Separator::Semicolon => line.split(';').collect(),
        Separator::Tab => line.split('\t').collect(),
        Separator::Spaces => line.split_whitespace().collect(),
        Separator::Comma => line.split(',').collect(),
    };
    cells
        .into_iter()
        .map(|c| c.trim().to_string())
        .filter(|c| !c.is_empty() || sep != Separator::Spaces)
        .collect()
}

/// A number, with a decimal comma where the columns are not comma-separated.
fn number(cell: &str, sep: Separator) -> Option<f64> {
    let c = if sep == Separator::Comma {
        cell.to_string()
    } else {
        cell.replace(',', ".")
    };
    c.parse::<f64>().ok()
}

/// The units a header line names (position, deviation).
// Err(String): the reason of the caller's `SurfaceError` (file and line).
fn header_units(position: &str, deviation: &str) -> Result<Units, String> {
    let p = position.to_lowercase();
    let d = deviation.to_lowercase();
    let position = if p.contains("mm") {
        1e-3
    } else if p.ends_with("_m") || p.contains("[m]") || p.contains("(m)") {
        1.0
    } else {
        1e-3
    };
    let deviation = if d.contains("um") || d.contains("µm") || d.contains("micron") {
        1e-6
    } else if d.contains("nm") {
        1e-9
    } else if d.contains("mm") {
        1e-3
    } else if d.chars().any(char::is_alphabetic) {
        1e-6
    } else {
        return Err(format!("`{deviation}`: a header names its columns"));
    };
    Ok(Units {
        position,
        deviation,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_independent_format_reads_with_its_wheel_and_touch() {
        let text = "# wheel = trailing\n# s = 0 touches the rail at x = 14.2508 m (and again every 2*pi*0.4 m)\ns_mm,radius_deviation_um\n0,0.00\n1,-1.50\n2,2.25\n";
        let t = parse_trace("p.csv", text).unwrap();
        assert_eq!(t.wheel, Some(WheelPosition::Trailing));
        assert_eq!(t.touch_x_m, Some(14.2508));
        assert!((t.trace.spacing_m() - 1e-3).abs() < 1e-15);
        assert!((t.trace.deviation_m()[1] + 1.5e-6).abs() < 1e-18);
    }

    #[test]
    fn decimal_commas_semicolons_tabs_and_units_read_alike() {
        let expect = |text: &str, spacing_m: f64, second_m: f64| {
            let t = parse_trace("t", text).unwrap();
            assert!((t.trace.spacing_m() - spacing_m).abs() < 1e-12, "{text}");
            assert!(
                (t.trace.deviation_m()[1] - second_m).abs() < 1e-15,
                "{text}"
            );
        };
        expect(
            "Distance [m];Roughness [µm]\n0,000;1,5\n0,001;-2,5\n",
            1e-3,
            -2.5e-6,
        );
        expect("0\t1,5\n0,5\t-2,5\n", 0.5e-3, -2.5e-6);
        expect("0 1.5\n0.5 -2.5\n", 0.5e-3, -2.5e-6);
        expect("x_mm,dev_mm\n0,0.001\n1,-0.002\n", 1e-3, -2e-6);
    }

    #[test]
    fn refusals_name_the_line_and_the_value() {
        let e = parse_trace("t.csv", "0,1\n1,abc\n").unwrap_err();
        assert_eq!(e.line, 2);
        assert!(e.to_string().contains("`abc` is not a number"), "{e}");
        let e = parse_trace("t.csv", "0,1\n1,2\n2,3\n6,4\n").unwrap_err();
        assert_eq!(e.line, 4);
        assert!(e.to_string().contains("evenly spaced"), "{e}");
        let e = parse_trace("t.csv", "0,1\n1,9000\n").unwrap_err();
        assert!(e.to_string().contains("sample 1"), "{e}");
        let e = parse_trace("t.csv", "# wheel = middle\n0,1\n1,2\n").unwrap_err();
        assert_eq!(e.line, 1);
        let e = parse_trace("t.csv", "0\n").unwrap_err();
        assert!(e.to_string().contains("two columns"), "{e}");
        assert!(parse_trace("t.csv", "1,0\n0,1\n").is_err());
    }
}
