//! A whole train pass: a recording and its trigger file (and consist), each bogie identified
//! against the member its speed and load pick, refined on request, its table written and its
//! bogies stored.

use super::input::{read_text, MAX_MEASUREMENT_BYTES, MAX_TRIGGER_BYTES};
use super::{store, PassError};
use crate::history::{Db, PassMeta, PassRecord};
use crate::identify::detect::family::Members;
use crate::identify::refine::RefineSettings;
use crate::identify::{Identifier, Measurement};
use crate::train::TrainResult;
use std::path::{Path, PathBuf};

/// A train pass identified: the result and, per bogie, the member it was compared with.
pub struct TrainPass {
    /// Every bogie and wheel.
    pub result: TrainResult,
    /// Per bogie, the member of the family (index) it was compared with.
    pub members: Vec<usize>,
    /// How long the train's identification took (ms), stored with each bogie's pass.
    pub answer_ms: f64,
}

/// One train pass, a recording and its trigger file, against a bank or a bank family: each
/// bogie's speed (from its trigger pair) picks the member it is compared with, which must
/// cover a train ([`crate::train::check_coverage`]). With `refine`, every wheel
/// with a flat is refined with those settings ([`crate::train::refine_wheels`]). A consist names the bogies; it is checked
/// before any bogie is identified.
pub fn identify_train(
    members: &mut Members,
    recording: &Path,
    triggers: &Path,
    consist: Option<&Path>,
    refine: Option<RefineSettings>,
) -> Result<TrainPass, PassError> {
    let started = std::time::Instant::now();
    let rate = members.family().sample_rate_hz;
    let text = read_text(recording, MAX_MEASUREMENT_BYTES, "recording")?;
    let m = Measurement::from_csv(recording, &text, rate)?;
    let ttext = read_text(triggers, MAX_TRIGGER_BYTES, "trigger file")?;
    let times = crate::train::read_triggers(triggers, &ttext)?;
    let cal = members
        .any()?
        .bank()
        .metadata()
        .calibration
        .clone()
        .check()
        .map_err(|e| PassError::StoredCalibration(Box::new(e)))?;
    let bogies = crate::train::bogies_from_triggers(&cal, triggers, &times)?;
    let ids = match consist {
        Some(p) => {
            let text = read_text(p, MAX_TRIGGER_BYTES, "consist file")?;
            Some(crate::history::consist::read_consist(
                p,
                &text,
                bogies.len(),
            )?)
        }
        None => None,
    };
    let mut picked = Vec::with_capacity(bogies.len());
    for (b, bogie) in bogies.iter().enumerate() {
        // The bogie's speed, then the load its part of the record shows, pick the member.
        let mut at_bogie = m.clone();
        at_bogie.laser_trigger_s = Some(bogie.triggers_s[0]);
        at_bogie.speed_km_per_h = Some(bogie.speed_km_per_h);
        let k = members
            .member_for_pass(&at_bogie, None, false)
            .map_err(|source| PassError::NoMemberForBogie {
                triggers: triggers.to_path_buf(),
                bogie: b + 1,
                source: Box::new(source),
            })?;
        if !picked.contains(&k) {
            crate::train::check_coverage(members.get(k).bank(), &members.family().members[k].dir)?;
        }
        picked.push(k);
    }
    let identifiers: Vec<&Identifier> = picked.iter().map(|&k| members.get(k)).collect();
    let mut result = crate::train::identify_bogies(&identifiers, &m, &bogies)?;
    if let Some(settings) = refine {
        crate::train::refine_wheels(&mut result, &identifiers, settings)?;
    }
    if let Some(ids) = ids {
        for (b, id) in ids.iter().enumerate() {
            result.bogies[b].bogie_id = Some(id.clone());
        }
        for w in &mut result.wheels {
            w.wheel_id = Some(format!("{}/{}", ids[w.bogie - 1], w.wheel.name()));
        }
    }
    Ok(TrainPass {
        result,
        members: picked,
        answer_ms: started.elapsed().as_secs_f64() * 1e3,
    })
}

/// What storing a train pass did: bogie passes new to the database, and those the consist
/// named.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Stored {
    /// Bogie passes not stored before.
    pub new: usize,
    /// Bogies with an id (from the consist).
    pub named: usize,
}

/// Stores every bogie of a train pass in the results database (each bogie a pass, keyed by
/// the recording, its triggers and the bogie's place); `result_dir`: where the train's table
/// was written, when it was.
pub fn store_train(
    db: &mut Db,
    members: &Members,
    pass: &TrainPass,
    files: &[&Path],
    result_dir: Option<&Path>,
) -> Result<Stored, PassError> {
    let time_s = crate::history::db::now_s();
    let result = &pass.result;
    let mut stored = Stored { new: 0, named: 0 };
    for (b, bogie) in result.bogies.iter().enumerate() {
        let identifier = members.get(pass.members[b]);
        let meta = PassMeta {
            key: store::pass_key(files, &format!("bogie {}", b + 1))?,
            time_s,
            measurement: format!("{} (bogie {})", result.recording, b + 1),
            bank_id: identifier.bank().metadata().bank_id.clone(),
            speed_km_per_h: Some(bogie.speed_km_per_h),
            bank_speed_km_per_h: bogie.bank_speed_km_per_h,
            load_kn: bogie.load.as_ref().map(|l| l.wheel_load_kn),
            bogie_id: bogie.bogie_id.clone(),
            summary: bogie
                .identification
                .as_ref()
                .map_or_else(|| "No flat detected.".to_string(), |id| id.summary.clone()),
            result_dir: result_dir.map(|d| d.display().to_string()),
            answer_ms: Some(pass.answer_ms),
        };
        let rec = PassRecord::of_parts(
            meta,
            Some(&bogie.detection),
            bogie.identification.as_ref(),
            identifier,
        );
        let new = db.insert(&rec).map_err(|source| PassError::Store {
            what: format!("bogie {} of {}", b + 1, result.recording),
            source: Box::new(source),
        })?;
        stored.new += usize::from(new);
        stored.named += usize::from(bogie.bogie_id.is_some());
    }
    Ok(stored)
}

/// Writes `train.csv`, `train.json` and `train.html` into `out` (made when absent; each file
/// atomically); their paths.
pub fn write_train(result: &TrainResult, out: &Path) -> Result<[PathBuf; 3], PassError> {
    std::fs::create_dir_all(out).map_err(|source| PassError::CreateFolder {
        path: out.to_path_buf(),
        source,
    })?;
    let csv = out.join("train.csv");
    let json = out.join("train.json");
    let html = out.join("train.html");
    let write = |path: &Path, bytes: &[u8]| {
        crate::atomic::write_atomically(path, bytes).map_err(|source| PassError::Write {
            path: path.to_path_buf(),
            source,
        })
    };
    write(&csv, crate::report::train::table_csv(result).as_bytes())?;
    write(
        &json,
        serde_json::to_string_pretty(result)
            .expect("train result serialises")
            .as_bytes(),
    )?;
    write(&html, crate::report::train::table_html(result).as_bytes())?;
    Ok([csv, json, html])
}
