//! A physics-varied validation set (issue 56): `cargo run --release -p wheelflat-studies --bin
//! physics_passes -- OUT FLATS GOOD SEED`.
//!
//! FLATS flats drawn uniformly over the default (site) population, on either wheel, and GOOD
//! good wheels, each simulated at the converged reference with its model errors as physics,
//! not Eq. 1 gains: the vehicle, contact and track drawn per pass ([`study::physics`]: the
//! paper's Table 3 and beyond), the car body ×[0.6, 1.4] (a load family's band), and in every
//! sixth pass (case 0, 6, 12, …) and the cases of ROUGH (`FROM:TO,…`; by default `0:23,150:162`,
//! the passes an earlier revision made rough before every sixth was chosen, so that the
//! documented cache is made again) both treads rough (a class drawn among disc, composite and
//! cast-iron, seeded per pass) — a rough pass costs about ten times a round one at the
//! converged reference. The measurement
//! then carries the table's measurement sources only — sensor accuracy ±5 % and the
//! additional ±2 % as one gain per sensor, ±1 kN noise per sample, the 0.05 kN resolution —
//! and no model source (no train-system, FE, mesh or track-calibration gain drawn). Written to
//! OUT as `case-K.csv`, `case-K.truth.json` and `case-K.physics.json` (what was drawn).
use rayon::prelude::*;
use std::path::PathBuf;
use wheelflat::identify::synth::{synthesize_on, FieldNoise, PassSurfaces};
use wheelflat::model::surface::SurfaceSpec;
use wheelflat::model::{Calibration, WheelPosition};
use wheelflat_studies::study;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 5 {
        panic!("usage: physics_passes OUT FLATS GOOD SEED");
    }
    let out = PathBuf::from(&args[1]);
    let flats: usize = args[2].parse().expect("FLATS");
    let good: usize = args[3].parse().expect("GOOD");
    let seed: u64 = args[4].parse().expect("SEED");
    std::fs::create_dir_all(&out).expect("OUT is writable");
    let base = Calibration::default();
    let drawn = study::uniform_flats(&base.population, flats, seed);
    let spans: Vec<(usize, usize)> = std::env::var("ROUGH")
        .unwrap_or_else(|_| "0:23,150:162".into())
        .split(',')
        .filter(|s| !s.is_empty())
        .map(|s| {
            let (a, b) = s.split_once(':').expect("ROUGH is FROM:TO,…");
            (a.parse().expect("FROM"), b.parse().expect("TO"))
        })
        .collect();
    let clock = std::time::Instant::now();
    (0..flats + good).into_par_iter().for_each(|k| {
        // Complete once its physics.json is written (last): a case cut short is made again.
        if out.join(format!("case-{k}.physics.json")).exists() {
            return;
        }
        let mut state = seed.wrapping_mul(7919).wrapping_add(k as u64);
        // The measurement's own sources only: no model source drawn.
        let (cal, body, class) = study::physics_draw(&base, &mut state);
        let rough = k % 6 == 0 || spans.iter().any(|&(a, b)| (a..b).contains(&k));
        let spec = SurfaceSpec {
            wheel_roughness: rough.then_some((class, seed.wrapping_add(k as u64))),
            ..SurfaceSpec::default()
        };
        let cal = cal.converged_reference().check().expect("physics in range");
        let surfaces = PassSurfaces::of(&spec, &cal).expect("surfaces");
        let flat = (k < flats).then(|| {
            let wheel = if study::splitmix_uniform(&mut state) < 0.5 {
                WheelPosition::Leading
            } else {
                WheelPosition::Trailing
            };
            drawn[k].on_wheel(wheel)
        });
        let syn = synthesize_on(
            &cal,
            flat.as_ref(),
            Some(&surfaces),
            seed.wrapping_add(k as u64),
            true,
            FieldNoise::TABLE,
        )
        .expect("simulated");
        study::write_case(&out, k, &syn);
        let v = &cal.vehicle;
        let physics = serde_json::json!({
            "car_body_factor": body,
            "wheel_mass_kg": v.wheel_mass_kg,
            "bogie_mass_kg": v.bogie_mass_kg,
            "bogie_pitch_inertia_kg_m2": v.bogie_pitch_inertia_kg_m2,
            "primary_stiffness_n_per_m": v.primary_stiffness_n_per_m,
            "primary_damping_ns_per_m": v.primary_damping_ns_per_m,
            "hertz_constant_n_per_m1_5": cal.hertz_constant(),
            "pad_damping_ns_per_m": cal.track.pad_damping_ns_per_m,
            "sleeper_mass_kg": cal.track.sleeper_mass_kg,
            "tread_roughness": if rough { format!("{class:?}") } else { "round".into() },
        });
        std::fs::write(
            out.join(format!("case-{k}.physics.json")),
            serde_json::to_string_pretty(&physics).expect("json"),
        )
        .expect("OUT is writable");
    });
    println!(
        "{} passes ({flats} flats, {good} good wheels) in {:.1} s",
        flats + good,
        clock.elapsed().as_secs_f64()
    );
}
