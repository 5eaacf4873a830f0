//! Oracle study (issue 11): how narrow can an honest answer be, whatever the bank?
//!
//! For each seeded case the bank-only identification gives the method's comparison points
//! (EIP and envelope points, with their thresholds at the per-point probability of the
//! answer). Flats are then simulated *directly* (no bank, no cells, κ = 0) around the truth —
//! which no method knows; this is a measurement of the problem, not a method — and judged at
//! those points exactly as falsification judges an instance: inside the measured force's
//! thresholds, or the prediction's own where it is larger. The flats that survive cannot be
//! told from the truth by the measurement; the largest L0 among them (and the truth's) is the
//! smallest upper bound an answer that keeps them can give. Sampling only part of the admissible
//! region can make that bound too *low*, never too high, so the severity it gives is an upper
//! limit on what any answer that keeps every flat the measurement cannot rule out achieves.
//!
//! `cargo run --release -p wheelflat-studies --bin oracle_study -- BANK CASES SEED [same|finer] [SAMPLES] [eip|all]`
//! (`all`: every PIP candidate as well as the envelope points, Šídák over all of them).
use rayon::prelude::*;
use wheelflat_studies::study;

use study::Study;
use wheelflat::identify::envelope::EnvelopePoint;
use wheelflat::identify::result::CandidatePoint;
use wheelflat::identify::result::ParamRanges;
use wheelflat::identify::{Extras, Identifier};
use wheelflat::model::{batch_key, Flat, Record, Simulator, LANES};
use wheelflat_studies::coverage::{self, judge, method_line, severity_class, Judged};

/// A comparison point: bank axis, first and last sample of its window (equal for an EIP),
/// window maximum (`Some(true)`), minimum (`Some(false)`) or the sample (`None`), measured
/// force, and the thresholds at the measured force.
struct Pt {
    axis: usize,
    window: [usize; 2],
    max: Option<bool>,
    measured: f64,
    low: f64,
    high: f64,
}

fn main() {
    let study = Study::from_args("[SAMPLES] [eip|all]");
    let (cases, seed) = (study.cases, study.seed);
    let samples: usize = study.arg(5, 480);
    let all = study.flag(6, "all");
    let Study {
        bank,
        cal,
        meas_cal,
        ..
    } = study;
    let axes = bank.metadata().sensors.clone();
    let radius = cal.vehicle.wheel_radius_m;
    let (insp, urg, top) = coverage::severity_limits(&cal);
    let pop = cal.population.clone();
    let sim = Simulator::new(&cal).unwrap();
    let id = Identifier::new(bank, cal.identification.clone()).unwrap();
    let mut truth_rows: Vec<(f64, usize)> = Vec::new();
    let (mut bank_rows, mut oracle_rows): (Vec<Judged>, Vec<Judged>) = (Vec::new(), Vec::new());
    let mut admitted_truth = 0;
    for (case, flat) in coverage::truths(&cal, cases, seed).iter().enumerate() {
        let t0 = std::time::Instant::now();
        let (m, t) = coverage::case(&meas_cal, flat, seed, case).unwrap();
        let out = id.identify(&m, None, Extras::NONE).unwrap();
        let axis_of = |series: usize| {
            axes.iter()
                .position(|x| x.name == out.series[series].sensor)
                .unwrap()
        };
        // A flat not detected was not sized: no points (and φ itself for none).
        let z = out.sizing.as_ref();
        let candidates: &[CandidatePoint] = z.map_or(&[], |z| &z.candidates);
        let envelope: &[EnvelopePoint] = z.map_or(&[], |z| &z.envelope);
        let idx: Vec<usize> = if all {
            (0..candidates.len()).collect()
        } else {
            z.map_or_else(Vec::new, |z| z.eip.clone())
        };
        let p = match z {
            Some(z) if !all => z.per_point_probability,
            _ => out
                .phi
                .powf(1.0 / (idx.len() + envelope.len()).max(1) as f64),
        };
        let mut pts: Vec<Pt> = idx
            .iter()
            .map(|&i| {
                let c = &candidates[i];
                let (low, high) = id.thresholds(c.measured_kn, p);
                Pt {
                    axis: axis_of(c.series),
                    window: [c.sample, c.sample],
                    max: None,
                    measured: c.measured_kn,
                    low,
                    high,
                }
            })
            .collect();
        pts.extend(envelope.iter().map(|x| {
            let (low, high) = id.thresholds(x.measured_kn, p);
            Pt {
                axis: axis_of(x.series),
                window: [x.sample - x.half_width, x.sample + x.half_width],
                max: Some(x.kind == wheelflat::identify::envelope::Extreme::Max),
                measured: x.measured_kn,
                low,
                high,
            }
        }));

        // Flats around the truth: a local box, and ridges along which the flat ends
        // (X_p + L) or its middle (X_p + L/2) stay put, over the population's L and d.
        let mut state = seed ^ (case as u64).wrapping_mul(0x1234_5678_9ABC_DEF1);
        let clamp = |v: f64, r: [f64; 2]| v.clamp(r[0], r[1]);
        let mut flats: Vec<Flat> = vec![flat.on_wheel(cal.vehicle.flat_wheel)];
        while flats.len() < samples {
            let mut u = || study::splitmix_uniform(&mut state);
            let family = flats.len() % 3;
            let (l, d, x) = match family {
                0 => {
                    let l = clamp(t.length_mm * (0.7 + 0.6 * u()), pop.length_mm);
                    let d = clamp(t.depth_mm + 0.3 * (u() - 0.5), pop.depth_mm);
                    (l, d, t.impact_position_m + 0.03 * (u() - 0.5))
                }
                _ => {
                    let l = pop.length_mm[0] + u() * (pop.length_mm[1] - pop.length_mm[0]);
                    let d = pop.depth_mm[0] + u() * (pop.depth_mm[1] - pop.depth_mm[0]);
                    let share = if family == 1 { 1.0 } else { 0.5 };
                    let x =
                        t.impact_position_m + share * (t.length_mm - l) * 1e-3 + 0.02 * (u() - 0.5);
                    (l, d, x)
                }
            };
            let c_max = pop.curvature_mm[1].min(0.49 * d);
            let c = pop.curvature_mm[0] + u() * (c_max - pop.curvature_mm[0]).max(0.0);
            if let Ok(f) = Flat::from_mm(l, d, c, clamp(x, pop.impact_position_m)) {
                flats.push(f.on_wheel(cal.vehicle.flat_wheel));
            }
        }
        let mut order: Vec<usize> = (0..flats.len()).collect();
        order.sort_by(|&i, &j| {
            batch_key(&sim, Some(&flats[i])).total_cmp(&batch_key(&sim, Some(&flats[j])))
        });
        let kept: Vec<usize> = order
            .par_chunks(LANES)
            .map_init(
                || sim.lane_workspace::<LANES>(),
                |ws, batch| {
                    let members: Vec<Option<&Flat>> =
                        batch.iter().map(|&k| Some(&flats[k])).collect();
                    let (results, _) = sim.run_batch(&members, Record::default(), ws);
                    batch
                        .iter()
                        .zip(results)
                        .filter(|(_, r)| {
                            let Ok(resp) = r else { return false };
                            pts.iter().all(|pt| {
                                let a = &axes[pt.axis];
                                let w = resp.window(pt.axis, a.first_sample, a.samples);
                                let vals = w[pt.window[0]..=pt.window[1]].iter().map(|v| v / 1e3);
                                let g = match pt.max {
                                    None => w[pt.window[0]] / 1e3,
                                    Some(true) => vals.fold(f64::MIN, f64::max),
                                    Some(false) => vals.fold(f64::MAX, f64::min),
                                };
                                let r = g - pt.measured;
                                let (lo, hi) = if (pt.low..=pt.high).contains(&r) {
                                    (pt.low, pt.high)
                                } else {
                                    id.band(pt.measured, g, p)
                                };
                                (lo..=hi).contains(&r)
                            })
                        })
                        .map(|(&k, _)| k)
                        .collect::<Vec<usize>>()
                },
            )
            .flatten()
            .collect();
        let truth_kept = kept.contains(&0);
        admitted_truth += usize::from(truth_kept);
        let span = |f: &dyn Fn(&Flat) -> f64| {
            kept.iter()
                .map(|&k| f(&flats[k]))
                .fold([f64::MAX, f64::MIN], |s, v| [s[0].min(v), s[1].max(v)])
        };
        let oracle = (!kept.is_empty()).then(|| {
            let depth = span(&|f| f.depth_m() * 1e3);
            ParamRanges {
                length_mm: span(&|f| f.length_m() * 1e3),
                depth_mm: depth,
                curvature_mm: span(&|f| f.curvature_m() * 1e3),
                impact_position_m: span(&|f| f.impact_position_m()),
                l0_mm: [
                    Flat::fresh_length_mm(depth[0], radius),
                    Flat::fresh_length_mm(depth[1], radius),
                ],
                flat_wheels: vec![cal.vehicle.flat_wheel],
                impact: None,
            }
        });
        let base = out.cms_ranges().cloned();
        let b = judge(base.as_ref(), &t, false, insp, urg);
        let o = judge(oracle.as_ref(), &t, false, insp, urg);
        let cls = severity_class(t.l0_mm, insp, urg);
        println!(
            "{case:>3} L {:6.1} d {:.3} X {:.3} L0 {:5.1} cls {cls} | bank [{:5.1},{:5.1}] cls {} | oracle [{:5.1},{:5.1}] cls {} kept {}/{} truth {} | {} points {:.1} s",
            t.length_mm, t.depth_mm, t.impact_position_m, t.l0_mm, b.l0_mm[0], b.l0_mm[1], b.class_index(),
            o.l0_mm[0], o.l0_mm[1], o.class_index(), kept.len(), flats.len(), u8::from(truth_kept), pts.len(),
            t0.elapsed().as_secs_f64()
        );
        truth_rows.push((t.l0_mm, cls));
        bank_rows.push(b);
        oracle_rows.push(o);
    }
    println!(
        "{}",
        method_line("bank-only (default)", &truth_rows, &bank_rows, top)
    );
    println!(
        "{}",
        method_line(
            "oracle (direct simulation, κ 0)",
            &truth_rows,
            &oracle_rows,
            top
        )
    );
    println!(
        "truth itself kept at κ 0: {admitted_truth} of {}",
        truth_rows.len()
    );
}
