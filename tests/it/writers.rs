//! One writer at a time per bank directory, and pruning old versions: a second generator is
//! refused while the first runs (and the first's final message is true), the tasks of a job
//! array run side by side, and `bank prune` removes old complete versions only, without
//! disturbing a reader that has one open.

use crate::common::{options, small_calibration, wheelflat, wheelflat_path, write_calibration};
use std::path::Path;
use std::time::{Duration, Instant};
use wheelflat::bank::{self, Bank, Quiet};
use wheelflat::model::CheckedCalibration;

fn calibration(stiffness_factor: f64) -> CheckedCalibration {
    let mut c = small_calibration(40);
    c.track.pad_stiffness_n_per_m *= stiffness_factor;
    c.check().unwrap()
}

fn current(dir: &Path) -> String {
    std::fs::read_to_string(dir.join("CURRENT"))
        .unwrap()
        .lines()
        .next()
        .unwrap()
        .to_string()
}

#[test]
fn a_second_generator_is_refused_while_the_first_writes() {
    let dir = tempfile::tempdir().unwrap();
    let bank = dir.path().join("bank");
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    std::fs::create_dir_all(&a).unwrap();
    std::fs::create_dir_all(&b).unwrap();
    let cal_a = write_calibration(calibration(1.0).document(), &a);
    let cal_b = write_calibration(calibration(1.1).document(), &b);
    // The first: long enough to be caught running (a few seconds on 2 cores).
    let first = std::process::Command::new(wheelflat_path())
        .args([
            "bank",
            "generate",
            "--defer-tables",
            "--instances",
            "600",
            "--shard-size",
            "50",
        ])
        .arg("--calibration")
        .arg(&cal_a)
        .arg("--out")
        .arg(&bank)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let started = Instant::now();
    while !std::fs::read_dir(&bank).is_ok_and(|mut d| {
        d.any(|e| e.is_ok_and(|e| e.file_name().to_string_lossy().starts_with("v-")))
    }) {
        assert!(
            started.elapsed() < Duration::from_secs(60),
            "the first never started"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
    let small_run = || {
        wheelflat()
            .args(["bank", "generate", "--defer-tables", "--instances", "20"])
            .arg("--calibration")
            .arg(&cal_b)
            .arg("--out")
            .arg(&bank)
            .output()
            .unwrap()
    };
    let second = small_run();
    let err = String::from_utf8_lossy(&second.stderr);
    assert!(!second.status.success(), "the second writer was let in");
    assert!(
        err.contains("is being written by another `wheelflat bank generate`"),
        "{err}"
    );
    let out = first.wait_with_output().unwrap();
    let log = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{log}");
    // The first's message names the version CURRENT holds: it is true.
    let named = log.split("CURRENT -> ").nth(1).unwrap().trim().to_string();
    assert!(
        named.ends_with(&current(&bank)),
        "{log} vs {}",
        current(&bank)
    );
    // Now the lock is free again.
    assert!(small_run().status.success());
}

#[test]
fn tasks_of_a_job_array_share_the_lock_and_exclude_a_whole_bank_run() {
    let dir = tempfile::tempdir().unwrap();
    let t1 = bank::lock(dir.path(), bank::Access::Shared).unwrap();
    let cal = calibration(1.0);
    // A task alongside another task: runs.
    let task = wheelflat::bank::GenerateOptions {
        machine_shard: Some((0, 2)),
        ..options(20, 10)
    };
    bank::generate(&cal, dir.path(), &task, &Quiet).unwrap();
    // A whole-bank run (merge) while a task holds the lock: refused.
    let err = bank::generate(&cal, dir.path(), &options(20, 10), &Quiet)
        .unwrap_err()
        .to_string();
    assert!(err.contains("is being written"), "{err}");
    drop(t1);
}

#[test]
fn prune_removes_old_complete_versions_only_and_a_reader_keeps_reading() {
    let dir = tempfile::tempdir().unwrap();
    let bank_dir = dir.path().join("bank");
    let mut versions = Vec::new();
    for (k, factor) in [1.0, 1.1, 1.2].into_iter().enumerate() {
        bank::generate(&calibration(factor), &bank_dir, &options(12, 6), &Quiet).unwrap();
        versions.push(bank_dir.join(current(&bank_dir)));
        if k == 0 {
            // Distinct manifest times, oldest first.
            std::thread::sleep(Duration::from_millis(20));
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    // A reader holds the oldest version open.
    let reader = Bank::open(&versions[0]).unwrap();
    let before = reader
        .read_columns(&[1 + wheelflat::bank::schema::PARAMETER_COLUMNS.len(), 40])
        .unwrap();
    // An abandoned, incomplete version.
    let incomplete = bank_dir.join("v-0000000000000000");
    std::fs::create_dir_all(&incomplete).unwrap();
    std::fs::write(incomplete.join("shard-00000-of-00002.parquet"), b"partial").unwrap();

    let out = wheelflat()
        .args(["bank", "prune", "--keep", "2"])
        .arg(&bank_dir)
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{log}");
    assert!(!versions[0].exists(), "{log}");
    assert!(versions[1].join("manifest.json").is_file(), "{log}");
    assert!(versions[2].join("manifest.json").is_file(), "{log}");
    assert!(incomplete.exists() && log.contains("incomplete"), "{log}");
    assert!(log.contains("1 removed"), "{log}");
    // The reader's mapped files stay readable after their removal.
    assert_eq!(
        reader
            .read_columns(&[1 + wheelflat::bank::schema::PARAMETER_COLUMNS.len(), 40])
            .unwrap(),
        before
    );
    // The version CURRENT names is never removed, whatever --keep says.
    let out = wheelflat()
        .args(["bank", "prune", "--keep", "1"])
        .arg(&bank_dir)
        .output()
        .unwrap();
    assert!(out.status.success());
    assert!(!versions[1].exists());
    assert!(versions[2].join("manifest.json").is_file());
    Bank::open(&bank_dir).unwrap();
    // --keep 0 is refused by the parser.
    let out = wheelflat()
        .args(["bank", "prune", "--keep", "0"])
        .arg(&bank_dir)
        .output()
        .unwrap();
    assert!(!out.status.success());
}
