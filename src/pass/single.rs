//! One measurement: identified against the member of its bank or family, refined on request,
//! its result written and its pass stored.

use super::{input, store, PassError};
use crate::history::{Db, PassRecord};
use crate::identify::detect::family::Members;
use crate::identify::refine::{bank_simulator, refine, RefineSettings};
use crate::identify::{Extras, Identification, Identifier, Measurement};
use std::path::{Path, PathBuf};

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
/// `file`; its result written into `result_dir`; its answer took `answer_ms`), stored;
/// whether it is new.
pub fn store_measurement(
    db: &mut Db,
    id: &Identification,
    identifier: &Identifier,
    m: &Measurement,
    file: &Path,
    result_dir: &Path,
    answer_ms: Option<f64>,
) -> Result<bool, PassError> {
    let mut rec = record(id, identifier, m, file, result_dir)?;
    rec.meta.answer_ms = answer_ms;
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
/// the measurement as read, where its result was written, and whether its pass was new to the
/// database (`None`: none).
pub struct Pass {
    /// The identification.
    pub id: Identification,
    /// The measurement (its speed stated).
    pub measurement: Measurement,
    /// `identification.json`.
    pub json: PathBuf,
    /// Stored in the results database: new (`true`) or already in (`false`).
    pub stored: Option<bool>,
}

/// What a pass of one measurement asks for besides the measurement: the same request for
/// every command that identifies one (`identify`, `watch`, `demo --serve`).
#[derive(Debug, Clone, Copy)]
pub struct Request<'a> {
    /// Only these sensors (all when `None`).
    pub sensors: Option<&'a [String]>,
    /// What the report needs besides the answer (baselines, curves).
    pub extras: Extras,
    /// Refine with this many simulations (`--refine`), when given.
    pub refine_simulations: Option<usize>,
    /// The folder its result goes into.
    pub out: &'a Path,
}

/// One measurement's pass against `identifier`: identified, refined when asked,
/// `identification.json` written into the request's folder, then stored in `db` (keyed by the
/// SHA-256 of `file`, with how long it took from here to its result written) — a pass is
/// stored only once its result is written.
pub fn identify_measurement(
    identifier: &Identifier,
    measurement: Measurement,
    file: &Path,
    request: Request,
    db: Option<&mut Db>,
) -> Result<Pass, PassError> {
    let started = std::time::Instant::now();
    let mut id = identifier.identify(&measurement, request.sensors, request.extras)?;
    if let Some(simulations) = request.refine_simulations {
        refine_into(identifier, &mut id, simulations)?;
    }
    let json = id
        .write_json(request.out)
        .map_err(|source| PassError::Report {
            dir: request.out.to_path_buf(),
            source: Box::new(source.into()),
        })?;
    let stored = match db {
        Some(db) => Some(store_measurement(
            db,
            &id,
            identifier,
            &measurement,
            file,
            request.out,
            Some(started.elapsed().as_secs_f64() * 1e3),
        )?),
        None => None,
    };
    Ok(Pass {
        id,
        measurement,
        json,
        stored,
    })
}

/// A resident identifier's pass (`watch`): reads `path` and identifies it
/// ([`identify_measurement`]) against the member its speed and load pick.
pub fn identify_file(
    members: &mut Members,
    path: &Path,
    request: Request,
    db: Option<&mut Db>,
) -> Result<Pass, PassError> {
    let (m, k) = input::read_measurement(members, path, None, false)?;
    identify_measurement(members.get(k), m, path, request, db)
}
