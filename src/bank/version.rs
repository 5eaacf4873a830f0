//! A bank's version directory as a reader finds it: `CURRENT`, the manifest, and the files the
//! manifest lists beside the shards (neighbour graph, column layout), each checked before it
//! is used.
//!
//! `CURRENT` names the complete version readers use and, since the manifest became part of
//! what is checked, the manifest's SHA-256:
//!
//! ```text
//! v-1bc1deb19c07a902
//! manifest-sha256 3f2a…
//! ```
//!
//! The name must be a version directory of this bank (`v-` and letters, digits, `-` or `_`:
//! no path), and the manifest must hash to what `CURRENT` says, so a manifest edited, cut or
//! swapped after the bank was written is refused. A `CURRENT` of one line (banks written
//! before) is read without the check until `bank generate` with the bank's arguments
//! rewrites it. Writers replace the manifest first and `CURRENT` second; a reader that finds
//! them in between reads `CURRENT` again once.

use super::layout::Layout;
use super::schema::{sha256_hex, Manifest, ManifestAux, CURRENT, MANIFEST};
use super::BankError;
use bytes::Bytes;
use std::path::{Path, PathBuf};

/// The manifest line's key in `CURRENT`.
const MANIFEST_KEY: &str = "manifest-sha256";

/// What `CURRENT` says.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Current {
    /// The version directory.
    pub version: PathBuf,
    /// The manifest's SHA-256, hex (`None`: a `CURRENT` written before it was stored).
    pub manifest_sha256: Option<String>,
}

/// The text of `CURRENT` for a version and its manifest's bytes.
pub fn current_text(version_name: &str, manifest: &[u8]) -> String {
    format!("{version_name}\n{MANIFEST_KEY} {}\n", sha256_hex(manifest))
}

/// Reads `DIR/CURRENT` (`None` when there is none), checked: one version name of this bank,
/// then optionally the manifest's hash.
pub fn read_current(dir: &Path) -> Result<Option<Current>, BankError> {
    let path = dir.join(CURRENT);
    if !path.is_file() {
        return Ok(None);
    }
    let text = std::fs::read_to_string(&path).map_err(|source| BankError::Io {
        path: path.clone(),
        source,
    })?;
    parse_current(dir, &path, &text).map(Some)
}

/// A version pinned elsewhere (a family's `family.json`), checked as `CURRENT` is; `path`
/// names the pin in messages.
pub(crate) fn pinned(
    dir: &Path,
    path: &Path,
    version_name: &str,
    manifest_sha256: &str,
) -> Result<Current, BankError> {
    // The text always has its hash line, so the parsed pin always has a hash (or is refused).
    let text = format!("{version_name}\n{MANIFEST_KEY} {manifest_sha256}\n");
    parse_current(dir, path, &text)
}

/// The text of a `CURRENT` file of bank `dir` (read from `path`), checked.
fn parse_current(dir: &Path, path: &Path, text: &str) -> Result<Current, BankError> {
    let bad = |message: String| BankError::Corrupt {
        path: path.to_path_buf(),
        message,
    };
    let mut lines = text.lines().map(str::trim).filter(|l| !l.is_empty());
    let name = lines.next().unwrap_or_default();
    let plain = name.len() > 2
        && name.len() <= 64
        && name.starts_with("v-")
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_');
    if !plain {
        return Err(bad(format!(
            "`{}` is not a version of this bank (expected `v-<bank id>`, a directory beside CURRENT)",
            name.chars().take(80).collect::<String>()
        )));
    }
    let manifest_sha256 = match lines.next() {
        None => None,
        Some(line) => match line.split_once(' ') {
            Some((MANIFEST_KEY, hex))
                if hex.len() == 64 && hex.chars().all(|c| c.is_ascii_hexdigit()) =>
            {
                Some(hex.to_ascii_lowercase())
            }
            _ => {
                return Err(bad(format!(
                    "second line `{}` is not `{MANIFEST_KEY} <64 hex digits>`",
                    line.chars().take(80).collect::<String>()
                )))
            }
        },
    };
    if let Some(extra) = lines.next() {
        return Err(bad(format!(
            "unexpected line `{}`",
            extra.chars().take(80).collect::<String>()
        )));
    }
    Ok(Current {
        version: dir.join(name),
        manifest_sha256,
    })
}

/// The version directory a bank path designates — `DIR/CURRENT`'s target, or `DIR` itself
/// when it holds a manifest — with the manifest hash `CURRENT` states (none for a version
/// directory named directly).
pub(crate) fn resolve(dir: &Path) -> Result<Current, BankError> {
    if let Some(current) = read_current(dir)? {
        return Ok(current);
    }
    if dir.join(MANIFEST).is_file() {
        return Ok(Current {
            version: dir.to_path_buf(),
            manifest_sha256: None,
        });
    }
    Err(BankError::NotABank {
        dir: dir.to_path_buf(),
    })
}

/// The version a bank path designates and its manifest, checked against the hash `CURRENT`
/// states (read again once when a writer is between the two files).
pub(crate) fn open_manifest(dir: &Path) -> Result<(PathBuf, Manifest), BankError> {
    let mut attempt = 0;
    loop {
        let current = resolve(dir)?;
        match read_hashed(&current)? {
            Ok(manifest) => return Ok((current.version, manifest)),
            Err(_) if attempt == 0 => attempt += 1,
            Err((path, got, want)) => {
                return Err(BankError::Corrupt {
                    path,
                    message: format!("sha256 {got}, CURRENT says {want}"),
                })
            }
        }
    }
}

/// The manifest of a pinned version (a family member), checked against the pin's hash.
pub(crate) fn open_pinned_manifest(current: &Current) -> Result<Manifest, BankError> {
    manifest_as_stated(current, "the family manifest pins")
}

/// The manifest of `current`'s version, checked against the hash `current` states (`stated_by`
/// names who states it in the error).
pub(crate) fn manifest_as_stated(
    current: &Current,
    stated_by: &str,
) -> Result<Manifest, BankError> {
    read_hashed(current)?.map_err(|(path, got, want)| BankError::Corrupt {
        path,
        message: format!("sha256 {got}, {stated_by} {want}"),
    })
}

/// The manifest of `current`'s version, parsed when it hashes to what `current` states;
/// `Ok(Err((path, got, want)))` when it does not.
#[allow(clippy::type_complexity)]
fn read_hashed(
    current: &Current,
) -> Result<Result<Manifest, (PathBuf, String, String)>, BankError> {
    let (path, bytes) = manifest_bytes(&current.version)?;
    if let Some(want) = &current.manifest_sha256 {
        let got = sha256_hex(&bytes);
        if &got != want {
            return Ok(Err((path, got, want.clone())));
        }
    }
    parse_manifest(&path, &bytes).map(Ok)
}

fn parse_manifest(path: &Path, bytes: &[u8]) -> Result<Manifest, BankError> {
    serde_json::from_slice(bytes).map_err(|e| BankError::Corrupt {
        path: path.to_path_buf(),
        message: e.to_string(),
    })
}

/// Reads the neighbour graph a manifest lists and checks it: size and SHA-256 against the
/// manifest, header against the bank.
pub(crate) fn read_neighbours(
    version: &Path,
    aux: &ManifestAux,
    bank_id: &str,
    instances: usize,
) -> Result<super::neighbours::StoredGraph, BankError> {
    let (path, bytes) = read_aux(version, aux)?;
    super::neighbours::decode(&path, &bytes, bank_id, instances)
}

/// Reads the column layout a manifest lists and checks it against the manifest: size,
/// SHA-256, bank id, and every shard's rows and size.
pub(crate) fn read_layout(
    version: &Path,
    manifest: &Manifest,
) -> Result<Option<Layout>, BankError> {
    let Some(aux) = &manifest.layout else {
        return Ok(None);
    };
    let (path, bytes) = read_aux(version, aux)?;
    let layout = Layout::decode(&path, &bytes, &manifest.bank_id)?;
    let columns_match = manifest.files.len() == layout.shards.len()
        && manifest
            .files
            .iter()
            .zip(&layout.shards)
            .all(|(f, s)| f.rows == s.rows && f.bytes == s.file_bytes);
    if !columns_match {
        return Err(BankError::Corrupt {
            path,
            message: "its shards' rows or sizes differ from the manifest's".into(),
        });
    }
    Ok(Some(layout))
}

/// The instance column must hold 0, 1, …, N − 1 in order: shards listed twice, swapped or left
/// out of a manifest are refused here.
pub(crate) fn check_instance_order(version: &Path, instance: &[u32]) -> Result<(), BankError> {
    match instance.iter().enumerate().find(|&(i, &v)| v as usize != i) {
        None => Ok(()),
        Some((i, v)) => Err(BankError::Corrupt {
            path: version.join(MANIFEST),
            message: format!(
                "row {i} of the bank holds instance {v}: the shards it lists are out of order, repeated or missing"
            ),
        }),
    }
}

/// Reads a file the manifest lists beside the shards, checked against its size and SHA-256.
fn read_aux(version: &Path, aux: &ManifestAux) -> Result<(PathBuf, Bytes), BankError> {
    let path = version.join(&aux.name);
    // Mapped, not read: a fresh process then faults its pages in from the page cache a batch
    // at a time instead of touching a new heap buffer page by page (1.3 and 1.6 MB for the
    // 50k bank's layout and graph).
    let bytes = super::schema::map(&path)?;
    check_against_manifest(&path, &bytes, aux.bytes, &aux.sha256)?;
    Ok((path, bytes))
}

/// A file's bytes against the size and SHA-256 the manifest lists for it.
pub(crate) fn check_against_manifest(
    path: &Path,
    bytes: &[u8],
    size: u64,
    sha256: &str,
) -> Result<(), BankError> {
    let corrupt = |message: String| BankError::Corrupt {
        path: path.to_path_buf(),
        message,
    };
    if bytes.len() as u64 != size {
        return Err(corrupt(format!(
            "{} bytes, the manifest says {size}",
            bytes.len()
        )));
    }
    let sum = sha256_hex(bytes);
    if sum != sha256 {
        return Err(corrupt(format!("sha256 {sum}, the manifest says {sha256}")));
    }
    Ok(())
}

/// Reads a version directory's manifest (unchecked against `CURRENT`: for writers and for
/// `bank verify`, which checks it itself).
pub fn read_manifest(version: &Path) -> Result<Manifest, BankError> {
    let (path, bytes) = manifest_bytes(version)?;
    parse_manifest(&path, &bytes)
}

/// The SHA-256 of a version's manifest as it is on disk (for a `CURRENT` that states none).
pub(crate) fn manifest_sha256(version: &Path) -> Result<String, BankError> {
    Ok(sha256_hex(&manifest_bytes(version)?.1))
}

/// A version's manifest path and bytes.
fn manifest_bytes(version: &Path) -> Result<(PathBuf, Vec<u8>), BankError> {
    let path = version.join(MANIFEST);
    let bytes = std::fs::read(&path).map_err(|source| BankError::Io {
        path: path.clone(),
        source,
    })?;
    Ok((path, bytes))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn current_names_a_version_of_this_bank_and_its_manifest_hash() {
        let dir = tempfile::tempdir().unwrap();
        let write = |text: &str| std::fs::write(dir.path().join(CURRENT), text).unwrap();
        assert_eq!(read_current(dir.path()).unwrap(), None);
        write(&current_text("v-abc", b"{}"));
        let c = read_current(dir.path()).unwrap().unwrap();
        assert_eq!(c.version, dir.path().join("v-abc"));
        assert_eq!(c.manifest_sha256, Some(sha256_hex(b"{}")));
        // A CURRENT of one line (written before the hash was stored) is read without it.
        write("v-abc\n");
        assert_eq!(
            read_current(dir.path()).unwrap().unwrap().manifest_sha256,
            None
        );
        for bad in [
            "",
            "/elsewhere/v-abc\n",
            "../v-abc\n",
            "v-../x\n",
            "abc\n",
            "v-abc\nmanifest-sha256 xyz\n",
            "v-abc\nsomething else\n",
            &format!("{}extra\n", current_text("v-abc", b"{}")),
        ] {
            write(bad);
            let err = read_current(dir.path()).unwrap_err().to_string();
            assert!(err.contains("CURRENT"), "{bad:?}: {err}");
        }
    }
}
