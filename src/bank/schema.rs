//! The bank's file layout: the names in a bank directory, the Parquet schema (wide, one f32
//! column per sensor sample), the key/value metadata every shard file carries (and how it is
//! read back), and the manifest of a complete bank. Both the generator and the reader build
//! on this module; neither depends on the other.

use super::BankError;
use crate::model::{Calibration, CheckedCalibration};
use arrow_schema::{DataType, Field, Schema};
use bytes::Bytes;
use parquet::arrow::arrow_reader::{ArrowReaderMetadata, ArrowReaderOptions};
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use std::path::Path;
use std::sync::Arc;

/// Name of the pointer file in a bank directory.
pub const CURRENT: &str = "CURRENT";
/// Name of the manifest in a version directory.
pub const MANIFEST: &str = "manifest.json";
/// Name of shard file `index` of `count`.
pub fn shard_file_name(index: usize, count: usize) -> String {
    format!("shard-{index:05}-of-{count:05}.parquet")
}

/// Version of the on-disk format (schema, metadata and manifest).
pub const FORMAT_VERSION: u32 = 3;
/// Revision of the physics: bump when a code change alters simulated values, so that
/// existing banks are rebuilt and audits report the drift. Revision 2: the lockstep stepper
/// (fused multiply–adds, the final accelerations by a second substitution; values within one
/// f32 step of revision 1).
pub const MODEL_REVISION: u32 = 2;
/// The one key/value metadata key of a shard file; its value is [`BankMetadata`] as JSON.
pub const METADATA_KEY: &str = "wheelflat.bank";
/// Parameter columns, in order, before the sample columns (all f64; `flat_wheel` is 0 for
/// the leading wheel, 1 for the trailing one; `peak_contact_kn` is the largest wheel–rail
/// contact force of the flat's wheel over the run, a simulated result rather than a flat
/// parameter). Format 2 added `flat_wheel`, format 3 `peak_contact_kn`.
pub const PARAMETER_COLUMNS: [&str; 7] = [
    "length_mm",
    "depth_mm",
    "curvature_mm",
    "impact_position_m",
    "l0_mm",
    "flat_wheel",
    "peak_contact_kn",
];

/// Time axis of one sensor's window.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SensorAxis {
    /// Sensor name (column prefix).
    pub name: String,
    /// Sleeper index.
    pub sleeper: usize,
    /// Position along the rail (m).
    pub position_m: f64,
    /// Sample rate (Hz).
    pub sample_rate_hz: f64,
    /// Global index of the first sample: sample k of the window is at `(first_sample + k)/rate` s.
    pub first_sample: usize,
    /// Samples in the window.
    pub samples: usize,
    /// Time of the first sample (s).
    pub t0_s: f64,
}

/// Which part of the bank a shard file holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct ShardInfo {
    /// Index of this shard file.
    pub index: usize,
    /// Number of shard files in the bank.
    pub count: usize,
    /// First instance number in the file.
    pub first_instance: usize,
    /// Instances (rows) in the file.
    pub rows: usize,
}

/// Metadata stored (as JSON) in every shard file under [`METADATA_KEY`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BankMetadata {
    /// [`FORMAT_VERSION`].
    pub format_version: u32,
    /// `wheelflat <crate version>`.
    pub generator: String,
    /// [`MODEL_REVISION`].
    pub model_revision: u32,
    /// Identity of the bank: hash of everything that determines its contents.
    pub bank_id: String,
    /// SHA-256 of the calibration's canonical TOML text.
    pub calibration_sha256: String,
    /// The full calibration.
    pub calibration: Calibration,
    /// Population sampling scheme.
    pub sampling: String,
    /// Instances in the whole bank.
    pub instances: usize,
    /// Seed of the population (0: plain Hammersley).
    pub seed: u64,
    /// Instances per shard file.
    pub shard_size: usize,
    /// This file's part of the bank.
    pub shard: ShardInfo,
    /// Time axis of every sensor.
    pub sensors: Vec<SensorAxis>,
    /// Unit of the sample columns.
    pub force_unit: String,
    /// The good wheel's (flat-free) prediction in every sensor window (kN): the template for
    /// aligning a measurement by cross-correlation without simulating.
    pub flat_free_kn: Vec<Vec<f32>>,
}

/// The parameter columns of every instance.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Parameters {
    /// Instance numbers.
    pub instance: Vec<u32>,
    /// Flat length L (mm).
    pub length_mm: Vec<f64>,
    /// Flat depth d (mm).
    pub depth_mm: Vec<f64>,
    /// Curvature c (mm).
    pub curvature_mm: Vec<f64>,
    /// Impact position X_p (m).
    pub impact_position_m: Vec<f64>,
    /// Fresh-flat length L0 = sqrt(8·d·R_w) (mm).
    pub l0_mm: Vec<f64>,
    /// The wheel carrying the flat: 0 leading, 1 trailing.
    pub flat_wheel: Vec<u8>,
    /// The largest wheel–rail contact force of the flat's wheel over the run (kN).
    pub peak_contact_kn: Vec<f64>,
}

/// One shard file in the manifest.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ManifestFile {
    /// File name inside the bank version directory.
    pub name: String,
    /// First instance number.
    pub first_instance: usize,
    /// Rows.
    pub rows: usize,
    /// Size in bytes.
    pub bytes: u64,
    /// SHA-256 of the file, hex.
    pub sha256: String,
}

/// `manifest.json`: written last, once every shard file is in place.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// [`FORMAT_VERSION`].
    pub format_version: u32,
    /// Bank identity (matches every file's metadata).
    pub bank_id: String,
    /// Generator version.
    pub generator: String,
    /// Calibration hash.
    pub calibration_sha256: String,
    /// Instances in the bank.
    pub instances: usize,
    /// The shard files, in instance order.
    pub files: Vec<ManifestFile>,
    /// The neighbour graph (`neighbours.bin`, [`crate::bank::neighbours`]); absent in banks
    /// written before it was stored, whose readers search it at open.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub neighbours: Option<ManifestAux>,
    /// Where every column's values lie in the shards (`layout.bin`, [`crate::bank::layout`]);
    /// absent for banks stored compressed and banks written before it was stored, whose
    /// readers parse the shards' footers.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub layout: Option<ManifestAux>,
}

/// A file beside the shards, in the manifest.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ManifestAux {
    /// File name inside the bank version directory.
    pub name: String,
    /// Size in bytes.
    pub bytes: u64,
    /// SHA-256 of the file, hex.
    pub sha256: String,
}

/// Hex SHA-256 of bytes.
pub fn sha256_hex(bytes: &[u8]) -> String {
    let digest = Sha256::digest(bytes);
    digest.iter().map(|b| format!("{b:02x}")).collect()
}

/// SHA-256 of the calibration's canonical TOML text.
pub fn calibration_sha256(cal: &CheckedCalibration) -> String {
    sha256_hex(cal.document().to_toml_string().as_bytes())
}

/// Bank identity: everything that determines the simulated values and their storage
/// (the calibration without its `[identification]` settings, which do not change them).
pub fn bank_id(
    cal: &CheckedCalibration,
    instances: usize,
    seed: u64,
    shard_size: usize,
    storage: &str,
) -> String {
    let key = format!(
        "{}\nformat={FORMAT_VERSION}\nmodel={MODEL_REVISION}\ngenerator={}\ninstances={instances}\nseed={seed}\nshard_size={shard_size}\nstorage={storage}\n",
        cal.document().model_toml_string(),
        env!("CARGO_PKG_VERSION"),
    );
    sha256_hex(key.as_bytes())[..16].to_string()
}

/// Time axes of a calibration's sensors.
pub fn sensor_axes(cal: &CheckedCalibration) -> Vec<SensorAxis> {
    (0..cal.sensors.pad.len())
        .map(|i| {
            let first = cal.window_start_sample(i);
            SensorAxis {
                name: cal.sensors.pad[i].name.clone(),
                sleeper: cal.sensors.pad[i].sleeper,
                position_m: cal.sensor_position_m(i),
                sample_rate_hz: cal.output.sample_rate_hz,
                first_sample: first,
                samples: cal.output.window_samples,
                t0_s: first as f64 / cal.output.sample_rate_hz,
            }
        })
        .collect()
}

/// Name of sample `k` of sensor `sensor`: `rps2_t0137` (zero-padded to at least 4 digits).
pub fn sample_column(sensor: &str, k: usize, samples: usize) -> String {
    let width = (samples.saturating_sub(1)).to_string().len().max(4);
    format!("{sensor}_t{k:0width$}")
}

/// The Arrow schema: `instance` (u32), the parameter columns (f64), then one non-nullable f32
/// column per sensor sample, sensor by sensor.
pub fn arrow_schema(axes: &[SensorAxis]) -> Arc<Schema> {
    let mut fields = vec![Field::new("instance", DataType::UInt32, false)];
    for p in PARAMETER_COLUMNS {
        fields.push(Field::new(p, DataType::Float64, false));
    }
    for a in axes {
        for k in 0..a.samples {
            fields.push(Field::new(
                sample_column(&a.name, k, a.samples),
                DataType::Float32,
                false,
            ));
        }
    }
    Arc::new(Schema::new(fields))
}

/// Index in the schema of sample `k` of sensor number `s`.
pub fn sample_column_index(axes: &[SensorAxis], s: usize, k: usize) -> usize {
    1 + PARAMETER_COLUMNS.len() + axes[..s].iter().map(|a| a.samples).sum::<usize>() + k
}

/// A Parquet error on `path` as a corrupt-file error.
pub(crate) fn parquet_err(path: &Path) -> impl Fn(parquet::errors::ParquetError) -> BankError + '_ {
    move |e| BankError::Corrupt {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

/// Maps a file read-only.
pub(crate) fn map(path: &Path) -> Result<Bytes, BankError> {
    let file = std::fs::File::open(path).map_err(|source| BankError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    // SAFETY: bank files (shards, layout, graph) are written to a temporary name and renamed
    // into place when complete; no wheelflat process modifies a file after that, so the mapping
    // is not mutated under us. (Another program truncating the file while it is mapped would be
    // outside this contract.)
    let mmap = unsafe { memmap2::Mmap::map(&file) }.map_err(|source| BankError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    Ok(Bytes::from_owner(mmap))
}

/// Reads and parses a shard file's footer and its wheelflat metadata.
pub(crate) fn open_shard(
    path: &Path,
) -> Result<(Bytes, ArrowReaderMetadata, BankMetadata), BankError> {
    let bytes = map(path)?;
    let meta =
        ArrowReaderMetadata::load(&bytes, ArrowReaderOptions::new()).map_err(parquet_err(path))?;
    let kv = bank_metadata_text(path, meta.metadata().file_metadata())?;
    let bank_meta = parse_bank_metadata(path, &kv)?;
    Ok((bytes, meta, bank_meta))
}

/// A shard's `wheelflat.bank` metadata from its JSON text (`path` names where it was read).
pub(crate) fn parse_bank_metadata(path: &Path, kv: &str) -> Result<BankMetadata, BankError> {
    let bad = |e: serde_json::Error| BankError::Corrupt {
        path: path.to_path_buf(),
        message: format!("bad `{METADATA_KEY}` metadata: {e}"),
    };
    let bank_meta: BankMetadata = match serde_json::from_str(kv) {
        Ok(m) => m,
        // The identification settings are not part of a bank's identity: a bank written by a
        // version with other identification keys opens with today's defaults for them.
        Err(first) => {
            let mut v: serde_json::Value = serde_json::from_str(kv).map_err(bad)?;
            let dropped = v
                .get_mut("calibration")
                .and_then(|c| c.as_object_mut())
                .and_then(|c| c.remove("identification"))
                .is_some();
            if !dropped {
                return Err(bad(first));
            }
            serde_json::from_value(v).map_err(|_| bad(first))?
        }
    };
    Ok(bank_meta)
}

/// The `wheelflat.bank` JSON of a shard's footer.
pub(crate) fn bank_metadata_text(
    path: &Path,
    file: &parquet::file::metadata::FileMetaData,
) -> Result<String, BankError> {
    file.key_value_metadata()
        .and_then(|kvs| kvs.iter().find(|kv| kv.key == METADATA_KEY))
        .and_then(|kv| kv.value.clone())
        .ok_or_else(|| BankError::Corrupt {
            path: path.to_path_buf(),
            message: format!("no `{METADATA_KEY}` metadata: not a wheelflat bank file"),
        })
}

/// What a reader checks of every shard after the first: its bank id and format.
#[derive(Debug, Deserialize)]
pub(crate) struct ShardIdentity {
    /// The bank id.
    pub bank_id: String,
    /// [`FORMAT_VERSION`].
    pub format_version: u32,
}

/// How footers after a bank's first are parsed: with the first's schema (`first`), without
/// the column statistics the bank does not write.
pub fn sibling_footer_options(
    first: &ArrowReaderMetadata,
) -> parquet::file::metadata::ParquetMetaDataOptions {
    use parquet::file::metadata::{ParquetMetaDataOptions, ParquetStatisticsPolicy};
    ParquetMetaDataOptions::new()
        .with_schema(first.metadata().file_metadata().schema_descr_ptr())
        .with_encoding_stats_policy(ParquetStatisticsPolicy::SkipAll)
        .with_column_stats_policy(ParquetStatisticsPolicy::SkipAll)
        .with_size_stats_policy(ParquetStatisticsPolicy::SkipAll)
}

/// Opens a shard of a bank whose first shard is already open (`first`): its footer is parsed
/// with the first shard's schema (every shard of a bank has the same columns; a footer whose
/// columns do not match fails to parse) and without the column statistics the bank does not
/// write, and only the bank id and format are read from its metadata. About a third of the
/// cost of [`open_shard`], and what `identify` pays for every shard of every bank it opens.
pub(crate) fn open_sibling_shard(
    path: &Path,
    first: &ArrowReaderMetadata,
) -> Result<(Bytes, ArrowReaderMetadata, ShardIdentity), BankError> {
    let bytes = map(path)?;
    let parsed = parquet::file::metadata::ParquetMetaDataReader::new()
        .with_metadata_options(Some(sibling_footer_options(first)))
        .parse_and_finish(&bytes)
        .map_err(parquet_err(path))?;
    let kv = bank_metadata_text(path, parsed.file_metadata())?;
    let identity: ShardIdentity = serde_json::from_str(&kv).map_err(|e| BankError::Corrupt {
        path: path.to_path_buf(),
        message: format!("bad `{METADATA_KEY}` metadata: {e}"),
    })?;
    let meta = ArrowReaderMetadata::try_new(
        Arc::new(parsed),
        ArrowReaderOptions::new()
            .with_skip_arrow_metadata(true)
            .with_schema(first.schema().clone()),
    )
    .map_err(parquet_err(path))?;
    Ok((bytes, meta, identity))
}

/// Checks that a complete shard file holds `info` and otherwise exactly the metadata `expected`
/// (used on resume).
pub(crate) fn shard_matches(
    path: &Path,
    expected: &BankMetadata,
    info: &ShardInfo,
) -> Result<(), BankError> {
    let (_, meta, bank_meta) = open_shard(path)?;
    let rows = meta.metadata().file_metadata().num_rows() as usize;
    // Everything but the shard's own place must be what this run would write (a shard written
    // by another version, e.g. with another calibration checksum, is simulated again).
    let mut want = expected.clone();
    want.shard = *info;
    if bank_meta != want || rows != info.rows {
        return Err(BankError::Corrupt {
            path: path.to_path_buf(),
            message: "belongs to another bank or holds other rows".into(),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bank_identity_ignores_the_identification_settings_but_not_the_model() {
        let base = Calibration::paper_profile();
        let id = |c: &Calibration| bank_id(&c.clone().check().unwrap(), 100, 0, 50, "plain");
        let mut other = base.clone();
        other.identification.phi = 0.9;
        other.identification.bank_resolution = 0.0;
        other.identification.uncertainty.clear();
        assert_eq!(id(&base), id(&other));
        assert!(!base.model_toml_string().contains("identification"));
        // An operator's rulebook (`[maintenance]`) neither.
        let mut rulebook = base.clone();
        rulebook.maintenance = Some(crate::model::calibration::MaintenanceParams {
            inspect_l0_mm: 20.0,
            urgent_l0_mm: 35.0,
            ..Default::default()
        });
        assert_eq!(id(&base), id(&rulebook));
        let checked = rulebook.check().unwrap();
        assert_eq!(
            (
                checked.identification.inspect_l0_mm,
                checked.identification.urgent_l0_mm
            ),
            (20.0, 35.0)
        );
        let mut model = base.clone();
        model.run.speed_km_per_h += 1.0;
        assert_ne!(id(&base), id(&model));
    }

    #[test]
    fn sample_columns_are_zero_padded_without_dots() {
        assert_eq!(sample_column("rps2", 137, 1000), "rps2_t0137");
        assert_eq!(sample_column("rps1", 5, 20000), "rps1_t00005");
        let cal = Calibration::default().check().unwrap();
        let axes = sensor_axes(&cal);
        let schema = arrow_schema(&axes);
        assert_eq!(schema.fields().len(), 1 + 7 + 5 * 1000);
        assert_eq!(
            schema.field(sample_column_index(&axes, 1, 137)).name(),
            "rps2_t0137"
        );
        assert!(schema
            .fields()
            .iter()
            .all(|f| !f.name().contains('.') && !f.is_nullable()));
    }

    #[test]
    fn bank_id_changes_with_calibration_and_size() {
        let cal = Calibration::default().check().unwrap();
        let a = bank_id(&cal, 100, 0, 50, "x");
        assert_eq!(a, bank_id(&cal, 100, 0, 50, "x"));
        assert_ne!(a, bank_id(&cal, 101, 0, 50, "x"));
        let mut c = cal.document().clone();
        c.track.pad_stiffness_n_per_m *= 1.01;
        assert_ne!(a, bank_id(&c.check().unwrap(), 100, 0, 50, "x"));
    }
}
