//! The input files of a pass, read within their bounds, and the bank or family a pass is
//! compared with: opened, with the member its speed and load pick.

use super::PassError;
use crate::identify::detect::family::Members;
use crate::identify::{Identifier, Measurement};
use crate::model::{Calibration, CheckedCalibration};
use std::path::{Path, PathBuf};

/// Size limits of the files wheelflat reads (bytes): a 5-sensor, 10 s measurement at 2.5 kHz
/// is about 2 MB, a whole train's recording a few times that, a calibration a few kB.
pub const MAX_MEASUREMENT_BYTES: u64 = 64 << 20;
/// A trigger file: one line per wheel.
pub const MAX_TRIGGER_BYTES: u64 = 1 << 20;
/// A calibration file, a truth file.
pub const MAX_SMALL_FILE_BYTES: u64 = 1 << 20;
/// An identification.json (its series and candidate model set).
pub const MAX_JSON_BYTES: u64 = 256 << 20;

/// Why a file could not be read as text within its bound; each names the file and what it
/// was to be.
#[derive(Debug, thiserror::Error)]
pub enum InputError {
    /// The file could not be opened or read.
    #[error("cannot read {what} {}", path.display())]
    Unreadable {
        /// What the file was to be ("measurement", "calibration file", …).
        what: &'static str,
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// A device, pipe or directory.
    #[error("{what} {} is not a regular file (a device, pipe or directory cannot be read as one)", path.display())]
    NotAFile {
        /// What the file was to be.
        what: &'static str,
        /// The path.
        path: PathBuf,
    },
    /// Larger than its bound.
    #[error("{what} {}: {len} bytes, more than the {limit} a {what} may have", path.display())]
    TooLarge {
        /// What the file was to be.
        what: &'static str,
        /// The file.
        path: PathBuf,
        /// Its size.
        len: u64,
        /// The bound.
        limit: u64,
    },
    /// Grew past its bound while it was read.
    #[error("{what} {} grew past {limit} bytes while it was read", path.display())]
    Grew {
        /// What the file was to be.
        what: &'static str,
        /// The file.
        path: PathBuf,
        /// The bound.
        limit: u64,
    },
}

/// Reads a text file that must be a regular file of at most `limit` bytes: a device, a pipe or
/// a directory (`/dev/zero` would read forever) and an oversized file are refused, naming the
/// file, before anything is read.
pub fn read_text(path: &Path, limit: u64, what: &'static str) -> Result<String, InputError> {
    let unreadable = |source| InputError::Unreadable {
        what,
        path: path.to_path_buf(),
        source,
    };
    let meta = std::fs::metadata(path).map_err(unreadable)?;
    if !meta.is_file() {
        return Err(InputError::NotAFile {
            what,
            path: path.to_path_buf(),
        });
    }
    if meta.len() > limit {
        return Err(InputError::TooLarge {
            what,
            path: path.to_path_buf(),
            len: meta.len(),
            limit,
        });
    }
    let mut text = String::new();
    use std::io::Read as _;
    std::fs::File::open(path)
        .and_then(|f| f.take(limit + 1).read_to_string(&mut text))
        .map_err(unreadable)?;
    if text.len() as u64 > limit {
        return Err(InputError::Grew {
            what,
            path: path.to_path_buf(),
            limit,
        });
    }
    Ok(text)
}

/// Reads and checks a calibration file, or returns the built-in defaults.
pub fn load_calibration(path: Option<&Path>) -> Result<CheckedCalibration, PassError> {
    let Some(path) = path else {
        return Calibration::default()
            .check()
            .map_err(|e| PassError::Defaults(Box::new(e)));
    };
    let text = read_text(path, MAX_SMALL_FILE_BYTES, "calibration file")?;
    let in_file = |source| PassError::Calibration {
        path: path.to_path_buf(),
        source: Box::new(source),
    };
    Calibration::from_toml_str(&text)
        .map_err(in_file)?
        .check()
        .map_err(in_file)
}

/// Opens a bank or bank family for identification, with the settings of `calibration` when
/// given.
pub fn open_members(bank_dir: &Path, calibration: Option<&Path>) -> Result<Members, PassError> {
    let settings = match calibration {
        Some(p) => Some(load_calibration(Some(p))?.identification.clone()),
        None => None,
    };
    Members::open(bank_dir, settings).map_err(|source| PassError::OpenBank {
        path: bank_dir.to_path_buf(),
        source: Box::new(source),
    })
}

/// Reads a measurement on the family's sample rate, with its speed stated (its line or
/// `speed`); the member its speed, then the load its record shows, pick, opened (a speed
/// outside the band names the file). `nearest`: the nearest member however far (diagnosis).
pub fn read_measurement(
    members: &mut Members,
    path: &Path,
    speed: Option<f64>,
    nearest: bool,
) -> Result<(Measurement, usize), PassError> {
    let text = read_text(path, MAX_MEASUREMENT_BYTES, "measurement")?;
    let mut m = Measurement::from_csv(path, &text, members.family().sample_rate_hz)?;
    let v = m.pass_speed(speed)?;
    m.speed_km_per_h = Some(v);
    let k = members
        .member_for_pass(&m, None, nearest)
        .map_err(|source| PassError::NoMember {
            path: path.to_path_buf(),
            source: Box::new(source),
        })?;
    Ok((m, k))
}

/// Opens the bank a measurement is compared with and reads the measurement: for a family, the
/// member at the pass's speed (the CSV's `# speed_km_per_h` line, or `speed` when it has
/// none; never assumed). The settings and uncertainty table come from `calibration` when
/// given, else from the bank. `nearest` as for [`read_measurement`].
pub fn open_identifier(
    bank_dir: &Path,
    measured: &Path,
    calibration: Option<&Path>,
    speed: Option<f64>,
    nearest: bool,
) -> Result<(Identifier, Measurement), PassError> {
    let mut members = open_members(bank_dir, calibration)?;
    let (m, k) = read_measurement(&mut members, measured, speed, nearest)?;
    Ok((members.take(k), m))
}
