//! Field-like synthetic measurements from a chosen true flat: simulated, then perturbed with
//! errors drawn inside the calibration's uncertainty table, seeded.
//!
//! Per series (sensor) the model error is systematic: one draw of every model source, and the
//! "true" force is `g·(1 − E_model)` (the model's prediction `g` errs by `E_model` of the
//! force). The measurement then adds a per-sensor gain error (one draw of every relative
//! measurement source), independent noise per sample (the absolute sources other than the
//! resolution), and quantisation to the sensor resolution (a resolution of ±r is a step of 2r).

use super::domain::uncertainty::{draw_sources, resolution_step_kn};
use crate::model::calibration::{UncertaintyGroup, UncertaintyKind};
use crate::model::surface::SurfaceNote;
use crate::model::{
    CheckedCalibration, ContactFilter, Flat, Record, SimError, Simulator, Surfaces, WheelPosition,
};
use serde::{Deserialize, Serialize};

/// Extra samples recorded before the first and after the last sensor window.
pub const MARGIN_SAMPLES: usize = 100;

/// What `synth` hid in a measurement: the truth to compare an identification with.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Truth {
    /// Flat length L (mm).
    pub length_mm: f64,
    /// Depth d (mm).
    pub depth_mm: f64,
    /// Curvature c (mm).
    pub curvature_mm: f64,
    /// Impact position X_p (m).
    pub impact_position_m: f64,
    /// L0 = sqrt(8·d·R_w) (mm).
    pub l0_mm: f64,
    /// The largest wheel–rail contact force of the flat's wheel over the run, noise-free (kN;
    /// of either wheel for a good wheel).
    #[serde(default)]
    pub peak_contact_kn: f64,
    /// How long the flat's wheel was off the rail, noise-free (ms; 0 when it kept contact).
    #[serde(default)]
    pub contact_loss_ms: f64,
    /// The wheel carrying the flat (absent for a good wheel).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flat_wheel: Option<WheelPosition>,
    /// Seed of the perturbation.
    pub seed: u64,
    /// Per sensor: the systematic model error E_model drawn (fraction).
    pub model_error: Vec<(String, f64)>,
    /// Per sensor: the gain error drawn (fraction).
    pub gain_error: Vec<(String, f64)>,
    /// Bank time = file time + this (s).
    pub shift_s: f64,
    /// Laser trigger time written to the file (file clock), if any.
    pub laser_trigger_s: Option<f64>,
    /// Effects of the calibration simulated (hidden in the measurement, for diagnosis).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub effects: Vec<crate::model::Effect>,
    /// The wheel and rail surfaces simulated (rough treads, out-of-round wheels, a measured
    /// profile), as described by whoever drew them.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub surfaces: Vec<SurfaceNote>,
}

/// The surfaces a synthetic pass is simulated with, the contact filter and their
/// description for the truth.
#[derive(Debug, Clone, PartialEq)]
pub struct PassSurfaces {
    /// The surfaces.
    pub surfaces: Surfaces,
    /// The contact filter they go through.
    pub filter: ContactFilter,
    /// Their description.
    pub notes: Vec<SurfaceNote>,
}

impl PassSurfaces {
    /// The surfaces `spec` asks for on `cal`'s wheels and rail, through `spec`'s contact
    /// filter.
    pub fn of(
        spec: &crate::model::surface::SurfaceSpec,
        cal: &CheckedCalibration,
    ) -> Result<PassSurfaces, crate::model::surface::SurfaceError> {
        let (surfaces, notes) = spec.build(cal.vehicle.wheel_radius_m, cal.rail_length_m())?;
        Ok(PassSurfaces {
            surfaces,
            filter: spec.filter,
            notes,
        })
    }
}

/// A synthetic measurement: CSV text and its truth.
#[derive(Debug, Clone, PartialEq)]
pub struct Synthetic {
    /// The CSV (same format as `simulate`, with `#` metadata lines).
    pub csv: String,
    /// The truth.
    pub truth: Truth,
}

/// Field-like noise instead of the table's independent noise (the clean cases with
/// coloured noise): per sensor an AR(1) series `e_0 = s·u_0`, `e_k = ρ·e_{k−1} + √(1−ρ²)·s·u_k`,
/// `u_k` the table's independent draw. Stationary: its standard deviation is `s` times the
/// table's and its lag-1 correlation `ρ`. `FieldNoise::TABLE` (`s = 1`, `ρ = 0`) gives the
/// table's noise draw for draw.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FieldNoise {
    /// Scale `s` of the noise's standard deviation over the table's (≥ 0).
    pub scale: f64,
    /// Lag-1 correlation `ρ` (0 ≤ ρ < 1).
    pub ar1: f64,
}

impl FieldNoise {
    /// The table's own independent noise.
    pub const TABLE: FieldNoise = FieldNoise {
        scale: 1.0,
        ar1: 0.0,
    };
}

/// Simulates `flat` with `cal` and perturbs it; `with_trigger` writes the laser trigger time.
pub fn synthesize(
    cal: &CheckedCalibration,
    flat: &Flat,
    seed: u64,
    with_trigger: bool,
) -> Result<Synthetic, SimError> {
    synthesize_with_noise(cal, flat, seed, with_trigger, FieldNoise::TABLE)
}

/// [`synthesize`] with field-like noise `noise` (see [`FieldNoise`]).
pub fn synthesize_with_noise(
    cal: &CheckedCalibration,
    flat: &Flat,
    seed: u64,
    with_trigger: bool,
    noise: FieldNoise,
) -> Result<Synthetic, SimError> {
    synthesize_pass(cal, Some(flat), seed, with_trigger, noise)
}

/// [`synthesize_with_noise`] of a flat or, with `None`, of a good wheel (its truth then gives
/// a flat of size zero: L, d, c and L0 all 0).
pub fn synthesize_pass(
    cal: &CheckedCalibration,
    flat: Option<&Flat>,
    seed: u64,
    with_trigger: bool,
    noise: FieldNoise,
) -> Result<Synthetic, SimError> {
    synthesize_on(cal, flat, None, seed, with_trigger, noise)
}

/// [`synthesize_pass`] over wheel and rail surfaces (rough treads, out-of-round wheels, a
/// measured profile; `None`: round wheels on a smooth rail).
pub fn synthesize_on(
    cal: &CheckedCalibration,
    flat: Option<&Flat>,
    surfaces: Option<&PassSurfaces>,
    seed: u64,
    with_trigger: bool,
    noise: FieldNoise,
) -> Result<Synthetic, SimError> {
    if !(noise.scale >= 0.0 && noise.scale.is_finite() && (0.0..1.0).contains(&noise.ar1)) {
        return Err(SimError::Setup(format!(
            "field noise scale {} (≥ 0) and AR(1) correlation {} (0 ≤ ρ < 1) out of range",
            noise.scale, noise.ar1
        )));
    }
    let innovation = (1.0 - noise.ar1 * noise.ar1).sqrt();
    // Record a margin around the windows: simulate with longer windows (the run is causal, so
    // the samples inside the bank's windows are unchanged).
    let mut wide = cal.document().clone();
    wide.output.window_samples += 2 * MARGIN_SAMPLES;
    let wide = wide.check().map_err(|e| SimError::Setup(e.to_string()))?;
    let mut sim = Simulator::new(&wide)?;
    if let Some(s) = surfaces {
        sim = sim.with_surfaces(&s.surfaces, s.filter)?;
    }
    let resp = sim.run(flat, Record::default())?;
    let id = &cal.identification;
    let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0xD1CE;
    let mut draw =
        |group, kind, skip_resolution| draw_sources(id, group, kind, skip_resolution, &mut state);
    let names: Vec<String> = cal.sensors.pad.iter().map(|p| p.name.clone()).collect();
    let model_error: Vec<f64> = names
        .iter()
        .map(|_| draw(UncertaintyGroup::Model, UncertaintyKind::Relative, false))
        .collect();
    let gain_error: Vec<f64> = names
        .iter()
        .map(|_| {
            draw(
                UncertaintyGroup::Measurement,
                UncertaintyKind::Relative,
                false,
            )
        })
        .collect();
    let resolution_kn = resolution_step_kn(id);
    let rate = cal.output.sample_rate_hz;
    let mut csv = String::from("# wheelflat synthetic measurement (see the truth JSON)\n");
    let shift_s = resp.first_sample as f64 / rate;
    let laser = with_trigger.then(|| {
        (cal.sensors.laser_trigger_m - cal.run.leading_wheel_start_m) / cal.speed_m_per_s()
            - shift_s
    });
    if let Some(t) = laser {
        csv += &format!("# laser_trigger_s = {t:.6}\n");
    }
    csv += &format!("# speed_km_per_h = {}\n", cal.run.speed_km_per_h);
    csv += "time_s";
    for n in &names {
        csv += &format!(",{n}_kn");
    }
    csv.push('\n');
    let mut previous = vec![0.0; names.len()];
    for j in 0..resp.len() {
        csv += &format!("{:.6}", j as f64 / rate);
        for (s, series) in resp.pad_force_n.iter().enumerate() {
            let g = series[j] / 1e3;
            let truth = g * (1.0 - model_error[s]);
            let u = noise.scale
                * draw(
                    UncertaintyGroup::Measurement,
                    UncertaintyKind::AbsoluteKn,
                    true,
                );
            let e = if j == 0 {
                u
            } else {
                noise.ar1 * previous[s] + innovation * u
            };
            previous[s] = e;
            let mut y = truth * (1.0 + gain_error[s]) + e;
            if resolution_kn > 0.0 {
                y = (y / resolution_kn).round() * resolution_kn;
            }
            csv += &format!(",{y:.4}");
        }
        csv.push('\n');
    }
    let size = |f: fn(&Flat) -> f64| flat.map_or(0.0, |x| f(x) * 1e3);
    let truth = Truth {
        length_mm: size(Flat::length_m),
        depth_mm: size(Flat::depth_m),
        curvature_mm: size(Flat::curvature_m),
        impact_position_m: flat.map_or(0.0, Flat::impact_position_m),
        l0_mm: flat.map_or(0.0, |x| x.fresh_length_m(cal.vehicle.wheel_radius_m) * 1e3),
        peak_contact_kn: match flat {
            Some(f) => {
                resp.peak_contact_force_n[f.wheel().unwrap_or(cal.vehicle.flat_wheel).index()]
            }
            None => resp.peak_contact_force_n[0].max(resp.peak_contact_force_n[1]),
        } / 1e3,
        contact_loss_ms: flat.map_or(0.0, |f| {
            resp.contact_loss_s[f.wheel().unwrap_or(cal.vehicle.flat_wheel).index()] * 1e3
        }),
        flat_wheel: flat.map(|f| f.wheel().unwrap_or(cal.vehicle.flat_wheel)),
        seed,
        model_error: names.iter().cloned().zip(model_error).collect(),
        gain_error: names.iter().cloned().zip(gain_error).collect(),
        shift_s,
        laser_trigger_s: laser,
        effects: cal.effects.clone(),
        surfaces: surfaces.map_or_else(Vec::new, |s| s.notes.clone()),
    };
    Ok(Synthetic { csv, truth })
}
