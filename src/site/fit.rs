//! The least-squares fit of a site's track to its good wheels (docs/calibration.md, "The
//! model learns its site"): the pad and ballast stiffness (factors of the calibration's) and a
//! voided sleeper's gap at each sleeper next to the sensors, by Levenberg–Marquardt on the
//! passes' series, each sensor's amplitude in each pass profiled out (it carries the pass's
//! load and the sensor's gain); the Jacobian by forward differences of simulations at the
//! bank's mesh, the good wheel simulated at each pass's load (bins of [`LOAD_BIN`]).
//! Intervals: a pairs bootstrap over whole passes of the linearised problem at the optimum
//! (each pass's own `JᵀJ` and `Jᵀr`, so the samples of one pass stay together).

use super::passes::SitePass;
pub use super::residual::{amplitudes, VOID_T};
use super::residual::{clearly_better, distinct, evaluate, normal_equations, pass_sse, Evaluation};
use super::SiteError;
use crate::bank::schema::{sensor_axes, SensorAxis};
use crate::model::{Calibration, CheckedCalibration, Effect, Record, Simulator};
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

/// The prior range of the stiffness factors (a site's track within ±30 % of the calibration
/// it was commissioned with, the range).
pub const PRIOR_FACTOR: [f64; 2] = [0.7, 1.3];

/// The largest voided-sleeper gap fitted (mm).
pub const MAX_GAP_MM: f64 = 3.0;

/// Width of the load bins the good wheel is simulated at (relative wheel load).
pub const LOAD_BIN: f64 = 0.02;

/// Voids fitted at most (the sites have up to two near the sensors).
pub const MAX_VOIDS: usize = 2;

/// Bins searched either side of a pass's amplitude-read load.
const LOAD_SEARCH: i64 = 4;

/// Iterations of Levenberg–Marquardt at most.
const MAX_ITERATIONS: usize = 12;

/// Forward-difference steps: stiffness factors, gaps (mm).
const STEP: [f64; 2] = [0.01, 0.05];

/// Evaluates parameter sets on the passes, counting simulations.
type Evaluator<'a> = dyn Fn(&[Params], &mut usize) -> Result<Vec<Evaluation>, SiteError> + 'a;

/// The parameters: `[support factor, gap at each candidate sleeper (mm)]`: the support factor
/// scales pad and ballast stiffness together (good wheels pin their series stiffness, not the
/// split: docs/calibration.md).
pub type Params = Vec<f64>;

/// A pass at its load bin: per sensor the amplitude, and its misfit
/// ([`TrackFit::misfits`]).
type AtBin = (Vec<f64>, [f64; 2]);

/// The track model a fit varies.
pub struct TrackFit {
    /// The calibration without the effects the fit owns (voided sleepers next to the sensors).
    base: Calibration,
    /// The sensors' windows.
    pub axes: Vec<SensorAxis>,
    /// Sleepers where a void is fitted.
    pub void_sleepers: Vec<usize>,
    /// The base's static wheel load (N).
    wheel_load_n: f64,
}

/// The fit's outcome.
#[derive(Debug, Clone)]
pub struct Fitted {
    /// The parameters at the optimum.
    pub params: Params,
    /// Bootstrap draws of the parameters.
    pub draws: Vec<Params>,
    /// Per pass used, per sensor, the profiled amplitude at the optimum.
    pub amplitudes: Vec<Vec<f64>>,
    /// RMS residual over every sample (kN) at the start and at the optimum.
    pub rms_kn: [f64; 2],
    /// Iterations taken.
    pub iterations: usize,
    /// Simulations run.
    pub simulations: usize,
}

impl TrackFit {
    /// The fit around `cal`: the voids it already states at the sensors' sleepers are the
    /// starting point, not fixed.
    pub fn new(cal: &CheckedCalibration) -> (TrackFit, Params) {
        let axes = sensor_axes(cal);
        let (lo, hi) = axes.iter().fold((usize::MAX, 0), |(lo, hi), a| {
            (lo.min(a.sleeper), hi.max(a.sleeper))
        });
        let void_sleepers: Vec<usize> = (lo.saturating_sub(1).max(1)..=hi + 1)
            .filter(|&s| s < cal.track.bays)
            .collect();
        let mut base = cal.document().clone();
        let mut start = vec![1.0];
        start.extend(void_sleepers.iter().map(|&s| {
            base.effects
                .iter()
                .find_map(|e| match e {
                    Effect::VoidedSleeper { sleeper, gap_mm } if *sleeper == s => Some(*gap_mm),
                    _ => None,
                })
                .unwrap_or(0.0)
        }));
        base.effects.retain(
            |e| !matches!(e, Effect::VoidedSleeper { sleeper, .. } if void_sleepers.contains(sleeper)),
        );
        let wheel_load_n = base.vehicle.static_wheel_load_n();
        (
            TrackFit {
                base,
                axes,
                void_sleepers,
                wheel_load_n,
            },
            start,
        )
    }

    /// The base's static wheel load (N): a template's relative load is over it.
    pub fn wheel_load_n(&self) -> f64 {
        self.wheel_load_n
    }

    /// The calibration with parameters `p` (and the base's wheel load).
    pub fn calibration(&self, p: &[f64]) -> Calibration {
        let mut doc = self.base.clone();
        doc.track.pad_stiffness_n_per_m *= p[0];
        doc.track.ballast_stiffness_n_per_m *= p[0];
        for (i, &s) in self.void_sleepers.iter().enumerate() {
            if p[1 + i] > 1e-3 {
                doc.effects.push(Effect::VoidedSleeper {
                    sleeper: s,
                    gap_mm: p[1 + i],
                });
            }
        }
        doc
    }

    /// The good wheel's series (kN) on every window with parameters `p`, at relative wheel
    /// load `load`.
    pub fn template(&self, p: &[f64], load: f64) -> Result<Vec<Vec<f64>>, SiteError> {
        let mut doc = self.calibration(p);
        let v = &mut doc.vehicle;
        // ((m_c + m_b)/2 + m_w)·g = load·W.
        v.car_body_mass_kg = 2.0
            * (load * self.wheel_load_n / v.gravity_m_per_s2 - v.wheel_mass_kg)
            - v.bogie_mass_kg;
        let cal = doc.check()?;
        let sim = Simulator::new(&cal)?;
        let resp = sim.run(None, Record::default())?;
        Ok(self
            .axes
            .iter()
            .enumerate()
            .map(|(i, a)| {
                resp.window(i, a.first_sample, a.samples)
                    .iter()
                    .map(|v| v / 1e3)
                    .collect()
            })
            .collect())
    }

    /// The good wheel with parameters `p` at each load bin of `bins` (in parallel).
    fn templates_at(&self, p: &[f64], bins: &[i64]) -> Result<Vec<Vec<Vec<f64>>>, SiteError> {
        bins.par_iter()
            .map(|&b| self.template(p, b as f64 * LOAD_BIN))
            .collect()
    }

    /// Clamps `p` to the prior ranges.
    fn clamp(p: &mut [f64]) {
        for (i, x) in p.iter_mut().enumerate() {
            *x = if i < 1 {
                x.clamp(0.5, 1.5)
            } else {
                x.clamp(0.0, MAX_GAP_MM)
            };
        }
    }

    /// Fits `passes` from `start`; `bootstrap` draws (seeded) for the intervals. The support
    /// first; then voids one at a time (at most [`MAX_VOIDS`]): each candidate sleeper tried
    /// at a few gaps, the best fitted with what is already in, and kept only when the passes
    /// agree that it fits better — the mean of the passes' own drops in the sum of squares at
    /// least [`VOID_T`] standard errors above zero (the passes are independent; their samples
    /// are not).
    pub fn fit(
        &self,
        passes: &[SitePass],
        start: &[f64],
        bootstrap: usize,
        seed: u64,
    ) -> Result<Fitted, SiteError> {
        if passes.is_empty() {
            return Err(SiteError::NoPass);
        }
        let mut sims = 0usize;
        // Voids the start states stay candidates fitted from their gap.
        let mut free: Vec<usize> = (0..start.len())
            .filter(|&k| k == 0 || start[k] > 0.0)
            .collect();
        let (mut p, mut at, mut bins, mut iterations, first_sse) =
            self.fit_free(passes, start.to_vec(), &free, &mut sims)?;
        while free.len() - 1 < MAX_VOIDS {
            let distinct = distinct(&bins);
            let candidates: Vec<Params> = (1..p.len())
                .filter(|k| !free.contains(k))
                .flat_map(|k| {
                    let p = &p;
                    [0.3, 0.7, 1.2].into_iter().map(move |g| {
                        let mut q = p.clone();
                        q[k] = g;
                        q
                    })
                })
                .collect();
            if candidates.is_empty() {
                break;
            }
            let evals = self.evaluate_all(passes, &bins, &distinct, &candidates, &mut sims)?;
            let Some((best, _)) = evals
                .iter()
                .enumerate()
                .min_by(|a, b| a.1.sse.total_cmp(&b.1.sse))
            else {
                break;
            };
            // The candidate's sleeper: the one gap it sets (three gaps per candidate).
            let k = (1..p.len())
                .filter(|k| !free.contains(k))
                .nth(best / 3)
                .unwrap_or(1);
            let mut with = free.clone();
            with.push(k);
            let (q, e, b, it, _) =
                self.fit_free(passes, candidates[best].clone(), &with, &mut sims)?;
            if !clearly_better(&at, &e) {
                break;
            }
            (p, at, bins, free) = (q, e, b, with);
            iterations += it;
        }
        let distinct = distinct(&bins);
        let eval =
            |ps: &[Params], sims: &mut usize| self.evaluate_all(passes, &bins, &distinct, ps, sims);
        // The bootstrap over whole passes of the problem linearised at the optimum.
        let jac = self.jacobian(&p, &free, &at, &eval, &mut sims)?;
        let per_pass: Vec<(DMatrix<f64>, DVector<f64>)> = at
            .ranges
            .iter()
            .map(|r| normal_equations(&jac, &at.residual, r.clone()))
            .collect();
        let n = free.len();
        let mut state = seed ^ 0x5EED_CA11;
        let draws = (0..bootstrap)
            .filter_map(|_| {
                let mut a = DMatrix::zeros(n, n);
                let mut g = DVector::zeros(n);
                for _ in 0..per_pass.len() {
                    let i = crate::model::random::index(&mut state, per_pass.len());
                    a += &per_pass[i].0;
                    g += &per_pass[i].1;
                }
                for i in 0..n {
                    a[(i, i)] += 1e-9 * a[(i, i)].abs().max(1e-12);
                }
                let step = a.lu().solve(&(-g))?;
                let mut q = p.clone();
                for (j, &k) in free.iter().enumerate() {
                    q[k] += step[j];
                }
                Self::clamp(&mut q);
                Some(q)
            })
            .collect();
        let count = at.residual.len() as f64;
        Ok(Fitted {
            params: p,
            draws,
            amplitudes: at.amplitudes,
            rms_kn: [(first_sse / count).sqrt(), (at.sse / count).sqrt()],
            iterations,
            simulations: sims,
        })
    }

    /// Levenberg–Marquardt on the parameters `free` from `p`, the passes' load bins read again
    /// at the optimum until they stay (three rounds at most): the optimum, its evaluation, the
    /// bins, the iterations and the first sum of squares.
    #[allow(clippy::type_complexity)]
    fn fit_free(
        &self,
        passes: &[SitePass],
        mut p: Params,
        free: &[usize],
        sims: &mut usize,
    ) -> Result<(Params, Evaluation, Vec<i64>, usize, f64), SiteError> {
        let mut first = None;
        let mut iterations = 0;
        let mut bins = self.load_bins(&p, passes, sims)?;
        for round in 1..=3 {
            let d = distinct(&bins);
            let (q, at, it, sse0) = self.minimise(passes, &bins, &d, p, free, sims)?;
            iterations += it;
            let first_sse = *first.get_or_insert(sse0);
            let again = self.load_bins(&q, passes, sims)?;
            p = q;
            if again == bins || round == 3 {
                return Ok((p, at, bins, iterations, first_sse));
            }
            bins = again;
        }
        unreachable!("the loop returns in its third round")
    }

    /// Each pass's load bin against the good wheel at `p`: the bin whose good wheel fits the
    /// pass best (least sum of squares, amplitudes profiled) within [`LOAD_SEARCH`] bins of
    /// the median of its amplitudes (a voided sleeper's response is not proportional to the
    /// load, and each sensor's amplitude carries its own per-pass error).
    fn load_bins(
        &self,
        p: &[f64],
        passes: &[SitePass],
        sims: &mut usize,
    ) -> Result<Vec<i64>, SiteError> {
        let nominal = self.template(p, 1.0)?;
        let guess: Vec<i64> = passes
            .iter()
            .map(|x| {
                let mut a = amplitudes(&x.series_kn, &nominal);
                a.sort_by(f64::total_cmp);
                let s = a[a.len() / 2];
                (s.clamp(0.4, 1.8) / LOAD_BIN).round() as i64
            })
            .collect();
        let lo = guess.iter().min().copied().unwrap_or(0) - LOAD_SEARCH;
        let hi = guess.iter().max().copied().unwrap_or(0) + LOAD_SEARCH;
        let bins: Vec<i64> = (lo..=hi).collect();
        *sims += bins.len() + 1;
        let t = self.templates_at(p, &bins)?;
        Ok(passes
            .iter()
            .zip(&guess)
            .map(|(x, &g)| {
                (g - LOAD_SEARCH..=g + LOAD_SEARCH)
                    .min_by(|&a, &b| {
                        let sse = |bin: i64| pass_sse(&x.series_kn, &t[(bin - lo) as usize]);
                        sse(a).total_cmp(&sse(b))
                    })
                    .unwrap_or(g)
            })
            .collect())
    }

    /// Every parameter set of `ps` evaluated on `passes` at their load bins.
    fn evaluate_all(
        &self,
        passes: &[SitePass],
        bins: &[i64],
        distinct: &[i64],
        ps: &[Params],
        sims: &mut usize,
    ) -> Result<Vec<Evaluation>, SiteError> {
        let jobs: Vec<(usize, i64)> = (0..ps.len())
            .flat_map(|k| distinct.iter().map(move |&b| (k, b)))
            .collect();
        *sims += jobs.len();
        let t: Vec<Vec<Vec<f64>>> = jobs
            .par_iter()
            .map(|&(k, b)| self.template(&ps[k], b as f64 * LOAD_BIN))
            .collect::<Result<_, _>>()?;
        Ok((0..ps.len())
            .map(|k| {
                let of = |b: i64| {
                    let i = distinct.iter().position(|&x| x == b).unwrap_or(0);
                    &t[k * distinct.len() + i]
                };
                evaluate(passes, bins, of)
            })
            .collect())
    }

    /// Levenberg–Marquardt from `p` with the passes at `bins`: the optimum, its evaluation,
    /// the iterations and the starting sum of squares.
    fn minimise(
        &self,
        passes: &[SitePass],
        bins: &[i64],
        distinct: &[i64],
        mut p: Params,
        free: &[usize],
        sims: &mut usize,
    ) -> Result<(Params, Evaluation, usize, f64), SiteError> {
        let eval =
            |ps: &[Params], sims: &mut usize| self.evaluate_all(passes, bins, distinct, ps, sims);
        let mut at = eval(std::slice::from_ref(&p), sims)?.remove(0);
        let first_sse = at.sse;
        let mut lambda = 1e-2;
        let mut iterations = 0;
        let n = free.len();
        while iterations < MAX_ITERATIONS {
            iterations += 1;
            let jac = self.jacobian(&p, free, &at, &eval, sims)?;
            let (a, g) = normal_equations(&jac, &at.residual, 0..at.residual.len());
            let mut improved = false;
            for _ in 0..6 {
                let mut m = a.clone();
                for i in 0..n {
                    m[(i, i)] += lambda * a[(i, i)].max(1e-9);
                }
                let Some(step) = m.lu().solve(&(-&g)) else {
                    lambda *= 10.0;
                    continue;
                };
                let mut trial = p.clone();
                for (j, &k) in free.iter().enumerate() {
                    trial[k] += step[j];
                }
                Self::clamp(&mut trial);
                let e = eval(std::slice::from_ref(&trial), sims)?.remove(0);
                if e.sse < at.sse {
                    let gain = (at.sse - e.sse) / at.sse;
                    p = trial;
                    at = e;
                    lambda = (lambda / 3.0).max(1e-6);
                    improved = gain > 1e-5;
                    break;
                }
                lambda *= 4.0;
            }
            if !improved {
                break;
            }
        }
        Ok((p, at, iterations, first_sse))
    }

    /// Forward-difference Jacobian columns of the residual at `p`.
    fn jacobian(
        &self,
        p: &[f64],
        free: &[usize],
        at: &Evaluation,
        eval: &Evaluator<'_>,
        sims: &mut usize,
    ) -> Result<Vec<Vec<f64>>, SiteError> {
        let steps: Vec<f64> = free
            .iter()
            .map(|&k| {
                let h = STEP[usize::from(k >= 1)];
                let hi = if k < 1 { 1.5 } else { MAX_GAP_MM };
                if p[k] + h > hi {
                    -h
                } else {
                    h
                }
            })
            .collect();
        let shifted: Vec<Params> = free
            .iter()
            .zip(&steps)
            .map(|(&k, h)| {
                let mut q = p.to_vec();
                q[k] += h;
                q
            })
            .collect();
        let evals = eval(&shifted, sims)?;
        Ok(evals
            .iter()
            .zip(&steps)
            .map(|(e, h)| {
                e.residual
                    .iter()
                    .zip(&at.residual)
                    .map(|(a, b)| (a - b) / h)
                    .collect()
            })
            .collect())
    }
}

impl TrackFit {
    /// Per pass, per sensor, the amplitude of the good wheel with parameters `p` at the pass's
    /// load bin (the passes held back from the fit are read so).
    pub fn amplitudes_at(
        &self,
        p: &[f64],
        passes: &[SitePass],
    ) -> Result<Vec<Vec<f64>>, SiteError> {
        Ok(self
            .at_bins(p, passes)?
            .into_iter()
            .map(|(a, _)| a)
            .collect())
    }

    /// Per pass, how far it is from a good wheel on this track with parameters `p` at its
    /// load bin (amplitudes profiled), whatever its load: `[sum of squares left over its own
    /// sum of squares, largest residual over the residual's RMS]` — the first grows with
    /// anything the good wheel lacks, the second with what is concentrated in a few samples
    /// (a flat's impacts) rather than spread over the pass (a rough tread, a track not yet
    /// fitted).
    pub fn misfits(&self, p: &[f64], passes: &[SitePass]) -> Result<Vec<[f64; 2]>, SiteError> {
        Ok(self
            .at_bins(p, passes)?
            .into_iter()
            .map(|(_, m)| m)
            .collect())
    }

    /// Per pass at its load bin: the amplitudes, and `[sum of squares left over its own,
    /// largest residual over the residual's RMS]`.
    fn at_bins(&self, p: &[f64], passes: &[SitePass]) -> Result<Vec<AtBin>, SiteError> {
        let bins = self.load_bins(p, passes, &mut 0)?;
        let distinct = distinct(&bins);
        let t = self.templates_at(p, &distinct)?;
        Ok(passes
            .iter()
            .zip(&bins)
            .map(|(x, b)| {
                let g = &t[distinct.iter().position(|d| d == b).unwrap_or(0)];
                let a = amplitudes(&x.series_kn, g);
                let (mut sse, mut total, mut peak, mut n) = (0.0, 0.0, 0.0f64, 0usize);
                for ((y, g), c) in x.series_kn.iter().zip(g).zip(&a) {
                    for (y, g) in y.iter().zip(g) {
                        let r = y - c * g;
                        sse += r * r;
                        total += y * y;
                        peak = peak.max(r.abs());
                        n += 1;
                    }
                }
                let rms = (sse / n.max(1) as f64).sqrt();
                (a, [sse / total.max(1e-12), peak / rms.max(1e-12)])
            })
            .collect())
    }
}
