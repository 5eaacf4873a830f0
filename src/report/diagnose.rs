//! The diagnosis report: `diagnosis.json`, the residual-against-thresholds figure per sensor
//! before (and after the effect is added), and `diagnosis.html` with the verdict, the ranking
//! of the effects and the numbers before and after.

use super::canvas::{
    escape_html as esc, min_max, msg, render_png, PlotError, FONT, GRID_LIGHT, TAB_BLUE, TAB_RED,
};
use crate::diagnose::{CandidateKind, Diagnosis, Located, SensorGap, Stage};
use crate::report::canvas::DrawResult;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Files written.
#[derive(Debug, Clone, PartialEq)]
pub struct DiagnosisFiles {
    /// `diagnosis.json`.
    pub json: PathBuf,
    /// `diagnosis.html`.
    pub html: PathBuf,
    /// `diagnosis-gap.png`.
    pub figure: PathBuf,
    /// `calibration-with-effect.toml`, when an effect was added.
    pub calibration: Option<PathBuf>,
}

/// Errors of the report.
#[derive(Debug, thiserror::Error)]
pub enum DiagnosisReportError {
    /// A file could not be written.
    #[error("cannot write {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The figure could not be drawn.
    #[error(transparent)]
    Plot(#[from] PlotError),
}

const RESIDUAL: RGBColor = TAB_BLUE;
const BAND: RGBColor = RGBColor(200, 200, 200);
const OUTSIDE: RGBColor = TAB_RED;

/// Draws one panel: a sensor's residual against its thresholds.
fn draw_gap_panel(
    area: &DrawingArea<BitMapBackend, Shift>,
    title: &str,
    g: &SensorGap,
    t0: f64,
    rate: f64,
) -> DrawResult {
    let n = g.residual_kn.len().max(2);
    let t = |k: usize| t0 + k as f64 / rate;
    let (lo, hi) = min_max(
        g.residual_kn
            .iter()
            .copied()
            .chain(g.thresholds_kn.iter().flatten().copied()),
    )
    .unwrap_or((-1.0, 1.0));
    let pad = 0.05 * (hi - lo).max(1.0);
    let mut chart = ChartBuilder::on(area)
        .caption(title, (FONT, 20))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(65)
        .build_cartesian_2d(t(0)..t(n - 1), (lo - pad)..(hi + pad))
        .map_err(msg)?;
    chart
        .configure_mesh()
        .x_desc("bank time (s)")
        .y_desc("prediction − measured (kN)")
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 15))
        .light_line_style(GRID_LIGHT)
        .draw()
        .map_err(msg)?;
    let upper: Vec<(f64, f64)> = (0..g.thresholds_kn.len())
        .map(|k| (t(k), g.thresholds_kn[k][1]))
        .collect();
    let lower: Vec<(f64, f64)> = (0..g.thresholds_kn.len())
        .rev()
        .map(|k| (t(k), g.thresholds_kn[k][0]))
        .collect();
    chart
        .draw_series(std::iter::once(Polygon::new(
            upper.into_iter().chain(lower).collect::<Vec<_>>(),
            BAND.mix(0.6).filled(),
        )))
        .map_err(msg)?
        .label("thresholds (Šídák over all samples, widened by the cell)")
        .legend(|(x, y)| Rectangle::new([(x, y - 5), (x + 20, y + 5)], BAND.filled()));
    chart
        .draw_series(std::iter::once(PathElement::new(
            (0..g.residual_kn.len())
                .map(|k| (t(k), g.residual_kn[k]))
                .collect::<Vec<_>>(),
            RESIDUAL.stroke_width(1),
        )))
        .map_err(msg)?
        .label("residual of the best instance")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RESIDUAL.stroke_width(2)));
    chart
        .draw_series(
            (0..g.residual_kn.len())
                .filter(|&k| {
                    let [a, b] = g.thresholds_kn[k];
                    g.residual_kn[k] < a || g.residual_kn[k] > b
                })
                .map(|k| Circle::new((t(k), g.residual_kn[k]), 2, OUTSIDE.filled())),
        )
        .map_err(msg)?
        .label("outside")
        .legend(|(x, y)| Circle::new((x + 10, y), 3, OUTSIDE.filled()));
    chart
        .configure_series_labels()
        .label_font((FONT, 13))
        .background_style(WHITE.mix(0.7))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperRight)
        .draw()
        .map_err(msg)
}

/// Draws the residual-against-thresholds figure: a row per sensor, the column before and,
/// when given, the column after the effect was added.
pub fn draw_gap(
    title: &str,
    before: &Located,
    after: Option<&Located>,
    series_time: &[(String, f64, f64)],
    path: &Path,
) -> Result<(), PlotError> {
    let rows = before.sensors.len().max(1);
    let cols = if after.is_some() { 2 } else { 1 };
    render_png(path, (800 * cols as u32, 80 + 300 * rows as u32), |root| {
        let root = root.titled(title, (FONT, 26)).map_err(msg)?;
        let areas = root.split_evenly((rows, cols));
        for (r, s) in before.sensors.iter().enumerate() {
            let (t0, rate) = series_time
                .iter()
                .find(|(n, _, _)| *n == s.sensor)
                .map_or((0.0, 1.0), |(_, t, r)| (*t, *r));
            let title = format!(
                "{} before: {} of {} outside, gap RMS {:.3} kN",
                s.sensor, s.samples_outside, s.samples, s.gap_rms_kn
            );
            draw_gap_panel(&areas[r * cols], &title, s, t0, rate)?;
            if let Some(a) = after {
                if let Some(sa) = a.sensors.iter().find(|x| x.sensor == s.sensor) {
                    let title = format!(
                        "{} after: {} of {} outside, gap RMS {:.3} kN",
                        sa.sensor, sa.samples_outside, sa.samples, sa.gap_rms_kn
                    );
                    draw_gap_panel(&areas[r * cols + 1], &title, sa, t0, rate)?;
                }
            }
        }
        Ok(())
    })
}

fn write(path: &Path, bytes: &[u8]) -> Result<(), DiagnosisReportError> {
    crate::atomic::write_atomically(path, bytes).map_err(|source| DiagnosisReportError::Io {
        path: path.to_path_buf(),
        source,
    })
}

fn range(r: Option<[f64; 2]>) -> String {
    r.map_or("— (empty)".into(), |[a, b]| format!("[{a:.1}, {b:.1}]"))
}

/// The before/after table rows (HTML).
fn stage_rows(before: &Stage, after: Option<&Stage>) -> String {
    let mut s = String::new();
    let row = |s: &mut String, name: &str, f: &dyn Fn(&Stage) -> String| {
        let _ = writeln!(
            s,
            "<tr><td>{name}</td><td>{}</td><td>{}</td></tr>",
            f(before),
            after.map_or("—".into(), f)
        );
    };
    row(&mut s, "bank", &|x| {
        format!("{} ({} instances)", x.bank_id, x.bank_instances)
    });
    row(&mut s, "samples outside the thresholds", &|x| {
        format!("{} of {}", x.samples_outside, x.samples)
    });
    row(&mut s, "gap RMS (excess over the thresholds, kN)", &|x| {
        format!("{:.3}", x.gap_rms_kn)
    });
    row(&mut s, "residual RMS of the best instance (kN)", &|x| {
        format!("{:.2}", x.rms_residual_kn)
    });
    row(&mut s, "candidate model set", &|x| x.cms.to_string());
    row(&mut s, "L0 range of the CMS (mm)", &|x| range(x.l0_mm));
    row(&mut s, "best instance, its L0 (mm)", &|x| {
        format!("{}, {:.1}", x.best_instance, x.best_l0_mm)
    });
    s
}

/// The HTML page.
pub fn html(d: &Diagnosis, figure: &str) -> String {
    let mut h = String::from(
        "<!doctype html><html><head><meta charset=\"utf-8\"><title>wheelflat diagnosis</title>\
         <style>body{font-family:sans-serif;max-width:1400px;margin:auto}table{border-collapse:collapse}\
         td,th{border:1px solid #ccc;padding:3px 8px;text-align:right}td:first-child,th:first-child{text-align:left}\
         .v{font-size:1.2em;padding:8px;background:#f4f4f4}</style></head><body>",
    );
    let _ = writeln!(h, "<h1>Diagnosis of {}</h1>", esc(&d.measurement));
    let _ = writeln!(h, "<p class=\"v\"><b>{}</b></p>", esc(&d.verdict));
    let _ = writeln!(h, "<h2>Before and after</h2><table><tr><th></th><th>before (bank without the effect)</th><th>after (local bank with the effect)</th></tr>");
    h += &stage_rows(&d.before_stage, d.added.as_ref().map(|a| &a.after_stage));
    h += "</table>";
    if let Some(a) = &d.added {
        let r = a.local_ranges;
        let _ = writeln!(
            h,
            "<p>Local bank <code>{}</code>: L [{:.1}, {:.1}] mm, d [{:.3}, {:.3}] mm, c [{:.3}, {:.3}] mm, X_p [{:.4}, {:.4}] m \
             (the fitted flat ± 1.5 cells of the original bank), the effect at its fitted parameters. \
             The calibration with the effect is <code>calibration-with-effect.toml</code>.</p>",
            esc(&a.local_bank), r[0][0], r[0][1], r[1][0], r[1][1], r[2][0], r[2][1], r[3][0], r[3][1]
        );
    }
    let _ = writeln!(h, "<h2>Where the model and the measurement disagree</h2><img src=\"{figure}\" style=\"max-width:100%\">");
    h += "<table><tr><th>sensor</th><th>outside</th><th>by chance</th><th>RMS residual (kN)</th><th>gap RMS (kN)</th><th>worst window (s)</th><th>bogie centre (m)</th><th>wheels at the worst sample (m)</th><th>largest excess (kN)</th></tr>";
    for s in &d.before.sensors {
        let w = s.windows.first();
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{:.2}</td><td>{:.2}</td><td>{:.3}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            s.sensor,
            s.samples_outside,
            s.expected_by_chance,
            s.rms_residual_kn,
            s.gap_rms_kn,
            w.map_or("—".into(), |w| format!("{:.4}–{:.4}", w.time_s[0], w.time_s[1])),
            w.map_or("—".into(), |w| format!("{:.2}–{:.2}", w.bogie_centre_m[0], w.bogie_centre_m[1])),
            w.map_or("—".into(), |w| format!("{:.2}, {:.2}", w.wheels_m[0], w.wheels_m[1])),
            w.map_or("—".into(), |w| format!("{:.2}", w.max_outside_kn)),
        );
    }
    h += "</table>";
    if let Some(e) = &d.noise {
        let _ = writeln!(
            h,
            "<h2>Noise from the record</h2><p>σ {} kN (the table's {:.3} kN), AR(1) lag-1 correlation ρ {:.3}, from {} high-passed samples of the flat-only fit's residual outside the flat's strikes; the fits use σ {:.3} kN and ρ {:.3}.</p>",
            e.sigma_estimated_kn.map_or("not estimated".to_string(), |v| format!("{v:.3}")),
            e.sigma_table_kn,
            e.rho,
            e.samples,
            e.sigma_used_kn,
            e.rho
        );
    }
    if let Some(n) = &d.naming {
        let _ = writeln!(
            h,
            "<h2>Ranking of the effects</h2><p>{}</p><p>{} simulations.</p>",
            esc(&n.criterion),
            n.simulations
        );
        if let Some(place) = &n.place {
            let _ = writeln!(h, "<p>Place of the best: {}.</p>", esc(place));
        }
        if let Some([lo, hi]) = n.second_flat_l0_mm {
            let _ = writeln!(h, "<p>Second flat: L0 {lo:.1}–{hi:.1} mm.</p>");
        }
        h += "<table><tr><th>effect</th><th>where</th><th>parameters (± 1 sd)</th><th>χ²</th><th>z</th><th>BIC</th><th>ΔBIC to the best</th><th>flat L, d, c, X_p</th><th>flat refitted</th></tr>";
        let best = n.ranking.first().map_or(n.no_effect.bic, |c| c.bic);
        for c in n.ranking.iter().chain(std::iter::once(&n.no_effect)) {
            let params = params_text(c);
            let _ = writeln!(
                h,
                "<tr><td>{}</td><td>{}</td><td>{}</td><td>{:.1}</td><td>{:.1}</td><td>{:.1}</td><td>{:.1}</td><td>{:.1} mm, {:.3} mm, {:.3} mm, {:.4} m</td><td>{}</td></tr>",
                if c.kind == CandidateKind::None { "none (the flat alone)" } else { c.kind.as_str() },
                esc(&c.location),
                params,
                c.chi2,
                c.chi2_z,
                c.bic,
                c.bic - best,
                c.flat[0], c.flat[1], c.flat[2], c.flat[3],
                if c.joint { "yes" } else { "X_p only" }
            );
        }
        h += "</table>";
        if let Some(step) = &n.second {
            let _ = writeln!(
                h,
                "<h2>A second effect (forward selection)</h2><p>{}</p><p>First: {} at {}. Pairs, best first (χ², z and BIC of the pair):</p><table><tr><th>second effect</th><th>where</th><th>parameters (± 1 sd)</th><th>χ²</th><th>z</th><th>BIC</th></tr>",
                esc(&step.verdict),
                esc(step.first.kind.as_str()),
                esc(&step.first.location)
            );
            for c in &step.ranking {
                let _ = writeln!(
                    h,
                    "<tr><td>{}</td><td>{}</td><td>{}</td><td>{:.1}</td><td>{:.1}</td><td>{:.1}</td></tr>",
                    esc(c.kind.as_str()),
                    esc(&c.location),
                    params_text(c),
                    c.chi2,
                    c.chi2_z,
                    c.bic
                );
            }
            h += "</table>";
        }
    }
    h += "<h2>Timings</h2><ul>";
    for (name, s) in &d.timings_s {
        let _ = writeln!(h, "<li>{name}: {s:.1} s</li>");
    }
    h += "</ul></body></html>\n";
    h
}

/// A candidate's fitted parameters, `name value ± sd; …`, escaped.
fn params_text(c: &crate::diagnose::Candidate) -> String {
    c.parameters
        .iter()
        .map(|p| format!("{} {:.4} ± {:.4}", esc(&p.name), p.value, p.sd))
        .collect::<Vec<_>>()
        .join("; ")
}

/// Writes the report into `dir` (created if needed).
pub fn write_diagnosis_report(
    d: &Diagnosis,
    series_time: &[(String, f64, f64)],
    dir: &Path,
) -> Result<DiagnosisFiles, DiagnosisReportError> {
    std::fs::create_dir_all(dir).map_err(|source| DiagnosisReportError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    let figure = dir.join("diagnosis-gap.png");
    draw_gap(
        if d.added.is_some() {
            "Residual of the best instance against the thresholds: before (left), after adding the effect (right)"
        } else {
            "Residual of the best instance against the thresholds"
        },
        &d.before,
        d.added.as_ref().map(|a| &a.after),
        series_time,
        &figure,
    )?;
    let json = dir.join("diagnosis.json");
    let text = serde_json::to_string_pretty(d).expect("a diagnosis serialises");
    write(&json, text.as_bytes())?;
    let calibration = match &d.added {
        Some(a) => {
            let p = dir.join("calibration-with-effect.toml");
            write(&p, a.calibration_toml.as_bytes())?;
            Some(p)
        }
        None => None,
    };
    let html_path = dir.join("diagnosis.html");
    write(&html_path, html(d, "diagnosis-gap.png").as_bytes())?;
    Ok(DiagnosisFiles {
        json,
        html: html_path,
        figure,
        calibration,
    })
}
