//! Shared by the integration tests that need a small bank.

use std::path::PathBuf;
use wheelflat::bank::{self, GenerateOptions, Quiet, StorageFormat};
use wheelflat::model::{Calibration, CheckedCalibration};

/// Builds (or finds up to date) a bank of `instances` for `cal` under the test target's
/// temporary folder, `shard_size` instances per file; returns its directory. Call it once per
/// test binary (behind a `OnceLock`): tests run in parallel and must not build side by side.
pub fn build_bank(
    cal: &CheckedCalibration,
    name: &str,
    instances: usize,
    shard_size: usize,
) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    let opts = GenerateOptions {
        instances,
        seed: 0,
        shard_size,
        machine_shard: None,
        format: StorageFormat::default(),
        simulate_missing: true,
    };
    bank::generate(cal, &dir, &opts, &Quiet).unwrap();
    dir
}

/// The CI-sized identification calibration ([`Calibration::narrow_profile`]).
#[allow(dead_code)] // not every test binary uses it
pub fn narrow_calibration() -> CheckedCalibration {
    Calibration::narrow_profile().check().unwrap()
}
