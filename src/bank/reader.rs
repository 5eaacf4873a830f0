//! The memory-mapped bank reader: the identifier's hot path.
//!
//! [`Bank::open`] maps every shard file (`memmap2`, wrapped in `bytes::Bytes` without a copy).
//! A bank with a column layout ([`super::layout`], the default) is then read without parsing
//! any footer: a column is a checked slice of the mapped file. Other banks (compressed,
//! byte-stream-split, or written before the layout was stored) have each footer parsed once,
//! and [`Bank::read_columns`] decodes only the projected columns (`ProjectionMask`) from the
//! mapped pages.

use super::fold::Fold;
use super::layout::{f32_values, f64_values, u32_values, Layout};
pub use super::schema::Parameters;
use super::schema::{
    map, open_shard, open_sibling_shard, parquet_err, parse_bank_metadata, BankMetadata, Manifest,
    ManifestFile, FORMAT_VERSION, MANIFEST, PARAMETER_COLUMNS,
};
use super::version::{
    check_against_manifest, check_instance_order, open_manifest, read_layout, read_neighbours,
};
use super::BankError;
use arrow_array::{Array, Float32Array, Float64Array, UInt32Array};
use bytes::Bytes;
use parquet::arrow::arrow_reader::{
    ArrowReaderMetadata, ParquetRecordBatchReader, ParquetRecordBatchReaderBuilder,
};
use parquet::arrow::ProjectionMask;
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// One mapped shard file.
#[derive(Debug, Clone)]
pub(super) struct ShardFile {
    pub(super) path: PathBuf,
    pub(super) bytes: Bytes,
    /// The parsed footer; `None` when the bank is read through its layout.
    pub(super) meta: Option<ArrowReaderMetadata>,
    pub(super) rows: usize,
    /// The columns whose values this process has checked against the layout's CRC-32.
    pub(super) checked: Checked,
}

/// Which columns of a shard this process has checked against their CRC-32 (a bank read
/// through its layout). A version's files are never rewritten in place (every writer writes
/// a new file and renames it), so a column is checked at its first read in a process, not at
/// every read: `watch`'s next pass, or a pass's second read of a column, reads it unchecked
/// (docs/performance.md, "Identification speed"). `bank verify` checks every byte.
#[derive(Default)]
pub(super) struct Checked(std::sync::OnceLock<Vec<std::sync::atomic::AtomicU64>>);

// A copy of a bank checks its columns again at their first read (conservative and rare).
impl Clone for Checked {
    fn clone(&self) -> Checked {
        Checked::default()
    }
}

impl std::fmt::Debug for Checked {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let n: u32 = self.0.get().map_or(0, |b| {
            b.iter()
                .map(|w| w.load(std::sync::atomic::Ordering::Relaxed).count_ones())
                .sum()
        });
        write!(f, "Checked({n} columns)")
    }
}

impl Checked {
    fn bits(&self, columns: usize) -> &[std::sync::atomic::AtomicU64] {
        self.0.get_or_init(|| {
            (0..columns.div_ceil(64))
                .map(|_| std::sync::atomic::AtomicU64::new(0))
                .collect()
        })
    }

    /// Whether column `col` of `columns` was checked already.
    fn has(&self, col: usize, columns: usize) -> bool {
        self.bits(columns)[col / 64].load(std::sync::atomic::Ordering::Acquire) & (1 << (col % 64))
            != 0
    }

    /// Notes column `col` checked.
    fn note(&self, col: usize, columns: usize) {
        self.bits(columns)[col / 64]
            .fetch_or(1 << (col % 64), std::sync::atomic::Ordering::Release);
    }
}

impl ShardFile {
    /// A reader of the columns `sorted` (ascending schema indices), all rows in one batch,
    /// decoding straight from the mapped bytes (banks without a layout).
    fn projected(
        &self,
        meta: &ArrowReaderMetadata,
        sorted: &[usize],
    ) -> Result<ParquetRecordBatchReader, BankError> {
        let schema = meta.metadata().file_metadata().schema_descr();
        let mask = ProjectionMask::roots(schema, sorted.iter().copied());
        ParquetRecordBatchReaderBuilder::new_with_metadata(self.bytes.clone(), meta.clone())
            .with_projection(mask)
            .with_batch_size(self.rows.max(1))
            .build()
            .map_err(parquet_err(&self.path))
    }
}

/// An open bank.
#[derive(Debug, Clone)]
pub struct Bank {
    pub(super) dir: PathBuf,
    pub(super) manifest: Manifest,
    pub(super) metadata: BankMetadata,
    pub(super) files: Vec<ShardFile>,
    /// The stored neighbour graph, checked at open (`None` for banks written without one).
    pub(super) neighbours: Option<super::neighbours::StoredGraph>,
    /// The column layout, checked at open (`None`: read through the footers).
    pub(super) layout: Option<Layout>,
    /// A folded bank's view ([`super::fold`]; `None`: read as stored).
    pub(super) fold: Option<Fold>,
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

impl Bank {
    /// Opens a bank (a bank directory with `CURRENT`, or a version directory), maps its shard
    /// files and parses their footers once.
    pub fn open(dir: &Path) -> Result<Bank, BankError> {
        let (version, manifest) = open_manifest(dir)?;
        Bank::open_version(version, manifest)
    }

    /// Opens a pinned version (a family member): its manifest must hash to the pin.
    pub fn open_current(current: &super::version::Current) -> Result<Bank, BankError> {
        let manifest = super::version::open_pinned_manifest(current)?;
        Bank::open_version(current.version.clone(), manifest)
    }

    fn open_version(version: PathBuf, manifest: Manifest) -> Result<Bank, BankError> {
        let Some(first) = manifest.files.first() else {
            return Err(BankError::Corrupt {
                path: version.join(MANIFEST),
                message: "lists no shard files".into(),
            });
        };
        // Every file is checked against the manifest before it is used: its size, the bank id
        // and format its metadata states.
        let check_size = |path: &Path, bytes: &Bytes, f: &ManifestFile| {
            if bytes.len() as u64 != f.bytes {
                return Err(BankError::Corrupt {
                    path: path.to_path_buf(),
                    message: format!("{} bytes, the manifest says {}", bytes.len(), f.bytes),
                });
            }
            Ok(())
        };
        let check_identity = |path: &Path, id: &str, format: u32| {
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
        let layout = read_layout(&version, &manifest)?;
        let (bank_meta, files) = match &layout {
            Some(layout) => {
                // No footer: the metadata from the layout, every file checked against it.
                let path = version.join(&manifest.layout.as_ref().expect("listed").name);
                let bank_meta = parse_bank_metadata(&path, &layout.metadata_json)?;
                check_identity(&path, &bank_meta.bank_id, bank_meta.format_version)?;
                let samples: usize = bank_meta.sensors.iter().map(|a| a.samples).sum();
                let widths_match = layout.widths.len() == 1 + PARAMETER_COLUMNS.len() + samples
                    && layout.widths.iter().enumerate().all(|(j, &w)| {
                        w == if (1..=PARAMETER_COLUMNS.len()).contains(&j) {
                            8
                        } else {
                            4
                        }
                    });
                if !widths_match {
                    return Err(BankError::Corrupt {
                        path,
                        message: format!(
                            "{} columns do not match the bank's instance, {} parameter and {samples} sample columns",
                            layout.widths.len(),
                            PARAMETER_COLUMNS.len()
                        ),
                    });
                }
                let files = manifest
                    .files
                    .par_iter()
                    .enumerate()
                    .map(|(i, f)| {
                        let path = version.join(&f.name);
                        let bytes = map(&path)?;
                        check_size(&path, &bytes, f)?;
                        layout.check_file(i, &path, &bytes)?;
                        Ok(ShardFile {
                            path,
                            bytes,
                            meta: None,
                            rows: f.rows,
                            checked: Checked::default(),
                        })
                    })
                    .collect::<Result<Vec<_>, BankError>>()?;
                (bank_meta, files)
            }
            None => {
                // Without a layout there is no per-chunk checksum to check reads against: every
                // file is checked against the manifest's SHA-256 before its footer is parsed
                // (a damaged footer can ask for any allocation). Compressed banks, and plain
                // banks until `bank generate` adds their layout, pay this at every open.
                manifest.files.par_iter().try_for_each(|f| {
                    let path = version.join(&f.name);
                    check_against_manifest(&path, &map(&path)?, f.bytes, &f.sha256)
                })?;
                let path = version.join(&first.name);
                let (bytes, meta, bank_meta) = open_shard(&path)?;
                check_size(&path, &bytes, first)?;
                check_identity(&path, &bank_meta.bank_id, bank_meta.format_version)?;
                let rest: Vec<ShardFile> = manifest.files[1..]
                    .par_iter()
                    .map(|f| {
                        let path = version.join(&f.name);
                        let (bytes, meta, identity) = open_sibling_shard(&path, &meta)?;
                        check_size(&path, &bytes, f)?;
                        check_identity(&path, &identity.bank_id, identity.format_version)?;
                        Ok(ShardFile {
                            path,
                            bytes,
                            meta: Some(meta),
                            rows: f.rows,
                            checked: Checked::default(),
                        })
                    })
                    .collect::<Result<_, BankError>>()?;
                let head = ShardFile {
                    path,
                    bytes,
                    meta: Some(meta),
                    rows: first.rows,
                    checked: Checked::default(),
                };
                (bank_meta, std::iter::once(head).chain(rest).collect())
            }
        };
        let (bank_meta, fold) = Fold::of(bank_meta, &version)?;
        let stored: usize = files.iter().map(|f| f.rows).sum();
        let instances = stored * fold.as_ref().map_or(1, Fold::factor);
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
            layout,
            fold,
        })
    }

    /// The neighbour graph stored with the bank, checked against the manifest's SHA-256 and
    /// the bank id ([`super::neighbours`]); `None` for a bank written without one.
    pub fn neighbours(&self) -> Option<&[u32]> {
        self.neighbours.as_ref().map(|g| g.graph.as_slice())
    }

    /// The axis weights the stored neighbour graph was searched with
    /// ([`super::neighbours::cell_weights`]; [1; 4] for a graph of the earlier format).
    pub fn neighbour_weights(&self) -> Option<[f64; 4]> {
        self.neighbours.as_ref().map(|g| g.weights)
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

    /// Number of instances: those stored, times the whole-bay shifts of a folded bank.
    pub fn instances(&self) -> usize {
        self.stored_instances() * self.fold_factor()
    }

    /// Number of instances stored (rows of the shard files).
    pub fn stored_instances(&self) -> usize {
        self.files.iter().map(|f| f.rows).sum()
    }

    /// Presented instances per stored one: the whole-bay shifts of a folded bank plus one
    /// (1: not folded).
    pub fn fold_factor(&self) -> usize {
        self.fold.as_ref().map_or(1, Fold::factor)
    }

    /// Schema index of sample `k` of sensor number `s`.
    pub fn sample_index(&self, s: usize, k: usize) -> usize {
        super::schema::sample_column_index(&self.metadata.sensors, s, k)
    }

    /// A shard's parsed footer (banks without a layout have every footer parsed at open).
    pub(super) fn footer<'a>(
        &self,
        file: &'a ShardFile,
    ) -> Result<&'a ArrowReaderMetadata, BankError> {
        file.meta
            .as_ref()
            .ok_or_else(|| BankError::FooterNotParsed {
                path: file.path.clone(),
            })
    }

    /// Decodes the columns `indices` of every shard through the footers, handing each to
    /// `sink` (banks without a layout).
    fn read_projected<F: FnMut(usize, &dyn Array)>(
        &self,
        indices: &[usize],
        mut sink: F,
    ) -> Result<(), BankError> {
        let mut sorted: Vec<usize> = indices.to_vec();
        sorted.sort_unstable();
        sorted.dedup();
        for file in &self.files {
            let reader = file.projected(self.footer(file)?, &sorted)?;
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
    /// [`Bank::read_columns_flat`] for the hot path.
    pub fn read_columns(&self, indices: &[usize]) -> Result<Vec<Vec<f32>>, BankError> {
        let n = self.instances();
        let mut flat = vec![0.0f32; indices.len() * n];
        self.read_columns_flat(indices, &mut flat)?;
        Ok(flat.chunks(n.max(1)).map(<[f32]>::to_vec).collect())
    }

    /// [`Bank::read_columns`] into one caller-provided buffer of `indices.len() × instances`
    /// values, column `j` at `[j·N, (j+1)·N)`: the hot path reuses it across measurements (a
    /// fresh 12 MB allocation costs more in page faults than the copying itself). Shard files
    /// are read in parallel on the current rayon pool, each straight into its own slices.
    pub fn read_columns_flat(&self, indices: &[usize], out: &mut [f32]) -> Result<(), BankError> {
        match &self.fold {
            // Each presented column is its stored columns at shifts 0..=K, one after another:
            // the stored reads land exactly where the presented column's blocks go.
            Some(fold) => {
                let stored = fold.stored_columns(&self.metadata.sensors, indices)?;
                self.read_stored_columns(&stored, out)
            }
            None => self.read_stored_columns(indices, out),
        }
    }

    /// [`Bank::read_columns_flat`] over the stored columns and instances.
    fn read_stored_columns(&self, indices: &[usize], out: &mut [f32]) -> Result<(), BankError> {
        let n = self.stored_instances();
        if out.len() != indices.len() * n {
            return Err(BankError::BufferSize {
                values: out.len(),
                columns: indices.len(),
                instances: n,
            });
        }
        let mut sorted: Vec<usize> = indices.to_vec();
        sorted.sort_unstable();
        sorted.dedup();
        // Each distinct column is read into the slot of its first request, then copied to the
        // slots of any repeats.
        let first_slot: Vec<usize> = sorted
            .iter()
            .map(|c| indices.iter().position(|x| x == c).expect("asked for"))
            .collect();
        let mut by_slot: Vec<Option<&mut [f32]>> = out.chunks_mut(n.max(1)).map(Some).collect();
        let mut columns: Vec<&mut [f32]> = first_slot
            .iter()
            .map(|&slot| by_slot[slot].take().expect("one distinct column per slot"))
            .collect();
        // Per file, its rows of every column.
        let mut slots: Vec<Vec<&mut [f32]>> = self
            .files
            .iter()
            .map(|_| Vec::with_capacity(sorted.len()))
            .collect();
        for col in columns.iter_mut() {
            let mut rest: &mut [f32] = col;
            for (file_slots, file) in slots.iter_mut().zip(&self.files) {
                let (head, tail) = rest.split_at_mut(file.rows);
                file_slots.push(head);
                rest = tail;
            }
        }
        if let Some(layout) = &self.layout {
            // Slices of the mapped files: a copy per column and shard.
            self.files
                .par_iter()
                .zip(slots.par_iter_mut())
                .enumerate()
                .try_for_each(|(s, (_, file_slots))| {
                    for (slot, &col) in file_slots.iter_mut().zip(&sorted) {
                        f32_values(self.column_values(layout, s, col)?, slot);
                    }
                    Ok::<(), BankError>(())
                })?;
        } else {
            self.decode_columns(&sorted, &mut slots)?;
        }
        // Repeats: copies of their column's first slot.
        for (slot, &col) in indices.iter().enumerate() {
            let pos = sorted.binary_search(&col).expect("every index is sorted");
            let from = first_slot[pos];
            if from != slot {
                out.copy_within(from * n..(from + 1) * n, slot * n);
            }
        }
        Ok(())
    }

    /// The value bytes of stored force column `col` in shard `s` (every row), checked against the layout's CRC-32 at the column's first read in this process.
    pub(super) fn column_values<'a>(
        &'a self,
        layout: &Layout,
        s: usize,
        col: usize,
    ) -> Result<&'a [u8], BankError> {
        let file = &self.files[s];
        let columns = layout.widths.len();
        if col >= columns || layout.widths[col] != 4 || col == 0 {
            return Err(BankError::NotForceColumn { column: col });
        }
        if file.checked.has(col, columns) {
            return Ok(layout.values_unchecked(s, col, 0..file.rows, &file.bytes));
        }
        let bytes = layout.values(s, col, 0..file.rows, &file.bytes, &file.path)?;
        file.checked.note(col, columns);
        Ok(bytes)
    }

    /// The footer path of [`Bank::read_columns_flat`]: every shard's projected columns decoded
    /// into its slots, shards in parallel.
    fn decode_columns(
        &self,
        sorted: &[usize],
        slots: &mut [Vec<&mut [f32]>],
    ) -> Result<(), BankError> {
        self.files
            .par_iter()
            .zip(slots.par_iter_mut())
            .try_for_each(|(file, file_slots)| -> Result<(), BankError> {
                let reader = file.projected(self.footer(file)?, sorted)?;
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
                            .ok_or(BankError::NotForceColumn {
                                column: sorted[pos],
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
            })
    }

    /// Reads the parameter columns of every instance (a folded bank's at every shift).
    pub fn read_parameters(&self) -> Result<Parameters, BankError> {
        let p = self.read_stored_parameters()?;
        Ok(match &self.fold {
            Some(_) => super::fold::expand(p, &self.metadata.calibration),
            None => p,
        })
    }

    /// The parameter columns as stored.
    fn read_stored_parameters(&self) -> Result<Parameters, BankError> {
        let mut p = Parameters::default();
        if let Some(layout) = &self.layout {
            for (s, file) in self.files.iter().enumerate() {
                let col = |c: usize| layout.values(s, c, 0..file.rows, &file.bytes, &file.path);
                p.instance.extend(u32_values(col(0)?));
                p.length_mm.extend(f64_values(col(1)?));
                p.depth_mm.extend(f64_values(col(2)?));
                p.curvature_mm.extend(f64_values(col(3)?));
                p.impact_position_m.extend(f64_values(col(4)?));
                p.l0_mm.extend(f64_values(col(5)?));
                p.flat_wheel.extend(f64_values(col(6)?).map(|w| w as u8));
                p.peak_contact_kn.extend(f64_values(col(7)?));
            }
            check_instance_order(&self.dir, &p.instance)?;
            return Ok(p);
        }
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
                    6 => {
                        p.flat_wheel.extend(a.values().iter().map(|&w| w as u8));
                        return;
                    }
                    _ => &mut p.peak_contact_kn,
                };
                target.extend_from_slice(a.values());
            }
        })?;
        check_instance_order(&self.dir, &p.instance)?;
        Ok(p)
    }
}
