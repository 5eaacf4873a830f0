//! `wheelflat bank …`: generate, merge, info, verify and audit a bank.

use super::args::GenerateArgs;
use super::load_calibration;
use super::progress::Progress;
use anyhow::{Context, Result};
use std::path::Path;
use std::time::Instant;
use wheelflat::audit::BankAudit;
use wheelflat::bank::family::{read_family_manifest, SpeedBand, FAMILY_FILE};
use wheelflat::bank::{self, Bank, GenerateOptions, Outcome, StorageFormat};
use wheelflat::bank::{parameter_ranges, BankSize};

/// `bank generate` (`simulate_missing`) and `bank merge` (not): builds or completes the bank
/// on a pool of the asked threads, with progress on standard error.
pub(super) fn generate(a: &GenerateArgs, simulate_missing: bool) -> Result<()> {
    let cal = load_calibration(a.calibration.as_deref())?;
    // `--instances` counts instances as identification reads them: a folded population
    // stores one in K + 1 ([`wheelflat::model::Calibration::fold_shifts`]).
    let factor = cal.fold_factor();
    if !a.instances.is_multiple_of(factor) {
        anyhow::bail!(
            "--instances {}: the calibration folds X_p into one sleeper bay and reads each stored instance at {factor} whole-bay shifts, so the count must be a multiple of {factor} (e.g. {})",
            a.instances,
            a.instances.div_ceil(factor) * factor
        );
    }
    let opts = GenerateOptions {
        instances: a.instances / factor,
        seed: a.seed,
        shard_size: a.shard_size,
        machine_shard: a.shard,
        format: StorageFormat {
            codec: a.compression.into(),
            encoding: a.encoding.into(),
        },
        simulate_missing,
        tables: !a.defer_tables,
    };
    let threads = a
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .context("cannot start the worker threads")?;
    std::fs::create_dir_all(&a.out)
        .with_context(|| format!("cannot create bank directory {}", a.out.display()))?;
    // A family directory remembers its band (and loads).
    let stored = match a.out.join(FAMILY_FILE).is_file() {
        true => Some(
            read_family_manifest(&a.out)
                .with_context(|| format!("bank family {}", a.out.display()))?
                .0,
        ),
        false => None,
    };
    let loads = match &a.loads {
        Some(text) if text == "auto" => Some(auto_loads(&cal)?),
        Some(text) => Some(
            bank::LoadBand::parse(text, &cal.vehicle)
                .map_err(|e| anyhow::anyhow!("--loads {e}"))?,
        ),
        None => stored.as_ref().and_then(|m| m.loads),
    };
    let band = match (a.speeds, &stored) {
        (Some(b), _) => Some(b),
        (None, Some(m)) => Some(m.band),
        // Loads alone: one speed, the calibration's.
        (None, None) => loads.map(|_| SpeedBand {
            from_km_per_h: cal.run.speed_km_per_h,
            to_km_per_h: cal.run.speed_km_per_h,
            step_km_per_h: 1.0,
        }),
    };
    if let Some(band) = band {
        return generate_family(a, &cal, &opts, (band, loads), threads, &pool);
    }
    let progress = Progress::new().with_terminal();
    let started = Instant::now();
    let outcome = pool.install(|| bank::generate(&cal, &a.out, &opts, &progress));
    progress.finish();
    let outcome = outcome.with_context(|| format!("bank {}", a.out.display()))?;
    let secs = started.elapsed().as_secs_f64();
    report_outcome(
        a,
        &a.out,
        &outcome,
        secs,
        progress.tables_seconds(),
        threads,
    );
    Ok(())
}

/// `bank generate --speeds` (or on a family directory): every member, then `family.json`.
fn generate_family(
    a: &GenerateArgs,
    cal: &wheelflat::model::CheckedCalibration,
    opts: &GenerateOptions,
    (band, loads): (SpeedBand, Option<bank::LoadBand>),
    threads: usize,
    pool: &rayon::ThreadPool,
) -> Result<()> {
    let started = Instant::now();
    let count = bank::family::member_grid(&band, loads.as_ref()).len();
    let members = |n: usize| format!("{n} member{}", if n == 1 { "" } else { "s" });
    let band_words = match loads {
        Some(l) => format!("{band} × {l}"),
        None => band.to_string(),
    };
    println!(
        "bank family {}: {}, {band_words}",
        a.out.display(),
        members(count)
    );
    let progress = Progress::new().with_terminal();
    let announce = |k: usize, n: usize, name: &str| {
        eprintln!("member {}/{n}: {name}", k + 1);
    };
    let outcome = pool.install(|| {
        bank::family_write::generate_family(cal, &a.out, band, loads, opts, &progress, &announce)
    });
    progress.finish();
    let outcome = outcome.with_context(|| format!("bank family {}", a.out.display()))?;
    for (name, o, secs) in &outcome.members {
        report_outcome(a, &a.out.join(name), o, *secs, 0.0, threads);
    }
    let secs = started.elapsed().as_secs_f64();
    if outcome.manifest_written {
        println!(
            "bank family complete: {} ({band_words}) in {secs:.1} s (the tables a pass needs {:.1} s of it); {} pins each member's version",
            members(count),
            progress.tables_seconds(),
            a.out.join(FAMILY_FILE).display()
        );
    } else {
        println!(
            "this machine's part of every member is done ({secs:.1} s); run `wheelflat bank merge` with the same arguments when all parts are done"
        );
    }
    Ok(())
}

/// Says what a generate call did for one bank (`secs` in all, `tables_s` of them building the
/// tables a pass needs).
fn report_outcome(
    a: &GenerateArgs,
    dir: &Path,
    outcome: &Outcome,
    secs: f64,
    tables_s: f64,
    threads: usize,
) {
    let sim_s = (secs - tables_s).max(0.0);
    let took = format!(" in {sim_s:.1} s");
    let tables = if tables_s > 0.0 {
        format!("; the tables a pass needs {tables_s:.1} s")
    } else {
        String::new()
    };
    match outcome {
        Outcome::UpToDate { version, upgraded } => {
            if *upgraded {
                println!(
                    "bank {} is up to date ({}); added or renewed what this wheelflat stores beside the shards (neighbour graph, column layout, manifest hash in CURRENT, the tables a pass needs) ({secs:.1} s)",
                    dir.display(),
                    version.display()
                );
            } else {
                println!(
                    "bank {} is up to date ({}); nothing to do",
                    dir.display(),
                    version.display()
                );
            }
        }
        Outcome::Complete {
            version,
            simulated,
            resumed,
        } => {
            println!(
                "bank complete: {} instances in {} ({simulated} simulated{took}, {:.0} instances/s on {threads} threads; {resumed} kept from an earlier run{tables}); CURRENT -> {}",
                a.instances,
                version.display(),
                *simulated as f64 / sim_s.max(1e-9),
                version.file_name().map(|n| n.to_string_lossy()).unwrap_or_default()
            );
        }
        Outcome::ShardDone {
            version,
            simulated,
            files,
        } => {
            let (i, n) = a.shard.unwrap_or((0, 1));
            println!(
                "shard {i}/{n} done: {files} shard files in {} ({simulated} instances simulated{took}); run `wheelflat bank merge` with the same arguments when all shards are done",
                version.display()
            );
        }
    }
}

/// `bank info` of one bank: metadata, size and parameter ranges.
pub(super) fn info(dir: &Path) -> Result<()> {
    let b = Bank::open(dir).with_context(|| format!("cannot open bank {}", dir.display()))?;
    let m = b.metadata();
    let size = BankSize::of(&b);
    println!("bank            {}", b.dir().display());
    println!("bank id         {}", m.bank_id);
    println!(
        "format          {} ({}), model revision {}",
        m.format_version, m.generator, m.model_revision
    );
    println!("calibration     sha256 {}", m.calibration_sha256);
    let folded = match b.fold_factor() {
        1 => String::new(),
        k => format!(
            " ({} stored over one sleeper bay × {k} whole-bay shifts: X_p over a revolution; stored windows also at {})",
            b.stored_instances(),
            b.stored_axes()[m.sensors.len()..]
                .iter()
                .map(|a| a.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    };
    println!(
        "instances       {} in {} shard files of {}{folded}",
        size.instances, size.files, m.shard_size
    );
    println!("sampling        {} (seed {})", m.sampling, m.seed);
    println!(
        "size            {:.1} MB, {:.1} kB per stored instance",
        size.megabytes(),
        size.kilobytes_per_instance() * b.fold_factor() as f64
    );
    println!("sensors         (force in {})", m.force_unit);
    for s in &m.sensors {
        println!(
            "  {:<6} sleeper {:>2} at {:>6.2} m: {} samples at {} Hz from t = {:.4} s",
            s.name, s.sleeper, s.position_m, s.samples, s.sample_rate_hz, s.t0_s
        );
    }
    let ranges =
        parameter_ranges(&b).with_context(|| format!("reading parameters of {}", dir.display()))?;
    println!("parameter ranges");
    for r in ranges {
        println!("  {:<18} [{:.4}, {:.4}]", r.name, r.min, r.max);
    }
    Ok(())
}

/// `bank verify` of one bank: every file against the manifest; fails naming the bad files.
pub(super) fn verify(dir: &Path) -> Result<()> {
    let (manifest, problems) =
        bank::verify(dir).with_context(|| format!("cannot verify bank {}", dir.display()))?;
    if problems.is_empty() {
        println!(
            "bank {} verified: {} files, {} instances, checksums match",
            dir.display(),
            manifest.files.len(),
            manifest.instances
        );
        return Ok(());
    }
    for p in &problems {
        eprintln!("{}: {}", p.path.display(), p.message);
    }
    anyhow::bail!(
        "bank {} failed verification: {} of {} files bad",
        dir.display(),
        problems.len(),
        manifest.files.len()
    )
}

/// `bank prune`: removes old versions ([`bank::prune`]) and says what it did and left.
pub(super) fn prune(dir: &Path, keep: usize) -> Result<()> {
    let p =
        bank::prune(dir, keep).with_context(|| format!("cannot prune bank {}", dir.display()))?;
    print_pruned(dir, &p);
    Ok(())
}

/// What a prune did and left, a line each.
pub(super) fn print_pruned(dir: &Path, p: &bank::Pruned) {
    let name = |p: &Path| {
        p.file_name()
            .map(|n| n.to_string_lossy().to_string())
            .unwrap_or_default()
    };
    match &p.current {
        Some(c) => println!("kept {} (CURRENT)", name(c)),
        None => println!("no CURRENT in {}: no version is in use", dir.display()),
    }
    for k in &p.kept {
        println!("kept {}", name(k));
    }
    let mut freed = 0;
    for (r, bytes) in &p.removed {
        println!("removed {} ({:.1} MB)", name(r), *bytes as f64 / 1e6);
        freed += bytes;
    }
    for i in &p.incomplete {
        println!(
            "left {} (incomplete: `bank generate` with its arguments resumes it; remove it by hand if it is abandoned)",
            name(i)
        );
    }
    println!(
        "bank {}: {} removed, {:.1} MB freed",
        dir.display(),
        p.removed.len(),
        freed as f64 / 1e6
    );
}

/// `bank audit`: re-simulates `sample` instances ([`BankAudit`]), prints each verdict and
/// fails on drift.
pub(super) fn audit(dir: &Path, sample: usize, calibration: Option<&Path>) -> Result<()> {
    let b = Bank::open(dir).with_context(|| format!("cannot open bank {}", dir.display()))?;
    let against = match calibration {
        Some(p) => Some(load_calibration(Some(p))?),
        None => None,
    };
    audit_bank(&b, dir, against, calibration, sample)
}

/// Audits one open bank (`against`: the calibration to re-simulate with, read from
/// `calibration`).
pub(super) fn audit_bank(
    b: &Bank,
    dir: &Path,
    against: Option<wheelflat::model::CheckedCalibration>,
    calibration: Option<&Path>,
    sample: usize,
) -> Result<()> {
    let what = match calibration {
        Some(p) => format!("the calibration in {}", p.display()),
        None => "the calibration stored in the bank".into(),
    };
    let plan = BankAudit::new(b, against, sample)?;
    println!(
        "bank {} ({} instances, bank id {}): re-simulating {} instances with {what}",
        dir.display(),
        b.instances(),
        b.metadata().bank_id,
        plan.instances().len()
    );
    let report = plan.run()?;
    for r in &report.results {
        println!("  instance {:>6}: {}", r.instance, r.verdict());
    }
    let drifted = report.drifted();
    if drifted.is_empty() {
        println!(
            "no drift: all {} re-simulated instances match the bank bit for bit",
            report.results.len()
        );
        return Ok(());
    }
    anyhow::bail!(
        "DRIFT: {} of {} re-simulated instances differ from the bank (max |Δ| {:.4} kN). The bank no longer matches this code and {what}: find the change, or regenerate the bank (`wheelflat bank generate`)",
        drifted.len(),
        report.results.len(),
        report.worst_kn()
    )
}

/// `--loads auto`: the site's band (`site::load_step::BAND`) at the step its calibration
/// states (`population.family_load_step`, written by `calibrate`), else at the coarsest step
/// of `site::load_step::STEPS` the load tolerances admit (a linear track); said on stderr.
fn auto_loads(cal: &wheelflat::model::CheckedCalibration) -> anyhow::Result<bank::LoadBand> {
    use wheelflat::site::load_step::{BAND, STEPS};
    let text = |step: f64| format!("{}:{}:{step}", BAND[0], BAND[1]);
    let (band, why) = match cal.population.family_load_step {
        Some(step) => (
            bank::LoadBand::parse(&text(step), &cal.vehicle)
                .map_err(|e| anyhow::anyhow!("--loads auto (population.family_load_step = {step}): {e}"))?,
            "population.family_load_step, written by calibrate",
        ),
        None => (
            STEPS
                .iter()
                .find_map(|&s| bank::LoadBand::parse(&text(s), &cal.vehicle).ok())
                .ok_or_else(|| anyhow::anyhow!("--loads auto: no step of {STEPS:?} covers {}–{} × the car body within the load tolerances", BAND[0], BAND[1]))?,
            "the coarsest the load tolerances admit: the calibration states no population.family_load_step (run calibrate at a site with a hanging sleeper)",
        ),
    };
    eprintln!(
        "--loads auto: car-body mass {}–{} × every {} ({why})",
        band.from, band.to, band.step
    );
    Ok(band)
}
