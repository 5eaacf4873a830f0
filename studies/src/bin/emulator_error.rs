//! Could a local linear emulator stand for the flats between simulations at the whole record
//! (issue 11; docs/severity.md, "What it would take")?
//!
//! For each seeded truth, `M` flats are simulated uniformly in a box around it with
//! half-widths `s ×` (14 mm of L, 0.13 mm of d, 0.05 mm of c, 5 mm of X_p — about one cell of
//! the default bank), s = 1, ½ and ¼. Every sample of every sensor window is fitted, by least
//! squares, as linear in the four parameters; the truth's own record is then predicted and
//! the error at each sample compared with the threshold half-width there (Šídák over all
//! 5,000 samples, the thresholds of the truth's force). Beside it, the error of the nearest
//! simulated flat (in the box's units): what a cell stands for today.
//!
//! `cargo run --release -p wheelflat-studies --bin emulator_error -- BANK CASES SEED [same] [M]`
use wheelflat_studies::study;

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use study::{windows_kn, Study};
use wheelflat::model::{Flat, Simulator};
use wheelflat_studies::coverage;

/// One cell of the default bank, about (L mm, d mm, c mm, X_p m).
const CELL: [f64; 4] = [14.0, 0.13, 0.05, 0.005];

fn main() {
    let study = Study::from_args("[M]");
    let (cases, seed) = (study.cases, study.seed);
    let m: usize = study.arg(5, 60);
    let (id, cal, _) = study.into_identifier();
    let sim = Simulator::new(&cal).unwrap();
    let axes = id.bank().metadata().sensors.clone();
    let pop = cal.population.clone();
    let total: usize = axes.iter().map(|a| a.samples).sum();
    let p = cal.identification.phi.powf(1.0 / total as f64);
    let record = |x: &[f64; 4]| -> Option<Vec<f64>> {
        let flat = Flat::from_mm(x[0], x[1], x[2], x[3]).ok()?;
        Some(windows_kn(&sim, &axes, &flat)?.concat())
    };
    let truths = coverage::truths(&cal, cases, seed);
    for scale in [1.0, 0.5, 0.25] {
        // Per case: the worst sample's error over its half-width, emulator and nearest flat.
        let mut worst: Vec<(f64, f64)> = Vec::new();
        for (case, flat) in truths.iter().enumerate() {
            let t = [
                flat.length_m() * 1e3,
                flat.depth_m() * 1e3,
                flat.curvature_m() * 1e3,
                flat.impact_position_m(),
            ];
            let Some(y) = record(&t) else { continue };
            let mut state = seed ^ (case as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
            let mut uniform = || study::uniform(&mut state);
            let clamp = |v: f64, r: [f64; 2]| v.clamp(r[0], r[1]);
            let xs: Vec<[f64; 4]> = (0..m)
                .map(|_| {
                    let mut x = [0.0; 4];
                    for (j, xj) in x.iter_mut().enumerate() {
                        *xj = t[j] + scale * CELL[j] * (2.0 * uniform() - 1.0);
                    }
                    x[0] = clamp(x[0], pop.length_mm);
                    x[1] = clamp(x[1], pop.depth_mm);
                    x[2] = clamp(x[2], pop.curvature_mm).min(0.49 * x[1]);
                    x[3] = clamp(x[3], pop.impact_position_m);
                    x
                })
                .collect();
            let sims: Vec<([f64; 4], Vec<f64>)> = xs
                .par_iter()
                .filter_map(|x| record(x).map(|g| (*x, g)))
                .collect();
            if sims.len() < 10 {
                continue;
            }
            // Least squares: [1, (x − t)/cell] → every sample at once.
            let unit = |x: &[f64; 4], j: usize| (x[j] - t[j]) / (scale * CELL[j]);
            let a = DMatrix::from_fn(sims.len(), 5, |i, j| {
                if j == 0 {
                    1.0
                } else {
                    unit(&sims[i].0, j - 1)
                }
            });
            let b = DMatrix::from_fn(sims.len(), total, |i, k| sims[i].1[k]);
            let at = a.transpose();
            let coef = (&at * &a)
                .try_inverse()
                .map(|inv| inv * (&at * &b))
                .expect("the box's flats span the four parameters");
            // At the truth every unit coordinate is 0: the prediction is the intercept row.
            let emulated = DVector::from_iterator(total, coef.row(0).iter().copied());
            let nearest = sims
                .iter()
                .min_by(|p, q| {
                    let d = |x: &[f64; 4]| (0..4).map(|j| unit(x, j).powi(2)).sum::<f64>();
                    d(&p.0).total_cmp(&d(&q.0))
                })
                .map(|s| &s.1)
                .unwrap();
            let ratio = |g: &dyn Fn(usize) -> f64| {
                (0..total)
                    .map(|k| {
                        let (lo, hi) = id.thresholds(y[k], p);
                        (g(k) - y[k]).abs() / (0.5 * (hi - lo))
                    })
                    .fold(0.0, f64::max)
            };
            let w = (ratio(&|k| emulated[k]), ratio(&|k| nearest[k]));
            if std::env::var_os("SHOW").is_some() {
                println!(
                    "  box ×{scale} case {case:>3} L {:6.1} d {:.3} c {:.3}: emulator {:.2}, nearest {:.2}",
                    t[0], t[1], t[2], w.0, w.1
                );
            }
            worst.push(w);
        }
        let share = |f: &dyn Fn(&(f64, f64)) -> f64, limit: f64| {
            worst.iter().filter(|w| f(w) <= limit).count() as f64 / worst.len().max(1) as f64
        };
        let median = |f: &dyn Fn(&(f64, f64)) -> f64| {
            let mut v: Vec<f64> = worst.iter().map(f).collect();
            v.sort_by(f64::total_cmp);
            v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
        };
        println!(
            "box ×{scale}: {} cases, {m} flats each | worst sample / half-width, median: emulator {:.2}, nearest flat {:.2} | cases within ½ half-width: emulator {:.2}, nearest {:.2}; within 1: {:.2}, {:.2}",
            worst.len(),
            median(&|w| w.0),
            median(&|w| w.1),
            share(&|w| w.0, 0.5),
            share(&|w| w.1, 0.5),
            share(&|w| w.0, 1.0),
            share(&|w| w.1, 1.0),
        );
    }
}
