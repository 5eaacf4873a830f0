//! Issue 45, the model learns its site: `calibrate` fits a site's track and sensors to its
//! good wheels, the calibrated bank answers that site's good wheels "no flat" where the
//! default calls every one a flat, and a site whose errors are all drawn afresh each pass is
//! not narrowed. CI-sized: the bank's own mesh, the default site with 600-sample windows and
//! the narrow profile's flats (`site::site_small`); the converged sites are in
//! docs/calibration.md ("The model learns its site").

use crate::common::options;
use std::path::PathBuf;
use wheelflat::bank::family::SpeedBand;
use wheelflat::bank::family_write::generate_family;
use wheelflat::bank::schema::sensor_axes;
use wheelflat::bank::{LoadBand, Quiet};
use wheelflat::identify::synth::{synthesize_pass, FieldNoise};
use wheelflat::identify::{Extras, Measurement, Members};
use wheelflat::model::{Calibration, CheckedCalibration, Effect, Flat};
use wheelflat::site::table::{scope, Scope};
use wheelflat::site::{self, passes, passes::SitePass, Options, SiteCalibration};

/// The site's relative sensor gains (hidden from the fit).
const GAINS: [f64; 5] = [1.04, 0.97, 1.0, 1.02, 0.96];

fn start() -> CheckedCalibration {
    crate::site::site_small().check().unwrap()
}

/// The hidden track: pad and ballast ×0.8 (the support ×0.8) and, with `void`, sleeper 17
/// (RPS3's) hanging over a 0.8 mm void.
fn hidden(void: bool) -> Calibration {
    let mut c = start().document().clone();
    c.track.pad_stiffness_n_per_m *= 0.8;
    c.track.ballast_stiffness_n_per_m *= 0.8;
    if void {
        c.effects.push(Effect::VoidedSleeper {
            sleeper: 17,
            gap_mm: 0.8,
        });
    }
    c
}

/// Pass `k` at the hidden site: car body 0.7–1.3× the calibration's, the table's errors per
/// Eq. 1 — only its per-pass entries with the site's gains applied (`fresh` false), or every
/// entry drawn afresh (`fresh`).
fn pass(k: usize, flat: Option<&Flat>, fresh: bool) -> Measurement {
    pass_at(k, flat, fresh, true).0
}

/// [`pass`] with or without the void, and the pass's true static wheel load (kN).
fn pass_at(k: usize, flat: Option<&Flat>, fresh: bool, void: bool) -> (Measurement, f64) {
    let mut c = hidden(void);
    c.vehicle.car_body_mass_kg *= 0.7 + 0.6 * ((k * 7919) % 101) as f64 / 100.0;
    let load_kn = c.vehicle.static_wheel_load_n() / 1e3;
    if !fresh {
        c.identification
            .uncertainty
            .retain(|u| scope(u) == Scope::Pass);
    }
    let cal = c.check().unwrap();
    let syn = synthesize_pass(&cal, flat, 100 + k as u64, true, FieldNoise::TABLE).unwrap();
    let mut m = Measurement::from_csv(std::path::Path::new("p.csv"), &syn.csv, 2500.0).unwrap();
    if !fresh {
        for (v, g) in m.values_kn.iter_mut().zip(GAINS) {
            v.iter_mut().for_each(|x| *x *= g);
        }
    }
    (m, load_kn)
}

fn calibrated(fresh: bool) -> SiteCalibration {
    let cal = start();
    let axes = sensor_axes(&cal);
    let ps: Vec<passes::SitePass> = (0..60)
        .map(|k| SitePass::of(&pass(k, None, fresh), &cal, &axes).unwrap())
        .collect();
    site::calibrate(&cal, &ps, &Options::default()).unwrap()
}

/// The calibrated calibration as a family over car-body masses 0.7–1.3× (7 members of 1,000
/// stored instances, 4,000 as read).
fn calibrated_family(c: &SiteCalibration) -> PathBuf {
    family_of(
        &c.calibration,
        "site-calibrated-loads",
        Some("0.7:1.3:0.1"),
        1000,
    )
}

/// A family of `c` at 50 km/h over the loads `loads` (one member at the calibration's load
/// when `None`), `instances` stored a member, under the test target's folder `name`.
fn family_of(c: &Calibration, name: &str, loads: Option<&str>, instances: usize) -> PathBuf {
    let cal = c.clone().check().unwrap();
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    let band = SpeedBand::parse("50:50:1").unwrap();
    let loads = loads.map(|l| LoadBand::parse(l, &cal.vehicle).unwrap());
    let opts = options(instances, instances / 2);
    generate_family(&cal, &dir, band, loads, &opts, &Quiet, &|_, _, _| {}).unwrap();
    dir
}

#[test]
fn a_calibrated_site_finds_its_track_and_quiets_most_of_its_good_wheels() {
    let c = calibrated(false);
    println!("{}", serde_json::to_string_pretty(&c).unwrap());
    let s = &c.support_factor;
    assert!(s.pinned && s.low <= 0.8 && 0.8 <= s.high, "support {s:?}");
    for v in &c.voids {
        let g = v.gap_mm;
        if v.sleeper == 17 {
            assert!(g.low <= 0.8 && 0.8 <= g.high, "void at 17: {g:?}");
        } else {
            assert!(g.value < 0.1, "no void at {}: {g:?}", v.sleeper);
        }
    }
    // Normalised over the sensors whose gain is pinned, as calibrate does.
    let logs: Vec<f64> = GAINS
        .iter()
        .zip(&c.gains)
        .filter(|(_, g)| g.factor.pinned)
        .map(|(t, _)| t.ln())
        .collect();
    let gm = (logs.iter().sum::<f64>() / logs.len() as f64).exp();
    for (g, t) in c.gains.iter().zip(GAINS).filter(|(g, _)| g.factor.pinned) {
        let f = g.factor;
        assert!(
            f.low <= t / gm && t / gm <= f.high,
            "{}: {f:?} vs {}",
            g.sensor,
            t / gm
        );
    }
    // The hanging sleeper makes the good wheel depart from linear in load: calibrate
    // measures it per step (the error shrinking as the step does) and writes the coarsest
    // step within the table's noise bound; a step of 0.4 misses it.
    let step = c
        .load_step
        .as_ref()
        .expect("calibrate measures the load step");
    println!("{}", step.words());
    let e: Vec<f64> = step.errors_kn.iter().map(|x| x[1]).collect();
    assert!(e.windows(2).all(|w| w[0] >= w[1]), "{e:?}");
    assert!(e[0] > step.tolerance_kn && step.step < 0.4, "{step:?}");
    assert_eq!(c.calibration.population.family_load_step, Some(step.step));
    // The default calls this site's good wheels flats; the calibrated family (over the
    // loads the site's cars carry: a hanging sleeper's response changes shape with the load,
    // which a bank at one load cannot follow) does not.
    let (dir, _) = crate::site::site_bank();
    let mut default = Members::open(dir, None).unwrap();
    let family = calibrated_family(&c);
    let mut site_id = Members::open(&family, None).unwrap();
    let (mut flagged_default, mut flagged_site) = (0, 0);
    for k in 200..210 {
        let m = pass(k, None, false);
        // Not quiet: flagged as a flat, or refused (the default misreads the load of a pass
        // over a hanging sleeper: "load 39 kN a wheel … build a family").
        let flagged = |ms: &mut Members| match ms.member_for_pass(&m, None, false) {
            Ok(i) => {
                let r = ms.get(i).identify(&m, None, Extras::NONE).unwrap();
                r.detection.as_ref().is_some_and(|d| d.flat_detected)
            }
            Err(e) => {
                println!("refused: {e}");
                true
            }
        };
        flagged_default += usize::from(flagged(&mut default));
        flagged_site += usize::from(flagged(&mut site_id));
    }
    println!("good wheels not quiet: default {flagged_default} of 10, calibrated {flagged_site}");
    // Measured (2026-11-28): default 10 of 10, calibrated family 1 of 10 — 2 of 10 before the
    // pass was read and put on its member with the members' shapes (issue 57); 0 of 10 with a
    // search of the load inside its interval, not kept: it hid small flats at the study sites
    // (docs/calibration.md, "The family's load step").
    assert_eq!(flagged_default, 10, "the default must not fit this site");
    assert!(
        flagged_site <= 1,
        "calibrated family: {flagged_site} of 10 not quiet"
    );
}

#[test]
#[ignore = "acceptance: a second 60-pass calibration of the CI site, every error drawn afresh"]
fn a_site_whose_errors_are_drawn_afresh_each_pass_is_not_narrowed() {
    let (kept, fresh) = (calibrated(false), calibrated(true));
    println!(
        "site residual: site-fixed errors ±{:.3}, drawn afresh ±{:.3} (held back {:?} vs {:?})",
        kept.site_residual,
        fresh.site_residual,
        kept.held_back_quantiles,
        fresh.held_back_quantiles
    );
    assert!(fresh.site_residual > 2.0 * kept.site_residual);
}

/// Writes `n` good-wheel passes of calibration `c` (errors per Eq. 1, car body 0.7–1.3×) as
/// CSV files into `dir`.
fn write_passes(c: &Calibration, dir: &std::path::Path, n: usize) {
    std::fs::create_dir_all(dir).unwrap();
    for k in 0..n {
        let mut c = c.clone();
        c.vehicle.car_body_mass_kg *= 0.7 + 0.6 * ((k * 7919) % 101) as f64 / 100.0;
        let syn = synthesize_pass(
            &c.check().unwrap(),
            None,
            500 + k as u64,
            true,
            FieldNoise::TABLE,
        )
        .unwrap();
        std::fs::write(dir.join(format!("pass-{k:03}.csv")), syn.csv).unwrap();
    }
}

/// `calibrate --check` as cron runs it: the site's pad stiffness dropped 20 % since the bank's
/// calibration (the support, pad and ballast in series, ×0.93): the night's passes flag it
/// (exit 3) and the new calibration is written; checked against that new calibration, the
/// same passes show no drift (exit 0, nothing written). A pass without its trigger is set
/// aside, named, not fitted.
#[test]
fn calibrate_check_flags_a_drifted_track_and_writes_the_new_calibration() {
    let tmp = tempfile::tempdir().unwrap();
    let before = crate::common::write_calibration(start().document(), tmp.path());
    let mut after = start().document().clone();
    after.track.pad_stiffness_n_per_m *= 0.8;
    let passes = tmp.path().join("night");
    write_passes(&after, &passes, 30);
    std::fs::write(
        passes.join("zz-no-trigger.csv"),
        "time_s,rps1_kn\n0,1\n0.0004,1\n",
    )
    .unwrap();
    let new = tmp.path().join("new.toml");
    let out = crate::common::wheelflat()
        .args(["calibrate", "--check", "--passes"])
        .arg(&passes)
        .arg("--calibration")
        .arg(&before)
        .arg("--out")
        .arg(&new)
        .arg("--report")
        .arg(tmp.path().join("night.json"))
        .output()
        .unwrap();
    let text =
        String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr);
    println!("{text}");
    assert_eq!(out.status.code(), Some(3), "{text}");
    assert!(
        text.contains("drifted: support stiffness factor was 1.000"),
        "{text}"
    );
    assert!(
        text.contains("set aside") && text.contains("zz-no-trigger.csv"),
        "{text}"
    );
    let fitted = Calibration::from_toml_str(&std::fs::read_to_string(&new).unwrap()).unwrap();
    let ratio = fitted.track.pad_stiffness_n_per_m / start().track.pad_stiffness_n_per_m;
    // Pad and ballast scaled together to the series stiffness of 0.8·K_p with K_b: ×0.933
    // (within 1 %: the bank's mesh, 24 fitted passes).
    assert!((ratio - 0.9333).abs() < 0.01, "support ×{ratio}");
    std::fs::remove_file(tmp.path().join("night.json")).unwrap();
    let again = tmp.path().join("again.toml");
    let out = crate::common::wheelflat()
        .args(["calibrate", "--check", "--passes"])
        .arg(&passes)
        .arg("--calibration")
        .arg(&new)
        .arg("--out")
        .arg(&again)
        .arg("--report")
        .arg(tmp.path().join("night.json"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout).to_string();
    assert_eq!(out.status.code(), Some(0), "{text}");
    assert!(text.contains("no drift"), "{text}");
    assert!(!again.exists());
}

/// Refusals name what and why: a folder that is not there, too few passes to fit and hold
/// back, and nothing is written.
#[test]
fn calibrate_refuses_a_missing_folder_and_too_few_passes() {
    let tmp = tempfile::tempdir().unwrap();
    let cal = crate::common::write_calibration(start().document(), tmp.path());
    let run = |dir: &std::path::Path| {
        let out = crate::common::wheelflat()
            .args(["calibrate", "--passes"])
            .arg(dir)
            .arg("--calibration")
            .arg(&cal)
            .arg("--out")
            .arg(tmp.path().join("c.toml"))
            .arg("--report")
            .arg(tmp.path().join("c.json"))
            .output()
            .unwrap();
        assert!(!out.status.success());
        String::from_utf8_lossy(&out.stderr).to_string()
    };
    let err = run(&tmp.path().join("nope"));
    assert!(err.contains("listing") && err.contains("nope"), "{err}");
    let few = tmp.path().join("few");
    write_passes(start().document(), &few, 3);
    let err = run(&few);
    assert!(
        err.contains("3 usable passes: calibration needs at least 25"),
        "{err}"
    );
    assert!(!tmp.path().join("c.toml").exists() && !tmp.path().join("c.json").exists());
}

/// The level the site's sensors and model together read over the table's mean (+6 %): what
/// good wheels alone cannot tell from the loads.
const COMMON_LEVEL: f64 = 1.06;

/// Passes of known load (a `# reference_wheel_load_kn` line) give the sensors' absolute
/// gains, and the load read from a record at the calibrated site is then as close as the
/// per-pass entries allow; with good wheels alone the site's common level (+6 %) stays in
/// every load read. A site without a void (the load read is linear in the load there), the
/// support ×0.8, the relative [`GAINS`] and [`COMMON_LEVEL`].
#[test]
fn passes_of_known_load_give_absolute_gains_and_the_load_read_follows() {
    let cal = start();
    let axes = sensor_axes(&cal);
    let site = |k: usize| {
        let (mut m, load_kn) = pass_at(k, None, false, false);
        m.values_kn
            .iter_mut()
            .for_each(|v| v.iter_mut().for_each(|x| *x *= COMMON_LEVEL));
        (m, load_kn)
    };
    let calibrate_with = |references: bool| {
        let ps: Vec<SitePass> = (0..40)
            .map(|k| {
                let (m, load_kn) = site(k);
                let mut p = SitePass::of(&m, &cal, &axes).unwrap();
                // Every other pass weighed.
                if references && k % 2 == 0 {
                    p.reference_wheel_load_kn = Some(load_kn);
                }
                p
            })
            .collect();
        site::calibrate(&cal, &ps, &Options::default()).unwrap()
    };
    let (relative, absolute) = (calibrate_with(false), calibrate_with(true));
    assert!(relative.absolute.is_none());
    let r = absolute.absolute.as_ref().expect("20 passes of known load");
    assert_eq!(r.passes, 20);
    println!("{r:?}");
    // The common level the load reader needs: the site's, times the per-pass entries' mean
    // (1.05: the train system −15/+5 %, which these passes draw), over the calibrated table's
    // mean (`table_level`, 1.065: it keeps the site's model-form entries) — their geometric
    // against arithmetic mean differs by < 0.2 %, inside the 1 % allowance.
    let common = COMMON_LEVEL * 1.05 / r.table_level;
    let c = r.common;
    assert!(c.low <= common && common <= c.high, "{c:?} vs {common}");
    for (g, t) in r.gains.iter().zip(GAINS) {
        let t = t * common;
        assert!(g.pinned && g.low <= t && t <= g.high, "{g:?} vs {t}");
    }
    // The load read on 40 other passes, through a bank of each calibration.
    let banks = [
        family_of(&relative.calibration, "site-relative-gains", None, 500),
        family_of(&absolute.calibration, "site-absolute-gains", None, 500),
    ];
    let errors: Vec<Vec<f64>> = banks
        .iter()
        .map(|b| {
            let mut ms = Members::open(b, None).unwrap();
            let id = ms.any().unwrap();
            (300..340)
                .map(|k| {
                    let (m, load_kn) = site(k);
                    let l = id.estimate_load(&m, None).unwrap().unwrap();
                    l.wheel_load_kn / load_kn - 1.0
                })
                .collect()
        })
        .collect();
    let mean = |e: &[f64]| e.iter().sum::<f64>() / e.len() as f64;
    let within = |e: &[f64]| e.iter().filter(|x| x.abs() <= 0.03).count();
    println!(
        "load error: relative gains mean {:+.2} % ({} of 40 within 3 %), absolute mean {:+.2} % ({} of 40)",
        100.0 * mean(&errors[0]),
        within(&errors[0]),
        100.0 * mean(&errors[1]),
        within(&errors[1])
    );
    // Good wheels alone: the common level is read as load (1.06 × 1.05 / 1.065: +4.5 %
    // expected; measured +4.1 %).
    assert!(mean(&errors[0]) > 0.025, "relative: {:?}", errors[0]);
    // Known loads: unbiased to within 2.5 standard errors (the per-pass entries, train
    // system −15/+5 % and measurement ±2 % a sensor, averaged over 5 sensors: ±2.6 % a
    // pass, 0.4 % over 40 passes; the common level from 20 weighed passes: 0.6 %; together
    // 0.7 %; measured −0.5 %) …
    assert!(mean(&errors[1]).abs() < 0.018, "absolute: {:?}", errors[1]);
    // … and within 3 % as often as that scatter allows (75 %: 30 of 40; ≥ 24 is 2 standard
    // deviations of a binomial below it). The goal of 95 % is out of reach while the table
    // draws the train system afresh per pass and sensor: docs/calibration.md.
    assert!(within(&errors[1]) >= 24, "absolute: {:?}", errors[1]);
}

/// A night's passes are good wheels by what the site answered; a flat among them (here three
/// of forty, 40–60 mm) would pull the track's fit. Each is set aside, named, after the first
/// fit, and the site found as without them.
#[test]
#[ignore = "acceptance: two calibrations of the CI site with a flat among its good wheels"]
fn a_flat_among_the_good_wheels_is_set_aside_and_the_site_found_as_without_it() {
    let cal = start();
    let axes = sensor_axes(&cal);
    let flats = [(7, 40.0), (23, 50.0), (31, 60.0)];
    let ps: Vec<SitePass> = (0..40)
        .map(|k| {
            let flat = flats
                .iter()
                .find(|f| f.0 == k)
                .map(|f| Flat::from_mm(f.1, 0.4, 0.05, 12.4).unwrap());
            let mut m = pass(k, flat.as_ref(), false);
            m.path = format!("p{k}.csv").into();
            SitePass::of(&m, &cal, &axes).unwrap()
        })
        .collect();
    let c = site::calibrate(&cal, &ps, &Options::default()).unwrap();
    let names: Vec<&str> = c.set_aside.iter().map(|x| x.path.as_str()).collect();
    println!("set aside {:?}", c.set_aside);
    assert_eq!(names, ["p7.csv", "p23.csv", "p31.csv"]);
    let s = &c.support_factor;
    assert!(s.low <= 0.8 && 0.8 <= s.high, "support {s:?}");
    let v = c.voids.iter().find(|v| v.sleeper == 17).unwrap().gap_mm;
    assert!(v.low <= 0.8 && 0.8 <= v.high, "void at 17: {v:?}");
}
