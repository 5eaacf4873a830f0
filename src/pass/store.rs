//! A pass in the results database: what makes it itself (its key), and storing it.

use super::PassError;
use crate::history::{Db, PassRecord};
use sha2::{Digest, Sha256};
use std::path::Path;

/// What makes a pass itself: the SHA-256 of its file(s), and `extra` (a bogie's place in a
/// train), in hex.
pub fn pass_key(files: &[&Path], extra: &str) -> Result<String, PassError> {
    let mut h = Sha256::new();
    for f in files {
        let bytes = std::fs::read(f).map_err(|source| PassError::Read {
            path: f.to_path_buf(),
            source,
        })?;
        h.update((bytes.len() as u64).to_le_bytes());
        h.update(&bytes);
    }
    h.update(extra.as_bytes());
    Ok(h.finalize().iter().map(|b| format!("{b:02x}")).collect())
}

/// Opens (or makes) the results database.
pub fn open_db(path: &Path) -> Result<Db, PassError> {
    Db::open(path).map_err(|e| PassError::OpenDb(Box::new(e)))
}

/// Stores one pass: whether it is new (`false`: the same pass was stored before).
pub fn store(db: &mut Db, rec: &PassRecord) -> Result<bool, PassError> {
    db.insert(rec).map_err(|source| PassError::Store {
        what: format!("the pass of {}", rec.meta.measurement),
        source: Box::new(source),
    })
}
