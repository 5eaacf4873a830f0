//! The newest nightly check (`calibrate --check --report BANK/calibration-DATE.json`, as
//! `scripts/regenerate-nightly.sh` writes it) read from the bank folder: what `serve`'s site
//! page and `/metrics` show, and what raises the calibration-drift alarm.

use crate::history::{Db, DbError, DriftLine};
use crate::site::drift::Drifted;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The largest check report read (a report is a few kilobytes).
const MAX_REPORT_BYTES: u64 = 16 << 20;

/// The newest `calibration-*.json` in a bank folder.
#[derive(Debug, Clone, Serialize)]
pub struct LastCheck {
    /// Its file name (the date the nightly script put in it).
    pub file: String,
    /// When it was written (Unix seconds), when the file system says.
    pub modified_s: Option<f64>,
    /// What drifted (empty: nothing); `None` for a report of `calibrate` without `--check`.
    pub drifted: Option<Vec<Drifted>>,
    /// Why it cannot be read, when it cannot.
    pub unreadable: Option<String>,
    /// Its bytes (what makes the drift alarm's key).
    #[serde(skip)]
    content: Vec<u8>,
}

/// The part of a report read.
#[derive(Deserialize)]
struct Report {
    #[serde(default)]
    check: Option<Vec<Drifted>>,
}

/// The newest `calibration-*.json` in `dir` (by name: the nightly script dates them), read.
pub fn newest_check(dir: &Path) -> Option<LastCheck> {
    let newest = std::fs::read_dir(dir)
        .ok()?
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with("calibration-") && n.ends_with(".json"))
        .max()?;
    let path = dir.join(&newest);
    let meta = std::fs::metadata(&path);
    let modified_s = modified_s(&path);
    // Err(String): why the report cannot be shown, on the page beside its name.
    let read = || -> Result<(Option<Vec<Drifted>>, Vec<u8>), String> {
        let bytes = meta.as_ref().map_err(|e| e.to_string())?.len();
        if bytes > MAX_REPORT_BYTES {
            return Err(format!(
                "{bytes} bytes, more than a report's {MAX_REPORT_BYTES}"
            ));
        }
        let content = std::fs::read(&path).map_err(|e| e.to_string())?;
        let r: Report =
            serde_json::from_slice(&content).map_err(|e| format!("not a report: {e}"))?;
        Ok((r.check, content))
    };
    Some(match read() {
        Ok((drifted, content)) => LastCheck {
            file: newest,
            modified_s,
            drifted,
            unreadable: None,
            content,
        },
        Err(e) => LastCheck {
            file: newest,
            modified_s,
            drifted: None,
            unreadable: Some(e),
            content: Vec::new(),
        },
    })
}

/// When `path` was last written (Unix seconds), when the file system says.
pub(crate) fn modified_s(path: &Path) -> Option<f64> {
    std::fs::metadata(path)
        .ok()?
        .modified()
        .ok()?
        .duration_since(std::time::UNIX_EPOCH)
        .ok()
        .map(|d| d.as_secs_f64())
}

/// Raises the calibration-drift alarm when the newest check in `bank_dir` found drift (once a
/// check: its key is the file's name and bytes); whether one was raised now.
pub fn raise_if_drifted(db: &mut Db, bank_dir: &Path) -> Result<bool, DbError> {
    let Some(check) = newest_check(bank_dir) else {
        return Ok(false);
    };
    let Some(drifted) = check.drifted.filter(|d| !d.is_empty()) else {
        return Ok(false);
    };
    let lines = drifted
        .into_iter()
        .map(|d| DriftLine {
            what: d.what,
            was: d.was,
            now: d.now,
        })
        .collect();
    db.raise_drift(&check.file, &check.content, lines)
}
