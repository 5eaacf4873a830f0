//! How well does a time shift of the flat-induced response stand in for a change of the
//! impact position X_p? For five flats and shifts δ, the largest error over every sample of
//! every sensor against direct simulation, in kN and in threshold half-widths (Šídák over 20
//! points), for four ways of shifting and for no shift at all:
//! `cargo run --release -p wheelflat-studies --bin shift_error`
//!
//! - `frac-lin`, `frac-cubic`: the response delayed by δ/v, interpolated between samples
//!   (linear, Catmull–Rom), against direct simulation at X_p + δ;
//! - `whole`: delayed by n = round(δ/Δs) whole samples (Δs = v/f_s), against X_p + n·Δs;
//! - `whole-ratio`: the same, scaled by the flat-free force's ratio T(t)/T(t − n/f_s) where
//!   that is above 1 kN (the influence line does not move with the impact).
use wheelflat::identify::CombinedUncertainty;
use wheelflat::model::{Calibration, Flat, Record, Simulator};

fn at(r: &[f64], k: isize) -> f64 {
    r[k.clamp(0, r.len() as isize - 1) as usize]
}

fn lin(r: &[f64], x: f64) -> f64 {
    let (i, f) = (x.floor() as isize, x - x.floor());
    at(r, i) * (1.0 - f) + at(r, i + 1) * f
}

fn cubic(r: &[f64], x: f64) -> f64 {
    let (i, t) = (x.floor() as isize, x - x.floor());
    let (p0, p1, p2, p3) = (at(r, i - 1), at(r, i), at(r, i + 1), at(r, i + 2));
    0.5 * (2.0 * p1
        + (-p0 + p2) * t
        + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * t * t
        + (-p0 + 3.0 * p1 - 3.0 * p2 + p3) * t * t * t)
}

fn main() {
    let cal = Calibration::default().check().expect("defaults are valid");
    let sim = Simulator::new(&cal).expect("simulator");
    let unc = CombinedUncertainty::new(&cal.identification);
    let p = 0.95f64.powf(1.0 / 20.0);
    let (v, rate) = (cal.speed_m_per_s(), cal.output.sample_rate_hz);
    let run = |f: Option<Flat>| sim.run(f.as_ref(), Record::default()).expect("run");
    let kn = |x: &[f64]| x.iter().map(|v| v / 1e3).collect::<Vec<f64>>();
    let free = run(None);
    let flats = [
        (150.0, 0.3, 0.05),
        (60.0, 0.5, 0.1),
        (100.0, 0.8, 0.2),
        (40.0, 0.3, 0.05),
        (30.0, 0.9, 0.1),
    ];
    let x0 = 12.4;
    println!("flat (mm)          delta_mm | worst error kN / half-widths: frac-lin | frac-cubic | whole | whole-ratio | unshifted");
    for (l, d, c) in flats {
        let flat = |x: f64| Some(Flat::from_mm(l, d, c, x).expect("valid flat"));
        let base = run(flat(x0));
        for delta_mm in [0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 35.0, 67.0, 133.0, 250.0] {
            let delta = delta_mm * 1e-3;
            let tau = delta / v * rate;
            let n = tau.round().max(1.0);
            let direct = run(flat(x0 + delta));
            let direct_whole = run(flat(x0 + n / rate * v));
            let mut worst = [[0.0f64; 2]; 5];
            for s in 0..base.pad_force_n.len() {
                let t = kn(&free.pad_force_n[s]);
                let g = kn(&base.pad_force_n[s]);
                let r: Vec<f64> = g.iter().zip(&t).map(|(g, t)| g - t).collect();
                let (truth, truth_whole) =
                    (kn(&direct.pad_force_n[s]), kn(&direct_whole.pad_force_n[s]));
                for j in 0..t.len() {
                    let k = j as isize - n as isize;
                    let ratio = if at(&t, k).abs() > 1.0 {
                        (t[j] / at(&t, k)).clamp(0.0, 3.0)
                    } else {
                        1.0
                    };
                    let x = j as f64 - tau;
                    let cands = [
                        (t[j] + lin(&r, x), truth[j]),
                        (t[j] + cubic(&r, x), truth[j]),
                        (t[j] + at(&r, k), truth_whole[j]),
                        (t[j] + at(&r, k) * ratio, truth_whole[j]),
                        (g[j], truth[j]),
                    ];
                    for (m, (pred, tr)) in cands.iter().enumerate() {
                        let (lo, hi) = unc.thresholds(*tr, p);
                        let e = (pred - tr).abs();
                        worst[m][0] = worst[m][0].max(e);
                        worst[m][1] = worst[m][1].max(e / (0.5 * (hi - lo)));
                    }
                }
            }
            let cell = |w: [f64; 2]| format!("{:6.2} / {:5.2}", w[0], w[1]);
            println!(
                "L {l:>3} d {d:.1} c {c:.2} {delta_mm:>6} | {} | {} | {} (n = {n}) | {} | {}",
                cell(worst[0]),
                cell(worst[1]),
                cell(worst[2]),
                cell(worst[3]),
                cell(worst[4])
            );
        }
    }
}
