//! `wheelflat bank …` and the operational scripts (nightly regeneration, Slurm job array),
//! driven as an operator would, on tiny banks with short windows.

use crate::common;
use crate::common::{small_calibration, wheelflat, wheelflat_path, write_calibration};
use assert_cmd::Command;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A calibration file with 50-sample windows.
fn calibration_file(dir: &Path) -> PathBuf {
    write_calibration(&small_calibration(50), dir)
}

/// The files of a bank folder, without the nightly script's `.regenerate*` working files.
fn files(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    common::files(dir, &[".regenerate"])
}

fn stdout_of(cmd: &mut Command) -> String {
    let out = cmd.assert().success();
    String::from_utf8_lossy(&out.get_output().stdout).to_string()
}

#[test]
fn generate_info_verify_and_a_corrupt_file_is_named() {
    let tmp = tempfile::tempdir().unwrap();
    let cal = calibration_file(tmp.path());
    let bank = tmp.path().join("bank");
    let out = stdout_of(
        wheelflat()
            .args([
                "bank",
                "generate",
                "--instances",
                "24",
                "--shard-size",
                "8",
                "--calibration",
            ])
            .arg(&cal)
            .arg("--out")
            .arg(&bank),
    );
    assert!(out.contains("bank complete: 24 instances"), "{out}");
    // Built with the tables a pass needs (docs/bank.md, "Built with the bank").
    assert!(out.contains("the tables a pass needs"), "{out}");
    let version = std::fs::read_to_string(bank.join("CURRENT")).unwrap();
    let version = bank.join(version.lines().next().unwrap());
    for t in [
        "departures.bin",
        "departures-binomial5.bin",
        "roughness.json",
        "out-of-round.bin",
    ] {
        assert!(version.join(t).is_file(), "{t}");
    }
    let info = stdout_of(wheelflat().args(["bank", "info"]).arg(&bank));
    assert!(
        info.contains("instances       24 in 3 shard files of 8"),
        "{info}"
    );
    assert!(info.contains("rps2   sleeper 18"), "{info}");
    assert!(info.contains("length_mm"), "{info}");
    let ok = stdout_of(wheelflat().args(["bank", "verify"]).arg(&bank));
    assert!(ok.contains("verified: 3 files"), "{ok}");
    let again = stdout_of(
        wheelflat()
            .args([
                "bank",
                "generate",
                "--instances",
                "24",
                "--shard-size",
                "8",
                "--calibration",
            ])
            .arg(&cal)
            .arg("--out")
            .arg(&bank),
    );
    assert!(again.contains("up to date"), "{again}");

    let current = std::fs::read_to_string(bank.join("CURRENT")).unwrap();
    let victim = bank
        .join(current.lines().next().unwrap())
        .join("shard-00001-of-00003.parquet");
    let mut bytes = std::fs::read(&victim).unwrap();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 0x55;
    std::fs::write(&victim, bytes).unwrap();
    let out = wheelflat()
        .args(["bank", "verify"])
        .arg(&bank)
        .assert()
        .failure();
    let err = String::from_utf8_lossy(&out.get_output().stderr).to_string();
    assert!(
        err.contains("shard-00001-of-00003.parquet: checksum mismatch"),
        "{err}"
    );
    assert!(
        err.contains("1 of 3 files bad") && !err.contains("panicked"),
        "{err}"
    );
}

#[test]
fn a_killed_run_resumes_and_ends_byte_identical() {
    let tmp = tempfile::tempdir().unwrap();
    let cal = calibration_file(tmp.path());
    let args = [
        "bank",
        "generate",
        "--defer-tables",
        "--instances",
        "120",
        "--shard-size",
        "20",
        "--threads",
        "1",
    ];
    let whole = tmp.path().join("whole");
    wheelflat()
        .args(args)
        .arg("--calibration")
        .arg(&cal)
        .arg("--out")
        .arg(&whole)
        .assert()
        .success();

    let killed = tmp.path().join("killed");
    let mut child = std::process::Command::new(wheelflat_path())
        .args(args)
        .arg("--calibration")
        .arg(&cal)
        .arg("--out")
        .arg(&killed)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // Kill it once the first shard file is in place, before the last one.
    let started = Instant::now();
    let finished_files = || -> usize {
        std::fs::read_dir(&killed)
            .into_iter()
            .flatten()
            .flatten()
            .filter(|e| e.path().is_dir())
            .flat_map(|v| std::fs::read_dir(v.path()).into_iter().flatten().flatten())
            .filter(|f| f.file_name().to_string_lossy().starts_with("shard-"))
            .count()
    };
    while finished_files() == 0 && started.elapsed() < Duration::from_secs(120) {
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let done = finished_files();
    assert!((1..6).contains(&done), "killed after {done} of 6 files");
    assert!(!killed.join("CURRENT").exists());

    let out = stdout_of(
        wheelflat()
            .args(args)
            .arg("--calibration")
            .arg(&cal)
            .arg("--out")
            .arg(&killed),
    );
    assert!(
        out.contains(&format!("{} kept from an earlier run", done * 20)),
        "{out}"
    );
    assert!(
        files(&whole) == files(&killed),
        "resumed bank differs from the uninterrupted one"
    );
}

#[test]
fn slurm_array_then_merge_equals_a_single_run() {
    let tmp = tempfile::tempdir().unwrap();
    let cal = calibration_file(tmp.path());
    let extra = ["--instances", "30", "--shard-size", "5", "--defer-tables"];
    let single = tmp.path().join("single");
    wheelflat()
        .args(["bank", "generate"])
        .args(extra)
        .arg("--calibration")
        .arg(&cal)
        .arg("--out")
        .arg(&single)
        .assert()
        .success();

    let cluster = tmp.path().join("cluster");
    let script = |name: &str| repo().join("scripts/slurm").join(name);
    let merge = || {
        std::process::Command::new("bash")
            .arg(script("bank-merge.sbatch"))
            .arg(&cal)
            .arg(&cluster)
            .args(extra)
            .env("WHEELFLAT", wheelflat_path())
            .output()
            .unwrap()
    };
    for task in [2, 0] {
        let status = std::process::Command::new("bash")
            .arg(script("bank-array.sbatch"))
            .arg(&cal)
            .arg(&cluster)
            .args(extra)
            .env("WHEELFLAT", wheelflat_path())
            .env("SLURM_ARRAY_TASK_ID", task.to_string())
            .env("SLURM_ARRAY_TASK_COUNT", "3")
            .env("SLURM_CPUS_PER_TASK", "1")
            .status()
            .unwrap();
        assert!(status.success());
    }
    // Task 1 has not run: the merge refuses and names its files.
    let out = merge();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("shard-00002-of-00006.parquet, shard-00003-of-00006.parquet"),
        "{err}"
    );
    let status = std::process::Command::new("bash")
        .arg(script("bank-array.sbatch"))
        .arg(&cal)
        .arg(&cluster)
        .args(extra)
        .env("WHEELFLAT", wheelflat_path())
        .env("SLURM_ARRAY_TASK_ID", "1")
        .env("SLURM_ARRAY_TASK_COUNT", "3")
        .status()
        .unwrap();
    assert!(status.success());
    let out = merge();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stdout).contains("verified: 6 files"));
    assert!(
        files(&single) == files(&cluster),
        "cluster bank differs from the single run"
    );
}

#[test]
fn nightly_script_rebuilds_only_when_the_calibration_changes() {
    let tmp = tempfile::tempdir().unwrap();
    let cal = calibration_file(tmp.path());
    let bank = tmp.path().join("bank");
    let run = || {
        let out = std::process::Command::new("bash")
            .arg(repo().join("scripts/regenerate-nightly.sh"))
            .arg(&cal)
            .arg(&bank)
            .args(["--instances", "10", "--shard-size", "5"])
            .env("WHEELFLAT", wheelflat_path())
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8_lossy(&out.stdout).to_string()
    };
    assert!(run().contains("bank complete"));
    let first = std::fs::read_to_string(bank.join("CURRENT")).unwrap();
    assert!(run().contains("up to date"));
    let text = std::fs::read_to_string(&cal).unwrap().replace(
        "pad_stiffness_n_per_m = 150000000.0",
        "pad_stiffness_n_per_m = 160000000.0",
    );
    std::fs::write(&cal, text).unwrap();
    let third = run();
    assert!(
        third.contains("bank complete") && third.contains("verified"),
        "{third}"
    );
    let second = std::fs::read_to_string(bank.join("CURRENT")).unwrap();
    assert_ne!(first, second);
    assert!(
        bank.join(first.lines().next().unwrap())
            .join("manifest.json")
            .is_file(),
        "old version kept beside"
    );
}
