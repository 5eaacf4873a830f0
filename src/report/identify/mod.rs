//! The identification report: one folder with the machine-readable result
//! (`identification.json`), the paper-style figures (Cao et al., Figs. 12–18) as PNG and SVG,
//! and one self-contained `report.html` for people.
//!
//! Figures:
//! - [`Figure::Series`]: each measured series with its PIPs (hollow circles), the selected
//!   EIP (filled, numbered in selection order) and the falsification band at each EIP
//!   (Figs. 12, 13, 15);
//! - [`Figure::Entropy`]: the entropy of the bank's predictions at every PIP (Fig. 14);
//! - [`Figure::JointEntropy`]: joint entropy against the number of points, per sensor set
//!   (Fig. 16);
//! - [`Figure::ParallelCoordinates`]: the candidate model set and the residual-minimisation
//!   optimum in parallel coordinates (Fig. 17);
//! - [`Figure::RandomSubsets`]: the CMS size over random subsets of the PIPs (Fig. 18); only
//!   when the identification has random-subset results.
//!
//! Every file is written atomically: to a hidden temporary sibling first, then renamed into
//! place, so a reader never sees a half-written file.

use std::fmt;
use std::fs;
use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::canvas::{
    ensure_font, format_tick, legend_font, msg, render_png, text_width, Chart, PlotError, FONT,
    GRID_BOLD, TAB10, TAB_BLUE, TAB_ORANGE, TAB_RED,
};
use crate::identify::result::Identification;

mod detection;
mod entropy;
mod html;
mod parallel;
#[cfg(test)]
mod sample;
mod series;
mod subsets;
#[cfg(test)]
mod tests;

/// File name of the JSON result inside the report folder.
pub const JSON_FILE: &str = "identification.json";
/// File name of the HTML report inside the report folder.
pub const HTML_FILE: &str = "report.html";

/// Errors from writing the report. Every variant names the file (or folder) concerned; for
/// figures rendered in memory by [`figure_svg`] that is the figure's bare SVG file name, e.g.
/// `series.svg`.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// Creating the folder, or writing or renaming a file, failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The folder or file concerned (the target, or its temporary sibling).
        path: PathBuf,
        /// The underlying I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The identification could not be serialised to JSON.
    #[error("{}: cannot serialise the identification: {source}", path.display())]
    Json {
        /// The JSON file that was to be written.
        path: PathBuf,
        /// The serialiser's error.
        #[source]
        source: serde_json::Error,
    },
    /// The embedded font could not be registered with the plotting library.
    #[error("{}: the embedded font assets/DejaVuSans.ttf could not be loaded", path.display())]
    Font {
        /// The figure that was to be drawn.
        path: PathBuf,
    },
    /// The plotting library failed while drawing or encoding a figure.
    #[error("{}: drawing the figure failed: {message}", path.display())]
    Draw {
        /// The figure that was to be drawn.
        path: PathBuf,
        /// The plotting library's error message.
        message: String,
    },
    /// The figure needs data the identification does not have (random-subset results).
    #[error("{}: the identification has no data for the {} figure", path.display(), figure.name())]
    Unavailable {
        /// The figure that was to be drawn.
        path: PathBuf,
        /// Which figure.
        figure: Figure,
    },
}

/// The files of one report, all inside the report folder.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ReportFiles {
    /// `identification.json`: the whole [`Identification`], pretty-printed.
    pub json: PathBuf,
    /// `report.html`: the self-contained report for people.
    pub html: PathBuf,
    /// The figures, PNG then SVG for each drawn figure, in [`Figure::ALL`] order.
    pub figures: Vec<PathBuf>,
}

/// One figure of the report.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Figure {
    /// Measured series with PIPs, EIP and falsification bands (paper Figs. 12, 13, 15).
    Series,
    /// The detection step: each sensor's residual after its gain against the good wheel's
    /// bound (docs/detection.md).
    Detection,
    /// Entropy of the predictions at every PIP (paper Fig. 14).
    Entropy,
    /// Joint entropy against the number of points, per sensor set (paper Fig. 16).
    JointEntropy,
    /// Candidate model set in parallel coordinates (paper Fig. 17).
    ParallelCoordinates,
    /// CMS sizes over random subsets of the PIPs (paper Fig. 18).
    RandomSubsets,
}

impl Figure {
    /// Every figure, in report order.
    pub const ALL: [Figure; 6] = [
        Figure::Series,
        Figure::Detection,
        Figure::Entropy,
        Figure::JointEntropy,
        Figure::ParallelCoordinates,
        Figure::RandomSubsets,
    ];

    /// File stem of the figure, e.g. `"joint_entropy"` (files `joint_entropy.png` and
    /// `joint_entropy.svg`).
    pub fn name(self) -> &'static str {
        match self {
            Figure::Series => "series",
            Figure::Detection => "detection",
            Figure::Entropy => "entropy",
            Figure::JointEntropy => "joint_entropy",
            Figure::ParallelCoordinates => "parallel_coordinates",
            Figure::RandomSubsets => "random_subsets",
        }
    }

    /// Whether `id` has the data for this figure (all but [`Figure::RandomSubsets`] always
    /// do; that one needs [`Identification::random_subsets`]).
    pub fn is_available(self, id: &Identification) -> bool {
        match self {
            Figure::RandomSubsets => id.random_subsets.is_some(),
            Figure::Detection => detection::is_available(id),
            _ => true,
        }
    }

    fn file_name(self, extension: &str) -> String {
        format!("{}.{extension}", self.name())
    }

    /// Caption used in the HTML report.
    fn caption(self) -> &'static str {
        match self {
            Figure::Series => {
                "Measured series. Hollow circles: perceptually important points (PIP); filled \
                 circles: selected points (EIP), numbered in selection order; orange bars: the \
                 range of predictions that survive falsification at each EIP \
                 (measurement + thresholds)."
            }
            Figure::Detection => {
                "Detection before sizing: per sensor, the measurement less the good wheel's \
                 prediction scaled by the sensor's gain, against the good wheel's bound (the \
                 table's absolute errors and the model-form allowance). A flat's strikes leave \
                 the band; a good wheel stays inside it."
            }
            Figure::Entropy => {
                "Entropy of the bank's predictions at every PIP; EIP in red, numbered in \
                 selection order."
            }
            Figure::JointEntropy => {
                "Joint entropy as points are added greedily, for each sensor set. The dashed line \
                 is log2 N, the entropy of the bank when every instance is told apart."
            }
            Figure::ParallelCoordinates => {
                "Candidate model set in parallel coordinates (each axis spans the population \
                 bounds), with the residual-minimisation optimum (no uncertainties) dashed."
            }
            Figure::RandomSubsets => {
                "CMS size when the same number of comparison points is drawn at random from the \
                 PIPs, against the CMS size with the EIP."
            }
        }
    }
}

impl fmt::Display for Figure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Writes the report into `dir` (created with its parents if missing):
/// `identification.json` (the pretty-printed JSON of `id`), each available figure as
/// `<name>.png` and `<name>.svg` (see [`Figure::name`]; the random-subsets figure is skipped
/// when `id.random_subsets` is `None`), and the self-contained `report.html` with the figures
/// inlined as SVG. Existing files of the same names are replaced.
///
/// Every file is written atomically (hidden temporary sibling, then rename); the HTML is
/// written last.
///
/// # Errors
/// [`ReportError::Io`] when the folder cannot be created or a file cannot be written,
/// [`ReportError::Json`], [`ReportError::Font`] or [`ReportError::Draw`] when serialising or
/// drawing fails. Files written before the failure stay in place.
pub fn write_identification_report(
    id: &Identification,
    dir: &Path,
) -> Result<ReportFiles, ReportError> {
    let json = write_identification_json(id, dir)?;
    let (figures, html) = write_figures_and_html(id, dir)?;
    Ok(ReportFiles {
        json,
        html,
        figures,
    })
}

/// Writes `identification.json` alone into `dir` (created with its parents if missing),
/// atomically: what a monitoring system reads, before any figure is drawn. Returns its path.
///
/// # Errors
/// [`ReportError::Io`] or [`ReportError::Json`].
pub fn write_identification_json(id: &Identification, dir: &Path) -> Result<PathBuf, ReportError> {
    fs::create_dir_all(dir).map_err(|source| ReportError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    let json_path = dir.join(JSON_FILE);
    let json = serde_json::to_string_pretty(id).map_err(|source| ReportError::Json {
        path: json_path.clone(),
        source,
    })?;
    write_atomic(&json_path, json.as_bytes())?;
    Ok(json_path)
}

/// Draws every available figure of `id` (PNG and SVG) and `report.html` into `dir`, e.g. from
/// an `identification.json` read back later (`wheelflat report`). Returns the figure paths
/// and the HTML path.
///
/// # Errors
/// As [`write_identification_report`].
pub fn write_figures_and_html(
    id: &Identification,
    dir: &Path,
) -> Result<(Vec<PathBuf>, PathBuf), ReportError> {
    fs::create_dir_all(dir).map_err(|source| ReportError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    let mut figures = Vec::new();
    let mut inline = Vec::new();
    for fig in Figure::ALL {
        if !fig.is_available(id) {
            continue;
        }
        let png = dir.join(fig.file_name("png"));
        write_png(id, fig, &png)?;
        let svg_path = dir.join(fig.file_name("svg"));
        let svg = render_svg(id, fig, &svg_path)?;
        write_atomic(&svg_path, svg.as_bytes())?;
        figures.push(png);
        figures.push(svg_path);
        inline.push((fig, svg));
    }

    let html_path = dir.join(HTML_FILE);
    // Writing into a String cannot fail; the error is mapped only for completeness.
    let html = html::render_html(id, &inline).map_err(|_| ReportError::Io {
        path: html_path.clone(),
        source: std::io::Error::other("formatting the HTML report failed"),
    })?;
    write_atomic(&html_path, html.as_bytes())?;
    Ok((figures, html_path))
}

/// Renders one figure of `id` to an SVG document (as written to `<name>.svg`; the HTML report
/// inlines the same drawing).
///
/// # Errors
/// [`ReportError::Unavailable`] for [`Figure::RandomSubsets`] when `id.random_subsets` is
/// `None`; [`ReportError::Font`] or [`ReportError::Draw`] when drawing fails. The error's path
/// is the figure's bare file name, e.g. `series.svg`.
pub fn figure_svg(id: &Identification, fig: Figure) -> Result<String, ReportError> {
    render_svg(id, fig, Path::new(&fig.file_name("svg")))
}

// ---------------------------------------------------------------------------------------
// Files
// ---------------------------------------------------------------------------------------

/// Writes `bytes` to `path` atomically ([`crate::atomic::write_atomically`]).
fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), ReportError> {
    crate::atomic::write_atomically(path, bytes).map_err(|source| ReportError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Draws `fig` into a PNG at `path`, atomically ([`render_png`]).
fn write_png(id: &Identification, fig: Figure, path: &Path) -> Result<(), ReportError> {
    render_png(path, figure_size(id, fig), |root| render(root, id, fig)).map_err(|e| match e {
        PlotError::Font { path } => ReportError::Font { path },
        PlotError::Io { path, source } => ReportError::Io { path, source },
        PlotError::Draw { path, message } => ReportError::Draw { path, message },
        other => ReportError::Draw {
            path: path.to_path_buf(),
            message: other.to_string(),
        },
    })
}

/// Draws `fig` into an SVG string; errors name `path`.
fn render_svg(id: &Identification, fig: Figure, path: &Path) -> Result<String, ReportError> {
    if !fig.is_available(id) {
        return Err(ReportError::Unavailable {
            path: path.to_path_buf(),
            figure: fig,
        });
    }
    if !ensure_font() {
        return Err(ReportError::Font {
            path: path.to_path_buf(),
        });
    }
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, figure_size(id, fig)).into_drawing_area();
        render(&root, id, fig)
            .and_then(|()| root.present().map_err(msg))
            .map_err(|message| ReportError::Draw {
                path: path.to_path_buf(),
                message,
            })?;
    }
    Ok(svg)
}

// ---------------------------------------------------------------------------------------
// Figures: common layout
// ---------------------------------------------------------------------------------------

/// Width of every figure (pixels, also the SVG view box).
const WIDTH: u32 = 1400;
/// Height of one panel of the series figure.
const SERIES_PANEL_HEIGHT: u32 = 380;

/// Colours.
const MEASURED_COLOUR: RGBColor = TAB_BLUE;
const PIP_COLOUR: RGBColor = RGBColor(70, 70, 70);
const EIP_COLOUR: RGBColor = TAB_RED;
const EIP_LABEL_COLOUR: RGBColor = RGBColor(150, 20, 20);
const BAND_COLOUR: RGBColor = TAB_ORANGE;
const ENVELOPE_COLOUR: RGBColor = RGBColor(44, 160, 44);
const BAR_COLOUR: RGBColor = RGBColor(120, 155, 195);
const CMS_COLOUR: RGBColor = RGBColor(125, 125, 125);
const REFERENCE_COLOUR: RGBColor = RGBColor(40, 40, 40);
/// Light grid lines, fainter than the single figures' (the bold ones are shared).
const GRID_FAINT: RGBColor = RGBColor(243, 243, 243);
/// Line colours of the joint-entropy curves (matplotlib "tab10" without red and orange, which
/// mark EIP and bands elsewhere).
const PALETTE: [RGBColor; 6] = [TAB10[0], TAB10[2], TAB10[4], TAB10[5], TAB10[6], TAB10[9]];

/// Text sizes.
const TITLE_SIZE: u32 = 28;
const CAPTION_SIZE: u32 = 22;
const TICK_SIZE: u32 = 17;
const AXIS_DESC_SIZE: u32 = 20;
const ANNOTATION_SIZE: u32 = 17;

/// Legend layout (pixels): length of a line sample, gap sample–label, gap between entries,
/// height of a row.
const LEGEND_SAMPLE: u32 = 34;
const LEGEND_GAP: u32 = 8;
const LEGEND_SPACING: u32 = 34;
const LEGEND_ROW: u32 = 30;

/// Size of `fig` for `id` in pixels.
fn figure_size(id: &Identification, fig: Figure) -> (u32, u32) {
    match fig {
        Figure::Series => {
            let panels = id.series.len().max(1) as u32;
            (WIDTH, 110 + SERIES_PANEL_HEIGHT * panels)
        }
        Figure::Detection => {
            let panels = id.detection.as_ref().map_or(1, |d| d.sensors.len().max(1)) as u32;
            (WIDTH, 110 + SERIES_PANEL_HEIGHT * panels)
        }
        Figure::Entropy => (WIDTH, 620),
        Figure::JointEntropy => (WIDTH, 720),
        Figure::ParallelCoordinates => (WIDTH, 820),
        Figure::RandomSubsets => (WIDTH, 660),
    }
}

/// Draws the whole of `fig` on `root`.
fn render<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    id: &Identification,
    fig: Figure,
) -> Result<(), String> {
    root.fill(&WHITE).map_err(msg)?;
    match fig {
        Figure::Series => series::render_series(root, id),
        Figure::Detection => detection::render_detection(root, id),
        Figure::Entropy => entropy::render_entropy(root, id),
        Figure::JointEntropy => entropy::render_joint_entropy(root, id),
        Figure::ParallelCoordinates => parallel::render_parallel(root, id),
        Figure::RandomSubsets => subsets::render_random_subsets(root, id),
    }
}

/// How a legend entry is drawn.
#[derive(Debug, Clone, Copy)]
enum Swatch {
    Line(RGBColor, u32),
    Dashed(RGBColor, u32),
    HollowCircle(RGBColor),
    FilledCircle(RGBColor),
    Bar(RGBColor),
    ErrorBar(RGBColor),
}

/// One legend entry.
struct Entry {
    label: String,
    swatch: Swatch,
}

impl Entry {
    fn new(label: impl Into<String>, swatch: Swatch) -> Self {
        Self {
            label: label.into(),
            swatch,
        }
    }
}

fn annotation_font(colour: &'static RGBColor) -> TextStyle<'static> {
    TextStyle::from((FONT, ANNOTATION_SIZE).into_font()).color(colour)
}

/// The title, then a legend row (wrapped when needed) under it; returns the area left for the
/// plot.
fn frame<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    entries: &[Entry],
) -> Result<DrawingArea<DB, Shift>, String> {
    let body = root
        .margin(14, 6, 6, 14)
        .titled(title, (FONT, TITLE_SIZE).into_font().color(&BLACK))
        .map_err(msg)?;
    if entries.is_empty() {
        return Ok(body);
    }
    let font = legend_font();
    let (w, _) = body.dim_in_pixel();
    let max_row = w.saturating_sub(40);
    // Greedy wrapping: each row is a list of (entry, width of swatch + label).
    let mut rows: Vec<Vec<(&Entry, u32)>> = vec![Vec::new()];
    let mut row_width = 0;
    for entry in entries {
        let tw = text_width(&body, &entry.label, &font)?;
        let width = LEGEND_SAMPLE + LEGEND_GAP + tw;
        let extra = if row_width == 0 {
            width
        } else {
            LEGEND_SPACING + width
        };
        if row_width > 0 && row_width + extra > max_row {
            rows.push(Vec::new());
            row_width = width;
        } else {
            row_width += extra;
        }
        if let Some(row) = rows.last_mut() {
            row.push((entry, width));
        }
    }
    let height = LEGEND_ROW * rows.len() as u32 + 10;
    let (legend, rest) = body.split_vertically(height);
    let text_style = font.pos(Pos::new(HPos::Left, VPos::Center));
    for (r, row) in rows.iter().enumerate() {
        let total: u32 = row.iter().map(|(_, w)| w).sum::<u32>()
            + LEGEND_SPACING * row.len().saturating_sub(1) as u32;
        let mut x = (w.saturating_sub(total) / 2) as i32;
        let y = (LEGEND_ROW * r as u32 + LEGEND_ROW / 2) as i32;
        for (entry, width) in row {
            draw_swatch(&legend, entry.swatch, x, y)?;
            legend
                .draw(&Text::new(
                    entry.label.as_str(),
                    (x + (LEGEND_SAMPLE + LEGEND_GAP) as i32, y),
                    text_style.clone(),
                ))
                .map_err(msg)?;
            x += (width + LEGEND_SPACING) as i32;
        }
    }
    Ok(rest)
}

/// Draws a legend sample whose left end is at (`x`, `y`).
fn draw_swatch<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    swatch: Swatch,
    x: i32,
    y: i32,
) -> Result<(), String> {
    let x1 = x + LEGEND_SAMPLE as i32;
    let xm = (x + x1) / 2;
    match swatch {
        Swatch::Line(c, w) => area.draw(&PathElement::new(
            vec![(x, y), (x1, y)],
            ShapeStyle::from(&c).stroke_width(w),
        )),
        Swatch::Dashed(c, w) => area.draw(&DashedPathElement::new(
            vec![(x, y), (x1, y)],
            7,
            4,
            ShapeStyle::from(&c).stroke_width(w),
        )),
        Swatch::HollowCircle(c) => area.draw(&Circle::new(
            (xm, y),
            5,
            ShapeStyle::from(&c).stroke_width(2),
        )),
        Swatch::FilledCircle(c) => area.draw(&Circle::new((xm, y), 6, c.filled())),
        Swatch::Bar(c) => area.draw(&Rectangle::new(
            [(x + 8, y - 9), (x1 - 8, y + 9)],
            c.filled(),
        )),
        Swatch::ErrorBar(c) => {
            let style = ShapeStyle::from(&c).stroke_width(2);
            area.draw(&PathElement::new(vec![(xm, y - 11), (xm, y + 11)], style))
                .and_then(|()| {
                    area.draw(&PathElement::new(
                        vec![(xm - 5, y - 11), (xm + 5, y - 11)],
                        style,
                    ))
                })
                .and_then(|()| {
                    area.draw(&PathElement::new(
                        vec![(xm - 5, y + 11), (xm + 5, y + 11)],
                        style,
                    ))
                })
        }
    }
    .map_err(msg)
}

/// A note centred on `area` (for figures without data).
fn centred_note<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    text: &str,
    colour: RGBColor,
) -> Result<(), String> {
    let (w, h) = area.dim_in_pixel();
    let style = TextStyle::from((FONT, 30).into_font())
        .color(&colour)
        .pos(Pos::new(HPos::Center, VPos::Center));
    area.draw(&Text::new(text, ((w / 2) as i32, (h / 2) as i32), style))
        .map_err(msg)
}

/// Axes, grid and axis descriptions; `integer_x` / `integer_y` hide fractional tick labels.
fn draw_mesh<DB: DrawingBackend>(
    chart: &mut Chart<DB>,
    x_desc: &str,
    y_desc: &str,
    integer_x: bool,
    integer_y: bool,
) -> Result<(), String> {
    let plain = |v: &f64| format_tick(*v);
    let integer = |v: &f64| {
        let r = v.round();
        if (v - r).abs() > 1e-6 {
            String::new()
        } else if r.abs() < 0.5 {
            "0".to_string()
        } else {
            format!("{r:.0}")
        }
    };
    let mut mesh = chart.configure_mesh();
    mesh.x_desc(x_desc)
        .y_desc(y_desc)
        .x_labels(12)
        .y_labels(8)
        .label_style((FONT, TICK_SIZE))
        .axis_desc_style((FONT, AXIS_DESC_SIZE))
        .light_line_style(GRID_FAINT)
        .bold_line_style(GRID_BOLD)
        .x_label_formatter(if integer_x { &integer } else { &plain })
        .y_label_formatter(if integer_y { &integer } else { &plain });
    mesh.draw().map_err(msg)
}

/// A builder with the common margins and label areas.
fn chart_builder<'a, 'b, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
) -> ChartBuilder<'a, 'b, DB> {
    let mut builder = ChartBuilder::on(area);
    builder
        .margin_top(10)
        .margin_bottom(6)
        .margin_left(10)
        .margin_right(24)
        .x_label_area_size(58)
        .y_label_area_size(88);
    builder
}

/// Selection order (1-based) of every candidate that is an EIP.
fn eip_order(id: &Identification) -> Vec<Option<usize>> {
    let mut order = vec![None; id.candidates.len()];
    for (k, &c) in id.eip.iter().enumerate() {
        if let Some(slot) = order.get_mut(c) {
            slot.get_or_insert(k + 1);
        }
    }
    order
}

// ---------------------------------------------------------------------------------------
// Numbers
// ---------------------------------------------------------------------------------------

/// `v` with `decimals` decimals; non-finite values as "–".
fn fmt_num(v: f64, decimals: usize) -> String {
    if v.is_finite() {
        let s = format!("{v:.decimals$}");
        // "-0.0" reads oddly.
        if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
            s[1..].to_string()
        } else {
            s
        }
    } else {
        "–".to_string()
    }
}

/// An axis value with decimals suited to the axis span, without trailing zeros.
fn fmt_axis(v: f64, span: f64) -> String {
    let span = span.abs();
    let decimals = if span >= 100.0 {
        0
    } else if span >= 10.0 {
        1
    } else if span >= 1.0 {
        2
    } else {
        3
    };
    let s = fmt_num(v, decimals);
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// `[min, max]` as "min – max".
fn fmt_range([lo, hi]: [f64; 2], decimals: usize) -> String {
    format!("{} – {}", fmt_num(lo, decimals), fmt_num(hi, decimals))
}
