//! One time step of several instances at once.
//!
//! Every instance of a bank shares the track, the vehicle and the step sizes; only the flat
//! differs, and with it the contact forces and where the fine steps fall. The stepper
//! therefore carries `B` instances ("lanes") side by side: each track vector holds, per DOF,
//! one value per lane (`[f64; B]`), so the band products and the band substitutions run
//! across the lanes in SIMD registers. The substitution is latency-bound for one right-hand
//! side, so the extra lanes come nearly free; the contact solve stays scalar, per lane.
//!
//! A lane's arithmetic never depends on the other lanes: the same instance gives the same
//! bits in any batch, with any batch-mates and with `B = 1` (the single-instance path,
//! [`super::Simulator::run`]). Inactive lanes (waiting for a step of the other size, or
//! finished) are computed along but not committed.
//!
//! The step is Newmark average acceleration on track and vehicle with the two Hertz
//! contacts solved implicitly at the end of the step (docs/model.md §9):
//!
//! 1. predictors `ũ = u + dt·v + dt²/4·a`, `ṽ = v + dt/2·a`;
//! 2. right-hand side `r = −K·ũ − C·ṽ` (minus the voided sleepers' unilateral ballast);
//! 3. contact-free accelerations `a* = A⁻¹·r`, read under the wheels only;
//! 4. the 2×2 contact Newton per lane, with the compliances of the precomputed `A⁻¹`;
//! 5. final accelerations `a = A⁻¹·(r + Σ Nᵀ·F)`, a second substitution rather than adding
//!    eight columns of `A⁻¹` (which would not vectorise across lanes whose wheels sit over
//!    different elements).
//!
//! The work is four sweeps along the band (`A = L·D·Lᵀ`, half-bandwidth 4), each touching a
//! DOF's lane vectors once: (1) predictors, `r` and the forward substitution `y = L⁻¹·r`
//! together; (2) the backward substitution of `a*` only down to the lowest DOF under a wheel
//! (`lo`), all the contact needs; (3) the forward substitution of `r + Σ Nᵀ·F` from `lo` on
//! (below `lo` it equals `y`); (4) the full backward substitution, committing `u`, `v`, `a`
//! row by row. Each sweep does exactly the arithmetic of the plain two solves, so the split
//! changes no bit.
//!
//! Products are fused multiply–adds (`f64::mul_add`, correctly rounded on every platform, so
//! the bits do not depend on the CPU; the wide path is compiled for AVX2+FMA and chosen at
//! run time, [`super::batch`]).

use super::banded::BandedLdl;
use super::contact::solve_contact_pair;
use super::effect::Effect;
use super::track::TrackModel;
use super::vehicle::{mul4, wheel, VehicleModel, BOUNCE};

/// The dynamic state of `B` instances: per track DOF one value per lane.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct LaneState<const B: usize> {
    /// Time of each lane (s).
    pub time_s: [f64; B],
    /// Track displacements.
    pub u: Vec<[f64; B]>,
    /// Track velocities.
    pub v: Vec<[f64; B]>,
    /// Track accelerations.
    pub a: Vec<[f64; B]>,
    /// Vehicle displacements `[z_b, φ, z_w1, z_w2]` of each lane.
    pub q: [[f64; 4]; B],
    /// Vehicle velocities.
    pub qd: [[f64; 4]; B],
    /// Vehicle accelerations.
    pub qdd: [[f64; 4]; B],
    /// Contact forces `[leading, trailing]` of each lane (N).
    pub contact_n: [[f64; 2]; B],
}

impl<const B: usize> LaneState<B> {
    /// All lanes at rest at zero (padding lanes stay so).
    pub(crate) fn zeros(n: usize) -> LaneState<B> {
        LaneState {
            time_s: [0.0; B],
            u: vec![[0.0; B]; n],
            v: vec![[0.0; B]; n],
            a: vec![[0.0; B]; n],
            q: [[0.0; 4]; B],
            qd: [[0.0; 4]; B],
            qdd: [[0.0; 4]; B],
            contact_n: [[0.0; 2]; B],
        }
    }

    /// Lane `l`'s track displacement vector is finite (and so its step did not diverge).
    pub(crate) fn lane_finite(&self, l: usize) -> bool {
        self.q[l][wheel(0)].is_finite() && self.u.iter().all(|u| u[l].is_finite())
    }
}

/// Scratch vectors of a lane step; one per thread, reused.
#[derive(Debug, Clone)]
pub struct LaneWork<const B: usize> {
    ut: Vec<[f64; B]>,
    vt: Vec<[f64; B]>,
    r: Vec<[f64; B]>,
    y: Vec<[f64; B]>,
}

impl<const B: usize> LaneWork<B> {
    /// Scratch for a track of `n` DOFs.
    pub fn new(n: usize) -> LaneWork<B> {
        LaneWork {
            ut: vec![[0.0; B]; n],
            vt: vec![[0.0; B]; n],
            r: vec![[0.0; B]; n],
            y: vec![[0.0; B]; n],
        }
    }
}

/// The track's stiffness and damping as sparse rows (nonzeros only), for `K·ũ + C·ṽ`, and
/// the voided sleepers by DOF.
#[derive(Debug, Clone)]
pub(crate) struct Coupling {
    /// Row `i`'s stiffness entries are `k[k_start[i]..k_start[i+1]]`.
    k_start: Vec<usize>,
    k: Vec<(usize, f64)>,
    c_start: Vec<usize>,
    c: Vec<(usize, f64)>,
    /// Farthest column any row reaches beyond its own.
    reach: usize,
    /// Voided sleepers `(DOF, gap, K_b, C_b)`, in DOF order.
    voided: Vec<(usize, f64, f64, f64)>,
}

impl Coupling {
    /// The nonzero rows of the track's `K` and `C`, columns ascending.
    pub(crate) fn new(track: &TrackModel) -> Coupling {
        let n = track.dofs();
        let hb = track.k.half_bandwidth().max(track.c.half_bandwidth());
        let rows = |m: &super::banded::BandedSym| {
            let mut start = vec![0];
            let mut entries = Vec::new();
            for i in 0..n {
                for j in i.saturating_sub(hb)..(i + hb + 1).min(n) {
                    let v = m.get(i, j);
                    if v != 0.0 {
                        entries.push((j, v));
                    }
                }
                start.push(entries.len());
            }
            (start, entries)
        };
        let (k_start, k) = rows(&track.k);
        let (c_start, c) = rows(&track.c);
        let mut voided = track.voided.clone();
        voided.sort_by_key(|v| v.0);
        Coupling {
            k_start,
            k,
            c_start,
            c,
            reach: hb,
            voided,
        }
    }

    /// `−(K·ut + C·vt)` of row `i`, lane by lane, terms summed in column order (stiffness
    /// first).
    #[inline(always)]
    fn minus_row<const B: usize>(&self, i: usize, ut: &[[f64; B]], vt: &[[f64; B]]) -> [f64; B] {
        let mut acc = [0.0; B];
        for &(j, kv) in &self.k[self.k_start[i]..self.k_start[i + 1]] {
            let x = &ut[j];
            acc = std::array::from_fn(|l| kv.mul_add(x[l], acc[l]));
        }
        for &(j, cv) in &self.c[self.c_start[i]..self.c_start[i + 1]] {
            let x = &vt[j];
            acc = std::array::from_fn(|l| cv.mul_add(x[l], acc[l]));
        }
        std::array::from_fn(|l| -acc[l])
    }
}

/// The predictors `ũ = u + dt·v + dt²/4·a`, `ṽ = v + dt/2·a` of row `i`. (A function, not a
/// closure: closures are not compiled with the caller's target features and would call the
/// software `fma`.)
#[inline(always)]
fn predict<const B: usize>(i: usize, st: &LaneState<B>, ws: &mut LaneWork<B>, dt: f64) {
    let (b, g) = (0.25 * dt * dt, 0.5 * dt);
    let (u, v, a) = (&st.u[i], &st.v[i], &st.a[i]);
    ws.ut[i] = std::array::from_fn(|l| b.mul_add(a[l], dt.mul_add(v[l], u[l])));
    ws.vt[i] = std::array::from_fn(|l| g.mul_add(a[l], v[l]));
}

/// `new` where `keep` is 0, `old` where it is all ones: an exact, vectorisable select.
#[inline(always)]
fn select(new: f64, old: f64, keep: u64) -> f64 {
    f64::from_bits((new.to_bits() & !keep) | (old.to_bits() & keep))
}

/// One row of the forward substitution `y_i = r_i − Σ_d L[i][i−d]·y_{i−d}` for every lane,
/// farthest term first; `h = [y_{i−1}, y_{i−2}, y_{i−3}, y_{i−4}]`.
#[inline(always)]
fn forward_row<const B: usize>(row: &[f64], r: [f64; B], h: &[[f64; B]; 4]) -> [f64; B] {
    let (r1, r2, r3, r4) = (-row[1], -row[2], -row[3], -row[4]);
    std::array::from_fn(|l| {
        let far = r2.mul_add(h[1][l], r3.mul_add(h[2][l], r4.mul_add(h[3][l], r[l])));
        r1.mul_add(h[0][l], far)
    })
}

/// One row of the backward substitution `x_i = y_i/D_i − Σ_d L[i+d][i]·x_{i+d}`;
/// `h = [x_{i+1}, …, x_{i+4}]`.
#[inline(always)]
fn backward_row<const B: usize>(
    col: &[f64],
    inv_d: f64,
    y: [f64; B],
    h: &[[f64; B]; 4],
) -> [f64; B] {
    let (c1, c2, c3, c4) = (-col[1], -col[2], -col[3], -col[4]);
    std::array::from_fn(|l| {
        let far = c2.mul_add(
            h[1][l],
            c3.mul_add(h[2][l], c4.mul_add(h[3][l], y[l] * inv_d)),
        );
        c1.mul_add(h[0][l], far)
    })
}

/// Where each lane's wheels are and what they roll over at the end of the step.
#[derive(Debug, Clone, Copy)]
pub(crate) struct LaneInputs<const B: usize> {
    /// Lanes that take this step; the others keep their state.
    pub active: [bool; B],
    /// Wheel positions `[leading, trailing]` (m).
    pub x: [[f64; 2]; B],
    /// Wheel-centre drops (flat and irregularities) under each wheel (m).
    pub z_tr: [[f64; 2]; B],
}

/// Factored matrices for one time-step size.
#[derive(Debug, Clone)]
pub(super) struct StepLevel {
    pub(super) dt: f64,
    pub(super) ldl: BandedLdl,
    /// Dense inverse of the track's effective matrix (symmetric, row `i` at `i*n`), for the
    /// contact compliances.
    pub(super) a_inv: Vec<f64>,
    pub(super) veh_inv: [[f64; 4]; 4],
}

/// What one step of the lanes reads of the simulator ([`super::Simulator`] makes one a step):
/// the step size's factored matrices, the track, the vehicle, the coupling rows, the contact
/// constant, and the effects that load the car body.
pub(super) struct Stepper<'a> {
    pub(super) level: &'a StepLevel,
    pub(super) track: &'a TrackModel,
    pub(super) vehicle: &'a VehicleModel,
    pub(super) coupling: &'a Coupling,
    pub(super) c_h: f64,
    pub(super) effects: &'a [Effect],
    /// The car body's weight `M_c·g` (N).
    pub(super) weight_n: f64,
}

impl Stepper<'_> {
    /// The car body's load beyond `M_c·g` at time `t` (car-body bounce effects; 0 otherwise).
    #[inline]
    fn body_bounce_n(&self, t: f64) -> f64 {
        self.effects
            .iter()
            .map(|e| e.body_load_n(self.weight_n, t))
            .sum()
    }

    /// Advances the active lanes of `st` by one step (module docs).
    #[inline(always)]
    pub(super) fn step<const B: usize>(
        &self,
        st: &mut LaneState<B>,
        ws: &mut LaneWork<B>,
        input: &LaneInputs<B>,
    ) {
        let lv = self.level;
        let dt = lv.dt;
        let b = 0.25 * dt * dt;
        let g = 0.5 * dt;
        let n = self.track.dofs();
        let ldl = &lv.ldl;
        let cp = &self.coupling;
        let z = [0.0; B];

        // Where the wheels are: the lowest DOF under a wheel of an active lane bounds the
        // partial sweeps.
        let loc: [[([usize; 4], [f64; 4]); 2]; B] = std::array::from_fn(|l| {
            if input.active[l] {
                [
                    self.track.locate(input.x[l][0]),
                    self.track.locate(input.x[l][1]),
                ]
            } else {
                [([usize::MAX; 4], [0.0; 4]); 2]
            }
        });
        let lo = loc
            .iter()
            .flat_map(|w| w.iter().flat_map(|(idx, _)| idx.iter()))
            .copied()
            .filter(|&d| d != usize::MAX)
            .min()
            .unwrap_or(0);

        // Sweep 1: predictors (`reach` rows ahead), right-hand side, forward substitution.
        for i in 0..cp.reach.min(n) {
            predict(i, st, ws, dt);
        }
        let mut voided = cp.voided.iter();
        let mut next_void = voided.next();
        let mut h = [z; 4];
        for i in 0..n {
            if i + cp.reach < n {
                predict(i + cp.reach, st, ws, dt);
            }
            let mut r = cp.minus_row(i, &ws.ut, &ws.vt);
            if let Some(&(_, gap, kb, cb)) = next_void.filter(|v| v.0 == i) {
                let (ut, vt) = (&ws.ut[i], &ws.vt[i]);
                for l in 0..B {
                    r[l] -= TrackModel::voided_ballast_force(kb, cb, gap, ut[l], vt[l]);
                }
                next_void = voided.next();
            }
            ws.r[i] = r;
            let y = forward_row(ldl.lower_row(i), r, &h);
            ws.y[i] = y;
            h = [y, h[0], h[1], h[2]];
        }
        // Sweep 2: a* = A⁻¹·r from the top down to `lo`, in place of y.
        let mut h = [z; 4];
        for i in (lo..n).rev() {
            let x = backward_row(ldl.upper_col(i), ldl.inv_pivot(i), ws.y[i], &h);
            ws.y[i] = x;
            h = [x, h[0], h[1], h[2]];
        }

        // Vehicle and contact, lane by lane.
        for l in 0..B {
            if !input.active[l] {
                continue;
            }
            let (x, z_tr) = (input.x[l], input.z_tr[l]);
            let (q, qd, qdd) = (st.q[l], st.qd[l], st.qdd[l]);
            let ut_v: [f64; 4] =
                std::array::from_fn(|i| b.mul_add(qdd[i], dt.mul_add(qd[i], q[i])));
            let vt_v: [f64; 4] = std::array::from_fn(|i| g.mul_add(qdd[i], qd[i]));
            let ku = mul4(&self.vehicle.k, &ut_v);
            let cv = mul4(&self.vehicle.c, &vt_v);
            let mut load = self.vehicle.load;
            load[BOUNCE] += self.body_bounce_n(st.time_s[l] + dt);
            let rv: [f64; 4] = std::array::from_fn(|i| load[i] - ku[i] - cv[i]);
            let av_free = mul4(&lv.veh_inv, &rv);

            let loc = &loc[l];
            let mut delta_free = [0.0; 2];
            let mut comp = [[0.0; 2]; 2];
            for i in 0..2 {
                let (idx, sh) = &loc[i];
                let mut w_free = 0.0;
                for a in 0..4 {
                    if idx[a] != usize::MAX {
                        let d = idx[a];
                        w_free = sh[a].mul_add(b.mul_add(ws.y[d][l], ws.ut[d][l]), w_free);
                    }
                }
                let z_free = b.mul_add(av_free[wheel(i)], ut_v[wheel(i)]);
                delta_free[i] = z_free - w_free - z_tr[i];
                for j in 0..2 {
                    let (jdx, shj) = &loc[j];
                    let mut h = 0.0;
                    for a in 0..4 {
                        if idx[a] == usize::MAX {
                            continue;
                        }
                        let row = &lv.a_inv[idx[a] * n..(idx[a] + 1) * n];
                        for c in 0..4 {
                            if jdx[c] != usize::MAX {
                                h += sh[a] * row[jdx[c]] * shj[c];
                            }
                        }
                    }
                    comp[i][j] = b * (h + lv.veh_inv[wheel(i)][wheel(j)]);
                }
                comp[i][i] += self.track.interior_compliance_at(x[i]);
            }
            let f = solve_contact_pair(self.c_h, delta_free, comp);

            // The contact forces on the rail join the right-hand side of sweep 3.
            for i in 0..2 {
                if f[i] == 0.0 {
                    continue;
                }
                let (idx, sh) = &loc[i];
                for a in 0..4 {
                    if idx[a] != usize::MAX {
                        ws.r[idx[a]][l] = sh[a].mul_add(f[i], ws.r[idx[a]][l]);
                    }
                }
            }
            let mut av = av_free;
            for (r, avr) in av.iter_mut().enumerate() {
                *avr -= lv.veh_inv[r][wheel(0)] * f[0] + lv.veh_inv[r][wheel(1)] * f[1];
            }
            for i in 0..4 {
                st.qdd[l][i] = av[i];
                st.q[l][i] = b.mul_add(av[i], ut_v[i]);
                st.qd[l][i] = g.mul_add(av[i], vt_v[i]);
            }
            st.contact_n[l] = f;
            st.time_s[l] += dt;
        }

        // Sweep 3: forward substitution of r + Σ Nᵀ·F from `lo` on (below, it equals y).
        let mut h: [[f64; B]; 4] =
            std::array::from_fn(|d| if lo > d { ws.y[lo - 1 - d] } else { z });
        for i in lo..n {
            let y = forward_row(ldl.lower_row(i), ws.r[i], &h);
            ws.y[i] = y;
            h = [y, h[0], h[1], h[2]];
        }
        // Sweep 4: the final accelerations, committed to the active lanes row by row
        // (waiting lanes keep their bits: a bitwise select, exact and vectorisable).
        let keep: [u64; B] = std::array::from_fn(|l| if input.active[l] { 0 } else { u64::MAX });
        let mut h = [z; 4];
        for i in (0..n).rev() {
            let r = backward_row(ldl.upper_col(i), ldl.inv_pivot(i), ws.y[i], &h);
            h = [r, h[0], h[1], h[2]];
            let (ut, vt) = (&ws.ut[i], &ws.vt[i]);
            let (u, v, a) = (&mut st.u[i], &mut st.v[i], &mut st.a[i]);
            *u = std::array::from_fn(|l| select(b.mul_add(r[l], ut[l]), u[l], keep[l]));
            *v = std::array::from_fn(|l| select(g.mul_add(r[l], vt[l]), v[l], keep[l]));
            *a = std::array::from_fn(|l| select(r[l], a[l], keep[l]));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::banded::BandedSym;

    #[test]
    fn lane_sweeps_solve_like_the_scalar_substitution() {
        // An SPD band of half-width 4; three lanes with different right-hand sides. The fused
        // sweeps differ from the scalar solve only in rounding (fused products): 1e-13
        // relative is ~500 ulps, far below any physical effect, far above rounding noise.
        let n = 41;
        let mut a = BandedSym::zeros(n, 4);
        for i in 0..n {
            a.add(i, i, 10.0 + (i % 7) as f64);
            for d in 1..=4.min(i) {
                a.add(i, i - d, 1.0 / (1.0 + d as f64 + (i % 3) as f64));
            }
        }
        let ldl = a.factor().unwrap();
        let rhs: Vec<[f64; 3]> = (0..n)
            .map(|i| {
                let x = i as f64;
                [(0.37 * x).sin(), (0.91 * x).cos(), x - 20.0]
            })
            .collect();
        let mut y = rhs.clone();
        let mut h = [[0.0; 3]; 4];
        for (i, yi) in y.iter_mut().enumerate() {
            let v = forward_row(ldl.lower_row(i), *yi, &h);
            *yi = v;
            h = [v, h[0], h[1], h[2]];
        }
        let mut h = [[0.0; 3]; 4];
        for i in (0..n).rev() {
            let v = backward_row(ldl.upper_col(i), ldl.inv_pivot(i), y[i], &h);
            y[i] = v;
            h = [v, h[0], h[1], h[2]];
        }
        for l in 0..3 {
            let mut x: Vec<f64> = rhs.iter().map(|r| r[l]).collect();
            ldl.solve_in_place(&mut x);
            for i in 0..n {
                let tol = 1e-13 * x[i].abs().max(1.0);
                assert!(
                    (y[i][l] - x[i]).abs() <= tol,
                    "lane {l} row {i}: {} vs {}",
                    y[i][l],
                    x[i]
                );
            }
        }
    }
}
