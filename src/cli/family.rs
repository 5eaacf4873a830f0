//! `wheelflat bank info|verify|prune|audit` on a bank directory: a single bank ([`super::bank`]),
//! or a bank family, each member in turn through the version `family.json` pins.

use anyhow::{Context, Result};
use std::path::Path;
use wheelflat::bank::family::{Family, FAMILY_FILE};
use wheelflat::bank::BankSize;

/// Whether `dir` is a bank family.
fn is_family(dir: &Path) -> bool {
    dir.join(FAMILY_FILE).is_file()
}

fn open(dir: &Path) -> Result<Family> {
    Ok(Family::open(dir)
        .with_context(|| format!("cannot open bank family {}", dir.display()))?
        .0)
}

fn band(f: &Family) -> String {
    let speeds = f.band.map(|b| b.to_string()).unwrap_or_default();
    match f.loads {
        Some(l) => format!("{speeds} × {l}"),
        None => speeds,
    }
}

/// A member in a line: its speed, and its wheel load in a family over loads.
fn member_words(f: &Family, m: &wheelflat::bank::family::Member) -> String {
    match f.loads {
        Some(_) => format!("{:>6.1} km/h {:>5.1} kN", m.speed_km_per_h, m.wheel_load_kn),
        None => format!("{:>6.1} km/h", m.speed_km_per_h),
    }
}

/// `bank info`: of a family, the band, then one line per member.
pub(super) fn info(dir: &Path) -> Result<()> {
    if !is_family(dir) {
        return super::bank::info(dir);
    }
    let f = open(dir)?;
    println!("bank family     {}", dir.display());
    println!("band            {} ({} members)", band(&f), f.members.len());
    println!("sample rate     {} Hz", f.sample_rate_hz);
    println!(
        "members         (a member's details: wheelflat bank info {}/speed-…)",
        dir.display()
    );
    for m in &f.members {
        let b = m
            .open()
            .with_context(|| format!("member {}", m.dir.display()))?;
        let size = BankSize::of(&b);
        println!(
            "  {}  {}  {} instances, {:.1} MB, bank id {}",
            member_words(&f, m),
            m.current
                .version
                .strip_prefix(dir)
                .unwrap_or(&m.current.version)
                .display(),
            size.instances,
            size.megabytes(),
            b.metadata().bank_id
        );
    }
    Ok(())
}

/// `bank verify`: of a family, every member's pinned version in full.
pub(super) fn verify(dir: &Path) -> Result<()> {
    if !is_family(dir) {
        return super::bank::verify(dir);
    }
    let f = open(dir)?;
    let mut bad = 0;
    for m in &f.members {
        // The pin and the member's speed first, then every file against its manifest.
        let checked = m
            .open()
            .map_err(anyhow::Error::from)
            .and_then(|_| wheelflat::bank::verify(&m.current.version).map_err(anyhow::Error::from));
        match checked {
            Ok((manifest, problems)) if problems.is_empty() => println!(
                "  {}: {} files, {} instances, checksums match",
                member_words(&f, m),
                manifest.files.len(),
                manifest.instances
            ),
            Ok((_, problems)) => {
                bad += 1;
                for p in &problems {
                    eprintln!("{}: {}", p.path.display(), p.message);
                }
            }
            Err(e) => {
                bad += 1;
                eprintln!("{}: {e:#}", m.dir.display());
            }
        }
    }
    if bad > 0 {
        anyhow::bail!(
            "bank family {} failed verification: {bad} of {} members bad",
            dir.display(),
            f.members.len()
        );
    }
    println!(
        "bank family {} ({}): {} members verified",
        dir.display(),
        band(&f),
        f.members.len()
    );
    Ok(())
}

/// `bank prune`: of a family, every member, keeping the versions `family.json` pins.
pub(super) fn prune(dir: &Path, keep: usize) -> Result<()> {
    if !is_family(dir) {
        return super::bank::prune(dir, keep);
    }
    let f = open(dir)?;
    for m in &f.members {
        println!("member {}:", member_words(&f, m).trim());
        let p =
            wheelflat::bank::prune_keeping(&m.dir, keep, std::slice::from_ref(&m.current.version))
                .with_context(|| format!("cannot prune {}", m.dir.display()))?;
        super::bank::print_pruned(&m.dir, &p);
    }
    Ok(())
}

/// `bank audit`: of a family, `sample` instances of every member (with `calibration`, that
/// calibration at each member's speed and load).
pub(super) fn audit(dir: &Path, sample: usize, calibration: Option<&Path>) -> Result<()> {
    if !is_family(dir) {
        return super::bank::audit(dir, sample, calibration);
    }
    let f = open(dir)?;
    let mut drifted = 0;
    for m in &f.members {
        let b = m
            .open()
            .with_context(|| format!("member {}", m.dir.display()))?;
        let against = match calibration {
            // At the member's speed, and at its load (a factor of the family's car body).
            Some(p) => Some(wheelflat::bank::family_write::at_speed_and_load(
                &super::load_calibration(Some(p))?,
                m.speed_km_per_h,
                m.load_factor,
            )?),
            None => None,
        };
        if let Err(e) = super::bank::audit_bank(&b, &m.dir, against, calibration, sample) {
            eprintln!("{e:#}");
            drifted += 1;
        }
    }
    if drifted > 0 {
        anyhow::bail!(
            "bank family {}: {drifted} of {} members drifted",
            dir.display(),
            f.members.len()
        );
    }
    println!("bank family {}: no member drifted", dir.display());
    Ok(())
}
