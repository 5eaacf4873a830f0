//! Good wheels and flats on rough treads and rails, against the converged reference
//! (docs/detection.md, "Rough wheels"):
//! `cargo run --release -p wheelflat-studies --bin rough_coverage -- BANK CACHE CASES SEED [smooth|norail]`.
//!
//! CASES good wheels and CASES flats of the bank's whole population, each pass with both
//! wheels' treads drawn from a wheel roughness class (disc, composite, cast iron, its rough
//! end, in turn) and the rail at the EN ISO 3095 limit (`norail`: a smooth rail; `smooth`:
//! round wheels on a smooth rail), simulated at `Calibration::converged_reference` with the contact filter `FILTER`
//! (`none`, the default, as the independent implementation; `default`: patch and rolling
//! circle) and perturbed per the paper's Eq. 1 (seed `SEED + case`). The passes are written to
//! CACHE once and read back, so identification settings compare on the same passes. `ROUGH=
//! r1:r0` adds the bounded sources `good_wheel_relative ±r1` and `bound_kn ±r0` to the bank's
//! table. Per class: good wheels quiet, flats held (L, d inside), refuted (empty answer),
//! median L0 width, one class spanned. `CLASS=name` puts every pass in one class;
//! `DEPTH_MM=lo:hi` draws the flats' depths from that range (a class's detection limit).
use rayon::prelude::*;
use wheelflat::identify::synth::{synthesize_on, FieldNoise, PassSurfaces, Truth};
use wheelflat::identify::{Extras, Identifier, Measurement};
use wheelflat::model::calibration::{UncertaintyGroup, UncertaintyKind, UncertaintySource};
use wheelflat::model::surface::{RoughnessClass, SurfaceSpec};
use wheelflat::model::{ContactFilter, Flat};
use wheelflat_studies::{coverage, study};

fn surfaces(
    class: RoughnessClass,
    smooth: bool,
    with_rail: bool,
    cal: &wheelflat::model::CheckedCalibration,
    seed: u64,
    filter: ContactFilter,
) -> Option<PassSurfaces> {
    if smooth {
        return None;
    }
    let spec = SurfaceSpec {
        wheel_roughness: Some((class, seed)),
        rail_roughness: with_rail.then_some((RoughnessClass::RailIso3095, seed * 4 + 3)),
        filter,
        ..SurfaceSpec::default()
    };
    Some(PassSurfaces::of(&spec, cal).expect("surfaces"))
}

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let (bank, cal, cache, cases, seed, args) =
        study::cached_args("rough_coverage", "[smooth|norail]");
    let smooth = args.iter().skip(5).any(|a| a == "smooth");
    let with_rail = !args.iter().skip(5).any(|a| a == "norail");
    let filter = study::filter_from_env();
    let model = coverage::converged_model(&cal);
    // DEPTH_MM=lo:hi draws the flats' depths from that range only (e.g. at a detection limit).
    let mut truth_cal = cal.document().clone();
    if let Ok(d) = std::env::var("DEPTH_MM") {
        let (lo, hi) = d.split_once(':').expect("DEPTH_MM=lo:hi");
        truth_cal.population.depth_mm = [lo.parse().unwrap(), hi.parse().unwrap()];
    }
    let truth_cal = truth_cal
        .check()
        .expect("DEPTH_MM inside the calibration's checks");
    let flats = coverage::truths_within(&truth_cal, cases, seed, 0.0);
    // Case k: good wheels 0..cases, flats cases..2·cases; wheel class k mod 4, or CLASS=name
    // for every case.
    let only: Option<RoughnessClass> = std::env::var("CLASS")
        .ok()
        .map(|c| RoughnessClass::from_name(&c).expect("CLASS names a wheel class"));
    let class_of = |k: usize| only.unwrap_or(RoughnessClass::WHEELS[k % 4]);
    (0..2 * cases).into_par_iter().for_each(|k| {
        let csv = cache.join(format!("case-{k}.csv"));
        if csv.exists() {
            return;
        }
        let flat: Option<&Flat> = (k >= cases).then(|| &flats[k - cases]);
        let surf = surfaces(
            class_of(k),
            smooth,
            with_rail,
            &cal,
            seed * 10_000 + k as u64,
            filter,
        );
        let syn = synthesize_on(
            &model,
            flat,
            surf.as_ref(),
            seed.wrapping_add(k as u64),
            true,
            FieldNoise::TABLE,
        )
        .expect("simulated");
        study::write_case(&cache, k, &syn);
    });
    let mut settings = study::wheels_from_env(cal.identification.clone());
    if let Ok(r) = std::env::var("ROUGH") {
        let (r1, r0) = r.split_once(':').expect("ROUGH=r1:r0");
        let (r1, r0): (f64, f64) = (r1.parse().unwrap(), r0.parse().unwrap());
        settings.uncertainty.push(UncertaintySource {
            group: UncertaintyGroup::Model,
            name: "roughness, near a wheel".into(),
            kind: UncertaintyKind::GoodWheelRelative,
            min: -r1,
            max: r1,
        });
        settings.uncertainty.push(UncertaintySource {
            group: UncertaintyGroup::Model,
            name: "roughness, floor".into(),
            kind: UncertaintyKind::BoundKn,
            min: -r0,
            max: r0,
        });
    }
    if std::env::var("RAIL").is_ok_and(|r| r == "iso3095") {
        settings.rail_roughness = wheelflat::model::calibration::RailRoughness::Iso3095;
    }
    if let Ok(a) = std::env::var("DISC") {
        settings.discretisation_fraction = a.parse().expect("DISC is a number");
    }
    // ORACLE=r1,r0;r1,r0;r1,r0;r1,r0: each wheel class's pass judged with its own bounds.
    let oracle: Option<Vec<Identifier>> = std::env::var("ORACLE").ok().map(|spec| {
        spec.split(';')
            .map(|pair| {
                let (r1, r0) = pair.split_once(',').expect("r1,r0");
                let (r1, r0): (f64, f64) = (r1.parse().unwrap(), r0.parse().unwrap());
                let mut s = settings.clone();
                s.uncertainty.push(UncertaintySource {
                    group: UncertaintyGroup::Model,
                    name: "roughness, near a wheel".into(),
                    kind: UncertaintyKind::GoodWheelRelative,
                    min: -r1,
                    max: r1,
                });
                s.uncertainty.push(UncertaintySource {
                    group: UncertaintyGroup::Model,
                    name: "roughness, floor".into(),
                    kind: UncertaintyKind::BoundKn,
                    min: -r0,
                    max: r0,
                });
                Identifier::new(study::open_bank(&args[1]).0, s).expect("identifier")
            })
            .collect()
    });
    let id = Identifier::new(bank, settings).expect("identifier");
    let (insp, urg, _) = coverage::severity_limits(&cal);
    // Per class: [good, quiet, flats, held, refuted], widths, one class.
    let mut rows: Vec<(RoughnessClass, bool, bool, bool, Option<f64>, bool)> = Vec::new();
    // (class, a flat, detected, held, L0 width, refuted)
    let results: Vec<_> = (0..2 * cases)
        .into_par_iter()
        .map(|k| {
            let csv = cache.join(format!("case-{k}.csv"));
            let text = std::fs::read_to_string(&csv).unwrap();
            let t: Truth = serde_json::from_str(
                &std::fs::read_to_string(cache.join(format!("case-{k}.truth.json"))).unwrap(),
            )
            .unwrap();
            let m = Measurement::from_csv(&csv, &text, cal.output.sample_rate_hz).expect("csv");
            let id = oracle.as_ref().map_or(&id, |o| &o[k % 4]);
            let out = id.identify(&m, None, Extras::NONE).expect("identified");
            (k, t, out)
        })
        .collect();
    for (k, t, out) in results {
        let is_flat = k >= cases;
        let detected = out.detection.as_ref().is_some_and(|d| d.flat_detected);
        let (held, refuted, width) = if !detected || out.below_population() {
            (false, false, None)
        } else {
            match out.cms_ranges() {
                Some(r) => {
                    let j = coverage::judge(Some(r), &t, false, insp, urg);
                    (j.holds, false, Some(r.l0_mm[1] - r.l0_mm[0]))
                }
                None => (false, true, None),
            }
        };
        if std::env::var("VERBOSE").is_ok() {
            let w = out.detection.as_ref().and_then(|d| d.worst());
            println!(
                "{k:>4} {:16} as {:16} h {:5.2} spike {:5.2} {} L0 {:5.1} det {} excess {:6.2} {} held {} refuted {} width {:?} limit {:?}{}",
                class_of(k).name(),
                out.roughness.as_ref().and_then(|r| r.wheel).map_or("round", |c| c.name()),
                out.roughness.as_ref().map_or(f64::NAN, |r| r.hf_kn),
                out.detection
                    .as_ref()
                    .and_then(|d| d.spike.as_ref())
                    .map_or(f64::NAN, |s| s.sensors.iter().map(|x| x.2).fold(0.0, f64::max)),
                if is_flat { "flat" } else { "good" },
                t.l0_mm,
                u8::from(detected),
                w.map_or(f64::NAN, |w| w.excess_kn),
                w.map_or("", |w| w.sensor.as_str()),
                u8::from(held),
                u8::from(refuted),
                width.map(|w| w.round()),
                out.detection
                    .as_ref()
                    .and_then(|d| d.limit.as_ref())
                    .and_then(|l| l.l0_mm)
                    .map(|l| l.round()),
                out.detection
                    .as_ref()
                    .and_then(|d| d.out_of_round.as_ref())
                    .map_or(String::new(), |f| format!(
                        " OOR {} n{} {:.0} µm explains {:.2} before {:.2}",
                        f.wheel.name(),
                        f.order,
                        f.amplitude_um,
                        f.explained_share,
                        f.excess_before_kn
                    ))
            );
        }
        rows.push((class_of(k), is_flat, detected, held, width, refuted));
    }
    println!(
        "{} good wheels and {} flats a class split over 4 classes, {} (contact filter {}), bank {}",
        cases,
        cases,
        match (smooth, with_rail) {
            (true, _) => "smooth wheels and rail",
            (false, true) => "rough treads, rail at the EN ISO 3095 limit",
            (false, false) => "rough treads, smooth rail",
        },
        if filter.patch {
            "patch + rolling circle"
        } else {
            "none"
        },
        args[1]
    );
    println!("class              good quiet   flats detected  held  refuted  median L0 width");
    for class in RoughnessClass::WHEELS
        .into_iter()
        .map(Some)
        .chain(std::iter::once(None))
    {
        let pick: Vec<_> = rows
            .iter()
            .filter(|r| class.is_none_or(|c| r.0 == c))
            .collect();
        let good: Vec<_> = pick.iter().filter(|r| !r.1).collect();
        let fl: Vec<_> = pick.iter().filter(|r| r.1).collect();
        let quiet = good.iter().filter(|r| !r.2).count();
        let det = fl.iter().filter(|r| r.2).count();
        let held = fl.iter().filter(|r| r.3).count();
        let refuted = fl.iter().filter(|r| r.5).count();
        let widths: Vec<f64> = fl.iter().filter_map(|r| r.4).collect();
        println!(
            "{:16} {:>4}/{:<4}   {:>4}/{:<4} {:>5} {:>7}  {:6.1} mm",
            class.map_or("all", |c| c.name()),
            quiet,
            good.len(),
            det,
            fl.len(),
            held,
            refuted,
            median(widths)
        );
    }
}
