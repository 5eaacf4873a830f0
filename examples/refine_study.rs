//! Refinement study (issue 11): after the bank-only identification, simulate a local
//! Hammersley population inside the candidate model set's ranges with the bank's calibration,
//! falsify it with cells of the local population, and repeat.
//! `cargo run --release --example refine_study -- BANK CASES SEED [same|finer] M ROUNDS [eip|all] [kappa]`
//! `SHOW=CASE` prints that case's boxes and survivors.
use rayon::prelude::*;
use std::path::Path;
use wheelflat::bank::schema::sensor_axes;
use wheelflat::bank::Population;
use wheelflat::identify::cells::Cells;
use wheelflat::identify::coverage::{judge, method_line, severity_class, Judged};
use wheelflat::identify::falsify::{falsify, Point, Resolution};
use wheelflat::identify::result::ParamRanges;
use wheelflat::identify::{coverage, Extras, Identifier};
use wheelflat::model::{Flat, Record, Simulator};

/// (true L0, true class, bank-only, refined, refinement time in ms) of one case.
type Row = (f64, usize, Judged, Judged, f64);

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let bank = wheelflat::bank::Bank::open(Path::new(&a[1])).expect("bank");
    let cases: usize = a[2].parse().unwrap();
    let seed: u64 = a[3].parse().unwrap();
    let finer = a.get(4).is_some_and(|s| s == "finer");
    let m_local: usize = a.get(5).map_or(128, |s| s.parse().unwrap());
    let rounds: usize = a.get(6).map_or(2, |s| s.parse().unwrap());
    let all = a.get(7).is_some_and(|s| s == "all");
    let kappa: f64 = a.get(8).map_or(0.5, |s| s.parse().unwrap());
    let cal = bank.metadata().calibration.clone().check().unwrap();
    let meas_cal = if finer {
        coverage::finer_model(&cal)
    } else {
        cal.clone()
    };
    let axes = sensor_axes(&cal);
    let radius = cal.vehicle.wheel_radius_m;
    let (insp, urg) = (
        cal.identification.inspect_l0_mm,
        cal.identification.urgent_l0_mm,
    );
    let sim = Simulator::new(&cal).unwrap();
    let id = Identifier::new(bank, cal.identification.clone()).unwrap();
    let top = Flat::fresh_length_mm(cal.population.depth_mm[1], radius);
    let mut rows: Vec<Row> = Vec::new();
    for (case, flat) in coverage::truths(&cal, cases, seed).iter().enumerate() {
        let (m, t) = coverage::case(&meas_cal, flat, seed, case).unwrap();
        let out = id.identify(&m, None, Extras::NONE).unwrap();
        let base = out.falsifications[0].ranges.clone();
        // Comparison points: (bank axis, sample, measured, low, high).
        let idx: Vec<usize> = if all {
            (0..out.candidates.len()).collect()
        } else {
            out.eip.clone()
        };
        let p = out.phi.powf(1.0 / idx.len().max(1) as f64);
        let pts: Vec<(usize, usize, f64, f64, f64)> = idx
            .iter()
            .map(|&i| {
                let c = &out.candidates[i];
                let axis = axes
                    .iter()
                    .position(|x| x.name == out.series[c.series].sensor)
                    .unwrap();
                let (lo, hi) = id.thresholds(c.measured_kn, p);
                (axis, c.sample, c.measured_kn, lo, hi)
            })
            .collect();
        let t0 = std::time::Instant::now();
        let mut current = base.clone();
        let mut history = Vec::new();
        for round in 0..rounds {
            let Some(r) = current.clone() else { break };
            let mut pop = cal.population.clone();
            pop.length_mm = r.length_mm;
            pop.depth_mm = r.depth_mm;
            pop.curvature_mm = [
                r.curvature_mm[0].min(0.45 * r.depth_mm[0]),
                r.curvature_mm[1],
            ];
            pop.impact_position_m = r.impact_position_m;
            let local = Population::new(&pop, m_local, 1 + round as u64 + 7 * case as u64);
            let flats: Vec<_> = (0..m_local).map(|i| local.instance(i)).collect();
            let preds: Vec<Vec<f32>> = flats
                .par_iter()
                .map_init(
                    || sim.workspace(),
                    |ws, s| {
                        let f = Flat::from_mm(
                            s.length_mm,
                            s.depth_mm,
                            s.curvature_mm,
                            s.impact_position_m,
                        )
                        .unwrap()
                        .on_wheel(cal.vehicle.flat_wheel);
                        let resp = sim.run_with(Some(&f), Record::default(), ws).unwrap();
                        pts.iter()
                            .map(|&(ax, k, ..)| {
                                (resp.window(ax, axes[ax].first_sample, axes[ax].samples)[k] / 1e3)
                                    as f32
                            })
                            .collect()
                    },
                )
                .collect();
            // Column-major predictions per point.
            let cols: Vec<Vec<f32>> = (0..pts.len())
                .map(|j| preds.iter().map(|row| row[j]).collect())
                .collect();
            let coords: Vec<[f64; 4]> = flats
                .iter()
                .map(|s| [s.length_mm, s.depth_mm, s.curvature_mm, s.impact_position_m])
                .collect();
            let unit: Vec<[f64; 4]> = (0..m_local).map(|i| local.unit_point(i)).collect();
            let cells = Cells::from_points(&unit, &coords);
            let points: Vec<Point> = pts
                .iter()
                .zip(&cols)
                .map(|(&(_, _, y, lo, hi), g)| Point {
                    predictions: g,
                    measured_kn: y,
                    low_kn: lo,
                    high_kn: hi,
                    // As measured on 2026-11-23: thresholds at the measured force only.
                    curve: None,
                })
                .collect();
            let surv = falsify(
                &points,
                Some(Resolution {
                    cells: &cells,
                    kappa,
                }),
            );
            let next = (!surv.is_empty()).then(|| {
                let span = |tix: usize, clamp: [f64; 2]| {
                    let (mut lo, mut hi) = (f64::MAX, f64::MIN);
                    for &k in &surv {
                        let h = cells.half_extent(k as usize)[tix];
                        lo = lo.min(coords[k as usize][tix] - h);
                        hi = hi.max(coords[k as usize][tix] + h);
                    }
                    [lo.max(clamp[0]), hi.min(clamp[1])]
                };
                let depth = span(1, r.depth_mm);
                ParamRanges {
                    length_mm: span(0, r.length_mm),
                    depth_mm: depth,
                    curvature_mm: span(2, r.curvature_mm),
                    impact_position_m: span(3, r.impact_position_m),
                    l0_mm: [
                        Flat::fresh_length_mm(depth[0], radius),
                        Flat::fresh_length_mm(depth[1], radius),
                    ],
                    flat_wheels: r.flat_wheels.clone(),
                }
            });
            history.push(surv.len());
            if std::env::var("SHOW").is_ok_and(|v| v == case.to_string()) {
                eprintln!(
                    "round {round} box L {:?} d {:?} c {:?} X {:?}",
                    r.length_mm, r.depth_mm, r.curvature_mm, r.impact_position_m
                );
                for &k in &surv {
                    let c = coords[k as usize];
                    eprintln!(
                        "  L {:6.1} d {:.3} c {:.3} X {:.4} half {:?}",
                        c[0],
                        c[1],
                        c[2],
                        c[3],
                        cells.half_extent(k as usize)
                    );
                }
            }
            current = next;
        }
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        let judge = |r: &Option<ParamRanges>| judge(r.as_ref(), &t, true, insp, urg);
        let (b, n) = (judge(&base), judge(&current));
        println!(
            "{case:>3} L {:6.1} d {:.3} c {:.3} X {:.3} L0 {:5.1} | base {} [{:5.1},{:5.1}] | refined {} [{:5.1},{:5.1}] cls {}/{} survivors {:?} {:.0} ms",
            t.length_mm, t.depth_mm, t.curvature_mm, t.impact_position_m, t.l0_mm,
            b.0 as u8, b.1[0], b.1[1], n.0 as u8, n.1[0], n.1[1], n.2, severity_class(t.l0_mm, insp, urg), history, ms
        );
        rows.push((t.l0_mm, severity_class(t.l0_mm, insp, urg), b, n, ms));
    }
    let truth: Vec<(f64, usize)> = rows.iter().map(|r| (r.0, r.1)).collect();
    let base: Vec<Judged> = rows.iter().map(|r| r.2).collect();
    let new: Vec<Judged> = rows.iter().map(|r| r.3).collect();
    println!("{}", method_line("bank-only", &truth, &base, top));
    println!("{}", method_line("refined", &truth, &new, top));
    let mut t: Vec<f64> = rows.iter().map(|r| r.4).collect();
    t.sort_by(f64::total_cmp);
    println!(
        "refinement median {:.0} ms, max {:.0} ms",
        t[t.len() / 2],
        t[t.len() - 1]
    );
}
