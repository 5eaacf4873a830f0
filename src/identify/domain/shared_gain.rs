//! What a pass shares, solved per candidate (docs/model.md §8, "Shared gains").
//!
//! The table's relative sources (train system, finite element model, mesh, track calibration,
//! sensor accuracy, additional) are one value a pass shares at each sensor — one vehicle over
//! one sensor on one stretch of track — not a value drawn anew at every comparison point. So
//! for each instance `k` the measurement at point `i` of sensor `s` is
//!
//! ```text
//! y_i = G_s · (g_ki + δ_ki) + e_i,   G_s ∈ [G_lo, G_hi],  |δ_ki| ≤ D_ki,  |e_i| ≤ E_i
//! ```
//!
//! with `G_s` the sensor's gain (the table's relative sources at their hard bounds, as Eq. 1
//! composes them: `(1 − ε_model)(1 + ε_meas)`), `δ` what is truly per point on the model's side
//! (the model-form residual a physics-varied vehicle, contact and track leave after the gain,
//! the bank mesh's landing allowance, the bank's resolution) and `e` what is per point on the
//! measurement's side (noise, resolution, the tread's and rail's roughness bound). Every bound
//! is hard, so no Šídák count applies: the instance survives when some gain inside its bounds
//! explains every point of every sensor at once. Each point restricts `G_s` to an interval;
//! the instance survives when, for every sensor, the intersection is not empty — O(points) per
//! instance.

use crate::identify::domain::falsify::Resolution;
use crate::identify::domain::table_bounds::TableBounds;

/// The bounds of a sensor's shared gain `G_s`, from the table's relative sources.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct GainBounds {
    /// The smallest gain (measured over predicted).
    pub(crate) lo: f64,
    /// The largest.
    pub(crate) hi: f64,
}

impl GainBounds {
    /// The gains the table's relative sources allow (measured over predicted; the bounds
    /// detection tests a good wheel with, [`TableBounds::gain`]).
    pub(crate) fn of(table: &TableBounds) -> GainBounds {
        GainBounds {
            lo: table.gain[0],
            hi: table.gain[1],
        }
    }
}

/// The per-point model-form residual a pass leaves after its shared gain (kN):
/// `relative·|g| + departure·|g − g_ff| + absolute`, `g_ff` the flat-free prediction there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ModelForm {
    /// A fraction of the prediction.
    pub(crate) relative: f64,
    /// A fraction of the prediction's departure from the good wheel.
    pub(crate) departure: f64,
    /// kN.
    pub(crate) absolute_kn: f64,
}

impl ModelForm {
    /// The residual's bound at a prediction `g` whose flat-free prediction is `flat_free` (kN).
    #[inline]
    pub(crate) fn at(&self, g: f64, flat_free: f64) -> f64 {
        self.relative * g.abs() + self.departure * (g - flat_free).abs() + self.absolute_kn
    }

    /// The settings' `[fraction of |g|, fraction of |g − g_ff|, kN]`.
    pub(crate) fn of(v: [f64; 3]) -> ModelForm {
        ModelForm {
            relative: v[0],
            departure: v[1],
            absolute_kn: v[2],
        }
    }
}

/// One point of the shared test: a sensor's sample (or a window's extreme) with the
/// measurement, the per-point measurement bound and every instance's prediction there.
#[derive(Debug, Clone, Copy)]
pub(crate) struct SharedPoint<'a> {
    /// Index of the sensor (series) the point belongs to.
    pub(crate) sensor: usize,
    /// Every instance's prediction (kN).
    pub(crate) predictions: &'a [f32],
    /// The measured value (kN).
    pub(crate) measured_kn: f64,
    /// The flat-free prediction there (kN).
    pub(crate) flat_free_kn: f64,
    /// `E_i`: the measurement's hard bound at the point (noise, resolution, roughness; kN).
    pub(crate) bound_kn: f64,
    /// Every instance's discretisation allowance there (share × step, kN; `None`: none).
    pub(crate) allowance: Option<(&'a [f32], &'a [f32])>,
}

impl SharedPoint<'_> {
    /// `D_ki` without the bank's resolution: model form and discretisation allowance (kN).
    #[inline]
    fn model_side(&self, k: usize, form: ModelForm) -> f64 {
        let g = self.predictions[k] as f64;
        form.at(g, self.flat_free_kn)
            + self
                .allowance
                .map_or(0.0, |(shares, steps)| (shares[k] * steps[k]) as f64)
    }
}

/// A closed interval of gains, possibly empty (`lo > hi`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Interval {
    /// Lower end.
    pub(crate) lo: f64,
    /// Upper end.
    pub(crate) hi: f64,
}

impl Interval {
    /// Whether the interval holds no gain.
    pub(crate) fn is_empty(&self) -> bool {
        self.lo > self.hi
    }

    /// Intersects the interval with the gains `G > 0` for which `G·[g − d, g + d]` meets
    /// `[y − e, y + e]`: `G·(g − d) ≤ y + e` and `G·(g + d) ≥ y − e`.
    #[inline]
    pub(crate) fn restrict(&mut self, g: f64, d: f64, y: f64, e: f64) {
        let (a, b) = (g - d, y + e);
        // G·a ≤ b
        if a > 0.0 {
            self.hi = self.hi.min(b / a);
        } else if a < 0.0 {
            self.lo = self.lo.max(b / a);
        } else if b < 0.0 {
            self.hi = f64::NEG_INFINITY;
        }
        let (a, b) = (g + d, y - e);
        // G·a ≥ b
        if a > 0.0 {
            self.lo = self.lo.max(b / a);
        } else if a < 0.0 {
            self.hi = self.hi.min(b / a);
        } else if b > 0.0 {
            self.hi = f64::NEG_INFINITY;
        }
    }
}

/// Every sensor's gains that explain instance `k` at `points`, with `extra(k, i)` added to the
/// model side's bound at point `i` (the bank's resolution). `sensors` is the number of sensors.
pub(crate) fn gains_of(
    points: &[SharedPoint],
    k: usize,
    gain: GainBounds,
    form: ModelForm,
    sensors: usize,
    extra: impl Fn(usize, usize) -> f64,
) -> Vec<Interval> {
    let mut out = vec![
        Interval {
            lo: gain.lo,
            hi: gain.hi,
        };
        sensors
    ];
    for (i, p) in points.iter().enumerate() {
        let d = p.model_side(k, form) + extra(k, i);
        out[p.sensor].restrict(p.predictions[k] as f64, d, p.measured_kn, p.bound_kn);
    }
    out
}

/// The instances of `alive` that some shared gain per sensor explains at every point.
/// `spread(k, i)` is the bank's resolution at instance `k` and point `i` (κ × the neighbour
/// spread; kN), only asked for where the instance fails without it.
pub(crate) fn keep(
    points: &[SharedPoint],
    alive: &[u32],
    gain: GainBounds,
    form: ModelForm,
    spread: impl Fn(usize, usize) -> f64 + Sync,
) -> Vec<u32> {
    use rayon::prelude::*;
    let sensors = points.iter().map(|p| p.sensor + 1).max().unwrap_or(0);
    alive
        .par_iter()
        .copied()
        .filter(|&k| {
            let k = k as usize;
            let explained = |extra: &dyn Fn(usize, usize) -> f64| {
                gains_of(points, k, gain, form, sensors, extra)
                    .iter()
                    .all(|g| !g.is_empty())
            };
            explained(&|_, _| 0.0) || explained(&spread)
        })
        .collect()
}

/// [`keep`] with the gain bounds of `bounds`, the settings' model form `form` and the bank's
/// resolution `res` (κ × the instance's neighbour spread at the point; none without it): the
/// stage as identification, refinement and audit judge with it.
pub(crate) fn keep_resolved(
    points: &[SharedPoint],
    alive: &[u32],
    bounds: &TableBounds,
    form: [f64; 3],
    res: Option<Resolution>,
) -> Vec<u32> {
    keep(
        points,
        alive,
        GainBounds::of(bounds),
        ModelForm::of(form),
        |k, i| res.map_or(0.0, |r| r.kappa * r.cells.spread(points[i].predictions, k)),
    )
}

/// `E_i` at a point whose flat-free prediction is `flat_free_kn`: the table's absolute
/// sources and the bounded ones (a rough tread's or rail's) at their bounds (kN).
pub(crate) fn measurement_bound_kn(bounds: &TableBounds, flat_free_kn: f64) -> f64 {
    bounds.absolute_kn + bounds.bound_kn + bounds.good_wheel_fraction * flat_free_kn.abs()
}

#[cfg(test)]
mod tests {
    use super::*;

    const NONE: ModelForm = ModelForm {
        relative: 0.0,
        departure: 0.0,
        absolute_kn: 0.0,
    };

    #[test]
    fn gain_bounds_are_the_tables_and_the_model_form_adds_its_three_parts() {
        let table = TableBounds::of(&crate::model::calibration::IdentificationParams::default());
        let g = GainBounds::of(&table);
        // S = model − measurement from −39 % to +26 %: y/g from 1/1.26 to 1/0.61.
        assert!((g.lo - 1.0 / 1.26).abs() < 1e-9, "{g:?}");
        assert!((g.hi - 1.0 / 0.61).abs() < 1e-9, "{g:?}");
        let f = ModelForm::of([0.02, 0.1, 2.0]);
        assert!((f.at(50.0, 40.0) - (1.0 + 1.0 + 2.0)).abs() < 1e-12);
    }

    #[test]
    fn an_interval_is_restricted_to_the_gains_that_meet_the_band() {
        let mut i = Interval { lo: 0.5, hi: 2.0 };
        // y = 10 ± 1, g = 10 exactly: G in [0.9, 1.1].
        i.restrict(10.0, 0.0, 10.0, 1.0);
        assert!((i.lo - 0.9).abs() < 1e-12 && (i.hi - 1.1).abs() < 1e-12);
        // A prediction of 0 ± 0 with a measurement of 5 ± 1: no gain meets it.
        let mut j = Interval { lo: 0.5, hi: 2.0 };
        j.restrict(0.0, 0.0, 5.0, 1.0);
        assert!(j.is_empty());
        // A prediction of 0 ± 0 with a measurement of 0.5 ± 1: every gain does.
        let mut k = Interval { lo: 0.5, hi: 2.0 };
        k.restrict(0.0, 0.0, 0.5, 1.0);
        assert_eq!(k, Interval { lo: 0.5, hi: 2.0 });
        // A negative prediction band [−3, −1] against y = −4 ± 0: G in [4/3, 4].
        let mut n = Interval { lo: 0.1, hi: 10.0 };
        n.restrict(-2.0, 1.0, -4.0, 0.0);
        assert!((n.lo - 4.0 / 3.0).abs() < 1e-12 && (n.hi - 4.0).abs() < 1e-12);
    }

    #[test]
    fn one_gain_must_explain_every_point_of_a_sensor() {
        // Instance 0 is the measurement × 1.2 at both points (one gain explains it); instance
        // 1 is × 1.2 at one point and × 0.8 at the other (each alone inside ±25 %, together
        // no single gain): the per-point test keeps both, the shared test only the first.
        let a = [12.0f32, 12.0];
        let b = [60.0f32, 40.0];
        let pts = [
            SharedPoint {
                sensor: 0,
                predictions: &a,
                measured_kn: 10.0,
                flat_free_kn: 10.0,
                bound_kn: 0.1,
                allowance: None,
            },
            SharedPoint {
                sensor: 0,
                predictions: &b,
                measured_kn: 50.0,
                flat_free_kn: 50.0,
                bound_kn: 0.1,
                allowance: None,
            },
        ];
        let gain = GainBounds { lo: 0.75, hi: 1.25 };
        assert_eq!(keep(&pts, &[0, 1], gain, NONE, |_, _| 0.0), vec![0]);
        // On two sensors each point has a gain of its own: both kept.
        let apart = [
            pts[0],
            SharedPoint {
                sensor: 1,
                ..pts[1]
            },
        ];
        assert_eq!(keep(&apart, &[0, 1], gain, NONE, |_, _| 0.0), vec![0, 1]);
        // A model-form residual of 25 % of the departure does not help a point without one;
        // 25 % of the prediction does.
        let dep = ModelForm {
            departure: 0.25,
            ..NONE
        };
        assert_eq!(keep(&pts, &[0, 1], gain, dep, |_, _| 0.0), vec![0]);
        let rel = ModelForm {
            relative: 0.25,
            ..NONE
        };
        assert_eq!(keep(&pts, &[0, 1], gain, rel, |_, _| 0.0), vec![0, 1]);
        // The resolution is asked for where the instance fails without it, and widens it.
        assert_eq!(
            keep(&pts, &[0, 1], gain, NONE, |k, _| if k == 1 {
                10.0
            } else {
                0.0
            }),
            vec![0, 1]
        );
    }

    #[test]
    fn the_allowance_widens_each_instance_by_its_own_share_of_its_step() {
        let g = [13.0f32, 13.0];
        let shares = [0.5f32, 0.0];
        let steps = [4.0f32, 4.0];
        // y = 10 ± 0, gains 0.9–1.1: 13 needs 13·0.9 = 11.7 ≥ 10 − … — no gain without an
        // allowance; 13 − 2 = 11 reaches 10 at G = 0.909.
        let p = SharedPoint {
            sensor: 0,
            predictions: &g,
            measured_kn: 10.0,
            flat_free_kn: 10.0,
            bound_kn: 0.0,
            allowance: Some((&shares, &steps)),
        };
        let gain = GainBounds { lo: 0.9, hi: 1.1 };
        assert_eq!(keep(&[p], &[0, 1], gain, NONE, |_, _| 0.0), vec![0]);
    }
}
