//! The tables a bank needs to answer a pass, built with the bank (docs/bank.md, "Built with
//! the bank"): the departures tables of both comparisons (the detection limit and the
//! departure rule), the roughness table of the calibration's rail, and the out-of-round basis.
//! Each is derived from the bank's contents or its calibration only, so it is built once,
//! when `bank generate` completes a version (or finds a complete one without them), before
//! `CURRENT` points at it: the first pass a bank sees is as fast as the hundredth.
//!
//! They stay caches, not part of the manifest: each file carries the bank id and a CRC-32 and
//! is checked when a process reads it; one that fails is computed again by the process that
//! needs it (and `bank verify` names it). A stated rail other than the bank's own (a
//! `--calibration` file of another site) has its roughness rows computed on first use.

use super::cache::Store;
use super::observer::GenerateObserver;
use super::reader::Bank;
use super::BankError;
use crate::model::average::BINOMIAL5;
use std::path::Path;
use std::time::Instant;

/// Builds every table of the complete version `version` that is missing or fails its checks,
/// telling `observer` each one built with its time; returns how many were built.
pub(crate) fn build(version: &Path, observer: &dyn GenerateObserver) -> Result<usize, BankError> {
    let bank = Bank::open(version)?;
    let rail = bank
        .metadata()
        .calibration
        .identification
        .rail_roughness
        .class();
    let mut built = 0;
    let mut note = |what: &str, file: &str, t: Instant, fresh: bool| {
        if fresh {
            observer.table_built(what, file, t.elapsed().as_secs_f64());
            built += 1;
        }
    };
    for (weights, file, what) in [
        (
            &[1.0][..],
            super::departures::DEPARTURES_FILE,
            "departures (detection limit, departure rule)",
        ),
        (
            &BINOMIAL5[..],
            super::departures::AVERAGED_DEPARTURES_FILE,
            "departures of the averaged predictions (rough passes)",
        ),
    ] {
        let t = Instant::now();
        let (_, fresh) = super::departures::load_or_build(&bank, weights, Store::Required)?;
        note(what, file, t, fresh);
    }
    let t = Instant::now();
    let (_, fresh) = super::roughness::load_or_build(&bank, rail, Store::Required)?;
    note(
        "roughness table (the calibration's rail)",
        super::roughness::ROUGHNESS_FILE,
        t,
        fresh,
    );
    let t = Instant::now();
    let (_, fresh) = super::out_of_round::load_or_build(&bank, Store::Required)?;
    note(
        "out-of-round basis",
        super::out_of_round::OUT_OF_ROUND_FILE,
        t,
        fresh,
    );
    Ok(built)
}
