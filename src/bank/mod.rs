//! The model bank: the whole population simulated once, offline, stored as columnar Parquet
//! (wide layout: one f32 column per sensor sample), read back through a memory map.
//!
//! - [`population`]: Hammersley sampling of (L, d, c, X_p).
//! - [`schema`]: file and column names, metadata (written and read back), manifest; both
//!   [`generate`] and [`reader`] build on it, neither on the other.
//! - [`writer`]: one shard file.
//! - [`generate`]: parallel generation, resume, versions and the `CURRENT` pointer.
//! - [`family`]: banks at speeds across a band, the member a pass is compared with.
//! - [`reader`]: memory-mapped reading of projected columns; verification.
//! - [`info`]: a bank's size and parameter ranges.
//! - [`neighbours`]: the instances' neighbour graph, built at generation, stored with the bank.
//! - [`derived`]: the tables a pass needs (departures, roughness, out of round), built with
//!   the bank.
//! - [`layout`]: where every column's values lie in the shards, so a reader skips the footers.
//! - [`version`]: `CURRENT`, the manifest and the files beside the shards, checked as read.
//! - [`verify`]: every file checked against the manifest in full.
//! - [`lock`]: one writer at a time per bank directory; [`prune`]: old versions removed.

mod band;
mod cache;
pub(crate) mod departures;
pub(crate) mod derived;
pub mod family;
pub mod family_write;
mod fold;
mod gather;
pub mod generate;
pub(crate) mod info;
pub(crate) mod layout;
pub(crate) mod loads;
pub(crate) mod lock;
pub mod neighbours;
mod observer;
pub mod out_of_round;
pub(crate) mod population;
pub(crate) mod prune;
pub(crate) mod reader;
pub mod roughness;
mod rows;
pub mod schema;
pub(crate) mod simulate;
mod speeds;
pub(crate) mod verify;
pub(crate) mod version;
mod warm;
pub(crate) mod writer;

pub use generate::{generate, GenerateOptions, Outcome};
pub use info::{parameter_ranges, BankSize};
pub use layout::{Layout, ShardLayout};
pub use loads::LoadBand;
pub use lock::{lock, Access, WriterLock, LOCK_FILE};
pub use observer::{GenerateObserver, Quiet};
pub use population::{FlatSample, Population};
pub use prune::{prune, prune_keeping, Pruned};
pub use reader::{Bank, Parameters, StoredInstance};
pub use schema::{BankMetadata, Manifest};
pub use verify::{verify, VerifyProblem};
pub use version::{current_text, read_current, read_manifest};
pub use writer::{Codec, StorageFormat, ValueEncoding};

use std::path::PathBuf;
use thiserror::Error;

/// Errors of the bank layer.
#[derive(Debug, Error)]
pub enum BankError {
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// Parquet could not write a file.
    #[error("{path}: cannot write Parquet: {message}")]
    Parquet {
        /// The file.
        path: PathBuf,
        /// The writer's message.
        message: String,
    },
    /// A bank file is unreadable, truncated or foreign.
    #[error("{path}: corrupt or foreign bank file: {message}")]
    Corrupt {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The directory holds neither a `CURRENT` pointer nor a manifest.
    #[error("{dir} is not a wheelflat bank (no CURRENT file and no manifest.json)")]
    NotABank {
        /// The directory.
        dir: PathBuf,
    },
    /// `bank merge` found shard files missing.
    #[error("{dir} is incomplete: missing {}", missing.join(", "))]
    Incomplete {
        /// The version directory.
        dir: PathBuf,
        /// Missing file names.
        missing: Vec<String>,
    },
    /// An instance could not be simulated.
    #[error("instance {instance}: {message}")]
    Instance {
        /// Instance number.
        instance: usize,
        /// The simulator's message.
        message: String,
    },
    /// The simulator could not be built.
    #[error(transparent)]
    Sim(#[from] crate::model::SimError),
    /// Another writer holds the bank directory.
    #[error("{dir} is being written by {holder} right now: wait for it to finish (the lock goes when that process ends, however it ends)")]
    Locked {
        /// The bank directory.
        dir: PathBuf,
        /// Who holds it, in words.
        holder: String,
    },
    /// A speed band that does not check (the band's own words: which of FROM, TO, STEP and
    /// why).
    #[error("{0}")]
    SpeedBand(String),
    /// A load band that does not check for the calibration's vehicle.
    #[error("loads {band}: {reason}")]
    LoadBand {
        /// The band as given.
        band: String,
        /// Why, in the band check's words.
        reason: String,
    },
    /// A family over loads regenerated with a calibration of another car-body mass.
    #[error("the family's loads are factors of a {family_kg} kg car body; the calibration's is {calibration_kg} kg: regenerate with --loads")]
    LoadsOfAnotherCarBody {
        /// The car body the family's load factors are of (kg).
        family_kg: f64,
        /// The calibration's (kg).
        calibration_kg: f64,
    },
    /// A column asked for that holds no force samples (the parameters, or beyond the bank).
    #[error("column {column} is not a force-sample column")]
    NotForceColumn {
        /// The column.
        column: usize,
    },
    /// A shard read through the layout asked for its footer (a defect of the caller).
    #[error("{}: read through the layout, its footer was not parsed", path.display())]
    FooterNotParsed {
        /// The shard file.
        path: PathBuf,
    },
    /// A buffer for columns of another size than the columns asked for (a defect of the
    /// caller).
    #[error("a buffer of {values} values for {columns} columns of {instances} instances")]
    BufferSize {
        /// Values the buffer holds.
        values: usize,
        /// Columns asked for.
        columns: usize,
        /// Stored instances.
        instances: usize,
    },
    /// An instance the bank does not hold.
    #[error("instance {instance} is not in the bank (it holds instances 0 to {last})")]
    NoSuchInstance {
        /// The instance asked for.
        instance: usize,
        /// The last it holds.
        last: usize,
    },
    /// A family asked for in a directory that holds a single bank.
    #[error("{} holds a single bank (CURRENT); a family needs a directory of its own", dir.display())]
    SingleBankThere {
        /// The directory.
        dir: PathBuf,
    },
    /// `bank prune --keep 0`.
    #[error("--keep must be at least 1: the version CURRENT names is always kept")]
    KeepNone,
    /// No instances, or shard files of none.
    #[error("instances and shard size must be positive")]
    Empty,
    /// More instances than the instance column holds.
    #[error("{instances} instances exceed the u32 instance column")]
    TooManyInstances {
        /// Instances asked for.
        instances: usize,
    },
    /// `--shard I/N` outside `0 <= I < N`.
    #[error("shard {index}/{count}: need 0 <= I < N")]
    Shard {
        /// I.
        index: usize,
        /// N.
        count: usize,
    },
    /// The calibration cannot be stored as asked (a folded population it cannot fold).
    #[error(transparent)]
    Calibration(#[from] crate::model::CalibrationError),
    /// A calibration derived from the bank's (a family member's, the stored one) does not
    /// check.
    #[error("{context}")]
    DerivedCalibration {
        /// Which calibration.
        context: String,
        /// Why.
        #[source]
        source: crate::model::CalibrationError,
    },
}
