//! Tests of the identification report: a hand-made identification written as a whole
//! report, the figures' labels, degenerate input, errors, and the agreement of `report.html`
//! with `identification.json`.

use super::*;
use crate::identify::answer::result::{ParamRanges, WheelRanges};
use crate::report::canvas::{escape_html, format_tick};
use crate::report::dir_entries;

mod sample;

use sample::{hull_of, identification as synthetic, SUMMARY};

/// The sample's sizing, to change.
fn sized(id: &mut Identification) -> &mut crate::identify::Sizing {
    id.sizing.as_mut().expect("the sample is sized")
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
    for method in [
        "EIP (joint entropy)",
        "equidistant points",
        "random PIP subsets (mean of 200)",
    ] {
        assert!(html.contains(method), "{method} missing");
    }
}

#[test]
fn report_with_random_subsets_has_six_figures() {
    check_report(&synthetic(), 6);
}

#[test]
fn a_result_without_a_detection_has_no_detection_figure() {
    // An identification.json written before detection existed draws the others.
    let mut id = synthetic();
    id.detection = None;
    check_report(&id, 5);
    let err = figure_svg(&id, Figure::Detection).unwrap_err();
    assert!(
        matches!(
            &err,
            ReportError::Unavailable {
                figure: Figure::Detection,
                ..
            }
        ),
        "{err:?}"
    );
}

/// A pass that was not sized (no flat detected): the report draws the series and the
/// detection, says the pass was not sized, and shows no figure of a sizing that did not happen
/// (no "0 of N instances", no α, no Šídák probability); the JSON keeps the form its readers
/// know (the sizing's fields empty) and reads back as not sized.
#[test]
fn a_pass_without_sizing_reports_none() {
    let mut id = synthetic();
    id.sizing = None;
    id.summary = "No flat detected.".into();
    let tmp = tempfile::tempdir().expect("tempdir");
    let files = write_identification_report(&id, tmp.path()).expect("write report");
    let names: Vec<String> = files
        .figures
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(
        names,
        ["series.png", "series.svg", "detection.png", "detection.svg"]
    );
    let html = fs::read_to_string(&files.html).expect("read html");
    assert!(html.contains("not sized"), "{html}");
    for placeholder in [
        "Šídák",
        "stop threshold",
        "of 50000 instances",
        "EIP (joint entropy)",
    ] {
        assert!(
            !html.contains(placeholder),
            "{placeholder} in a report without sizing"
        );
    }
    let json = fs::read_to_string(&files.json).expect("read json");
    let value: serde_json::Value = serde_json::from_str(&json).expect("parse json");
    assert_eq!(value["falsifications"], serde_json::json!([]));
    assert_eq!(value["alpha_bits"], 0.0);
    let back: Identification = serde_json::from_str(&json).expect("parse json");
    assert_eq!(back, id);
    for fig in [
        Figure::Entropy,
        Figure::JointEntropy,
        Figure::ParallelCoordinates,
    ] {
        assert!(matches!(
            figure_svg(&id, fig),
            Err(ReportError::Unavailable { .. })
        ));
    }
}

#[test]
fn report_without_random_subsets_has_five_figures() {
    let mut id = synthetic();
    sized(&mut id).random_subsets = None;
    check_report(&id, 5);
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
    let z = sized(&mut id);
    z.cms.clear();
    z.model_class_refuted = true;
    let svg = figure_svg(&id, Figure::ParallelCoordinates).expect("parallel");
    assert!(svg.contains("empty CMS: model class refuted"));
    let tmp = tempfile::tempdir().expect("tempdir");
    let files = write_identification_report(&id, tmp.path()).expect("write report");
    let html = fs::read_to_string(files.html).expect("read html");
    assert!(html.contains("verdict refuted"));
}

/// A refined answer (`identify --refine`) is shown under the result, escaped, and survives the
/// JSON round trip that `wheelflat report --from` relies on.
#[test]
fn a_refined_answer_is_shown_and_read_back() {
    let mut id = synthetic();
    id.refinement = Some(crate::identify::refine::Refinement {
        ranges: id.cms_ranges().cloned(),
        survivors: 7,
        simulations: 640,
        rounds: Vec::new(),
        stopped_early: false,
        time_ms: 1200.0,
        summary: "refined: 7 flats survive & L0 < 45 mm".into(),
        maintenance_hint: "refined verdict: inspect".into(),
        severity: None,
        cells: Vec::new(),
        landings_simulated: 8,
        landings_removed: 3,
        landings_settled: Some([true, false]),
        strategy: crate::identify::refine::RefineStrategy::Bounds,
        bounds_settled: Some(true),
        kept_l0_mm: Some([36.5, 41.0]),
    });
    let tmp = tempfile::tempdir().expect("tempdir");
    let files = write_identification_report(&id, tmp.path()).expect("write report");
    let html = fs::read_to_string(&files.html).expect("read html");
    assert!(html.contains("<h2>Refined</h2>"));
    assert!(html.contains("refined: 7 flats survive &amp; L0 &lt; 45 mm"));
    let back: Identification =
        serde_json::from_str(&fs::read_to_string(&files.json).expect("read json")).expect("json");
    assert_eq!(back.refinement, id.refinement);
    // Without one, the JSON has no `refinement` key (files written before it read the same).
    let plain = synthetic();
    let text = serde_json::to_string(&plain).expect("json");
    assert!(!text.contains("refinement"));
}

#[test]
fn degenerate_input_still_draws() {
    let mut id = synthetic();
    id.series.clear();
    id.bank_instances = 0;
    id.population.depth_mm = [1.0, 1.0];
    let z = sized(&mut id);
    z.candidates.clear();
    z.eip = vec![3, 99];
    z.entropy_curves.clear();
    if let Some(rs) = z.random_subsets.as_mut() {
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

/// Regression: the HTML recomputed the CMS ranges as the hull of the surviving
/// instances, while `identify` reports the union of their cells, so `report.html` disagreed
/// with `identification.json`. Here the two differ; the page must show the JSON's.
#[test]
fn html_shows_the_ranges_the_json_carries() {
    let mut id = synthetic();
    let z = sized(&mut id);
    let hull = hull_of(&z.cms).expect("a CMS");
    // The union of cells: each instance's cell reaches past it, so the ranges are wider.
    let widen = |[lo, hi]: [f64; 2], h: f64| [lo - h, hi + h];
    let cells = ParamRanges {
        length_mm: widen(hull.length_mm, 2.5),
        depth_mm: widen(hull.depth_mm, 0.021),
        curvature_mm: widen(hull.curvature_mm, 0.05),
        impact_position_m: widen(hull.impact_position_m, 0.07),
        l0_mm: widen(hull.l0_mm, 1.3),
        flat_wheels: hull.flat_wheels.clone(),
        impact: None,
    };
    z.falsifications[0].ranges = Some(cells.clone());
    z.wheel_ranges = vec![WheelRanges {
        wheel: crate::model::WheelPosition::Trailing,
        cms_count: z.cms.len(),
        ranges: cells,
    }];

    let tmp = tempfile::tempdir().expect("tempdir");
    let files = write_identification_report(&id, tmp.path()).expect("write report");
    let back: Identification =
        serde_json::from_str(&fs::read_to_string(&files.json).expect("read json"))
            .expect("parse json");
    let html = fs::read_to_string(&files.html).expect("read html");
    let json_ranges = back.cms_ranges().expect("the JSON carries the CMS ranges");
    assert_eq!(
        Some(json_ranges),
        back.sizing
            .as_ref()
            .and_then(|z| z.wheel_ranges.first())
            .map(|w| &w.ranges)
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

/// The report preview example (`examples/identify_preview.rs`) reads the sample identifications
/// from `examples/data/`: they must be these, serialised (`WHEELFLAT_WRITE_FIXTURES=1` writes
/// them again after the sample changes).
#[test]
fn the_preview_fixtures_are_the_sample() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/data");
    for (name, id) in [
        ("preview.json", synthetic()),
        ("preview-dense.json", sample::dense()),
    ] {
        let path = dir.join(name);
        if std::env::var_os("WHEELFLAT_WRITE_FIXTURES").is_some() {
            std::fs::create_dir_all(&dir).unwrap();
            std::fs::write(&path, serde_json::to_string(&id).unwrap()).unwrap();
        }
        let text = std::fs::read_to_string(&path).unwrap();
        let stored: Identification = serde_json::from_str(&text).unwrap();
        assert_eq!(stored, id, "{}", path.display());
    }
}
