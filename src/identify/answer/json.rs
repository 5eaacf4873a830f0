//! `identification.json`: the whole result as a monitoring system reads it, written beside
//! the result type — by `identify` (before any figure), the headless `watch`, and the report.

use crate::identify::answer::identification::Identification;
use std::path::{Path, PathBuf};

/// The result's file name in a pass's output folder.
pub const JSON_FILE: &str = "identification.json";

/// Why `identification.json` could not be written.
#[derive(Debug, thiserror::Error)]
pub enum WriteError {
    /// Creating the folder, or writing or renaming the file, failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The folder or file concerned.
        path: PathBuf,
        /// The underlying I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The identification could not be serialised to JSON.
    #[error("{}: cannot serialise the identification: {source}", path.display())]
    Json {
        /// The JSON file that was to be written.
        path: PathBuf,
        /// The serialiser's error.
        #[source]
        source: serde_json::Error,
    },
}

impl Identification {
    /// Writes `identification.json` (the whole result, pretty-printed) into `dir`, created
    /// with its parents if missing, atomically (a hidden temporary sibling, then a rename).
    /// Returns its path.
    pub fn write_json(&self, dir: &Path) -> Result<PathBuf, WriteError> {
        std::fs::create_dir_all(dir).map_err(|source| WriteError::Io {
            path: dir.to_path_buf(),
            source,
        })?;
        let path = dir.join(JSON_FILE);
        let json = serde_json::to_string_pretty(self).map_err(|source| WriteError::Json {
            path: path.clone(),
            source,
        })?;
        crate::atomic::write_atomically(&path, json.as_bytes()).map_err(|source| {
            WriteError::Io {
                path: path.clone(),
                source,
            }
        })?;
        Ok(path)
    }
}
