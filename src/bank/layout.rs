//! Where every column's values lie in every shard file, stored beside the shards so that
//! opening a bank does not parse their footers.
//!
//! A shard's Parquet footer describes 5,007 column chunks; parsing the 20 footers of the 50k
//! bank took 60–100 ms of every cold `identify`, more than the whole goal. A bank stored plain
//! and uncompressed (the default) keeps each column chunk as one data page whose values are
//! the chunk's last `rows × width` bytes, so a column is a slice of the mapped file once its
//! offset is known. `bank generate` and `bank merge` take those offsets from the Parquet
//! crate's own footer, check every column's slice against the Parquet decoder, and store them
//! as `layout.bin`, listed in the manifest with its size and SHA-256. Banks stored otherwise
//! (compressed, byte-stream-split) have no layout and are read through the decoder.
//!
//! The file also carries the first shard's `wheelflat.bank` metadata, so the reader needs no
//! footer at all for identification, and a CRC-32 of every column's values in every shard: a
//! read checks the chunks it touches before it uses them (12 MB for a measurement's 60
//! columns: about a millisecond), so a damaged value is an error naming the file and column,
//! never a changed answer. (`bank verify` checks whole files by SHA-256.) Layout
//! (little-endian):
//!
//! ```text
//! magic    b"WFLAYOU2"              8 bytes
//! id_len   u32, id                  the bank id (UTF-8)
//! meta_len u32, meta                the first shard's metadata JSON
//! shards   u32, columns u32
//! widths   columns × u8             bytes per value: 4 (u32, f32) or 8 (f64)
//! per shard:
//!   rows u64, file bytes u64, footer u32 (the footer length the file's last 8 bytes state)
//!   offsets columns × u64           where the column's values start in the file
//!   crc32   columns × u32           CRC-32 (IEEE) of the column's value bytes
//! ```

use super::BankError;
use arrow_array::{Array, Float32Array, Float64Array, UInt32Array};
use bytes::Bytes;
use parquet::arrow::arrow_reader::{ArrowReaderMetadata, ParquetRecordBatchReaderBuilder};
use parquet::basic::{Compression, Encoding, Type as PhysicalType};
use std::path::Path;

/// The layout's file name inside a version directory.
pub(crate) const LAYOUT_FILE: &str = "layout.bin";

const MAGIC: &[u8; 8] = b"WFLAYOU2";

/// The magic of the first layout format (without checksums), which `bank generate` replaces.
pub(crate) const EARLIER_MAGIC: &[u8; 8] = b"WFLAYOU1";

/// Where one shard's column values lie.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ShardLayout {
    /// Rows of the shard.
    pub rows: usize,
    /// The shard file's size.
    pub file_bytes: u64,
    /// Length of its Parquet footer (stated in the file's last 8 bytes).
    pub footer_bytes: u32,
    /// Start of every column's values in the file.
    pub offsets: Vec<u64>,
    /// CRC-32 of every column's value bytes.
    pub crc32: Vec<u32>,
}

/// A bank's column layout.
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    /// The bank id it belongs to.
    pub bank_id: String,
    /// The first shard's `wheelflat.bank` metadata (JSON).
    pub metadata_json: String,
    /// Bytes per value of every column.
    pub widths: Vec<u8>,
    /// Every shard, in manifest order.
    pub shards: Vec<ShardLayout>,
}

/// The footer length a Parquet file states in its last 8 bytes (`len u32`, `PAR1`), or `None`
/// when the file does not end like a Parquet file.
pub(crate) fn footer_length(file: &[u8]) -> Option<u32> {
    let n = file.len();
    if n < 12 || &file[n - 4..] != b"PAR1" || &file[..4] != b"PAR1" {
        return None;
    }
    Some(u32::from_le_bytes(
        file[n - 8..n - 4].try_into().expect("4 bytes"),
    ))
}

/// What [`derive`] finds for one shard.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum Derived {
    /// The shard's layout and its columns' value widths.
    Layout(ShardLayout, Vec<u8>),
    /// The shard is not stored so that a layout applies (compressed, other encodings, several
    /// pages or row groups): why.
    NotApplicable(String),
}

fn ineligible(why: String) -> Result<Derived, BankError> {
    Ok(Derived::NotApplicable(why))
}

/// A shard's layout from its footer (`meta`) and bytes, each column's slice checked equal to
/// what the Parquet decoder reads.
pub(crate) fn derive(
    path: &Path,
    bytes: &Bytes,
    meta: &ArrowReaderMetadata,
) -> Result<Derived, BankError> {
    let corrupt = |message: String| BankError::Corrupt {
        path: path.to_path_buf(),
        message,
    };
    let md = meta.metadata();
    if md.num_row_groups() != 1 {
        return ineligible(format!("{} row groups", md.num_row_groups()));
    }
    let rg = md.row_group(0);
    let rows = rg.num_rows() as usize;
    let footer_bytes = footer_length(bytes).ok_or_else(|| corrupt("not a Parquet file".into()))?;
    let mut offsets = Vec::with_capacity(rg.num_columns());
    let mut widths = Vec::with_capacity(rg.num_columns());
    for c in rg.columns() {
        let width = match c.column_type() {
            PhysicalType::INT32 | PhysicalType::FLOAT => 4,
            PhysicalType::DOUBLE => 8,
            other => return ineligible(format!("physical type {other}")),
        };
        let plain_only = c
            .encodings()
            .all(|e| matches!(e, Encoding::PLAIN | Encoding::RLE));
        if c.compression() != Compression::UNCOMPRESSED
            || c.dictionary_page_offset().is_some()
            || !plain_only
            || c.num_values() as usize != rows
        {
            return ineligible(format!(
                "column {} is compressed, dictionary-encoded or not plain",
                c.column_path()
            ));
        }
        let end = c.data_page_offset() + c.compressed_size();
        let start = end - (rows * width) as i64;
        if start < 4 || end as u64 > bytes.len() as u64 {
            return Err(corrupt(format!(
                "column {} lies outside the file",
                c.column_path()
            )));
        }
        offsets.push(start as u64);
        widths.push(width as u8);
    }
    let crc32 = offsets
        .iter()
        .zip(&widths)
        .map(|(&o, &w)| crc32fast::hash(&bytes[o as usize..o as usize + rows * w as usize]))
        .collect();
    let layout = ShardLayout {
        rows,
        file_bytes: bytes.len() as u64,
        footer_bytes,
        offsets,
        crc32,
    };
    // Every column's slice against the decoder (one page per chunk is what makes the slice
    // the values; a chunk of several pages would differ here).
    let reader = ParquetRecordBatchReaderBuilder::new_with_metadata(bytes.clone(), meta.clone())
        .with_batch_size(rows.max(1))
        .build()
        .map_err(|e| corrupt(e.to_string()))?;
    let mut row = 0;
    for batch in reader {
        let batch = batch.map_err(|e| corrupt(e.to_string()))?;
        for (j, column) in batch.columns().iter().enumerate() {
            let decoded = values_bytes(column.as_ref())
                .ok_or_else(|| corrupt(format!("column {j} has an unexpected type")))?;
            let width = decoded.len() / column.len().max(1);
            let at = layout.offsets[j] as usize + row * width;
            if bytes.get(at..at + decoded.len()) != Some(decoded) {
                return ineligible(format!("column {j}: slice differs from the decoder"));
            }
        }
        row += batch.num_rows();
    }
    if row != rows {
        return Err(corrupt(format!(
            "{row} rows decoded, the footer says {rows}"
        )));
    }
    Ok(Derived::Layout(layout, widths))
}

/// The little-endian value bytes of a u32, f32 or f64 column without nulls.
fn values_bytes(a: &dyn Array) -> Option<&[u8]> {
    if a.null_count() > 0 {
        return None;
    }
    let any = a.as_any();
    if let Some(a) = any.downcast_ref::<Float32Array>() {
        return Some(a.values().inner().as_slice());
    }
    if let Some(a) = any.downcast_ref::<Float64Array>() {
        return Some(a.values().inner().as_slice());
    }
    any.downcast_ref::<UInt32Array>()
        .map(|a| a.values().inner().as_slice())
}

impl Layout {
    /// The file bytes.
    pub fn encode(&self) -> Vec<u8> {
        let columns = self.widths.len();
        let mut out = Vec::with_capacity(
            32 + self.bank_id.len()
                + self.metadata_json.len()
                + columns
                + self.shards.len() * (20 + 12 * columns),
        );
        let u32le = |out: &mut Vec<u8>, v: usize| {
            out.extend_from_slice(&u32::try_from(v).expect("fits u32").to_le_bytes())
        };
        out.extend_from_slice(MAGIC);
        u32le(&mut out, self.bank_id.len());
        out.extend_from_slice(self.bank_id.as_bytes());
        u32le(&mut out, self.metadata_json.len());
        out.extend_from_slice(self.metadata_json.as_bytes());
        u32le(&mut out, self.shards.len());
        u32le(&mut out, columns);
        out.extend_from_slice(&self.widths);
        for s in &self.shards {
            out.extend_from_slice(&(s.rows as u64).to_le_bytes());
            out.extend_from_slice(&s.file_bytes.to_le_bytes());
            out.extend_from_slice(&s.footer_bytes.to_le_bytes());
            for o in &s.offsets {
                out.extend_from_slice(&o.to_le_bytes());
            }
            for c in &s.crc32 {
                out.extend_from_slice(&c.to_le_bytes());
            }
        }
        out
    }

    /// A layout from its file bytes, checked for form and against the bank it must belong to
    /// (`bank_id`): every shard's values must lie between the file's leading magic and its
    /// footer. The shard files themselves are checked by [`Layout::check_file`].
    pub fn decode(path: &Path, bytes: &[u8], bank_id: &str) -> Result<Layout, BankError> {
        let bad = |message: String| BankError::Corrupt {
            path: path.to_path_buf(),
            message,
        };
        let at = std::cell::Cell::new(0usize);
        let take = |len: usize| -> Result<&[u8], BankError> {
            let from = at.get();
            let s = bytes
                .get(from..from.saturating_add(len))
                .ok_or_else(|| bad(format!("{} bytes: ends at byte {from}", bytes.len())))?;
            at.set(from + len);
            Ok(s)
        };
        let magic = take(8)?;
        if magic == EARLIER_MAGIC {
            return Err(bad("a layout of an earlier wheelflat, without checksums; `wheelflat bank generate` with the bank's arguments writes the current one".into()));
        }
        if magic != MAGIC {
            return Err(bad("not a wheelflat column layout (bad magic)".into()));
        }
        let u32_at = |s: &[u8]| u32::from_le_bytes(s.try_into().expect("4 bytes")) as usize;
        let u64_at = |s: &[u8]| u64::from_le_bytes(s.try_into().expect("8 bytes"));
        let id_len = u32_at(take(4)?);
        let id = take(id_len.min(256))?;
        if id != bank_id.as_bytes() {
            return Err(bad(format!(
                "belongs to bank {}, not {bank_id}",
                String::from_utf8_lossy(id)
            )));
        }
        let meta_len = u32_at(take(4)?);
        let metadata_json = std::str::from_utf8(take(meta_len)?)
            .map_err(|e| bad(format!("metadata is not UTF-8: {e}")))?
            .to_string();
        let shards = u32_at(take(4)?);
        let columns = u32_at(take(4)?);
        // Bounds before any allocation from the stated counts.
        let per_shard = 20 + 12 * columns;
        let rest = bytes.len().saturating_sub(at.get() + columns);
        if shards.saturating_mul(per_shard) != rest {
            return Err(bad(format!(
                "{} bytes do not hold {shards} shards of {columns} columns",
                bytes.len()
            )));
        }
        let widths = take(columns)?.to_vec();
        if let Some(w) = widths.iter().find(|&&w| w != 4 && w != 8) {
            return Err(bad(format!("value width {w}")));
        }
        let mut out = Vec::with_capacity(shards);
        for s in 0..shards {
            let rows = u64_at(take(8)?) as usize;
            let file_bytes = u64_at(take(8)?);
            let footer_bytes = u32_at(take(4)?) as u32;
            let values_end = file_bytes.saturating_sub(8 + footer_bytes as u64);
            let mut offsets = Vec::with_capacity(columns);
            for (j, chunk) in take(8 * columns)?.chunks_exact(8).enumerate() {
                let o = u64_at(chunk);
                let len = (rows as u64).saturating_mul(widths[j] as u64);
                if o < 4 || o.saturating_add(len) > values_end {
                    return Err(bad(format!(
                        "shard {s}, column {j}: values at {o}..{} outside the data pages (..{values_end})",
                        o.saturating_add(len)
                    )));
                }
                offsets.push(o);
            }
            let crc32 = take(4 * columns)?
                .chunks_exact(4)
                .map(|c| u32_at(c) as u32)
                .collect();
            out.push(ShardLayout {
                rows,
                file_bytes,
                footer_bytes,
                offsets,
                crc32,
            });
        }
        Ok(Layout {
            bank_id: bank_id.to_string(),
            metadata_json,
            widths,
            shards: out,
        })
    }

    /// The value bytes of column `column` in shard `shard` (`file`: the mapped shard, already
    /// checked by [`Layout::check_file`]), rows `rows` of it, once the whole column's bytes
    /// match their CRC-32; `path` names the shard in the error.
    pub fn values<'a>(
        &self,
        shard: usize,
        column: usize,
        rows: std::ops::Range<usize>,
        file: &'a [u8],
        path: &Path,
    ) -> Result<&'a [u8], BankError> {
        let s = &self.shards[shard];
        let all = self.values_unchecked(shard, column, 0..s.rows, file);
        let crc = crc32fast::hash(all);
        if crc != s.crc32[column] {
            return Err(BankError::Corrupt {
                path: path.to_path_buf(),
                message: format!(
                    "column {column}: its values' CRC-32 is {crc:08x}, the layout says {:08x}; `wheelflat bank verify` checks the whole bank",
                    s.crc32[column]
                ),
            });
        }
        let w = self.widths[column] as usize;
        Ok(&all[rows.start * w..rows.end * w])
    }

    /// [`Layout::values`] without the CRC-32 (a column this process has checked already).
    pub fn values_unchecked<'a>(
        &self,
        shard: usize,
        column: usize,
        rows: std::ops::Range<usize>,
        file: &'a [u8],
    ) -> &'a [u8] {
        let s = &self.shards[shard];
        let w = self.widths[column] as usize;
        let start = s.offsets[column] as usize;
        &file[start + rows.start * w..start + rows.end * w]
    }

    /// Checks a mapped shard file against its layout entry: size, Parquet magic at both ends
    /// and the footer length the file states (a shard rewritten since the layout was made
    /// fails one of them; `bank verify` checks the content by SHA-256).
    pub fn check_file(&self, index: usize, path: &Path, file: &[u8]) -> Result<(), BankError> {
        let s = &self.shards[index];
        let footer = footer_length(file);
        if file.len() as u64 != s.file_bytes || footer != Some(s.footer_bytes) {
            return Err(BankError::Corrupt {
                path: path.to_path_buf(),
                message: format!(
                    "{} bytes, footer {footer:?}; the layout says {} bytes, footer {}",
                    file.len(),
                    s.file_bytes,
                    s.footer_bytes
                ),
            });
        }
        Ok(())
    }
}

/// The values of a 4-byte column as f32 (the column's bytes, little-endian).
pub(crate) fn f32_values(bytes: &[u8], out: &mut [f32]) {
    for (o, c) in out.iter_mut().zip(bytes.chunks_exact(4)) {
        *o = f32::from_le_bytes(c.try_into().expect("4 bytes"));
    }
}

/// The values of an 8-byte column as f64.
pub(crate) fn f64_values(bytes: &[u8]) -> impl Iterator<Item = f64> + '_ {
    bytes
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
}

/// The values of a 4-byte column as u32.
pub(crate) fn u32_values(bytes: &[u8]) -> impl Iterator<Item = u32> + '_ {
    bytes
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes(c.try_into().expect("4 bytes")))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Layout {
        Layout {
            bank_id: "abc".into(),
            metadata_json: "{\"x\":1}".into(),
            widths: vec![4, 8, 4],
            shards: vec![
                ShardLayout {
                    rows: 2,
                    file_bytes: 200,
                    footer_bytes: 50,
                    offsets: vec![10, 20, 40],
                    crc32: vec![1, 2, 3],
                },
                ShardLayout {
                    rows: 1,
                    file_bytes: 100,
                    footer_bytes: 40,
                    offsets: vec![4, 8, 16],
                    crc32: vec![4, 5, 0xffff_ffff],
                },
            ],
        }
    }

    #[test]
    fn a_layout_reads_back_and_damaged_or_foreign_ones_are_refused() {
        let l = sample();
        let bytes = l.encode();
        let p = Path::new("layout.bin");
        assert_eq!(Layout::decode(p, &bytes, "abc").unwrap(), l);
        assert!(Layout::decode(p, &bytes, "abd").is_err());
        for cut in [0, 9, bytes.len() / 2, bytes.len() - 1] {
            assert!(
                Layout::decode(p, &bytes[..cut], "abc").is_err(),
                "cut {cut}"
            );
        }
        // An offset past the data pages (file 100 bytes, footer 40: values end at 52).
        let mut far = l.clone();
        far.shards[1].offsets[2] = 49;
        let err = Layout::decode(p, &far.encode(), "abc")
            .unwrap_err()
            .to_string();
        assert!(err.contains("outside the data pages"), "{err}");
        // A width that is neither 4 nor 8.
        let mut odd = l.clone();
        odd.widths[0] = 3;
        assert!(Layout::decode(p, &odd.encode(), "abc").is_err());
    }

    #[test]
    fn a_shard_that_changed_since_the_layout_was_made_is_refused() {
        let mut l = sample();
        let mut file = vec![0u8; 100];
        file[..4].copy_from_slice(b"PAR1");
        file[96..].copy_from_slice(b"PAR1");
        file[92..96].copy_from_slice(&40u32.to_le_bytes());
        l.check_file(1, Path::new("s"), &file).unwrap();
        file[92..96].copy_from_slice(&41u32.to_le_bytes());
        assert!(l.check_file(1, Path::new("s"), &file).is_err());
        l.shards[1].file_bytes = 101;
        assert!(l.check_file(1, Path::new("s"), &file[..99]).is_err());
    }
}
