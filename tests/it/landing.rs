//! Landings against the converged reference (docs/identification.md, "Landings"): the samples
//! around a flat's landing impact on `Calibration::with_converged_landings` (40 rail elements
//! a bay ±3 bays around the sensors, 4 µs fine steps) against the converged reference (40
//! elements everywhere, 20 µs / 2 µs steps).

use wheelflat::bank::schema::sensor_axes;
use wheelflat::model::{Calibration, CheckedCalibration, Flat, Record, Simulator};
use wheelflat_testkit::landing::near_strikes;

/// Per flat: the largest |model − reference| over the reference's peak at the samples from
/// 1 ms before a strike to 5 ms after the flat has passed, and whether the reference lost
/// contact.
fn landing_errors(model: &CheckedCalibration, flats: &[Flat]) -> Vec<(f64, bool)> {
    let base = Calibration::default();
    let cal = base.clone().check().unwrap();
    let axes = sensor_axes(&cal);
    let reference = Simulator::new(&base.converged_reference().check().unwrap()).unwrap();
    let sim = Simulator::new(model).unwrap();
    flats
        .iter()
        .map(|f| {
            let r = reference.run(Some(f), Record::default()).unwrap();
            let g = sim.run(Some(f), Record::default()).unwrap();
            let lost = r.contact_loss_s.iter().any(|&t| t > 0.0);
            let near = near_strikes(&cal, &r, f);
            let (mut peak, mut worst) = (0.0f64, 0.0f64);
            for (s, a) in axes.iter().enumerate() {
                let (rw, gw) = (
                    r.window(s, a.first_sample, a.samples),
                    g.window(s, a.first_sample, a.samples),
                );
                for ((x, y), &n) in rw.iter().zip(gw).zip(&near[s]) {
                    peak = peak.max(x.abs());
                    if n {
                        worst = worst.max((x - y).abs());
                    }
                }
            }
            (worst / peak, lost)
        })
        .collect()
}

/// Flats that lose contact, over the site population's lengths and positions: deep and short
/// for their length (the landing is what the bank's mesh gets a whole step wrong).
fn landing_flats() -> Vec<Flat> {
    [
        (30.0, 0.6, 0.05, 12.3),
        (45.0, 0.9, 0.10, 12.9),
        (60.0, 1.0, 0.20, 13.6),
        (80.0, 1.0, 0.05, 14.2),
        (40.0, 0.8, 0.30, 12.6),
        (25.0, 0.5, 0.02, 13.9),
    ]
    .iter()
    .map(|&(l, d, c, x)| Flat::from_mm(l, d, c, x).unwrap())
    .collect()
}

/// Tolerance: 1 % of the peak pad force at every sample around the landing, on these six
/// flats (all lose contact; 0.19–0.77 % on the landings mesh, 0.72–2.79 % on the bank's,
/// 2026-11-27). Over the 218 landing flats of 600 drawn from the population the landings mesh
/// reaches 4.44 % at the 99th percentile and the bank's 10.06 % (`landing_study 600 7
/// 4:1:100:40:3`, docs/identification.md): these six are not its worst.
#[test]
#[ignore = "acceptance: 12 runs at the converged reference (~30 s on 2 cores)"]
fn a_landing_on_the_landings_mesh_is_within_1_percent_of_the_converged_reference() {
    let flats = landing_flats();
    let landings = Calibration::default()
        .with_converged_landings()
        .check()
        .unwrap();
    let errors = landing_errors(&landings, &flats);
    let bank = landing_errors(&Calibration::default().check().unwrap(), &flats);
    let lost = errors.iter().filter(|e| e.1).count();
    assert!(
        lost >= 4,
        "only {lost} of the flats lose contact: {errors:?}"
    );
    for (i, ((e, lost), (b, _))) in errors.iter().zip(&bank).enumerate() {
        eprintln!(
            "flat {i}: lost contact {lost}, landings {:.2} %, bank mesh {:.2} % of the peak",
            100.0 * e,
            100.0 * b
        );
    }
    for (i, (e, lost)) in errors.iter().enumerate() {
        if *lost {
            assert!(*e <= 0.01, "flat {i}: {:.2} % of the peak", 100.0 * e);
        }
    }
    // The test tells the meshes apart: the bank's lands some of these flats outside it.
    let bank_worst = bank.iter().filter(|b| b.1).map(|b| b.0).fold(0.0, f64::max);
    assert!(
        bank_worst > 0.01,
        "the bank's mesh lands every flat within 1 % too ({:.2} %)",
        100.0 * bank_worst
    );
}
