//! A train pass's trigger file (one laser time per wheel) and the bogies it gives: their
//! trigger pairs and speeds.

use crate::identify::IdentifyError;
use crate::model::CheckedCalibration;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Reads a trigger file: one time per wheel passing the laser (s, recording clock), an
/// optional `time_s` header, `#` comments. Errors name the file, line and value.
pub fn read_triggers(path: &Path, text: &str) -> Result<Vec<f64>, IdentifyError> {
    let bad = |line: usize, message: String| IdentifyError::Measurement {
        path: path.to_path_buf(),
        line,
        message,
    };
    let mut times: Vec<f64> = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') || (i == 0 && line == "time_s") {
            continue;
        }
        let t: f64 = line
            .parse()
            .map_err(|_| bad(i + 1, format!("`{line}` is not a time in seconds")))?;
        if !t.is_finite() {
            return Err(bad(i + 1, format!("`{line}` is not a finite time")));
        }
        if let Some(&prev) = times.last() {
            if t <= prev {
                return Err(bad(
                    i + 1,
                    format!("trigger time {t} s does not increase (previous {prev} s)"),
                ));
            }
        }
        times.push(t);
    }
    if times.is_empty() {
        return Err(bad(1, "no trigger times".into()));
    }
    Ok(times)
}

/// One bogie of a recording: its wheels' trigger times and the speed they give.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Bogie {
    /// Leading and trailing wheel's trigger times (s, recording clock).
    pub triggers_s: [f64; 2],
    /// The bogie's speed over the laser (km/h): wheelbase / time between its wheels.
    pub speed_km_per_h: f64,
}

/// Pairs the triggers into bogies (leading, trailing wheel), each with the speed its pair
/// gives over the calibration's wheelbase (a train may accelerate through the site, so every
/// bogie has its own); a speed outside 1–500 km/h is an error naming the line.
pub fn bogies_from_triggers(
    cal: &CheckedCalibration,
    path: &Path,
    times: &[f64],
) -> Result<Vec<Bogie>, IdentifyError> {
    if !times.len().is_multiple_of(2) {
        return Err(IdentifyError::Measurement {
            path: path.to_path_buf(),
            line: 1,
            message: format!(
                "{} trigger times: a half bogie has two wheels, so the count must be even",
                times.len()
            ),
        });
    }
    let wheelbase = 2.0 * cal.vehicle.half_wheelbase_m;
    times
        .chunks(2)
        .enumerate()
        .map(|(b, p)| {
            let gap = p[1] - p[0];
            let speed = wheelbase / gap * 3.6;
            if !(1.0..=500.0).contains(&speed) {
                return Err(IdentifyError::Measurement {
                    path: path.to_path_buf(),
                    line: 2 * b + 2,
                    message: format!(
                        "bogie {}: its wheels passed {gap:.4} s apart, which is {speed:.1} km/h over the {wheelbase:.2} m wheelbase: not a train speed (1 to 500 km/h)",
                        b + 1,
                    ),
                });
            }
            Ok(Bogie {
                triggers_s: [p[0], p[1]],
                speed_km_per_h: speed,
            })
        })
        .collect()
}
