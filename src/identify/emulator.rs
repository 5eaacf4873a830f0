//! A local linear emulator inside each aligned cell, instead of widening to the farthest
//! neighbour.
//!
//! Within instance i's cell the flat-induced response at a point is modelled as linear in
//! the offset `u = (ΔL, Δd, Δc, Δφ)` from i (each scaled by its population range, φ in
//! one-sample units after the whole-sample alignment): `r(u) ≈ r_i + a·u`, with `a` fitted by
//! least squares to the 8 aligned neighbours. Its error is bounded by `κ_e` times the largest
//! neighbour residual of the fit. A box of offsets is kept when, at every point, some `u` in
//! the box can bring the prediction within the thresholds widened by that error
//! (`|r_i + a·u_c − target| ≤ halfwidth + e + Σ|a_t|·h_t` for the box centre `u_c` and
//! half-sizes `h`); kept boxes are halved in every dimension and tested again, `depth` times.
//! The ranges are the union of the boxes kept at the last level, so they can be narrower than
//! the cell.

use super::aligned::{AlignedCells, ShiftPoint, Survivor, NEIGHBOURS};
use crate::bank::Parameters;
use crate::model::calibration::PopulationParams;
use rayon::prelude::*;

/// Settings of the emulator stage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EmulatorSettings {
    /// Factor on the largest neighbour residual of the linear fit.
    pub kappa_error: f64,
    /// Box halvings.
    pub depth: u32,
    /// Shift error per millimetre of shift, as a fraction of the flat-induced force.
    pub shift_error_per_mm: f64,
}

impl Default for EmulatorSettings {
    fn default() -> Self {
        EmulatorSettings {
            kappa_error: 1.0,
            depth: 3,
            shift_error_per_mm: 0.003,
        }
    }
}

/// The physical bounds `[lo, hi]` of L, d, c (mm) and X_p (m) that an instance keeps.
pub type Bounds = [[f64; 2]; 4];

/// The emulator stage's answer: the kept bounds of each instance and their union.
pub type Emulated = (Vec<(u32, Bounds)>, Option<super::result::ParamRanges>);

/// Per point: the linear model `r_i + a·u` and its error bound.
struct Local {
    base: f64,
    slope: [f64; 4],
    error: f64,
    target: f64,
    halfwidth: f64,
}

/// Solves the 4×4 ridge normal equations for the 8 offsets (rows of `x`).
fn pseudo_inverse(x: &[[f64; 4]]) -> Option<[[f64; NEIGHBOURS]; 4]> {
    let mut a = nalgebra::Matrix4::<f64>::zeros();
    for r in x {
        for p in 0..4 {
            for q in 0..4 {
                a[(p, q)] += r[p] * r[q];
            }
        }
    }
    let trace = (0..4).map(|p| a[(p, p)]).sum::<f64>();
    for p in 0..4 {
        a[(p, p)] += 1e-6 * trace.max(1e-12);
    }
    let inv = a.try_inverse()?;
    let mut out = [[0.0; NEIGHBOURS]; 4];
    for (j, r) in x.iter().enumerate() {
        for p in 0..4 {
            out[p][j] = (0..4).map(|q| inv[(p, q)] * r[q]).sum();
        }
    }
    Some(out)
}

/// Refines every survivor of the aligned pre-filter; returns the kept bounds of each.
#[allow(clippy::too_many_arguments)]
pub fn refine(
    points: &[ShiftPoint],
    cells: &AlignedCells,
    params: &Parameters,
    pop: &PopulationParams,
    survivors: &[Survivor],
    st: &EmulatorSettings,
) -> Vec<(u32, Bounds)> {
    let scale = [
        (pop.length_mm[1] - pop.length_mm[0]).max(1e-9),
        (pop.depth_mm[1] - pop.depth_mm[0]).max(1e-9),
        (pop.curvature_mm[1] - pop.curvature_mm[0]).max(1e-9),
        1.0,
    ];
    survivors
        .par_iter()
        .filter_map(|s| {
            let i = s.row as usize;
            let nb: Vec<(usize, i32)> = cells.neighbours(i).collect();
            let theta = |k: usize| {
                [
                    params.length_mm[k],
                    params.depth_mm[k],
                    params.curvature_mm[k],
                    params.impact_position_m[k],
                ]
            };
            let ti = theta(i);
            let offsets: Vec<[f64; 4]> = nb
                .iter()
                .map(|&(j, m)| {
                    let tj = theta(j);
                    let dx = (tj[3] - ti[3]) / cells.step_m - m as f64;
                    [
                        (tj[0] - ti[0]) / scale[0],
                        (tj[1] - ti[1]) / scale[1],
                        (tj[2] - ti[2]) / scale[2],
                        dx,
                    ]
                })
                .collect();
            let pinv = pseudo_inverse(&offsets)?;
            // The cell: half-way to the farthest neighbour, per dimension (φ: half a sample).
            let mut half = [0.0f64; 4];
            for o in &offsets {
                for t in 0..3 {
                    half[t] = half[t].max(0.5 * o[t].abs());
                }
            }
            half[3] = 0.5;
            let mut kept: Option<Bounds> = None;
            for n in s.n_min..=s.n_max {
                let Some(locals) = points
                    .iter()
                    .map(|p| local(p, cells, i, n, &nb, &offsets, &pinv, st))
                    .collect::<Option<Vec<Local>>>()
                else {
                    continue;
                };
                let mut boxes = vec![([0.0f64; 4], half)];
                for level in 0..=st.depth {
                    boxes.retain(|(c, h)| {
                        locals.iter().all(|l| {
                            let g = l.base + (0..4).map(|t| l.slope[t] * c[t]).sum::<f64>();
                            let reach: f64 = (0..4).map(|t| (l.slope[t] * h[t]).abs()).sum();
                            (g - l.target).abs() <= l.halfwidth + l.error + reach
                        })
                    });
                    if boxes.is_empty() || level == st.depth {
                        break;
                    }
                    boxes = boxes
                        .iter()
                        .flat_map(|(c, h)| {
                            let h2 = h.map(|v| v / 2.0);
                            (0..16).map(move |b| {
                                let mut c2 = *c;
                                for t in 0..4 {
                                    c2[t] += if b >> t & 1 == 1 { h2[t] } else { -h2[t] };
                                }
                                (c2, h2)
                            })
                        })
                        .collect();
                }
                for (c, h) in &boxes {
                    let x0 = ti[3] + n as f64 * cells.step_m;
                    let b: Bounds = [
                        [
                            ti[0] + (c[0] - h[0]) * scale[0],
                            ti[0] + (c[0] + h[0]) * scale[0],
                        ],
                        [
                            ti[1] + (c[1] - h[1]) * scale[1],
                            ti[1] + (c[1] + h[1]) * scale[1],
                        ],
                        [
                            ti[2] + (c[2] - h[2]) * scale[2],
                            ti[2] + (c[2] + h[2]) * scale[2],
                        ],
                        [
                            x0 + (c[3] - h[3]) * cells.step_m,
                            x0 + (c[3] + h[3]) * cells.step_m,
                        ],
                    ];
                    kept = super::aligned::union(kept.into_iter().chain([b]));
                }
            }
            kept.map(|b| (s.row, b))
        })
        .collect()
}

#[allow(clippy::too_many_arguments)]
fn local(
    p: &ShiftPoint,
    cells: &AlignedCells,
    i: usize,
    n: i32,
    nb: &[(usize, i32)],
    offsets: &[[f64; 4]],
    pinv: &[[f64; NEIGHBOURS]; 4],
    st: &EmulatorSettings,
) -> Option<Local> {
    let s = p.sample as isize - n as isize;
    let ri = p.response_at(i, s)?;
    let dv: Vec<f64> = nb
        .iter()
        .map(|&(j, m)| p.response_at(j, s + m as isize).map_or(0.0, |rj| rj - ri))
        .collect();
    let slope: [f64; 4] = std::array::from_fn(|t| (0..nb.len()).map(|j| pinv[t][j] * dv[j]).sum());
    let error = (0..nb.len())
        .map(|j| (dv[j] - (0..4).map(|t| slope[t] * offsets[j][t]).sum::<f64>()).abs())
        .fold(0.0, f64::max);
    let shift = st.shift_error_per_mm * (n as f64 * cells.step_m * 1e3).abs() * ri.abs();
    let center = 0.5 * (p.low_kn + p.high_kn);
    Some(Local {
        base: ri,
        slope,
        error: st.kappa_error * error + shift,
        target: p.measured_kn - p.template[p.sample] as f64 + center,
        halfwidth: 0.5 * (p.high_kn - p.low_kn),
    })
}
