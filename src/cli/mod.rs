//! The `wheelflat` command line: a thin layer that parses arguments, reads and writes files,
//! and calls the library. Errors carry context naming the file and value (anyhow).

use crate::model::{Calibration, CheckedCalibration, Flat, Record, Response, Simulator};
use crate::report::plot::{draw_pad_forces, PadForcePlot, Series};
use anyhow::{Context, Result};
use clap::{Args, Parser, Subcommand};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
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
    },
    /// Simulate one train pass over the sensors and write the rail-pad forces.
    Simulate(SimulateArgs),
    /// Run the main job on built-in defaults and write its outputs to a folder.
    Demo {
        /// Output folder.
        #[arg(long, default_value = "wheelflat-demo")]
        out: PathBuf,
    },
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
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Calibration { out } => cmd_calibration(out.as_deref()),
        Command::Simulate(args) => cmd_simulate(&args),
        Command::Demo { out } => cmd_demo(&out),
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

/// Writes `bytes` to `path` through a temporary file in the same folder and a rename, so that a
/// reader never sees a half-written file.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .with_context(|| format!("{} is not a file path", path.display()))?;
    let tmp = dir.join(format!(
        ".{}.tmp-{}",
        name.to_string_lossy(),
        std::process::id()
    ));
    let result = (|| -> std::io::Result<()> {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result.with_context(|| format!("cannot write {}", path.display()))
}

fn cmd_calibration(out: Option<&Path>) -> Result<()> {
    let text = Calibration::default().to_toml_string();
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

fn cmd_demo(out: &Path) -> Result<()> {
    std::fs::create_dir_all(out)
        .with_context(|| format!("cannot create output folder {}", out.display()))?;
    let cal = load_calibration(None)?;
    let sim = Simulator::new(&cal)?;
    println!(
        "wheelflat demo: built-in calibration (MODEL.md defaults), outputs in {}",
        out.display()
    );
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
    Ok(())
}
