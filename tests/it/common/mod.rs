//! Shared by the integration tests: the binary under test, the small calibrations, banks
//! built once per test run, and listing the files of a folder.

use assert_cmd::Command;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::{Duration, Instant};
use wheelflat::bank::{self, GenerateOptions, Quiet, StorageFormat};
use wheelflat::model::{Calibration, CheckedCalibration};

/// Path of the `wheelflat` binary that Cargo built for these tests (for
/// `std::process::Command` and for scripts that read it from `$WHEELFLAT`).
pub fn wheelflat_path() -> PathBuf {
    PathBuf::from(env!("CARGO_BIN_EXE_wheelflat"))
}

/// The `wheelflat` binary as an `assert_cmd` command.
pub fn wheelflat() -> Command {
    Command::new(wheelflat_path())
}

/// `wheelflat identify --bank BANK --measured MEASURED --out OUT --db DB`, which must succeed.
pub fn identify_into_db(bank: &Path, measured: &Path, out: &Path, db: &Path) {
    let o = wheelflat()
        .args(["identify", "--bank"])
        .arg(bank)
        .arg("--measured")
        .arg(measured)
        .arg("--out")
        .arg(out)
        .arg("--db")
        .arg(db)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// `serve`'s settings for `db` and the site's bank `bank`, at the default class limits.
pub fn serve_settings(db: &Path, bank: &Path) -> wheelflat::serve::Settings {
    wheelflat::serve::Settings {
        db: db.to_path_buf(),
        bank: Some(bank.to_path_buf()),
        limits_l0_mm: [25.0, 40.0],
        limits_dynamic_ratio: [2.0, 3.0],
        phi: 0.95,
        token: None,
    }
}

/// The paper's calibration ([`Calibration::paper_profile`]) with `window_samples`-sample
/// windows per sensor: short windows keep banks small and fast to build.
pub fn small_calibration(window_samples: usize) -> Calibration {
    let mut c = Calibration::paper_profile();
    c.output.window_samples = window_samples;
    c
}

/// The CI-sized identification calibration ([`Calibration::narrow_profile`]).
pub fn narrow_calibration() -> CheckedCalibration {
    Calibration::narrow_profile()
        .check()
        .expect("the narrow profile is valid")
}

/// Writes `cal` as a calibration file `track.toml` in `dir` (the same text as `wheelflat
/// calibration` prints) and returns its path.
pub fn write_calibration(cal: &Calibration, dir: &Path) -> PathBuf {
    let path = dir.join("track.toml");
    std::fs::write(&path, cal.to_toml_string()).unwrap();
    path
}

/// Bank generation options: `instances` from seed 0, `shard_size` instances per file, the
/// default storage format, on one machine.
pub fn options(instances: usize, shard_size: usize) -> GenerateOptions {
    GenerateOptions {
        instances,
        seed: 0,
        shard_size,
        machine_shard: None,
        format: StorageFormat::default(),
        simulate_missing: true,
        // The tables a pass needs are left to the first pass that needs them (as a bank of an
        // earlier wheelflat is served): most test banks answer few passes, and their build
        // (~80 simulations) would cost more than it saves. Built with the bank and checked in
        // `bank::a_bank_is_built_with_the_tables_a_pass_needs_and_a_first_pass_builds_nothing`.
        tables: false,
    }
}

/// A bank in the test target's temporary folder and the calibration it was built from.
pub type CachedBank = (PathBuf, CheckedCalibration);

/// The bank `name` of `instances` for the calibration `cal` gives, `shard_size` instances per
/// file, under the test target's temporary folder: built (or found up to date from an earlier
/// run) on the first call in this test binary, then shared. Tests run in parallel and must not
/// build a bank side by side, so builds hold one lock; `name` must be unique across test
/// binaries (they may run at the same time) and name one configuration.
pub fn cached_bank(
    name: &str,
    cal: impl FnOnce() -> CheckedCalibration,
    instances: usize,
    shard_size: usize,
) -> &'static CachedBank {
    static BANKS: Mutex<Vec<(String, usize, usize, &'static CachedBank)>> = Mutex::new(Vec::new());
    let cal = cal();
    // A test that panicked while holding the lock left the list as it was: still usable.
    let mut banks = BANKS.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(&(_, i, s, bank)) = banks.iter().find(|(n, ..)| n == name) {
        assert!(
            (i, s) == (instances, shard_size) && bank.1.document() == cal.document(),
            "bank `{name}` asked for with two configurations"
        );
        return bank;
    }
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    bank::generate(&cal, &dir, &options(instances, shard_size), &Quiet).unwrap();
    let bank: &'static CachedBank = Box::leak(Box::new((dir, cal)));
    banks.push((name.to_string(), instances, shard_size, bank));
    bank
}

/// Every file under `dir` (recursively) as (path relative to `dir`, bytes), sorted by path.
/// Entries whose name starts with one of `skip` are left out, folders with all they hold.
pub fn files(dir: &Path, skip: &[&str]) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            let name = p.file_name().unwrap().to_string_lossy();
            if skip.iter().any(|s| name.starts_with(s)) {
                continue;
            }
            if p.is_dir() {
                stack.push(p);
            } else {
                out.push((
                    p.strip_prefix(dir).unwrap().to_path_buf(),
                    std::fs::read(&p).unwrap(),
                ));
            }
        }
    }
    out.sort();
    out
}

/// Writes a manifest into a bank's version directory the way a writer does: the manifest,
/// then, when `CURRENT` names this version, `CURRENT` with its hash (readers refuse a manifest
/// `CURRENT` does not vouch for).
pub fn write_manifest(version: &Path, manifest: &wheelflat::bank::Manifest) {
    let text = serde_json::to_string_pretty(manifest).unwrap();
    std::fs::write(version.join("manifest.json"), &text).unwrap();
    let name = version.file_name().unwrap().to_string_lossy().to_string();
    let bank = version.parent().unwrap();
    let current = std::fs::read_to_string(bank.join("CURRENT")).unwrap_or_default();
    if current.lines().next() == Some(name.as_str()) {
        std::fs::write(
            bank.join("CURRENT"),
            wheelflat::bank::current_text(&name, text.as_bytes()),
        )
        .unwrap();
    }
}

/// Whether this run is under CI, where the Python checks must run: `CI` set (to anything but
/// empty, `0` or `false`, as CI services set it) or `WHEELFLAT_PYTHON` set (by `.ci/run`).
pub fn under_ci() -> bool {
    let ci = std::env::var("CI").is_ok_and(|v| !matches!(v.trim(), "" | "0" | "false"));
    ci || std::env::var_os("WHEELFLAT_PYTHON").is_some()
}

/// The interpreter in `WHEELFLAT_PYTHON`, else `python3`, and why it cannot `import {modules}`
/// (`None` when it can).
pub fn python_with(modules: &str) -> (String, Option<String>) {
    let python = std::env::var("WHEELFLAT_PYTHON").unwrap_or_else(|_| "python3".into());
    let import = std::process::Command::new(&python)
        .args(["-c", &format!("import {modules}")])
        .output();
    let missing = match &import {
        Ok(out) if out.status.success() => None,
        // The last line of the traceback: the error itself.
        Ok(out) => Some(
            String::from_utf8_lossy(&out.stderr)
                .trim()
                .lines()
                .last()
                .unwrap_or("no error message")
                .to_string(),
        ),
        Err(e) => Some(format!("cannot run it: {e}")),
    };
    (python, missing)
}

/// A synthetic measurement of the narrow population: a seeded flat inside its ranges;
/// `with_trigger: false` leaves the alignment to cross-correlation.
pub fn narrow_measurement(cal: &CheckedCalibration, seed: u64, with_trigger: bool) -> String {
    let k = seed as f64;
    let flat = wheelflat::model::Flat::from_mm(
        45.0 + (k * 7.3) % 30.0,
        0.35 + (k * 0.037) % 0.2,
        0.03,
        12.32 + (k * 0.013) % 0.16,
    )
    .unwrap();
    wheelflat::identify::synth::synthesize(cal, &flat, seed, with_trigger)
        .unwrap()
        .csv
}

/// Waits until `cond` holds, at most `secs` seconds.
pub fn wait_for(secs: u64, what: &str, mut cond: impl FnMut() -> bool) {
    let t = Instant::now();
    while !cond() {
        assert!(
            t.elapsed() < Duration::from_secs(secs),
            "timed out waiting for {what}"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

pub fn names_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .map(|r| {
            r.map(|e| e.unwrap().file_name().to_string_lossy().to_string())
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// Drops a file into the inbox the way writers must: another name, then a rename.
pub fn drop_file(inbox: &Path, name: &str, text: &str) {
    let part = inbox.join(format!(".{name}.part"));
    std::fs::write(&part, text).unwrap();
    std::fs::rename(&part, inbox.join(name)).unwrap();
}

/// The lines `child` writes to its stdout, collected on a thread until it closes it.
pub fn collect_stdout(child: &mut std::process::Child) -> std::thread::JoinHandle<Vec<String>> {
    use std::io::BufRead;
    let out = child.stdout.take().expect("stdout piped");
    std::thread::spawn(move || {
        std::io::BufReader::new(out)
            .lines()
            .map(|l| l.unwrap())
            .collect()
    })
}

/// Whether at least `n` files of `inbox` were answered by `watch` (moved to `done/`, or to
/// `failed/` beside their `.error.txt`).
pub fn answered(inbox: &Path, n: usize) -> impl FnMut() -> bool {
    let (done, failed) = (inbox.join("done"), inbox.join("failed"));
    move || {
        let f = names_in(&failed)
            .iter()
            .filter(|n| !n.ends_with(".error.txt"))
            .count();
        names_in(&done).len() + f >= n
    }
}

/// SIGTERM to a child (`watch` and `ship --follow` stop cleanly on it), the signal sent.
pub fn terminate(child: &std::process::Child) {
    let sent = std::process::Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap()
        .success();
    assert!(sent, "SIGTERM to {}", child.id());
}
