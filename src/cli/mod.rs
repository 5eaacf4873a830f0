//! The `wheelflat` command line: a thin layer that parses arguments, reads and writes files,
//! and calls the library. Errors carry context naming the file and value (anyhow).

use crate::audit;
use crate::bank::{
    self, Codec, GenerateObserver, GenerateOptions, Outcome, StorageFormat, ValueEncoding,
};
use crate::identify::{self, Extras, Identification, Identifier, Measurement};
use crate::model::{Calibration, CheckedCalibration, Flat, Record, Response, Simulator};
use crate::report::plot::{draw_pad_forces, PadForcePlot, Series};
use anyhow::{Context, Result};
use clap::{Args, Parser, Subcommand};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

/// Wheel-flat identification from rail-pad forces, with uncertainties.
#[derive(Debug, Parser)]
#[command(name = "wheelflat", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Print the built-in calibration (MODEL.md defaults) as a TOML file to start from.
    Calibration {
        /// Write to this file instead of standard output.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Population profile: `paper` (flat on the trailing wheel, X_p in [12, 13] m) or
        /// `train` (either wheel, X_p over one wheel revolution; what `train` needs).
        #[arg(long, value_enum, default_value_t = Profile::Paper)]
        profile: Profile,
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
    /// Identify the flat size behind a measurement from a bank: JSON, figures, HTML report.
    Identify(IdentifyArgs),
    /// Print the paper-style comparison of the method with its baselines for one measurement.
    Compare(CompareArgs),
    /// Identify every wheel of a whole train pass: one recording, the trigger time of every
    /// wheel; a table (CSV, JSON, HTML) with flat yes/no, L0 range and severity per wheel.
    Train(TrainArgs),
    /// Audit one model instance: re-simulate it and compare with the bank; with a measurement,
    /// show why it is kept or falsified.
    Audit(AuditArgs),
    /// Diagnose a model gap: locate where the best instances leave the thresholds, fit every
    /// effect of the library with the flat and rank them (BIC), name one only when the evidence
    /// is clear, add it, regenerate a local bank and identify again; report before and after.
    Diagnose(DiagnoseArgs),
    /// Run the main job on built-in defaults: simulate, build the bank on first use (with
    /// progress), make a synthetic field measurement, identify the flat, write the report.
    Demo {
        /// Output folder.
        #[arg(long, default_value = "wheelflat-demo")]
        out: PathBuf,
        /// Bank directory (built here on first use; reused while it is up to date).
        #[arg(long, default_value = "bank")]
        bank: PathBuf,
        /// Instances in the bank (the paper's 50,000; fewer for a quick look).
        #[arg(long, default_value_t = 50_000)]
        instances: usize,
    },
}

/// The built-in population profiles.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Profile {
    /// The paper's: trailing wheel, X_p in [12, 13] m.
    Paper,
    /// Whole-train monitoring: both wheels, X_p over one revolution.
    Train,
    /// CI-sized: narrower flat ranges and 600-sample windows, for small banks (tests, the
    /// diagnosis suite, trying things out).
    Narrow,
}

#[derive(Debug, Subcommand)]
enum BankCommand {
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

#[derive(Debug, Args)]
struct GenerateArgs {
    /// Calibration file (TOML); the built-in defaults when omitted.
    #[arg(long)]
    calibration: Option<PathBuf>,
    /// Instances in the population.
    #[arg(long, default_value_t = 50_000)]
    instances: usize,
    /// Bank directory.
    #[arg(long, default_value = "bank")]
    out: PathBuf,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Build only part I of N (0-based), e.g. `--shard 3/10`, for a cluster job array.
    #[arg(long, value_parser = parse_shard)]
    shard: Option<(usize, usize)>,
    /// Population seed (0: plain Hammersley).
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Instances per shard file (the unit of resumable work).
    #[arg(long, default_value_t = 2500)]
    shard_size: usize,
    /// Compression of the force columns.
    #[arg(long, value_enum, default_value_t = Codec::None)]
    compression: Codec,
    /// Encoding of the force columns.
    #[arg(long, value_enum, default_value_t = ValueEncoding::Plain)]
    encoding: ValueEncoding,
}

fn parse_shard(s: &str) -> std::result::Result<(usize, usize), String> {
    let (i, n) = s
        .split_once('/')
        .ok_or_else(|| format!("`{s}`: expected I/N, e.g. 0/4"))?;
    let i: usize = i
        .trim()
        .parse()
        .map_err(|_| format!("`{s}`: I is not a number"))?;
    let n: usize = n
        .trim()
        .parse()
        .map_err(|_| format!("`{s}`: N is not a number"))?;
    if n == 0 || i >= n {
        return Err(format!("`{s}`: need 0 <= I < N"));
    }
    Ok((i, n))
}

#[derive(Debug, Args)]
struct SynthArgs {
    #[command(flatten)]
    flat: FlatArgs,
    /// Calibration file (TOML); the built-in defaults when omitted.
    #[arg(long)]
    calibration: Option<PathBuf>,
    /// Seed of the perturbation.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Measurement CSV to write.
    #[arg(long)]
    out: PathBuf,
    /// Truth JSON to write (default: the CSV path with `.truth.json`).
    #[arg(long)]
    truth: Option<PathBuf>,
    /// Leave the laser trigger time out (alignment then uses cross-correlation).
    #[arg(long)]
    no_trigger: bool,
    /// A whole train instead of one bogie: writes the recording, a trigger file
    /// (`<out>.triggers.csv`, one time per wheel) and the truth. Without `--flat-on`: flats
    /// on bogie 2 leading, bogie 7 trailing and bogie 11 leading.
    #[arg(long)]
    train: bool,
    /// Bogies in the train.
    #[arg(long, default_value_t = 12, requires = "train")]
    bogies: usize,
    /// Hide an effect of the library in the measurement: `KIND:KEY=VALUE,…`, e.g.
    /// `pad_stiffness:sleeper=16,factor=0.5` or `wheel_out_of_round:wheel=leading,order=8,amplitude_mm=0.05`
    /// (repeat for more; the keys are those of `[[effects]]` in the calibration).
    #[arg(long = "effect")]
    effects: Vec<String>,
    /// A flat on one wheel of the train: `BOGIE:WHEEL:L_MM:D_MM:C_MM:XP_M`, e.g.
    /// `3:leading:60:0.5:0.1:12.9` (repeat for more).
    #[arg(long = "flat-on", requires = "train")]
    flat_on: Vec<String>,
}

#[derive(Debug, Args)]
struct MeasuredArgs {
    /// Bank directory.
    #[arg(long, default_value = "bank")]
    bank: PathBuf,
    /// Measurement CSV (`time_s,<sensor>_kn,…`).
    #[arg(long)]
    measured: PathBuf,
    /// Only these sensors, e.g. `rps1,rps2` (a broken sensor is left out).
    #[arg(long, value_delimiter = ',')]
    sensors: Option<Vec<String>>,
    /// Identification settings and uncertainty table from this calibration file instead of
    /// the bank's.
    #[arg(long)]
    calibration: Option<PathBuf>,
}

#[derive(Debug, Args)]
struct IdentifyArgs {
    #[command(flatten)]
    input: MeasuredArgs,
    /// Report folder (JSON, PNG/SVG figures, report.html).
    #[arg(long)]
    out: PathBuf,
    /// Skip the baselines (residual minimisation is always reported) and entropy curves.
    #[arg(long)]
    no_baselines: bool,
}

#[derive(Debug, Args)]
struct TrainArgs {
    /// Bank directory (a train-profile bank: both wheels, X_p over a revolution).
    #[arg(long, default_value = "bank")]
    bank: PathBuf,
    /// The recording: CSV `time_s,<sensor>_kn,…` over the whole train pass.
    #[arg(long)]
    recording: PathBuf,
    /// Trigger times, one per wheel passing the laser (`time_s` column).
    #[arg(long)]
    triggers: PathBuf,
    /// Report folder: `train.csv`, `train.json`, `train.html`.
    #[arg(long)]
    out: PathBuf,
}

#[derive(Debug, Args)]
struct AuditArgs {
    /// Bank directory.
    #[arg(long, default_value = "bank")]
    bank: PathBuf,
    /// Instance number.
    #[arg(long)]
    instance: usize,
    /// Measurement CSV to judge the instance against (identified first, as `identify` does).
    #[arg(long)]
    measured: Option<PathBuf>,
    /// Only these sensors of the measurement, e.g. `rps1,rps2`.
    #[arg(long, value_delimiter = ',', requires = "measured")]
    sensors: Option<Vec<String>>,
    /// Identification settings and uncertainty table from this calibration file instead of
    /// the bank's.
    #[arg(long, requires = "measured")]
    calibration: Option<PathBuf>,
    /// Folder for `audit.json` and `audit.png`.
    #[arg(long)]
    out: Option<PathBuf>,
}

#[derive(Debug, Args)]
struct DiagnoseArgs {
    #[command(flatten)]
    input: MeasuredArgs,
    /// Report folder: `diagnosis.json`, `diagnosis.html`, `diagnosis-gap.png`, and with an
    /// effect named `calibration-with-effect.toml` and the local bank in `local-bank/`.
    #[arg(long)]
    out: PathBuf,
    /// Instances of the local bank regenerated with the named effect.
    #[arg(long, default_value_t = 1000)]
    local_instances: usize,
    /// Name the effect but do not regenerate a bank (no "after").
    #[arg(long)]
    no_local_bank: bool,
}

#[derive(Debug, Args)]
struct CompareArgs {
    #[command(flatten)]
    input: MeasuredArgs,
    /// Truth JSON from `synth`, to mark whether each method's range holds it.
    #[arg(long)]
    truth: Option<PathBuf>,
}

#[derive(Debug, Args)]
struct FlatArgs {
    /// Flat length L (mm).
    #[arg(long = "l-mm", default_value_t = 60.0)]
    length_mm: f64,
    /// Flat depth d (mm).
    #[arg(long = "d-mm", default_value_t = 0.5)]
    depth_mm: f64,
    /// Curvature parameter c (mm), 0 ≤ c < d/2.
    #[arg(long = "c-mm", default_value_t = 0.1)]
    curvature_mm: f64,
    /// Impact position X_p (m from the left rail end).
    #[arg(long = "xp-m", default_value_t = 12.4)]
    impact_position_m: f64,
    /// Simulate a good wheel (no flat): the flat-free signature.
    #[arg(long, conflicts_with_all = ["length_mm", "depth_mm", "curvature_mm", "impact_position_m"])]
    no_flat: bool,
}

#[derive(Debug, Args)]
struct SimulateArgs {
    #[command(flatten)]
    flat: FlatArgs,
    /// Calibration file (TOML); the built-in defaults when omitted.
    #[arg(long)]
    calibration: Option<PathBuf>,
    /// CSV output: a time column and one pad-force column per sensor (kN).
    #[arg(long)]
    out: PathBuf,
    /// Also draw the series (PNG or SVG, by extension).
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Also write the two wheel–rail contact forces (kN) to the CSV and plot.
    #[arg(long)]
    contact: bool,
}

/// Entry point of the binary.
pub fn main() -> ExitCode {
    // Like other Unix tools, end quietly when the reader of our output goes away
    // (`wheelflat bank info bank | head`) instead of panicking on a broken pipe.
    #[cfg(unix)]
    // SAFETY: called first thing in main, before any other thread exists; resetting a signal
    // disposition to its default has no other effect on the process.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Calibration { out, profile } => cmd_calibration(out.as_deref(), profile),
        Command::Simulate(args) => cmd_simulate(&args),
        Command::Bank { command } => match command {
            BankCommand::Generate(a) => cmd_bank_generate(&a, true),
            BankCommand::Merge(a) => cmd_bank_generate(&a, false),
            BankCommand::Info { dir } => cmd_bank_info(&dir),
            BankCommand::Verify { dir } => cmd_bank_verify(&dir),
            BankCommand::Audit {
                dir,
                sample,
                calibration,
            } => cmd_bank_audit(&dir, sample, calibration.as_deref()),
        },
        Command::Synth(a) => cmd_synth(&a),
        Command::Identify(a) => cmd_identify(&a),
        Command::Compare(a) => cmd_compare(&a),
        Command::Audit(a) => cmd_audit(&a),
        Command::Diagnose(a) => cmd_diagnose(&a),
        Command::Train(a) => cmd_train(&a),
        Command::Demo {
            out,
            bank,
            instances,
        } => cmd_demo(&out, &bank, instances),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// Reads and checks a calibration file, or returns the built-in defaults.
pub fn load_calibration(path: Option<&Path>) -> Result<CheckedCalibration> {
    let Some(path) = path else {
        return Ok(Calibration::default().check()?);
    };
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read calibration file {}", path.display()))?;
    let doc = Calibration::from_toml_str(&text)
        .with_context(|| format!("in calibration file {}", path.display()))?;
    doc.check()
        .with_context(|| format!("in calibration file {}", path.display()))
}

/// Writes `bytes` to `path` atomically ([`crate::atomic::write_atomically`]), naming the file
/// in the error.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<()> {
    crate::atomic::write_atomically(path, bytes)
        .with_context(|| format!("cannot write {}", path.display()))
}

fn cmd_calibration(out: Option<&Path>, profile: Profile) -> Result<()> {
    let text = match profile {
        Profile::Paper => Calibration::default(),
        Profile::Train => Calibration::train_profile(),
        Profile::Narrow => Calibration::narrow_profile(),
    }
    .to_toml_string();
    match out {
        Some(p) => write_atomically(p, text.as_bytes()),
        None => {
            print!("{text}");
            Ok(())
        }
    }
}

fn flat_from_args(a: &FlatArgs) -> Result<Option<Flat>> {
    if a.no_flat {
        return Ok(None);
    }
    Ok(Some(Flat::from_mm(
        a.length_mm,
        a.depth_mm,
        a.curvature_mm,
        a.impact_position_m,
    )?))
}

/// The CSV text of a response: `time_s`, one `<sensor>_kn` column per sensor, and the contact
/// forces when recorded.
pub fn response_csv(cal: &CheckedCalibration, r: &Response) -> String {
    let mut s = String::from("time_s");
    for p in &cal.sensors.pad {
        s += &format!(",{}_kn", p.name);
    }
    if r.contact_force_n.is_some() {
        s += ",contact_leading_kn,contact_trailing_kn";
    }
    s.push('\n');
    for j in 0..r.len() {
        s += &format!("{:.6}", r.time_s(j));
        for series in &r.pad_force_n {
            s += &format!(",{:.4}", series[j] / 1e3);
        }
        if let Some(c) = &r.contact_force_n {
            s += &format!(",{:.4},{:.4}", c[0][j] / 1e3, c[1][j] / 1e3);
        }
        s.push('\n');
    }
    s
}

/// Human summary of a run: per-sensor peaks, contact peaks and loss of contact.
pub fn response_summary(cal: &CheckedCalibration, r: &Response) -> String {
    let mut s = String::new();
    s += "sensor  position_m  peak_kn  at_time_s\n";
    for (i, p) in cal.sensors.pad.iter().enumerate() {
        let (j, peak) =
            r.pad_force_n[i]
                .iter()
                .copied()
                .enumerate()
                .fold(
                    (0, f64::MIN),
                    |acc, (j, v)| if v > acc.1 { (j, v) } else { acc },
                );
        s += &format!(
            "{:<6}  {:>10.2}  {:>7.2}  {:>9.4}\n",
            p.name,
            cal.sensor_position_m(i),
            peak / 1e3,
            r.time_s(j)
        );
    }
    s += &format!(
        "peak contact force: leading {:.1} kN, trailing {:.1} kN (static {:.1} kN)\n",
        r.peak_contact_force_n[0] / 1e3,
        r.peak_contact_force_n[1] / 1e3,
        cal.static_wheel_load_n() / 1e3
    );
    for (w, name) in ["leading", "trailing"].iter().enumerate() {
        if r.contact_loss_s[w] > 0.0 {
            s += &format!(
                "loss of contact: {name} wheel off the rail for {:.2} ms in total\n",
                r.contact_loss_s[w] * 1e3
            );
        }
    }
    if !r.strike_times_s.is_empty() {
        let t: Vec<String> = r.strike_times_s.iter().map(|t| format!("{t:.4}")).collect();
        s += &format!("flat strikes at t = {} s\n", t.join(", "));
    }
    s
}

/// Draws a response with all sensors, the strikes marked, and the contact forces if recorded.
pub fn plot_response(
    cal: &CheckedCalibration,
    r: &Response,
    title: &str,
    path: &Path,
) -> Result<()> {
    let time: Vec<f64> = (0..r.len()).map(|j| r.time_s(j)).collect();
    let kn: Vec<Vec<f64>> = r
        .pad_force_n
        .iter()
        .map(|s| s.iter().map(|v| v / 1e3).collect())
        .collect();
    let contact: Option<[Vec<f64>; 2]> = r
        .contact_force_n
        .as_ref()
        .map(|c| [0, 1].map(|w| c[w].iter().map(|v| v / 1e3).collect()));
    let series = cal
        .sensors
        .pad
        .iter()
        .zip(&kn)
        .map(|(p, v)| Series {
            label: &p.name,
            values_kn: v,
        })
        .collect();
    let plot = PadForcePlot {
        title,
        time_s: &time,
        series,
        strike_times_s: &r.strike_times_s,
        contact_kn: contact.as_ref().map(|c| [c[0].as_slice(), c[1].as_slice()]),
    };
    draw_pad_forces(&plot, path).with_context(|| format!("cannot draw {}", path.display()))
}

fn flat_title(flat: Option<&Flat>) -> String {
    match flat {
        None => "good wheel (no flat)".to_string(),
        Some(f) => format!(
            "flat L = {:.1} mm, d = {:.3} mm, c = {:.3} mm, X_p = {:.3} m",
            f.length_m() * 1e3,
            f.depth_m() * 1e3,
            f.curvature_m() * 1e3,
            f.impact_position_m()
        ),
    }
}

fn cmd_simulate(a: &SimulateArgs) -> Result<()> {
    let cal = load_calibration(a.calibration.as_deref())?;
    let flat = flat_from_args(&a.flat)?;
    let started = Instant::now();
    let sim = Simulator::new(&cal)?;
    let resp = sim.run(flat.as_ref(), Record { contact: a.contact })?;
    let elapsed = started.elapsed();
    write_atomically(&a.out, response_csv(&cal, &resp).as_bytes())?;
    println!("{}", flat_title(flat.as_ref()));
    print!("{}", response_summary(&cal, &resp));
    println!(
        "simulated {:.3} s of train passage in {:.1} ms ({} coarse + {} fine steps); wrote {}",
        cal.end_sample() as f64 / cal.output.sample_rate_hz,
        elapsed.as_secs_f64() * 1e3,
        resp.steps[0],
        resp.steps[1],
        a.out.display()
    );
    if let Some(p) = &a.plot {
        plot_response(&cal, &resp, &flat_title(flat.as_ref()), p)?;
        println!("wrote {}", p.display());
    }
    Ok(())
}

/// The demo's field case: a flat between the bank's instances, errors seeded.
const DEMO_FLAT: (f64, f64, f64, f64, u64) = (62.0, 0.55, 0.05, 12.156, 3);

fn cmd_demo(out: &Path, bank_dir: &Path, instances: usize) -> Result<()> {
    std::fs::create_dir_all(out)
        .with_context(|| format!("cannot create output folder {}", out.display()))?;
    let cal = load_calibration(None)?;
    let sim = Simulator::new(&cal)?;
    println!(
        "wheelflat demo: built-in calibration (MODEL.md defaults), outputs in {}",
        out.display()
    );
    println!("\n1. Simulate");
    for (name, flat) in [
        ("good-wheel", None),
        ("flat-60mm", Some(Flat::from_mm(60.0, 0.5, 0.1, 12.4)?)),
    ] {
        let resp = sim.run(flat.as_ref(), Record { contact: true })?;
        let csv = out.join(format!("{name}.csv"));
        let png = out.join(format!("{name}.png"));
        write_atomically(&csv, response_csv(&cal, &resp).as_bytes())?;
        plot_response(&cal, &resp, &flat_title(flat.as_ref()), &png)?;
        println!("\n{}", flat_title(flat.as_ref()));
        print!("{}", response_summary(&cal, &resp));
        println!("wrote {} and {}", csv.display(), png.display());
    }

    println!(
        "\n2. Bank ({instances} instances in {})",
        bank_dir.display()
    );
    let bank_args = DemoBank::try_parse_from([
        "demo".as_ref(),
        "--out".as_ref(),
        bank_dir.as_os_str(),
        "--instances".as_ref(),
        instances.to_string().as_ref(),
    ])
    .context("demo bank arguments")?;
    cmd_bank_generate(&bank_args.generate, true)?;

    let (l, d, c, xp, seed) = DEMO_FLAT;
    let flat = Flat::from_mm(l, d, c, xp)?;
    println!("\n3. Synthetic field measurement");
    let syn = identify::synth::synthesize(&cal, &flat, seed, true)?;
    let measured = out.join("measurement.csv");
    let truth_path = out.join("measurement.truth.json");
    write_atomically(&measured, syn.csv.as_bytes())?;
    let json = serde_json::to_string_pretty(&syn.truth).expect("truth serialises");
    write_atomically(&truth_path, json.as_bytes())?;
    println!(
        "{} (L0 {:.1} mm), errors drawn inside the uncertainty table with seed {seed}: wrote {} and {}",
        flat_title(Some(&flat)),
        syn.truth.l0_mm,
        measured.display(),
        truth_path.display()
    );

    println!("\n4. Identify");
    let input = MeasuredArgs {
        bank: bank_dir.to_path_buf(),
        measured,
        sensors: None,
        calibration: None,
    };
    let (identifier, m) = open_identifier(&input)?;
    let id = identifier.identify(
        &m,
        None,
        Extras {
            baselines: true,
            curves: true,
        },
    )?;
    report_identification(&id, &out.join("identification"), Some(&syn.truth))
}

/// The bank arguments of the demo, parsed like `wheelflat bank generate`'s.
#[derive(Debug, Parser)]
struct DemoBank {
    #[command(flatten)]
    generate: GenerateArgs,
}

/// Progress of a bank generation: an indicatif bar on a terminal, plain periodic log lines
/// otherwise (cron, batch schedulers).
struct Progress {
    bar: Option<indicatif::ProgressBar>,
    done: AtomicUsize,
    total: AtomicUsize,
    started: Instant,
    last_log: Mutex<Instant>,
}

impl Progress {
    fn new() -> Progress {
        Progress {
            bar: None,
            done: AtomicUsize::new(0),
            total: AtomicUsize::new(0),
            started: Instant::now(),
            last_log: Mutex::new(Instant::now()),
        }
    }

    fn with_terminal(mut self) -> Progress {
        if std::io::stderr().is_terminal() {
            let bar = indicatif::ProgressBar::new(0);
            bar.set_style(
                indicatif::ProgressStyle::with_template(
                    "{spinner} [{elapsed_precise}] {wide_bar} {pos}/{len} instances  {per_sec}  ETA {eta}",
                )
                .expect("valid template"),
            );
            self.bar = Some(bar);
        }
        self
    }

    fn log_line(&self) -> String {
        let done = self.done.load(Ordering::Relaxed);
        let total = self.total.load(Ordering::Relaxed).max(1);
        let secs = self.started.elapsed().as_secs_f64();
        let rate = done as f64 / secs.max(1e-9);
        let eta = (total - done.min(total)) as f64 / rate.max(1e-9);
        format!(
            "bank: {done}/{total} instances ({:.1} %), {rate:.0} instances/s, ETA {:.0} s",
            100.0 * done as f64 / total as f64,
            eta
        )
    }
}

impl GenerateObserver for Progress {
    fn started(&self, to_simulate: usize, already_done: usize) {
        self.total.store(to_simulate, Ordering::Relaxed);
        if already_done > 0 {
            eprintln!("bank: resuming, {already_done} instances already on disk");
        }
        if let Some(b) = &self.bar {
            b.set_length(to_simulate as u64);
        } else if to_simulate > 0 {
            eprintln!("bank: simulating {to_simulate} instances");
        }
    }

    fn instance_done(&self) {
        self.done.fetch_add(1, Ordering::Relaxed);
        if let Some(b) = &self.bar {
            b.inc(1);
            return;
        }
        let mut last = self.last_log.lock().unwrap_or_else(|e| e.into_inner());
        if last.elapsed().as_secs_f64() >= 10.0 {
            *last = Instant::now();
            eprintln!("{}", self.log_line());
        }
    }

    fn file_written(&self, name: &str) {
        match &self.bar {
            Some(b) => b.println(format!("wrote {name}")),
            None => eprintln!("bank: wrote {name}"),
        }
    }
}

fn cmd_bank_generate(a: &GenerateArgs, simulate_missing: bool) -> Result<()> {
    let cal = load_calibration(a.calibration.as_deref())?;
    let opts = GenerateOptions {
        instances: a.instances,
        seed: a.seed,
        shard_size: a.shard_size,
        machine_shard: a.shard,
        format: StorageFormat {
            codec: a.compression,
            encoding: a.encoding,
        },
        simulate_missing,
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
    let progress = Progress::new().with_terminal();
    let started = Instant::now();
    let outcome = pool.install(|| bank::generate(&cal, &a.out, &opts, &progress));
    if let Some(b) = &progress.bar {
        b.finish_and_clear();
    }
    let outcome = outcome.with_context(|| format!("bank {}", a.out.display()))?;
    let secs = started.elapsed().as_secs_f64();
    match outcome {
        Outcome::UpToDate { version } => {
            println!(
                "bank {} is up to date ({}); nothing to do",
                a.out.display(),
                version.display()
            );
        }
        Outcome::Complete {
            version,
            simulated,
            resumed,
        } => {
            println!(
                "bank complete: {} instances in {} ({simulated} simulated in {secs:.1} s, {:.0} instances/s on {threads} threads; {resumed} kept from an earlier run); CURRENT -> {}",
                a.instances,
                version.display(),
                simulated as f64 / secs.max(1e-9),
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
                "shard {i}/{n} done: {files} shard files in {} ({simulated} instances simulated in {secs:.1} s); run `wheelflat bank merge` with the same arguments when all shards are done",
                version.display()
            );
        }
    }
    Ok(())
}

fn cmd_bank_info(dir: &Path) -> Result<()> {
    let b = bank::Bank::open(dir).with_context(|| format!("cannot open bank {}", dir.display()))?;
    let m = b.metadata();
    let bytes: u64 = b.manifest().files.iter().map(|f| f.bytes).sum();
    println!("bank            {}", b.dir().display());
    println!("bank id         {}", m.bank_id);
    println!(
        "format          {} ({}), model revision {}",
        m.format_version, m.generator, m.model_revision
    );
    println!("calibration     sha256 {}", m.calibration_sha256);
    println!(
        "instances       {} in {} shard files of {}",
        b.instances(),
        b.manifest().files.len(),
        m.shard_size
    );
    println!("sampling        {} (seed {})", m.sampling, m.seed);
    println!(
        "size            {:.1} MB, {:.1} kB per instance",
        bytes as f64 / 1e6,
        bytes as f64 / 1e3 / b.instances().max(1) as f64
    );
    println!("sensors         (force in {})", m.force_unit);
    for s in &m.sensors {
        println!(
            "  {:<6} sleeper {:>2} at {:>6.2} m: {} samples at {} Hz from t = {:.4} s",
            s.name, s.sleeper, s.position_m, s.samples, s.sample_rate_hz, s.t0_s
        );
    }
    let p = b
        .read_parameters()
        .with_context(|| format!("reading parameters of {}", dir.display()))?;
    let range = |v: &[f64]| {
        v.iter()
            .fold((f64::MAX, f64::MIN), |(lo, hi), &x| (lo.min(x), hi.max(x)))
    };
    println!("parameter ranges");
    for (name, v) in [
        ("length_mm", &p.length_mm),
        ("depth_mm", &p.depth_mm),
        ("curvature_mm", &p.curvature_mm),
        ("impact_position_m", &p.impact_position_m),
        ("l0_mm", &p.l0_mm),
    ] {
        let (lo, hi) = range(v);
        println!("  {name:<18} [{lo:.4}, {hi:.4}]");
    }
    Ok(())
}

fn cmd_bank_verify(dir: &Path) -> Result<()> {
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

fn cmd_bank_audit(dir: &Path, sample: usize, calibration: Option<&Path>) -> Result<()> {
    use rayon::prelude::*;
    let b = bank::Bank::open(dir).with_context(|| format!("cannot open bank {}", dir.display()))?;
    let against = match calibration {
        Some(p) => Some(load_calibration(Some(p))?),
        None => None,
    };
    let what = match calibration {
        Some(p) => format!("the calibration in {}", p.display()),
        None => "the calibration stored in the bank".into(),
    };
    let resim = audit::Resimulator::new(&b, against)?;
    let picks = audit::sample_instances(b.instances(), sample);
    println!(
        "bank {} ({} instances, bank id {}): re-simulating {} instances with {what}",
        dir.display(),
        b.instances(),
        b.metadata().bank_id,
        picks.len()
    );
    let results: Vec<audit::Resimulation> = picks
        .par_iter()
        .map_init(
            || resim.workspace(),
            |ws, &i| -> Result<audit::Resimulation> {
                let stored = b.read_instance(i)?;
                let r = resim.run(&stored, ws)?;
                Ok(audit::compare(&stored, &r, &b))
            },
        )
        .collect::<Result<_>>()?;
    let drifted: Vec<&audit::Resimulation> = results.iter().filter(|r| !r.identical).collect();
    for r in &results {
        println!("  instance {:>6}: {}", r.instance, r.verdict());
    }
    if drifted.is_empty() {
        println!(
            "no drift: all {} re-simulated instances match the bank bit for bit",
            results.len()
        );
        return Ok(());
    }
    let worst = drifted.iter().map(|r| r.max_abs_kn).fold(0.0f64, f64::max);
    anyhow::bail!(
        "DRIFT: {} of {} re-simulated instances differ from the bank (max |Δ| {worst:.4} kN). The bank no longer matches this code and {what}: find the change, or regenerate the bank (`wheelflat bank generate`)",
        drifted.len(),
        results.len()
    )
}

fn cmd_train(a: &TrainArgs) -> Result<()> {
    let b = bank::Bank::open(&a.bank)
        .with_context(|| format!("cannot open bank {}", a.bank.display()))?;
    crate::train::check_coverage(&b, &a.bank)?;
    let cal = b
        .metadata()
        .calibration
        .clone()
        .check()
        .context("the bank's stored calibration")?;
    let rate = b.metadata().sensors[0].sample_rate_hz;
    let text = std::fs::read_to_string(&a.recording)
        .with_context(|| format!("cannot read recording {}", a.recording.display()))?;
    let recording = Measurement::from_csv(&a.recording, &text, rate)?;
    let ttext = std::fs::read_to_string(&a.triggers)
        .with_context(|| format!("cannot read triggers {}", a.triggers.display()))?;
    let times = crate::train::read_triggers(&a.triggers, &ttext)?;
    let bogies = crate::train::bogies_from_triggers(&cal, &a.triggers, &times)?;
    let identifier = Identifier::new(b, cal.identification.clone())?;
    let result = crate::train::identify_train(&identifier, &recording, &bogies)?;
    std::fs::create_dir_all(&a.out)
        .with_context(|| format!("cannot create output folder {}", a.out.display()))?;
    let csv = a.out.join("train.csv");
    let json = a.out.join("train.json");
    let html = a.out.join("train.html");
    write_atomically(&csv, crate::report::train::table_csv(&result).as_bytes())?;
    write_atomically(
        &json,
        serde_json::to_string_pretty(&result)
            .expect("train result serialises")
            .as_bytes(),
    )?;
    write_atomically(&html, crate::report::train::table_html(&result).as_bytes())?;
    print!("{}", crate::report::train::table_text(&result));
    let flats = result.wheels.iter().filter(|w| w.flat == "yes").count();
    println!(
        "{} bogies, {} wheels: {flats} with a flat; identified in {:.0} ms ({:.0} ms per bogie)",
        result.bogies.len(),
        result.wheels.len(),
        result.total_ms,
        result.total_ms / result.bogies.len().max(1) as f64
    );
    println!("severity rule: {}", result.severity_rule);
    for w in &result.warnings {
        println!("warning: {w}");
    }
    println!(
        "wrote {}, {} and {}",
        csv.display(),
        json.display(),
        html.display()
    );
    Ok(())
}

fn cmd_audit(a: &AuditArgs) -> Result<()> {
    let b = bank::Bank::open(&a.bank)
        .with_context(|| format!("cannot open bank {}", a.bank.display()))?;
    let stored = b.read_instance(a.instance)?;
    let [l, d, c, xp, l0, wheel] = stored.parameters;
    let wheel = crate::model::WheelPosition::from_code(wheel as u8).name();
    println!(
        "instance {}: L {l:.2} mm, d {d:.4} mm, c {c:.4} mm, X_p {xp:.4} m, L0 {l0:.1} mm, on the {wheel} wheel",
        stored.instance
    );
    let resim = audit::Resimulator::new(&b, None)?;
    let series = resim.run(&stored, &mut resim.workspace())?;
    let comparison = audit::compare(&stored, &series, &b);
    println!(
        "re-simulated with the bank's stored calibration (bank id {}): {}",
        b.metadata().bank_id,
        comparison.verdict()
    );
    if !comparison.identical {
        println!("  the code or its calibration handling changed since this bank was built");
    }
    let mut check = None;
    let mut identification = None;
    if let Some(measured) = &a.measured {
        let input = MeasuredArgs {
            bank: a.bank.clone(),
            measured: measured.clone(),
            sensors: a.sensors.clone(),
            calibration: a.calibration.clone(),
        };
        let (identifier, m) = open_identifier(&input)?;
        let id = identifier.identify(&m, a.sensors.as_deref(), Extras::NONE)?;
        let c = audit::check_against(&identifier, &id, &stored)?;
        print!("{}", audit_table(&c));
        check = Some(c);
        identification = Some(id);
    }
    if let Some(out) = &a.out {
        std::fs::create_dir_all(out)
            .with_context(|| format!("cannot create output folder {}", out.display()))?;
        let json = serde_json::json!({
            "instance": stored.instance,
            "parameters": {
                "length_mm": l, "depth_mm": d, "curvature_mm": c,
                "impact_position_m": xp, "l0_mm": l0, "flat_wheel": wheel,
            },
            "bank_id": b.metadata().bank_id,
            "resimulation": comparison,
            "measured": check,
        });
        let json_path = out.join("audit.json");
        write_atomically(
            &json_path,
            serde_json::to_string_pretty(&json)
                .expect("audit serialises")
                .as_bytes(),
        )?;
        let png = out.join("audit.png");
        let axes = &b.metadata().sensors;
        let panels: Vec<crate::report::audit::AuditPanel> = axes
            .iter()
            .enumerate()
            .filter_map(|(ai, axis)| {
                let measured = match &identification {
                    Some(id) => Some(
                        id.series
                            .iter()
                            .find(|s| s.sensor == axis.name)?
                            .values_kn
                            .as_slice(),
                    ),
                    None => None,
                };
                let points = check
                    .iter()
                    .flat_map(|c| c.points.iter())
                    .filter(|p| p.sensor == axis.name)
                    .map(|p| crate::report::audit::BandPoint {
                        time_s: p.time_s,
                        predicted_kn: p.predicted_kn,
                        band_kn: [
                            p.measured_kn + p.threshold_kn[0] - p.widening_kn,
                            p.measured_kn + p.threshold_kn[1] + p.widening_kn,
                        ],
                        falsifies: p.outside_by_kn > 0.0,
                    })
                    .collect();
                Some(crate::report::audit::AuditPanel {
                    sensor: &axis.name,
                    t0_s: axis.t0_s,
                    rate_hz: axis.sample_rate_hz,
                    stored: &stored.forces_kn[ai],
                    resimulated: &series[ai],
                    measured,
                    points,
                })
            })
            .collect();
        let verdict = match &check {
            Some(c) if c.kept => "kept",
            Some(_) => "falsified",
            None => "",
        };
        crate::report::audit::draw_audit(
            &format!(
                "instance {} (L {l:.1} mm, d {d:.3} mm, c {c:.3} mm, X_p {xp:.3} m) {verdict}",
                stored.instance
            ),
            &panels,
            &png,
        )?;
        println!("wrote {} and {}", json_path.display(), png.display());
    }
    Ok(())
}

/// The verdict of an instance against a measurement, with its points, falsifying ones first.
fn audit_table(c: &audit::MeasuredCheck) -> String {
    let mut s = if c.kept {
        let margin = c
            .points
            .iter()
            .map(|p| -p.outside_by_kn)
            .fold(f64::MAX, f64::min);
        format!(
            "against {}: KEPT — inside the admissible residual at all {} comparison points (closest margin {margin:.2} kN); {} the candidate model set\n",
            c.measurement,
            c.points.len(),
            if c.in_cms { "member of" } else { "NOT in" }
        )
    } else {
        format!(
            "against {}: FALSIFIED at {} of {} comparison points (per-point probability {:.5}); {} the candidate model set\n",
            c.measurement,
            c.falsified_by.len(),
            c.points.len(),
            c.per_point_probability,
            if c.in_cms { "yet member of" } else { "not in" }
        )
    };
    s += &format!(
        "  {:<5} {:<6} {:>9} {:>10} {:>10} {:>9} {:>22} {:>9}  {}\n",
        "EIP",
        "sensor",
        "time (s)",
        "measured",
        "predicted",
        "residual",
        "admissible residual",
        "outside",
        "verdict"
    );
    let mut order: Vec<usize> = c.falsified_by.clone();
    order.extend((0..c.points.len()).filter(|i| !c.falsified_by.contains(i)));
    for i in order {
        let p = &c.points[i];
        s += &format!(
            "  {:<5} {:<6} {:>9.4} {:>10.2} {:>10.2} {:>+9.2} {:>22} {:>+9.2}  {}\n",
            p.order,
            p.sensor,
            p.time_s,
            p.measured_kn,
            p.predicted_kn,
            p.residual_kn,
            format!(
                "[{:+.2}, {:+.2}] ± {:.2}",
                p.threshold_kn[0], p.threshold_kn[1], p.widening_kn
            ),
            p.outside_by_kn,
            if p.outside_by_kn > 0.0 {
                "falsifies"
            } else {
                "inside"
            }
        );
    }
    s
}

/// Parses `BOGIE:WHEEL:L_MM:D_MM:C_MM:XP_M`.
fn parse_flat_on(text: &str, bogies: usize) -> Result<crate::train::TrainFlat> {
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
        "leading" => crate::model::WheelPosition::Leading,
        "trailing" => crate::model::WheelPosition::Trailing,
        w => anyhow::bail!("--flat-on `{text}`: wheel `{w}` is neither `leading` nor `trailing`"),
    };
    let num = |i: usize, what: &str| -> Result<f64> {
        f[i].parse()
            .with_context(|| format!("--flat-on `{text}`: {what} `{}` is not a number", f[i]))
    };
    let flat = Flat::from_mm(num(2, "L")?, num(3, "d")?, num(4, "c")?, num(5, "X_p")?)
        .with_context(|| format!("--flat-on `{text}`"))?;
    Ok(crate::train::TrainFlat { bogie, wheel, flat })
}

fn cmd_synth_train(a: &SynthArgs, cal: &CheckedCalibration) -> Result<()> {
    let flats = if a.flat_on.is_empty() {
        crate::train::default_flats()
    } else {
        a.flat_on
            .iter()
            .map(|t| parse_flat_on(t, a.bogies))
            .collect::<Result<Vec<_>>>()?
    };
    let mut spec = crate::train::TrainSpec::twelve_bogies(flats, a.seed);
    spec.bogies = a.bogies;
    let syn = crate::train::synthesize_train(cal, &spec)?;
    let triggers = a.out.with_extension("triggers.csv");
    let truth = a
        .truth
        .clone()
        .unwrap_or_else(|| a.out.with_extension("truth.json"));
    write_atomically(&a.out, syn.csv.as_bytes())?;
    write_atomically(&triggers, syn.triggers_csv.as_bytes())?;
    let json = serde_json::to_string_pretty(&syn.truth).expect("truth serialises");
    write_atomically(&truth, json.as_bytes())?;
    println!(
        "synthetic train of {} bogies, flats on {}, seed {}: wrote {}, {} and {}",
        a.bogies,
        syn.truth
            .flats
            .iter()
            .map(|f| format!("bogie {} {} (L0 {:.1} mm)", f.0, f.1.name(), f.6))
            .collect::<Vec<_>>()
            .join(", "),
        a.seed,
        a.out.display(),
        triggers.display(),
        truth.display()
    );
    Ok(())
}

/// Parses `KIND:KEY=VALUE,…` into an effect (numbers as numbers, anything else as a string).
fn parse_effect(text: &str) -> Result<crate::model::Effect> {
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

fn cmd_synth(a: &SynthArgs) -> Result<()> {
    let mut cal = load_calibration(a.calibration.as_deref())?;
    if !a.effects.is_empty() {
        let mut doc = cal.document().clone();
        for e in &a.effects {
            doc.effects.push(parse_effect(e)?);
        }
        cal = doc.check().context("the effects given with --effect")?;
    }
    if a.train {
        return cmd_synth_train(a, &cal);
    }
    let flat = flat_from_args(&a.flat)?.context("synth needs a flat (drop --no-flat)")?;
    let syn = identify::synth::synthesize(&cal, &flat, a.seed, !a.no_trigger)?;
    let truth_path = a
        .truth
        .clone()
        .unwrap_or_else(|| a.out.with_extension("truth.json"));
    write_atomically(&a.out, syn.csv.as_bytes())?;
    let json = serde_json::to_string_pretty(&syn.truth).expect("truth serialises");
    write_atomically(&truth_path, json.as_bytes())?;
    println!(
        "synthetic measurement of {} (L0 {:.1} mm){}, seed {}: wrote {} and {}",
        flat_title(Some(&flat)),
        syn.truth.l0_mm,
        if cal.effects.is_empty() {
            String::new()
        } else {
            format!(" with hidden effects {:?}", cal.effects)
        },
        a.seed,
        a.out.display(),
        truth_path.display()
    );
    Ok(())
}

/// Opens the bank and the identification settings, reads the measurement.
fn open_identifier(a: &MeasuredArgs) -> Result<(Identifier, Measurement)> {
    let bank = bank::Bank::open(&a.bank)
        .with_context(|| format!("cannot open bank {}", a.bank.display()))?;
    let settings = match &a.calibration {
        Some(p) => load_calibration(Some(p))?.identification.clone(),
        None => bank.metadata().calibration.identification.clone(),
    };
    let rate = bank.metadata().sensors[0].sample_rate_hz;
    let text = std::fs::read_to_string(&a.measured)
        .with_context(|| format!("cannot read measurement {}", a.measured.display()))?;
    let m = Measurement::from_csv(&a.measured, &text, rate)?;
    Ok((Identifier::new(bank, settings)?, m))
}

fn range_text(
    r: &Option<crate::identify::result::ParamRanges>,
    f: fn(&crate::identify::result::ParamRanges) -> [f64; 2],
    digits: usize,
) -> String {
    match r {
        Some(r) => {
            let [lo, hi] = f(r);
            format!("[{lo:.digits$}, {hi:.digits$}]")
        }
        None => "—".into(),
    }
}

/// The paper-style comparison table of an identification.
pub fn comparison_table(id: &Identification, truth: Option<&identify::synth::Truth>) -> String {
    let mut s = format!(
        "{:<34} {:>6} {:>7}  {:<16} {:<16} {:<14}\n",
        "method", "points", "CMS", "L0 (mm)", "L (mm)", "d (mm)"
    );
    for f in &id.falsifications {
        s += &format!(
            "{:<34} {:>6} {:>7}  {:<16} {:<16} {:<14}\n",
            f.method,
            f.points,
            f.cms_count,
            range_text(&f.ranges, |r| r.l0_mm, 0),
            range_text(&f.ranges, |r| r.length_mm, 0),
            range_text(&f.ranges, |r| r.depth_mm, 2)
        );
    }
    let rm = &id.residual_minimisation;
    s += &format!(
        "{:<34} {:>6} {:>7}  {:<16} {:<16} {:<14}\n",
        "residual minimisation (no unc.)",
        id.eip.len(),
        1,
        format!("{:.0}", rm.l0_mm),
        format!("{:.0}", rm.length_mm),
        format!("{:.2}", rm.depth_mm)
    );
    if let Some(rs) = &id.random_subsets {
        s += &format!(
            "random subsets: {} draws of {} PIPs, CMS mean {:.1}, median {:.1}\n",
            rs.subsets, rs.size, rs.mean, rs.median
        );
    }
    if let Some(t) = truth {
        s += &format!(
            "truth: L0 {:.1} mm, L {:.1} mm, d {:.3} mm, X_p {:.3} m\n",
            t.l0_mm, t.length_mm, t.depth_mm, t.impact_position_m
        );
        for f in &id.falsifications {
            if let Some(r) = &f.ranges {
                let inside = |x: f64, [lo, hi]: [f64; 2]| lo <= x && x <= hi;
                let ok = inside(t.length_mm, r.length_mm) && inside(t.depth_mm, r.depth_mm);
                s += &format!(
                    "  {:<32} truth (L, d) inside its ranges: {}\n",
                    f.method,
                    if ok { "yes" } else { "NO" }
                );
            }
        }
    }
    s
}

fn print_identification(id: &Identification) {
    println!("{}", id.summary);
    println!("{}", id.maintenance_hint);
    println!(
        "alignment: {} (bank time = file time {:+.4} s{}); {} EIP of {} PIPs; per-point probability {:.5}",
        id.alignment.method,
        id.alignment.shift_s,
        id.alignment.correlation.map(|c| format!(", correlation {c:.4}")).unwrap_or_default(),
        id.eip.len(),
        id.candidates.len(),
        id.per_point_probability
    );
    let t: Vec<String> = id
        .timings_ms
        .iter()
        .map(|(n, ms)| format!("{n} {ms:.1} ms"))
        .collect();
    println!("timings: {}", t.join(", "));
}

fn cmd_identify(a: &IdentifyArgs) -> Result<()> {
    let (identifier, m) = open_identifier(&a.input)?;
    let extras = Extras {
        baselines: !a.no_baselines,
        curves: !a.no_baselines,
    };
    let id = identifier.identify(&m, a.input.sensors.as_deref(), extras)?;
    report_identification(&id, &a.out, None)
}

/// Writes an identification's report into `dir` and prints its summary and comparison table.
fn report_identification(
    id: &Identification,
    dir: &Path,
    truth: Option<&identify::synth::Truth>,
) -> Result<()> {
    let files = crate::report::identify::write_identification_report(id, dir)
        .with_context(|| format!("cannot write the report in {}", dir.display()))?;
    print_identification(id);
    print!("{}", comparison_table(id, truth));
    println!(
        "wrote {} and {} ({} figures)",
        files.json.display(),
        files.html.display(),
        files.figures.len()
    );
    Ok(())
}

fn cmd_diagnose(a: &DiagnoseArgs) -> Result<()> {
    let (identifier, m) = open_identifier(&a.input)?;
    let sensors = a.input.sensors.as_deref();
    let extras = Extras::NONE;
    let id = identifier.identify(&m, sensors, extras)?;
    eprintln!(
        "identified: {} of {} instances kept; diagnosing (fits by re-simulation, a minute at most)",
        id.cms.len(),
        id.bank_instances
    );
    let opts = crate::diagnose::Options {
        local_instances: a.local_instances,
        local_bank_dir: (!a.no_local_bank).then(|| a.out.join("local-bank")),
        ..Default::default()
    };
    let progress = Progress::new().with_terminal();
    let d = crate::diagnose::diagnose(&identifier, &m, sensors, &id, &opts, &progress)?;
    let times: Vec<(String, f64, f64)> = id
        .series
        .iter()
        .map(|s| (s.sensor.clone(), s.t0_s, s.sample_rate_hz))
        .collect();
    let files = crate::report::diagnose::write_diagnosis_report(&d, &times, &a.out)?;
    println!("{}", d.verdict);
    let stage = |name: &str, s: &crate::diagnose::Stage| {
        println!(
            "{name:<7} {:>5} of {} samples outside, gap RMS {:.3} kN, residual RMS {:.2} kN, CMS {}, L0 {}",
            s.samples_outside,
            s.samples,
            s.gap_rms_kn,
            s.rms_residual_kn,
            s.cms,
            s.l0_mm
                .map_or("— (empty)".into(), |[a, b]| format!("[{a:.1}, {b:.1}] mm"))
        );
    };
    stage("before", &d.before_stage);
    if let Some(added) = &d.added {
        stage("after", &added.after_stage);
    }
    if let Some(n) = &d.naming {
        println!("ranking ({}):", n.criterion);
        let best = n.ranking.first().map_or(n.no_effect.bic, |c| c.bic);
        for c in n
            .ranking
            .iter()
            .chain(std::iter::once(&n.no_effect))
            .take(8)
        {
            println!(
                "  {:<20} {:<34} ΔBIC {:>10.1}  z {:>7.1}",
                c.kind,
                c.location,
                c.bic - best,
                c.chi2_z
            );
        }
    }
    println!(
        "wrote {}, {} and {}{}",
        files.json.display(),
        files.html.display(),
        files.figure.display(),
        files
            .calibration
            .map_or(String::new(), |p| format!(", {}", p.display()))
    );
    Ok(())
}

fn cmd_compare(a: &CompareArgs) -> Result<()> {
    let (identifier, m) = open_identifier(&a.input)?;
    let truth = match &a.truth {
        Some(p) => {
            let text = std::fs::read_to_string(p)
                .with_context(|| format!("cannot read truth {}", p.display()))?;
            Some(
                serde_json::from_str::<identify::synth::Truth>(&text)
                    .with_context(|| format!("in truth file {}", p.display()))?,
            )
        }
        None => None,
    };
    let id = identifier.identify(
        &m,
        a.input.sensors.as_deref(),
        Extras {
            baselines: true,
            curves: false,
        },
    )?;
    print!("{}", comparison_table(&id, truth.as_ref()));
    Ok(())
}
