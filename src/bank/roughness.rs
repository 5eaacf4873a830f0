//! How far rough treads and rails move a bank's good-wheel prediction, per roughness class
//! (docs/detection.md, "Rough wheels"): the bounds identification adds for them, and the
//! high-frequency level by which a pass's record tells which class its wheels belong to.
//!
//! For each wheel class (round, and the published spectra of [`RoughnessClass::WHEELS`]) on
//! each rail class asked for (smooth, or at the EN ISO 3095 limit), [`PASSES`] good-wheel
//! passes are simulated with the bank's own calibration, both wheels drawn from the class
//! (seeded), the trace as the wheel's drop (no contact filter: the harsher input, and the
//! independent implementation's), and compared with the smooth run on every bank axis:
//!
//! - `floor_kn`: the largest `|Δ̄_k|` where the averaged flat-free force `|ḡ_k|` is under 2 kN
//!   (no wheel near the sensor);
//! - `near_wheel_fraction`: the largest `(|Δ̄_k| − floor)/|ḡ_k|` where it is 2 kN or more;
//! - `hf_kn`: the largest, over the passes, of the median over the axes of the robust scale
//!   (1.4826 × median absolute value) of the record's high-frequency part `x − B₅x` over the
//!   loaded samples (`|ḡ| ≥ max(¼ peak, 2 kN)`), noise-free: the class's upper end;
//!
//! each the largest over the passes times [`SAFETY`] (the largest of a few dozen passes lies
//! below a high percentile of many: measured in docs/detection.md). `Δ̄` and `ḡ` are the
//! windows through the 5-sample binomial average `B₅` ([`crate::model::average`]), the one a
//! rough pass is compared through, taken on each window alone as identification takes it.
//!
//! The table depends only on the bank's contents, so it is computed once and kept beside the
//! shards as `roughness.json` (by `bank generate` when it completes a version, or by the first
//! identification that needs it): the JSON, then a last line `# crc32 XXXXXXXX` of the bytes
//! before it. It is checked as read (CRC-32, format, bank id, finite non-negative values) and
//! computed again when it fails: a cache, not part of the manifest; `bank verify` reports a
//! damaged one.

use super::reader::Bank;
use super::schema::SensorAxis;
use super::BankError;
use crate::model::average::{centred_average, BINOMIAL5};
use crate::model::surface::{rail_roughness, wheel_roughness, RoughnessClass};
use crate::model::{
    CheckedCalibration, ContactFilter, RailSurface, Record, Response, Simulator, Surfaces,
    WheelPosition, WheelSurface,
};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// The table's file name inside a version directory.
pub(crate) const ROUGHNESS_FILE: &str = "roughness.json";

/// The file's format.
const FORMAT: u32 = 1;

/// Passes simulated per wheel and rail class.
pub const PASSES: usize = 24;

/// The factor on the largest of [`PASSES`] passes (docs/detection.md, "Rough wheels").
pub const SAFETY: f64 = 1.15;

/// The rail's class: smooth, or a roughness class of its own.
pub type RailClass = Option<RoughnessClass>;

/// One wheel class on one rail class.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RoughnessRow {
    /// The wheels' class (`None`: round wheels).
    pub wheel: Option<RoughnessClass>,
    /// The rail's class (`None`: a smooth rail).
    pub rail: RailClass,
    /// Passes simulated.
    pub passes: usize,
    /// The bound's part near a wheel: a fraction of the averaged flat-free force.
    pub near_wheel_fraction: f64,
    /// The bound's floor (kN).
    pub floor_kn: f64,
    /// The class's upper high-frequency level, noise-free (kN).
    pub hf_kn: f64,
}

/// A bank's roughness table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RoughnessTable {
    /// File format.
    pub format: u32,
    /// The bank it belongs to.
    pub bank_id: String,
    /// The rows computed, by rail class then wheel class (round first).
    pub rows: Vec<RoughnessRow>,
}

impl RoughnessTable {
    /// The rows of one rail class, round wheels first, smoothest class first.
    pub fn on_rail(&self, rail: RailClass) -> Vec<&RoughnessRow> {
        self.rows.iter().filter(|r| r.rail == rail).collect()
    }
}

/// The wheel classes of a table, round wheels first.
fn wheel_classes() -> Vec<Option<RoughnessClass>> {
    std::iter::once(None)
        .chain(RoughnessClass::WHEELS.into_iter().map(Some))
        .collect()
}

/// Per axis: the window as recorded, and through the average `B₅` (kN).
fn windows(resp: &Response, axes: &[(usize, &SensorAxis)]) -> Vec<(Vec<f64>, Vec<f64>)> {
    axes.iter()
        .map(|&(i, a)| {
            let raw = window_kn(resp, i, a);
            let averaged = centred_average(&raw, &BINOMIAL5);
            (raw, averaged)
        })
        .collect()
}

/// Bank axis `a`'s window of a run's pad force at the calibration's sensor `i` (kN).
pub(crate) fn window_kn(resp: &Response, i: usize, a: &SensorAxis) -> Vec<f64> {
    resp.window(i, a.first_sample, a.samples)
        .iter()
        .map(|v| v / 1e3)
        .collect()
}

/// The robust scale (1.4826 × median absolute value) of `x`, 0 when empty.
pub fn robust_scale(mut x: Vec<f64>) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    for v in &mut x {
        *v = v.abs();
    }
    let mid = x.len() / 2;
    x.select_nth_unstable_by(mid, f64::total_cmp);
    1.4826 * x[mid]
}

/// The loaded samples of an averaged flat-free window: `|ḡ| ≥ max(¼ peak, 2 kN)`.
pub fn loaded(flat_free_kn: &[f64]) -> impl Fn(f64) -> bool {
    let peak = flat_free_kn.iter().fold(0.0f64, |m, g| m.max(g.abs()));
    let floor = (0.25 * peak).max(2.0);
    move |g: f64| g.abs() >= floor
}

/// The high-frequency level of a record on one window: the robust scale of `x − B₅x` over
/// the loaded samples of the window's flat-free prediction `flat_free`.
pub fn hf_level(window: &[f64], flat_free: &[f64]) -> f64 {
    let avg = centred_average(window, &BINOMIAL5);
    let is_loaded = loaded(flat_free);
    robust_scale(
        flat_free
            .iter()
            .enumerate()
            .filter(|(_, &g)| is_loaded(g))
            .map(|(k, _)| window[k] - avg[k])
            .collect(),
    )
}

/// The largest high-frequency value of a record on one window over the samples where a
/// wheel is near the sensor (flat-free force over ½ kN): `max |x − B₅x|` (kN).
pub fn hf_peak(window: &[f64], flat_free: &[f64]) -> f64 {
    let avg = centred_average(window, &BINOMIAL5);
    flat_free
        .iter()
        .enumerate()
        .filter(|(_, g)| g.abs() > 0.5)
        .map(|(k, _)| (window[k] - avg[k]).abs())
        .fold(0.0f64, f64::max)
}

/// One row: `PASSES` passes of `wheel` on `rail`.
fn row(
    sim: &Simulator,
    cal: &CheckedCalibration,
    axes: &[(usize, &SensorAxis)],
    smooth: &[(Vec<f64>, Vec<f64>)],
    (wheel, rail): (Option<RoughnessClass>, RailClass),
) -> Result<RoughnessRow, BankError> {
    let radius = cal.vehicle.wheel_radius_m;
    let class_code = |c: Option<RoughnessClass>| {
        c.map_or(0, |c| {
            RoughnessClass::ALL
                .iter()
                .position(|&x| x == c)
                .unwrap_or(0)
                + 1
        })
    };
    let per_pass: Vec<[f64; 3]> = (0..PASSES)
        .into_par_iter()
        .map(|p| -> Result<[f64; 3], BankError> {
            let seed = 0x0A0B_0000u64
                + 1000 * class_code(wheel) as u64
                + 100_000 * class_code(rail) as u64
                + p as u64;
            let wheels = match wheel {
                Some(c) => [WheelPosition::Leading, WheelPosition::Trailing]
                    .iter()
                    .enumerate()
                    .map(|(i, &w)| {
                        Ok(WheelSurface {
                            wheel: w,
                            trace: wheel_roughness(c, radius, seed * 2 + i as u64)
                                .map_err(crate::model::SimError::from)?,
                            touch_x_m: 0.37 * p as f64 + 1.1 * i as f64,
                        })
                    })
                    .collect::<Result<Vec<_>, crate::model::SimError>>()?,
                None => Vec::new(),
            };
            let rail = match rail {
                Some(c) => Some(RailSurface {
                    start_x_m: 0.0,
                    trace: rail_roughness(c, cal.rail_length_m(), seed * 2 + 7)
                        .map_err(crate::model::SimError::from)?,
                }),
                None => None,
            };
            let surfaces = Surfaces { wheels, rail };
            let no_filter = ContactFilter {
                patch: false,
                rolling_circle: false,
            };
            let resp = sim
                .clone()
                .with_surfaces(&surfaces, no_filter)?
                .run(None, Record::default())?;
            let rough = windows(&resp, axes);
            let mut hf = Vec::new();
            // The floor, then each loaded sample's departure and force.
            let (mut floor, mut excess) = (0.0f64, Vec::new());
            for ((raw, avg), (_, g)) in rough.iter().zip(smooth) {
                hf.push(hf_level(raw, g));
                for (&y, &gk) in avg.iter().zip(g) {
                    let d = (y - gk).abs();
                    if gk.abs() < 2.0 {
                        floor = floor.max(d);
                    } else {
                        excess.push((d, gk.abs()));
                    }
                }
            }
            let near = excess
                .iter()
                .map(|&(d, g)| ((d - floor) / g).max(0.0))
                .fold(0.0f64, f64::max);
            hf.sort_by(f64::total_cmp);
            Ok([floor, near, hf[hf.len() / 2]])
        })
        .collect::<Result<_, _>>()?;
    let max = |j: usize| {
        if wheel.is_none() && rail.is_none() {
            0.0
        } else {
            SAFETY * per_pass.iter().map(|r| r[j]).fold(0.0f64, f64::max)
        }
    };
    Ok(RoughnessRow {
        wheel,
        rail,
        passes: PASSES,
        near_wheel_fraction: max(1),
        floor_kn: max(0),
        hf_kn: max(2),
    })
}

/// The rows of every wheel class on `rail` for the bank of calibration `cal` and axes `axes`.
pub(crate) fn compute_rows(
    cal: &CheckedCalibration,
    axes: &[SensorAxis],
    rail: RailClass,
) -> Result<Vec<RoughnessRow>, BankError> {
    let sim = Simulator::new(cal)?;
    let on_cal: Vec<(usize, &SensorAxis)> = axes
        .iter()
        .filter_map(|a| cal.sensor_index(&a.name).map(|i| (i, a)))
        .collect();
    let smooth = windows(&sim.run(None, Record::default())?, &on_cal);
    wheel_classes()
        .into_iter()
        .map(|w| row(&sim, cal, &on_cal, &smooth, (w, rail)))
        .collect()
}

/// Where a bank keeps its table.
pub(crate) fn path(bank: &Bank) -> PathBuf {
    bank.dir().join(ROUGHNESS_FILE)
}

/// The file's text: the table's JSON, then `# crc32 XXXXXXXX` of the bytes before it.
pub(crate) fn encode(table: &RoughnessTable) -> String {
    let mut text = serde_json::to_string_pretty(table).expect("the table serialises");
    text.push('\n');
    let crc = crc32fast::hash(text.as_bytes());
    text.push_str(&format!("# crc32 {crc:08x}\n"));
    text
}

/// Checks a stored table's text against the bank it must belong to; the reason when it does
/// not.
// Err(String): the message of the caller's `BankError::Corrupt` (the file).
pub(crate) fn decode(text: &str, bank_id: &str) -> Result<RoughnessTable, String> {
    let body_end = text
        .trim_end_matches('\n')
        .rfind('\n')
        .map(|i| i + 1)
        .ok_or("no checksum line")?;
    let (body, last) = text.split_at(body_end);
    let stated = last
        .trim()
        .strip_prefix("# crc32 ")
        .and_then(|h| u32::from_str_radix(h, 16).ok())
        .ok_or("no checksum line")?;
    if crc32fast::hash(body.as_bytes()) != stated {
        return Err("CRC-32 mismatch".into());
    }
    let t: RoughnessTable =
        serde_json::from_str(body).map_err(|e| format!("not a roughness table: {e}"))?;
    if t.format != FORMAT {
        return Err(format!(
            "format {} (this wheelflat writes {FORMAT})",
            t.format
        ));
    }
    if t.bank_id != bank_id {
        return Err(format!("bank {} (this bank is {bank_id})", t.bank_id));
    }
    for r in &t.rows {
        let values = [r.near_wheel_fraction, r.floor_kn, r.hf_kn];
        if values.iter().any(|v| !(v.is_finite() && *v >= 0.0)) || r.passes == 0 {
            return Err("a value that is negative or not finite".into());
        }
    }
    Ok(t)
}

/// The stored table when it passes its checks and holds the rail class `rail`; else the
/// missing rows computed with the bank's calibration (a few seconds) and the table stored
/// again. A version directory that cannot be written only costs that time again.
pub fn load_or_compute(bank: &Bank, rail: RailClass) -> Result<RoughnessTable, BankError> {
    load_or_build(bank, rail, super::cache::Store::BestEffort).map(|(t, _)| t)
}

/// [`load_or_compute`] with the store's failure handled as `store` says; also whether the
/// rail's rows were simulated.
pub(crate) fn load_or_build(
    bank: &Bank,
    rail: RailClass,
    store: super::cache::Store,
) -> Result<(RoughnessTable, bool), BankError> {
    let meta = bank.metadata();
    let p = path(bank);
    let mut table = std::fs::read_to_string(&p)
        .ok()
        .and_then(|t| decode(&t, &meta.bank_id).ok())
        .unwrap_or(RoughnessTable {
            format: FORMAT,
            bank_id: meta.bank_id.clone(),
            rows: Vec::new(),
        });
    let complete = table.on_rail(rail).len() == wheel_classes().len();
    if !complete {
        let cal =
            meta.calibration
                .clone()
                .check()
                .map_err(|source| BankError::DerivedCalibration {
                    context: "the bank's calibration, for its roughness table".into(),
                    source,
                })?;
        table.rows.retain(|r| r.rail != rail);
        table.rows.extend(compute_rows(&cal, &meta.sensors, rail)?);
        store.write(&p, encode(&table).as_bytes())?;
    }
    Ok((table, !complete))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_robust_scale_of_a_normal_sample_is_its_standard_deviation() {
        // 1.4826 × median |x| of N(0, σ²) is σ; 20,001 draws: within 2 %.
        let mut s = 3u64;
        let x: Vec<f64> = (0..20_001)
            .map(|_| 2.0 * crate::model::random::gaussian(&mut s))
            .collect();
        assert!((robust_scale(x) - 2.0).abs() < 0.04);
        assert_eq!(robust_scale(Vec::new()).to_bits(), 0.0f64.to_bits());
    }

    #[test]
    fn a_foreign_or_damaged_table_is_refused() {
        let t = RoughnessTable {
            format: FORMAT,
            bank_id: "abc".into(),
            rows: vec![RoughnessRow {
                wheel: Some(RoughnessClass::CastIron),
                rail: None,
                passes: 24,
                near_wheel_fraction: 0.1,
                floor_kn: 0.5,
                hf_kn: 0.8,
            }],
        };
        let text = encode(&t);
        assert_eq!(decode(&text, "abc").unwrap(), t);
        assert!(decode(&text, "abd").is_err(), "another bank");
        // A changed digit is caught by the checksum, not only a malformed file.
        assert!(
            decode(&text.replace("0.5", "0.6"), "abc").is_err(),
            "a digit"
        );
        assert!(decode(&text[..text.len() - 3], "abc").is_err(), "cut");
        let mut negative = t.clone();
        negative.rows[0].floor_kn = -0.5;
        assert!(
            decode(&encode(&negative), "abc").is_err(),
            "a negative bound"
        );
    }
}
