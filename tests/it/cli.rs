//! The real `wheelflat` binary on temporary folders.

use crate::common::wheelflat;
use std::path::Path;

fn read(p: &Path) -> String {
    std::fs::read_to_string(p).unwrap()
}

#[test]
fn simulate_writes_five_pad_force_series_and_prints_peaks() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("run.csv");
    let png = dir.path().join("run.png");
    let out = wheelflat()
        .args([
            "simulate", "--l-mm", "60", "--d-mm", "0.5", "--c-mm", "0.1", "--xp-m", "12.4", "--out",
        ])
        .arg(&csv)
        .arg("--plot")
        .arg(&png)
        .assert()
        .success();
    let stdout = String::from_utf8_lossy(&out.get_output().stdout).to_string();
    assert!(
        stdout.contains("rps2") && stdout.contains("peak contact force"),
        "{stdout}"
    );
    let text = read(&csv);
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "time_s,rps1_kn,rps2_kn,rps3_kn,rps4_kn,rps5_kn"
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    assert!(rows.len() > 1000);
    assert!(rows
        .iter()
        .all(|r| r.len() == 6 && r.iter().all(|v| v.is_finite())));
    // Time strictly increasing at the output rate (2.5 kHz).
    for w in rows.windows(2) {
        assert!((w[1][0] - w[0][0] - 4e-4).abs() < 2e-6);
    }
    let png_bytes = std::fs::read(&png).unwrap();
    assert_eq!(&png_bytes[..8], b"\x89PNG\r\n\x1a\n");
}

#[test]
fn no_flat_gives_the_good_wheel_signature_with_contact_columns() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("good.csv");
    wheelflat()
        .args(["simulate", "--no-flat", "--contact", "--out"])
        .arg(&csv)
        .assert()
        .success();
    let text = read(&csv);
    assert!(text
        .lines()
        .next()
        .unwrap()
        .ends_with("contact_leading_kn,contact_trailing_kn"));
    // A good wheel never loses contact and no pad sees more than the wheel load.
    for l in text.lines().skip(1) {
        let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
        assert!(v[1..6].iter().all(|&f| f < 49.6));
        assert!(v[6] > 40.0 && v[7] > 40.0, "{l}");
    }
}

#[test]
fn curvature_not_below_half_depth_is_rejected_naming_the_value() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("x.csv");
    let out = wheelflat()
        .args(["simulate", "--d-mm", "0.4", "--c-mm", "0.2", "--out"])
        .arg(&csv)
        .assert()
        .failure();
    let err = String::from_utf8_lossy(&out.get_output().stderr).to_string();
    assert!(err.contains("curvature_mm") && err.contains("0.2"), "{err}");
    assert!(!csv.exists(), "nothing is written on error");
}

#[test]
fn calibration_round_trips_and_bad_values_name_file_key_and_value() {
    let dir = tempfile::tempdir().unwrap();
    let cal = dir.path().join("track.toml");
    wheelflat()
        .args(["calibration", "--out"])
        .arg(&cal)
        .assert()
        .success();
    let csv = dir.path().join("a.csv");
    wheelflat()
        .args(["simulate", "--no-flat", "--calibration"])
        .arg(&cal)
        .arg("--out")
        .arg(&csv)
        .assert()
        .success();

    let bad = read(&cal).replace("wheel_mass_kg = 650.0", "wheel_mass_kg = -650.0");
    std::fs::write(&cal, bad).unwrap();
    let out = wheelflat()
        .args(["simulate", "--no-flat", "--calibration"])
        .arg(&cal)
        .arg("--out")
        .arg(dir.path().join("b.csv"))
        .assert()
        .failure();
    let err = String::from_utf8_lossy(&out.get_output().stderr).to_string();
    assert!(
        err.contains("track.toml") && err.contains("vehicle.wheel_mass_kg") && err.contains("-650"),
        "{err}"
    );

    std::fs::write(&cal, "[track]\nbays = \"many\"\n").unwrap();
    let out = wheelflat()
        .args(["simulate", "--no-flat", "--calibration"])
        .arg(&cal)
        .arg("--out")
        .arg(dir.path().join("c.csv"))
        .assert()
        .failure();
    let err = String::from_utf8_lossy(&out.get_output().stderr).to_string();
    assert!(
        err.contains("track.toml") && err.contains("line 2"),
        "{err}"
    );
}

/// Issue 32: the converged reference is reachable from the command line, as a calibration
/// file any command takes (`simulate`, `synth`, `bank generate`).
#[test]
fn the_converged_reference_is_a_calibration_any_command_takes() {
    let dir = tempfile::tempdir().unwrap();
    let cal = dir.path().join("converged.toml");
    wheelflat()
        .args(["calibration", "--profile", "narrow", "--converged", "--out"])
        .arg(&cal)
        .assert()
        .success();
    let text = read(&cal);
    assert!(text.contains("elements_per_bay = 40"), "{text}");
    assert!(text.contains("coarse_steps_per_sample = 20"), "{text}");
    assert!(text.contains("window_samples = 600"), "the profile is kept");
}

#[test]
fn demo_runs_the_whole_main_job_and_reuses_its_bank() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("demo");
    let bank = dir.path().join("bank");
    let run = || {
        wheelflat()
            .args(["demo", "--instances", "300", "--out"])
            .arg(&out)
            .arg("--bank")
            .arg(&bank)
            .assert()
            .success()
    };
    let first = String::from_utf8(run().get_output().stdout.clone()).unwrap();
    assert!(first.contains("bank complete: 300 instances"), "{first}");
    assert!(
        first.contains("model instances survive") || first.contains("refuted"),
        "{first}"
    );
    assert!(first.contains("truth: L0"), "{first}");
    for f in [
        "good-wheel.csv",
        "good-wheel.png",
        "flat-60mm.csv",
        "flat-60mm.png",
        "measurement.csv",
        "measurement.truth.json",
        "identification/identification.json",
        "identification/report.html",
        "identification/series.png",
    ] {
        assert!(out.join(f).metadata().unwrap().len() > 200, "{f}");
    }
    // Second run: the bank is up to date and not simulated again.
    let second = String::from_utf8(run().get_output().stdout.clone()).unwrap();
    assert!(second.contains("is up to date"), "{second}");
}
