//! One measurement: identified against the member of its bank or family, refined on request,
//! its result written and its pass stored.

use super::{input, store, PassError};
use crate::history::{Db, PassRecord};
use crate::identify::detect::family::Members;
use crate::identify::refine::{bank_simulator, refine, RefineSettings};
use crate::identify::{Extras, Identification, Identifier, Measurement};
use std::path::{Path, PathBuf};

/// Refines `id` ([`crate::identify::refine`]) as `settings` say, with the identifier's bank
/// calibration, and keeps the result in `id.refinement`.
pub fn refine_into(
    identifier: &Identifier,
    id: &mut Identification,
    settings: RefineSettings,
) -> Result<(), PassError> {
    let sim = bank_simulator(identifier)?;
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
    /// Refine with these settings (`--refine`), when given.
    pub refine: Option<RefineSettings>,
    /// The folder its result goes into.
    pub out: &'a Path,
}

/// The pass's answer refined when asked, `identification.json` written into the request's
/// folder, then stored in `db` (keyed by the SHA-256 of `file`, with how long it took from
/// `started` to its result written) — a pass is stored only once its result is written.
fn finish(
    identifier: &Identifier,
    mut id: Identification,
    measurement: Measurement,
    file: &Path,
    request: Request,
    db: Option<&mut Db>,
    started: std::time::Instant,
) -> Result<Pass, PassError> {
    if let Some(settings) = request.refine {
        refine_into(identifier, &mut id, settings)?;
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

/// One measurement's pass against member `k` of `members` (as [`input::read_measurement`]
/// picked it): identified, refined when asked, written and stored ([`finish`]), with one more
/// step for a family over loads: when member `k` refutes every
/// instance, the pass is compared with the members next to it by load at its speed (the
/// nearer first, [`Members::load_neighbours`]) and the first one with an answer is taken, the
/// summary saying so. A load read a few per cent off (a light wagon's car body moving on its
/// springs) can pick a member the flat does not fit at that load; the flats of the next load
/// are as much an answer as a refutation would be a wrong one. Refuted only when every
/// neighbour refutes too.
pub fn identify_in(
    members: &mut Members,
    k: usize,
    measurement: Measurement,
    file: &Path,
    request: Request,
    db: Option<&mut Db>,
) -> Result<Pass, PassError> {
    let started = std::time::Instant::now();
    let mut id = members
        .get(k)
        .identify(&measurement, request.sensors, request.extras)?;
    let mut used = k;
    if id.model_class_refuted() {
        for j in members.load_neighbours(k)? {
            let other = members
                .get(j)
                .identify(&measurement, request.sensors, request.extras)?;
            if !other.model_class_refuted() && other.sizing.is_some() {
                let load = |i: usize| members.family().members[i].wheel_load_kn;
                id = other;
                id.summary = format!(
                    "{} (Compared with the {:.1} kN member: the {:.1} kN member its load read picked refutes every instance.)",
                    id.summary,
                    load(j),
                    load(k)
                );
                used = j;
                break;
            }
        }
    }
    finish(
        members.get(used),
        id,
        measurement,
        file,
        request,
        db,
        started,
    )
}

/// A resident identifier's pass (`watch`): reads `path` and identifies it
/// ([`identify_in`]) against the member its speed and load pick.
pub fn identify_file(
    members: &mut Members,
    path: &Path,
    request: Request,
    db: Option<&mut Db>,
) -> Result<Pass, PassError> {
    let (m, k) = input::read_measurement(members, path, None, false)?;
    identify_in(members, k, m, path, request, db)
}
