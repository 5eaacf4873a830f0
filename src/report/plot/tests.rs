//! Tests of the pad-force plots.
use super::*;
use crate::report::dir_entries;
use std::fs;

const N: usize = 200;

/// Synthetic pad forces: each sensor sees a sine-shaped bump as the wheels pass,
/// shifted by sensor, plus a small ripple.
fn synthetic() -> (Vec<f64>, Vec<Vec<f64>>, [Vec<f64>; 2]) {
    let time: Vec<f64> = (0..N).map(|i| i as f64 * 0.01).collect();
    let pads = (0..5)
        .map(|k| {
            time.iter()
                .map(|&t| {
                    let phase = (t - 0.2 * k as f64) * std::f64::consts::PI / 0.6;
                    let bump = if (0.0..std::f64::consts::PI).contains(&phase) {
                        40.0 * phase.sin()
                    } else {
                        0.0
                    };
                    bump + 2.0 * (40.0 * t).sin()
                })
                .collect()
        })
        .collect();
    let leading = time
        .iter()
        .map(|&t| 80.0 + 10.0 * (30.0 * t).sin())
        .collect();
    let trailing = time
        .iter()
        .map(|&t| 78.0 + 8.0 * (30.0 * t + 1.0).sin())
        .collect();
    (time, pads, [leading, trailing])
}

const LABELS: [&str; 5] = ["rps1", "rps2", "rps3", "rps4", "rps5"];
const STRIKES: [f64; 4] = [0.35, 0.95, 1.55, 5.0];

fn plot<'a>(
    time: &'a [f64],
    pads: &'a [Vec<f64>],
    contact: Option<&'a [Vec<f64>; 2]>,
) -> PadForcePlot<'a> {
    PadForcePlot {
        title: "Rail-pad forces, 20 mm flat at 100 km/h",
        time_s: time,
        series: pads
            .iter()
            .zip(LABELS)
            .map(|(v, label)| Series {
                label,
                values_kn: v,
            })
            .collect(),
        strike_times_s: &STRIKES,
        contact_kn: contact.map(|[a, b]| [a.as_slice(), b.as_slice()]),
    }
}

#[test]
fn png_is_written_atomically() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (time, pads, _) = synthetic();
    let path = dir.path().join("pads.png");
    draw_pad_forces(&plot(&time, &pads, None), &path).expect("draw png");
    let bytes = fs::read(&path).expect("read png");
    assert!(bytes.starts_with(b"\x89PNG\r\n\x1a\n"), "not a PNG");
    assert!(bytes.len() > 10_000, "PNG only {} bytes", bytes.len());
    assert_eq!(
        dir_entries(dir.path()),
        ["pads.png"],
        "temporary left behind"
    );
}

#[test]
fn png_with_contact_panel_is_taller() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (time, pads, contact) = synthetic();
    let path = dir.path().join("pads_contact.PNG");
    draw_pad_forces(&plot(&time, &pads, Some(&contact)), &path).expect("draw png");
    let bytes = fs::read(&path).expect("read png");
    assert!(bytes.starts_with(b"\x89PNG\r\n\x1a\n"), "not a PNG");
    // IHDR: width and height are big-endian u32 at offsets 16 and 20.
    let be = |i: usize| u32::from_be_bytes([bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]]);
    assert_eq!((be(16), be(20)), SIZE_WITH_CONTACT);
    assert_eq!(dir_entries(dir.path()), ["pads_contact.PNG"]);
}

#[test]
fn svg_has_legend_labels() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (time, pads, contact) = synthetic();
    let path = dir.path().join("pads.svg");
    draw_pad_forces(&plot(&time, &pads, Some(&contact)), &path).expect("draw svg");
    let svg = fs::read_to_string(&path).expect("read svg");
    assert!(svg.contains("<svg"));
    for label in LABELS {
        assert!(svg.contains(label), "legend label {label} missing");
    }
    for text in [
        "flat strike",
        "leading wheel",
        "trailing wheel",
        "rail-pad force (kN)",
        "contact force (kN)",
        "time (s)",
    ] {
        assert!(svg.contains(text), "{text} missing");
    }
    assert_eq!(dir_entries(dir.path()), ["pads.svg"]);
}

#[test]
fn strikes_outside_the_time_range_are_not_drawn() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (time, pads, _) = synthetic();
    let path = dir.path().join("pads.svg");
    let mut p = plot(&time, &pads, None);
    p.strike_times_s = &[-1.0, 5.0, f64::NAN];
    draw_pad_forces(&p, &path).expect("draw svg");
    let svg = fs::read_to_string(&path).expect("read svg");
    assert!(!svg.contains("flat strike"));
}

#[test]
fn unknown_extension_writes_nothing() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (time, pads, _) = synthetic();
    for name in ["pads.pdf", "pads"] {
        let path = dir.path().join(name);
        let err = draw_pad_forces(&plot(&time, &pads, None), &path).unwrap_err();
        assert!(
            matches!(&err, PlotError::UnsupportedExtension { path: p } if *p == path),
            "{err:?}"
        );
    }
    assert!(dir_entries(dir.path()).is_empty());
}

#[test]
fn mismatched_lengths_are_rejected_and_write_nothing() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (time, pads, contact) = synthetic();
    let path = dir.path().join("pads.png");
    let short = &contact[1][..N - 1];
    let mut p = plot(&time, &pads, None);
    p.contact_kn = Some([&contact[0], short]);
    let err = draw_pad_forces(&p, &path).unwrap_err();
    assert!(matches!(err, PlotError::InvalidData { .. }), "{err:?}");
    let p = plot(&[], &[], None);
    let err = draw_pad_forces(&p, &path).unwrap_err();
    assert!(matches!(err, PlotError::InvalidData { .. }), "{err:?}");
    assert!(dir_entries(dir.path()).is_empty());
}

#[test]
fn missing_directory_is_an_error_without_leftovers() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (time, pads, _) = synthetic();
    let path = dir.path().join("no_such_dir").join("pads.svg");
    let err = draw_pad_forces(&plot(&time, &pads, None), &path).unwrap_err();
    assert!(matches!(err, PlotError::Io { .. }), "{err:?}");
    assert!(dir_entries(dir.path()).is_empty());
}

#[test]
fn force_range_starts_at_zero_and_pads_the_top() {
    let a = [5.0, 10.0, f64::NAN];
    let (lo, hi) = force_range([a.as_slice()].into_iter());
    assert!(lo.abs() < 1e-12 && (hi - 11.0).abs() < 1e-12);
    let b = [-3.0, 10.0];
    let (lo, _) = force_range([b.as_slice()].into_iter());
    assert!((lo + 3.0).abs() < 1e-12);
    let (lo, hi) = force_range(std::iter::empty());
    assert!(hi > lo);
}
