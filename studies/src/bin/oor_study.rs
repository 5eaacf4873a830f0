//! Out-of-round good wheels against the converged reference (docs/detection.md, "Rough
//! wheels"): `cargo run --release -p wheelflat-studies --bin oor_study -- BANK CACHE CASES SEED`.
//!
//! CASES good wheels (no flat), each with one out-of-round harmonic on one wheel: order
//! `1 + k mod 20`, amplitude drawn in 5–50 µm, phase drawn, the wheel alternating; simulated at
//! `Calibration::converged_reference` with the default contact filter (an out-of-round wheel's
//! wavelengths, 126 mm and longer, pass it unchanged) and perturbed per the paper's Eq. 1 (seed
//! `SEED + case`); written to CACHE once and read back. Each pass is answered by
//! `Identifier::identify` with the bank's settings (`WHEELS=round|auto|…` overrides
//! `wheel_roughness`): one line per pass, then how many were sized as a flat, per order band.
use rayon::prelude::*;
use wheelflat::identify::synth::{synthesize_on, FieldNoise, PassSurfaces, Truth};
use wheelflat::identify::{Extras, Identifier, Measurement};
use wheelflat::model::surface::{Harmonic, SurfaceSpec};
use wheelflat::model::{ContactFilter, WheelPosition};
use wheelflat_studies::{coverage, study};

fn main() {
    let (bank, cal, cache, cases, seed, args) = study::cached_args("oor_study", "");
    let model = coverage::converged_model(&cal);
    // (wheel, order, amplitude µm, phase) of case k, from a seeded draw.
    let harmonic = |k: usize| {
        let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ k as u64;
        let mut next = || {
            state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
        };
        let wheel = if k.is_multiple_of(2) {
            WheelPosition::Trailing
        } else {
            WheelPosition::Leading
        };
        let order = 1 + (k % 20) as u32;
        let amplitude_um = 5.0 + 45.0 * next();
        let phase = std::f64::consts::TAU * next();
        (wheel, order, amplitude_um, phase)
    };
    (0..cases).into_par_iter().for_each(|k| {
        let csv = cache.join(format!("case-{k}.csv"));
        if csv.exists() {
            return;
        }
        let (wheel, order, amplitude_um, phase) = harmonic(k);
        let spec = SurfaceSpec {
            out_of_round: vec![(
                wheel,
                Harmonic {
                    order,
                    amplitude_m: amplitude_um * 1e-6,
                    phase_rad: phase,
                },
            )],
            filter: ContactFilter::DEFAULT,
            ..SurfaceSpec::default()
        };
        let surf = PassSurfaces::of(&spec, &cal).expect("surfaces");
        let syn = synthesize_on(
            &model,
            None,
            Some(&surf),
            seed.wrapping_add(k as u64),
            true,
            FieldNoise::TABLE,
        )
        .expect("simulated");
        study::write_case(&cache, k, &syn);
    });
    let settings = study::wheels_from_env(cal.identification.clone());
    let id = Identifier::new(bank, settings).expect("identifier");
    let results: Vec<_> = (0..cases)
        .into_par_iter()
        .map(|k| {
            let csv = cache.join(format!("case-{k}.csv"));
            let text = std::fs::read_to_string(&csv).unwrap();
            let _t: Truth = serde_json::from_str(
                &std::fs::read_to_string(cache.join(format!("case-{k}.truth.json"))).unwrap(),
            )
            .unwrap();
            let m = Measurement::from_csv(&csv, &text, cal.output.sample_rate_hz).expect("csv");
            let out = id.identify(&m, None, Extras::NONE).expect("identified");
            (k, out)
        })
        .collect();
    // Per order band (1–5, 6–10, 11–15, 16–20): passes, flagged as a flat, named out of
    // round, named with the right wheel and order.
    let mut bands = [[0usize; 4]; 4];
    for (k, out) in &results {
        let (wheel, order, amplitude_um, _) = harmonic(*k);
        let d = out.detection.as_ref();
        let detected = d.is_some_and(|d| d.flat_detected);
        let sized = detected && out.sizing.as_ref().is_some_and(|z| !z.cms.is_empty());
        let b = ((order - 1) / 5) as usize;
        let named = d.and_then(|d| d.out_of_round.as_ref());
        let right = named.is_some_and(|f| f.wheel == wheel && f.order == order);
        bands[b][0] += 1;
        bands[b][1] += usize::from(detected);
        bands[b][2] += usize::from(named.is_some());
        bands[b][3] += usize::from(right);
        println!(
            "{k:>4} {:8} order {order:>2} {amplitude_um:5.1} µm  h {:5.2}  {}{}{}",
            wheel.name(),
            out.roughness.as_ref().map_or(f64::NAN, |r| r.hf_kn),
            if detected { "FLAT DETECTED" } else { "no flat" },
            named.map_or(String::new(), |f| format!(
                "; named: {} order {} {:.1} µm, explains {:.2}{}",
                f.wheel.name(),
                f.order,
                f.amplitude_um,
                f.explained_share,
                if right { "" } else { " (WRONG)" }
            )),
            if sized {
                format!(
                    ", sized: CMS {} L0 {:?}",
                    out.sizing.as_ref().map_or(0, |z| z.cms.len()),
                    out.cms_ranges().map(|r| r.l0_mm)
                )
            } else {
                String::new()
            }
        );
    }
    println!(
        "{cases} out-of-round good wheels (orders 1–20, 5–50 µm), bank {}",
        args[1]
    );
    for (b, [n, flagged, named, right]) in bands.iter().enumerate() {
        println!(
            "orders {:>2}–{:<2}: {flagged} of {n} flagged as a flat; named out of round {named}, the right wheel and order {right}",
            5 * b + 1,
            5 * b + 5
        );
    }
    let total = |j: usize| bands.iter().map(|b| b[j]).sum::<usize>();
    println!(
        "all: {} of {cases} flagged as a flat; named out of round {}, the right wheel and order {}",
        total(1),
        total(2),
        total(3)
    );
}
