//! Writing one shard file: a single row group, one f32 column per sensor sample.
//! Pure storage: it receives the simulated rows and writes them; simulation and parallelism
//! live in [`super::generate`].

use super::schema::{arrow_schema, BankMetadata, METADATA_KEY, PARAMETER_COLUMNS};
use super::BankError;
use arrow_array::{ArrayRef, Float32Array, Float64Array, RecordBatch, UInt32Array};
use parquet::arrow::ArrowWriter;
use parquet::basic::{Compression, Encoding, ZstdLevel};
use parquet::file::metadata::KeyValue;
use parquet::file::properties::{EnabledStatistics, WriterProperties};
use std::path::Path;
use std::sync::Arc;

/// Column compression of the sample columns.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Codec {
    /// No compression: reading is a copy.
    None,
    /// Snappy.
    Snappy,
    /// LZ4 (raw).
    Lz4,
    /// Zstandard, level 1.
    Zstd,
}

/// Value encoding of the sample columns.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ValueEncoding {
    /// Plain little-endian floats.
    Plain,
    /// Byte-stream split: the bytes of all floats grouped by significance, which lets a
    /// compressor find the redundancy in exponents and leading mantissa bytes.
    ByteStreamSplit,
}

/// How shard files are encoded (chosen by measurement: docs/performance.md, "Bank encoding
/// and compression").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StorageFormat {
    /// Compression codec.
    pub codec: Codec,
    /// Value encoding.
    pub encoding: ValueEncoding,
}

impl Default for StorageFormat {
    fn default() -> Self {
        StorageFormat {
            codec: Codec::None,
            encoding: ValueEncoding::Plain,
        }
    }
}

impl StorageFormat {
    /// Short name, part of the bank identity.
    pub fn name(&self) -> String {
        format!("{:?}+{:?}", self.codec, self.encoding).to_lowercase()
    }

    fn properties(&self, metadata_json: String, rows: usize) -> WriterProperties {
        let compression = match self.codec {
            Codec::None => Compression::UNCOMPRESSED,
            Codec::Snappy => Compression::SNAPPY,
            Codec::Lz4 => Compression::LZ4_RAW,
            Codec::Zstd => Compression::ZSTD(ZstdLevel::try_new(1).expect("zstd level 1 exists")),
        };
        let encoding = match self.encoding {
            ValueEncoding::Plain => Encoding::PLAIN,
            ValueEncoding::ByteStreamSplit => Encoding::BYTE_STREAM_SPLIT,
        };
        // One row group per file (the reader touches each column chunk once), no dictionary
        // (continuous values), no statistics or page indexes: with thousands of columns they
        // would multiply the footer that every reader parses.
        WriterProperties::builder()
            .set_created_by(format!("wheelflat {}", env!("CARGO_PKG_VERSION")))
            .set_compression(compression)
            .set_encoding(encoding)
            .set_dictionary_enabled(false)
            .set_statistics_enabled(EnabledStatistics::None)
            .set_write_page_header_statistics(false)
            .set_offset_index_disabled(true)
            .set_max_row_group_row_count(Some(rows.max(1)))
            .set_data_page_size_limit(1 << 20)
            .set_key_value_metadata(Some(vec![KeyValue::new(
                METADATA_KEY.to_string(),
                metadata_json,
            )]))
            .build()
    }
}

/// One simulated instance, ready to store.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct InstanceRow {
    /// Instance number.
    pub instance: u32,
    /// `PARAMETER_COLUMNS` values.
    pub parameters: [f64; PARAMETER_COLUMNS.len()],
    /// Pad forces (kN), sensor-major: sample k of sensor s at `s·samples + k`.
    pub forces_kn: Vec<f32>,
}

/// Writes `rows` as a shard file at `tmp` (the caller renames it into place).
pub(crate) fn write_shard(
    tmp: &Path,
    meta: &BankMetadata,
    rows: &[InstanceRow],
    format: StorageFormat,
) -> Result<(), BankError> {
    let schema = arrow_schema(&meta.sensors);
    let json = serde_json::to_string(meta).expect("metadata serialises");
    let mut columns: Vec<ArrayRef> = Vec::with_capacity(schema.fields().len());
    columns.push(Arc::new(UInt32Array::from_iter_values(
        rows.iter().map(|r| r.instance),
    )));
    for p in 0..PARAMETER_COLUMNS.len() {
        columns.push(Arc::new(Float64Array::from_iter_values(
            rows.iter().map(|r| r.parameters[p]),
        )));
    }
    let total: usize = meta.sensors.iter().map(|a| a.samples).sum();
    for j in 0..total {
        columns.push(Arc::new(Float32Array::from_iter_values(
            rows.iter().map(|r| r.forces_kn[j]),
        )));
    }
    let io = |source| BankError::Io {
        path: tmp.to_path_buf(),
        source,
    };
    let pq = |e: parquet::errors::ParquetError| BankError::Parquet {
        path: tmp.to_path_buf(),
        message: e.to_string(),
    };
    let batch = RecordBatch::try_new(schema.clone(), columns).map_err(|e| BankError::Parquet {
        path: tmp.to_path_buf(),
        message: e.to_string(),
    })?;
    let file = std::fs::File::create(tmp).map_err(io)?;
    let mut writer = ArrowWriter::try_new(file, schema, Some(format.properties(json, rows.len())))
        .map_err(pq)?;
    writer.write(&batch).map_err(pq)?;
    let file = writer.into_inner().map_err(pq)?;
    file.sync_all().map_err(io)?;
    Ok(())
}
