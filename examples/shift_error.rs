//! How well does a time shift stand in for a change of impact position X_p?
//! `cargo run --release --example shift_error`
use wheelflat::identify::uncertainty::CombinedUncertainty;
use wheelflat::model::{Calibration, Flat, Record, Simulator};

fn lin(r: &[f64], x: f64) -> f64 {
    let i = x.floor();
    let f = x - i;
    let i = i as isize;
    let at = |k: isize| r[k.clamp(0, r.len() as isize - 1) as usize];
    at(i) * (1.0 - f) + at(i + 1) * f
}
fn cubic(r: &[f64], x: f64) -> f64 {
    let i = x.floor();
    let t = x - i;
    let i = i as isize;
    let at = |k: isize| r[k.clamp(0, r.len() as isize - 1) as usize];
    let (p0, p1, p2, p3) = (at(i - 1), at(i), at(i + 1), at(i + 2));
    0.5 * ((2.0 * p1)
        + (-p0 + p2) * t
        + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * t * t
        + (-p0 + 3.0 * p1 - 3.0 * p2 + p3) * t * t * t)
}

fn main() {
    let cal = Calibration::default().check().unwrap();
    let sim = Simulator::new(&cal).unwrap();
    let unc = CombinedUncertainty::new(&cal.identification);
    let p = 0.95f64.powf(1.0 / 20.0);
    let v = cal.speed_m_per_s();
    let rate = cal.output.sample_rate_hz;
    let free = sim.run(None, Record::default()).unwrap();
    let flats = [(150.0, 0.3, 0.05), (60.0, 0.5, 0.1), (100.0, 0.8, 0.2), (40.0, 0.3, 0.05), (30.0, 0.9, 0.1)];
    let x0 = 12.4;
    println!("flat          delta_mm | ratio>20%: kN / hw | ratio>1kN: kN / hw | int-sample: kN / hw | unshifted: kN / hw");
    for (l, d, c) in flats {
        let base = sim.run(Some(&Flat::from_mm(l, d, c, x0).unwrap()), Record::default()).unwrap();
        for n in [1.0f64, 2.0, 6.0, 12.0, 24.0, 45.0, 90.0] {
            let delta = n / rate * v; let delta_mm = delta * 1e3;
            let shifted = sim.run(Some(&Flat::from_mm(l, d, c, x0 + delta).unwrap()), Record::default()).unwrap();
            let tau = delta / v * rate; // samples
            let n_int = tau.round();
            let int_delta = n_int / rate * v;
            let shifted_int = sim.run(Some(&Flat::from_mm(l, d, c, x0 + int_delta).unwrap()), Record::default()).unwrap();
            let mut w = [[0.0f64; 2]; 4];
            for s in 0..base.pad_force_n.len() {
                let t: Vec<f64> = free.pad_force_n[s].iter().map(|x| x / 1e3).collect();
                let r: Vec<f64> = base.pad_force_n[s].iter().zip(&t).map(|(g, t)| g / 1e3 - t).collect();
                for j in 0..t.len() {
                    let truth = shifted.pad_force_n[s][j] / 1e3;
                    let truth_int = shifted_int.pad_force_n[s][j] / 1e3;
                    let (lo, hi) = unc.thresholds(truth, p);
                    let hw = 0.5 * (hi - lo);
                    let _x = j as f64 - tau;
                    let cands = [
                        { let k = (j as isize - n_int as isize).clamp(0, r.len() as isize - 1) as usize;
                          let tm = t.iter().fold(0.0f64, |a, b| a.max(b.abs()));
                          let ratio = if t[k].abs() > 0.2 * tm { (t[j] / t[k]).clamp(0.0, 3.0) } else { 1.0 };
                          (t[j] + r[k] * ratio, truth_int) },
                        { let k = (j as isize - n_int as isize).clamp(0, r.len() as isize - 1) as usize;
                          let ratio = if t[k].abs() > 1.0 { (t[j] / t[k]).clamp(0.0, 3.0) } else { 1.0 };
                          (t[j] + r[k] * ratio, truth_int) },
                        (t[j] + r[(j as isize - n_int as isize).clamp(0, r.len() as isize - 1) as usize], truth_int),
                        (base.pad_force_n[s][j] / 1e3, truth),
                    ];
                    for (m, (g, tr)) in cands.iter().enumerate() {
                        let e = (g - tr).abs();
                        w[m][0] = w[m][0].max(e);
                        w[m][1] = w[m][1].max(e / hw);
                    }
                }
            }
            println!(
                "L{l:>3} d{d:.1} c{c:.2} {delta_mm:>5} | {:6.2} / {:5.2} | {:6.2} / {:5.2} | {:6.2} / {:5.2} | {:6.2} / {:5.2}",
                w[0][0], w[0][1], w[1][0], w[1][1], w[2][0], w[2][1], w[3][0], w[3][1]
            );
        }
    }
}
