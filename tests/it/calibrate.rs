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
use wheelflat::site::{self, passes, Options, SiteCalibration};

/// The site's relative sensor gains (hidden from the fit).
const GAINS: [f64; 5] = [1.04, 0.97, 1.0, 1.02, 0.96];

fn start() -> CheckedCalibration {
    crate::site::site_small().check().unwrap()
}

/// The hidden track: pad and ballast ×0.8 (the support ×0.8) and sleeper 17 (RPS3's)
/// hanging over a 0.8 mm void.
fn hidden() -> Calibration {
    let mut c = start().document().clone();
    c.track.pad_stiffness_n_per_m *= 0.8;
    c.track.ballast_stiffness_n_per_m *= 0.8;
    c.effects.push(Effect::VoidedSleeper {
        sleeper: 17,
        gap_mm: 0.8,
    });
    c
}

/// Pass `k` at the hidden site: car body 0.7–1.3× the calibration's, the table's errors per
/// Eq. 1 — only its per-pass entries with the site's gains applied (`fresh` false), or every
/// entry drawn afresh (`fresh`).
fn pass(k: usize, flat: Option<&Flat>, fresh: bool) -> Measurement {
    let mut c = hidden();
    c.vehicle.car_body_mass_kg *= 0.7 + 0.6 * ((k * 7919) % 101) as f64 / 100.0;
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
    m
}

fn calibrated(fresh: bool) -> SiteCalibration {
    let cal = start();
    let axes = sensor_axes(&cal);
    let ps: Vec<passes::SitePass> = (0..60)
        .map(|k| passes::SitePass {
            path: format!("p{k}.csv").into(),
            series_kn: passes::on_windows(&pass(k, None, fresh), &cal, &axes).unwrap(),
        })
        .collect();
    site::calibrate(&cal, &ps, &Options::default()).unwrap()
}

/// The calibrated calibration as a family over car-body masses 0.7–1.3× (7 members of 1,000
/// stored instances, 4,000 as read).
fn calibrated_family(c: &SiteCalibration) -> PathBuf {
    let cal = c.calibration.clone().check().unwrap();
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("site-calibrated-loads");
    let band = SpeedBand::parse("50:50:1").unwrap();
    let loads = LoadBand::parse("0.7:1.3:0.1", &cal.vehicle).unwrap();
    generate_family(
        &cal,
        &dir,
        band,
        Some(loads),
        &options(1000, 500),
        &Quiet,
        &|_, _, _| {},
    )
    .unwrap();
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
    // Measured (2026-11-27): default 10 of 10, calibrated family 2 of 10. The goal (≥ 99 %
    // quiet) is not reached at a site with a hanging sleeper: docs/calibration.md, "The model
    // learns its site", says why and what would reach it.
    assert_eq!(flagged_default, 10, "the default must not fit this site");
    assert!(
        flagged_site <= 3,
        "calibrated family: {flagged_site} of 10 not quiet"
    );
}

#[test]
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
