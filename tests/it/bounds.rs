//! Absurd inputs are refused with a clear error before any large allocation or long loop:
//! calibration values outside their physical range or resource bound, measurement files that
//! are huge, wide or not files at all, and impossible thread counts. Each command runs under a
//! watchdog (a hang fails the test); the times are printed, not asserted.

use crate::common;
use crate::common::{wheelflat_path, write_calibration};
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};
use wheelflat::model::Calibration;

/// Runs wheelflat with `args`, killing it after 60 s (a hang, which fails the test).
fn run(args: &[&str]) -> (Output, Duration) {
    let started = Instant::now();
    let mut child = Command::new(wheelflat_path())
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    loop {
        if child.try_wait().unwrap().is_some() {
            break;
        }
        if started.elapsed() > Duration::from_secs(60) {
            child.kill().unwrap();
            panic!("wheelflat {args:?} still running after 60 s");
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    let out = child.wait_with_output().unwrap();
    (out, started.elapsed())
}

fn refused(args: &[&str], needles: &[&str]) {
    let (out, took) = run(args);
    let err = String::from_utf8_lossy(&out.stderr);
    println!(
        "{:>7.1} ms  {args:?}: {}",
        took.as_secs_f64() * 1e3,
        err.trim()
    );
    assert!(!out.status.success(), "{args:?} was accepted");
    for n in needles {
        assert!(err.contains(n), "{args:?}: `{n}` not in: {err}");
    }
}

/// A change to the default calibration.
type Edit = Box<dyn Fn(&mut Calibration)>;

#[test]
fn calibration_values_outside_their_range_or_resource_bound_are_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let cases: Vec<(&str, Edit, &[&str])> = vec![
        (
            "bays",
            Box::new(|c| c.track.bays = 100_000),
            &["track.bays", "100000", "[2, 2000]"],
        ),
        (
            "elements",
            Box::new(|c| c.integration.elements_per_bay = 10_000),
            &["integration.elements_per_bay", "10000", "[1, 64]"],
        ),
        (
            "spacing",
            Box::new(|c| c.track.sleeper_spacing_m = 1e6),
            &["track.sleeper_spacing_m", "1000000", "[0.05, 5]"],
        ),
        (
            "rate",
            Box::new(|c| c.output.sample_rate_hz = 1e9),
            &["output.sample_rate_hz", "1000000000", "[100, 100000]"],
        ),
        (
            "speed",
            Box::new(|c| c.run.speed_km_per_h = 0.001),
            &["run.speed_km_per_h", "0.001", "[1, 500]"],
        ),
        (
            "fine",
            Box::new(|c| c.integration.fine_steps_per_coarse = 1_000_000),
            &["integration.fine_steps_per_coarse", "1000000", "[1, 1000]"],
        ),
        (
            "coarse",
            Box::new(|c| c.integration.coarse_steps_per_sample = 100_000),
            &["integration.coarse_steps_per_sample", "100000"],
        ),
        (
            "steps",
            Box::new(|c| {
                c.integration.coarse_steps_per_sample = 1000;
                c.integration.fine_steps_per_coarse = 1000;
            }),
            &[
                "integration.fine_steps_per_coarse",
                "fine steps",
                "a run may take",
            ],
        ),
        (
            "rail elements",
            Box::new(|c| {
                c.track.bays = 1500;
                c.integration.elements_per_bay = 64;
            }),
            &["integration.elements_per_bay", "rail elements", "20000"],
        ),
        (
            "units slip",
            Box::new(|c| c.track.youngs_modulus_pa = 210.0),
            &[
                "track.youngs_modulus_pa",
                "210",
                "[10000000000, 1000000000000]",
            ],
        ),
        (
            "monte carlo",
            Box::new(|c| c.identification.monte_carlo_samples = 1_000_000_000),
            &["identification.monte_carlo_samples", "1000000000"],
        ),
    ];
    for (name, edit, needles) in cases {
        let mut c = Calibration::default();
        edit(&mut c);
        let case = dir.path().join(name.replace(' ', "-"));
        std::fs::create_dir_all(&case).unwrap();
        let cal = write_calibration(&c, &case);
        let out = case.join("bank");
        refused(
            &[
                "bank",
                "generate",
                "--instances",
                "4",
                "--calibration",
                cal.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
            ],
            needles,
        );
        assert!(!out.join("CURRENT").exists(), "{name}: nothing written");
    }
}

#[test]
fn measurements_that_are_not_files_too_large_or_too_wide_and_absurd_thread_counts_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let bank = dir.path().join("bank");
    let cal = common::small_calibration(40).check().unwrap();
    wheelflat::bank::generate(&cal, &bank, &common::options(8, 8), &wheelflat::bank::Quiet)
        .unwrap();
    let b = bank.to_str().unwrap();
    let out = dir.path().join("out");
    let o = out.to_str().unwrap();

    // A device: it would read forever.
    refused(
        &[
            "identify",
            "--bank",
            b,
            "--measured",
            "/dev/zero",
            "--out",
            o,
        ],
        &["/dev/zero", "not a regular file"],
    );
    // A directory.
    let d = dir.path().to_str().unwrap();
    refused(
        &["identify", "--bank", b, "--measured", d, "--out", o],
        &["not a regular file"],
    );
    // 100,000 columns: refused at the header, without a quadratic scan.
    let wide = dir.path().join("wide.csv");
    let mut text = String::from("time_s");
    for i in 0..100_000 {
        text.push_str(&format!(",s{i}_kn"));
    }
    text.push('\n');
    std::fs::write(&wide, &text).unwrap();
    refused(
        &[
            "identify",
            "--bank",
            b,
            "--measured",
            wide.to_str().unwrap(),
            "--out",
            o,
        ],
        &["wide.csv", "line 1", "more than the 16384 a line may have"],
    );
    let many = dir.path().join("many.csv");
    let mut text = String::from("time_s");
    for i in 0..100 {
        text.push_str(&format!(",s{i}_kn"));
    }
    text.push('\n');
    std::fs::write(&many, &text).unwrap();
    refused(
        &[
            "identify",
            "--bank",
            b,
            "--measured",
            many.to_str().unwrap(),
            "--out",
            o,
        ],
        &["many.csv", "100 sensor columns", "64"],
    );
    // Larger than a measurement may be (sparse: no disk is used).
    let huge = dir.path().join("huge.csv");
    std::fs::File::create(&huge)
        .unwrap()
        .set_len(65 << 20)
        .unwrap();
    refused(
        &[
            "identify",
            "--bank",
            b,
            "--measured",
            huge.to_str().unwrap(),
            "--out",
            o,
        ],
        &["huge.csv", "68157440 bytes", "more than the 67108864"],
    );
    assert!(!Path::new(&out).join("identification.json").exists());

    for threads in ["0", "100000", "many"] {
        refused(
            &["bank", "generate", "--threads", threads, "--out", b],
            &["--threads", "1 to 1024"],
        );
    }
}
