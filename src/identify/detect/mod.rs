//! Detection before sizing: is there a flat at all? (docs/identification.md,
//! "Detection").
//!
//! Falsification sizes a flat by ruling instances out at a few points where the measurement
//! has features. A good wheel has none where a flat would strike, so nothing rules out the
//! flats whose strikes fall between the points, and a sizing of a good wheel always reports
//! some flat. So the flat-free model is tested first, at **every** sample of every sensor
//! window, and sizing runs only when it is falsified.
//!
//! The error model is the uncertainty table's (paper Eq. 1): the relative sources are one draw
//! per sensor and pass (the synthetic passes and the independent ones draw them so), so
//! together they scale a sensor's whole series by one gain; the absolute sources (noise,
//! resolution) are per sample and bounded. Per sensor the test therefore
//!
//! 1. takes the residual `r_k = y_k − a·g_k` at every sample and its bound
//!    `b_k = T_max + allowance_kn + allowance_fraction·a·|g_k|`, with `T_max` the sum of the
//!    absolute sources' hard bounds (1.05 kN in the default table) and the allowance the
//!    flat-free model's own form error against a converged mesh (measured: ≤ 0.1 kN, docs);
//! 2. with the gain `a` fitted by least squares over the loaded samples (`g_k` at least a
//!    quarter of the window's peak and 2 kN; a flat's strike touches a few dozen of several
//!    hundred, and its residuals of both signs mostly cancel), clamped to what the table
//!    allows (`1/(1+S)` for the relative sources' sum `S` in its hard bounds);
//! 3. calls a flat **detected** when some `|r_k| > b_k`. A fitted gain outside the table is
//!    named (`gain_outside_table`): the record's level differs from the bank's.
//!
//! Two other gains were tried and lost (docs/detection.md): the median of the ratios (biased
//! by up to the noise over the peak force when the noise is at its bounds), and the gain that
//! makes the largest excess smallest (it leans into a strike by the bound's slack at the peak
//! and missed a 0.04 mm flat the others detect).
//!
//! Under the table, the bound holds with probability 1 for a good wheel (every source is a
//! bounded uniform), so a false alarm comes only from what the table lacks; the measured
//! false-alarm rate is in docs/detection.md, "Measured".
//!
//! The **detection limit** of a pass is computed from the bank: instance `i` is surely
//! detected by the sensors used when its noise-free departure from the flat-free prediction,
//! shrunk by the smallest gain the table allows, still exceeds the bound plus the largest
//! noise that could hide it, `a_min·D_i − allowance_fraction·F_i − allowance_kn − 2·T_max > 0`
//! at its largest departure `D_i` ([`crate::bank::departures`]). The limit is the smallest
//! L0 from which every 1 mm L0 bin of the population has at least 90 % of its instances
//! surely detected.

pub(crate) mod family;
pub(in crate::identify) mod flat_free;
pub(crate) mod harmonic;
pub(crate) mod load;
pub mod out_of_round;
pub mod roughness;
pub(crate) mod spike;
use super::detect::spike::SpikeTest;
pub(crate) use super::domain::table_bounds::TableBounds;
use super::input::measurement::MeasuredSeries;
use crate::bank::departures::Departures;
use serde::{Deserialize, Serialize};

/// The share of an L0 bin's instances that must be surely detected for the bin to count as
/// within the detection limit.
pub(crate) const LIMIT_SHARE: f64 = 0.9;

/// Width of the L0 bins of the detection limit (mm).
pub(crate) const LIMIT_BIN_MM: f64 = 1.0;

/// The flat-free test of one sensor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SensorTest {
    /// Sensor name.
    pub sensor: String,
    /// The gain fitted (after clamping to the table).
    pub gain: f64,
    /// The fitted gain lay outside the table's gains and was clamped: the record's level
    /// differs from the bank's more than the table allows (another load, or a sensor's
    /// calibration).
    pub gain_outside_table: bool,
    /// The gain as fitted, before clamping: the record's level over the bank's flat-free
    /// prediction at this sensor (another load moves every sensor's; [`super::detect::load`]).
    #[serde(default)]
    pub fitted_gain: f64,
    /// Loaded samples the gain was estimated from.
    pub loaded_samples: usize,
    /// The largest `|r_k| − b_k` over the window (kN): positive means the flat-free model is
    /// falsified here.
    pub excess_kn: f64,
    /// Bank time of that sample (s).
    pub at_time_s: f64,
    /// The residual `y − a·g` there (kN).
    pub residual_kn: f64,
    /// The measured departure from the good wheel, `max_k |y_k − a·g_k|` (kN): what the
    /// departure rule compares each instance's own largest departure with.
    #[serde(default)]
    pub departure_kn: f64,
    /// The bank's flat-free prediction on the series' samples (kN): what the report's
    /// detection figure draws the residual and the bound from.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub flat_free_kn: Vec<f64>,
}

/// One L0 bin of the detection limit.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LimitBin {
    /// The bin's lower L0 edge (mm).
    pub l0_mm: f64,
    /// Bank instances in the bin.
    pub instances: usize,
    /// Of those, the ones the sensors used would surely have detected.
    pub detected: usize,
}

/// The smallest flat this pass would have shown (computed from the bank).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DetectionLimit {
    /// The smallest L0 from which every bin has at least [`LIMIT_SHARE`] of its instances
    /// surely detected (mm); `None` when even the population's largest flats are not.
    pub l0_mm: Option<f64>,
    /// True when the limit is the population's smallest L0: smaller flats may be detected too,
    /// the bank cannot say.
    pub at_population_floor: bool,
    /// The share of all bank instances surely detected.
    pub share_detected: f64,
    /// Every bin, smallest L0 first.
    pub bins: Vec<LimitBin>,
    /// Per wheel, when the bank puts flats on both: that wheel's limit (its L0 from which
    /// flats are surely detected; `None`: this pass does not see that wheel's flats).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub wheels: Vec<WheelLimit>,
}

/// One wheel's detection limit.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct WheelLimit {
    /// The wheel.
    pub wheel: crate::model::WheelPosition,
    /// [`DetectionLimit::l0_mm`] over that wheel's instances.
    pub l0_mm: Option<f64>,
}

/// The result of the detection step.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Detection {
    /// Whether the flat-free model is falsified: a flat (or something else the flat-free model
    /// lacks) is in the record.
    pub flat_detected: bool,
    /// The bounds used.
    pub bounds: TableBounds,
    /// Samples tested (all sensors).
    pub samples: usize,
    /// Per sensor used.
    pub sensors: Vec<SensorTest>,
    /// The detection limit, given with every "no flat detected".
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub limit: Option<DetectionLimit>,
    /// The strike test on the record as taken, when the bank compares through an average
    /// (`B₅`, [`super::input::compare`]; [`SpikeTest`]). A flat is detected when either test falsifies
    /// the good wheel.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spike: Option<SpikeTest>,
    /// The harmonic of one wheel that explains a pass the test flagged: the pass is then "no
    /// flat detected; out of round" (`identify::out_of_round`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub out_of_round: Option<super::detect::harmonic::OutOfRoundFit>,
}

impl Detection {
    /// The sensor with the largest excess.
    pub fn worst(&self) -> Option<&SensorTest> {
        self.sensors
            .iter()
            .max_by(|a, b| a.excess_kn.total_cmp(&b.excess_kn))
    }

    /// The record's level lies outside the table's gains at some sensor.
    pub fn level_outside_table(&self) -> bool {
        self.sensors.iter().any(|s| s.gain_outside_table)
    }
}

/// The level of `y` over the prediction `g` (same samples) by least squares over the loaded
/// samples, `a = Σ y·g / Σ g²` where `|g|` is at least a quarter of its peak and 2 kN, and how
/// many samples were loaded; the level is `None` when none were (or it is not finite). What
/// detection fits each sensor's gain with, and what the load is read from.
pub(crate) fn loaded_level<G: Copy + Into<f64>>(y: &[f64], g: &[G]) -> (Option<f64>, usize) {
    let peak = g.iter().fold(0.0f64, |m, &x| m.max(x.into().abs()));
    let floor = (0.25 * peak).max(2.0);
    let (yg, gg, n) = y
        .iter()
        .zip(g)
        .map(|(&y, &g)| (y, g.into()))
        .filter(|&(_, g)| g.abs() >= floor)
        .fold((0.0, 0.0, 0), |(yg, gg, n), (y, g)| {
            (yg + y * g, gg + g * g, n + 1)
        });
    let level = (gg > 0.0 && (yg / gg).is_finite()).then(|| yg / gg);
    (level, n)
}

/// Tests one sensor's series `y` against the flat-free prediction `g` (same samples).
#[cfg(test)]
pub(crate) fn test_sensor(
    sensor: &MeasuredSeries,
    template_kn: &[f32],
    bounds: &TableBounds,
) -> SensorTest {
    test_sensor_with(sensor, template_kn, bounds, &[])
}

/// [`test_sensor`] with the bound at sample `k` raised by `extra_kn[k]` (absent: 0).
fn test_sensor_with(
    sensor: &MeasuredSeries,
    template_kn: &[f32],
    bounds: &TableBounds,
    extra_kn: &[f64],
) -> SensorTest {
    let y = &sensor.values_kn;
    let (level, loaded_samples) = loaded_level(y, template_kn);
    let fitted = level.unwrap_or(1.0);
    let gain = fitted.clamp(bounds.gain[0], bounds.gain[1]);
    let mut worst = (f64::NEG_INFINITY, 0usize, 0.0);
    let mut departure_kn = 0.0f64;
    for (k, (&y, &g)) in y.iter().zip(template_kn).enumerate() {
        let g = f64::from(g);
        let r = y - gain * g;
        departure_kn = departure_kn.max(r.abs());
        let excess = r.abs() - bounds.bound_kn(gain, g) - extra_kn.get(k).copied().unwrap_or(0.0);
        if excess > worst.0 {
            worst = (excess, k, r);
        }
    }
    SensorTest {
        sensor: sensor.sensor.clone(),
        gain,
        gain_outside_table: !(bounds.gain[0]..=bounds.gain[1]).contains(&fitted),
        fitted_gain: fitted,
        loaded_samples,
        excess_kn: worst.0,
        at_time_s: sensor.t0_s + worst.1 as f64 / sensor.sample_rate_hz,
        residual_kn: worst.2,
        departure_kn,
        flat_free_kn: template_kn.iter().map(|&g| f64::from(g)).collect(),
    }
}

/// Tests every series (with its bank axis' flat-free prediction).
pub(crate) fn detect(
    series: &[MeasuredSeries],
    templates: &[&[f32]],
    bounds: TableBounds,
) -> Detection {
    detect_with(series, templates, bounds, &[])
}

/// [`detect`] with sensor `i`'s bound at sample `k` raised by `extra_kn[i][k]` (absent: 0):
/// what the prediction at the pass's load may miss there between a family's members
/// ([`crate::identify::domain::load_shapes::LoadShapes::interpolation_error_kn`]).
pub(crate) fn detect_with(
    series: &[MeasuredSeries],
    templates: &[&[f32]],
    bounds: TableBounds,
    extra_kn: &[&[f64]],
) -> Detection {
    let sensors: Vec<SensorTest> = series
        .iter()
        .zip(templates)
        .enumerate()
        .map(|(i, (s, t))| test_sensor_with(s, t, &bounds, extra_kn.get(i).copied().unwrap_or(&[])))
        .collect();
    Detection {
        flat_detected: sensors.iter().any(|s| s.excess_kn > 0.0),
        bounds,
        samples: series.iter().map(|s| s.values_kn.len()).sum(),
        sensors,
        limit: None,
        spike: None,
        out_of_round: None,
    }
}

/// Whether instance `i` would surely be detected by the sensors `axes` (bank axis indices).
pub(crate) fn surely_detected(d: &Departures, axes: &[usize], i: usize, b: &TableBounds) -> bool {
    axes.iter().any(|&s| {
        let dep = f64::from(d.departure_kn[s][i]);
        let force = f64::from(d.flat_free_kn[s][i]);
        b.gain[0] * dep
            - b.fraction() * force
            - b.allowance_kn
            - 2.0 * b.absolute_kn
            - 2.0 * b.bound_kn
            > 0.0
    })
}

/// The departure rule of sizing: whether instance `i`'s cell predicts, at some sensor, a
/// larger departure from the good wheel than the measurement shows, beyond every error. With
/// `a` the sensor's fitted gain, `ε` the model-form fraction, `D` the smallest largest departure
/// over the instance and its neighbours (`cell`, the instances its cell reaches) and `F` the
/// flat-free force there, the truth's measured departure is at least
/// `a·(1 − ε)·D − allowance_fraction·a·F − allowance_kn − T_max`; a measured departure below
/// that rules the instance out. `sensors` pairs each sensor's bank axis with its test.
pub(crate) fn falsified_by_departure(
    d: &Departures,
    i: usize,
    cell: &[u32],
    sensors: &[(usize, &SensorTest)],
    b: &TableBounds,
    model_form_fraction: f64,
) -> bool {
    sensors.iter().any(|&(s, t)| {
        let (dep, force) = (&d.departure_kn[s], &d.flat_free_kn[s]);
        let (least, at) = cell
            .iter()
            .map(|&j| j as usize)
            .chain(std::iter::once(i))
            .map(|j| (dep[j], force[j]))
            .fold(
                (f32::INFINITY, 0.0f32),
                |m, x| if x.0 < m.0 { x } else { m },
            );
        let shown = t.gain * (1.0 - model_form_fraction) * f64::from(least)
            - b.fraction() * t.gain * f64::from(at)
            - b.allowance_kn
            - b.absolute_kn
            - b.bound_kn;
        shown > t.departure_kn
    })
}

/// The detection limit over the instances with L0 `l0_mm` ([`DetectionLimit`]; the tests'
/// reference for the identifier's own).
#[cfg(test)]
pub(crate) fn limit(
    d: &Departures,
    l0_mm: &[f64],
    axes: &[usize],
    b: &TableBounds,
) -> DetectionLimit {
    limit_of(l0_mm, &detected(d, axes, b), |_| true)
}

/// Whether each instance would surely have been detected through the bank axes `axes`
/// ([`surely_detected`]): computed once a pass, then binned by [`limit_of`] for the whole
/// population and for each wheel.
pub(crate) fn detected(d: &Departures, axes: &[usize], b: &TableBounds) -> Vec<bool> {
    (0..d.instances)
        .map(|i| surely_detected(d, axes, i, b))
        .collect()
}

/// [`limit`] over the instances `keep` accepts (e.g. one wheel's), from each instance's
/// [`detected`].
pub(crate) fn limit_of(
    l0_mm: &[f64],
    detected: &[bool],
    keep: impl Fn(usize) -> bool,
) -> DetectionLimit {
    let kept = || l0_mm.iter().enumerate().filter(|&(i, _)| keep(i));
    let lowest = kept().map(|(_, &l)| l).fold(f64::INFINITY, f64::min);
    let highest = kept().map(|(_, &l)| l).fold(f64::NEG_INFINITY, f64::max);
    if !lowest.is_finite() || !highest.is_finite() {
        return DetectionLimit {
            l0_mm: None,
            at_population_floor: false,
            share_detected: 0.0,
            bins: Vec::new(),
            wheels: Vec::new(),
        };
    }
    let first = (lowest / LIMIT_BIN_MM).floor() * LIMIT_BIN_MM;
    let count = (((highest - first) / LIMIT_BIN_MM).floor() as usize + 1).min(100_000);
    let mut bins: Vec<LimitBin> = (0..count)
        .map(|j| LimitBin {
            l0_mm: first + j as f64 * LIMIT_BIN_MM,
            instances: 0,
            detected: 0,
        })
        .collect();
    let mut total = 0usize;
    let mut n = 0usize;
    for (i, &l0) in kept() {
        n += 1;
        let j = (((l0 - first) / LIMIT_BIN_MM).floor() as usize).min(count - 1);
        bins[j].instances += 1;
        if detected[i] {
            bins[j].detected += 1;
            total += 1;
        }
    }
    let ok = |bin: &LimitBin| {
        bin.instances == 0 || bin.detected as f64 >= LIMIT_SHARE * bin.instances as f64
    };
    // The smallest bin from which every bin up is within the limit.
    let from = bins.iter().rposition(|b| !ok(b)).map_or(0, |j| j + 1);
    let l0 = (from < bins.len()).then(|| if from == 0 { lowest } else { bins[from].l0_mm });
    DetectionLimit {
        l0_mm: l0,
        at_population_floor: from == 0,
        share_detected: total as f64 / n as f64,
        bins,
        wheels: Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::calibration::IdentificationParams;

    fn bounds() -> TableBounds {
        TableBounds::of(&IdentificationParams::default())
    }

    fn series(values_kn: Vec<f64>) -> MeasuredSeries {
        MeasuredSeries {
            sensor: "rps1".into(),
            t0_s: 0.0,
            sample_rate_hz: 2500.0,
            values_kn,
        }
    }

    /// A wheel passing a pad: a smooth bump up to 23 kN over 1000 samples.
    fn template() -> Vec<f32> {
        (0..1000)
            .map(|k| {
                let x = (k as f64 - 500.0) / 120.0;
                (23.0 * (-x * x).exp()) as f32
            })
            .collect()
    }

    #[test]
    fn the_default_tables_bounds_are_its_sums() {
        // S in [−0.32 − 0.07, 0.19 + 0.07]; T_max = 1 + 0.05 kN.
        let b = bounds();
        assert!((b.gain[0] - 1.0 / 1.26).abs() < 1e-12, "{:?}", b.gain);
        assert!((b.gain[1] - 1.0 / 0.61).abs() < 1e-12, "{:?}", b.gain);
        assert!((b.absolute_kn - 1.05).abs() < 1e-12);
    }

    #[test]
    fn a_good_wheel_at_the_tables_edges_is_not_detected() {
        // The largest gain error, and noise at its bound alternating in sign.
        let g = template();
        let b = bounds();
        for gain in [b.gain[0], 1.0, b.gain[1]] {
            let y: Vec<f64> = g
                .iter()
                .enumerate()
                .map(|(k, &g)| gain * f64::from(g) + if k % 2 == 0 { 1.04 } else { -1.04 })
                .collect();
            let t = test_sensor(&series(y), &g, &b);
            assert!(
                t.excess_kn < 0.0,
                "gain {gain}: {:?}",
                (t.gain, t.excess_kn)
            );
            assert!((t.gain - gain).abs() < 1e-3, "{} for {gain}", t.gain);
        }
    }

    #[test]
    fn a_strike_of_a_few_kilonewtons_is_detected_where_it_is() {
        let g = template();
        let mut y: Vec<f64> = g.iter().map(|&g| 1.1 * f64::from(g)).collect();
        for (j, k) in (620..630).enumerate() {
            y[k] += if j % 2 == 0 { 2.5 } else { -1.5 };
        }
        let t = test_sensor(&series(y), &g, &bounds());
        assert!(t.excess_kn > 0.5, "{:?}", (t.gain, t.excess_kn));
        // Least squares over the loaded samples: the strike's residuals of both signs move the
        // gain by less than 0.1 %.
        assert!((t.gain - 1.1).abs() < 1e-3, "{}", t.gain);
        assert!((620..630).contains(&((t.at_time_s * 2500.0).round() as usize)));
    }

    #[test]
    fn a_level_outside_the_table_is_named() {
        let g = template();
        let y: Vec<f64> = g.iter().map(|&g| 0.5 * f64::from(g)).collect();
        let t = test_sensor(&series(y), &g, &bounds());
        assert!(t.gain_outside_table);
        assert!(
            t.excess_kn > 0.0,
            "half the load is not a good wheel of this bank"
        );
    }

    #[test]
    fn the_departure_rule_rules_out_only_what_every_error_cannot_explain() {
        // Instance 0 departs 10 kN, instance 1 (its neighbour) 4 kN, instance 2 30 kN.
        let d = Departures {
            instances: 3,
            departure_kn: vec![vec![10.0, 4.0, 30.0]],
            flat_free_kn: vec![vec![20.0; 3]],
        };
        let b = bounds();
        let test = |measured_kn: f64| SensorTest {
            sensor: "rps1".into(),
            gain: 1.0,
            gain_outside_table: false,
            fitted_gain: 1.0,
            loaded_samples: 400,
            excess_kn: 1.0,
            at_time_s: 0.0,
            residual_kn: measured_kn,
            departure_kn: measured_kn,
            flat_free_kn: Vec::new(),
        };
        let t = test(5.0);
        let rule =
            |i: usize, cell: &[u32]| falsified_by_departure(&d, i, cell, &[(0, &t)], &b, 0.25);
        // 30·0.75 − 0.2 − 0.25 − 1.05 = 21 kN shown at least: 5 kN measured rules it out.
        assert!(rule(2, &[]));
        // 10·0.75 − 1.5 = 6 kN: ruled out alone, kept when its cell reaches the 4 kN neighbour.
        assert!(rule(0, &[]));
        assert!(!rule(0, &[1]));
        // A measured departure as large as the prediction keeps every instance.
        let t = test(30.0);
        assert!(!falsified_by_departure(&d, 2, &[], &[(0, &t)], &b, 0.25));
    }

    #[test]
    fn the_limit_is_the_smallest_l0_from_which_every_bin_is_seen() {
        // Departures grow with L0; bins below 30 mm are not seen.
        let l0: Vec<f64> = (0..400).map(|i| 18.0 + i as f64 * 0.1).collect();
        let dep: Vec<f32> = l0
            .iter()
            .map(|&l| if l >= 30.0 { 10.0 } else { 1.0 })
            .collect();
        let d = Departures {
            instances: l0.len(),
            departure_kn: vec![dep],
            flat_free_kn: vec![vec![20.0; l0.len()]],
        };
        let lim = limit(&d, &l0, &[0], &bounds());
        assert_eq!(lim.l0_mm, Some(30.0));
        assert!(!lim.at_population_floor);
        let all_seen = Departures {
            departure_kn: vec![vec![10.0; l0.len()]],
            ..d.clone()
        };
        let lim = limit(&all_seen, &l0, &[0], &bounds());
        assert_eq!(lim.l0_mm, Some(18.0));
        assert!(lim.at_population_floor);
        let none_seen = Departures {
            departure_kn: vec![vec![1.0; l0.len()]],
            ..d
        };
        assert_eq!(limit(&none_seen, &l0, &[0], &bounds()).l0_mm, None);
    }

    #[test]
    fn a_wheel_whose_strikes_the_sensors_miss_has_no_limit_of_its_own() {
        // Even instances on one wheel, seen from L0 30 mm; odd ones on the other, never seen
        // (their strikes fall where the sensors cannot see them). Over both, at most half of a
        // bin is detected, so there is no limit; per wheel, one has its limit, the other
        // none: "flat not seen" for that wheel, never "good".
        let l0: Vec<f64> = (0..800).map(|i| 18.0 + (i / 2) as f64 * 0.1).collect();
        let dep: Vec<f32> = l0
            .iter()
            .enumerate()
            .map(|(i, &l)| if i % 2 == 0 && l >= 30.0 { 10.0 } else { 1.0 })
            .collect();
        let d = Departures {
            instances: l0.len(),
            departure_kn: vec![dep],
            flat_free_kn: vec![vec![20.0; l0.len()]],
        };
        assert_eq!(limit(&d, &l0, &[0], &bounds()).l0_mm, None);
        let flags = detected(&d, &[0], &bounds());
        let seen = limit_of(&l0, &flags, |i| i % 2 == 0);
        assert_eq!(seen.l0_mm, Some(30.0));
        assert!(
            (seen.share_detected - 0.7).abs() < 0.01,
            "{}",
            seen.share_detected
        );
        assert_eq!(limit_of(&l0, &flags, |i| i % 2 == 1).l0_mm, None);
    }
}
