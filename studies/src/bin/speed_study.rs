//! Issue 14's spacing measurement: how far may a pass's speed be from its bank's before the
//! truth stops being covered? Seeded `synth` cases simulated at the bank's speed × (1 + δ),
//! identified against the bank; coverage, median L0 width and severity per δ:
//! `cargo run --release -p wheelflat-studies --bin speed_study -- BANK CASES SEED δ% [δ% …]`
//! `RESCALE=1`: the pass's time axis scaled to the bank's speed first
//! (`Measurement::at_speed`); without it the pass is read as if it ran at the bank's speed.
use std::path::Path;
use wheelflat::bank::Bank;
use wheelflat::identify::{Extras, Identifier};
use wheelflat_studies::coverage::{self, judge, method_line, severity_class};

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let dir = Path::new(&a[1]);
    let cases: usize = a[2].parse().unwrap();
    let seed: u64 = a[3].parse().unwrap();
    let offsets: Vec<f64> = a[4..].iter().map(|s| s.parse().unwrap()).collect();
    let rescale = std::env::var("RESCALE").is_ok_and(|v| v == "1");
    let bank = Bank::open(dir).expect("bank");
    let cal = bank.metadata().calibration.clone().check().unwrap();
    let id = Identifier::new(bank, cal.identification.clone()).unwrap();
    let (insp, urg, top) = coverage::severity_limits(&cal);
    let truths = coverage::truths(&cal, cases, seed);
    println!("rescale {rescale}");
    for delta in offsets {
        let mut doc = cal.document().clone();
        doc.run.speed_km_per_h *= 1.0 + delta / 100.0;
        let meas_cal = doc.check().unwrap();
        let (mut truth, mut judged, mut failed) = (Vec::new(), Vec::new(), 0);
        for (case, flat) in truths.iter().enumerate() {
            let (mut m, t) = coverage::case(&meas_cal, flat, seed, case).unwrap();
            if rescale {
                m = m.at_speed(meas_cal.run.speed_km_per_h, cal.run.speed_km_per_h);
            } else {
                m.speed_km_per_h = None;
            }
            let cls = severity_class(t.l0_mm, insp, urg);
            match id.identify(&m, None, Extras::NONE) {
                Ok(x) => {
                    truth.push((t.l0_mm, cls));
                    judged.push(judge(x.cms_ranges(), &t, false, insp, urg));
                }
                Err(e) => {
                    failed += 1;
                    eprintln!("δ {delta} % case {case}: {e}");
                }
            }
        }
        println!(
            "{}",
            method_line(
                &format!("δ {delta:+.1} % ({failed} refused)"),
                &truth,
                &judged,
                top
            )
        );
    }
}
