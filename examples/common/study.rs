//! What the issue-11 study examples share: the arguments `BANK CASES SEED [same|finer] …`,
//! the bank, its calibration and the model the cases' measurements are simulated with.
// Each example compiles this module on its own and uses part of it.
#![allow(dead_code)]

use std::path::Path;
use wheelflat::bank::Bank;
use wheelflat::identify::coverage;
use wheelflat::model::CheckedCalibration;

/// A study's bank and cases.
pub struct Study {
    /// The bank.
    pub bank: Bank,
    /// Its calibration.
    pub cal: CheckedCalibration,
    /// The model the measurements are simulated with (the bank's, or the finer one).
    pub meas_cal: CheckedCalibration,
    /// Seeded cases.
    pub cases: usize,
    /// Their seed.
    pub seed: u64,
    args: Vec<String>,
}

impl Study {
    /// Reads `BANK CASES SEED [same|finer]` from the command line; `usage` names the rest.
    pub fn from_args(usage: &str) -> Study {
        let args: Vec<String> = std::env::args().collect();
        if args.len() < 4 {
            panic!("usage: {} BANK CASES SEED [same|finer] {usage}", args[0]);
        }
        let bank = Bank::open(Path::new(&args[1])).expect("bank");
        let cal = bank
            .metadata()
            .calibration
            .clone()
            .check()
            .expect("calibration");
        let finer = args.get(4).is_some_and(|s| s == "finer");
        Study {
            meas_cal: coverage::measurement_model(&cal, finer),
            cases: args[2].parse().expect("CASES"),
            seed: args[3].parse().expect("SEED"),
            bank,
            cal,
            args,
        }
    }

    /// Argument `i` (1-based, as on the command line) parsed, or `default` when absent.
    pub fn arg<T: std::str::FromStr>(&self, i: usize, default: T) -> T
    where
        T::Err: std::fmt::Debug,
    {
        self.args
            .get(i)
            .map_or(default, |s| s.parse().expect("a number"))
    }

    /// Whether argument `i` is `word`.
    pub fn flag(&self, i: usize, word: &str) -> bool {
        self.args.get(i).is_some_and(|s| s == word)
    }
}
