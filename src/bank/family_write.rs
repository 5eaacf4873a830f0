//! Writing a bank family ([`super::family`]): each member's entry, `family.json`, and the generation of every
//! member of a band (and load band).

use super::family::FAMILY_FILE;
use super::family::{member_dir_name, member_grid, FamilyManifest, MemberEntry, SpeedBand};
use super::family::{FAMILY_FORMAT, FAMILY_FORMAT_LOADS};
use crate::bank::generate::{generate, GenerateOptions, Outcome};
use crate::bank::loads::LoadBand;
use crate::bank::observer::GenerateObserver;
use crate::bank::version::read_current;
use crate::bank::BankError;
use crate::model::calibration::VehicleParams;
use crate::model::CheckedCalibration;
use std::path::Path;

/// The entry of member `dir` (a complete bank) at `speed` (and, in a family over loads, at
/// load factor `load.0` with static wheel load `load.1` kN): its `CURRENT`, as pinned now.
pub fn member_entry(
    dir: &Path,
    speed_km_per_h: f64,
    load: Option<(f64, f64)>,
) -> Result<MemberEntry, BankError> {
    let c = read_current(dir)?.ok_or_else(|| BankError::NotABank {
        dir: dir.to_path_buf(),
    })?;
    // Only a manifest that hashes to what the member's CURRENT says is pinned.
    let manifest = crate::bank::version::manifest_as_stated(&c, "CURRENT says")?;
    let manifest_sha256 = match &c.manifest_sha256 {
        Some(s) => s.clone(),
        None => crate::bank::version::manifest_sha256(&c.version)?,
    };
    Ok(MemberEntry {
        speed_km_per_h,
        dir: member_dir_name(speed_km_per_h, load.map(|l| l.0)),
        load_factor: load.map(|l| l.0),
        wheel_load_kn: load.map(|l| l.1),
        version: c
            .version
            .file_name()
            .map(|n| n.to_string_lossy().to_string())
            .unwrap_or_default(),
        manifest_sha256,
        bank_id: manifest.bank_id,
    })
}

/// Writes `DIR/family.json` (atomically) for `band` (× `loads`, factors of the car-body mass
/// of the vehicle given with them), pinning every member's `CURRENT` as it is now; every
/// member must be complete.
pub fn write_family_manifest(
    dir: &Path,
    band: SpeedBand,
    loads: Option<(LoadBand, &VehicleParams)>,
    sample_rate_hz: f64,
) -> Result<FamilyManifest, BankError> {
    let members = member_grid(&band, loads.as_ref().map(|l| &l.0))
        .into_iter()
        .map(|(v, f)| {
            let load = f
                .zip(loads.as_ref())
                .map(|(f, (b, vehicle))| (f, b.wheel_load_kn(f, vehicle)));
            member_entry(&dir.join(member_dir_name(v, f)), v, load)
        })
        .collect::<Result<Vec<_>, _>>()?;
    let loads = loads.map(|l| l.0);
    let m = FamilyManifest {
        format: if loads.is_some() {
            FAMILY_FORMAT_LOADS
        } else {
            FAMILY_FORMAT
        }
        .into(),
        band,
        loads,
        sample_rate_hz,
        members,
    };
    let mut text = serde_json::to_string_pretty(&m).expect("a family manifest serialises");
    text.push('\n');
    crate::bank::generate::write_file_atomically(&dir.join(FAMILY_FILE), text.as_bytes())?;
    Ok(m)
}

/// What a family generation did, member by member.
#[derive(Debug, Clone, PartialEq)]
pub struct FamilyOutcome {
    /// Each member's directory name, outcome and the seconds it took.
    pub members: Vec<(String, Outcome, f64)>,
    /// Whether `family.json` was written (every member complete); `false` after `--shard`
    /// runs, which leave it to `bank merge`.
    pub manifest_written: bool,
}

/// Generates (or, with `opts.simulate_missing` false, merges) every member of `band` (× `loads`)
/// in `dir`, one after the other, each a bank of `cal` at its speed (and car-body mass) with
/// the same options (`--shard I/N` takes part I of every member); then, when all are
/// complete, writes `family.json`. `member_started` is told each member (its index, the
/// count, its directory name) before its work starts.
pub fn generate_family(
    cal: &CheckedCalibration,
    dir: &Path,
    band: SpeedBand,
    loads: Option<LoadBand>,
    opts: &GenerateOptions,
    observer: &dyn GenerateObserver,
    member_started: &dyn Fn(usize, usize, &str),
) -> Result<FamilyOutcome, BankError> {
    band.check().map_err(BankError::SpeedBand)?;
    if let Some(b) = &loads {
        b.check(&cal.vehicle)
            .map_err(|reason| BankError::LoadBand {
                band: b.to_string(),
                reason,
            })?;
        if (b.car_body_mass_kg - cal.vehicle.car_body_mass_kg).abs() > 1e-6 {
            return Err(BankError::LoadsOfAnotherCarBody {
                family_kg: b.car_body_mass_kg,
                calibration_kg: cal.vehicle.car_body_mass_kg,
            });
        }
    }
    if read_current(dir)?.is_some() {
        return Err(BankError::SingleBankThere {
            dir: dir.to_path_buf(),
        });
    }
    let grid = member_grid(&band, loads.as_ref());
    let mut members = Vec::with_capacity(grid.len());
    for (k, &(v, f)) in grid.iter().enumerate() {
        let name = member_dir_name(v, f);
        member_started(k, grid.len(), &name);
        let member_cal = at_speed_and_load(cal, v, f)?;
        // A member stored unfolded (its speed has no whole number of samples per bay) holds
        // as many instances as the folded members read.
        let unfolded = cal.fold_factor() / member_cal.fold_factor();
        let member_opts = GenerateOptions {
            instances: opts.instances * unfolded,
            ..opts.clone()
        };
        let opts = &member_opts;
        let member_dir = dir.join(&name);
        std::fs::create_dir_all(&member_dir).map_err(|source| BankError::Io {
            path: member_dir.clone(),
            source,
        })?;
        let started = std::time::Instant::now();
        let outcome = generate(&member_cal, &member_dir, opts, observer)?;
        members.push((name, outcome, started.elapsed().as_secs_f64()));
    }
    let complete = members
        .iter()
        .all(|(_, o, _)| !matches!(o, Outcome::ShardDone { .. }));
    if complete {
        write_family_manifest(
            dir,
            band,
            loads.map(|b| (b, &cal.vehicle)),
            cal.output.sample_rate_hz,
        )?;
    }
    Ok(FamilyOutcome {
        members,
        manifest_written: complete,
    })
}

/// The calibration `cal` at train speed `speed` km/h (a family member's), checked.
pub fn at_speed(
    cal: &CheckedCalibration,
    speed_km_per_h: f64,
) -> Result<CheckedCalibration, BankError> {
    at_speed_and_load(cal, speed_km_per_h, None)
}

/// The calibration `cal` at train speed `speed` km/h and, when given, `load` × its car-body
/// mass (a family member's), checked.
pub fn at_speed_and_load(
    cal: &CheckedCalibration,
    speed_km_per_h: f64,
    load: Option<f64>,
) -> Result<CheckedCalibration, BankError> {
    let mut doc = cal.document().clone();
    doc.run.speed_km_per_h = speed_km_per_h;
    if let Some(f) = load {
        doc.vehicle.car_body_mass_kg *= f;
    }
    // A folded population needs a whole number of samples per sleeper bay; a member at a speed
    // without one stores the same instances over the whole revolution instead (docs/bank.md
    // "Folded banks": four times coarser in X_p).
    if doc.population.fold_to_one_bay && !doc.bay_is_whole_samples() {
        doc.population.fold_to_one_bay = false;
    }
    doc.check().map_err(|source| BankError::DerivedCalibration {
        context: format!("at {speed_km_per_h} km/h"),
        source,
    })
}
