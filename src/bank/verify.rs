//! `bank verify`: every file of a bank checked against its manifest, in full.

use super::layout::{derive, Derived};
use super::schema::{open_shard, sha256_hex, Manifest};
use super::schema::{shard_file_name, FORMAT_VERSION, MANIFEST};
use super::version::{read_current, read_layout, read_manifest, read_neighbours, resolve};
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
/// naming this bank and its place in it; the neighbour graph; the column layout against the
/// footers; the departures table when one is stored), the manifest against `CURRENT` and against itself (format, instance count, shard
/// names and ranges). Returns the problems found (empty: the bank is intact).
pub fn verify(dir: &Path) -> Result<(Manifest, Vec<VerifyProblem>), BankError> {
    let current = resolve(dir)?;
    let version = current.version.clone();
    let manifest = read_manifest(&version)?;
    let mut problems = Vec::new();
    let manifest_path = version.join(MANIFEST);
    let mut problem = |path: &Path, message: String| {
        problems.push(VerifyProblem {
            path: path.to_path_buf(),
            message,
        })
    };
    if read_current(dir)?.is_some() {
        match &current.manifest_sha256 {
            None => problem(
                &dir.join(super::schema::CURRENT),
                "states no manifest hash (written by an earlier wheelflat): `wheelflat bank generate` with the bank's arguments adds it".into(),
            ),
            Some(want) => {
                let got = std::fs::read(&manifest_path)
                    .map(|b| super::schema::sha256_hex(&b))
                    .unwrap_or_default();
                if &got != want {
                    problem(&manifest_path, format!("sha256 {got}, CURRENT says {want}"));
                }
            }
        }
    }
    if manifest.format_version != FORMAT_VERSION {
        problem(
            &manifest_path,
            format!(
                "format {}, this wheelflat reads {FORMAT_VERSION}",
                manifest.format_version
            ),
        );
    }
    let rows: usize = manifest.files.iter().map(|f| f.rows).sum();
    if rows != manifest.instances || manifest.files.is_empty() {
        problem(
            &manifest_path,
            format!(
                "{} instances, but its {} shard files hold {rows}",
                manifest.instances,
                manifest.files.len()
            ),
        );
    }
    let mut first = 0;
    for (i, f) in manifest.files.iter().enumerate() {
        let name = shard_file_name(i, manifest.files.len());
        if f.name != name || f.first_instance != first {
            problem(
                &manifest_path,
                format!(
                    "entry {i} is {} from instance {}; expected {name} from instance {first}",
                    f.name, f.first_instance
                ),
            );
        }
        first += f.rows;
    }
    let mut footers = Vec::with_capacity(manifest.files.len());
    // Instances as read per stored one (a folded bank's shifts; its neighbour graph spans them).
    let mut fold_factor = 1;
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
            Ok((bytes, meta, bank_meta)) => {
                let footer_rows = meta.metadata().file_metadata().num_rows() as usize;
                let place = bank_meta.shard;
                fold_factor = bank_meta.calibration.fold_factor();
                let mismatch = if bank_meta.bank_id != manifest.bank_id {
                    Some(format!(
                        "belongs to bank {}, the manifest is bank {}",
                        bank_meta.bank_id, manifest.bank_id
                    ))
                } else if bank_meta.calibration_sha256 != manifest.calibration_sha256 {
                    Some("its calibration hash differs from the manifest's".to_string())
                } else if place.index != index
                    || place.count != manifest.files.len()
                    || place.first_instance != f.first_instance
                    || place.rows != f.rows
                    || footer_rows != f.rows
                    || bank_meta.instances != manifest.instances
                {
                    Some(format!(
                        "holds shard {} of {} (instances {}.., {} rows; {footer_rows} in its footer) of a {}-instance bank; the manifest lists it as shard {index} of {} (instances {}.., {} rows) of {}",
                        place.index,
                        place.count,
                        place.first_instance,
                        place.rows,
                        bank_meta.instances,
                        manifest.files.len(),
                        f.first_instance,
                        f.rows,
                        manifest.instances
                    ))
                } else {
                    None
                };
                if let Some(message) = mismatch {
                    problems.push(VerifyProblem {
                        path: path.clone(),
                        message,
                    });
                }
                footers.push((index, path, bytes, meta));
            }
        }
    }
    if let Some(aux) = &manifest.neighbours {
        if let Err(e) = read_neighbours(
            &version,
            aux,
            &manifest.bank_id,
            manifest.instances * fold_factor,
        ) {
            problems.push(VerifyProblem {
                path: version.join(&aux.name),
                message: e.to_string(),
            });
        }
    }
    // The departures table is a cache, not in the manifest; when present it must still be this
    // bank's and whole (identification would recompute a damaged one, but a damaged file is
    // worth knowing about).
    for name in [
        super::departures::DEPARTURES_FILE,
        super::departures::AVERAGED_DEPARTURES_FILE,
    ] {
        let departures = version.join(name);
        if let Ok(bytes) = std::fs::read(&departures) {
            if let Err(message) = super::departures::check(
                &bytes,
                &manifest.bank_id,
                manifest.instances * fold_factor,
            ) {
                problems.push(VerifyProblem {
                    path: departures,
                    message: format!(
                        "the departures table (a cache; delete it to have it rebuilt): {message}"
                    ),
                });
            }
        }
    }
    // The roughness table is a cache too (bank::roughness): when present, whole and this bank's.
    let roughness = version.join(super::roughness::ROUGHNESS_FILE);
    if let Ok(text) = std::fs::read_to_string(&roughness) {
        if let Err(message) = super::roughness::decode(&text, &manifest.bank_id) {
            problems.push(VerifyProblem {
                path: roughness,
                message: format!(
                    "the roughness table (a cache; delete it to have it rebuilt): {message}"
                ),
            });
        }
    } else if roughness.exists() {
        problems.push(VerifyProblem {
            path: roughness,
            message: "the roughness table (a cache; delete it to have it rebuilt) is not text"
                .into(),
        });
    }
    // The out-of-round basis is a cache too (bank::out_of_round): when present, whole and this
    // bank's.
    let basis = version.join(super::out_of_round::OUT_OF_ROUND_FILE);
    if let Ok(bytes) = std::fs::read(&basis) {
        if let Err(message) = super::out_of_round::decode(&bytes, &manifest.bank_id, None) {
            problems.push(VerifyProblem {
                path: basis,
                message: format!(
                    "the out-of-round basis (a cache; delete it to have it rebuilt): {message}"
                ),
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
