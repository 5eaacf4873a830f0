//! `bank verify`: every file of a bank checked against its manifest, in full.

use super::layout::{derive, Derived};
use super::reader::{read_layout, read_manifest, read_neighbours, resolve_version};
use super::schema::{open_shard, sha256_hex, Manifest};
use super::BankError;
use std::path::{Path, PathBuf};

/// One problem found by [`verify`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct VerifyProblem {
    /// The file.
    pub path: PathBuf,
    /// What is wrong.
    pub message: String,
}

/// Checks every file of a bank against its manifest (presence, size, SHA-256, readable footer
/// naming this bank; the neighbour graph; the column layout against the footers). Returns the
/// problems found (empty: the bank is intact).
pub fn verify(dir: &Path) -> Result<(Manifest, Vec<VerifyProblem>), BankError> {
    let version = resolve_version(dir)?;
    let manifest = read_manifest(&version)?;
    let mut problems = Vec::new();
    let mut footers = Vec::with_capacity(manifest.files.len());
    for (index, f) in manifest.files.iter().enumerate() {
        let path = version.join(&f.name);
        let bytes = match std::fs::read(&path) {
            Ok(b) => b,
            Err(e) => {
                problems.push(VerifyProblem {
                    path,
                    message: format!("cannot read: {e}"),
                });
                continue;
            }
        };
        if bytes.len() as u64 != f.bytes {
            problems.push(VerifyProblem {
                path,
                message: format!(
                    "truncated or extended: {} bytes, manifest says {}",
                    bytes.len(),
                    f.bytes
                ),
            });
            continue;
        }
        let sum = sha256_hex(&bytes);
        if sum != f.sha256 {
            problems.push(VerifyProblem {
                path,
                message: format!(
                    "checksum mismatch: sha256 {sum}, manifest says {}",
                    f.sha256
                ),
            });
            continue;
        }
        match open_shard(&path) {
            Err(e) => problems.push(VerifyProblem {
                path,
                message: e.to_string(),
            }),
            Ok((bytes, meta, _)) => footers.push((index, path, bytes, meta)),
        }
    }
    if let Some(aux) = &manifest.neighbours {
        if let Err(e) = read_neighbours(&version, aux, &manifest.bank_id, manifest.instances) {
            problems.push(VerifyProblem {
                path: version.join(&aux.name),
                message: e.to_string(),
            });
        }
    }
    // The layout: checked as the reader checks it, then every offset against the one the
    // shard's own footer gives (and the decoder confirms).
    if let Some(aux) = &manifest.layout {
        let path = version.join(&aux.name);
        match read_layout(&version, &manifest) {
            Err(e) => problems.push(VerifyProblem {
                path,
                message: e.to_string(),
            }),
            Ok(layout) => {
                let layout = layout.expect("the manifest lists it");
                // Shards with a problem of their own are reported above and not compared.
                for (s, shard_path, bytes, meta) in &footers {
                    let stored = layout.shards.get(*s);
                    let message = match derive(shard_path, bytes, meta) {
                        Err(e) => Some(e.to_string()),
                        Ok(Derived::NotApplicable(why)) => Some(format!(
                            "lists {}, which has no layout: {why}",
                            shard_path.display()
                        )),
                        Ok(Derived::Layout(l, widths)) => {
                            (stored != Some(&l) || widths != layout.widths).then(|| {
                                format!("{} does not match {}", aux.name, shard_path.display())
                            })
                        }
                    };
                    if let Some(message) = message {
                        problems.push(VerifyProblem {
                            path: path.clone(),
                            message,
                        });
                    }
                }
            }
        }
    }
    Ok((manifest, problems))
}
