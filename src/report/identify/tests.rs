//! Tests of the identification report: a hand-made identification written as a whole
//! report, the figures' labels, degenerate input, errors, and the agreement of `report.html`
//! with `identification.json`.

use super::html::cms_ranges;
use super::*;
use crate::identify::result::{
    Alignment, CandidatePoint, EntropyCurve, Falsification, InstanceParams, MeasuredSeries,
    ParamRanges, RandomSubsets, WheelRanges,
};
use crate::report::canvas::{escape_html, min_max};
use crate::report::dir_entries;

const RATE_HZ: f64 = 5000.0;
const SAMPLES: usize = 300;
const SUMMARY: &str = "The flat is L0 = 41–54 mm long (fresh-flat length < 60 mm & d < 1 mm); \
                       15 of 50000 instances remain \"candidate\" models.";

/// `v` rounded to 9 decimals. serde_json is built without its `float_roundtrip` feature,
/// so its parser may be one ulp off for 17-digit numbers; measured data with realistic
/// precision (≤ 15 significant digits) round-trips exactly.
fn q(v: f64) -> f64 {
    (v * 1e9).round() / 1e9
}

/// Smooth rail-pad pulses: a wheel passing (broad bump), the flat's impact (sharp peak
/// with a decaying ripple), and the second wheel.
fn pulse(t: f64, impact: f64) -> f64 {
    let g = |c: f64, w: f64| (-((t - c) / w).powi(2)).exp();
    let ripple = if t > impact {
        8.0 * (-(t - impact) / 0.004).exp()
            * (2.0 * std::f64::consts::PI * 450.0 * (t - impact)).sin()
    } else {
        0.0
    };
    q(4.0 + 55.0 * g(0.018, 0.006) + 70.0 * g(impact, 0.0012) + 45.0 * g(0.046, 0.006) + ripple)
}

fn instance(k: u32) -> InstanceParams {
    let f = f64::from(k);
    let depth = q(0.55 + 0.02 * (f * 1.7).sin().abs() + 0.01 * f / 15.0);
    InstanceParams {
        instance: 1000 + 313 * k,
        length_mm: q(48.0 + 6.0 * (f * 0.9).sin()),
        depth_mm: depth,
        curvature_mm: q(0.2 + 0.15 * (f * 2.3).cos().abs()),
        impact_position_m: q(0.9 + 0.35 * (f * 0.37).sin()),
        l0_mm: q((8.0 * depth * 400.0).sqrt()),
        flat_wheel: crate::model::WheelPosition::Trailing,
    }
}

/// Parameter ranges over a set of instances: their hull (none when empty). The report used
/// to show these for the CMS; the identification reports the union of cells, which is wider.
fn hull_of(instances: &[InstanceParams]) -> Option<ParamRanges> {
    let range =
        |f: fn(&InstanceParams) -> f64| min_max(instances.iter().map(f)).map(|(lo, hi)| [lo, hi]);
    Some(ParamRanges {
        length_mm: range(|p| p.length_mm)?,
        depth_mm: range(|p| p.depth_mm)?,
        curvature_mm: range(|p| p.curvature_mm)?,
        impact_position_m: range(|p| p.impact_position_m)?,
        l0_mm: range(|p| p.l0_mm)?,
        flat_wheels: {
            let mut w: Vec<_> = instances.iter().map(|p| p.flat_wheel).collect();
            w.sort_by_key(|w| w.index());
            w.dedup();
            w
        },
    })
}

/// A realistic hand-made identification: 2 series of 300 samples, 20 PIP, 6 EIP,
/// 15 CMS instances, 200 random subsets.
fn synthetic() -> Identification {
    let impacts = [0.0265, 0.0305];
    let series: Vec<MeasuredSeries> = ["rps1", "rps2"]
        .iter()
        .zip(impacts)
        .map(|(name, impact)| MeasuredSeries {
            sensor: (*name).to_string(),
            t0_s: 0.0,
            sample_rate_hz: RATE_HZ,
            values_kn: (0..SAMPLES)
                .map(|i| pulse(i as f64 / RATE_HZ, impact))
                .collect(),
        })
        .collect();
    // 10 PIP per series, in PIP order: the end points, then the peaks and the ripple.
    let pip_samples = [0, 299, 132, 90, 230, 150, 141, 160, 60, 200];
    let mut candidates = Vec::new();
    for (s, ser) in series.iter().enumerate() {
        for (order, &i) in pip_samples.iter().enumerate() {
            let i = if s == 1 && i > 0 && i < 299 {
                i + 20
            } else {
                i
            };
            let t = q(i as f64 / RATE_HZ);
            let entropy = if order < 2 {
                0.0
            } else {
                q(1.5 + 3.0 * ((order as f64) * 0.7 + s as f64).sin().abs())
            };
            candidates.push(CandidatePoint {
                series: s,
                sample: i,
                time_s: t,
                measured_kn: ser.values_kn[i],
                pip_order: order,
                entropy_bits: entropy,
                threshold_low_kn: q(-9.0 - 0.04 * ser.values_kn[i]),
                threshold_high_kn: q(7.0 + 0.03 * ser.values_kn[i]),
                resolution_kn: q(0.4 + 0.01 * ser.values_kn[i]),
            });
        }
    }
    let eip = vec![16, 5, 14, 6, 12, 7];
    let curve = |n: usize, cap: f64, rate: f64| -> Vec<f64> {
        (1..=n)
            .map(|k| q(cap * (1.0 - (-(k as f64) / rate).exp())))
            .collect()
    };
    let cms: Vec<InstanceParams> = (0..15).map(instance).collect();
    let counts: Vec<usize> = (0..200u64)
        .map(|k| {
            // A skewed, deterministic spread around 180.
            let u = ((k * 7919 + 13) % 200) as f64 / 200.0;
            (20.0 + 420.0 * u * u + 60.0 * u) as usize
        })
        .collect();
    let mean = q(counts.iter().sum::<usize>() as f64 / counts.len() as f64);
    let mut sorted = counts.clone();
    sorted.sort_unstable();
    let median = 0.5 * (sorted[99] + sorted[100]) as f64;
    let population = ParamRanges {
        length_mm: [20.0, 120.0],
        depth_mm: [0.1, 2.0],
        curvature_mm: [0.0, 1.0],
        impact_position_m: [0.0, 3.0],
        l0_mm: [
            q((8.0f64 * 0.1 * 400.0).sqrt()),
            q((8.0f64 * 2.0 * 400.0).sqrt()),
        ],
        flat_wheels: vec![crate::model::WheelPosition::Trailing],
    };
    Identification {
        measurement: "measurements/2019-03-14_train7_axle3.parquet".into(),
        bank_id: "bank-50000-4b1e".into(),
        bank_instances: 50_000,
        population,
        alignment: Alignment {
            method: "cross-correlation".into(),
            shift_s: 0.01234,
            correlation: Some(0.987),
        },
        series,
        pip_distance: "vertical".into(),
        pips_per_series: 10,
        candidates,
        eip,
        eip_joint_entropy_bits: vec![4.4, 7.1, 9.0, 10.3, 11.1, 11.6],
        alpha_bits: 0.05,
        entropy_curves: vec![
            EntropyCurve {
                label: "rps1".into(),
                joint_entropy_bits: curve(10, 7.7, 2.5),
            },
            EntropyCurve {
                label: "rps2".into(),
                joint_entropy_bits: curve(10, 11.2, 2.8),
            },
            EntropyCurve {
                label: "rps1+rps2".into(),
                joint_entropy_bits: curve(20, 12.2, 2.6),
            },
        ],
        phi: 0.95,
        per_point_probability: q(0.95f64.powf(1.0 / 6.0)),
        cms: cms.clone(),
        wheel_ranges: Vec::new(),
        falsifications: vec![
            Falsification {
                method: "EIP (joint entropy)".into(),
                points: 6,
                cms_count: 15,
                ranges: hull_of(&cms),
            },
            Falsification {
                method: "equidistant".into(),
                points: 6,
                cms_count: 412,
                ranges: Some(ParamRanges {
                    length_mm: [30.0, 90.0],
                    depth_mm: [0.3, 1.2],
                    curvature_mm: [0.0, 1.0],
                    impact_position_m: [0.0, 3.0],
                    l0_mm: [31.0, 62.0],
                    flat_wheels: vec![crate::model::WheelPosition::Trailing],
                }),
            },
            Falsification {
                method: "all PIP".into(),
                points: 20,
                cms_count: 0,
                ranges: None,
            },
        ],
        residual_minimisation: InstanceParams {
            instance: 4242,
            length_mm: 44.0,
            depth_mm: 0.52,
            curvature_mm: 0.31,
            impact_position_m: 1.1,
            l0_mm: q((8.0f64 * 0.52 * 400.0).sqrt()),
            flat_wheel: crate::model::WheelPosition::Trailing,
        },
        random_subsets: Some(RandomSubsets {
            subsets: 200,
            size: 6,
            cms_counts: counts,
            mean,
            median,
            seed: 7,
        }),
        model_class_refuted: false,
        summary: SUMMARY.into(),
        maintenance_hint: "Remove the wheelset from service within 24 h (GM/RT2466: L0 > 50 mm)."
            .into(),
        timings_ms: vec![
            ("load".into(), 12.5),
            ("pip".into(), 0.8),
            ("entropy".into(), 310.2),
            ("falsify".into(), 95.0),
        ],
    }
}

/// Writes the report and checks the files, the JSON round trip and the HTML.
fn check_report(id: &Identification, svgs: usize) {
    let tmp = tempfile::tempdir().expect("tempdir");
    let dir = tmp.path().join("nested").join("report");
    let files = write_identification_report(id, &dir).expect("write report");

    assert_eq!(files.json, dir.join(JSON_FILE));
    assert_eq!(files.html, dir.join(HTML_FILE));
    assert_eq!(files.figures.len(), 2 * svgs);
    for path in files.figures.iter().chain([&files.json, &files.html]) {
        let len = fs::metadata(path).expect("file exists").len();
        assert!(len > 500, "{} only {len} bytes", path.display());
    }
    for png in files
        .figures
        .iter()
        .filter(|p| p.extension().is_some_and(|e| e == "png"))
    {
        let bytes = fs::read(png).expect("read png");
        assert!(
            bytes.starts_with(b"\x89PNG\r\n\x1a\n"),
            "{} not a PNG",
            png.display()
        );
    }
    let mut expected: Vec<String> = Figure::ALL
        .iter()
        .filter(|f| f.is_available(id))
        .flat_map(|f| [f.file_name("png"), f.file_name("svg")])
        .chain([JSON_FILE.to_string(), HTML_FILE.to_string()])
        .collect();
    expected.sort();
    assert_eq!(dir_entries(&dir), expected, "unexpected or temporary files");

    let json = fs::read_to_string(&files.json).expect("read json");
    let back: Identification = serde_json::from_str(&json).expect("parse json");
    assert!(&back == id, "the JSON does not round-trip");
    assert_eq!(
        serde_json::to_string_pretty(&back).expect("serialise"),
        json
    );

    let html = fs::read_to_string(&files.html).expect("read html");
    assert_eq!(html.matches("<svg").count(), svgs);
    assert_eq!(html.matches("</svg>").count(), svgs);
    assert!(
        html.contains(&escape_html(SUMMARY)),
        "escaped summary missing"
    );
    assert!(html.contains("fresh-flat length &lt; 60 mm &amp; d &lt; 1 mm"));
    assert!(!html.contains(SUMMARY), "summary inserted unescaped");
    assert!(
        !html.contains("http"),
        "the report links an external resource"
    );
    assert!(!html.contains("<script"));
    assert!(!html.contains("<?xml"));
    for method in ["EIP (joint entropy)", "equidistant", "all PIP"] {
        assert!(html.contains(method), "{method} missing");
    }
}

#[test]
fn report_with_random_subsets_has_five_figures() {
    check_report(&synthetic(), 5);
}

#[test]
fn report_without_random_subsets_has_four_figures() {
    let mut id = synthetic();
    id.random_subsets = None;
    check_report(&id, 4);
    let err = figure_svg(&id, Figure::RandomSubsets).unwrap_err();
    assert!(
        matches!(&err, ReportError::Unavailable { path, figure: Figure::RandomSubsets }
            if path == Path::new("random_subsets.svg")),
        "{err:?}"
    );
}

#[test]
fn figures_carry_their_labels() {
    let id = synthetic();
    let series = figure_svg(&id, Figure::Series).expect("series");
    for text in ["(a) rps1", "(b) rps2", "time (s)", "force (kN)", "PIP"] {
        assert!(series.contains(text), "series figure lacks {text}");
    }
    let entropy = figure_svg(&id, Figure::Entropy).expect("entropy");
    assert!(entropy.contains("PIP index") && entropy.contains("entropy (bits)"));
    let joint = figure_svg(&id, Figure::JointEntropy).expect("joint entropy");
    assert!(joint.contains("log2 N") && joint.contains("rps1+rps2"));
    let parallel = figure_svg(&id, Figure::ParallelCoordinates).expect("parallel");
    for text in [
        "L (mm)", "d (mm)", "c (mm)", "X_p (m)", "L0 (mm)", "120", "20",
    ] {
        assert!(parallel.contains(text), "parallel coordinates lack {text}");
    }
    assert!(!parallel.contains("model class refuted"));
    let random = figure_svg(&id, Figure::RandomSubsets).expect("random subsets");
    assert!(random.contains("CMS size (instances)"));
}

#[test]
fn empty_cms_says_the_model_class_is_refuted() {
    let mut id = synthetic();
    id.cms.clear();
    id.model_class_refuted = true;
    let svg = figure_svg(&id, Figure::ParallelCoordinates).expect("parallel");
    assert!(svg.contains("empty CMS: model class refuted"));
    let tmp = tempfile::tempdir().expect("tempdir");
    let files = write_identification_report(&id, tmp.path()).expect("write report");
    let html = fs::read_to_string(files.html).expect("read html");
    assert!(html.contains("verdict refuted"));
}

#[test]
fn degenerate_input_still_draws() {
    let mut id = synthetic();
    id.series.clear();
    id.candidates.clear();
    id.eip = vec![3, 99];
    id.entropy_curves.clear();
    id.bank_instances = 0;
    id.population.depth_mm = [1.0, 1.0];
    if let Some(rs) = id.random_subsets.as_mut() {
        rs.cms_counts.clear();
        rs.mean = f64::NAN;
    }
    for fig in Figure::ALL {
        let svg = figure_svg(&id, fig).expect("figure");
        assert!(svg.starts_with("<svg"));
    }
}

#[test]
fn io_errors_name_the_path() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let file = tmp.path().join("not_a_dir");
    fs::write(&file, b"x").expect("write");
    let err = write_identification_report(&synthetic(), &file.join("report")).unwrap_err();
    assert!(
        matches!(&err, ReportError::Io { path, .. } if path.starts_with(&file)),
        "{err:?}"
    );
    assert!(err.to_string().contains("not_a_dir"));
}

#[test]
fn helpers() {
    assert_eq!(fmt_num(-0.0001, 2), "0.00");
    assert_eq!(fmt_num(f64::NAN, 2), "–");
    assert_eq!(fmt_range([41.04, 54.0], 1), "41.0 – 54.0");
    assert_eq!(format_tick(0.0150), "0.015");
    assert_eq!(format_tick(-0.0), "0");
    assert_eq!(fmt_axis(2.0, 1.9), "2");
    assert_eq!(fmt_axis(17.888, 62.1), "17.9");
    assert_eq!(fmt_axis(120.0, 100.0), "120");
}

/// Regression (issue 16): the HTML recomputed the CMS ranges as the hull of the surviving
/// instances, while `identify` reports the union of their cells, so `report.html` disagreed
/// with `identification.json`. Here the two differ; the page must show the JSON's.
#[test]
fn html_shows_the_ranges_the_json_carries() {
    let mut id = synthetic();
    let hull = hull_of(&id.cms).expect("a CMS");
    // The union of cells: each instance's cell reaches past it, so the ranges are wider.
    let widen = |[lo, hi]: [f64; 2], h: f64| [lo - h, hi + h];
    let cells = ParamRanges {
        length_mm: widen(hull.length_mm, 2.5),
        depth_mm: widen(hull.depth_mm, 0.021),
        curvature_mm: widen(hull.curvature_mm, 0.05),
        impact_position_m: widen(hull.impact_position_m, 0.07),
        l0_mm: widen(hull.l0_mm, 1.3),
        flat_wheels: hull.flat_wheels.clone(),
    };
    id.falsifications[0].ranges = Some(cells.clone());
    id.wheel_ranges = vec![WheelRanges {
        wheel: crate::model::WheelPosition::Trailing,
        cms_count: id.cms.len(),
        ranges: cells,
    }];

    let tmp = tempfile::tempdir().expect("tempdir");
    let files = write_identification_report(&id, tmp.path()).expect("write report");
    let back: Identification =
        serde_json::from_str(&fs::read_to_string(&files.json).expect("read json"))
            .expect("parse json");
    let html = fs::read_to_string(&files.html).expect("read html");
    let json_ranges = cms_ranges(&back).expect("the JSON carries the CMS ranges");
    assert_eq!(
        Some(json_ranges),
        back.wheel_ranges.first().map(|w| &w.ranges)
    );
    let row = |name: &str, range: [f64; 2], decimals: usize, unit: &str| {
        format!(
            "<tr><th>{name}</th><td>{} {unit}</td></tr>",
            fmt_range(range, decimals)
        )
    };
    for (name, json, hull, decimals, unit) in [
        (
            "Fresh-flat length L0",
            json_ranges.l0_mm,
            hull.l0_mm,
            1,
            "mm",
        ),
        (
            "Flat length L",
            json_ranges.length_mm,
            hull.length_mm,
            1,
            "mm",
        ),
        ("Flat depth d", json_ranges.depth_mm, hull.depth_mm, 3, "mm"),
        (
            "Curvature c",
            json_ranges.curvature_mm,
            hull.curvature_mm,
            3,
            "mm",
        ),
        (
            "Impact position X_p",
            json_ranges.impact_position_m,
            hull.impact_position_m,
            3,
            "m",
        ),
    ] {
        let shown = row(name, json, decimals, unit);
        assert!(html.contains(&shown), "{shown} missing from the HTML");
        let recomputed = row(name, hull, decimals, unit);
        assert!(
            !html.contains(&recomputed),
            "the HTML shows the hull of the instances: {recomputed}"
        );
    }
}
