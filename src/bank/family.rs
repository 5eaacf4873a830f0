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
//! `family.json` is the family's `CURRENT`: it pins each member's version directory and its
//! manifest's SHA-256, and is replaced only when every member is complete, so a reader never
//! mixes members of two calibrations however long a nightly regeneration takes. A member is
//! a bank in its own right (`bank info DIR/speed-46.0` works) and is opened through the pin.
//!
//! A pass is compared with the member nearest its speed, and only when that member is within
//! [`SPEED_TOLERANCE`] of it (relative); outside the band the pass is refused with the band
//! named. A single bank is a family of one member at its speed.

use super::generate::{generate, GenerateObserver, GenerateOptions, Outcome};
use super::schema::{sha256_hex, MANIFEST};
use super::version::{read_current, Current};
use super::{Bank, BankError};
use crate::model::CheckedCalibration;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The family manifest's file name.
pub const FAMILY_FILE: &str = "family.json";
/// The family manifest's format.
pub const FAMILY_FORMAT: &str = "wheelflat-bank-family-1";
/// How far (relative) a pass's speed may be from the member it is compared with, the pass's
/// time axis scaled to the member's speed ([`crate::identify::Measurement::at_speed`]):
/// measured 2026-11-24 (`examples/speed_study`, 100 cases, docs/bank.md "Speed"): coverage
/// 0.94–0.95 at ±3 % against 0.95 at the member's own speed, 0.91–0.92 at ±4 %. (Without the
/// scaling it is 0.25 already at ±1 %.)
pub const SPEED_TOLERANCE: f64 = 0.03;
/// The most members a family may have.
pub const MAX_MEMBERS: usize = 200;
/// The largest family manifest read (a few hundred bytes a member).
const MAX_FAMILY_BYTES: u64 = 1 << 20;

/// Speeds from `from` to `to` every `step` (km/h), each a multiple of 0.1 km/h.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SpeedBand {
    /// Lowest member speed (km/h).
    pub from_km_per_h: f64,
    /// Highest member speed (km/h).
    pub to_km_per_h: f64,
    /// Spacing (km/h).
    pub step_km_per_h: f64,
}

impl SpeedBand {
    /// Parses `FROM:TO:STEP` (km/h), e.g. `40:60:2`, checked: speeds within the calibration's
    /// [1, 500] km/h, multiples of 0.1 km/h, FROM ≤ TO, STEP > 0, at most [`MAX_MEMBERS`]
    /// members, and no speed in the band farther than [`SPEED_TOLERANCE`] from a member.
    pub fn parse(text: &str) -> Result<SpeedBand, String> {
        let parts: Vec<&str> = text.split(':').collect();
        if parts.len() != 3 {
            return Err(format!(
                "`{text}` is not FROM:TO:STEP in km/h (e.g. `40:60:2`)"
            ));
        }
        let mut v = [0.0; 3];
        for (slot, (part, name)) in v.iter_mut().zip(parts.iter().zip(["FROM", "TO", "STEP"])) {
            *slot = part
                .trim()
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| format!("{name} `{part}` in `{text}` is not a number of km/h"))?;
        }
        let band = SpeedBand {
            from_km_per_h: v[0],
            to_km_per_h: v[1],
            step_km_per_h: v[2],
        };
        band.check().map_err(|e| format!("`{text}`: {e}"))?;
        Ok(band)
    }

    /// The checks of [`SpeedBand::parse`].
    pub fn check(&self) -> Result<(), String> {
        let (a, b, s) = (self.from_km_per_h, self.to_km_per_h, self.step_km_per_h);
        let tenth = |x: f64| ((x * 10.0).round() - x * 10.0).abs() < 1e-6;
        if !(1.0..=500.0).contains(&a) || !(1.0..=500.0).contains(&b) {
            return Err("speeds must lie in [1, 500] km/h".into());
        }
        if !(tenth(a) && tenth(b) && tenth(s)) {
            return Err("speeds and step must be multiples of 0.1 km/h".into());
        }
        if b < a {
            return Err(format!("TO {b} is below FROM {a}"));
        }
        if s <= 0.0 || (s < 0.1 - 1e-9) {
            return Err(format!("STEP {s} must be at least 0.1 km/h"));
        }
        let n = ((b - a) / s + 1e-9).floor() as usize + 1;
        if n > MAX_MEMBERS {
            return Err(format!(
                "{n} members, more than the {MAX_MEMBERS} a family may have"
            ));
        }
        if ((a + (n - 1) as f64 * s) - b).abs() > 1e-6 {
            return Err(format!(
                "STEP {s} does not reach TO {b} from FROM {a} in whole steps"
            ));
        }
        // Every speed between two members must be within the tolerance of one of them: the
        // worst is the gap's middle, judged against the lower member.
        if n > 1 && s / 2.0 > SPEED_TOLERANCE * a + 1e-9 {
            return Err(format!(
                "STEP {s} km/h leaves {:.2} km/h between {a} km/h and the next member, more than the {:.0} % ({:.2} km/h) a pass may be off its member (measured, docs/bank.md); use a STEP of at most {:.1} km/h",
                s / 2.0,
                SPEED_TOLERANCE * 100.0,
                SPEED_TOLERANCE * a,
                (2.0 * SPEED_TOLERANCE * a * 10.0 + 1e-9).floor() / 10.0
            ));
        }
        Ok(())
    }

    /// The member speeds, rounded to 0.1 km/h.
    pub fn speeds(&self) -> Vec<f64> {
        let n = ((self.to_km_per_h - self.from_km_per_h) / self.step_km_per_h + 1e-9).floor()
            as usize
            + 1;
        (0..n)
            .map(|k| ((self.from_km_per_h + k as f64 * self.step_km_per_h) * 10.0).round() / 10.0)
            .collect()
    }
}

impl std::fmt::Display for SpeedBand {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}–{} km/h every {} km/h",
            self.from_km_per_h, self.to_km_per_h, self.step_km_per_h
        )
    }
}

/// The directory name of the member at `speed` km/h.
pub fn member_dir_name(speed_km_per_h: f64) -> String {
    format!("speed-{speed_km_per_h:.1}")
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
}

/// `family.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FamilyManifest {
    /// [`FAMILY_FORMAT`].
    pub format: String,
    /// The band the members were generated for.
    pub band: SpeedBand,
    /// The members' sample rate (Hz), the same for all: a measurement is read on it before
    /// its speed picks a member.
    pub sample_rate_hz: f64,
    /// The members, by increasing speed.
    pub members: Vec<MemberEntry>,
}

/// A family member as a reader finds it.
#[derive(Debug, Clone, PartialEq)]
pub struct Member {
    /// Train speed (km/h).
    pub speed_km_per_h: f64,
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
                sample_rate_hz: cal.output.sample_rate_hz,
                members: vec![Member {
                    speed_km_per_h: cal.run.speed_km_per_h,
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
    if m.format != FAMILY_FORMAT {
        return Err(bad(format!(
            "format `{}`: this wheelflat reads `{FAMILY_FORMAT}`",
            m.format.chars().take(60).collect::<String>()
        )));
    }
    m.band.check().map_err(|e| bad(format!("band: {e}")))?;
    if !(m.sample_rate_hz.is_finite() && (1.0..=1e6).contains(&m.sample_rate_hz)) {
        return Err(bad(format!("sample rate {} Hz", m.sample_rate_hz)));
    }
    let speeds = m.band.speeds();
    if m.members.len() != speeds.len() {
        return Err(bad(format!(
            "{} members listed, the band {} has {}",
            m.members.len(),
            m.band,
            speeds.len()
        )));
    }
    for (e, v) in m.members.iter().zip(&speeds) {
        if (e.speed_km_per_h - v).abs() > 1e-9 || e.dir != member_dir_name(*v) {
            return Err(bad(format!(
                "member `{}` at {} km/h: the band {} has `{}` at {v} km/h there",
                e.dir.chars().take(60).collect::<String>(),
                e.speed_km_per_h,
                m.band,
                member_dir_name(*v)
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

/// The entry of member `dir` (a complete bank) at `speed`: its `CURRENT`, as pinned now.
pub fn member_entry(dir: &Path, speed_km_per_h: f64) -> Result<MemberEntry, BankError> {
    let c = read_current(dir)?.ok_or_else(|| BankError::NotABank {
        dir: dir.to_path_buf(),
    })?;
    // Only a manifest that hashes to what the member's CURRENT says is pinned.
    let manifest = super::version::manifest_as_stated(&c, "CURRENT says")?;
    let manifest_sha256 = match &c.manifest_sha256 {
        Some(s) => s.clone(),
        None => super::version::manifest_sha256(&c.version)?,
    };
    Ok(MemberEntry {
        speed_km_per_h,
        dir: member_dir_name(speed_km_per_h),
        version: c
            .version
            .file_name()
            .map(|n| n.to_string_lossy().to_string())
            .unwrap_or_default(),
        manifest_sha256,
        bank_id: manifest.bank_id,
    })
}

/// Writes `DIR/family.json` (atomically) for `band`, pinning every member's `CURRENT` as it
/// is now; every member must be complete.
pub fn write_family_manifest(
    dir: &Path,
    band: SpeedBand,
    sample_rate_hz: f64,
) -> Result<FamilyManifest, BankError> {
    let members = band
        .speeds()
        .into_iter()
        .map(|v| member_entry(&dir.join(member_dir_name(v)), v))
        .collect::<Result<Vec<_>, _>>()?;
    let m = FamilyManifest {
        format: FAMILY_FORMAT.into(),
        band,
        sample_rate_hz,
        members,
    };
    let mut text = serde_json::to_string_pretty(&m).expect("a family manifest serialises");
    text.push('\n');
    super::generate::write_file_atomically(&dir.join(FAMILY_FILE), text.as_bytes())?;
    Ok(m)
}

/// What a family generation did, member by member.
#[derive(Debug, Clone, PartialEq)]
pub struct FamilyOutcome {
    /// Each member's speed, outcome and the seconds it took.
    pub members: Vec<(f64, Outcome, f64)>,
    /// Whether `family.json` was written (every member complete); `false` after `--shard`
    /// runs, which leave it to `bank merge`.
    pub manifest_written: bool,
}

/// Generates (or, with `opts.simulate_missing` false, merges) every member of `band` in
/// `dir`, one after the other, each a bank of `cal` at its speed with the same options
/// (`--shard I/N` takes part I of every member); then, when all are complete, writes
/// `family.json`. `member_started` is told each member before its work starts.
pub fn generate_family(
    cal: &CheckedCalibration,
    dir: &Path,
    band: SpeedBand,
    opts: &GenerateOptions,
    observer: &dyn GenerateObserver,
    member_started: &dyn Fn(usize, usize, f64),
) -> Result<FamilyOutcome, BankError> {
    band.check().map_err(BankError::Invalid)?;
    if read_current(dir)?.is_some() {
        return Err(BankError::Invalid(format!(
            "{} holds a single bank (CURRENT); a family needs a directory of its own",
            dir.display()
        )));
    }
    let speeds = band.speeds();
    let mut members = Vec::with_capacity(speeds.len());
    for (k, &v) in speeds.iter().enumerate() {
        member_started(k, speeds.len(), v);
        let member_cal = at_speed(cal, v)?;
        // A member stored unfolded (its speed has no whole number of samples per bay) holds
        // as many instances as the folded members read.
        let unfolded = cal.fold_factor() / member_cal.fold_factor();
        let member_opts = GenerateOptions {
            instances: opts.instances * unfolded,
            ..opts.clone()
        };
        let opts = &member_opts;
        let member_dir = dir.join(member_dir_name(v));
        std::fs::create_dir_all(&member_dir).map_err(|source| BankError::Io {
            path: member_dir.clone(),
            source,
        })?;
        let started = std::time::Instant::now();
        let outcome = generate(&member_cal, &member_dir, opts, observer)?;
        members.push((v, outcome, started.elapsed().as_secs_f64()));
    }
    let complete = members
        .iter()
        .all(|(_, o, _)| !matches!(o, Outcome::ShardDone { .. }));
    if complete {
        write_family_manifest(dir, band, cal.output.sample_rate_hz)?;
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
    let mut doc = cal.document().clone();
    doc.run.speed_km_per_h = speed_km_per_h;
    // A folded population needs a whole number of samples per sleeper bay; a member at a speed
    // without one stores the same instances over the whole revolution instead (docs/bank.md
    // "Folded banks": four times coarser in X_p).
    if doc.population.fold_to_one_bay && !doc.bay_is_whole_samples() {
        doc.population.fold_to_one_bay = false;
    }
    doc.check()
        .map_err(|e| BankError::Invalid(format!("at {speed_km_per_h} km/h: {e}")))
}
