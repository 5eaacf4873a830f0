//! A bank family: banks of one calibration at train speeds across a band, so that every pass
//! is compared with a bank of its own speed.
//!
//! ```text
//! DIR/family.json          the band and, per member, the version readers use (atomic rename)
//! DIR/speed-46.0/          a complete bank (CURRENT, v-<bank id>/, …) simulated at 46 km/h
//! DIR/speed-48.0/
//! …
//! ```
//!
//! A family over loads as well (`--loads`, [`super::loads`]) has a member per speed and load
//! (`DIR/speed-50.0-load-0.60/`, …) and the format [`FAMILY_FORMAT_LOADS`]; a pass is compared
//! with the members at its speed, the one nearest the load its record shows.
//!
//! `family.json` is the family's `CURRENT`: it pins each member's version directory and its
//! manifest's SHA-256, and is replaced only when every member is complete, so a reader never
//! mixes members of two calibrations however long a nightly regeneration takes. A member is
//! a bank in its own right (`bank info DIR/speed-46.0` works) and is opened through the pin.
//!
//! A pass is compared with the member nearest its speed, and only when that member is within
//! [`SPEED_TOLERANCE`] of it (relative); outside the band the pass is refused with the band
//! named. A single bank is a family of one member at its speed.

use super::loads::{nearest_however_far, nearest_load, LoadBand};
use super::loads::{LOAD_TOLERANCE_HEAVIER, LOAD_TOLERANCE_LIGHTER};
use super::schema::{sha256_hex, MANIFEST};
pub use super::speeds::{SpeedBand, MAX_MEMBERS, SPEED_TOLERANCE};
use super::version::Current;
use super::{Bank, BankError};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The family manifest's file name.
pub const FAMILY_FILE: &str = "family.json";
/// The family manifest's format.
pub const FAMILY_FORMAT: &str = "wheelflat-bank-family-1";
/// The format of a family over loads as well (older wheelflats refuse it by its name).
pub const FAMILY_FORMAT_LOADS: &str = "wheelflat-bank-family-2";
/// The largest family manifest read (a few hundred bytes a member).
const MAX_FAMILY_BYTES: u64 = 1 << 20;

/// The directory name of the member at `speed` km/h (and, in a family over loads, at
/// `load` × the calibration's car-body mass).
pub fn member_dir_name(speed_km_per_h: f64, load: Option<f64>) -> String {
    match load {
        None => format!("speed-{speed_km_per_h:.1}"),
        Some(f) => format!("speed-{speed_km_per_h:.1}-load-{f:.2}"),
    }
}

/// One member as `family.json` lists it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MemberEntry {
    /// The member's train speed (km/h).
    pub speed_km_per_h: f64,
    /// Its bank directory, beside `family.json`.
    pub dir: String,
    /// Its version directory inside `dir` (`v-<bank id>`).
    pub version: String,
    /// That version's manifest's SHA-256.
    pub manifest_sha256: String,
    /// Its bank id.
    pub bank_id: String,
    /// In a family over loads: its factor of the band's car-body mass.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub load_factor: Option<f64>,
    /// In a family over loads: its static wheel load (kN).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wheel_load_kn: Option<f64>,
}

/// `family.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FamilyManifest {
    /// [`FAMILY_FORMAT`].
    pub format: String,
    /// The band the members were generated for.
    pub band: SpeedBand,
    /// The load band, in a family over loads ([`FAMILY_FORMAT_LOADS`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub loads: Option<LoadBand>,
    /// The members' sample rate (Hz), the same for all: a measurement is read on it before
    /// its speed picks a member.
    pub sample_rate_hz: f64,
    /// The members, by increasing speed (and, at one speed, increasing load).
    pub members: Vec<MemberEntry>,
}

/// A family member as a reader finds it.
#[derive(Debug, Clone, PartialEq)]
pub struct Member {
    /// Train speed (km/h).
    pub speed_km_per_h: f64,
    /// Its static wheel load (kN): what a pass's load is compared with.
    pub wheel_load_kn: f64,
    /// Its car-body mass (kg), in a family over loads (checked when it is opened).
    pub car_body_mass_kg: Option<f64>,
    /// Its factor of the family's car-body mass, in a family over loads.
    pub load_factor: Option<f64>,
    /// The family's sample rate (Hz).
    pub sample_rate_hz: f64,
    /// The bank directory (for messages).
    pub dir: PathBuf,
    /// The pinned version and its manifest hash (a single bank: the version it was opened at,
    /// through its `CURRENT`, with no pin of its own).
    pub current: Current,
}

impl Member {
    /// Opens the member's bank through its pin, and checks that it was simulated at the speed
    /// the family says.
    pub fn open(&self) -> Result<Bank, BankError> {
        let bank = Bank::open_current(&self.current)?;
        let cal = &bank.metadata().calibration;
        let (speed, rate) = (cal.run.speed_km_per_h, cal.output.sample_rate_hz);
        if (speed - self.speed_km_per_h).abs() > 1e-9 || (rate - self.sample_rate_hz).abs() > 1e-9 {
            return Err(BankError::Corrupt {
                path: self.current.version.join(MANIFEST),
                message: format!(
                    "simulated at {speed} km/h and {rate} Hz, but the family lists it at {} km/h and {} Hz",
                    self.speed_km_per_h, self.sample_rate_hz
                ),
            });
        }
        let mass = cal.vehicle.car_body_mass_kg;
        if let Some(listed) = self.car_body_mass_kg.filter(|m| (m - mass).abs() > 1e-6) {
            return Err(BankError::Corrupt {
                path: self.current.version.join(MANIFEST),
                message: format!(
                    "simulated with a {mass} kg car body, but the family lists it at {listed} kg"
                ),
            });
        }
        Ok(bank)
    }
}

/// A bank family, or a single bank seen as a family of one.
#[derive(Debug, Clone, PartialEq)]
pub struct Family {
    /// The directory given.
    pub dir: PathBuf,
    /// The band, for a family (`None`: a single bank).
    pub band: Option<SpeedBand>,
    /// The load band, for a family over loads.
    pub loads: Option<LoadBand>,
    /// Members by increasing speed.
    pub members: Vec<Member>,
    /// The members' sample rate (Hz).
    pub sample_rate_hz: f64,
    /// What changes when readers should switch: `family.json`'s SHA-256, or the single bank's
    /// version and manifest hash.
    pub key: String,
}

/// Why no member suits a pass.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct SpeedError(pub String);

impl Family {
    /// Opens `dir`: a family (`family.json`) or a single bank (`CURRENT` or a version
    /// directory; its speed is read from its metadata, so this opens it).
    pub fn open(dir: &Path) -> Result<(Family, Option<Bank>), BankError> {
        let path = dir.join(FAMILY_FILE);
        if !path.is_file() {
            // The key before the bank: one regenerated in between is noticed at the next look.
            let key = Family::current_key(dir)?;
            let bank = Bank::open(dir)?;
            let cal = &bank.metadata().calibration;
            let family = Family {
                dir: dir.to_path_buf(),
                band: None,
                loads: None,
                sample_rate_hz: cal.output.sample_rate_hz,
                members: vec![Member {
                    speed_km_per_h: cal.run.speed_km_per_h,
                    wheel_load_kn: cal.vehicle.static_wheel_load_n() / 1e3,
                    car_body_mass_kg: None,
                    load_factor: None,
                    sample_rate_hz: cal.output.sample_rate_hz,
                    dir: dir.to_path_buf(),
                    current: Current {
                        version: bank.dir().to_path_buf(),
                        manifest_sha256: None,
                    },
                }],
                key,
            };
            return Ok((family, Some(bank)));
        }
        let (manifest, sha) = read_family_manifest(dir)?;
        let members = manifest
            .members
            .iter()
            .map(|m| {
                let member_dir = dir.join(&m.dir);
                // The pin is checked as CURRENT is: a plain version name of that bank.
                let current = read_pin(&member_dir, &m.version, &m.manifest_sha256)?;
                Ok(Member {
                    speed_km_per_h: m.speed_km_per_h,
                    wheel_load_kn: m.wheel_load_kn.unwrap_or(f64::NAN),
                    car_body_mass_kg: manifest
                        .loads
                        .zip(m.load_factor)
                        .map(|(b, f)| b.car_body_mass_kg * f),
                    load_factor: m.load_factor,
                    sample_rate_hz: manifest.sample_rate_hz,
                    dir: member_dir,
                    current,
                })
            })
            .collect::<Result<Vec<_>, BankError>>()?;
        Ok((
            Family {
                dir: dir.to_path_buf(),
                band: Some(manifest.band),
                loads: manifest.loads,
                sample_rate_hz: manifest.sample_rate_hz,
                members,
                key: sha,
            },
            None,
        ))
    }

    /// The key readers compare to notice a regenerated bank or family (see [`Family::key`]),
    /// read without opening any bank.
    pub fn current_key(dir: &Path) -> Result<String, BankError> {
        if dir.join(FAMILY_FILE).is_file() {
            return Ok(read_family_manifest(dir)?.1);
        }
        let c = super::version::resolve(dir)?;
        let sha = match c.manifest_sha256 {
            Some(s) => s,
            None => super::version::manifest_sha256(&c.version)?,
        };
        Ok(format!("{}\n{sha}", c.version.display()))
    }

    /// The member a pass at `speed` km/h is compared with: the nearest, if within
    /// [`SPEED_TOLERANCE`]; otherwise an error naming the band.
    /// The member nearest `speed_km_per_h`, however far (diagnosis, which lets the record
    /// say what its speed was).
    pub fn nearest_member(&self, speed_km_per_h: f64) -> usize {
        (0..self.members.len())
            .min_by(|&a, &b| {
                (self.members[a].speed_km_per_h - speed_km_per_h)
                    .abs()
                    .total_cmp(&(self.members[b].speed_km_per_h - speed_km_per_h).abs())
            })
            .expect("a family has members")
    }

    pub fn member_for(&self, speed_km_per_h: f64) -> Result<usize, SpeedError> {
        if !speed_km_per_h.is_finite() || speed_km_per_h <= 0.0 {
            return Err(SpeedError(format!(
                "speed {speed_km_per_h} km/h is not a train speed"
            )));
        }
        let (i, m) = self
            .members
            .iter()
            .enumerate()
            .min_by(|a, b| {
                (a.1.speed_km_per_h - speed_km_per_h)
                    .abs()
                    .total_cmp(&(b.1.speed_km_per_h - speed_km_per_h).abs())
            })
            .expect("a family has members");
        let off = speed_km_per_h / m.speed_km_per_h - 1.0;
        if off.abs() <= SPEED_TOLERANCE + 1e-12 {
            return Ok(i);
        }
        let lo = self.members[0].speed_km_per_h;
        let hi = self.members[self.members.len() - 1].speed_km_per_h;
        let band = match self.band {
            Some(b) => format!("the family {} covers {b}", self.dir.display()),
            None => format!("the bank {} is simulated at {lo} km/h", self.dir.display()),
        };
        Err(SpeedError(format!(
            "speed {speed_km_per_h} km/h: {band}, and a pass may be at most {:.0} % off a member's speed ({:.2}–{:.2} km/h in all){}",
            SPEED_TOLERANCE * 100.0,
            lo * (1.0 - SPEED_TOLERANCE),
            hi * (1.0 + SPEED_TOLERANCE),
            if self.band.is_none() {
                "; build a family over the speeds you need with `wheelflat bank generate --speeds FROM:TO:STEP`"
            } else if speed_km_per_h > lo && speed_km_per_h < hi {
                "; the nearest member is too far: regenerate with a finer --speeds step"
            } else {
                "; regenerate with a band that includes it (`wheelflat bank generate --speeds FROM:TO:STEP`)"
            }
        )))
    }
}

impl Family {
    /// The members at member `k`'s speed, by increasing load (one, unless the family is over
    /// loads as well).
    pub fn at_speed_of(&self, k: usize) -> Vec<usize> {
        let v = self.members[k].speed_km_per_h;
        (0..self.members.len())
            .filter(|&j| (self.members[j].speed_km_per_h - v).abs() < 1e-9)
            .collect()
    }

    /// The member among `at_speed` (as [`Family::at_speed_of`] gives them, with their static
    /// wheel loads `loads_kn`) a pass showing `shown_kn` a wheel is compared with
    /// ([`nearest_load`]); otherwise an error naming the loads covered
    /// (`nearest`: the nearest however far, as diagnosis wants).
    pub fn member_for_load(
        &self,
        at_speed: &[usize],
        loads_kn: &[f64],
        shown_kn: f64,
        nearest: bool,
    ) -> Result<usize, SpeedError> {
        match nearest_load(loads_kn, shown_kn) {
            Ok(j) => Ok(at_speed[j]),
            Err(_) if nearest => Ok(at_speed[nearest_however_far(loads_kn, shown_kn)]),
            Err(range) => {
                let covered = match (self.loads, loads_kn) {
                    (Some(b), _) => format!(
                        "the family {} covers {b} ({:.1}–{:.1} kN a wheel)",
                        self.dir.display(),
                        loads_kn[0],
                        loads_kn[loads_kn.len() - 1]
                    ),
                    (None, [w, ..]) => format!(
                        "the bank {} is simulated at {w:.1} kN a wheel",
                        self.dir.display()
                    ),
                    (None, []) => unreachable!("a family has members"),
                };
                Err(SpeedError(format!(
                    "load {shown_kn:.1} kN a wheel: {covered}, and a pass may be at most {:.1} % lighter or {:.0} % heavier than a member ({:.1}–{:.1} kN in all); {}",
                    LOAD_TOLERANCE_LIGHTER * 100.0,
                    LOAD_TOLERANCE_HEAVIER * 100.0,
                    range[0],
                    range[1],
                    if self.loads.is_some() {
                        "regenerate with a load band that includes it (`wheelflat bank generate --loads FROM:TO:STEP`)"
                    } else {
                        "build a family over the loads your vehicles carry with `wheelflat bank generate --loads FROM:TO:STEP` (factors of the car-body mass, e.g. 0.6:1.1:0.5)"
                    }
                )))
            }
        }
    }
}

/// Reads and checks `DIR/family.json`; with its SHA-256.
pub fn read_family_manifest(dir: &Path) -> Result<(FamilyManifest, String), BankError> {
    let path = dir.join(FAMILY_FILE);
    let bad = |message: String| BankError::Corrupt {
        path: path.clone(),
        message,
    };
    let io = |source| BankError::Io {
        path: path.clone(),
        source,
    };
    let len = std::fs::metadata(&path).map_err(io)?.len();
    if len > MAX_FAMILY_BYTES {
        return Err(bad(format!(
            "{len} bytes, more than the {MAX_FAMILY_BYTES} a family manifest may have"
        )));
    }
    let bytes = std::fs::read(&path).map_err(io)?;
    let m: FamilyManifest =
        serde_json::from_slice(&bytes).map_err(|e| bad(format!("not a family manifest: {e}")))?;
    let format = if m.loads.is_some() {
        FAMILY_FORMAT_LOADS
    } else {
        FAMILY_FORMAT
    };
    if m.format != format {
        return Err(bad(format!(
            "format `{}`: this wheelflat reads `{format}` for a family {} loads",
            m.format.chars().take(60).collect::<String>(),
            if m.loads.is_some() { "over" } else { "without" }
        )));
    }
    m.band.check().map_err(|e| bad(format!("band: {e}")))?;
    if !(m.sample_rate_hz.is_finite() && (1.0..=1e6).contains(&m.sample_rate_hz)) {
        return Err(bad(format!("sample rate {} Hz", m.sample_rate_hz)));
    }
    if let Some(b) = &m.loads {
        // The band's own checks need the vehicle's other masses: the members' loads are
        // checked below instead.
        if !(b.car_body_mass_kg > 0.0 && b.car_body_mass_kg.is_finite()) || b.step <= 0.0 {
            return Err(bad(format!("load band {b}")));
        }
    }
    let grid = member_grid(&m.band, m.loads.as_ref());
    if m.members.len() != grid.len() {
        return Err(bad(format!(
            "{} members listed, the band {}{} has {}",
            m.members.len(),
            m.band,
            m.loads.map(|b| format!(" × {b}")).unwrap_or_default(),
            grid.len()
        )));
    }
    for (e, (v, f)) in m.members.iter().zip(&grid) {
        let load_ok = match f {
            None => e.load_factor.is_none(),
            Some(f) => {
                e.load_factor.is_some_and(|x| (x - f).abs() < 1e-9)
                    && e.wheel_load_kn.is_some_and(|w| w.is_finite() && w > 0.0)
            }
        };
        if (e.speed_km_per_h - v).abs() > 1e-9 || e.dir != member_dir_name(*v, *f) || !load_ok {
            return Err(bad(format!(
                "member `{}` at {} km/h: the band has `{}` there",
                e.dir.chars().take(60).collect::<String>(),
                e.speed_km_per_h,
                member_dir_name(*v, *f)
            )));
        }
    }
    Ok((m, sha256_hex(&bytes)))
}

/// A member's pin, checked like a `CURRENT` file (a plain version name, 64 hex digits).
fn read_pin(member_dir: &Path, version: &str, sha: &str) -> Result<Current, BankError> {
    let path = member_dir.parent().unwrap_or(member_dir).join(FAMILY_FILE);
    super::version::pinned(member_dir, &path, version, sha)
}

/// The members of a band (and load band), in order: speed, then load factor.
pub fn member_grid(band: &SpeedBand, loads: Option<&LoadBand>) -> Vec<(f64, Option<f64>)> {
    let factors: Vec<Option<f64>> = match loads {
        None => vec![None],
        Some(b) => b.factors().into_iter().map(Some).collect(),
    };
    band.speeds()
        .into_iter()
        .flat_map(|v| factors.iter().map(move |&f| (v, f)))
        .collect()
}
