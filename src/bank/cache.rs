//! How a table derived from a bank (`bank::derived`) is stored beside its shards: by a
//! process answering a pass, at its best; by `bank generate`, as part of what it builds.

use super::BankError;
use std::path::Path;

/// What a failed write of a table means.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Store {
    /// A process answering a pass: a bank it cannot write only costs the time again.
    BestEffort,
    /// `bank generate`: the table is part of what it builds, so a failed write is its error.
    Required,
}

impl Store {
    /// Writes `bytes` to `path` atomically, as this mode says.
    pub(crate) fn write(self, path: &Path, bytes: &[u8]) -> Result<(), BankError> {
        match crate::atomic::write_atomically(path, bytes) {
            Err(source) if self == Store::Required => Err(BankError::Io {
                path: path.to_path_buf(),
                source,
            }),
            _ => Ok(()),
        }
    }
}
