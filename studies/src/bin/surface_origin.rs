//! Wheel or rail (docs/diagnosis.md, "Wheel or rail"): `cargo run --release -p
//! wheelflat-studies --bin surface_origin -- BANK CACHE CASES SEED`.
//!
//! CASES good wheels (no flat) at `Calibration::converged_reference`, perturbed per the paper's
//! Eq. 1 (seed `SEED + case`), case `k` of kind `k mod 6`: round wheels on a smooth rail; a rail
//! at the EN ISO 3095 limit; a rail dip (cosine, 0.05–0.3 mm deep, 0.2–0.6 m long, centred
//! within ±0.35 m of sensor RPS3 at 11.9 m); both treads cast-iron (9.1 µm rms); both treads at
//! the rough end (22 µm); one wheel out of round (orders 6–15, 20–50 µm). Each pass is
//! identified as recorded and `diagnose::surface::origin` asked where its departure lives: one
//! line per pass, then a table of kind × finding.
use rayon::prelude::*;
use wheelflat::diagnose::surface::{self, Origin};
use wheelflat::identify::synth::{synthesize_on, FieldNoise, PassSurfaces};
use wheelflat::identify::{Extras, Identifier, Measurement};
use wheelflat::model::surface::{Harmonic, RailSurface, RoughnessClass, SurfaceSpec, Trace};
use wheelflat::model::{ContactFilter, WheelPosition};
use wheelflat_studies::{coverage, study};

const KINDS: [&str; 6] = [
    "round, smooth rail",
    "rail ISO 3095",
    "rail dip",
    "cast-iron treads",
    "rough-end treads",
    "one wheel out of round",
];

fn main() {
    let (bank, cal, cache, cases, seed, _args) = study::cached_args("surface_origin", "");
    let model = coverage::converged_model(&cal);
    (0..cases).into_par_iter().for_each(|k| {
        let csv = cache.join(format!("case-{k}.csv"));
        if csv.exists() {
            return;
        }
        let (spec, _) = spec_of(k, seed);
        let surf = (!spec.is_empty()).then(|| PassSurfaces::of(&spec, &cal).expect("surfaces"));
        let syn = synthesize_on(
            &model,
            None,
            surf.as_ref(),
            seed.wrapping_add(k as u64),
            true,
            FieldNoise::TABLE,
        )
        .expect("simulated");
        study::write_case(&cache, k, &syn);
    });
    let id = Identifier::new(bank, study::wheels_from_env(cal.identification.clone()))
        .expect("identifier");
    let results: Vec<_> = (0..cases)
        .into_par_iter()
        .map(|k| {
            let csv = cache.join(format!("case-{k}.csv"));
            let text = std::fs::read_to_string(&csv).unwrap();
            let m = Measurement::from_csv(&csv, &text, cal.output.sample_rate_hz).expect("csv");
            let out = id
                .identify(&m, None, Extras::AS_RECORDED)
                .expect("identified");
            let origin = surface::origin(&id, &m, &out).expect("origin");
            (
                k,
                out.sizing
                    .as_ref()
                    .is_some_and(|z| z.residual_minimisation.is_some()),
                origin,
            )
        })
        .collect();
    // kind × [noise, rail, both wheels, leading, trailing, sized as a flat]
    let mut table = [[0usize; 6]; 6];
    let mut wrong_wheel = 0;
    for (k, flat, o) in &results {
        let o = o.as_ref().expect("windows hold both wheels");
        let col = match o.origin {
            Origin::Noise => 0,
            Origin::Rail => 1,
            Origin::BothWheels => 2,
            Origin::Wheel(WheelPosition::Leading) => 3,
            Origin::Wheel(WheelPosition::Trailing) => 4,
        };
        table[k % 6][col] += 1;
        table[k % 6][5] += usize::from(*flat);
        if let (Some(w), Origin::Wheel(named)) = (spec_of(*k, seed).1, o.origin) {
            wrong_wheel += usize::from(w != named);
        }
        println!(
            "{k:>4} {:24} {}{}",
            KINDS[k % 6],
            if *flat { "[sized as a flat] " } else { "" },
            o.words()
        );
    }
    println!("kind                     | noise | rail | both wheels | leading | trailing | sized");
    for (i, r) in table.iter().enumerate() {
        println!(
            "{:24} | {:5} | {:4} | {:11} | {:7} | {:8} | {:5}",
            KINDS[i], r[0], r[1], r[2], r[3], r[4], r[5]
        );
    }
    println!("out-of-round cases named on the wrong wheel: {wrong_wheel}");
}

/// Case `k`'s surfaces, and the wheel carrying the out-of-round harmonic.
fn spec_of(k: usize, seed: u64) -> (SurfaceSpec, Option<WheelPosition>) {
    let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ (k as u64) << 8;
    let mut u = || study::splitmix_uniform(&mut state);
    let draw_seed = seed.wrapping_add(1000 + k as u64);
    let mut oor = None;
    let mut spec = SurfaceSpec {
        filter: ContactFilter::DEFAULT,
        ..SurfaceSpec::default()
    };
    match k % 6 {
        1 => spec.rail_roughness = Some((RoughnessClass::RailIso3095, draw_seed)),
        2 => {
            let (depth, length) = (0.05e-3 + 0.25e-3 * u(), 0.2 + 0.4 * u());
            let centre = 11.9 + 0.7 * (u() - 0.5);
            let start = centre - length / 2.0;
            let n = (length / 1e-3).round() as usize + 1;
            let dev: Vec<f64> = (0..n)
                .map(|i| {
                    let s = i as f64 / (n - 1) as f64;
                    -depth / 2.0 * (1.0 - (std::f64::consts::TAU * s).cos())
                })
                .collect();
            spec.rail_trace = Some((
                RailSurface {
                    start_x_m: start,
                    trace: Trace::new("rail dip", 1e-3, dev).expect("a dip trace"),
                },
                format!(
                    "dip {:.2} mm over {length:.2} m at {centre:.2} m",
                    depth * 1e3
                ),
            ));
        }
        3 => spec.wheel_roughness = Some((RoughnessClass::CastIron, draw_seed)),
        4 => spec.wheel_roughness = Some((RoughnessClass::CastIronRough, draw_seed)),
        5 => {
            let wheel = if u() < 0.5 {
                WheelPosition::Leading
            } else {
                WheelPosition::Trailing
            };
            let order = 6 + (u() * 10.0) as u32;
            oor = Some(wheel);
            spec.out_of_round = vec![(
                wheel,
                Harmonic {
                    order,
                    amplitude_m: (20.0 + 30.0 * u()) * 1e-6,
                    phase_rad: std::f64::consts::TAU * u(),
                },
            )];
        }
        _ => {}
    }
    (spec, oor)
}
