//! Issue 56, a flat that grows: ten passes of one wheel whose flat grows from L0 20 to 45 mm
//! (Eq. 1 errors, seeded), each identified with `--db`; each pass's range, the history's joint
//! answer and the site page's trend (`serve`'s wheel JSON and figure) are read back.
//! CI-sized: the narrow profile widened to the sizes the wheel goes through, 4,000 instances.

use crate::common::{cached_bank, identify_into_db, serve_settings, wheelflat, CachedBank};
use crate::serve::{get, json};
use axum::http::StatusCode;
use wheelflat::identify::synth::synthesize;
use wheelflat::model::{Calibration, Flat};
use wheelflat::serve::router;

/// The narrow profile over depths 0.1–0.75 mm (L0 18–49 mm), lengths 10–100 mm.
fn bank() -> &'static CachedBank {
    let calibration = || {
        let mut c = Calibration::narrow_profile();
        c.population.length_mm = [10.0, 100.0];
        c.population.depth_mm = [0.1, 0.75];
        c.population.curvature_mm = [0.0, 0.2];
        c.check().unwrap()
    };
    cached_bank("growing-wide", calibration, 4000, 1000)
}

/// The wheel's ten flats: L0 from 20 to 45 mm in equal steps, L 1.15 L0, c 0.3 d, struck a
/// little further on each pass.
fn flats(radius_m: f64) -> Vec<(f64, Flat)> {
    (0..10)
        .map(|k| {
            let l0 = 20.0 + 25.0 * k as f64 / 9.0;
            let d = l0 * l0 / (8.0 * radius_m * 1e3);
            let flat = Flat::from_mm(1.15 * l0, d, 0.3 * d, 12.32 + 0.013 * k as f64).unwrap();
            (l0, flat)
        })
        .collect()
}

fn range(v: &serde_json::Value) -> [f64; 2] {
    [v[0].as_f64().unwrap(), v[1].as_f64().unwrap()]
}

/// Kendall's τ of `xs` against their order: 1 when every later value is larger.
fn kendall_tau(xs: &[f64]) -> f64 {
    let (mut concordant, mut discordant) = (0.0, 0.0);
    for i in 0..xs.len() {
        for j in i + 1..xs.len() {
            if xs[j] > xs[i] {
                concordant += 1.0;
            } else if xs[j] < xs[i] {
                discordant += 1.0;
            }
        }
    }
    (concordant - discordant) / (xs.len() * (xs.len() - 1) / 2) as f64
}

#[test]
fn a_flat_growing_from_20_to_45_mm_over_ten_passes_is_seen_growing() {
    let (bank_dir, cal) = bank();
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("results.sqlite");
    let flats = flats(cal.vehicle.wheel_radius_m);
    for (k, (_, flat)) in flats.iter().enumerate() {
        let csv = synthesize(cal, flat, 600 + k as u64, true).unwrap().csv;
        let f = dir.path().join(format!("p{k}.csv"));
        std::fs::write(&f, format!("# bogie_id = W1\n{csv}")).unwrap();
        identify_into_db(bank_dir, &f, &dir.path().join(format!("o{k}")), &db);
    }
    let wheel = format!("W1/{}", cal.vehicle.flat_wheel.name());
    let out = dir.path().join("h");
    let h = wheelflat()
        .args(["history", "--wheel", &wheel, "--last", "10", "--db"])
        .arg(&db)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(h.status.success(), "{}", String::from_utf8_lossy(&h.stderr));
    let text = String::from_utf8_lossy(&h.stdout).to_string();
    eprintln!("{text}");
    let history: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("history.json")).unwrap()).unwrap();
    let passes = history["passes"].as_array().unwrap();
    assert_eq!(passes.len(), 10, "{text}");

    // Each pass's range holds its own flat (φ = 0.95 a pass; these seeds miss none).
    let ranges: Vec<[f64; 2]> = passes.iter().map(|p| range(&p["l0_mm"])).collect();
    for ((l0, _), r) in flats.iter().zip(&ranges) {
        assert!(
            r[0] <= *l0 && *l0 <= r[1],
            "L0 {l0:.1} outside {r:?}\n{text}"
        );
    }
    // The ranges rise with the flat: their lower ends in order (τ ≥ 0.6, a trend, not noise),
    // and the newest rules out the flat the wheel first had.
    let lows: Vec<f64> = ranges.iter().map(|r| r[0]).collect();
    assert!(kendall_tau(&lows) >= 0.6, "lower ends {lows:?}\n{text}");
    assert!(lows[9] > flats[0].0, "lower ends {lows:?}\n{text}");
    // The first pass allows a flat below the inspect limit; the newest does not.
    assert_eq!(passes[0]["severity"]["lowest"], "monitor", "{text}");
    assert_ne!(passes[9]["severity"]["lowest"], "monitor", "{text}");

    // The history's joint answer holds the newest flat and not the first one.
    let joint = range(&history["joint"]["l0_mm"]);
    assert!(
        joint[0] <= flats[9].0 && flats[9].0 <= joint[1] && joint[0] > flats[0].0,
        "joint {joint:?}\n{text}"
    );

    // The site page's trend shows the same passes and joint answer, and draws them.
    let app = router(serve_settings(&db, bank_dir)).unwrap();
    let w = json(
        &app,
        &format!("/api/wheel?id={}&last=10", wheel.replace('/', "%2F")),
    );
    assert_eq!(w["passes"], history["passes"]);
    assert_eq!(w["joint"]["l0_mm"], history["joint"]["l0_mm"]);
    let (status, _, svg) = get(
        &app,
        &format!("/wheel/trend.svg?id={}&last=10", wheel.replace('/', "%2F")),
        &[],
    );
    assert_eq!(status, StatusCode::OK);
    assert!(svg.starts_with("<svg"), "{}", &svg[..200.min(svg.len())]);
}
