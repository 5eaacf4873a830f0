//! An out-of-round wheel told from a flat (docs/detection.md, "Out-of-round wheels"): when a
//! pass leaves the good wheel's bounds with no sharp strike, each wheel's harmonics of orders
//! 1 to 20 are fitted to its departure from the round wheel ([`crate::bank::out_of_round`]);
//! if one harmonic on one wheel brings every sample back inside the same bounds, the pass is
//! "no flat detected; out of round", with the wheel, order, amplitude and phase, and is not
//! sized.
//!
//! The fit: at sensor `j` with detection's gain `a_j`, the departure `r_jk = y_jk − a_j·g_jk`
//! is modelled as `a_j·(c·B^cos_jk + s·B^sin_jk)` (the bank's responses per µm, through the
//! comparison's average as the series are), `c` and `s` by least squares over every sample
//! of every sensor; the amplitude is `√(c² + s²)` µm and the phase `atan2(−s, c)`. The fitted
//! harmonic is added to each sensor's good-wheel template and detection's test is run again
//! unchanged (gains refitted, the same bounds): the harmonic explains the pass only if that
//! test finds no flat, and only if it is the main part of the departure (at least
//! [`MIN_EXPLAINED_SHARE`] of its sum of squares). Amplitudes above [`MAX_AMPLITUDE_UM`] are
//! not named (the responses are linear well inside it).

use crate::bank::out_of_round::OrderResponse;
pub use crate::identify::detect::harmonic::OutOfRoundFit;
use crate::identify::detect::{self, Detection, TableBounds};
use crate::identify::error::IdentifyError;
use crate::identify::identifier::Identifier;
use crate::identify::input::compare::Comparison;
use crate::identify::input::measurement::MeasuredSeries;
use crate::model::average::centred_average;

/// The largest amplitude named (µm).
pub const MAX_AMPLITUDE_UM: f64 = 100.0;

/// The least share of the departure's sum of squares a harmonic must explain to name it: the
/// harmonic must be the main part of what left the bounds, not a wave that, on a rough pass's
/// wide bounds, pulls a flat's strikes back inside (measured: out-of-round good wheels 0.87 and
/// more, flats on rough treads 0.28 at most; docs/detection.md, "Out-of-round wheels").
pub const MIN_EXPLAINED_SHARE: f64 = 0.5;

impl Identifier {
    /// Whether one harmonic on one wheel explains a pass that detection flagged: the series
    /// `series` on bank axes `axes` as detection compared them (`c`), its result `detection`
    /// and bounds `bounds`. The fit and detection's test with it, or `None`.
    pub(in crate::identify) fn explain_out_of_round(
        &self,
        axes: &[usize],
        series: &[MeasuredSeries],
        detection: &Detection,
        bounds: TableBounds,
        c: Comparison,
    ) -> Result<Option<(OutOfRoundFit, Detection)>, IdentifyError> {
        let excess_before = detection.worst().map_or(f64::NEG_INFINITY, |w| w.excess_kn);
        let basis = self.out_of_round_basis()?;
        let templates: Vec<&[f32]> = axes.iter().map(|&a| self.flat_free(a, c)).collect();
        let mut best: Option<(OutOfRoundFit, Detection)> = None;
        for resp in &basis.responses {
            let Some((cos, sin, explained_share)) =
                fit(resp, axes, series, &templates, detection, c)
            else {
                continue;
            };
            let amplitude_um = cos.hypot(sin);
            if amplitude_um.is_nan()
                || amplitude_um > MAX_AMPLITUDE_UM
                || explained_share < MIN_EXPLAINED_SHARE
            {
                continue;
            }
            let shifted: Vec<Vec<f32>> = axes
                .iter()
                .zip(&templates)
                .map(|(&a, g)| {
                    let (bc, bs) = shapes(resp, a, c);
                    g.iter()
                        .zip(bc.iter().zip(&bs))
                        .map(|(&g, (&x, &y))| (f64::from(g) + cos * x + sin * y) as f32)
                        .collect()
                })
                .collect();
            let refs: Vec<&[f32]> = shifted.iter().map(|v| v.as_slice()).collect();
            let d = detect::detect(series, &refs, bounds);
            if d.flat_detected {
                continue;
            }
            let after = d.worst().map_or(f64::NEG_INFINITY, |w| w.excess_kn);
            if best
                .as_ref()
                .is_some_and(|(b, _)| b.excess_after_kn <= after)
            {
                continue;
            }
            let fit = OutOfRoundFit {
                wheel: resp.wheel,
                order: resp.order,
                amplitude_um,
                phase_rad: (-sin).atan2(cos),
                excess_before_kn: excess_before,
                excess_after_kn: after,
                explained_share,
            };
            best = Some((fit, d));
        }
        Ok(best)
    }
}

/// The response's two shapes on bank axis `axis` as comparison `c` sees them.
fn shapes(resp: &OrderResponse, axis: usize, c: Comparison) -> (Vec<f64>, Vec<f64>) {
    let w = c.weights();
    (
        centred_average(&resp.cos_kn_per_um[axis], w),
        centred_average(&resp.sin_kn_per_um[axis], w),
    )
}

/// The least-squares amplitudes `(c, s)` (µm) of one response's two shapes and the share of
/// the departure's sum of squares they explain, or `None` when the shapes do not reach the
/// sensors (a singular system).
fn fit(
    resp: &OrderResponse,
    axes: &[usize],
    series: &[MeasuredSeries],
    templates: &[&[f32]],
    detection: &Detection,
    c: Comparison,
) -> Option<(f64, f64, f64)> {
    let (mut aa, mut ab, mut bb, mut ar, mut br, mut rr) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for (((&axis, s), g), t) in axes
        .iter()
        .zip(series)
        .zip(templates)
        .zip(&detection.sensors)
    {
        let (bc, bs) = shapes(resp, axis, c);
        if bc.len() != s.values_kn.len() {
            return None;
        }
        for k in 0..s.values_kn.len() {
            let r = s.values_kn[k] - t.gain * f64::from(g[k]);
            let (x, y) = (t.gain * bc[k], t.gain * bs[k]);
            aa += x * x;
            ab += x * y;
            bb += y * y;
            ar += x * r;
            br += y * r;
            rr += r * r;
        }
    }
    let det = aa * bb - ab * ab;
    if det.is_nan() || det <= 1e-12 * (aa * bb).max(1e-300) {
        return None;
    }
    let (c, s) = ((ar * bb - br * ab) / det, (br * aa - ar * ab) / det);
    // Σ(r − c·x − s·y)² = rr − 2(c·ar + s·br) + c²·aa + 2cs·ab + s²·bb.
    let left = rr - 2.0 * (c * ar + s * br) + c * c * aa + 2.0 * c * s * ab + s * s * bb;
    Some((c, s, if rr > 0.0 { 1.0 - left / rr } else { 0.0 }))
}
