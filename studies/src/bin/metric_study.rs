//! Issue 11's acceptance figures for identification on a bank: seeded `synth` cases (or cases
//! simulated with the finer model), coverage, median L0 width, upper bound below the
//! population's top, severity, time:
//! `cargo run --release -p wheelflat-studies --bin metric_study -- BANK CASES SEED same|finer`
//! Variants by environment: `GRAPH=plain` (cells searched in the plain unit cube, the method
//! before 2026-11-24) or `GRAPH=W_L,W_d,W_c,W_X` (axis weights); `ENV_K`, `ENV_W` (envelope
//! windows per sensor and half-width; `ENV_K=0`: the EIP alone); `KAPPA`.
use std::path::Path;
use wheelflat::bank::neighbours::{cell_weights, neighbour_graph_weighted};
use wheelflat::bank::Bank;
use wheelflat::identify::{Extras, Identifier};
use wheelflat_studies::coverage::{self, judge, method_line, severity_class, Judged};

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let dir = Path::new(&a[1]);
    let cases: usize = a[2].parse().unwrap();
    let seed: u64 = a[3].parse().unwrap();
    let finer = a.get(4).is_some_and(|s| s == "finer");
    let bank = Bank::open(dir).expect("bank");
    let cal = bank.metadata().calibration.clone().check().unwrap();
    let mut settings = cal.identification.clone();
    let env = |k: &str| std::env::var(k).ok();
    if let Some(v) = env("KAPPA") {
        settings.bank_resolution = v.parse().unwrap();
    }
    if let Some(v) = env("ENV_K") {
        settings.envelope_windows_per_sensor = v.parse().unwrap();
    }
    if let Some(v) = env("ENV_W") {
        settings.envelope_half_width_samples = v.parse().unwrap();
    }
    let weights = match env("GRAPH").as_deref() {
        Some("plain") => [1.0; 4],
        Some(list) => {
            let w: Vec<f64> = list.split(',').map(|x| x.parse().unwrap()).collect();
            [w[0], w[1], w[2], w[3]]
        }
        None => cell_weights(&cal.population),
    };
    let params = bank.read_parameters().unwrap();
    let graph = neighbour_graph_weighted(&params, &cal.population, weights);
    let id = Identifier::with_neighbours(bank, settings.clone(), Some(graph)).unwrap();
    let meas_cal = coverage::measurement_model(&cal, finer);
    let (insp, urg, top) = coverage::severity_limits(&cal);
    println!(
        "weights {weights:?}, κ {}, envelope {} a sensor ± {} samples",
        settings.bank_resolution,
        settings.envelope_windows_per_sensor,
        settings.envelope_half_width_samples
    );
    let mut truth = Vec::new();
    let mut judged: Vec<Judged> = Vec::new();
    let mut ms = Vec::new();
    for (case, flat) in coverage::truths(&cal, cases, seed).iter().enumerate() {
        let (m, t) = coverage::case(&meas_cal, flat, seed, case).unwrap();
        let clock = std::time::Instant::now();
        let x = id.identify(&m, None, Extras::NONE).unwrap();
        ms.push(clock.elapsed().as_secs_f64() * 1e3);
        let cls = severity_class(t.l0_mm, insp, urg);
        let j = judge(x.cms_ranges(), &t, false, insp, urg);
        println!(
            "{case:>3} L {:6.1} d {:.3} c {:.3} X {:.3} L0 {:5.1} class {cls} | CMS {:>5} covered {} L0 [{:5.1},{:5.1}] class {} | {} EIP + {} envelope",
            t.length_mm, t.depth_mm, t.curvature_mm, t.impact_position_m, t.l0_mm,
            x.sizing.as_ref().map_or(0, |z| z.cms.len()), j.holds as u8, j.l0_mm[0], j.l0_mm[1], j.class_index(),
            x.sizing.as_ref().map_or(0, |z| z.eip.len()), x.sizing.as_ref().map_or(0, |z| z.envelope.len())
        );
        truth.push((t.l0_mm, cls));
        judged.push(j);
    }
    println!("{}", method_line("identify", &truth, &judged, top));
    ms.sort_by(f64::total_cmp);
    println!(
        "identify median {:.1} ms (in-process, warm after the first)",
        ms[ms.len() / 2]
    );
}
