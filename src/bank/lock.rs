//! The writer lock of a bank directory: one generator at a time.
//!
//! `bank generate` and `bank merge` hold an exclusive advisory lock (`flock`) on
//! `DIR/.writer.lock` while they work; the `--shard I/N` tasks of a cluster job array hold a
//! shared one, so that the tasks of one array run side by side but no whole-bank run (or
//! `bank prune`) starts while any of them is writing. The kernel releases the lock when the
//! process ends, however it ends, so a killed run never leaves the bank locked. A second
//! writer is refused at once with an error naming the directory. (On a cluster the bank
//! directory must be on a file system whose locks reach every node: NFSv4 and Lustre with
//! `flock` mounts do; a local disk or a file system without them does not coordinate nodes.)

use super::BankError;
use std::fs::{File, OpenOptions, TryLockError};
use std::path::Path;

/// The lock file's name in a bank directory.
pub const LOCK_FILE: &str = ".writer.lock";

/// A held lock; released when dropped (or when the process ends).
#[derive(Debug)]
pub struct WriterLock {
    _file: File,
}

/// Whether a lock excludes everyone (a whole-bank run, prune) or only whole-bank runs (one
/// task of a job array).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Access {
    /// Generate, merge, prune.
    Exclusive,
    /// One `--shard I/N` task.
    Shared,
}

/// Takes the writer lock of bank directory `dir` (created if needed), or refuses at once.
pub fn lock(dir: &Path, access: Access) -> Result<WriterLock, BankError> {
    let path = dir.join(LOCK_FILE);
    let file = OpenOptions::new()
        .read(true)
        .write(true)
        .create(true)
        .truncate(false)
        .open(&path)
        .map_err(|source| BankError::Io {
            path: path.clone(),
            source,
        })?;
    let taken = match access {
        Access::Exclusive => file.try_lock(),
        Access::Shared => file.try_lock_shared(),
    };
    match taken {
        Ok(()) => Ok(WriterLock { _file: file }),
        Err(TryLockError::WouldBlock) => Err(BankError::Locked {
            dir: dir.to_path_buf(),
            holder: match access {
                Access::Exclusive => "another `wheelflat bank generate`, `merge` or `prune`, or the tasks of a cluster job array,",
                Access::Shared => "a `wheelflat bank generate`, `merge` or `prune` of the whole bank",
            }
            .to_string(),
        }),
        Err(TryLockError::Error(source)) => Err(BankError::Io { path, source }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writers_exclude_each_other_and_tasks_share() {
        let dir = tempfile::tempdir().unwrap();
        let a = lock(dir.path(), Access::Exclusive).unwrap();
        let err = lock(dir.path(), Access::Exclusive).unwrap_err().to_string();
        assert!(err.contains("is being written"), "{err}");
        assert!(lock(dir.path(), Access::Shared).is_err());
        drop(a);
        let t1 = lock(dir.path(), Access::Shared).unwrap();
        let t2 = lock(dir.path(), Access::Shared).unwrap();
        assert!(lock(dir.path(), Access::Exclusive).is_err());
        drop((t1, t2));
        lock(dir.path(), Access::Exclusive).unwrap();
    }
}
