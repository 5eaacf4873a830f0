//! The memory-mapped bank reader: the identifier's hot path.
//!
//! [`Bank::open`] maps every shard file (`memmap2`, wrapped in `bytes::Bytes` without a copy)
//! and parses each footer once. [`Bank::read_columns`] then decodes only the projected columns
//! (`ProjectionMask`) straight from the mapped pages.

pub use super::schema::Parameters;
use super::schema::{
    open_shard, open_sibling_shard, parquet_err, sha256_hex, BankMetadata, Manifest, ManifestAux,
    ManifestFile, CURRENT, FORMAT_VERSION, MANIFEST, PARAMETER_COLUMNS,
};
use super::BankError;
use arrow_array::{Array, Float32Array, Float64Array, UInt32Array};
use bytes::Bytes;
use parquet::arrow::arrow_reader::{
    ArrowReaderMetadata, ParquetRecordBatchReader, ParquetRecordBatchReaderBuilder, RowSelection,
    RowSelector,
};
use parquet::arrow::ProjectionMask;
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// One mapped shard file.
#[derive(Debug, Clone)]
struct ShardFile {
    path: PathBuf,
    bytes: Bytes,
    meta: ArrowReaderMetadata,
    rows: usize,
}

impl ShardFile {
    /// A reader of the columns `sorted` (ascending schema indices), all rows in one batch,
    /// decoding straight from the mapped bytes.
    fn projected(&self, sorted: &[usize]) -> Result<ParquetRecordBatchReader, BankError> {
        let schema = self.meta.metadata().file_metadata().schema_descr();
        let mask = ProjectionMask::roots(schema, sorted.iter().copied());
        ParquetRecordBatchReaderBuilder::new_with_metadata(self.bytes.clone(), self.meta.clone())
            .with_projection(mask)
            .with_batch_size(self.rows.max(1))
            .build()
            .map_err(parquet_err(&self.path))
    }
}

/// An open bank.
#[derive(Debug, Clone)]
pub struct Bank {
    dir: PathBuf,
    manifest: Manifest,
    metadata: BankMetadata,
    files: Vec<ShardFile>,
    /// The stored neighbour graph, checked at open (`None` for banks written without one).
    neighbours: Option<Vec<u32>>,
}

/// One instance as stored: its parameter columns and its force series.
#[derive(Debug, Clone, PartialEq)]
pub struct StoredInstance {
    /// Instance number.
    pub instance: u32,
    /// L (mm), d (mm), c (mm), X_p (m), L0 (mm), flat wheel (0 leading, 1 trailing), as
    /// stored.
    pub parameters: [f64; PARAMETER_COLUMNS.len()],
    /// Force samples (kN) per sensor axis, in the bank's axis order.
    pub forces_kn: Vec<Vec<f32>>,
}

/// The version directory a bank path designates: `DIR/CURRENT`'s target, or `DIR` itself when
/// it holds a manifest.
pub fn resolve_version(dir: &Path) -> Result<PathBuf, BankError> {
    let current = dir.join(CURRENT);
    if current.is_file() {
        let name = std::fs::read_to_string(&current).map_err(|source| BankError::Io {
            path: current.clone(),
            source,
        })?;
        return Ok(dir.join(name.trim()));
    }
    if dir.join(MANIFEST).is_file() {
        return Ok(dir.to_path_buf());
    }
    Err(BankError::NotABank {
        dir: dir.to_path_buf(),
    })
}

/// Reads the neighbour graph a manifest lists and checks it: size and SHA-256 against the
/// manifest, header against the bank.
fn read_neighbours(
    version: &Path,
    aux: &ManifestAux,
    bank_id: &str,
    instances: usize,
) -> Result<Vec<u32>, BankError> {
    let path = version.join(&aux.name);
    let bytes = std::fs::read(&path).map_err(|source| BankError::Io {
        path: path.clone(),
        source,
    })?;
    if bytes.len() as u64 != aux.bytes {
        return Err(BankError::Corrupt {
            path,
            message: format!("{} bytes, the manifest says {}", bytes.len(), aux.bytes),
        });
    }
    let sum = sha256_hex(&bytes);
    if sum != aux.sha256 {
        return Err(BankError::Corrupt {
            path,
            message: format!("sha256 {sum}, the manifest says {}", aux.sha256),
        });
    }
    super::neighbours::decode(&path, &bytes, bank_id, instances)
}

/// Reads a version directory's manifest.
pub fn read_manifest(version: &Path) -> Result<Manifest, BankError> {
    let path = version.join(MANIFEST);
    let text = std::fs::read_to_string(&path).map_err(|source| BankError::Io {
        path: path.clone(),
        source,
    })?;
    serde_json::from_str(&text).map_err(|e| BankError::Corrupt {
        path,
        message: e.to_string(),
    })
}

impl Bank {
    /// Opens a bank (a bank directory with `CURRENT`, or a version directory), maps its shard
    /// files and parses their footers once.
    pub fn open(dir: &Path) -> Result<Bank, BankError> {
        let version = resolve_version(dir)?;
        let manifest = read_manifest(&version)?;
        let Some(first) = manifest.files.first() else {
            return Err(BankError::Corrupt {
                path: version.join(MANIFEST),
                message: "lists no shard files".into(),
            });
        };
        // The first shard in full (the bank's metadata and schema), the others against it, in
        // parallel; each checked against the manifest before it is used.
        let check = |path: &Path, bytes: &Bytes, f: &ManifestFile, id: &str, format: u32| {
            if bytes.len() as u64 != f.bytes {
                return Err(BankError::Corrupt {
                    path: path.to_path_buf(),
                    message: format!("{} bytes, the manifest says {}", bytes.len(), f.bytes),
                });
            }
            if id != manifest.bank_id {
                return Err(BankError::Corrupt {
                    path: path.to_path_buf(),
                    message: format!(
                        "bank id {id} does not match the manifest's {}",
                        manifest.bank_id
                    ),
                });
            }
            if format != FORMAT_VERSION {
                return Err(BankError::Corrupt {
                    path: path.to_path_buf(),
                    message: format!(
                        "bank format {format} — this wheelflat reads format {FORMAT_VERSION}; regenerate the bank with `wheelflat bank generate`"
                    ),
                });
            }
            Ok(())
        };
        let path = version.join(&first.name);
        let (bytes, meta, bank_meta) = open_shard(&path)?;
        check(
            &path,
            &bytes,
            first,
            &bank_meta.bank_id,
            bank_meta.format_version,
        )?;
        let head = ShardFile {
            path,
            bytes,
            meta,
            rows: first.rows,
        };
        let rest: Vec<ShardFile> = manifest.files[1..]
            .par_iter()
            .map(|f| {
                let path = version.join(&f.name);
                let (bytes, meta, identity) = open_sibling_shard(&path, &head.meta)?;
                check(&path, &bytes, f, &identity.bank_id, identity.format_version)?;
                Ok(ShardFile {
                    path,
                    bytes,
                    meta,
                    rows: f.rows,
                })
            })
            .collect::<Result<_, BankError>>()?;
        let files: Vec<ShardFile> = std::iter::once(head).chain(rest).collect();
        let instances = files.iter().map(|f| f.rows).sum();
        let neighbours = manifest
            .neighbours
            .as_ref()
            .map(|aux| read_neighbours(&version, aux, &manifest.bank_id, instances))
            .transpose()?;
        Ok(Bank {
            dir: version,
            manifest,
            metadata: bank_meta,
            files,
            neighbours,
        })
    }

    /// The neighbour graph stored with the bank, checked against the manifest's SHA-256 and
    /// the bank id ([`super::neighbours`]); `None` for a bank written without one.
    pub fn neighbours(&self) -> Option<&[u32]> {
        self.neighbours.as_deref()
    }

    /// The version directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The bank's metadata (from its first shard file; all files share it but for `shard`).
    pub fn metadata(&self) -> &BankMetadata {
        &self.metadata
    }

    /// The manifest.
    pub fn manifest(&self) -> &Manifest {
        &self.manifest
    }

    /// Number of instances.
    pub fn instances(&self) -> usize {
        self.files.iter().map(|f| f.rows).sum()
    }

    /// Schema index of a column name.
    pub fn column_index(&self, name: &str) -> Option<usize> {
        self.files[0].meta.schema().index_of(name).ok()
    }

    /// Schema index of sample `k` of sensor number `s`.
    pub fn sample_index(&self, s: usize, k: usize) -> usize {
        super::schema::sample_column_index(&self.metadata.sensors, s, k)
    }

    fn read_projected<F: FnMut(usize, &dyn Array)>(
        &self,
        indices: &[usize],
        mut sink: F,
    ) -> Result<(), BankError> {
        let mut sorted: Vec<usize> = indices.to_vec();
        sorted.sort_unstable();
        sorted.dedup();
        for file in &self.files {
            let reader = file.projected(&sorted)?;
            for batch in reader {
                let batch = batch.map_err(|e| BankError::Corrupt {
                    path: file.path.clone(),
                    message: e.to_string(),
                })?;
                for (pos, &col) in sorted.iter().enumerate() {
                    sink(col, batch.column(pos).as_ref());
                }
            }
        }
        Ok(())
    }

    /// Reads f32 sample columns (schema indices) for every instance: one vector per requested
    /// column, in the order asked, each in instance order. Allocates the result; see
    /// [`Bank::read_columns_into`] for the hot path.
    pub fn read_columns(&self, indices: &[usize]) -> Result<Vec<Vec<f32>>, BankError> {
        let mut out = Vec::new();
        self.read_columns_into(indices, &mut out)?;
        Ok(out)
    }

    /// [`Bank::read_columns`] into caller-provided buffers, reused across calls (a fresh
    /// 12 MB allocation per call costs more in page faults than the decoding itself). Shard
    /// files are decoded in parallel on the current rayon pool, each straight into its own
    /// slice of the output.
    pub fn read_columns_into(
        &self,
        indices: &[usize],
        out: &mut Vec<Vec<f32>>,
    ) -> Result<(), BankError> {
        let mut sorted: Vec<usize> = indices.to_vec();
        sorted.sort_unstable();
        sorted.dedup();
        let n = self.instances();
        out.resize_with(indices.len(), Vec::new);
        // Decode into the first `sorted.len()` buffers, then arrange them in the order asked.
        let mut columns: Vec<Vec<f32>> = std::mem::take(out);
        columns.truncate(indices.len());
        for c in columns.iter_mut() {
            c.resize(n, 0.0);
        }
        // Per file, its rows of every column.
        let mut slots: Vec<Vec<&mut [f32]>> = self
            .files
            .iter()
            .map(|_| Vec::with_capacity(sorted.len()))
            .collect();
        for col in columns[..sorted.len()].iter_mut() {
            let mut rest = col.as_mut_slice();
            for (file_slots, file) in slots.iter_mut().zip(&self.files) {
                let (head, tail) = rest.split_at_mut(file.rows);
                file_slots.push(head);
                rest = tail;
            }
        }
        self.files
            .par_iter()
            .zip(slots.par_iter_mut())
            .try_for_each(|(file, file_slots)| -> Result<(), BankError> {
                let reader = file.projected(&sorted)?;
                let mut offset = 0;
                for batch in reader {
                    let batch = batch.map_err(|e| BankError::Corrupt {
                        path: file.path.clone(),
                        message: e.to_string(),
                    })?;
                    for (pos, slot) in file_slots.iter_mut().enumerate() {
                        let values = batch
                            .column(pos)
                            .as_any()
                            .downcast_ref::<Float32Array>()
                            .ok_or_else(|| {
                                BankError::Invalid(format!(
                                    "column {} is not a force-sample column",
                                    sorted[pos]
                                ))
                            })?;
                        let len = values.len();
                        if offset + len > slot.len() {
                            return Err(BankError::Corrupt {
                                path: file.path.clone(),
                                message: format!("more rows than the manifest's {}", file.rows),
                            });
                        }
                        slot[offset..offset + len].copy_from_slice(values.values());
                    }
                    offset += batch.num_rows();
                }
                if offset != file.rows {
                    return Err(BankError::Corrupt {
                        path: file.path.clone(),
                        message: format!("{offset} rows, the manifest says {}", file.rows),
                    });
                }
                Ok(())
            })?;
        // Back to the order asked: decoded column `pos` goes to its first slot, later duplicates
        // get copies, spare buffers fill the rest.
        let spare = columns.split_off(sorted.len());
        let mut decoded: Vec<Option<Vec<f32>>> = columns.into_iter().map(Some).collect();
        let mut spare = spare.into_iter();
        let mut first_slot = vec![usize::MAX; sorted.len()];
        for (slot, &col) in indices.iter().enumerate() {
            let pos = sorted
                .binary_search(&col)
                .expect("every index is in the sorted set");
            match decoded[pos].take() {
                Some(v) => {
                    first_slot[pos] = slot;
                    out.push(v);
                }
                None => {
                    let mut v = spare.next().unwrap_or_default();
                    v.clear();
                    v.extend_from_slice(&out[first_slot[pos]]);
                    out.push(v);
                }
            }
        }
        Ok(())
    }

    /// Reads one whole instance (row `instance`: rows are stored in instance order), decoding
    /// only that row of its shard file.
    pub fn read_instance(&self, instance: usize) -> Result<StoredInstance, BankError> {
        let n = self.instances();
        if instance >= n {
            return Err(BankError::Invalid(format!(
                "instance {instance} is not in the bank (it holds instances 0 to {})",
                n.saturating_sub(1)
            )));
        }
        let mut row = instance;
        let file = self
            .files
            .iter()
            .find(|f| {
                if row < f.rows {
                    true
                } else {
                    row -= f.rows;
                    false
                }
            })
            .expect("the row is within the files' rows");
        let corrupt = |message: String| BankError::Corrupt {
            path: file.path.clone(),
            message,
        };
        let reader = ParquetRecordBatchReaderBuilder::new_with_metadata(
            file.bytes.clone(),
            file.meta.clone(),
        )
        .with_row_selection(RowSelection::from(vec![
            RowSelector::skip(row),
            RowSelector::select(1),
        ]))
        .build()
        .map_err(parquet_err(&file.path))?;
        let mut batches = Vec::new();
        for batch in reader {
            batches.push(batch.map_err(|e| corrupt(e.to_string()))?);
        }
        let batch = match batches.as_slice() {
            [b] if b.num_rows() == 1 => b,
            _ => return Err(corrupt(format!("row {row} could not be read"))),
        };
        let number = batch
            .column(0)
            .as_any()
            .downcast_ref::<UInt32Array>()
            .map(|a| a.value(0))
            .ok_or_else(|| corrupt("the instance column is not u32".into()))?;
        if number as usize != instance {
            return Err(corrupt(format!(
                "row {row} holds instance {number}, expected {instance}"
            )));
        }
        let mut parameters = [0.0; PARAMETER_COLUMNS.len()];
        for (k, p) in parameters.iter_mut().enumerate() {
            *p = batch
                .column(1 + k)
                .as_any()
                .downcast_ref::<Float64Array>()
                .map(|a| a.value(0))
                .ok_or_else(|| corrupt(format!("`{}` is not f64", PARAMETER_COLUMNS[k])))?;
        }
        let mut col = 1 + PARAMETER_COLUMNS.len();
        let mut forces_kn = Vec::with_capacity(self.metadata.sensors.len());
        for axis in &self.metadata.sensors {
            let mut v = Vec::with_capacity(axis.samples);
            for _ in 0..axis.samples {
                let value = batch
                    .column(col)
                    .as_any()
                    .downcast_ref::<Float32Array>()
                    .map(|a| a.value(0))
                    .ok_or_else(|| corrupt(format!("column {col} is not a force sample")))?;
                v.push(value);
                col += 1;
            }
            forces_kn.push(v);
        }
        Ok(StoredInstance {
            instance: number,
            parameters,
            forces_kn,
        })
    }

    /// Reads the parameter columns of every instance.
    pub fn read_parameters(&self) -> Result<Parameters, BankError> {
        let mut p = Parameters::default();
        let cols: Vec<usize> = (0..=PARAMETER_COLUMNS.len()).collect();
        self.read_projected(&cols, |col, array| {
            if col == 0 {
                if let Some(a) = array.as_any().downcast_ref::<UInt32Array>() {
                    p.instance.extend_from_slice(a.values());
                }
                return;
            }
            if let Some(a) = array.as_any().downcast_ref::<Float64Array>() {
                let target = match col {
                    1 => &mut p.length_mm,
                    2 => &mut p.depth_mm,
                    3 => &mut p.curvature_mm,
                    4 => &mut p.impact_position_m,
                    5 => &mut p.l0_mm,
                    _ => {
                        p.flat_wheel.extend(a.values().iter().map(|&w| w as u8));
                        return;
                    }
                };
                target.extend_from_slice(a.values());
            }
        })?;
        Ok(p)
    }
}

/// One problem found by [`verify`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct VerifyProblem {
    /// The file.
    pub path: PathBuf,
    /// What is wrong.
    pub message: String,
}

/// Checks every file of a bank against its manifest (presence, size, SHA-256, readable footer
/// naming this bank). Returns the problems found (empty: the bank is intact).
pub fn verify(dir: &Path) -> Result<(Manifest, Vec<VerifyProblem>), BankError> {
    let version = resolve_version(dir)?;
    let manifest = read_manifest(&version)?;
    let mut problems = Vec::new();
    for f in &manifest.files {
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
        if let Err(e) = open_shard(&path) {
            problems.push(VerifyProblem {
                path,
                message: e.to_string(),
            });
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
    Ok((manifest, problems))
}
