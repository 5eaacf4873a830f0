//! A kill campaign: `bank generate` killed with SIGKILL at seeded random moments of a run
//! (over 5–90 % of an uninterrupted run's time on the machine), then run again. After every
//! kill no reader sees a partial bank (there is no `CURRENT`, or it names a complete, checked
//! version), the writer lock has gone with the process, and the finished bank is
//! byte-identical to one built without interruption. CI kills `WHEELFLAT_KILLS` times (default
//! 4); the campaign in docs/bank.md used 26.

use crate::common::{files, options, small_calibration, wheelflat_path, write_calibration};
use std::time::Duration;
use wheelflat::bank::{self, Bank, Quiet};

#[test]
fn a_run_killed_at_any_moment_resumes_to_the_same_bytes_and_never_shows_a_partial_bank() {
    let kills: u64 = std::env::var("WHEELFLAT_KILLS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(4);
    let cal = small_calibration(40).check().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let reference = dir.path().join("reference");
    bank::generate(&cal, &reference, &options(240, 20), &Quiet).unwrap();
    let cal_file = write_calibration(cal.document(), dir.path());
    let args = |cmd: &mut std::process::Command, bank_dir: &std::path::Path| {
        cmd.args([
            "bank",
            "generate",
            "--defer-tables",
            "--instances",
            "240",
            "--shard-size",
            "20",
        ])
        .arg("--calibration")
        .arg(&cal_file)
        .arg("--out")
        .arg(bank_dir);
    };
    // How long an uninterrupted run takes on this machine today: the kills land at moments
    // drawn over 5–90 % of it (a fixed window let a fast machine finish before every kill).
    let timed = dir.path().join("timed");
    let t = std::time::Instant::now();
    let mut cmd = std::process::Command::new(wheelflat_path());
    args(&mut cmd, &timed);
    assert!(cmd.output().unwrap().status.success());
    let run_ms = t.elapsed().as_millis() as u64;
    // The CLI's uninterrupted run writes what the library writes.
    assert!(
        files(&timed, &[]) == files(&reference, &[]),
        "the uninterrupted CLI run differs from the reference"
    );
    let mut state = 26u64;
    let mut killed_before_done = 0;
    for k in 0..kills {
        let bank_dir = dir.path().join(format!("killed-{k}"));
        // Up to three kills of the same bank, each at a random moment of a run.
        for _ in 0..3 {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let wait_ms = run_ms / 20 + (state >> 33) % (run_ms * 17 / 20).max(1);
            let mut cmd = std::process::Command::new(wheelflat_path());
            args(&mut cmd, &bank_dir);
            let mut child = cmd
                .stdout(std::process::Stdio::null())
                .stderr(std::process::Stdio::null())
                .spawn()
                .unwrap();
            std::thread::sleep(Duration::from_millis(wait_ms));
            let finished = child.try_wait().unwrap().is_some();
            let _ = child.kill();
            child.wait().unwrap();
            if !finished {
                killed_before_done += 1;
            }
            // What a reader sees now: nothing, or the whole bank.
            match Bank::open(&bank_dir) {
                Ok(b) => assert_eq!(b.instances(), 240, "kill {k}: a partial bank is visible"),
                Err(e) => assert!(
                    matches!(e, bank::BankError::NotABank { .. }),
                    "kill {k} after {wait_ms} ms: {e}"
                ),
            }
        }
        // The lock went with the killed process: the next run resumes and finishes.
        let mut cmd = std::process::Command::new(wheelflat_path());
        args(&mut cmd, &bank_dir);
        let out = cmd.output().unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(
            files(&bank_dir, &[]) == files(&reference, &[]),
            "kill {k}: the resumed bank differs from the reference"
        );
    }
    println!(
        "{kills} banks, a run {run_ms} ms, {killed_before_done} kills before the run had finished"
    );
    assert!(killed_before_done > 0, "no kill landed during a run");
}
