//! A kill campaign: `bank generate` killed with SIGKILL at seeded random moments, then run
//! again. After every kill no reader sees a partial bank (there is no `CURRENT`, or it names a
//! complete, checked version), the writer lock has gone with the process, and the finished
//! bank is byte-identical to one built without interruption. CI kills `WHEELFLAT_KILLS` times
//! (default 4); the campaign in docs/bank.md used 26.

mod common;

use common::{files, options, small_calibration, wheelflat_path, write_calibration};
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
    let mut state = 26u64;
    let mut killed_before_done = 0;
    for k in 0..kills {
        let bank_dir = dir.path().join(format!("killed-{k}"));
        let args = |cmd: &mut std::process::Command| {
            cmd.args([
                "bank",
                "generate",
                "--instances",
                "240",
                "--shard-size",
                "20",
            ])
            .arg("--calibration")
            .arg(&cal_file)
            .arg("--out")
            .arg(&bank_dir);
        };
        // Up to three kills of the same bank, each at a random moment up to 1.5 s in.
        for _ in 0..3 {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let wait_ms = 20 + (state >> 33) % 1500;
            let mut cmd = std::process::Command::new(wheelflat_path());
            args(&mut cmd);
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
        args(&mut cmd);
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
    println!("{kills} banks, {killed_before_done} kills before the run had finished");
    assert!(killed_before_done > 0, "no kill landed during a run");
}
