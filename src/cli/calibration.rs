//! `wheelflat calibration`: the built-in calibration of a profile as TOML.

use super::args::Profile;
use super::write_file;
use crate::model::Calibration;
use anyhow::Result;
use std::path::Path;

/// Prints the profile's calibration, or writes it to `out`.
pub(super) fn run(out: Option<&Path>, profile: Profile) -> Result<()> {
    let text = match profile {
        Profile::Paper => Calibration::default(),
        Profile::Train => Calibration::train_profile(),
        Profile::Narrow => Calibration::narrow_profile(),
    }
    .to_toml_string();
    match out {
        Some(p) => write_file(p, text.as_bytes()),
        None => {
            print!("{text}");
            Ok(())
        }
    }
}
