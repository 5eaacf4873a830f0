//! Flats of measured-like shape against Eq. 9's family (docs/detection.md, "Flats of measured
//! shape"): `cargo run --release -p wheelflat-studies --bin shape_study -- BANK CACHE CASES SEED`.
//!
//! Each case starts from a flat of the bank's whole population (L, d, c, X_p, wheel) and makes
//! it measured-like, as a trace of the flat wheel's radius over one revolution (0.5 mm
//! spacing), drawn per case:
//!
//! - **asymmetric**: the deepest point at a share `a` of the length drawn in 0.3–0.7 (Eq. 9:
//!   0.5), each side stretched to it;
//! - **worn edges**: the profile through a moving average 2–12 mm wide (rounded edges);
//! - **rough bottom**: a cast-iron tread's roughness (CNOSSOS-EU `c`) on the whole tread, and
//!   inside the flat a second draw raised by a factor drawn in 1–3.
//!
//! `TREAD=none` leaves the roughness out (the shape alone).
//!
//! The pass is simulated from the trace (no Eq. 9 flat; the raw trace, as the independent
//! implementation's rough-flat passes; `FILTER=default` for the contact patch and rolling
//! circle) at `Calibration::converged_reference`, errors per Eq. 1, and identified with the
//! bank's settings. The truth is the independent passes' measure: `d` the deepest point below
//! the tread's median, `L0 = √(8·d·R_w)`; "held" means that L0 inside the answer's L0 range.
//! Each case is also run as its Eq. 9 original (the same errors) for comparison.
use rayon::prelude::*;
use wheelflat::identify::synth::{synthesize_on, FieldNoise, PassSurfaces};
use wheelflat::identify::{Extras, Identifier, Measurement};
use wheelflat::model::surface::{wheel_roughness, RoughnessClass};
use wheelflat::model::{Flat, Surfaces, Trace, WheelSurface};
use wheelflat_studies::{coverage, study};

/// A uniform draw in [0, 1) from `(seed, k, j)` (splitmix64).
fn draw(seed: u64, k: u64, j: u64) -> f64 {
    let mut z = seed
        .wrapping_mul(0x9E37_79B9_7F4A_7C15)
        .wrapping_add(k.wrapping_mul(0xBF58_476D_1CE4_E5B9))
        .wrapping_add(j.wrapping_mul(0x94D0_49BB_1331_11EB));
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
}

/// The measured-like trace of case `k` (deviation in m, 0.5 mm spacing, one revolution) and
/// its depth (m): the deepest point below the median.
fn shaped(flat: &Flat, radius: f64, seed: u64, k: u64) -> (Trace, f64, String) {
    let dx = 5e-4;
    let c = std::f64::consts::TAU * radius;
    let n = (c / dx).round() as usize;
    let l = flat.length_m();
    let a = 0.3 + 0.4 * draw(seed, k, 1);
    let wear_mm = 2.0 + 10.0 * draw(seed, k, 2);
    let bottom = 1.0 + 2.0 * draw(seed, k, 3);
    // Asymmetric Eq. 9: s in [0, a·L] maps to [0, L/2], [a·L, L] to [L/2, L].
    let mut e: Vec<f64> = (0..n)
        .map(|i| {
            let s = i as f64 * dx;
            if s > l {
                return 0.0;
            }
            let u = if s <= a * l {
                0.5 * l * s / (a * l)
            } else {
                0.5 * l + 0.5 * l * (s - a * l) / ((1.0 - a) * l)
            };
            -flat.profile(u)
        })
        .collect();
    // Worn edges: a centred moving average, periodic.
    let half = ((wear_mm * 1e-3 / dx) / 2.0).round() as isize;
    let src = e.clone();
    for (i, v) in e.iter_mut().enumerate() {
        let mut sum = 0.0;
        for j in -half..=half {
            sum += src[(i as isize + j).rem_euclid(n as isize) as usize];
        }
        *v = sum / (2 * half + 1) as f64;
    }
    // Rough tread, and a rougher bottom inside the flat.
    let tread = wheel_roughness(RoughnessClass::CastIron, radius, seed * 1000 + k).expect("tread");
    let extra = wheel_roughness(RoughnessClass::CastIron, radius, seed * 1000 + k + 500_000)
        .expect("bottom");
    let at = |t: &Trace, s: f64| {
        let d = t.deviation_m();
        let p = (s / t.spacing_m()).round() as usize % d.len();
        d[p]
    };
    let rough = std::env::var("TREAD").map_or(true, |t| t != "none");
    for (i, v) in e.iter_mut().enumerate().filter(|_| rough) {
        let s = i as f64 * dx;
        *v += at(&tread, s);
        if s <= l {
            *v += (bottom - 1.0) * at(&extra, s);
        }
    }
    let mut sorted = e.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[n / 2];
    let depth = median - sorted[0];
    let words = format!("a {a:.2}, wear {wear_mm:.1} mm, bottom ×{bottom:.1}");
    (
        Trace::new("shaped flat", dx, e).expect("trace"),
        depth,
        words,
    )
}

fn main() {
    let (bank, cal, cache, cases, seed, _) = study::cached_args("shape_study", "");
    let filter = study::filter_from_env();
    let model = coverage::converged_model(&cal);
    let radius = cal.vehicle.wheel_radius_m;
    let flats = coverage::truths_within(&cal, cases, seed, 0.0);
    // Case k: its shaped pass (`shaped-k.csv`) and its Eq. 9 original (`eq9-k.csv`).
    let meta: Vec<(f64, String)> = (0..cases)
        .into_par_iter()
        .map(|k| {
            let flat = &flats[k];
            let (trace, depth, words) = shaped(flat, radius, seed, k as u64);
            for (name, shaped_pass) in [("shaped", true), ("eq9", false)] {
                let csv = cache.join(format!("{name}-{k}.csv"));
                if csv.exists() {
                    continue;
                }
                let surf = PassSurfaces {
                    surfaces: Surfaces {
                        wheels: vec![WheelSurface {
                            wheel: flat.wheel().unwrap_or(cal.vehicle.flat_wheel),
                            trace: trace.clone(),
                            touch_x_m: flat.impact_position_m(),
                        }],
                        rail: None,
                    },
                    filter,
                    notes: Vec::new(),
                };
                let syn = match shaped_pass {
                    true => synthesize_on(
                        &model,
                        None,
                        Some(&surf),
                        seed + k as u64,
                        true,
                        FieldNoise::TABLE,
                    ),
                    false => synthesize_on(
                        &model,
                        Some(flat),
                        None,
                        seed + k as u64,
                        true,
                        FieldNoise::TABLE,
                    ),
                }
                .expect("simulated");
                std::fs::write(&csv, &syn.csv).unwrap();
            }
            (depth, words)
        })
        .collect();
    let id = Identifier::new(bank, cal.identification.clone()).expect("identifier");
    let mut rows = Vec::new();
    for (k, flat) in flats.iter().enumerate() {
        let (depth, words) = &meta[k];
        let l0_shaped = (8.0 * depth * radius).sqrt() * 1e3;
        let l0_eq9 = flat.fresh_length_m(radius) * 1e3;
        let mut line = format!(
            "{k:>4} {:8} L {:6.1} d {:.3} c {:.3} ({words}) L0 shaped {l0_shaped:5.1} eq9 {l0_eq9:5.1}",
            flat.wheel().unwrap_or(cal.vehicle.flat_wheel).name(),
            flat.length_m() * 1e3,
            flat.depth_m() * 1e3,
            flat.curvature_m() * 1e3
        );
        let mut row = [0.0f64; 6];
        for (j, (name, truth)) in [("shaped", l0_shaped), ("eq9", l0_eq9)].iter().enumerate() {
            let csv = cache.join(format!("{name}-{k}.csv"));
            let text = std::fs::read_to_string(&csv).unwrap();
            let m = Measurement::from_csv(&csv, &text, cal.output.sample_rate_hz).expect("csv");
            let out = id.identify(&m, None, Extras::NONE).expect("identified");
            let detected = out.detection.as_ref().is_some_and(|d| d.flat_detected);
            let r = out.cms_ranges();
            let (held, width) = match (detected, r) {
                (true, Some(r)) => (
                    r.l0_mm[0] - 0.5 <= *truth && *truth <= r.l0_mm[1] + 0.5,
                    r.l0_mm[1] - r.l0_mm[0],
                ),
                _ => (false, f64::NAN),
            };
            let refuted = detected && r.is_none();
            row[3 * j] = f64::from(u8::from(held));
            row[3 * j + 1] = width;
            row[3 * j + 2] = f64::from(u8::from(refuted));
            line += &format!(
                " | {name}: {} {}",
                if !detected {
                    "no flat".to_string()
                } else {
                    r.map_or("refuted".into(), |r| {
                        format!("[{:.0}, {:.0}]", r.l0_mm[0], r.l0_mm[1])
                    })
                },
                if held { "held" } else { "MISSED" }
            );
        }
        println!("{line}");
        rows.push(row);
    }
    let median = |j: usize| {
        let mut w: Vec<f64> = rows
            .iter()
            .map(|r| r[j])
            .filter(|w| w.is_finite())
            .collect();
        w.sort_by(f64::total_cmp);
        w.get(w.len() / 2).copied().unwrap_or(f64::NAN)
    };
    let sum = |j: usize| rows.iter().map(|r| r[j]).sum::<f64>() as usize;
    println!(
        "{cases} flats, filter {}: measured-like shape held {} (refuted {}), median L0 width {:.1} mm; Eq. 9 originals held {} (refuted {}), {:.1} mm",
        if filter.patch { "patch + rolling circle" } else { "none" },
        sum(0),
        sum(2),
        median(1),
        sum(3),
        sum(5),
        median(4)
    );
}
