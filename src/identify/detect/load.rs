//! The wheel load a pass carries, read from its record (docs/identification.md
//! "Load").
//!
//! Away from a flat's strikes a pad's force is the wheel loads spread over the pads: the bank's
//! flat-free prediction scaled by the load (the track is linear; measured in
//! docs/bank.md "Load"). The detection step already fits each sensor's level `a_s` (least
//! squares over the loaded samples, [`crate::identify::detect::test_sensor`]); their mean over the
//! sensors used, times the bank's static wheel load, is the record's load — as the *model*
//! would have to carry it to give this level. The uncertainty table says how far a level may
//! be from the model's at the true load: per sensor `(1 − E_model)·(1 + γ)` (the paper's Eq. 1,
//! every relative source one draw a sensor), whose mean (1.065 for the default table: the
//! model under-predicts by 6.5 % on average) the estimate is divided by, and whose spread,
//! averaged over the sensors used, gives the interval. With the default table one sensor's
//! level alone is ±15 % (95 %), two sensors' ±11 %, five sensors' ±7 %: the record cannot tell
//! the load better than the model's level is known, and the interval says so.

use crate::identify::detect::{loaded_level, Detection};
use crate::identify::domain::load_shapes::LoadShapes;
use crate::identify::domain::uncertainty::draw_sources;
use crate::identify::input::measurement::MeasuredSeries;
use crate::model::calibration::{
    IdentificationParams, UncertaintyGroup, UncertaintyKind, VehicleParams,
};
use serde::{Deserialize, Serialize};

/// The central probability of [`LoadEstimate::interval_kn`].
pub(crate) const LOAD_INTERVAL_PROBABILITY: f64 = 0.95;
/// Monte Carlo draws of the level factor (seeded: the same interval every time).
const DRAWS: usize = 20_000;

/// The wheel load read from a pass.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LoadEstimate {
    /// The static wheel load the record shows (kN).
    pub wheel_load_kn: f64,
    /// Where the true load lies with probability [`LOAD_INTERVAL_PROBABILITY`], given the
    /// table's level errors (kN).
    pub interval_kn: [f64; 2],
    /// The car-body mass (kg) the vehicle's other masses give this load with (the quarter car
    /// of docs/model.md §3).
    pub car_body_mass_kg: f64,
    /// The static wheel load of the bank compared with (kN).
    pub bank_wheel_load_kn: f64,
    /// The sensors' mean fitted level over the bank's flat-free prediction.
    pub mean_level: f64,
    /// Sensors it was read from.
    pub sensors: usize,
    /// On a family over loads, the loads of the two members the record was read between
    /// with their own shapes ([`crate::identify::domain::load_shapes`]; kN); `None`: read on one bank.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub between_members_kn: Option<[f64; 2]>,
}

impl LoadEstimate {
    /// The estimate over the bank's load, as a fraction (−0.27: 27 % lighter).
    pub fn off_bank(&self) -> f64 {
        self.wheel_load_kn / self.bank_wheel_load_kn - 1.0
    }

    /// How the record was put on the bank's load, in words.
    pub fn adjustment_words(&self) -> String {
        if self.between_members_kn.is_some() {
            let r = self.bank_wheel_load_kn / self.wheel_load_kn;
            return match r < 1.0 {
                true => format!("the record scaled by {r:.3} and its static part put on the bank's load with the members' shapes"),
                false => "the record's static part put on the bank's load with the members' shapes (impacts as recorded)".into(),
            };
        }
        match Adjustment::of(self) {
            Adjustment::Scale(r) => format!("the record scaled by {r:.3} to the bank's load"),
            Adjustment::AddStatic(e) if e.abs() < 5e-4 => "the record at the bank's load".into(),
            Adjustment::AddStatic(_) => {
                "the record's static part put on the bank's load (impacts as recorded)".into()
            }
        }
    }

    /// One line for the text verdict.
    pub fn words(&self) -> String {
        let shapes = match self.between_members_kn {
            Some([a, b]) => format!("; read with the members' shapes between {a:.1} and {b:.1} kN"),
            None => String::new(),
        };
        format!(
            "load: {:.1} kN a wheel ({:.1}–{:.1} kN, {:.0} %; car body ≈ {:.0} kg{shapes}), the bank's {:.1} kN ({:+.0} %)",
            self.wheel_load_kn,
            self.interval_kn[0],
            self.interval_kn[1],
            LOAD_INTERVAL_PROBABILITY * 100.0,
            self.car_body_mass_kg,
            self.bank_wheel_load_kn,
            self.off_bank() * 100.0
        )
    }
}

/// The table's level factor `(1 − E_model)·(1 + γ)`: its mean, and the central
/// [`LOAD_INTERVAL_PROBABILITY`] interval of its mean over `sensors` independent sensors.
pub(crate) fn level_factor(id: &IdentificationParams, sensors: usize) -> (f64, [f64; 2]) {
    let n = sensors.max(1);
    let mut state = 0x10AD_u64;
    let mut draws: Vec<f64> = (0..DRAWS)
        .map(|_| {
            (0..n)
                .map(|_| {
                    let e = draw_sources(
                        id,
                        UncertaintyGroup::Model,
                        UncertaintyKind::Relative,
                        false,
                        &mut state,
                    );
                    let g = draw_sources(
                        id,
                        UncertaintyGroup::Measurement,
                        UncertaintyKind::Relative,
                        false,
                        &mut state,
                    );
                    (1.0 - e) * (1.0 + g)
                })
                .sum::<f64>()
                / n as f64
        })
        .collect();
    let mean = mean_level_factor(id);
    draws.sort_by(f64::total_cmp);
    let tail = (1.0 - LOAD_INTERVAL_PROBABILITY) / 2.0;
    let at = |p: f64| draws[((DRAWS - 1) as f64 * p).round() as usize];
    (mean, [at(tail), at(1.0 - tail)])
}

/// The mean of the table's level factor `(1 − E_model)·(1 + γ)`, exactly: the sources are
/// independent and uniform, so it is `(1 − ΣE_mid)(1 + Σγ_mid)` (scripts/reference computes
/// the same). What a sensor's level over the model is on average at the true load.
pub(crate) fn mean_level_factor(id: &IdentificationParams) -> f64 {
    let mid = |group: UncertaintyGroup| -> f64 {
        id.uncertainty
            .iter()
            .filter(|u| u.group == group && u.kind == UncertaintyKind::Relative)
            .map(|u| 0.5 * (u.min + u.max))
            .sum()
    };
    (1.0 - mid(UncertaintyGroup::Model)) * (1.0 + mid(UncertaintyGroup::Measurement))
}

/// The load of a pass from its detection step on a bank whose static wheel load is
/// `bank_wheel_load_kn` (`vehicle`: the bank's, for the car-body mass), with the table's
/// [`level_factor`] for the sensors used; `None` when no sensor had loaded samples to fit.
pub(crate) fn estimate(
    detection: &Detection,
    bank_wheel_load_kn: f64,
    vehicle: &VehicleParams,
    (mean, spread): (f64, [f64; 2]),
) -> Option<LoadEstimate> {
    let levels: Vec<f64> = detection
        .sensors
        .iter()
        .filter(|s| s.loaded_samples > 0 && s.fitted_gain.is_finite() && s.fitted_gain > 0.0)
        .map(|s| s.fitted_gain)
        .collect();
    if levels.is_empty() {
        return None;
    }
    let mean_level = levels.iter().sum::<f64>() / levels.len() as f64;
    let shown_kn = mean_level * bank_wheel_load_kn;
    let wheel_load_kn = shown_kn / mean;
    Some(LoadEstimate {
        wheel_load_kn,
        interval_kn: [shown_kn / spread[1], shown_kn / spread[0]],
        car_body_mass_kg: car_body_mass_kg(vehicle, wheel_load_kn),
        bank_wheel_load_kn,
        mean_level,
        sensors: levels.len(),
        between_members_kn: None,
    })
}

/// The car-body mass (kg) that gives the static wheel load `wheel_load_kn` with `vehicle`'s
/// other masses (the quarter car of docs/model.md §3; [`VehicleParams::static_wheel_load_n`]
/// inverted).
fn car_body_mass_kg(vehicle: &VehicleParams, wheel_load_kn: f64) -> f64 {
    2.0 * (wheel_load_kn * 1e3 / vehicle.gravity_m_per_s2 - vehicle.wheel_mass_kg)
        - vehicle.bogie_mass_kg
}

/// The load `L` at which the record's mean level over the members' prediction at `L` is the
/// table's mean level factor `mean` — the linear read's own condition, with the prediction at
/// the load itself instead of the bank's scaled ([`crate::identify::domain::load_shapes`]); bracketed from the
/// linear read `start_kn` outwards in 2 % steps, then bisected to 0.01 %. `None` when no
/// sensor has loaded samples or no root lies within a factor of two of `start_kn`.
fn read_with_shapes(
    shapes: &LoadShapes,
    axes: &[usize],
    series: &[&[f64]],
    mean: f64,
    start_kn: f64,
) -> Option<f64> {
    let excess = |l: f64| -> Option<f64> {
        let levels: Vec<f64> = axes
            .iter()
            .zip(series)
            .filter_map(|(&a, y)| loaded_level(y, &shapes.at(a, l)).0)
            .filter(|a| *a > 0.0)
            .collect();
        (!levels.is_empty()).then(|| levels.iter().sum::<f64>() / levels.len() as f64 - mean)
    };
    let f0 = excess(start_kn)?;
    if f0 == 0.0 {
        return Some(start_kn);
    }
    // The level falls as the load rises: a positive excess means a heavier load.
    let dir = if f0 > 0.0 { 1.02 } else { 1.0 / 1.02 };
    let (mut a, mut fa) = (start_kn, f0);
    let mut b = start_kn;
    loop {
        b *= dir;
        if !(0.5 * start_kn..=2.0 * start_kn).contains(&b) {
            return None;
        }
        let fb = excess(b)?;
        if fb == 0.0 {
            return Some(b);
        }
        if fb.signum() != fa.signum() {
            break;
        }
        (a, fa) = (b, fb);
    }
    for _ in 0..40 {
        let m = 0.5 * (a + b);
        let fm = excess(m)?;
        if fm.signum() == fa.signum() {
            (a, fa) = (m, fm);
        } else {
            b = m;
        }
        if (b - a).abs() < 1e-4 * m {
            break;
        }
    }
    Some(0.5 * (a + b))
}

impl crate::identify::identifier::Identifier {
    /// The load a pass shows on this bank, before any sizing: the detection step over the
    /// sensors `sensors` (all the file's when `None`), milliseconds. This is what picks a
    /// member of a family over loads ([`crate::identify::detect::family::Members::member_for_pass`]).
    pub fn estimate_load(
        &self,
        m: &crate::identify::input::measurement::Measurement,
        sensors: Option<&[String]>,
    ) -> Result<Option<LoadEstimate>, crate::identify::error::IdentifyError> {
        let prepared = self.prepare(m, sensors)?;
        let axes: Vec<usize> = prepared.used.iter().map(|&(_, bi)| bi).collect();
        // The gains alone decide the load: the roughness bound does not change them.
        let d = self.detect(
            &axes,
            &prepared.series,
            self.bounds,
            crate::identify::input::compare::Comparison::Samples,
            None,
        );
        Ok(self.load_of(&axes, &prepared.series, &d))
    }

    /// Per bank axis in `axes`, per sample, how much the prediction's shape changes across the
    /// interval of the pass's load `load` ([`LoadShapes::shape_change_kn`]): what a load
    /// misread within it leaves in the record put on the member's load, which no sensor's
    /// level absorbs. `None` unless the load was read between a family's members.
    pub(in crate::identify) fn shape_change(
        &self,
        axes: &[usize],
        load: &LoadEstimate,
    ) -> Option<Vec<Vec<f64>>> {
        let shapes = self.load_shapes.as_ref()?;
        load.between_members_kn?;
        Some(
            axes.iter()
                .map(|&a| shapes.shape_change_kn(a, load.wheel_load_kn, load.interval_kn))
                .collect(),
        )
    }

    /// Puts a pass's series (on the bank axes `axes`) on the bank's load. A pass heavier than
    /// the bank is scaled down as a whole (every sample × bank load / load shown: its impacts
    /// shrink with its static load, and its noise only shrinks); a lighter one is not scaled up
    /// (that would scale its noise and impacts past what it recorded) but has the static part
    /// added: the flat-free prediction times the difference between the level the bank's load
    /// would show (the table's mean level factor) and the record's mean level. Each sensor's own
    /// level error stays as recorded. Every variant, measured: docs/decisions.md "Loads"; what
    /// is left bounds how far a member's load may be from the pass's
    /// ([`crate::bank::loads::LOAD_TOLERANCE_LIGHTER`], `…_HEAVIER`).
    pub(in crate::identify) fn at_bank_load(
        &self,
        axes: &[usize],
        series: &mut [crate::identify::input::measurement::MeasuredSeries],
        load: &LoadEstimate,
    ) {
        let meta = self.bank.metadata();
        if let (Some(shapes), Some(_)) = (&self.load_shapes, load.between_members_kn) {
            // The prediction at the pass's own load, interpolated between the members, and
            // each sensor's level over it: the static part moved from it to the bank's (a
            // heavier pass's impacts scaled down as below, its static part then the bank's).
            let r = load.bank_wheel_load_kn / load.wheel_load_kn;
            let mean = mean_level_factor(&self.settings);
            for (s, &axis) in series.iter_mut().zip(axes) {
                let at_load = shapes.at(axis, load.wheel_load_kn);
                let level = loaded_level(&s.values_kn, &at_load).0.unwrap_or(mean);
                let bank = &meta.flat_free_kn[axis];
                for ((y, &gl), &gk) in s.values_kn.iter_mut().zip(&at_load).zip(bank) {
                    let gk = f64::from(gk);
                    *y = if r < 1.0 {
                        r * *y + level * (gk - r * gl)
                    } else {
                        *y - level * (gl - gk)
                    };
                }
            }
            return;
        }
        match Adjustment::of(load) {
            Adjustment::Scale(r) => {
                for s in series.iter_mut() {
                    s.values_kn.iter_mut().for_each(|y| *y *= r);
                }
            }
            Adjustment::AddStatic(excess) => {
                for (s, &axis) in series.iter_mut().zip(axes) {
                    for (y, &g) in s.values_kn.iter_mut().zip(&meta.flat_free_kn[axis]) {
                        *y -= excess * f64::from(g);
                    }
                }
            }
        }
    }

    /// The load of a pass from its detection step on this bank ([`estimate`]); the level
    /// factor's interval is drawn once per number of sensors and kept.
    /// On a family over loads the load is then read again with the members' own shapes
    /// ([`read_with_shapes`]) from the series on the bank axes `axes`, as recorded.
    pub(in crate::identify) fn load_of(
        &self,
        axes: &[usize],
        series: &[MeasuredSeries],
        detection: &Detection,
    ) -> Option<LoadEstimate> {
        let cal = &self.bank.metadata().calibration;
        let n = detection.sensors.len();
        let factor = {
            let mut kept = self.load_levels.lock().unwrap_or_else(|e| e.into_inner());
            *kept
                .entry(n)
                .or_insert_with(|| level_factor(&self.settings, n))
        };
        let linear = estimate(
            detection,
            cal.vehicle.static_wheel_load_n() / 1e3,
            &cal.vehicle,
            factor,
        )?;
        let Some(shapes) = &self.load_shapes else {
            return Some(linear);
        };
        let ys: Vec<&[f64]> = series.iter().map(|s| s.values_kn.as_slice()).collect();
        let Some(l) = read_with_shapes(shapes, axes, &ys, factor.0, linear.wheel_load_kn) else {
            return Some(linear);
        };
        let (shown_kn, loads) = (l * factor.0, shapes.loads_kn());
        let hi = loads.partition_point(|&x| x < l).clamp(1, loads.len() - 1);
        Some(LoadEstimate {
            wheel_load_kn: l,
            interval_kn: [shown_kn / factor.1[1], shown_kn / factor.1[0]],
            car_body_mass_kg: car_body_mass_kg(&cal.vehicle, l),
            between_members_kn: Some([loads[hi - 1], loads[hi]]),
            ..linear
        })
    }
}

/// How a pass is put on its bank's load ([`crate::identify::identifier::Identifier::at_bank_load`]).
enum Adjustment {
    /// A heavier pass: every sample times this (< 1).
    Scale(f64),
    /// A lighter pass (or the bank's load): this times the flat-free prediction taken off
    /// (the record's mean level less the level at the bank's load; negative adds).
    AddStatic(f64),
}

impl Adjustment {
    fn of(load: &LoadEstimate) -> Adjustment {
        let r = load.bank_wheel_load_kn / load.wheel_load_kn;
        if r < 1.0 {
            Adjustment::Scale(r)
        } else {
            Adjustment::AddStatic(load.mean_level * (1.0 - r))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_level_factor_of_the_default_table_has_the_mean_its_sources_give() {
        // Mean of (1 − E)(1 + γ) with independent uniform sources: (1 − ΣE_mid)(1 + Σγ_mid);
        // the default table's model mid-points sum to −0.065, its gain mid-points to 0.
        let id = IdentificationParams::default();
        let (mean, one) = level_factor(&id, 1);
        assert!((mean - 1.065).abs() < 1e-12, "mean {mean}");
        let (_, two) = level_factor(&id, 2);
        // Averaging two sensors narrows the interval (by about √2).
        assert!(two[1] - two[0] < 0.8 * (one[1] - one[0]), "{one:?} {two:?}");
        assert!(one[0] < mean && mean < one[1]);
    }
}
