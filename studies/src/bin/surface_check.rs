//! The simulator's surfaces against the independent implementation (docs/model.md §5b):
//! `cargo run --release -p wheelflat-studies --bin surface_check -- PASSES_DIR [NAME…]`.
//!
//! For each disclosed pass with a `profile.csv` (rough-good1/2, rough-flat1/2, polygon-good1),
//! simulates the same profile on the same wheel at the converged reference's mesh and step with
//! each contact-filter variant (none, patch, rolling circle, both) and compares with the
//! pass's `noise-free.csv`: the largest and the rms difference of the pad forces (all five
//! sensors) and of the rough wheel's contact force, over the samples both cover. The smooth
//! wheel (no surface) is the first row: how much the surface itself moves the forces.
use std::path::Path;
use wheelflat::model::surface::parse_trace;
use wheelflat::model::{
    Calibration, ContactFilter, Record, Response, Simulator, Surfaces, WheelPosition, WheelSurface,
};

struct Reference {
    t0: f64,
    rate: f64,
    pads: Vec<Vec<f64>>,
    contact: [Vec<f64>; 2],
}

fn read_reference(path: &Path) -> Reference {
    let text = std::fs::read_to_string(path).expect("noise-free.csv");
    let mut rows: Vec<Vec<f64>> = Vec::new();
    for line in text.lines() {
        if line.starts_with('#') || line.starts_with("time_s") {
            continue;
        }
        rows.push(line.split(',').map(|c| c.parse().unwrap()).collect());
    }
    let col = |j: usize| rows.iter().map(|r| r[j]).collect::<Vec<f64>>();
    Reference {
        t0: rows[0][0],
        rate: 1.0 / (rows[1][0] - rows[0][0]),
        pads: (1..=5).map(col).collect(),
        contact: [col(6), col(7)],
    }
}

/// (max |Δ| pads, rms Δ pads, max |Δ| contact of `wheel`, rms Δ contact) in kN.
fn compare(r: &Response, reference: &Reference, wheel: usize) -> [f64; 4] {
    let (mut pmax, mut pss, mut pn) = (0.0f64, 0.0, 0usize);
    let (mut cmax, mut css, mut cn) = (0.0f64, 0.0, 0usize);
    let contact = r.contact_force_n.as_ref().expect("contact recorded");
    for (j, &c) in contact[wheel].iter().enumerate().take(r.len()) {
        let t = r.time_s(j);
        let k = ((t - reference.t0) * reference.rate).round() as usize;
        if k >= reference.pads[0].len() {
            break;
        }
        for s in 0..5 {
            let d = r.pad_force_n[s][j] / 1e3 - reference.pads[s][k];
            pmax = pmax.max(d.abs());
            pss += d * d;
            pn += 1;
        }
        let d = c / 1e3 - reference.contact[wheel][k];
        cmax = cmax.max(d.abs());
        css += d * d;
        cn += 1;
    }
    [
        pmax,
        (pss / pn as f64).sqrt(),
        cmax,
        (css / cn as f64).sqrt(),
    ]
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let dir = Path::new(
        args.get(1)
            .expect("usage: surface_check PASSES_DIR [NAME…]"),
    );
    let names: Vec<String> = if args.len() > 2 {
        args[2..].to_vec()
    } else {
        [
            "rough-good1",
            "rough-good2",
            "rough-flat1",
            "rough-flat2",
            "polygon-good1",
        ]
        .map(String::from)
        .to_vec()
    };
    let mesh = std::env::var("MESH").unwrap_or_else(|_| "converged".into());
    let base = Calibration::default();
    let cal = match mesh.as_str() {
        "bank" => base,
        _ => base.converged_reference(),
    };
    let mut cal = cal;
    if let Ok(e) = std::env::var("ELEM") {
        cal.integration.elements_per_bay = e.parse().unwrap();
    }
    if let Ok(c) = std::env::var("COARSE") {
        cal.integration.coarse_steps_per_sample = c.parse().unwrap();
    }
    let cal = cal.check().expect("calibration");
    let sim = Simulator::new(&cal).expect("simulator");
    let variants = [
        ("smooth wheel", None),
        (
            "no filter",
            Some(ContactFilter {
                patch: false,
                rolling_circle: false,
            }),
        ),
        (
            "patch",
            Some(ContactFilter {
                patch: true,
                rolling_circle: false,
            }),
        ),
        (
            "rolling circle",
            Some(ContactFilter {
                patch: false,
                rolling_circle: true,
            }),
        ),
        ("patch + rolling circle", Some(ContactFilter::DEFAULT)),
    ];
    println!("mesh: {mesh}; differences from noise-free.csv in kN: pads max / rms (5 sensors), rough wheel's contact max / rms");
    for name in &names {
        let pass = dir.join(name);
        let text = std::fs::read_to_string(pass.join("profile.csv")).expect("profile.csv");
        let file = parse_trace("profile.csv", &text).expect("trace");
        let wheel = file.wheel.unwrap_or(WheelPosition::Trailing);
        let shift_mm: f64 = std::env::var("SHIFT_MM").map_or(0.0, |v| v.parse().unwrap());
        let trace = if std::env::var("REVERSE").is_ok() {
            let mut d = file.trace.deviation_m().to_vec();
            d.reverse();
            d.rotate_right(1);
            wheelflat::model::Trace::new("rev", file.trace.spacing_m(), d).unwrap()
        } else {
            file.trace.clone()
        };
        let surfaces = Surfaces {
            wheels: vec![WheelSurface {
                wheel,
                trace,
                touch_x_m: file.touch_x_m.expect("touch position") + shift_mm * 1e-3,
            }],
            rail: None,
        };
        let reference = read_reference(&pass.join("noise-free.csv"));
        println!(
            "{name}: {} wheel, trace rms {:.1} µm",
            wheel.name(),
            file.trace.rms_m() * 1e6
        );
        for (label, filter) in variants {
            let s = match filter {
                None => sim.clone(),
                Some(f) => sim.clone().with_surfaces(&surfaces, f).expect("surfaces"),
            };
            let started = std::time::Instant::now();
            let r = s.run(None, Record { contact: true }).expect("run");
            let d = compare(&r, &reference, wheel.index());
            println!(
                "  {label:<24} pads {:6.3} / {:6.3}   contact {:6.2} / {:6.3}   peak contact {:6.1} kN  ({:.1} s)",
                d[0],
                d[1],
                d[2],
                d[3],
                r.peak_contact_force_n[wheel.index()] / 1e3,
                started.elapsed().as_secs_f64()
            );
        }
    }
}
