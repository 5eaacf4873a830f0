//! `wheelflat calibrate`: the site's track and sensors fitted to its good wheels
//! (docs/calibration.md, "The model learns its site"); with `--check`, the nightly comparison
//! with the bank's calibration (exit status 3 when it drifted).

use super::{load_calibration, write_file};
use anyhow::{bail, Context, Result};
use clap::Args;
use std::path::PathBuf;
use wheelflat::history::Db;
use wheelflat::site::{self, drift, passes, Interval, Options};

/// Parses `--hours`: 0.1 to 8,760 (a year).
// Err(String): a clap value parser: clap names the argument and prints the message.
fn hours(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(h) if (0.1..=8760.0).contains(&h) => Ok(h),
        _ => Err(format!("`{s}`: hours from 0.1 to 8760")),
    }
}

/// Exit status of `calibrate --check` when the calibration drifted (a new one was written).
pub(super) const DRIFTED: i32 = 3;

/// Arguments of `wheelflat calibrate`.
#[derive(Debug, Args)]
pub(super) struct CalibrateArgs {
    /// A folder of the site's good-wheel passes (`*.csv`, each with its laser trigger and
    /// speed lines; loads and roughness as they come).
    #[arg(long, required_unless_present = "db", conflicts_with = "db")]
    pub passes: Option<PathBuf>,
    /// Or the results database: the passes it answered "no flat" (or "a flat below the
    /// population") on every wheel, within `--hours` of its newest (their records where they
    /// were read, or in the `done/` folder beside, where `watch` moves them).
    #[arg(long)]
    pub db: Option<PathBuf>,
    /// With `--db`: the passes of the last this many hours (0.1 to 8,760).
    #[arg(long, default_value_t = 24.0, requires = "db", value_parser = hours)]
    pub hours: f64,
    /// The site's calibration now (the bank's); the built-in defaults when omitted.
    #[arg(long)]
    pub calibration: Option<PathBuf>,
    /// The calibrated calibration to write (TOML): fitted track, voids, sensor gains, and the
    /// uncertainty table with the site's entries replaced by its measured residual.
    #[arg(long, default_value = "calibrated.toml")]
    pub out: PathBuf,
    /// The calibration's report (JSON).
    #[arg(long, default_value = "calibration.json")]
    pub report: PathBuf,
    /// Compare with `--calibration` only: exit 0 when nothing drifted (nothing written), 3
    /// when something did (the new calibration written to `--out`, for the nightly rebuild).
    #[arg(long)]
    pub check: bool,
    /// Hold every Nth pass back from the fit to measure the residual on (2 to 20).
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(2..=20))]
    pub hold_back: u32,
    /// Bootstrap draws for the intervals (100 to 10,000).
    #[arg(long, default_value_t = 400, value_parser = clap::value_parser!(u32).range(100..=10_000))]
    pub bootstrap: u32,
}

/// Runs `calibrate`; returns the process's exit status.
pub(super) fn run(a: &CalibrateArgs) -> Result<i32> {
    let cal = load_calibration(a.calibration.as_deref())?;
    let (read, source) = match (&a.passes, &a.db) {
        (Some(dir), _) => (passes::read_folder(dir, &cal)?, dir.display().to_string()),
        (None, Some(db)) => {
            let stored = Db::open_existing(db)?.good_wheel_passes(a.hours, passes::MAX_PASSES)?;
            let files: Vec<PathBuf> = stored
                .iter()
                .map(|s| passes::record_now(std::path::Path::new(s)))
                .collect();
            let source = format!(
                "{} ({} passes answered \"no flat\" or \"below the population\" in the last {} h)",
                db.display(),
                files.len(),
                a.hours
            );
            (passes::read_files(&files, &cal), source)
        }
        (None, None) => bail!("give --passes DIR or --db FILE"),
    };
    for (f, why) in read.skipped.iter().take(5) {
        eprintln!("set aside {f}: {why}");
    }
    if read.skipped.len() > 5 {
        eprintln!("… and {} more set aside", read.skipped.len() - 5);
    }
    if read.passes.is_empty() {
        bail!(
            "{source}: no usable pass ({} set aside)",
            read.skipped.len()
        );
    }
    eprintln!(
        "calibrating on {} passes from {source} (every {}th held back)",
        read.passes.len(),
        a.hold_back
    );
    let clock = std::time::Instant::now();
    let opts = Options {
        hold_back_every: a.hold_back as usize,
        bootstrap: a.bootstrap as usize,
        seed: cal.identification.seed,
    };
    let mut c =
        site::calibrate(&cal, &read.passes, &opts).map_err(|e| anyhow::anyhow!("{source}: {e}"))?;
    print!("{}", words(&c));
    println!(
        "{} passes fitted, {} held back, {} set aside; {} simulations, {:.1} s",
        c.passes_fitted,
        c.passes_held_back,
        read.skipped.len(),
        c.simulations,
        clock.elapsed().as_secs_f64()
    );
    if a.check {
        let (_, start) = site::fit::TrackFit::new(&cal);
        c.check = Some(drift::drifted(&c, &start[1..]));
    }
    let report = serde_json::to_string_pretty(&c).context("the report serialises")?;
    write_file(&a.report, report.as_bytes())?;
    if let Some(moved) = &c.check {
        if moved.is_empty() {
            println!(
                "no drift: every value within its tolerance of the calibration's; nothing written"
            );
            return Ok(0);
        }
        for d in moved {
            println!(
                "drifted: {} was {:.3}, now {:.3} [{:.3}, {:.3}]",
                d.what, d.was, d.now[0], d.now[1], d.now[2]
            );
        }
        write_file(&a.out, c.calibration.to_operator_toml_string().as_bytes())?;
        println!(
            "wrote {} (rebuild the bank from it: scripts/regenerate-nightly.sh)",
            a.out.display()
        );
        return Ok(DRIFTED);
    }
    write_file(&a.out, c.calibration.to_operator_toml_string().as_bytes())?;
    println!("wrote {} and {}", a.out.display(), a.report.display());
    Ok(0)
}

/// The fitted values in words, one a line.
fn words(c: &site::SiteCalibration) -> String {
    let iv = |i: &Interval| {
        if i.pinned {
            format!("{:.3} [{:.3}, {:.3}]", i.value, i.low, i.high)
        } else {
            format!(
                "not pinned by the passes: stays {:.3}, prior [{:.3}, {:.3}]",
                i.value, i.low, i.high
            )
        }
    };
    let mut s = format!(
        "support stiffness (pad and ballast in series): × {}\n",
        iv(&c.support_factor)
    );
    for v in c.voids.iter().filter(|v| v.gap_mm.high > 0.05) {
        s += &format!("voided sleeper {}: gap {} mm\n", v.sleeper, iv(&v.gap_mm));
    }
    for (j, g) in c.gains.iter().enumerate() {
        s += &format!("relative gain of {}: × {}\n", g.sensor, iv(&g.factor));
        if let Some(r) = &c.absolute {
            s += &format!(
                "absolute gain of {}: × {} (written)\n",
                g.sensor,
                iv(&r.gains[j])
            );
        }
    }
    match &c.absolute {
        Some(r) => {
            s += &format!(
                "absolute gains: the relative ones × {} (the common level over the table's mean {:.3}, from {} passes of known load)\n",
                iv(&r.common), r.table_level, r.passes
            )
        }
        None => {
            s += &format!(
                "gains relative only: fewer than {} passes with a `# reference_wheel_load_kn` line (the sensors' common level stays the table's)\n",
                site::reference::MIN_REFERENCE_PASSES
            )
        }
    }
    s += &format!(
        "site residual: ±{:.1} % replaces the table's site entries (held-back passes' departures [{:+.1}, {:+.1}] %, the per-pass entries' [{:+.1}, {:+.1}] %)\n",
        100.0 * c.site_residual,
        100.0 * c.held_back_quantiles[0],
        100.0 * c.held_back_quantiles[1],
        100.0 * c.per_pass_quantiles[0],
        100.0 * c.per_pass_quantiles[1]
    );
    if let Some(l) = &c.load_step {
        s += &format!("{}\n", l.words());
    }
    for x in &c.set_aside {
        s += &format!(
            "set aside {}: its misfit is {:.1}× the passes' median after the fit (a flat, or no good wheel on this track); fitted again without it\n",
            x.path, x.misfit_over_median
        );
    }
    s += &format!(
        "RMS residual of the fitted passes: {:.3} kN → {:.3} kN ({} iterations)\n",
        c.rms_kn[0], c.rms_kn[1], c.iterations
    );
    s
}
