//! Coverage, width and severity of the aligned falsification against the bank-only method:
//! `cargo run --release -p wheelflat-studies --bin aligned_coverage -- BANK CASES SEED [finer] [reach_mm] [kappa] [eps] [eip|all]`
use std::path::Path;
use wheelflat::bank::Bank;
use wheelflat::identify::Identifier;
use wheelflat_studies::aligned::{self, AlignedPoints, AlignedSettings};
use wheelflat_studies::coverage;
use wheelflat_studies::coverage::{judge, method_line, severity_class, Judged};

/// (true L0, true class, bank-only, aligned, stage time in ms) of one case.
type Row = (f64, usize, Judged, Judged, f64);

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let bank = Bank::open(Path::new(&a[1])).expect("bank");
    let cases: usize = a[2].parse().unwrap();
    let seed: u64 = a[3].parse().unwrap();
    let finer = a.get(4).is_some_and(|s| s == "finer");
    let mut st = AlignedSettings::default();
    if let Some(v) = a.get(5) {
        st.reach_m = v.parse::<f64>().unwrap() * 1e-3;
    }
    if let Some(v) = a.get(6) {
        st.kappa = v.parse().unwrap();
    }
    if let Some(v) = a.get(7) {
        st.shift_error_per_mm = v.parse().unwrap();
    }
    let which = if a.get(8).is_some_and(|s| s == "all") {
        AlignedPoints::AllPips
    } else {
        AlignedPoints::Eip
    };
    let cal = bank.metadata().calibration.clone().check().unwrap();
    let meas_cal = coverage::measurement_model(&cal, finer);
    let id = Identifier::new(bank, cal.identification.clone()).unwrap();
    let t0 = std::time::Instant::now();
    let cells = aligned::aligned_cells(&id, st.reach_m);
    eprintln!(
        "aligned cells in {:.0} ms, max shift {}, max offset {}",
        t0.elapsed().as_secs_f64() * 1e3,
        cells.max_shift,
        cells.max_offset()
    );
    let (insp, urg, top) = coverage::severity_limits(&cal);
    let mut rows: Vec<Row> = Vec::new();
    for (case, flat) in coverage::truths(&cal, cases, seed).iter().enumerate() {
        let (m, t) = coverage::case(&meas_cal, flat, seed, case).unwrap();
        let out = aligned::identify_aligned(&id, &m, None, &cells, &st, which).unwrap();
        let truth_class = severity_class(t.l0_mm, insp, urg);
        let judge = |r, all| judge(r, &t, all, insp, urg);
        let b = judge(out.base.cms_ranges(), false);
        let n = judge(out.ranges.as_ref(), true);
        println!(
            "{case:>3} L {:6.1} d {:.3} c {:.3} X {:.3} L0 {:5.1} | base {:>5} {} [{:5.1},{:5.1}] | aligned {:>5} {} [{:5.1},{:5.1}] cls {}/{} | {} pts {} cols read {:.1} ms fals {:.1} ms",
            t.length_mm, t.depth_mm, t.curvature_mm, t.impact_position_m, t.l0_mm,
            out.base.sizing.as_ref().map_or(0, |z| z.cms.len()), b.holds as u8, b.l0_mm[0], b.l0_mm[1],
            out.survivors.len(), n.holds as u8, n.l0_mm[0], n.l0_mm[1], n.class_index(), truth_class,
            out.points, out.columns, out.read_ms, out.falsify_ms
        );
        rows.push((t.l0_mm, truth_class, b, n, out.read_ms + out.falsify_ms));
    }
    let truth: Vec<(f64, usize)> = rows.iter().map(|r| (r.0, r.1)).collect();
    let base: Vec<Judged> = rows.iter().map(|r| r.2).collect();
    let aligned: Vec<Judged> = rows.iter().map(|r| r.3).collect();
    println!(
        "{}",
        method_line("bank-only (kappa cells)", &truth, &base, top)
    );
    println!("{}", method_line("aligned", &truth, &aligned, top));
    let mut t: Vec<f64> = rows.iter().map(|r| r.4).collect();
    t.sort_by(f64::total_cmp);
    println!(
        "aligned stage (read + falsify) median {:.1} ms",
        t[t.len() / 2]
    );
}
