//! The monitoring path: `identify` writes the verdict and JSON first (figures later, from the
//! JSON, with `wheelflat report`), and `watch` identifies every measurement that arrives in
//! an inbox exactly once, against one bank version, while the bank is regenerated.

use crate::common;
use crate::common::{
    answered, collect_stdout, drop_file, names_in, narrow_calibration, wait_for, wheelflat,
    wheelflat_path, write_calibration,
};
use std::collections::BTreeMap;
use std::io::Write as _;
use std::path::Path;
use std::time::Duration;
use wheelflat::bank::{self, Bank, Quiet};
use wheelflat::identify::Identification;
use wheelflat::model::CheckedCalibration;

/// A synthetic measurement of the narrow population, with the laser trigger.
fn measurement(cal: &CheckedCalibration, seed: u64) -> String {
    common::narrow_measurement(cal, seed, true)
}

fn small_bank(cal: &CheckedCalibration, dir: &Path, instances: usize) {
    bank::generate(cal, dir, &common::options(instances, 100), &Quiet).unwrap();
}

fn read_id(path: &Path) -> Identification {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

#[test]
fn identify_gives_the_verdict_and_json_first_and_report_draws_the_figures_from_it() {
    let cal = narrow_calibration();
    let dir = tempfile::tempdir().unwrap();
    let bank_dir = dir.path().join("bank");
    small_bank(&cal, &bank_dir, 300);
    let m = dir.path().join("m.csv");
    std::fs::write(&m, measurement(&cal, 3)).unwrap();
    let quick = dir.path().join("quick");
    let out = wheelflat()
        .args(["identify", "--bank"])
        .arg(&bank_dir)
        .arg("--measured")
        .arg(&m)
        .arg("--out")
        .arg(&quick)
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let text = String::from_utf8(out).unwrap();
    assert!(
        text.lines()
            .next()
            .unwrap()
            .contains("model instances survive"),
        "{text}"
    );
    assert!(quick.join("identification.json").is_file());
    assert!(!quick.join("report.html").exists(), "no figures by default");
    assert!(!quick.join("series.png").exists(), "no figures by default");

    wheelflat()
        .args(["report", "--from"])
        .arg(quick.join("identification.json"))
        .assert()
        .success();
    assert!(quick.join("report.html").is_file());
    assert!(quick.join("series.png").is_file());

    // The full report path finds the same candidate model set.
    let full = dir.path().join("full");
    wheelflat()
        .args(["identify", "--report", "--bank"])
        .arg(&bank_dir)
        .arg("--measured")
        .arg(&m)
        .arg("--out")
        .arg(&full)
        .assert()
        .success();
    assert!(full.join("report.html").is_file());
    let (a, b) = (
        read_id(&quick.join("identification.json")),
        read_id(&full.join("identification.json")),
    );
    let (a, b) = (a.sizing.expect("sized"), b.sizing.expect("sized"));
    assert_eq!(a.cms, b.cms);
    assert!(b.random_subsets.is_some() && a.random_subsets.is_none());

    let err = wheelflat()
        .args(["report", "--from"])
        .arg(&m)
        .assert()
        .failure()
        .get_output()
        .stderr
        .clone();
    let err = String::from_utf8(err).unwrap();
    assert!(
        err.contains("m.csv") && err.contains("not an identification.json"),
        "{err}"
    );
}

#[test]
fn watch_identifies_every_file_once_against_one_bank_while_the_bank_is_regenerated() {
    let cal = narrow_calibration();
    let dir = tempfile::tempdir().unwrap();
    let bank_dir = dir.path().join("bank");
    small_bank(&cal, &bank_dir, 300);
    let first = Bank::open(&bank_dir).unwrap().metadata().bank_id.clone();
    let inbox = dir.path().join("inbox");
    let out = dir.path().join("out");
    std::fs::create_dir_all(&inbox).unwrap();
    let mut watcher = std::process::Command::new(wheelflat_path())
        .args(["watch", "--poll-ms", "20", "--bank"])
        .arg(&bank_dir)
        .arg("--inbox")
        .arg(&inbox)
        .arg("--out")
        .arg(&out)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::inherit())
        .spawn()
        .unwrap();
    let log_lines = collect_stdout(&mut watcher);

    let good = |i: usize| format!("pass-{i:02}.csv");
    let bad: Vec<(String, String)> = vec![
        (
            "bad-number.csv".into(),
            "time_s,rps1_kn\n0,12\n0.0004,abc\n".into(),
        ),
        ("bad-empty.csv".into(), String::new()),
        ("bad-header.csv".into(), "when,force\n0,1\n".into()),
        (
            "bad-sensor.csv".into(),
            "time_s,rps9_kn\n0,1\n0.0004,2\n".into(),
        ),
        (
            "bad-short.csv".into(),
            "time_s,rps1_kn\n0,1\n0.0004,2\n".into(),
        ),
        ("bad-binary.csv".into(), "\u{0}\u{1}\u{2}garbage".into()),
        (
            "bad-ragged.csv".into(),
            "time_s,rps1_kn,rps2_kn\n0,1\n".into(),
        ),
        ("bad-nan.csv".into(), "time_s,rps1_kn\n0,NaN\n".into()),
        ("bad-clock.csv".into(), "time_s,rps1_kn\n0,1\n0,2\n".into()),
    ];
    let done = inbox.join("done");
    let failed = inbox.join("failed");
    let processed = |n: usize| answered(&inbox, n);

    // Phase 1: 20 good files and the bad ones, against the first bank.
    for i in 0..20 {
        drop_file(&inbox, &good(i), &measurement(&cal, i as u64));
    }
    for (name, text) in &bad {
        drop_file(&inbox, name, text);
    }
    wait_for(120, "phase 1", processed(20 + bad.len()));

    // Phase 2: a regeneration (another calibration, so another version) runs while 20 more
    // arrive, one of them written slowly in pieces under a hidden name.
    let mut changed = cal.document().clone();
    changed.track.pad_stiffness_n_per_m *= 1.05;
    let toml = write_calibration(&changed, dir.path());
    let mut regen = std::process::Command::new(wheelflat_path())
        .args([
            "bank",
            "generate",
            "--defer-tables",
            "--instances",
            "240",
            "--shard-size",
            "120",
            "--out",
        ])
        .arg(&bank_dir)
        .arg("--calibration")
        .arg(&toml)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let slow_text = measurement(&cal, 20);
    let part = inbox.join(".pass-20.csv.part");
    let mut f = std::fs::File::create(&part).unwrap();
    for chunk in slow_text.as_bytes().chunks(slow_text.len() / 5 + 1) {
        f.write_all(chunk).unwrap();
        f.flush().unwrap();
        std::thread::sleep(Duration::from_millis(150));
    }
    drop(f);
    std::fs::rename(&part, inbox.join(good(20))).unwrap();
    for i in 21..40 {
        drop_file(&inbox, &good(i), &measurement(&cal, i as u64));
        std::thread::sleep(Duration::from_millis(30));
    }
    assert!(regen.wait().unwrap().success());
    let second = Bank::open(&bank_dir).unwrap().metadata().bank_id.clone();
    assert_ne!(first, second);
    wait_for(120, "phase 2", processed(40 + bad.len()));

    // Phase 3: after the switch, 1 more.
    drop_file(&inbox, &good(40), &measurement(&cal, 40));
    wait_for(60, "phase 3", processed(41 + bad.len()));

    // A clean stop on SIGTERM.
    common::terminate(&watcher);
    assert!(
        watcher.wait().unwrap().success(),
        "watch exits 0 on SIGTERM"
    );
    let lines = log_lines.join().unwrap();
    assert!(lines.last().unwrap().contains("stopping"), "{lines:?}");

    // Every good file once, in done/, with its result; every bad one in failed/ with a reason.
    let goods: Vec<String> = (0..41).map(good).collect();
    assert_eq!(names_in(&done), goods);
    let mut bad_names: Vec<String> = bad.iter().map(|(n, _)| n.clone()).collect();
    bad_names.sort();
    let mut expected_failed: Vec<String> = bad_names
        .iter()
        .flat_map(|n| [n.clone(), format!("{n}.error.txt")])
        .collect();
    expected_failed.sort();
    assert_eq!(names_in(&failed), expected_failed);
    for n in &bad_names {
        let why = std::fs::read_to_string(failed.join(format!("{n}.error.txt"))).unwrap();
        assert!(
            why.contains(n.as_str()) || why.contains("sensor"),
            "{n}: {why}"
        );
    }
    assert!(
        names_in(&inbox)
            .iter()
            .all(|n| n == "done" || n == "failed"),
        "inbox left with {:?}",
        names_in(&inbox)
    );
    // One result per good file, no partial or temporary file; each against one whole bank.
    let instances: BTreeMap<String, usize> = [(first.clone(), 300), (second.clone(), 240)].into();
    let mut used = BTreeMap::new();
    assert_eq!(
        names_in(&out),
        goods
            .iter()
            .map(|g| g.trim_end_matches(".csv").to_string())
            .collect::<Vec<_>>()
    );
    for (i, g) in goods.iter().enumerate() {
        let stem = g.trim_end_matches(".csv");
        assert_eq!(names_in(&out.join(stem)), vec!["identification.json"]);
        let id = read_id(&out.join(stem).join("identification.json"));
        assert_eq!(instances.get(&id.bank_id), Some(&id.bank_instances), "{g}");
        *used.entry(id.bank_id.clone()).or_insert(0) += 1;
        if i < 20 {
            assert_eq!(id.bank_id, first, "{g} arrived before the regeneration");
        }
        if i == 40 {
            assert_eq!(id.bank_id, second, "{g} arrived after the switch");
        }
        let ok_lines = lines
            .iter()
            .filter(|l| l.contains(&format!(" {g} ok ")))
            .count();
        assert_eq!(ok_lines, 1, "{g} logged {ok_lines} times");
    }
    assert!(
        lines.iter().any(|l| l.contains("bank switched to")),
        "{lines:?}"
    );
    assert_eq!(used.len(), 2);
}

#[test]
fn watch_identifies_a_train_pass_from_its_recording_and_trigger_file() {
    // A small train-profile bank: the result's quality is tests/it/train.rs's; here, the pairing,
    // the output and the moves.
    let mut c = wheelflat::model::Calibration::train_profile();
    c.output.window_samples = 600;
    c.population.length_mm = [40.0, 100.0];
    c.population.depth_mm = [0.25, 0.85];
    c.population.curvature_mm = [0.0, 0.25];
    let cal = c.check().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let bank_dir = dir.path().join("bank");
    bank::generate(&cal, &bank_dir, &common::options(400, 200), &Quiet).unwrap();
    let syn = wheelflat::train::synthesize_train(
        &cal,
        &wheelflat::train::TrainSpec::twelve_bogies(wheelflat::train::default_flats(), 4),
    )
    .unwrap();
    let inbox = dir.path().join("inbox");
    let out = dir.path().join("out");
    std::fs::create_dir_all(&inbox).unwrap();
    // The trigger file first, then the recording; a broken pair; a trigger file still waiting
    // for its recording.
    drop_file(&inbox, "pass.triggers.csv", &syn.triggers_csv);
    drop_file(&inbox, "pass.csv", &syn.csv);
    drop_file(&inbox, "broken.triggers.csv", "time_s\n1.0\nabc\n");
    drop_file(&inbox, "broken.csv", &syn.csv);
    drop_file(&inbox, "later.triggers.csv", &syn.triggers_csv);
    let run = wheelflat()
        .args(["watch", "--once", "--bank"])
        .arg(&bank_dir)
        .arg("--inbox")
        .arg(&inbox)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success(), "{log}");
    // Every log line starts with its time in RFC 3339 (UTC, milliseconds), not epoch seconds.
    for line in log.lines() {
        let t = line.split(' ').next().unwrap();
        assert!(
            t.ends_with('Z') && t.len() == "2026-11-26T15:40:12.345Z".len(),
            "{line}"
        );
        chrono::DateTime::parse_from_rfc3339(t).unwrap_or_else(|e| panic!("{line}: {e}"));
    }
    assert!(
        log.contains("pass.csv ok") && log.contains("train of 12 bogies"),
        "{log}"
    );
    let result: wheelflat::train::TrainResult =
        serde_json::from_str(&std::fs::read_to_string(out.join("pass/train.json")).unwrap())
            .unwrap();
    assert_eq!(result.wheels.len(), 24);
    assert!(out.join("pass/train.csv").is_file() && out.join("pass/train.html").is_file());
    assert_eq!(
        names_in(&inbox.join("done")),
        vec!["pass.csv", "pass.triggers.csv"]
    );
    assert_eq!(
        names_in(&inbox.join("failed")),
        vec!["broken.csv", "broken.csv.error.txt", "broken.triggers.csv"]
    );
    let why = std::fs::read_to_string(inbox.join("failed/broken.csv.error.txt")).unwrap();
    assert!(why.contains("broken.triggers.csv"), "{why}");
    assert!(
        !out.join("broken").exists(),
        "no partial output for a failed pass"
    );
    assert_eq!(
        names_in(&inbox),
        vec!["done", "failed", "later.triggers.csv"]
    );
}
