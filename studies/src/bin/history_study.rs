//! Issue 33's acceptance (docs/history.md): passes of the same wheel fused.
//! `cargo run --release -p wheelflat-studies --bin history_study -- FAMILY WHEELS SEED CACHE [V1:V2] [PASSES]`
//!
//! WHEELS seeded flats over the bank's whole population (the family's middle member's
//! calibration), each seen PASSES times (3 by default): every pass strikes at its own place
//! (X_p drawn over the population's range) at its own speed (uniform in V1:V2, default the
//! family's band), simulated with the converged reference and perturbed per the paper's Eq. 1
//! (its own seed), cached in CACHE. Every pass goes through what `identify --db` does: its
//! speed and load pick the member, the member identifies it, the pass is stored in a results
//! database (CACHE/history.sqlite, made anew) under bogie `W<k>`; then every wheel's passes are
//! read back and fused as `history` does, under both rules. Printed per rule: the truth held,
//! decisive (one class), under-stated (the class acted on below the truth's), the median
//! joint L0 width, how the passes related, and the time of a joint answer from the database;
//! beside it the single-pass figures on the same passes. `GOOD=N`: N good bogies too (both
//! wheels fused; how many joint answers are `none`). `REFINE=1`: every pass refined
//! (`identify --refine`) and its refined cells stored and fused. `PHYSICS=1`: the passes'
//! model errors as physics, a wheel's vehicle, contact, track, load and tread shared by its
//! passes ([`physics_pass`]; issue 63's wheel histories), instead of Eq. 1.
use wheelflat_studies::study;

use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::time::Instant;
use wheelflat::history::{fuse, Db, FusionRule, PassRecord, Window};
use wheelflat::identify::refine::{bank_simulator, refine as refine_answer, RefineSettings};
use wheelflat::identify::synth::{synthesize, synthesize_pass, FieldNoise};
use wheelflat::identify::Members;
use wheelflat::identify::{Extras, Measurement, Severity};
use wheelflat::model::{CheckedCalibration, Flat, WheelPosition};
use wheelflat_studies::coverage;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 5 {
        panic!("usage: history_study FAMILY WHEELS SEED CACHE [V1:V2] [PASSES]");
    }
    let mut members = Members::open(Path::new(&args[1]), None).expect("bank or family");
    let family = members.family().clone();
    let mid = family.members.len() / 2;
    members.open_member(mid).expect("the middle member");
    let base: CheckedCalibration = members
        .get(mid)
        .bank()
        .metadata()
        .calibration
        .clone()
        .check()
        .expect("calibration");
    let wheels: usize = args[2].parse().expect("WHEELS");
    let seed: u64 = args[3].parse().expect("SEED");
    let cache = PathBuf::from(&args[4]);
    let band = family.band.map(|b| [b.from_km_per_h, b.to_km_per_h]);
    let v: Vec<f64> = match args.get(5) {
        Some(s) => s.split(':').map(|x| x.parse().expect("V1:V2")).collect(),
        None => band.map_or(vec![base.run.speed_km_per_h; 2], |b| b.to_vec()),
    };
    let passes: usize = args.get(6).map_or(3, |s| s.parse().expect("PASSES"));
    let refine = std::env::var("REFINE").is_ok_and(|v| v == "1");
    let physics = std::env::var("PHYSICS").is_ok_and(|v| v == "1");
    let truths = coverage::truths_within(&base, wheels, seed, 0.0);
    let phi = base.identification.phi;
    let (insp, urg) = (
        base.identification.inspect_l0_mm,
        base.identification.urgent_l0_mm,
    );
    let xp = base.population.impact_position_m;
    // Per wheel and pass: the flat struck at its own place, the speed.
    let mut state = seed ^ 0x4157_0F1A;
    let cases: Vec<(usize, usize, Flat, f64)> = (0..wheels)
        .flat_map(|w| (0..passes).map(move |p| (w, p)))
        .map(|(w, p)| {
            let t = &truths[w];
            let x = xp[0] + (xp[1] - xp[0]) * study::splitmix_uniform(&mut state);
            let s = v[0] + (v[1] - v[0]) * study::splitmix_uniform(&mut state);
            let flat = Flat::from_mm(
                t.length_m() * 1e3,
                t.depth_m() * 1e3,
                t.curvature_m() * 1e3,
                x,
            )
            .expect("the truth's size at another place")
            .on_wheel(t.wheel().unwrap_or(WheelPosition::Trailing));
            (w, p, flat, (s * 10.0).round() / 10.0)
        })
        .collect();
    std::fs::create_dir_all(&cache).expect("cache folder");
    let started = Instant::now();
    cases.par_iter().for_each(|(w, p, flat, speed)| {
        let csv = cache.join(format!("w{w}-p{p}.csv"));
        if csv.exists() {
            return;
        }
        let mut doc = base.document().clone();
        doc.run.speed_km_per_h = *speed;
        let pass_seed = seed
            .wrapping_mul(1000)
            .wrapping_add((w * passes + p) as u64);
        let syn = if physics {
            physics_pass(&doc, *w, seed, flat, pass_seed)
        } else {
            let model = coverage::converged_model(&doc.check().expect("at speed"));
            synthesize(&model, flat, pass_seed, true).expect("simulated")
        };
        let part = cache.join(format!("w{w}-p{p}.csv.part"));
        std::fs::write(&part, &syn.csv).unwrap();
        std::fs::rename(&part, &csv).unwrap();
    });
    // `GOOD=N`: N good bogies too, each seen PASSES times at its own speed.
    let good: usize = std::env::var("GOOD").map_or(0, |v| v.parse().expect("GOOD"));
    let good_cases: Vec<(usize, usize, f64)> = (0..good)
        .flat_map(|g| (0..passes).map(move |p| (g, p)))
        .map(|(g, p)| {
            let s = v[0] + (v[1] - v[0]) * study::splitmix_uniform(&mut state);
            (g, p, (s * 10.0).round() / 10.0)
        })
        .collect();
    good_cases.par_iter().for_each(|(g, p, speed)| {
        let csv = cache.join(format!("g{g}-p{p}.csv"));
        if csv.exists() {
            return;
        }
        let mut doc = base.document().clone();
        doc.run.speed_km_per_h = *speed;
        let model = coverage::converged_model(&doc.check().expect("at speed"));
        let seed = seed
            .wrapping_mul(7000)
            .wrapping_add((g * passes + p) as u64);
        let syn = synthesize_pass(&model, None, seed, true, FieldNoise::TABLE).expect("simulated");
        let part = cache.join(format!("g{g}-p{p}.csv.part"));
        std::fs::write(&part, &syn.csv).unwrap();
        std::fs::rename(&part, &csv).unwrap();
    });
    println!(
        "{} passes simulated or cached in {:.0} s",
        cases.len() + good_cases.len(),
        started.elapsed().as_secs_f64()
    );
    // Identify and store every pass.
    let db_path = cache.join("history.sqlite");
    for ext in ["", "-wal", "-shm"] {
        let _ = std::fs::remove_file(format!("{}{ext}", db_path.display()));
    }
    let mut db = Db::open(&db_path).expect("database");
    let rate = family.sample_rate_hz;
    // Single-pass figures: (held, decisive, under-stated, L0 width)
    let mut single = Vec::new();
    let t0 = 1.8e9;
    for (w, p, flat, _) in &cases {
        let csv = cache.join(format!("w{w}-p{p}.csv"));
        let text = std::fs::read_to_string(&csv).unwrap();
        let m = Measurement::from_csv(&csv, &text, rate).expect("csv");
        let k = match members.member_for_pass(&m, None, false) {
            Ok(k) => k,
            Err(e) => {
                println!("wheel {w} pass {p}: refused: {e}");
                continue;
            }
        };
        let identifier = members.get(k);
        let mut id = identifier
            .identify(&m, None, Extras::NONE)
            .expect("identified");
        // `REFINE=1`: each pass refined as `identify --refine` does; its cells are stored.
        if refine && id.sizing.as_ref().is_some_and(|z| !z.cms.is_empty()) {
            let sim = bank_simulator(identifier).expect("the bank's simulator");
            id.refinement = Some(
                refine_answer(identifier, &sim, &id, RefineSettings::default()).expect("refined"),
            );
        }
        let rec = PassRecord::of(
            &id,
            identifier,
            Some(&format!("W{w}")),
            format!("w{w}-p{p}"),
            t0 + (*w as f64) * 1e5 + (*p as f64) * 3600.0,
        );
        let wheel = flat.wheel().expect("on a wheel");
        let wp = &rec.wheels[wheel.index()];
        let one = fuse(std::slice::from_ref(wp), FusionRule::All, phi, urg, insp);
        single.push(judge(&one, flat, &base, insp, urg));
        db.insert(&rec).expect("stored");
    }
    for (g, p, _) in &good_cases {
        let csv = cache.join(format!("g{g}-p{p}.csv"));
        let text = std::fs::read_to_string(&csv).unwrap();
        let m = Measurement::from_csv(&csv, &text, rate).expect("csv");
        let k = members.member_for_pass(&m, None, false).expect("a member");
        let identifier = members.get(k);
        let id = identifier
            .identify(&m, None, Extras::NONE)
            .expect("identified");
        let rec = PassRecord::of(
            &id,
            identifier,
            Some(&format!("G{g}")),
            format!("g{g}-p{p}"),
            t0 + (*g as f64) * 1e5 + (*p as f64) * 3600.0,
        );
        db.insert(&rec).expect("stored");
    }
    println!(
        "{} passes stored in {}",
        db.pass_count().unwrap(),
        db_path.display()
    );
    // A wheel's passes as `history` reads them.
    let read_wheel = |id: &str| {
        db.wheel_passes(
            id,
            Window {
                last: passes,
                hours: None,
            },
        )
        .expect("read")
    };
    if good > 0 {
        for rule in [FusionRule::Robust, FusionRule::All] {
            let (mut quiet, mut flagged) = (0, Vec::new());
            for g in 0..good {
                for wheel in ["leading", "trailing"] {
                    let stored = read_wheel(&format!("G{g}/{wheel}"));
                    let wp: Vec<_> = stored.into_iter().map(|s| s.wheel).collect();
                    let j = fuse(&wp, rule, phi, urg, insp);
                    let none = j.severity.is_some_and(|s| s.highest == Severity::None);
                    if none && j.allows(None) {
                        quiet += 1;
                    } else {
                        flagged.push(format!("G{g}/{wheel}: {}", j.words));
                    }
                }
            }
            println!(
                "good wheels ({}): {quiet} of {} joint answers `none` (decisive){}",
                rule.as_str(),
                2 * good,
                flagged
                    .iter()
                    .map(|f| format!("\n  {f}"))
                    .collect::<String>()
            );
        }
    }
    report("single pass", &single);
    for rule in [FusionRule::Robust, FusionRule::All] {
        let mut judged = Vec::new();
        let mut times = Vec::new();
        let mut kinds = std::collections::BTreeMap::<String, usize>::new();
        for (w, truth) in truths.iter().enumerate() {
            let wheel = truth.wheel().unwrap_or(WheelPosition::Trailing);
            let t = Instant::now();
            let stored = read_wheel(&format!("W{w}/{}", wheel.name()));
            let wp: Vec<_> = stored.into_iter().map(|s| s.wheel).collect();
            let joint = fuse(&wp, rule, phi, urg, insp);
            times.push(t.elapsed().as_secs_f64() * 1e3);
            let name = serde_json::to_value(&joint.agreement).unwrap()["kind"]
                .as_str()
                .unwrap()
                .to_string();
            *kinds.entry(name).or_default() += 1;
            let j = judge(&joint, truth, &base, insp, urg);
            if !j.0 || j.2 {
                println!(
                    "  wheel {w}: L0 {:.1} mm, truth {}held{}: {}",
                    l0(truth, &base),
                    if j.0 { "" } else { "NOT " },
                    if j.2 { ", UNDER-STATED" } else { "" },
                    joint.words
                );
            }
            judged.push(j);
        }
        times.sort_by(f64::total_cmp);
        report(&format!("joint ({})", rule.as_str()), &judged);
        println!(
            "  agreement {kinds:?}; joint answer from the database: median {:.1} ms, max {:.1} ms",
            times[times.len() / 2],
            times[times.len() - 1]
        );
    }
    // The plain intersection the issue tried by hand: each pass's L and d ranges intersected
    // (an empty intersection holds nothing and acts on the highest class any pass gives).
    let mut judged = Vec::new();
    for (w, truth) in truths.iter().enumerate() {
        let wheel = truth.wheel().unwrap_or(WheelPosition::Trailing);
        let stored = read_wheel(&format!("W{w}/{}", wheel.name()));
        let mut r = [[f64::NEG_INFINITY, f64::INFINITY]; 2];
        let mut highest = Severity::None;
        for s in &stored {
            highest = highest.max(s.wheel.severity.map_or(Severity::Inspect, |c| c.highest));
            let b = &s.wheel.boxes;
            let (l, d) = if b.is_empty() {
                ([0.0, 0.0], [0.0, s.wheel.space.depth_mm[0]])
            } else {
                let f = |i: usize, j: usize| {
                    b.iter().fold([f64::INFINITY, f64::NEG_INFINITY], |a, x| {
                        [a[0].min(f64::from(x[i])), a[1].max(f64::from(x[j]))]
                    })
                };
                (f(0, 1), f(2, 3))
            };
            r = [
                [r[0][0].max(l[0]), r[0][1].min(l[1])],
                [r[1][0].max(d[0]), r[1][1].min(d[1])],
            ];
        }
        let x = [truth.length_m() * 1e3, truth.depth_m() * 1e3];
        let empty = r[0][0] > r[0][1] || r[1][0] > r[1][1];
        let held = !empty && (0..2).all(|t| r[t][0] <= x[t] && x[t] <= r[t][1]);
        let rad = base.vehicle.wheel_radius_m;
        let l0r = [
            Flat::fresh_length_mm(r[1][0].max(0.0), rad),
            Flat::fresh_length_mm(r[1][1].max(0.0), rad),
        ];
        let classes = wheelflat::identify::SeverityRange::of_l0(l0r, urg, insp);
        let truth_class = Severity::of_upper_l0(l0(truth, &base), urg, insp);
        let acted = if empty { highest } else { classes.highest };
        judged.push((
            held,
            !empty && classes.decisive(),
            acted < truth_class,
            if empty { f64::NAN } else { l0r[1] - l0r[0] },
            held,
        ));
    }
    report("plain intersection of the passes' ranges", &judged);
}

/// `PHYSICS=1`: a wheel's pass with its model errors as physics (issue 63's wheel histories):
/// the vehicle, contact and track drawn once a wheel (`study::physics`, as `physics_passes`
/// draws them a pass), its car body ×[0.6, 1.4] and, every sixth wheel, both treads rough (a
/// class drawn, one profile a wheel); a pass its own strike, speed and the measurement's own
/// sources (sensor gains ±5 % and ±2 %, ±1 kN noise, drawn a pass), at the converged reference.
fn physics_pass(
    doc: &wheelflat::model::Calibration,
    w: usize,
    seed: u64,
    flat: &Flat,
    pass_seed: u64,
) -> wheelflat::identify::synth::Synthetic {
    use wheelflat::identify::synth::{synthesize_on, PassSurfaces};
    use wheelflat::model::surface::SurfaceSpec;
    let mut state = seed.wrapping_mul(7919).wrapping_add(w as u64) ^ 0x5EED_0FA1;
    let (cal, _, class) = study::physics_draw(doc, &mut state);
    let spec = SurfaceSpec {
        wheel_roughness: w
            .is_multiple_of(6)
            .then_some((class, seed.wrapping_add(w as u64))),
        ..SurfaceSpec::default()
    };
    let cal = cal.converged_reference().check().expect("physics in range");
    let surfaces = PassSurfaces::of(&spec, &cal).expect("surfaces");
    synthesize_on(
        &cal,
        Some(flat),
        Some(&surfaces),
        pass_seed,
        true,
        FieldNoise::TABLE,
    )
    .expect("simulated")
}

fn l0(f: &Flat, cal: &CheckedCalibration) -> f64 {
    Flat::fresh_length_mm(f.depth_m() * 1e3, cal.vehicle.wheel_radius_m)
}

/// (truth held: L and d inside the answer's ranges (the project's coverage), decisive,
/// under-stated, L0 width of the flat part, truth inside the fused cells themselves (L, d, c))
fn judge(
    j: &wheelflat::history::Joint,
    f: &Flat,
    cal: &CheckedCalibration,
    insp: f64,
    urg: f64,
) -> (bool, bool, bool, f64, bool) {
    let x = [f.length_m() * 1e3, f.depth_m() * 1e3, f.curvature_m() * 1e3];
    let within = |r: Option<[f64; 2]>, v: f64| r.is_some_and(|r| r[0] <= v && v <= r[1]);
    let held = within(j.length_mm, x[0]) && within(j.depth_mm, x[1]);
    let truth = Severity::of_upper_l0(l0(f, cal), urg, insp);
    let s = j.severity;
    (
        held,
        s.is_some_and(|s| s.decisive()),
        s.is_none_or(|s| s.highest < truth),
        j.l0_mm.map_or(f64::NAN, |r| r[1] - r[0]),
        j.allows(Some(x)),
    )
}

fn report(name: &str, j: &[(bool, bool, bool, f64, bool)]) {
    let n = j.len();
    let mut w: Vec<f64> = j.iter().map(|x| x.3).filter(|x| x.is_finite()).collect();
    w.sort_by(f64::total_cmp);
    println!(
        "{name}: {n} — truth held {:.3} ({}; inside the fused cells {}), decisive {:.3} ({}), under-stated {}, median L0 width {:.1} mm",
        j.iter().filter(|x| x.0).count() as f64 / n as f64,
        j.iter().filter(|x| x.0).count(),
        j.iter().filter(|x| x.4).count(),
        j.iter().filter(|x| x.1).count() as f64 / n as f64,
        j.iter().filter(|x| x.1).count(),
        j.iter().filter(|x| x.2).count(),
        w.get(w.len() / 2).copied().unwrap_or(f64::NAN)
    );
}
