//! Cells in a stretched parameter space (issue 11): the neighbour graph searched with the unit
//! cube's axes weighted (L, d, c, X_p), against the bank's stored, unweighted graph, on the
//! same seeded cases:
//! `cargo run --release --example metric_study -- BANK CASES SEED same|finer WL WD WC WX [KAPPA]`
use std::path::Path;
use wheelflat::bank::neighbours::neighbour_graph_weighted;
use wheelflat::bank::Bank;
use wheelflat::identify::coverage::{self, judge, method_line, severity_class, Judged};
use wheelflat::identify::{Extras, Identifier};

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let dir = Path::new(&a[1]);
    let cases: usize = a[2].parse().unwrap();
    let seed: u64 = a[3].parse().unwrap();
    let finer = a[4] == "finer";
    let w: [f64; 4] = std::array::from_fn(|t| a[5 + t].parse().unwrap());
    let bank = Bank::open(dir).expect("bank");
    let cal = bank.metadata().calibration.clone().check().unwrap();
    let mut settings = cal.identification.clone();
    if let Some(k) = a.get(9) {
        settings.bank_resolution = k.parse().unwrap();
    }
    let params = bank.read_parameters().unwrap();
    let t0 = std::time::Instant::now();
    let graph = neighbour_graph_weighted(&params, &cal.population, w);
    eprintln!(
        "weighted graph in {:.0} ms",
        t0.elapsed().as_secs_f64() * 1e3
    );
    let base = Identifier::new(Bank::open(dir).unwrap(), settings.clone()).unwrap();
    let graph_copy = graph.clone();
    let weighted = Identifier::with_neighbours(bank, settings, Some(graph)).unwrap();
    let meas_cal = if finer {
        coverage::finer_model(&cal)
    } else {
        cal.clone()
    };
    let (insp, urg, top) = coverage::severity_limits(&cal);
    let mut truth = Vec::new();
    let (mut jb, mut jw): (Vec<Judged>, Vec<Judged>) = (Vec::new(), Vec::new());
    let mut je: Vec<Judged> = Vec::new();
    let mut jeb: Vec<Judged> = Vec::new();
    let w_env: usize = std::env::var("ENV_W").map_or(2, |v| v.parse().unwrap());
    let k_env: usize = std::env::var("ENV_K").map_or(3, |v| v.parse().unwrap());
    let kappa = weighted.settings().bank_resolution;
    let mut ms = Vec::new();
    for (case, flat) in coverage::truths(&cal, cases, seed).iter().enumerate() {
        let (m, t) = coverage::case(&meas_cal, flat, seed, case).unwrap();
        let b = base.identify(&m, None, Extras::NONE).unwrap();
        let c0 = std::time::Instant::now();
        let x = weighted.identify(&m, None, Extras::NONE).unwrap();
        ms.push(c0.elapsed().as_secs_f64() * 1e3);
        let env_cms = envelope(&weighted, &x, &graph_copy, w_env, k_env, kappa);
        let env_ranges = ranges_of_members(&weighted, &graph_copy, &env_cms);
        let je1 = judge(env_ranges.as_ref(), &t, false, insp, urg);
        je.push(je1);
        let stored = base.bank().neighbours().unwrap().to_vec();
        let env_b = envelope(&base, &b, &stored, w_env, k_env, kappa);
        let jeb1 = judge(
            ranges_of_members(&base, &stored, &env_b).as_ref(),
            &t,
            false,
            insp,
            urg,
        );
        jeb.push(jeb1);
        println!(
            "      stored + envelope: {} of {} kept, {} [{:5.1},{:5.1}] {}",
            env_b.len(),
            b.cms.len(),
            jeb1.0 as u8,
            jeb1.1[0],
            jeb1.1[1],
            jeb1.2
        );
        println!(
            "      envelope: {} of {} kept, {} [{:5.1},{:5.1}] {}",
            env_cms.len(),
            x.cms.len(),
            je1.0 as u8,
            je1.1[0],
            je1.1[1],
            je1.2
        );
        let cls = severity_class(t.l0_mm, insp, urg);
        let jb1 = judge(b.falsifications[0].ranges.as_ref(), &t, false, insp, urg);
        let jw1 = judge(x.falsifications[0].ranges.as_ref(), &t, false, insp, urg);
        println!(
            "{case:>3} L {:6.1} d {:.3} c {:.3} X {:.3} L0 {:5.1} cls {cls} | base {:>5} {} [{:5.1},{:5.1}] {} | weighted {:>5} {} [{:5.1},{:5.1}] {} pts {}",
            t.length_mm, t.depth_mm, t.curvature_mm, t.impact_position_m, t.l0_mm,
            b.cms.len(), jb1.0 as u8, jb1.1[0], jb1.1[1], jb1.2,
            x.cms.len(), jw1.0 as u8, jw1.1[0], jw1.1[1], jw1.2, x.eip.len()
        );
        if std::env::var("DUMP")
            .ok()
            .and_then(|v| v.parse::<usize>().ok())
            == Some(case)
        {
            let mut c = x.cms.clone();
            c.sort_by(|p, q| q.l0_mm.total_cmp(&p.l0_mm));
            for i in c.iter().take(30) {
                println!(
                    "    #{:>5} L {:6.1} d {:.3} c {:.3} X {:.4} L0 {:.1}",
                    i.instance,
                    i.length_mm,
                    i.depth_mm,
                    i.curvature_mm,
                    i.impact_position_m,
                    i.l0_mm
                );
            }
        }
        truth.push((t.l0_mm, cls));
        jb.push(jb1);
        jw.push(jw1);
    }
    println!(
        "{}",
        method_line("stored (unweighted) cells", &truth, &jb, top)
    );
    println!(
        "{}",
        method_line(&format!("weighted cells {w:?}"), &truth, &jw, top)
    );
    println!(
        "{}",
        method_line(
            &format!("weighted + envelope w {w_env} k {k_env}"),
            &truth,
            &je,
            top
        )
    );
    println!(
        "{}",
        method_line(
            &format!("stored + envelope w {w_env} k {k_env}"),
            &truth,
            &jeb,
            top
        )
    );
    ms.sort_by(f64::total_cmp);
    println!("weighted identify median {:.1} ms", ms[ms.len() / 2]);
}

/// The survivors of `x` that also pass at envelope points: for each sensor the `k` largest
/// flat-induced deviations of the measurement (at least 2w+1 samples apart), and there the
/// maximum and the minimum of the series over ±w samples, for the measurement and every
/// survivor, the survivor widened by κ × its neighbours' spread of the same feature.
fn envelope(
    id: &Identifier,
    x: &wheelflat::identify::Identification,
    graph: &[u32],
    w: usize,
    k: usize,
    kappa: f64,
) -> Vec<usize> {
    let bank = id.bank();
    let meta = bank.metadata();
    let cms: Vec<usize> = x.cms.iter().map(|c| c.instance as usize).collect();
    if cms.is_empty() {
        return cms;
    }
    // (axis, centre sample) of every window.
    let mut windows: Vec<(usize, usize, &[f64])> = Vec::new();
    for ser in &x.series {
        let bi = meta
            .sensors
            .iter()
            .position(|a| a.name == ser.sensor)
            .unwrap();
        let tpl = &meta.flat_free_kn[bi];
        let n = ser.values_kn.len();
        let mut dev: Vec<(f64, usize)> = (w..n - w)
            .map(|s| ((ser.values_kn[s] - tpl[s] as f64).abs(), s))
            .collect();
        dev.sort_by(|a, b| b.0.total_cmp(&a.0));
        let mut chosen: Vec<usize> = Vec::new();
        for &(_, s) in &dev {
            if chosen.len() == k {
                break;
            }
            if chosen.iter().all(|&c| c.abs_diff(s) > 2 * w) {
                chosen.push(s);
            }
        }
        for c in chosen {
            windows.push((bi, c, ser.values_kn.as_slice()));
        }
    }
    let m_total = x.eip.len() + 2 * windows.len();
    let p = x.phi.powf(1.0 / m_total as f64);
    let mut alive = vec![true; cms.len()];
    for &(bi, c, y) in &windows {
        let cols: Vec<usize> = (c - w..=c + w).map(|s| bank.sample_index(bi, s)).collect();
        let g = bank.read_columns(&cols).unwrap();
        let feat = |i: usize, maxi: bool| -> f64 {
            let it = g.iter().map(|col| col[i] as f64);
            if maxi {
                it.fold(f64::MIN, f64::max)
            } else {
                it.fold(f64::MAX, f64::min)
            }
        };
        for maxi in [true, false] {
            let ys = y[c - w..=c + w].iter().copied();
            let yv = if maxi {
                ys.fold(f64::MIN, f64::max)
            } else {
                ys.fold(f64::MAX, f64::min)
            };
            let (lo, hi) = id.thresholds(yv, p);
            for (a, &i) in cms.iter().enumerate() {
                if !alive[a] {
                    continue;
                }
                let gi = feat(i, maxi);
                let spread = graph[i * 8..(i + 1) * 8]
                    .iter()
                    .map(|&j| (feat(j as usize, maxi) - gi).abs())
                    .fold(0.0, f64::max);
                let r = gi - yv;
                if r < lo - kappa * spread || r > hi + kappa * spread {
                    alive[a] = false;
                }
            }
        }
    }
    cms.into_iter()
        .zip(alive)
        .filter(|(_, a)| *a)
        .map(|(i, _)| i)
        .collect()
}

/// The ranges of a set of instances: the union of their cells (half-way to each neighbour).
fn ranges_of_members(
    id: &Identifier,
    graph: &[u32],
    members: &[usize],
) -> Option<wheelflat::identify::result::ParamRanges> {
    let bank = id.bank();
    let cal = &bank.metadata().calibration;
    let params = bank.read_parameters().unwrap();
    let coords: Vec<[f64; 4]> = (0..params.length_mm.len())
        .map(|i| {
            [
                params.length_mm[i],
                params.depth_mm[i],
                params.curvature_mm[i],
                params.impact_position_m[i],
            ]
        })
        .collect();
    let cells = wheelflat::identify::cells::Cells::from_graph(graph.to_vec(), coords);
    wheelflat::identify::ranges::ranges_of(
        &params,
        Some(&cells),
        &cal.population,
        cal.vehicle.wheel_radius_m,
        members.iter().copied(),
    )
}
