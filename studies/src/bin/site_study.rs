//! Sites that learn their track (docs/calibration.md, "The model learns its site"):
//! `cargo run --release -p wheelflat-studies --bin site_study -- CACHE SITE SEED MODE GOOD FLATS [BANK…]`.
//!
//! One simulated site `SITE` (seed `SEED`): a hidden track (pad and ballast stiffness factors
//! drawn in 0.7–1.3, 0–2 voided sleepers of 0.2–1.5 mm among the sleepers next to the
//! sensors), its site-fixed errors (the table's site entries, docs/calibration.md) drawn once
//! per sensor when `MODE` is `site`, or afresh per pass when it is `fresh`; every pass at the
//! converged reference with both treads drawn rough (disc, composite, cast iron in turn), a
//! car-body mass 0.6–1.4× the calibration's, the per-pass errors of Eq. 1 drawn per pass.
//! GOOD good wheels and FLATS flats of the site population are written to `CACHE/SITE` once.
//! Then `calibrate` on the good wheels (the built-in site calibration as the start), writing
//! `calibrated.toml` and `calibration.json` there, and the fitted values against the hidden
//! ones (`FIT_MESH=E:S`: the fit at E elements a bay and S steps a sample). With BANK
//! arguments (a bank or a family over loads), each identifies every pass on the member at its
//! load: good wheels quiet, flats held, refuted, median L0 width, and how many passes a single
//! bank's load tolerance would refuse (identified on it anyway).
use rayon::prelude::*;
use std::path::Path;
use wheelflat::identify::synth::{synthesize_on, FieldNoise, PassSurfaces, Truth};
use wheelflat::identify::{Extras, Measurement, Members};
use wheelflat::model::calibration::{UncertaintyGroup, UncertaintyKind};
use wheelflat::model::surface::{RoughnessClass, SurfaceSpec};
use wheelflat::model::{Calibration, CheckedCalibration, ContactFilter, Effect};
use wheelflat::site::table::{scope, Scope};
use wheelflat::site::{passes, Options};
use wheelflat_studies::{coverage, study};

/// The hidden site of seed `seed`: `(pad factor, ballast factor, voids)`.
fn hidden(seed: u64, sleepers: &[usize]) -> (f64, f64, Vec<(usize, f64)>) {
    let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0x517E;
    let mut u = || study::splitmix_uniform(&mut s);
    let pad = 0.7 + 0.6 * u();
    let ballast = 0.7 + 0.6 * u();
    let n = (u() * 3.0) as usize;
    let mut voids: Vec<(usize, f64)> = Vec::new();
    while voids.len() < n {
        let k = sleepers[(u() * sleepers.len() as f64) as usize % sleepers.len()];
        let gap = 0.2 + 1.3 * u();
        if voids.iter().all(|v| v.0 != k) {
            voids.push((k, gap));
        }
    }
    (pad, ballast, voids)
}

/// The site's fixed relative errors per sensor `(model, gain)`, from the table's site entries.
fn site_errors(cal: &CheckedCalibration, seed: u64) -> Vec<(f64, f64)> {
    let mut s = seed ^ 0xE220;
    let table = &cal.identification.uncertainty;
    (0..cal.sensors.pad.len())
        .map(|_| {
            let mut draw = |group| {
                table
                    .iter()
                    .filter(|u| {
                        u.group == group
                            && u.kind == UncertaintyKind::Relative
                            && scope(u) == Scope::Site
                    })
                    .map(|u| u.min + (u.max - u.min) * study::splitmix_uniform(&mut s))
                    .sum::<f64>()
            };
            (
                draw(UncertaintyGroup::Model),
                draw(UncertaintyGroup::Measurement),
            )
        })
        .collect()
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 7 {
        panic!("usage: site_study CACHE SITE SEED site|fresh GOOD FLATS [BANK…]");
    }
    let site: usize = args[2].parse().expect("SITE");
    let seed: u64 = args[3].parse().expect("SEED");
    let fresh = args[4] == "fresh";
    let (good, flats): (usize, usize) = (args[5].parse().unwrap(), args[6].parse().unwrap());
    let dir = Path::new(&args[1]).join(format!("site-{site}-{}", args[4]));
    std::fs::create_dir_all(&dir).unwrap();
    let start = Calibration::default().check().unwrap();
    let sleepers: Vec<usize> = {
        let s: Vec<usize> = start.sensors.pad.iter().map(|p| p.sleeper).collect();
        (s.iter().min().unwrap() - 1..=s.iter().max().unwrap() + 1).collect()
    };
    let site_seed = seed.wrapping_add(1000 * site as u64);
    let (pad, ballast, voids) = hidden(site_seed, &sleepers);
    println!("site {site}: hidden pad ×{pad:.3}, ballast ×{ballast:.3}, voids {voids:?}");
    let mut truth_doc = start.document().clone();
    truth_doc.track.pad_stiffness_n_per_m *= pad;
    truth_doc.track.ballast_stiffness_n_per_m *= ballast;
    for &(sleeper, gap_mm) in &voids {
        truth_doc
            .effects
            .push(Effect::VoidedSleeper { sleeper, gap_mm });
    }
    let truth_cal = truth_doc.check().unwrap();
    let errors = site_errors(&start, site_seed);
    // The per-pass table: the site entries left out in `site` mode (applied once, below).
    let mut per_pass_doc = truth_cal.document().clone();
    if !fresh {
        per_pass_doc
            .identification
            .uncertainty
            .retain(|u| scope(u) == Scope::Pass);
    }
    let flats_drawn = coverage::truths_within(&start, flats, seed.wrapping_add(7), 0.0);
    let total = good + flats;
    (0..total).into_par_iter().for_each(|k| {
        let csv = dir.join(format!("case-{k}.csv"));
        if csv.exists() {
            return;
        }
        let mut s = site_seed.wrapping_mul(31).wrapping_add(k as u64);
        let load = 0.6 + 0.8 * study::splitmix_uniform(&mut s);
        let mut doc = per_pass_doc.clone();
        doc.vehicle.car_body_mass_kg *= load;
        let model = coverage::converged_model(&doc.check().unwrap());
        let class = [
            RoughnessClass::Disc,
            RoughnessClass::Composite,
            RoughnessClass::CastIron,
        ][k % 3];
        let spec = SurfaceSpec {
            wheel_roughness: Some((class, site_seed ^ k as u64)),
            filter: ContactFilter::DEFAULT,
            ..SurfaceSpec::default()
        };
        let surf = PassSurfaces::of(&spec, &model).unwrap();
        let flat = (k >= good).then(|| flats_drawn[k - good]);
        let syn = synthesize_on(
            &model,
            flat.as_ref(),
            Some(&surf),
            s,
            true,
            FieldNoise::TABLE,
        )
        .unwrap();
        study::write_case(&dir, k, &syn);
    });
    // The passes as recorded: the site's fixed errors applied to every sensor.
    let read = |k: usize| -> (Measurement, Truth) {
        let csv = dir.join(format!("case-{k}.csv"));
        let mut m =
            Measurement::from_csv(&csv, &std::fs::read_to_string(&csv).unwrap(), 2500.0).unwrap();
        if !fresh {
            for (j, v) in m.values_kn.iter_mut().enumerate() {
                let (me, ge) = errors[j];
                v.iter_mut().for_each(|x| *x *= (1.0 - me) * (1.0 + ge));
            }
        }
        let t: Truth = serde_json::from_str(
            &std::fs::read_to_string(dir.join(format!("case-{k}.truth.json"))).unwrap(),
        )
        .unwrap();
        (m, t)
    };
    // The true static wheel load of pass k (kN), as drawn above.
    let true_load_kn = |k: usize| -> f64 {
        let mut s = site_seed.wrapping_mul(31).wrapping_add(k as u64);
        let mut v = per_pass_doc.vehicle.clone();
        v.car_body_mass_kg *= 0.6 + 0.8 * study::splitmix_uniform(&mut s);
        v.static_wheel_load_n() / 1e3
    };
    // REFERENCE=N: every Nth good pass carries its true load (a weighbridge's reading).
    let weigh_every: Option<usize> = std::env::var("REFERENCE").ok().map(|v| v.parse().unwrap());
    let axes = wheelflat::bank::schema::sensor_axes(&start);
    let site_passes: Vec<passes::SitePass> = (0..good)
        .map(|k| {
            let mut p = passes::SitePass::of(&read(k).0, &start, &axes).unwrap();
            if weigh_every.is_some_and(|n| k % n == 0) {
                p.reference_wheel_load_kn = Some(true_load_kn(k));
            }
            p
        })
        .collect();
    let clock = std::time::Instant::now();
    // FIT_MESH=E:S fits with E elements per bay and S coarse steps per sample (a study of
    // the fit's own discretisation).
    let fit_start = match std::env::var("FIT_MESH") {
        Ok(v) => {
            let (e, st) = v.split_once(':').expect("FIT_MESH=E:S");
            let mut d = start.document().clone();
            d.integration.elements_per_bay = e.parse().unwrap();
            d.integration.coarse_steps_per_sample = st.parse().unwrap();
            d.check().unwrap()
        }
        Err(_) => start.clone(),
    };
    let c = wheelflat::site::calibrate(&fit_start, &site_passes, &Options::default()).unwrap();
    let secs = clock.elapsed().as_secs_f64();
    std::fs::write(dir.join("calibrated.toml"), c.calibration.to_toml_string()).unwrap();
    std::fs::write(
        dir.join("calibration.json"),
        serde_json::to_string_pretty(&c).unwrap(),
    )
    .unwrap();
    let inside = |i: &wheelflat::site::Interval, v: f64| i.low <= v && v <= i.high;
    let mut held = 0;
    let mut total_values = 0;
    let mut line = |what: String, i: &wheelflat::site::Interval, v: f64| {
        total_values += 1;
        held += usize::from(inside(i, v));
        println!(
            "  {what:28} true {v:7.3}  fitted {:7.3} [{:7.3}, {:7.3}]{}{}",
            i.value,
            i.low,
            i.high,
            if i.pinned { "" } else { " (not pinned: prior)" },
            if inside(i, v) { "" } else { "  OUTSIDE" }
        );
    };
    // The series stiffness of pad and ballast, as a factor of the calibration's.
    let (kp, kb) = (
        start.track.pad_stiffness_n_per_m,
        start.track.ballast_stiffness_n_per_m,
    );
    let series = |a: f64, b: f64| a * b / (a + b);
    let support = series(kp * pad, kb * ballast) / series(kp, kb);
    line("support factor".into(), &c.support_factor, support);
    for v in &c.voids {
        let t = voids.iter().find(|x| x.0 == v.sleeper).map_or(0.0, |x| x.1);
        line(format!("void gap at {} (mm)", v.sleeper), &v.gap_mm, t);
    }
    if !fresh {
        // The true relative gains: (1 − m)(1 + g) over their geometric mean.
        // Normalised as calibrate normalises: over the sensors whose gain it pins.
        let raw: Vec<f64> = errors.iter().map(|(m, g)| (1.0 - m) * (1.0 + g)).collect();
        let pinned: Vec<f64> = raw
            .iter()
            .zip(&c.gains)
            .filter(|(_, g)| g.factor.pinned)
            .map(|(r, _)| r.ln())
            .collect();
        let gm = (pinned.iter().sum::<f64>() / pinned.len() as f64).exp();
        for (g, r) in c.gains.iter().zip(&raw) {
            if g.factor.pinned {
                line(format!("gain {}", g.sensor), &g.factor, r / gm);
            } else {
                println!(
                    "  gain {:23} not pinned (a hanging sleeper's sensor)",
                    g.sensor
                );
            }
        }
    }
    println!(
        "site {site}: {held} of {total_values} values inside their intervals; calibrate {secs:.1} s ({} simulations, {} iterations), RMS {:.3} → {:.3} kN; site residual ±{:.3} (held back {:?}, per-pass entries {:?})",
        c.simulations, c.iterations, c.rms_kn[0], c.rms_kn[1], c.site_residual, c.held_back_quantiles, c.per_pass_quantiles
    );
    if let Some(r) = &c.absolute {
        println!(
            "  absolute gains from {} weighed passes: common level {:.4} [{:.4}, {:.4}] over the table's {:.4}",
            r.passes, r.common.value, r.common.low, r.common.high, r.table_level
        );
    }
    for bank_dir in &args[7..] {
        // A single bank or a family (over loads: each pass on the member at its load).
        let mut members = Members::open(Path::new(bank_dir), None).expect("bank");
        if std::env::var("LOAD_ONLY").is_ok() {
            // The load read on the member each pass is taken on; with absolute gains the
            // bank's flat-free prediction is the relative bank's times the common level, so
            // the load read is the relative bank's over it.
            let common = c.absolute.as_ref().map_or(1.0, |r| r.common.value);
            let mut errors: Vec<[f64; 2]> = Vec::new();
            for k in 0..total {
                let (m, _) = read(k);
                let Ok(i) = members.member_for_pass(&m, None, true) else {
                    continue;
                };
                let Some(l) = members.get(i).estimate_load(&m, None).unwrap() else {
                    continue;
                };
                let t = true_load_kn(k);
                errors.push([
                    l.wheel_load_kn / t - 1.0,
                    l.wheel_load_kn / common / t - 1.0,
                ]);
            }
            let within = |j: usize| errors.iter().filter(|e| e[j].abs() <= 0.03).count();
            let mut e1: Vec<f64> = errors.iter().map(|e| e[1]).collect();
            e1.sort_by(f64::total_cmp);
            let q = |p: f64| e1[((e1.len() - 1) as f64 * p).round() as usize];
            println!(
                "  bank {bank_dir}: load within 3 %: relative gains {}/{}, absolute {}/{} (error 2.5/50/97.5 %: {:+.1} / {:+.1} / {:+.1} %)",
                within(0), errors.len(), within(1), errors.len(), 100.0 * q(0.025), 100.0 * q(0.5), 100.0 * q(0.975)
            );
            continue;
        }
        let mut refused = 0;
        let results: Vec<(usize, Option<bool>, f64, bool)> = (0..total)
            .map(|k| {
                let (m, t) = read(k);
                // A single bank refuses a load outside its tolerance: counted, and the pass
                // identified on it anyway (what the answers would be without the check).
                // A family's refusal (a load outside its band) is counted and the pass is
                // neither quiet nor held.
                let i = match members.member_for_pass(&m, None, false) {
                    Ok(i) => i,
                    Err(_) if members.family().members.len() == 1 => {
                        refused += 1;
                        0
                    }
                    Err(e) => {
                        println!("case {k} refused: {e}");
                        refused += 1;
                        return (
                            k,
                            if k < good { Some(true) } else { None },
                            f64::NAN,
                            k < good,
                        );
                    }
                };
                let r = members.get(i).identify(&m, None, Extras::NONE).unwrap();
                let detected = r.detection.as_ref().is_some_and(|d| d.flat_detected);
                if k < good && detected {
                    let d = r.detection.as_ref().expect("detected");
                    let w = d.worst().expect("a sensor");
                    println!(
                        "  good case {k} alarmed: load read {:.1} kN (true {:.1}), {} {:+.2} kN over its bound at {:.4} s{}",
                        r.load.as_ref().map_or(f64::NAN, |l| l.wheel_load_kn),
                        true_load_kn(k),
                        w.sensor,
                        w.excess_kn,
                        w.at_time_s,
                        if d.spike.as_ref().is_some_and(|s| s.flat_detected) { " (strike test)" } else { "" }
                    );
                }
                let ranges = r.cms_ranges().cloned();
                let holds = ranges.as_ref().map(|x| coverage::holds_truth(x, &t, false));
                let width = ranges
                    .as_ref()
                    .map_or(f64::NAN, |x| x.l0_mm[1] - x.l0_mm[0]);
                if k >= good && holds != Some(true) {
                    println!(
                        "  flat case {k} not held: L0 {:.1} mm, d {:.3} mm, {}; answered {:?}; load read {:.1} kN (true {:.1}){}",
                        t.l0_mm,
                        t.depth_mm,
                        if detected { "detected" } else { "not detected" },
                        ranges.as_ref().map(|x| x.l0_mm),
                        r.load.as_ref().map_or(f64::NAN, |l| l.wheel_load_kn),
                        true_load_kn(k),
                        if r.model_class_refuted() { ", refuted" } else { "" }
                    );
                }
                (
                    k,
                    if k < good { Some(detected) } else { holds },
                    width,
                    detected,
                )
            })
            .collect();
        let quiet = results[..good]
            .iter()
            .filter(|r| r.1 == Some(false))
            .count();
        let fl = &results[good..];
        let held = fl.iter().filter(|r| r.1 == Some(true)).count();
        let refuted = fl.iter().filter(|r| r.3 && r.1.is_none()).count();
        let missed = fl.iter().filter(|r| !r.3).count();
        let mut widths: Vec<f64> = fl.iter().filter(|r| r.1.is_some()).map(|r| r.2).collect();
        widths.sort_by(f64::total_cmp);
        println!(
            "  bank {bank_dir}: good quiet {quiet}/{good}; flats held {held}/{flats}, refuted {refuted}, not detected {missed}; median L0 width {:.1} mm; {refused} passes refused for their load (a single bank: identified anyway)",
            widths.get(widths.len() / 2).copied().unwrap_or(f64::NAN)
        );
    }
}
