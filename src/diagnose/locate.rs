//! Locate: the best instance of an identification (the residual-minimisation optimum) is
//! compared with the measurement at every sample of every sensor. The thresholds are Šídák over
//! all those samples, `φ^(1/N)`, so that clean data leaves them anywhere with probability
//! ≤ 1 − φ. They are widened sample by sample by the instance's cell (κ × the largest difference
//! to its neighbours' predictions, as in falsification). Samples outside are gathered per sensor
//! into time windows (runs of samples outside, gaps of up to [`MERGE_SAMPLES`] bridged), each
//! with the track positions of the bogie centre and the wheels.

use crate::audit::AuditError;
use crate::identify::{Identification, Identifier, Sizing};
use serde::{Deserialize, Serialize};

/// Runs of samples outside the thresholds closer than this are one window.
pub const MERGE_SAMPLES: usize = 5;

/// A time window where the residual leaves the thresholds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GapWindow {
    /// Bank time span (s).
    pub time_s: [f64; 2],
    /// Bogie-centre position over the span (m along the rail).
    pub bogie_centre_m: [f64; 2],
    /// Leading and trailing wheel positions at the window's largest excess (m).
    pub wheels_m: [f64; 2],
    /// Samples outside in the window.
    pub samples_outside: usize,
    /// Largest excess beyond the thresholds (kN).
    pub max_outside_kn: f64,
}

/// One sensor's disagreement.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SensorGap {
    /// Sensor.
    pub sensor: String,
    /// Samples compared.
    pub samples: usize,
    /// Samples outside the thresholds.
    pub samples_outside: usize,
    /// Expected outside by chance, `(1 − p)·samples` (independent samples; systematic errors
    /// make exceedances cluster, but their total probability stays ≤ 1 − φ).
    pub expected_by_chance: f64,
    /// RMS of the residual (kN).
    pub rms_residual_kn: f64,
    /// RMS of the excess over the thresholds (0 inside), all samples (kN).
    pub gap_rms_kn: f64,
    /// Windows where it leaves the thresholds, largest excess first.
    pub windows: Vec<GapWindow>,
    /// Residual (prediction − measurement) per sample (kN), for the plot.
    pub residual_kn: Vec<f64>,
    /// Thresholds per sample, widened by the instance's cell (kN).
    pub thresholds_kn: Vec<[f64; 2]>,
}

/// Where the best instance and the measurement disagree.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Located {
    /// The instance compared (the residual-minimisation optimum).
    pub instance: u32,
    /// Per-sample probability of the thresholds, `φ^(1/N)` over all N samples.
    pub per_point_probability: f64,
    /// Per sensor of the measurement.
    pub sensors: Vec<SensorGap>,
    /// RMS residual over all samples (kN).
    pub rms_residual_kn: f64,
    /// RMS of the excess over the thresholds (0 inside) over all samples (kN): the gap.
    pub gap_rms_kn: f64,
    /// Samples outside over all sensors.
    pub samples_outside: usize,
    /// Expected by chance over all sensors.
    pub expected_by_chance: f64,
}

/// Locates the disagreement of identification `id` (made by `identifier`; `sizing`, its
/// sizing, names the best instance).
pub fn locate(
    identifier: &Identifier,
    id: &Identification,
    sizing: &Sizing,
) -> Result<Located, AuditError> {
    let bank = identifier.bank();
    let meta = bank.metadata();
    let cal = &meta.calibration;
    let best = sizing
        .residual_minimisation
        .as_ref()
        .ok_or(AuditError::NoFlatDetected)?
        .instance;
    let stored = bank.read_instance(best as usize)?;
    // The instance stands for its cell: its thresholds widen by κ × the largest difference to
    // its neighbours' predictions, sample by sample, as in falsification.
    let resolution = identifier.resolution();
    let neighbours: Vec<crate::bank::StoredInstance> = match resolution {
        Some(r) => r
            .cells
            .neighbours(best as usize)
            .iter()
            .map(|&j| bank.read_instance(j as usize))
            .collect::<Result<_, _>>()?,
        None => Vec::new(),
    };
    let kappa = resolution.map_or(0.0, |r| r.kappa);
    // Šídák over every sample compared: clean data leaves the thresholds anywhere with
    // probability ≤ 1 − φ, whatever the correlation the systematic errors bring.
    let total: usize = id.series.iter().map(|s| s.values_kn.len()).sum();
    let p = identifier.settings().phi.powf(1.0 / total.max(1) as f64);
    let v = cal.run.speed_km_per_h / 3.6;
    let lead0 = cal.run.leading_wheel_start_m;
    let hb = cal.vehicle.half_wheelbase_m;
    let mut sensors = Vec::new();
    let (mut sum2, mut count, mut outside_all, mut expected_all) = (0.0, 0usize, 0usize, 0.0);
    let mut gap2 = 0.0;
    // As the identification compared: its average, its roughness' bounds.
    let c = id.comparison;
    // Through the average (f32, as the bank's columns are read); the samples as stored.
    let compared = |x: &[f32]| -> Vec<f32> {
        if c.weights().len() == 1 {
            return x.to_vec();
        }
        let x: Vec<f64> = x.iter().map(|&v| f64::from(v)).collect();
        crate::model::average::centred_average(&x, c.weights())
            .into_iter()
            .map(|v| v as f32)
            .collect()
    };
    let rough = id
        .roughness
        .clone()
        .unwrap_or_else(|| crate::identify::RoughnessUse::none(0.0, 0.0));
    for ser in &id.series {
        let Some(axis) = meta.sensors.iter().position(|a| a.name == ser.sensor) else {
            continue;
        };
        let g = compared(&stored.forces_kn[axis]);
        let near: Vec<Vec<f32>> = neighbours
            .iter()
            .map(|n| compared(&n.forces_kn[axis]))
            .collect();
        let flat_free = identifier.flat_free(axis, c);
        let time = |k: usize| ser.t0_s + k as f64 / ser.sample_rate_hz;
        let mut residual = Vec::with_capacity(g.len());
        let mut thresholds = Vec::with_capacity(g.len());
        let mut excess = Vec::with_capacity(g.len());
        for (k, (&gk, &y)) in g.iter().zip(&ser.values_kn).enumerate() {
            let r = gk as f64 - y;
            let spread = near
                .iter()
                .map(|n| (n[k] - gk).abs() as f64)
                .fold(0.0, f64::max);
            let (lo, hi) = identifier.point_thresholds(&rough, y, f64::from(flat_free[k]), p);
            let (lo, hi) = (lo - kappa * spread, hi + kappa * spread);
            residual.push(r);
            thresholds.push([lo, hi]);
            excess.push((r - hi).max(lo - r));
        }
        let outside: Vec<usize> = (0..excess.len()).filter(|&k| excess[k] > 0.0).collect();
        // Windows: runs of outside samples, gaps up to MERGE_SAMPLES bridged.
        let mut windows: Vec<GapWindow> = Vec::new();
        let mut start = 0;
        while start < outside.len() {
            let mut end = start;
            while end + 1 < outside.len() && outside[end + 1] - outside[end] <= MERGE_SAMPLES {
                end += 1;
            }
            let (k0, k1) = (outside[start], outside[end]);
            let kmax = outside[start..=end]
                .iter()
                .copied()
                .max_by(|&a, &b| excess[a].total_cmp(&excess[b]))
                .expect("a window has samples");
            let centre = |t: f64| lead0 - hb + v * t;
            windows.push(GapWindow {
                time_s: [time(k0), time(k1)],
                bogie_centre_m: [centre(time(k0)), centre(time(k1))],
                wheels_m: [centre(time(kmax)) + hb, centre(time(kmax)) - hb],
                samples_outside: end - start + 1,
                max_outside_kn: excess[kmax],
            });
            start = end + 1;
        }
        windows.sort_by(|a, b| b.max_outside_kn.total_cmp(&a.max_outside_kn));
        let s2: f64 = residual.iter().map(|r| r * r).sum();
        let e2: f64 = excess.iter().map(|e| e.max(0.0).powi(2)).sum();
        gap2 += e2;
        sum2 += s2;
        count += residual.len();
        outside_all += outside.len();
        let expected = (1.0 - p) * residual.len() as f64;
        expected_all += expected;
        sensors.push(SensorGap {
            sensor: ser.sensor.clone(),
            samples: residual.len(),
            samples_outside: outside.len(),
            expected_by_chance: expected,
            rms_residual_kn: (s2 / residual.len().max(1) as f64).sqrt(),
            gap_rms_kn: (e2 / residual.len().max(1) as f64).sqrt(),
            windows,
            residual_kn: residual,
            thresholds_kn: thresholds,
        });
    }
    Ok(Located {
        instance: best,
        per_point_probability: p,
        sensors,
        rms_residual_kn: (sum2 / count.max(1) as f64).sqrt(),
        gap_rms_kn: (gap2 / count.max(1) as f64).sqrt(),
        samples_outside: outside_all,
        expected_by_chance: expected_all,
    })
}
