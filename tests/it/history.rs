//! Issue 33, a wheel's history: passes stored in the results database by `identify`, `watch`
//! and `train` with `--db`, read back and fused by `history` (docs/history.md). CI-sized: the
//! narrow calibration, 2,000 instances.

use crate::common;
use crate::common::{cached_bank, narrow_calibration, wheelflat, wheelflat_path, CachedBank};
use std::path::Path;
use std::time::{Duration, Instant};
use wheelflat::history::{Db, DbError, Window};
use wheelflat::identify::synth::synthesize;
use wheelflat::model::Flat;

pub(crate) fn bank() -> &'static CachedBank {
    cached_bank("history-narrow", narrow_calibration, 2000, 500)
}

/// The truth of the history tests: L 62 mm, d 0.47 mm (L0 41.6 mm), c 0.03 mm.
const TRUTH: [f64; 3] = [62.0, 0.47, 0.03];

/// A pass of the truth struck at `x_p`, with the bogie id line, seeded errors per Eq. 1.
pub(crate) fn pass(x_p: f64, seed: u64, bogie: &str) -> String {
    let flat = Flat::from_mm(TRUTH[0], TRUTH[1], TRUTH[2], x_p).unwrap();
    let csv = synthesize(&bank().1, &flat, seed, true).unwrap().csv;
    format!("# bogie_id = {bogie}\n{csv}")
}

fn stdout_of(args: &[&str], db: &Path) -> String {
    let out = wheelflat().args(args).arg("--db").arg(db).output().unwrap();
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).to_string()
}

/// `identify --db`: the pass of `measured` against `bank`, stored in `db`; its output.
fn identify_stored(bank: &Path, measured: &Path, out: &Path, db: &Path) -> String {
    let [bank, measured, out] = [bank, measured, out].map(|p| p.to_str().unwrap());
    stdout_of(
        &[
            "identify",
            "--bank",
            bank,
            "--measured",
            measured,
            "--out",
            out,
        ],
        db,
    )
}

#[test]
fn the_database_refuses_a_file_that_is_not_its_schema_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let text = dir.path().join("notes.txt");
    std::fs::write(
        &text,
        "this is a text file, long enough to have a header of its own\n".repeat(20),
    )
    .unwrap();
    let e = Db::open(&text).err().expect("a text file is refused");
    assert!(matches!(e, DbError::NotOurs { .. }));
    assert!(
        e.to_string()
            .contains("notes.txt is not a wheelflat results database: not an SQLite file"),
        "{e}"
    );
    // The text file is left as it was.
    assert!(std::fs::read_to_string(&text)
        .unwrap()
        .starts_with("this is a text file"));

    let other = dir.path().join("other.sqlite");
    let c = rusqlite::Connection::open(&other).unwrap();
    c.execute_batch("CREATE TABLE t (x INTEGER); INSERT INTO t VALUES (1);")
        .unwrap();
    drop(c);
    let e = Db::open(&other)
        .err()
        .expect("another application's database is refused");
    assert!(
        e.to_string()
            .contains("an SQLite database of another application"),
        "{e}"
    );

    let newer = dir.path().join("newer.sqlite");
    drop(Db::open(&newer).unwrap());
    let c = rusqlite::Connection::open(&newer).unwrap();
    c.execute_batch("PRAGMA user_version = 9;").unwrap();
    drop(c);
    let e = Db::open(&newer).err().expect("a newer schema is refused");
    assert!(
        e.to_string()
            .contains("schema version 9, newer than this wheelflat's 3"),
        "{e}"
    );

    // `history` never makes a database; the command line names the file.
    let missing = dir.path().join("missing.sqlite");
    assert!(matches!(
        Db::open_existing(&missing),
        Err(DbError::Missing { .. })
    ));
    assert!(!missing.exists());
    let out = wheelflat()
        .arg("history")
        .arg("--db")
        .arg(&text)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("notes.txt is not a wheelflat results database"),
        "{err}"
    );
}

#[test]
fn identify_stores_each_pass_once_and_history_fuses_the_wheels_passes() {
    let (bank_dir, _) = bank();
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("results.sqlite");
    let places = [12.33, 12.41, 12.47];
    let mut files = Vec::new();
    for (k, x) in places.iter().enumerate() {
        let f = dir.path().join(format!("pass-{k}.csv"));
        std::fs::write(&f, pass(*x, 100 + k as u64, "B7")).unwrap();
        let out = identify_stored(bank_dir, &f, &dir.path().join(format!("out-{k}")), &db);
        assert!(
            out.contains("stored in") && out.contains("(bogie B7)"),
            "{out}"
        );
        assert!(out.contains("severity: "), "{out}");
        files.push(f);
    }
    // The same pass again is the same pass.
    let again = identify_stored(bank_dir, &files[0], &dir.path().join("again"), &db);
    assert!(again.contains("already in"), "{again}");
    assert_eq!(Db::open_existing(&db).unwrap().pass_count().unwrap(), 3);

    let list = wheelflat()
        .args(["history", "--db"])
        .arg(&db)
        .output()
        .unwrap();
    let list = String::from_utf8_lossy(&list.stdout);
    assert!(
        list.contains("3 passes, 2 named wheels") && list.contains("B7/trailing"),
        "{list}"
    );

    let out_dir = dir.path().join("hist");
    let text = wheelflat()
        .args(["history", "--rule", "all", "--wheel", "B7/trailing", "--db"])
        .arg(&db)
        .arg("--out")
        .arg(&out_dir)
        .output()
        .unwrap();
    assert!(
        text.status.success(),
        "{}",
        String::from_utf8_lossy(&text.stderr)
    );
    let text = String::from_utf8_lossy(&text.stdout);
    assert!(
        text.contains("wheel B7/trailing: 3 passes") && text.contains("joint: L0"),
        "{text}"
    );
    assert!(out_dir.join("history.png").is_file());
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out_dir.join("history.json")).unwrap())
            .unwrap();
    let joint = &json["joint"];
    let within = |key: &str, v: f64| {
        let r = &joint[key];
        r[0].as_f64().unwrap() <= v && v <= r[1].as_f64().unwrap()
    };
    // The truth is held (L and d inside the joint ranges) and, under the `all` rule, the
    // joint L0 range is no wider than the narrowest pass's, up to one grid bin of d (0.01 mm,
    // under 0.5 mm of L0).
    assert!(
        within("length_mm", TRUTH[0]) && within("depth_mm", TRUTH[1]),
        "{joint}"
    );
    let width = |r: &serde_json::Value| r[1].as_f64().unwrap() - r[0].as_f64().unwrap();
    let narrowest = json["passes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| width(&p["l0_mm"]))
        .fold(f64::INFINITY, f64::min);
    assert!(
        width(&joint["l0_mm"]) <= narrowest + 0.5,
        "{joint} vs {narrowest}"
    );
    assert_eq!(joint["rule"], "all");
    // The default rule (`robust`) keeps what two of the three allow: the truth too.
    let robust = wheelflat()
        .args(["history", "--wheel", "B7/trailing", "--db"])
        .arg(&db)
        .arg("--out")
        .arg(dir.path().join("robust"))
        .output()
        .unwrap();
    assert!(robust.status.success());
    let json: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("robust/history.json")).unwrap(),
    )
    .unwrap();
    let joint = &json["joint"];
    assert_eq!(joint["rule"], "robust");
    assert!(within_of(joint, "length_mm", TRUTH[0]) && within_of(joint, "depth_mm", TRUTH[1]));

    // The leading wheel: the flat is on the trailing one (the narrow population's wheel).
    let lead = wheelflat()
        .args(["history", "--wheel", "B7/leading", "--db"])
        .arg(&db)
        .output()
        .unwrap();
    let lead = String::from_utf8_lossy(&lead.stdout);
    assert!(lead.contains("none"), "{lead}");

    // A stored row altered behind wheelflat's back is refused, naming the pass, not fused.
    let broken = dir.path().join("broken.sqlite");
    std::fs::copy(&db, &broken).unwrap();
    let c = rusqlite::Connection::open(&broken).unwrap();
    c.execute(
        "UPDATE wheel_passes SET boxes = x'00010203' WHERE pass_id = 2 AND wheel = 'trailing'",
        [],
    )
    .unwrap();
    drop(c);
    let out = wheelflat()
        .args(["history", "--wheel", "B7/trailing", "--db"])
        .arg(&broken)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("broken.sqlite: pass 2: 4 bytes of cells are not whole, ordered boxes"),
        "{err}"
    );

    // An unknown wheel is named.
    let out = wheelflat()
        .args(["history", "--wheel", "B8/leading", "--db"])
        .arg(&db)
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("no pass of wheel `B8/leading`"));
}

fn within_of(joint: &serde_json::Value, key: &str, v: f64) -> bool {
    let r = &joint[key];
    r[0].as_f64().unwrap() <= v && v <= r[1].as_f64().unwrap()
}

#[test]
fn a_flat_that_grows_between_passes_is_reported_as_changed_not_as_an_empty_answer() {
    let (bank_dir, cal) = bank();
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("results.sqlite");
    // Two passes of a shallow flat (d 0.31 mm, L0 33.8 mm), then two of a deep one (d 0.59
    // mm, L0 46.6 mm): the wheel's flat grew between the second and the third pass.
    let flats = [
        (50.0, 0.31, 12.33),
        (52.0, 0.31, 12.45),
        (70.0, 0.59, 12.36),
        (72.0, 0.59, 12.44),
    ];
    for (k, (l, d, x)) in flats.iter().enumerate() {
        let flat = Flat::from_mm(*l, *d, 0.03, *x).unwrap();
        let csv = synthesize(cal, &flat, 40 + k as u64, true).unwrap().csv;
        let f = dir.path().join(format!("g{k}.csv"));
        std::fs::write(&f, format!("# bogie_id = G1\n{csv}")).unwrap();
        identify_stored(bank_dir, &f, &dir.path().join(format!("o{k}")), &db);
    }
    let out = dir.path().join("h");
    let text = wheelflat()
        .args(["history", "--wheel", "G1/trailing", "--db"])
        .arg(&db)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(text.status.success());
    let text = String::from_utf8_lossy(&text.stdout);
    assert!(
        text.contains("CHANGED: the flat grew after pass 2"),
        "{text}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("history.json")).unwrap()).unwrap();
    let joint = &json["joint"];
    assert_eq!(joint["agreement"]["kind"], "changed", "{joint}");
    assert_eq!(joint["passes_used"], serde_json::json!([2, 3]));
    // The answer is the deep flat's: its depth held, the class acted on urgent.
    assert!(within_of(joint, "depth_mm", 0.59), "{joint}");
    assert_eq!(joint["severity"]["highest"], "urgent");
}

/// Drops a file into the inbox the way writers must: another name, then a rename.
fn drop_file(inbox: &Path, name: &str, text: &str) {
    let part = inbox.join(format!(".{name}.part"));
    std::fs::write(&part, text).unwrap();
    std::fs::rename(&part, inbox.join(name)).unwrap();
}

#[test]
fn a_database_killed_while_watch_writes_keeps_whole_passes_each_once_and_serves_readers() {
    let (bank_dir, _) = bank();
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("results.sqlite");
    let inbox = dir.path().join("inbox");
    std::fs::create_dir_all(&inbox).unwrap();
    let passes = 24;
    for k in 0..passes {
        let x = 12.31 + 0.0075 * k as f64;
        drop_file(
            &inbox,
            &format!("p{k:02}.csv"),
            &pass(x, 500 + k as u64, &format!("B{}", k % 4)),
        );
    }
    // A reader reads the whole time.
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let reader = {
        let (db, stop) = (db.clone(), stop.clone());
        std::thread::spawn(move || {
            let mut reads = 0;
            while !stop.load(std::sync::atomic::Ordering::Relaxed) {
                if db.exists() {
                    let d = Db::open_existing(&db)
                        .expect("a reader opens the database while watch writes");
                    for w in d.wheels().expect("the wheels are read") {
                        d.wheel_passes(
                            &w.wheel_id,
                            Window {
                                last: 10,
                                hours: None,
                            },
                        )
                        .expect("a wheel's passes are read");
                    }
                    reads += 1;
                }
                std::thread::sleep(Duration::from_millis(5));
            }
            reads
        })
    };
    let watch = |once: bool| {
        let mut c = std::process::Command::new(wheelflat_path());
        c.args(["watch", "--poll-ms", "10", "--bank"])
            .arg(bank_dir)
            .arg("--inbox")
            .arg(&inbox)
            .arg("--out")
            .arg(dir.path().join("out"))
            .arg("--db")
            .arg(&db)
            .stdout(std::process::Stdio::null());
        if once {
            c.arg("--once");
        }
        c
    };
    // Killed (SIGKILL) six times in the middle of its work, at different moments.
    let done = inbox.join("done");
    let count = |d: &Path| std::fs::read_dir(d).map_or(0, |r| r.count());
    for round in 0..6 {
        let before = count(&done);
        let mut child = watch(false).spawn().unwrap();
        let t = Instant::now();
        // Until it has moved two more files (or 60 s), then a little more: 0–15 ms.
        while count(&done) < before + 2 && t.elapsed() < Duration::from_secs(60) {
            std::thread::sleep(Duration::from_millis(2));
        }
        std::thread::sleep(Duration::from_millis(3 * round as u64));
        child.kill().unwrap(); // SIGKILL
        child.wait().unwrap();
    }
    assert!(
        count(&done) < passes,
        "the kills came before the end of the work"
    );
    let status = watch(true).status().unwrap();
    assert!(status.success());
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    let reads = reader.join().unwrap();
    assert!(reads > 0);
    assert_eq!(count(&done), passes);

    let c = rusqlite::Connection::open(&db).unwrap();
    let ok: String = c
        .query_row("PRAGMA integrity_check", [], |r| r.get(0))
        .unwrap();
    assert_eq!(ok, "ok");
    let n: i64 = c
        .query_row("SELECT count(*) FROM passes", [], |r| r.get(0))
        .unwrap();
    assert_eq!(n as usize, passes, "every pass once");
    // Every pass whole: its two wheels.
    let partial: i64 = c
        .query_row(
            "SELECT count(*) FROM passes p WHERE (SELECT count(*) FROM wheel_passes w WHERE w.pass_id = p.id) != 2",
            [],
            |r| r.get(0),
        )
        .unwrap();
    assert_eq!(partial, 0);
    let per_wheel: i64 = c
        .query_row(
            "SELECT count(*) FROM wheel_passes WHERE wheel_id = 'B1/trailing'",
            [],
            |r| r.get(0),
        )
        .unwrap();
    assert_eq!(per_wheel as usize, passes / 4);
}

#[test]
fn the_maintenance_limits_are_settings() {
    let (bank_dir, cal) = bank();
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("p.csv");
    std::fs::write(&f, pass(12.4, 7, "B1")).unwrap();
    let mut doc = cal.document().clone();
    doc.maintenance = Some(wheelflat::model::calibration::MaintenanceParams {
        inspect_l0_mm: 60.0,
        urgent_l0_mm: 70.0,
        ..Default::default()
    });
    let strict = common::write_calibration(&doc, dir.path());
    let run = |cal: Option<&Path>| {
        let mut c = wheelflat();
        c.args(["identify", "--bank"])
            .arg(bank_dir)
            .arg("--measured")
            .arg(&f)
            .arg("--out")
            .arg(dir.path().join("o"));
        if let Some(p) = cal {
            c.arg("--calibration").arg(p);
        }
        let out = c.output().unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8_lossy(&out.stdout).to_string()
    };
    // The default limits (25 / 40 mm) call this 42 mm flat urgent at least in part; limits of
    // 60 / 70 mm call every L0 the narrow bank holds (up to 49 mm) monitor.
    assert!(run(None).contains("act as urgent") || run(None).contains("severity: urgent"));
    assert!(
        run(Some(&strict)).contains("severity: monitor"),
        "{}",
        run(Some(&strict))
    );
    // Limits out of order are refused, naming the key.
    let text = std::fs::read_to_string(&strict)
        .unwrap()
        .replace("inspect_l0_mm = 60.0", "inspect_l0_mm = 80.0");
    std::fs::write(&strict, text).unwrap();
    let out = wheelflat()
        .args(["history", "--db"])
        .arg(dir.path().join("none.sqlite"))
        .arg("--calibration")
        .arg(&strict)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("maintenance.inspect_l0_mm") || err.contains("no results database"),
        "{err}"
    );
}
