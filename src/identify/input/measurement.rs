//! Measured rail-pad forces: reading a CSV record, checking it once (parse, don't validate),
//! and putting it on the bank's time axis (laser trigger, or cross-correlation with the bank's
//! flat-free prediction).
//!
//! File format (what `wheelflat simulate` and `wheelflat synth` write):
//!
//! ```text
//! # laser_trigger_s = 0.3760        optional: when the leading wheel passed the laser (file clock)
//! # speed_km_per_h = 50             optional: checked against the bank's speed
//! # bogie_id = 4711-2                optional: the bogie measured (its wheels' history)
//! time_s,rps1_kn,rps2_kn
//! 0.000000,0.0173,-0.1595
//! ```
//!
//! A broken sensor is simply absent, or left out with `--sensors`.

use crate::bank::family::SPEED_TOLERANCE;
use crate::bank::schema::SensorAxis;
use crate::identify::error::IdentifyError;
use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use std::path::{Path, PathBuf};

/// The most sensor columns a measurement may have (a wayside site has a handful).
pub(crate) const MAX_SENSOR_COLUMNS: usize = 64;

/// The longest line a measurement may have (64 columns of numbers need about 2 kB).
pub(crate) const MAX_LINE_BYTES: usize = 16 << 10;

/// A checked measurement: finite samples, strictly increasing time on a uniform grid.
#[derive(Debug, Clone, PartialEq)]
pub struct Measurement {
    /// Where it came from (for messages).
    pub path: PathBuf,
    /// Time of sample 0 (s, file clock).
    pub t0_s: f64,
    /// Sample interval (s).
    pub dt_s: f64,
    /// Sensor names, in file order.
    pub sensors: Vec<String>,
    /// Samples per sensor (kN).
    pub values_kn: Vec<Vec<f64>>,
    /// Laser trigger time of the leading wheel (file clock), if recorded.
    pub laser_trigger_s: Option<f64>,
    /// Train speed, if recorded.
    pub speed_km_per_h: Option<f64>,
    /// The bogie measured (`# bogie_id = …`), if named: its wheels are `<id>/leading` and
    /// `<id>/trailing` in the results database.
    pub bogie_id: Option<String>,
    /// The wheel's static load (kN) known from elsewhere (`# reference_wheel_load_kn = …`: a
    /// weighbridge, or the vehicle named in the consist), if given: what `calibrate` reads the
    /// sensors' absolute gains from (docs/calibration.md, "Absolute gains").
    pub reference_wheel_load_kn: Option<f64>,
}

/// The range a reference wheel load may take (kN): a tram's empty wheel to a heavy-haul
/// wagon's loaded one, with room.
pub(crate) const REFERENCE_WHEEL_LOAD_KN: [f64; 2] = [5.0, 300.0];

/// The longest bogie id (characters).
pub(crate) const MAX_BOGIE_ID_CHARS: usize = 64;

/// Checks a bogie id: 1 to [`MAX_BOGIE_ID_CHARS`] characters out of letters, digits and
/// `. _ - :` (no `/`: it separates the bogie from the wheel in a wheel id). The reason when
/// not.
// Err(String): the message of the caller's `IdentifyError::Measurement` (file and line).
pub(crate) fn check_bogie_id(id: &str) -> Result<&str, String> {
    if id.is_empty() || id.chars().count() > MAX_BOGIE_ID_CHARS {
        return Err(format!(
            "bogie id `{id}` must have 1 to {MAX_BOGIE_ID_CHARS} characters"
        ));
    }
    match id
        .chars()
        .find(|c| !(c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-' | ':')))
    {
        Some(c) => Err(format!(
            "bogie id `{id}` holds `{c}`: letters, digits and . _ - : only"
        )),
        None => Ok(id),
    }
}

fn bad(path: &Path, line: usize, message: String) -> IdentifyError {
    IdentifyError::Measurement {
        path: path.to_path_buf(),
        line,
        message,
    }
}

impl Measurement {
    /// Reads and checks a measurement CSV. `expected_rate_hz` is the bank's sample rate.
    pub fn from_csv(
        path: &Path,
        text: &str,
        expected_rate_hz: f64,
    ) -> Result<Measurement, IdentifyError> {
        let mut laser = None;
        let mut speed = None;
        let mut bogie_id = None;
        let mut reference = None;
        let mut header: Option<(usize, Vec<String>)> = None;
        let mut time = Vec::new();
        let mut columns: Vec<Vec<f64>> = Vec::new();
        for (i, raw) in text.lines().enumerate() {
            let line_no = i + 1;
            if raw.len() > MAX_LINE_BYTES {
                return Err(bad(
                    path,
                    line_no,
                    format!(
                        "{} bytes on one line, more than the {MAX_LINE_BYTES} a line may have",
                        raw.len()
                    ),
                ));
            }
            let line = raw.trim();
            if line.is_empty() {
                continue;
            }
            if let Some(comment) = line.strip_prefix('#') {
                if let Some((k, v)) = comment.split_once('=') {
                    let (k, v) = (k.trim(), v.trim());
                    let parse = |v: &str| {
                        v.parse::<f64>()
                            .ok()
                            .filter(|x| x.is_finite())
                            .ok_or_else(|| {
                                bad(
                                    path,
                                    line_no,
                                    format!("`{k}` = `{v}` is not a finite number"),
                                )
                            })
                    };
                    match k {
                        "laser_trigger_s" => laser = Some(parse(v)?),
                        "speed_km_per_h" => speed = Some(parse(v)?),
                        "bogie_id" => {
                            let id = check_bogie_id(v).map_err(|e| bad(path, line_no, e))?;
                            bogie_id = Some(id.to_string());
                        }
                        "reference_wheel_load_kn" => {
                            let [lo, hi] = REFERENCE_WHEEL_LOAD_KN;
                            let x = parse(v)?;
                            if !(lo..=hi).contains(&x) {
                                return Err(bad(
                                    path,
                                    line_no,
                                    format!("`{k}` = {x} kN: a wheel's static load is read in {lo}–{hi} kN"),
                                ));
                            }
                            reference = Some(x);
                        }
                        _ => {}
                    }
                }
                continue;
            }
            let fields: Vec<&str> = line.split(',').map(str::trim).collect();
            let Some((_, names)) = &header else {
                if fields.first() != Some(&"time_s") {
                    return Err(bad(
                        path,
                        line_no,
                        format!(
                            "the header must start with `time_s`, found `{}`",
                            fields.first().unwrap_or(&"")
                        ),
                    ));
                }
                if fields.len() - 1 > MAX_SENSOR_COLUMNS {
                    return Err(bad(
                        path,
                        line_no,
                        format!(
                            "{} sensor columns, more than the {MAX_SENSOR_COLUMNS} a measurement may have",
                            fields.len() - 1
                        ),
                    ));
                }
                let mut names = Vec::new();
                let mut seen = std::collections::HashSet::new();
                for f in &fields[1..] {
                    let name = match f.strip_suffix("_kn") {
                        Some(n) if !n.is_empty() => n,
                        _ if f.ends_with("_n") => {
                            return Err(bad(
                                path,
                                line_no,
                                format!("column `{f}` is in N: wheelflat reads forces in kN, in columns named `<sensor>_kn`"),
                            ))
                        }
                        _ => {
                            return Err(bad(
                                path,
                                line_no,
                                format!("column `{f}`: force columns are named `<sensor>_kn` (force in kN)"),
                            ))
                        }
                    };
                    if !seen.insert(name) {
                        return Err(bad(path, line_no, format!("sensor `{name}` appears twice")));
                    }
                    names.push(name.to_string());
                }
                if names.is_empty() {
                    return Err(bad(path, line_no, "no sensor columns".into()));
                }
                columns = vec![Vec::new(); names.len()];
                header = Some((line_no, names));
                continue;
            };
            if fields.len() != names.len() + 1 {
                return Err(bad(
                    path,
                    line_no,
                    format!(
                        "{} fields, the header has {}",
                        fields.len(),
                        names.len() + 1
                    ),
                ));
            }
            let value = |j: usize| -> Result<f64, IdentifyError> {
                let col = if j == 0 {
                    "time_s".to_string()
                } else {
                    format!("{}_kn", names[j - 1])
                };
                fields[j]
                    .parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| {
                        bad(
                            path,
                            line_no,
                            format!("`{col}` = `{}` is not a finite number", fields[j]),
                        )
                    })
            };
            let t = value(0)?;
            if let Some(&prev) = time.last() {
                if t <= prev {
                    return Err(bad(
                        path,
                        line_no,
                        format!("time {t} s does not increase (previous {prev} s)"),
                    ));
                }
            }
            time.push(t);
            for (j, col) in columns.iter_mut().enumerate() {
                col.push(value(j + 1)?);
            }
            // Sample-rate check as we go, so the message names the line.
            if time.len() >= 2 {
                let dt = time[time.len() - 1] - time[time.len() - 2];
                let expected = 1.0 / expected_rate_hz;
                if (dt - expected).abs() > 0.01 * expected {
                    return Err(bad(
                        path,
                        line_no,
                        format!(
                            "time step {:.6} s ({:.1} Hz) does not match the bank's sample rate {expected_rate_hz} Hz",
                            dt,
                            1.0 / dt
                        ),
                    ));
                }
            }
        }
        let Some((header_line, sensors)) = header else {
            return Err(bad(path, 1, "no header line `time_s,<sensor>_kn,…`".into()));
        };
        if time.len() < 2 {
            return Err(bad(
                path,
                header_line,
                format!("only {} data rows", time.len()),
            ));
        }
        for (name, col) in sensors.iter().zip(&columns) {
            let max = col.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            if max > 2000.0 {
                return Err(bad(
                    path,
                    header_line,
                    format!("`{name}_kn` reaches {max:.0}: that looks like newtons, not kN"),
                ));
            }
        }
        let n = time.len();
        Ok(Measurement {
            path: path.to_path_buf(),
            t0_s: time[0],
            dt_s: (time[n - 1] - time[0]) / (n - 1) as f64,
            sensors,
            values_kn: columns,
            laser_trigger_s: laser,
            speed_km_per_h: speed,
            bogie_id,
            reference_wheel_load_kn: reference,
        })
    }

    /// The pass's train speed (km/h): its `# speed_km_per_h` line, or `given` (a `--speed`
    /// flag) when it has none; both must agree within 0.1 %, and neither is an error: the
    /// speed picks the bank the pass is compared with and is never assumed.
    pub fn pass_speed(&self, given: Option<f64>) -> Result<f64, IdentifyError> {
        match (self.speed_km_per_h, given) {
            (Some(line), Some(flag)) if (line / flag - 1.0).abs() > 1e-3 => Err(bad(
                &self.path,
                1,
                format!("its speed line says {line} km/h, --speed says {flag} km/h"),
            )),
            (Some(v), _) | (None, Some(v)) if !(1.0..=500.0).contains(&v) => Err(bad(
                &self.path,
                1,
                format!("speed {v} km/h is not a train speed (1 to 500 km/h)"),
            )),
            (Some(v), _) | (None, Some(v)) => Ok(v),
            (None, None) => Err(bad(
                &self.path,
                1,
                "no `# speed_km_per_h = …` line and no --speed: the pass's speed picks the bank it is compared with, and is never assumed".into(),
            )),
        }
    }

    /// The pass on a bank's time axis: itself when it states no speed or the bank's, else
    /// [`Measurement::at_speed`] when within [`SPEED_TOLERANCE`] of the bank's speed; farther,
    /// an error (a bank family has a member nearer).
    pub fn at_bank_speed(&self, bank_km_per_h: f64) -> Result<Cow<'_, Measurement>, IdentifyError> {
        let v = match self.speed_km_per_h {
            Some(v) if (v - bank_km_per_h).abs() > 1e-9 => v,
            _ => return Ok(Cow::Borrowed(self)),
        };
        let off = v / bank_km_per_h - 1.0;
        if off.abs() > SPEED_TOLERANCE + 1e-12 {
            return Err(bad(
                &self.path,
                1,
                format!(
                    "speed {v} km/h differs from the bank's {bank_km_per_h} km/h by {:+.1} %, more than the {:.0} % a bank covers (measured, docs/bank.md); use a bank family over the speeds you need",
                    off * 100.0,
                    SPEED_TOLERANCE * 100.0
                ),
            ));
        }
        Ok(Cow::Owned(self.at_speed(v, bank_km_per_h)))
    }

    /// The pass as it would have been recorded at `bank_km_per_h` instead of `pass_km_per_h`:
    /// the wheel reaches each place along the rail at file time × v_pass / v_bank (the laser
    /// trigger's time scaled alike), resampled on the same interval by linear interpolation.
    /// Only the kinematics are scaled: forces that depend on speed (impact heights) are not.
    pub fn at_speed(&self, pass_km_per_h: f64, bank_km_per_h: f64) -> Measurement {
        let r = pass_km_per_h / bank_km_per_h;
        let n = self.len();
        let span = (n.saturating_sub(1)) as f64 * self.dt_s * r;
        let samples = (span / self.dt_s + 1e-9).floor() as usize + 1;
        let t0 = self.t0_s * r;
        let values_kn = (0..self.sensors.len())
            .map(|s| {
                (0..samples)
                    .map(|k| {
                        let t_file = (t0 + k as f64 * self.dt_s) / r;
                        self.at(s, t_file)
                            .unwrap_or(self.values_kn[s][if k == 0 { 0 } else { n - 1 }])
                    })
                    .collect()
            })
            .collect();
        Measurement {
            path: self.path.clone(),
            t0_s: t0,
            dt_s: self.dt_s,
            sensors: self.sensors.clone(),
            values_kn,
            laser_trigger_s: self.laser_trigger_s.map(|t| t * r),
            speed_km_per_h: Some(bank_km_per_h),
            bogie_id: self.bogie_id.clone(),
            reference_wheel_load_kn: self.reference_wheel_load_kn,
        }
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.values_kn.first().map_or(0, Vec::len)
    }

    /// True when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Value of sensor `s` at file time `t` by linear interpolation (`None` outside the record).
    pub fn at(&self, s: usize, t: f64) -> Option<f64> {
        let x = (t - self.t0_s) / self.dt_s;
        let n = self.len();
        if x < -1e-9 || x > (n - 1) as f64 + 1e-9 {
            return None;
        }
        let x = x.clamp(0.0, (n - 1) as f64);
        let i = (x.floor() as usize).min(n - 2);
        let f = x - i as f64;
        let v = &self.values_kn[s];
        Some(v[i] * (1.0 - f) + v[i + 1] * f)
    }

    /// The series of sensor `s` on a bank window: bank time = file time + `shift_s`.
    pub fn on_window(
        &self,
        s: usize,
        axis: &SensorAxis,
        shift_s: f64,
    ) -> Result<Vec<f64>, IdentifyError> {
        (0..axis.samples)
            .map(|k| {
                let t_bank = (axis.first_sample + k) as f64 / axis.sample_rate_hz;
                self.at(s, t_bank - shift_s)
                    .ok_or_else(|| IdentifyError::TooShort {
                        path: self.path.clone(),
                        sensor: self.sensors[s].clone(),
                        needed: [
                            axis.t0_s - shift_s,
                            axis.t0_s + (axis.samples - 1) as f64 / axis.sample_rate_hz - shift_s,
                        ],
                        recorded: [self.t0_s, self.t0_s + (self.len() - 1) as f64 * self.dt_s],
                    })
            })
            .collect()
    }
}

/// One measured series, resampled onto a sensor's bank window.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MeasuredSeries {
    /// Sensor name.
    pub sensor: String,
    /// Bank time of sample 0 (s).
    pub t0_s: f64,
    /// Sample rate (Hz).
    pub sample_rate_hz: f64,
    /// Measured force (kN) at the bank's sample times.
    pub values_kn: Vec<f64>,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(speed: Option<f64>) -> Measurement {
        // A force that grows with time: 1 kN per ms, from t = 0.1 s, 2.5 kHz.
        let dt = 4e-4;
        Measurement {
            path: PathBuf::from("p.csv"),
            t0_s: 0.1,
            dt_s: dt,
            sensors: vec!["rps1".into()],
            values_kn: vec![(0..1000).map(|k| (0.1 + k as f64 * dt) * 1e3).collect()],
            laser_trigger_s: Some(0.2),
            speed_km_per_h: speed,
            bogie_id: None,
            reference_wheel_load_kn: None,
        }
    }

    #[test]
    fn a_reference_load_is_read_and_checked() {
        let body = "time_s,rps1_kn\n0.0,1.0\n0.0004,1.1\n0.0008,1.2\n";
        let read = |head: &str| {
            Measurement::from_csv(Path::new("p.csv"), &format!("{head}{body}"), 2500.0)
        };
        let m = read("# reference_wheel_load_kn = 49.5\n").unwrap();
        assert_eq!(m.reference_wheel_load_kn, Some(49.5));
        assert_eq!(read("").unwrap().reference_wheel_load_kn, None);
        let e = read("# reference_wheel_load_kn = 4950\n")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("p.csv, line 1") && e.contains("4950") && e.contains("5–300 kN"),
            "{e}"
        );
        let e = read("# reference_wheel_load_kn = heavy\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("`heavy` is not a finite number"), "{e}");
    }

    #[test]
    fn a_bogie_id_is_read_and_checked() {
        let text = "# bogie_id = 4711-2\ntime_s,rps1_kn\n0.0,1.0\n0.0004,1.1\n0.0008,1.2\n";
        let m = Measurement::from_csv(Path::new("m.csv"), text, 2500.0).unwrap();
        assert_eq!(m.bogie_id.as_deref(), Some("4711-2"));
        let bad = text.replace("4711-2", "47/11");
        let e = Measurement::from_csv(Path::new("m.csv"), &bad, 2500.0)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("m.csv") && e.contains("line 1") && e.contains("holds `/`"),
            "{e}"
        );
        assert!(check_bogie_id(&"x".repeat(65)).is_err());
    }

    #[test]
    fn a_pass_is_put_on_the_bank_speed_time_axis_exactly_for_a_linear_signal() {
        // At 49 km/h the wheel reaches a place at time t; at 50 km/h at t·49/50. The scaled
        // series at bank time t' is the pass's at t'·50/49 (linear interpolation is exact on
        // a ramp, so to rounding: 1e-9 kN).
        let m = ramp(Some(49.0));
        let s = m.at_bank_speed(50.0).unwrap();
        let r = 49.0 / 50.0;
        assert_eq!(s.dt_s.to_bits(), m.dt_s.to_bits());
        assert!((s.t0_s - 0.1 * r).abs() < 1e-15);
        assert!((s.laser_trigger_s.unwrap() - 0.2 * r).abs() < 1e-15);
        assert_eq!(s.speed_km_per_h, Some(50.0));
        // The record spans the same places: (n − 1)·dt·r long.
        assert_eq!(s.len(), ((999.0 * r) as usize) + 1);
        for k in 0..s.len() {
            let t_bank = s.t0_s + k as f64 * s.dt_s;
            let want = t_bank / r * 1e3;
            assert!((s.values_kn[0][k] - want).abs() < 1e-9, "sample {k}");
        }
        // The bank's own speed, or none: the pass itself.
        assert!(matches!(
            ramp(Some(50.0)).at_bank_speed(50.0).unwrap(),
            Cow::Borrowed(_)
        ));
        assert!(matches!(
            ramp(None).at_bank_speed(50.0).unwrap(),
            Cow::Borrowed(_)
        ));
        // Beyond 3 %: refused, saying by how much.
        let e = ramp(Some(52.0))
            .at_bank_speed(50.0)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("p.csv, line 1: speed 52 km/h differs from the bank's 50 km/h by +4.0 %"),
            "{e}"
        );
    }

    #[test]
    fn the_pass_speed_comes_from_its_line_or_the_flag_and_is_never_assumed() {
        let speed = |m: Measurement, flag| m.pass_speed(flag).unwrap().to_bits();
        assert_eq!(speed(ramp(Some(48.0)), None), 48f64.to_bits());
        assert_eq!(speed(ramp(None), Some(47.0)), 47f64.to_bits());
        assert_eq!(speed(ramp(Some(48.0)), Some(48.0)), 48f64.to_bits());
        let e = ramp(Some(48.0))
            .pass_speed(Some(50.0))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("its speed line says 48 km/h, --speed says 50 km/h"),
            "{e}"
        );
        let e = ramp(None).pass_speed(None).unwrap_err().to_string();
        assert!(
            e.contains("no `# speed_km_per_h = …` line and no --speed"),
            "{e}"
        );
        let e = ramp(Some(900.0)).pass_speed(None).unwrap_err().to_string();
        assert!(e.contains("900 km/h is not a train speed"), "{e}");
    }
}
