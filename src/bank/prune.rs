//! `bank prune`: removes old versions of a bank, keeping the one `CURRENT` names.
//!
//! A version is removed only when it is complete (has a manifest), is not the one `CURRENT`
//! names, and is not among the `keep` newest complete versions (by manifest time; `CURRENT`'s
//! counts as one of them). Incomplete versions are left alone and listed: a run with the same
//! arguments resumes them. Prune takes the bank's writer lock, so it never races a generator
//! or a cluster job array. Running readers are not disturbed: `identify` and `watch` map the
//! files of the version they opened, and a removed file stays readable to whoever has it
//! mapped or open until they let go (POSIX); a reader that opens the bank while prune runs
//! reads `CURRENT`, whose version is never removed.

use super::lock::{lock, Access};
use super::schema::MANIFEST;
use super::version::resolve;
use super::BankError;
use std::path::{Path, PathBuf};

/// What a prune did and left.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Pruned {
    /// The version `CURRENT` names (kept).
    pub current: Option<PathBuf>,
    /// Complete versions kept besides it, newest first.
    pub kept: Vec<PathBuf>,
    /// Versions removed, with the bytes freed.
    pub removed: Vec<(PathBuf, u64)>,
    /// Incomplete versions left for a run to resume.
    pub incomplete: Vec<PathBuf>,
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> BankError + '_ {
    move |source| BankError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Removes complete versions of bank `dir` beyond the `keep` newest (`keep` ≥ 1; the version
/// `CURRENT` names is always kept).
pub fn prune(dir: &Path, keep: usize) -> Result<Pruned, BankError> {
    prune_keeping(dir, keep, &[])
}

/// [`prune`], keeping also the versions in `pinned` (a family's pins, which may lag the
/// member's `CURRENT` while the family is regenerated); they are listed as kept.
pub fn prune_keeping(dir: &Path, keep: usize, pinned: &[PathBuf]) -> Result<Pruned, BankError> {
    if keep == 0 {
        return Err(BankError::KeepNone);
    }
    let _lock = lock(dir, Access::Exclusive)?;
    let current = super::version::read_current(dir)?
        .map(|_| resolve(dir).map(|c| c.version))
        .transpose()?;
    let mut complete: Vec<(std::time::SystemTime, PathBuf)> = Vec::new();
    let mut out = Pruned {
        current: current.clone(),
        ..Pruned::default()
    };
    for entry in std::fs::read_dir(dir).map_err(io(dir))? {
        let entry = entry.map_err(io(dir))?;
        let path = entry.path();
        let name = entry.file_name().to_string_lossy().to_string();
        if !name.starts_with("v-") || !path.is_dir() || Some(&path) == current.as_ref() {
            continue;
        }
        if pinned.contains(&path) {
            out.kept.push(path);
            continue;
        }
        match std::fs::metadata(path.join(MANIFEST)).and_then(|m| m.modified()) {
            Ok(t) => complete.push((t, path)),
            Err(_) => out.incomplete.push(path),
        }
    }
    complete.sort_by(|a, b| b.0.cmp(&a.0).then(a.1.cmp(&b.1)));
    let others = keep - usize::from(current.is_some());
    for (i, (_, path)) in complete.into_iter().enumerate() {
        if i < others {
            out.kept.push(path);
            continue;
        }
        let mut bytes = 0;
        for f in std::fs::read_dir(&path).map_err(io(&path))? {
            let f = f.map_err(io(&path))?;
            bytes += f.metadata().map(|m| m.len()).unwrap_or(0);
        }
        // The manifest first: an interrupted prune leaves an incomplete version (never read,
        // listed next time), not a complete-looking one with files missing.
        std::fs::remove_file(path.join(MANIFEST)).map_err(io(&path))?;
        std::fs::remove_dir_all(&path).map_err(io(&path))?;
        out.removed.push((path, bytes));
    }
    out.incomplete.sort();
    Ok(out)
}
