//! `wheelflat simulate`: one pass over the sensors, written as CSV (and a figure).

use super::args::SimulateArgs;
use super::{load_calibration, write_file};
use anyhow::{Context, Result};
use std::path::Path;
use std::time::Instant;
use wheelflat::model::{CheckedCalibration, Record, Response, Simulator};
use wheelflat::report::response::{flat_title, plot_response, response_csv, response_summary};

/// Simulates, writes the CSV, prints the summary and the timing, draws the figure if asked.
pub(super) fn run(a: &SimulateArgs) -> Result<()> {
    let cal = load_calibration(a.calibration.as_deref())?;
    let flat = a.flat.flat()?;
    let spec = a.surfaces.spec()?;
    let started = Instant::now();
    let mut sim = Simulator::new(&cal)?;
    let mut notes = Vec::new();
    if !spec.is_empty() {
        let (surfaces, n) = spec
            .build(cal.vehicle.wheel_radius_m, cal.rail_length_m())
            .context("the surfaces asked for")?;
        sim = sim.with_surfaces(&surfaces, spec.filter)?;
        notes = n;
    }
    let resp = sim.run(flat.as_ref(), Record { contact: a.contact })?;
    let elapsed = started.elapsed();
    write_file(&a.out, response_csv(&cal, &resp).as_bytes())?;
    println!("{}", flat_title(flat.as_ref()));
    for n in &notes {
        println!(
            "surface: {} — {} ({:.1} µm rms)",
            n.wheel.map_or("rail", |w| w.name()),
            n.source,
            n.rms_um
        );
    }
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
        draw(&cal, &resp, &flat_title(flat.as_ref()), p)?;
        println!("wrote {}", p.display());
    }
    Ok(())
}

/// [`plot_response`], naming the figure in the error.
pub(super) fn draw(cal: &CheckedCalibration, r: &Response, title: &str, path: &Path) -> Result<()> {
    plot_response(cal, r, title, path).with_context(|| format!("cannot draw {}", path.display()))
}
