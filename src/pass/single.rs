//! One measurement: identified against the member of its bank or family, refined on request,
//! its result written and its pass stored.

use super::{input, store, PassError};
use crate::history::{Db, PassRecord};
use crate::identify::detect::family::Members;
use crate::identify::refine::{bank_simulator, refine, RefineSettings};
use crate::identify::{Extras, Identification, Identifier, Measurement};
use std::path::Path;

/// Refines `id` ([`crate::identify::refine`]) with `simulations` new flats and the
/// identifier's bank calibration, and keeps the result in `id.refinement`.
pub fn refine_into(
    identifier: &Identifier,
    id: &mut Identification,
    simulations: usize,
) -> Result<(), PassError> {
    let sim = bank_simulator(identifier)?;
    let settings = RefineSettings {
        simulations,
        ..RefineSettings::default()
    };
    id.refinement = Some(refine(identifier, &sim, id, settings)?);
    Ok(())
}

/// The record of one identified measurement in the results database (keyed by the SHA-256 of
/// `file`; its result written into `result_dir`), stored; whether it is new.
pub fn store_measurement(
    db: &mut Db,
    id: &Identification,
    identifier: &Identifier,
    m: &Measurement,
    file: &Path,
    result_dir: &Path,
) -> Result<bool, PassError> {
    let rec = record(id, identifier, m, file, result_dir)?;
    store::store(db, &rec)
}

/// The record of one identified measurement, keyed by the SHA-256 of `file`, at this time;
/// its result written into `result_dir`.
pub fn record(
    id: &Identification,
    identifier: &Identifier,
    m: &Measurement,
    file: &Path,
    result_dir: &Path,
) -> Result<PassRecord, PassError> {
    let mut rec = PassRecord::of(
        id,
        identifier,
        m.bogie_id.as_deref(),
        store::pass_key(&[file], "")?,
        crate::history::db::now_s(),
    );
    rec.meta.result_dir = Some(result_dir.display().to_string());
    Ok(rec)
}

/// What one pass of a single measurement gave: its identification (refined when asked),
/// the measurement as read, and whether its pass was new to the database (`None`: none).
pub struct Pass {
    /// The identification.
    pub id: Identification,
    /// The measurement (its speed stated).
    pub measurement: Measurement,
    /// Stored in the results database: new (`true`) or already in (`false`).
    pub stored: Option<bool>,
}

/// A resident identifier's pass (`watch`): reads `path`, identifies it against the member its
/// speed and load pick, refines it with `refine_simulations` when given, writes
/// `identification.json` into `out` and stores the pass in `db` (after the result is written,
/// before the caller moves the input).
pub fn identify_file(
    members: &mut Members,
    path: &Path,
    sensors: Option<&[String]>,
    refine_simulations: Option<usize>,
    out: &Path,
    db: Option<&mut Db>,
) -> Result<Pass, PassError> {
    let (m, k) = input::read_measurement(members, path, None, false)?;
    let identifier = members.get(k);
    let mut id = identifier.identify(&m, sensors, Extras::NONE)?;
    if let Some(simulations) = refine_simulations {
        refine_into(identifier, &mut id, simulations)?;
    }
    id.write_json(out).map_err(|source| PassError::Report {
        dir: out.to_path_buf(),
        source: Box::new(source.into()),
    })?;
    let stored = match db {
        Some(db) => Some(store_measurement(db, &id, identifier, &m, path, out)?),
        None => None,
    };
    Ok(Pass {
        id,
        measurement: m,
        stored,
    })
}
