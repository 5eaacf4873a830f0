//! The command line's grammar: the clap types of every command and the parsers of the
//! arguments that are more than one value (`--shard I/N`, `--flat-on`, `--effect`).
//!
//! The doc comments on the fields and variants are the `--help` text; the types themselves
//! carry plain comments so that clap does not take them for help text.

use super::db_args::DbArgs;
pub(super) use super::flat_args::FlatArgs;
use super::format_args::{CodecArg, EncodingArg};
use super::refine_args::RefineArgs;
use super::value_parsers::{parse_shard, parse_speed, parse_threads};
use anyhow::{Context, Result};
use clap::{Args, Parser, Subcommand};
use std::path::PathBuf;
use wheelflat::bank::family::SpeedBand;
use wheelflat::model::{Effect, Flat, WheelPosition};
use wheelflat::train::TrainFlat;

/// Wheel-flat identification from rail-pad forces, with uncertainties.
#[derive(Debug, Parser)]
#[command(name = "wheelflat", version, about, long_about = None)]
pub(super) struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

// The commands.
#[derive(Debug, Subcommand)]
pub(super) enum Command {
    /// Print the built-in calibration (docs/model.md defaults) as a TOML file to start from.
    Calibration {
        /// Write to this file instead of standard output.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Population profile: `site` (either wheel, X_p over one wheel revolution, folded
        /// into one bay; what a site and `train` need), `paper` (the paper's case study: the
        /// trailing wheel, X_p in [12, 13] m) or `narrow` (CI-sized).
        #[arg(long, value_enum, default_value_t = Profile::Site)]
        profile: Profile,
        /// The profile at the converged reference's mesh and step (40 rail elements per bay,
        /// 20 µs / 2 µs): for simulating measurements that carry the bank mesh's
        /// discretisation error, as a field record does (about 200× slower than the bank's).
        #[arg(long, conflicts_with = "noise_from")]
        converged: bool,
        /// The profile with landings near the converged reference where the sensors see them
        /// (40 rail elements a bay ±3 bays around the sensors, 4 µs fine steps, no
        /// discretisation allowance): a bank about 13× the default's cost to build, for the
        /// nightly cluster job (docs/identification.md, "Landings").
        #[arg(long, conflicts_with_all = ["noise_from", "converged"])]
        landings: bool,
        /// Measure the site's noise from these passes (good wheels or flats: the strikes are
        /// left out) and widen the uncertainty table's noise entry to it when it is above the
        /// table; the bank's calibration is the starting point.
        #[arg(long, num_args = 1.., requires = "bank")]
        noise_from: Vec<PathBuf>,
        /// The bank (or family) the passes are compared with (with `--noise-from`).
        #[arg(long)]
        bank: Option<PathBuf>,
    },
    /// Simulate one train pass over the sensors and write the rail-pad forces.
    Simulate(SimulateArgs),
    /// Build, inspect and check model banks.
    Bank {
        #[command(subcommand)]
        command: BankCommand,
    },
    /// Make a field-like measurement from a chosen true flat (simulated, then perturbed with
    /// errors drawn inside the uncertainty table), with a truth JSON.
    Synth(SynthArgs),
    /// Identify the flat size behind a measurement from a bank: the verdict and
    /// identification.json first; figures and the HTML report with `--report`.
    Identify(IdentifyArgs),
    /// Draw the figures and the HTML report of an identification.json written by `identify`
    /// or `watch`.
    Report {
        /// The identification JSON.
        #[arg(long)]
        from: PathBuf,
        /// Report folder (default: the JSON's folder).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Keep a bank open and identify every measurement that arrives in an inbox folder:
    /// results atomically in the output folder, inputs moved to done/ or failed/ (with the
    /// reason), one log line per measurement; switches to a regenerated bank between
    /// measurements; stops cleanly on SIGTERM or SIGINT.
    Watch(WatchArgs),
    /// Print the paper-style comparison of the method with its baselines for one measurement.
    Compare(CompareArgs),
    /// Identify every wheel of a whole train pass: one recording, the trigger time of every
    /// wheel; a table (CSV, JSON, HTML) with flat yes/no, L0 range and severity per wheel.
    Train(super::train::TrainArgs),
    /// A wheel's history from a results database: every stored pass's answer, the joint
    /// answer of the newest passes (the flat must fit them all), its severity classes, and
    /// a trend figure; a wheel whose flat grew is reported as changed.
    History(super::history::HistoryArgs),
    /// The alarms in a results database's outbox, pending, failed (retried) and sent; with
    /// `--send --alarms F`, one delivery round first (docs/alarms.md).
    Alarms(super::alarms::AlarmsArgs),
    /// A read-only web view of a results database for the people who watch a site: the wheels
    /// that need action first, every wheel, the passes of the last hours, a wheel's trend, a
    /// pass's report, each page with its JSON (on 127.0.0.1:8080 unless told otherwise).
    Serve(super::serve::ServeArgs),
    /// Send a site's results database on to the fleet store (PostgreSQL): at least once,
    /// idempotent, in order; `--follow` keeps shipping (docs/fleet.md).
    Ship(super::ship::ShipArgs),
    /// Enter what the workshop measured on a pulled wheelset (or a CSV of findings) into the
    /// fleet store; `--table`: how the passes before each finding fared, per site and fleet.
    Found(super::found::FoundArgs),
    /// The fleet store's owner: migrate its schema, add a site or a login, the sites' health.
    Fleet(super::fleet::FleetCommandArgs),
    /// Audit one model instance: re-simulate it and compare with the bank; with a measurement,
    /// show why it is kept or falsified.
    Audit(AuditArgs),
    /// Diagnose a model gap: locate where the best instances leave the thresholds, fit every
    /// effect of the library with the flat and rank them (BIC), name one only when the evidence
    /// is clear, add it, regenerate a local bank and identify again; report before and after.
    Diagnose(DiagnoseArgs),
    /// Fit the site's track (support stiffness, voided sleepers) and sensors' relative gains to
    /// its good-wheel passes, and write the calibrated calibration; `--check` compares with
    /// the bank's for the nightly rebuild (exit 3 when it drifted).
    Calibrate(super::calibrate::CalibrateArgs),
    /// Run the main job on built-in defaults: simulate, build the bank on first use (with
    /// progress), make a synthetic field measurement, identify the flat, write the report.
    Demo {
        /// Output folder.
        #[arg(long, default_value = "wheelflat-demo")]
        out: PathBuf,
        /// Bank directory (built here on first use; reused while it is up to date).
        #[arg(long, default_value = "bank")]
        bank: PathBuf,
        /// Instances in the bank as identification reads them (the paper's 50,000; fewer for
        /// a quick look; a folded bank stores a quarter of them).
        #[arg(long, default_value_t = DEFAULT_INSTANCES)]
        instances: usize,
        /// Then identify a small site's passes into a results database and serve it (see it
        /// in a browser; Ctrl-C stops).
        #[arg(long)]
        serve: bool,
        /// Where `--serve` listens.
        #[arg(long, default_value = "127.0.0.1:8080", requires = "serve")]
        listen: std::net::SocketAddr,
        /// With `--serve`: the site's passes raise alarms by this `alarms.toml` and post them
        /// to its webhooks (docs/alarms.md).
        #[arg(long, requires = "serve")]
        alarms: Option<PathBuf>,
    },
}

/// The built-in population profiles.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub(super) enum Profile {
    /// A site's (the default): both wheels, X_p over one revolution, folded into one bay.
    #[value(alias = "train")]
    Site,
    /// The paper's case study: trailing wheel, X_p in [12, 13] m.
    Paper,
    /// CI-sized: narrower flat ranges and 600-sample windows, for small banks (tests, the
    /// diagnosis suite, trying things out).
    Narrow,
}

// The `bank` commands.
#[derive(Debug, Subcommand)]
pub(super) enum BankCommand {
    /// Simulate the whole population and store it as Parquet (resumes an interrupted run;
    /// does nothing when the bank is up to date).
    Generate(GenerateArgs),
    /// Complete a bank built by `--shard` runs: check every shard file, write the manifest,
    /// switch CURRENT. Simulates nothing.
    Merge(GenerateArgs),
    /// Show a bank's metadata, sizes and parameter ranges.
    Info {
        /// Bank directory.
        dir: PathBuf,
    },
    /// Check every file of a bank against its manifest (size, SHA-256, footer).
    Verify {
        /// Bank directory.
        dir: PathBuf,
    },
    /// Remove old complete versions of a bank, keeping the one CURRENT names and the newest
    /// others up to `--keep` in all (incomplete versions are listed, not removed).
    Prune {
        /// Bank directory.
        dir: PathBuf,
        /// Complete versions to keep, CURRENT's included (1 to 1000).
        #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u64).range(1..=1000))]
        keep: u64,
    },
    /// Re-simulate K instances spread through the bank and report any that no longer match
    /// (code or calibration drifted since the bank was built). Fails on drift.
    Audit {
        /// Bank directory.
        dir: PathBuf,
        /// Instances to re-simulate, spread evenly through the bank.
        #[arg(long, default_value_t = 32)]
        sample: usize,
        /// Re-simulate with this calibration instead of the one stored in the bank (shows
        /// whether a changed track calibration changes the predictions).
        #[arg(long)]
        calibration: Option<PathBuf>,
    },
}

/// Instances of a bank unless told otherwise (the paper's population).
const DEFAULT_INSTANCES: usize = 50_000;
/// Population seed unless told otherwise (plain Hammersley).
const DEFAULT_SEED: u64 = 0;
/// Instances per shard file unless told otherwise.
const DEFAULT_SHARD_SIZE: usize = 2500;

// `bank generate` and `bank merge`.
#[derive(Debug, Clone, PartialEq, Args)]
pub(super) struct GenerateArgs {
    /// Calibration file (TOML); the built-in defaults when omitted.
    #[arg(long)]
    pub calibration: Option<PathBuf>,
    /// Instances in the population as identification reads them; a folded population (the
    /// default) stores one in four, each read at four whole-bay shifts (a multiple of 4).
    #[arg(long, default_value_t = DEFAULT_INSTANCES)]
    pub instances: usize,
    /// Bank directory.
    #[arg(long, default_value = "bank")]
    pub out: PathBuf,
    /// Worker threads, 1 to 1024 (default: all cores).
    #[arg(long, value_parser = parse_threads)]
    pub threads: Option<usize>,
    /// Build only part I of N (0-based), e.g. `--shard 3/10`, for a cluster job array.
    #[arg(long, value_parser = parse_shard)]
    pub shard: Option<(usize, usize)>,
    /// Population seed (0: plain Hammersley).
    #[arg(long, default_value_t = DEFAULT_SEED)]
    pub seed: u64,
    /// Instances per shard file (the unit of resumable work).
    #[arg(long, default_value_t = DEFAULT_SHARD_SIZE)]
    pub shard_size: usize,
    /// Compression of the force columns.
    #[arg(long, value_enum, default_value_t = CodecArg::None)]
    pub compression: CodecArg,
    /// Encoding of the force columns.
    #[arg(long, value_enum, default_value_t = EncodingArg::Plain)]
    pub encoding: EncodingArg,
    /// A bank family: one member per train speed FROM:TO:STEP km/h (e.g. `40:60:2`), each a
    /// bank of the calibration at that speed, and `family.json` when all are complete. A
    /// family directory remembers its band: without this flag it is regenerated as it is.
    #[arg(long, value_parser = SpeedBand::parse)]
    pub speeds: Option<SpeedBand>,
    /// A family over loads too: members at car-body masses FROM:TO:STEP × the calibration's
    /// (e.g. `0.6:1.1:0.5`), at every speed (the calibration's, without --speeds); `auto`:
    /// 0.6–1.4 at the step the site's calibration states (`population.family_load_step`,
    /// written by `calibrate`).
    #[arg(long, value_name = "FROM:TO:STEP|auto")]
    pub loads: Option<String>,
    /// Leave the tables a pass needs (departures, roughness, out of round: ~15 s on 2 cores)
    /// to the first pass that needs one, instead of building them before `CURRENT` points at
    /// the bank: for a bank that answers few passes (a study, a test). A serving bank should
    /// have them (docs/bank.md, "Built with the bank").
    #[arg(long)]
    pub defer_tables: bool,
}

impl GenerateArgs {
    /// `bank generate --out OUT --instances N` with every other argument at its default (the
    /// demo's bank; a test checks this equals what clap parses).
    pub fn defaults(out: PathBuf, instances: usize) -> GenerateArgs {
        GenerateArgs {
            calibration: None,
            instances,
            out,
            threads: None,
            shard: None,
            seed: DEFAULT_SEED,
            shard_size: DEFAULT_SHARD_SIZE,
            compression: CodecArg::None,
            encoding: EncodingArg::Plain,
            speeds: None,
            loads: None,
            defer_tables: false,
        }
    }
}

// `synth`.
#[derive(Debug, Args)]
pub(super) struct SynthArgs {
    #[command(flatten)]
    pub flat: FlatArgs,
    /// Calibration file (TOML); the built-in defaults when omitted.
    #[arg(long)]
    pub calibration: Option<PathBuf>,
    /// Seed of the perturbation.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Field-like noise: its standard deviation this many times the table's (one bogie).
    #[arg(long, default_value_t = 1.0)]
    pub noise_scale: f64,
    /// Field-like noise: AR(1) lag-1 correlation, 0 ≤ ρ < 1 (one bogie).
    #[arg(long, default_value_t = 0.0)]
    pub noise_ar1: f64,
    /// Measurement CSV to write.
    #[arg(long)]
    pub out: PathBuf,
    /// Truth JSON to write (default: the CSV path with `.truth.json`).
    #[arg(long)]
    pub truth: Option<PathBuf>,
    /// Leave the laser trigger time out (alignment then uses cross-correlation).
    #[arg(long)]
    pub no_trigger: bool,
    /// A whole train instead of one bogie: writes the recording, a trigger file
    /// (`<out>.triggers.csv`, one time per wheel) and the truth. Without `--flat-on`: flats
    /// on bogie 2 leading, bogie 7 trailing and bogie 11 leading.
    #[arg(long)]
    pub train: bool,
    /// Bogies in the train.
    #[arg(long, default_value_t = 12, requires = "train")]
    pub bogies: usize,
    /// Hide an effect of the library in the measurement: `KIND:KEY=VALUE,…`, e.g.
    /// `pad_stiffness:sleeper=16,factor=0.5` or `wheel_out_of_round:wheel=leading,order=8,amplitude_mm=0.05`
    /// (repeat for more; the keys are those of `[[effects]]` in the calibration).
    #[arg(long = "effect")]
    pub effects: Vec<String>,
    /// A flat on one wheel of the train: `BOGIE:WHEEL:L_MM:D_MM:C_MM:XP_M`, e.g.
    /// `3:leading:60:0.5:0.1:12.9` (repeat for more).
    #[arg(long = "flat-on", requires = "train")]
    pub flat_on: Vec<String>,
    /// Each bogie's speed over the site (km/h), in running order, one per bogie, e.g. a train
    /// accelerating through it: `47.6,48.3,49.2,50.4` (default: all at the calibration's).
    #[arg(long = "bogie-speeds", value_delimiter = ',', value_parser = parse_speed, requires = "train")]
    pub bogie_speeds: Vec<f64>,
    /// Each bogie's car-body mass as a factor of the calibration's (empty or laden cars), one
    /// per bogie: `1,1,0.6,0.6` (default: all at the calibration's).
    #[arg(long = "bogie-loads", value_delimiter = ',', requires = "train")]
    pub bogie_loads: Vec<f64>,
    #[command(flatten)]
    pub surfaces: super::surface_args::SurfaceArgs,
}

// A bank and a measurement to identify against it.
#[derive(Debug, Args)]
pub(super) struct MeasuredArgs {
    /// Bank directory.
    #[arg(long, default_value = "bank")]
    pub bank: PathBuf,
    /// Measurement CSV (`time_s,<sensor>_kn,…`).
    #[arg(long)]
    pub measured: PathBuf,
    /// Only these sensors, e.g. `rps1,rps2` (a broken sensor is left out).
    #[arg(long, value_delimiter = ',')]
    pub sensors: Option<Vec<String>>,
    /// Identification settings and uncertainty table from this calibration file instead of
    /// the bank's.
    #[arg(long)]
    pub calibration: Option<PathBuf>,
    /// The pass's train speed (km/h), for a measurement without a `# speed_km_per_h` line;
    /// it picks the bank of a family the pass is compared with.
    #[arg(long, value_parser = parse_speed)]
    pub speed: Option<f64>,
}

// `identify`.
#[derive(Debug, Args)]
pub(super) struct IdentifyArgs {
    #[command(flatten)]
    pub input: MeasuredArgs,
    /// Report folder (JSON, PNG/SVG figures, report.html).
    #[arg(long)]
    pub out: PathBuf,
    /// Also draw the figures and write report.html, with the baselines and entropy curves
    /// (the engineer's report; `wheelflat report --from` draws them later from the JSON).
    #[arg(long)]
    pub report: bool,
    /// With `--report`: skip the baselines (residual minimisation is always reported) and the
    /// entropy curves.
    #[arg(long)]
    pub no_baselines: bool,
    #[command(flatten)]
    pub refine: RefineArgs,
    #[command(flatten)]
    pub store: DbArgs,
}

// `watch`.
#[derive(Debug, Args)]
pub(super) struct WatchArgs {
    /// Bank directory (its `CURRENT` is followed: a regenerated bank is used from the next
    /// measurement on).
    #[arg(long, default_value = "bank")]
    pub bank: PathBuf,
    /// Folder new measurements (`*.csv`) arrive in. Writers must write under another name
    /// (e.g. a leading dot or a `.part` suffix) and rename when complete; `done/` and
    /// `failed/` are made inside it.
    #[arg(long)]
    pub inbox: PathBuf,
    /// Results: `<name>/identification.json` per measurement.
    #[arg(long)]
    pub out: PathBuf,
    /// Only these sensors, e.g. `rps1,rps2`.
    #[arg(long, value_delimiter = ',')]
    pub sensors: Option<Vec<String>>,
    /// Identification settings and uncertainty table from this calibration file instead of
    /// the bank's.
    #[arg(long)]
    pub calibration: Option<PathBuf>,
    /// How often the inbox and `CURRENT` are looked at when idle (milliseconds, 10–60000).
    #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u64).range(10..=60_000))]
    pub poll_ms: u64,
    /// Process what is in the inbox, then exit (for cron jobs and tests).
    #[arg(long)]
    pub once: bool,
    /// Serve `/metrics` (the Prometheus text format, from the results database) on this
    /// localhost address, e.g. `127.0.0.1:9187` (docs/alarms.md).
    #[arg(long, requires = "db")]
    pub metrics: Option<std::net::SocketAddr>,
    #[command(flatten)]
    pub refine: RefineArgs,
    #[command(flatten)]
    pub store: DbArgs,
    /// Also ship the results database to this fleet store (PostgreSQL), on a thread of its
    /// own every 5 s: the site answers on while the store is unreachable and catches up
    /// after (docs/fleet.md). Needs --db.
    #[command(flatten)]
    pub fleet: super::fleet::FleetArgs,
}

// `audit`.
#[derive(Debug, Args)]
pub(super) struct AuditArgs {
    /// Bank directory.
    #[arg(long, default_value = "bank")]
    pub bank: PathBuf,
    /// Instance number.
    #[arg(long)]
    pub instance: usize,
    /// Measurement CSV to judge the instance against (identified first, as `identify` does).
    #[arg(long)]
    pub measured: Option<PathBuf>,
    /// Only these sensors of the measurement, e.g. `rps1,rps2`.
    #[arg(long, value_delimiter = ',', requires = "measured")]
    pub sensors: Option<Vec<String>>,
    /// Identification settings and uncertainty table from this calibration file instead of
    /// the bank's.
    #[arg(long, requires = "measured")]
    pub calibration: Option<PathBuf>,
    /// Folder for `audit.json` and `audit.png`.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Train speed (km/h): picks the member of a bank family (the measurement's speed line
    /// does when a measurement is given; this is for one without).
    #[arg(long, value_parser = parse_speed)]
    pub speed: Option<f64>,
}

// `diagnose`.
#[derive(Debug, Args)]
pub(super) struct DiagnoseArgs {
    #[command(flatten)]
    pub input: MeasuredArgs,
    /// Report folder: `diagnosis.json`, `diagnosis.html`, `diagnosis-gap.png`, and with an
    /// effect named `calibration-with-effect.toml` and the local bank in `local-bank/`.
    #[arg(long)]
    pub out: PathBuf,
    /// Instances of the local bank regenerated with the named effect.
    #[arg(long, default_value_t = 1000)]
    pub local_instances: usize,
    /// Name the effect but do not regenerate a bank (no "after").
    #[arg(long)]
    pub no_local_bank: bool,
}

// `compare`.
#[derive(Debug, Args)]
pub(super) struct CompareArgs {
    #[command(flatten)]
    pub input: MeasuredArgs,
    /// Truth JSON from `synth`, to mark whether each method's range holds it.
    #[arg(long)]
    pub truth: Option<PathBuf>,
}

// `simulate`.
#[derive(Debug, Args)]
pub(super) struct SimulateArgs {
    #[command(flatten)]
    pub flat: FlatArgs,
    /// Calibration file (TOML); the built-in defaults when omitted.
    #[arg(long)]
    pub calibration: Option<PathBuf>,
    /// CSV output: a time column and one pad-force column per sensor (kN).
    #[arg(long)]
    pub out: PathBuf,
    /// Also draw the series (PNG or SVG, by extension).
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Also write the two wheel–rail contact forces (kN) to the CSV and plot.
    #[arg(long)]
    pub contact: bool,
    #[command(flatten)]
    pub surfaces: super::surface_args::SurfaceArgs,
}

/// Parses `--flat-on BOGIE:WHEEL:L_MM:D_MM:C_MM:XP_M` for a train of `bogies` bogies.
pub(super) fn parse_flat_on(text: &str, bogies: usize) -> Result<TrainFlat> {
    let f: Vec<&str> = text.split(':').collect();
    anyhow::ensure!(
        f.len() == 6,
        "--flat-on `{text}`: expected BOGIE:WHEEL:L_MM:D_MM:C_MM:XP_M, e.g. 3:leading:60:0.5:0.1:12.9"
    );
    let bogie: usize = f[0]
        .parse()
        .with_context(|| format!("--flat-on `{text}`: bogie `{}` is not a number", f[0]))?;
    anyhow::ensure!(
        (1..=bogies).contains(&bogie),
        "--flat-on `{text}`: bogie {bogie} is not in the train (1 to {bogies})"
    );
    let wheel = match f[1] {
        "leading" => WheelPosition::Leading,
        "trailing" => WheelPosition::Trailing,
        w => anyhow::bail!("--flat-on `{text}`: wheel `{w}` is neither `leading` nor `trailing`"),
    };
    let num = |i: usize, what: &str| -> Result<f64> {
        f[i].parse()
            .with_context(|| format!("--flat-on `{text}`: {what} `{}` is not a number", f[i]))
    };
    let flat = Flat::from_mm(num(2, "L")?, num(3, "d")?, num(4, "c")?, num(5, "X_p")?)
        .with_context(|| format!("--flat-on `{text}`"))?;
    Ok(TrainFlat { bogie, wheel, flat })
}

/// Parses `--effect KIND:KEY=VALUE,…` into an effect (numbers as numbers, anything else as a
/// string).
pub(super) fn parse_effect(text: &str) -> Result<Effect> {
    let (kind, rest) = text.split_once(':').unwrap_or((text, ""));
    let mut doc = format!("kind = {:?}\n", kind.trim());
    for pair in rest.split(',').filter(|p| !p.trim().is_empty()) {
        let (k, v) = pair
            .split_once('=')
            .with_context(|| format!("--effect `{text}`: `{pair}` is not KEY=VALUE"))?;
        let v = v.trim();
        let value = if v.parse::<f64>().is_ok() {
            v.to_string()
        } else {
            format!("{v:?}")
        };
        doc += &format!("{} = {value}\n", k.trim());
    }
    toml::from_str(&doc).with_context(|| format!("--effect `{text}`"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    #[test]
    fn the_grammar_is_consistent() {
        Cli::command().debug_assert();
    }

    /// The demo builds its bank arguments in code; they must be what `bank generate --out OUT
    /// --instances N` parses to (the demo parsed them from such a line before).
    #[test]
    fn demo_bank_arguments_equal_the_parsed_defaults() {
        #[derive(Debug, Parser)]
        struct Generate {
            #[command(flatten)]
            generate: GenerateArgs,
        }
        let parsed =
            Generate::try_parse_from(["demo", "--out", "some/bank", "--instances", "123"]).unwrap();
        assert_eq!(
            parsed.generate,
            GenerateArgs::defaults(PathBuf::from("some/bank"), 123)
        );
    }

    #[test]
    fn flat_on_and_effects_parse() {
        let f = parse_flat_on("3:leading:60:0.5:0.1:12.9", 12).unwrap();
        assert_eq!((f.bogie, f.wheel), (3, WheelPosition::Leading));
        assert!(parse_flat_on("13:leading:60:0.5:0.1:12.9", 12).is_err());
        assert!(parse_flat_on("3:middle:60:0.5:0.1:12.9", 12).is_err());
        assert!(parse_effect("pad_stiffness:sleeper=16,factor=0.5").is_ok());
        assert!(parse_effect("pad_stiffness:sleeper").is_err());
    }
}
