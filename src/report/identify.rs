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

use std::fmt::{self, Write as _};
use std::fs;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::plot::{ensure_font, FONT};
use crate::identify::result::{Identification, InstanceParams, ParamRanges};

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
    pub const ALL: [Figure; 5] = [
        Figure::Series,
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
    let html = render_html(id, &inline).map_err(|_| ReportError::Io {
        path: html_path.clone(),
        source: std::io::Error::other("formatting the HTML report failed"),
    })?;
    write_atomic(&html_path, html.as_bytes())?;

    Ok(ReportFiles {
        json: json_path,
        html: html_path,
        figures,
    })
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

/// A hidden temporary sibling of `path` that keeps its extension (the PNG encoder picks the
/// format from it), unique within this process.
fn temp_path(path: &Path) -> PathBuf {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().into_owned())
        .unwrap_or_default();
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let tmp = format!(".{name}.tmp-{}-{n}.{ext}", std::process::id());
    path.parent().unwrap_or(Path::new("")).join(tmp)
}

/// Renames `tmp` to `path`; on failure removes `tmp`.
fn rename_into_place(tmp: &Path, path: &Path) -> Result<(), ReportError> {
    fs::rename(tmp, path).map_err(|source| {
        let _ = fs::remove_file(tmp);
        ReportError::Io {
            path: path.to_path_buf(),
            source,
        }
    })
}

/// Writes `bytes` to `path` atomically ([`crate::atomic::write_atomically`]).
fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), ReportError> {
    crate::atomic::write_atomically(path, bytes).map_err(|source| ReportError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Draws `fig` into a PNG at `path`, atomically.
fn write_png(id: &Identification, fig: Figure, path: &Path) -> Result<(), ReportError> {
    if !ensure_font() {
        return Err(ReportError::Font {
            path: path.to_path_buf(),
        });
    }
    let draw_err = |message: String| ReportError::Draw {
        path: path.to_path_buf(),
        message,
    };
    let tmp = temp_path(path);
    let drawn = {
        let root = BitMapBackend::new(&tmp, figure_size(id, fig)).into_drawing_area();
        render(&root, id, fig)
            .and_then(|()| root.present().map_err(msg))
            .map_err(draw_err)
    };
    match drawn {
        Ok(()) => rename_into_place(&tmp, path),
        Err(e) => {
            // Best effort: the temporary may not exist if drawing failed before saving.
            let _ = fs::remove_file(&tmp);
            Err(e)
        }
    }
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
const MEASURED_COLOUR: RGBColor = RGBColor(31, 119, 180);
const PIP_COLOUR: RGBColor = RGBColor(70, 70, 70);
const EIP_COLOUR: RGBColor = RGBColor(214, 39, 40);
const EIP_LABEL_COLOUR: RGBColor = RGBColor(150, 20, 20);
const BAND_COLOUR: RGBColor = RGBColor(255, 127, 14);
const BAR_COLOUR: RGBColor = RGBColor(120, 155, 195);
const CMS_COLOUR: RGBColor = RGBColor(125, 125, 125);
const REFERENCE_COLOUR: RGBColor = RGBColor(40, 40, 40);
const GRID_LIGHT: RGBColor = RGBColor(243, 243, 243);
const GRID_BOLD: RGBColor = RGBColor(205, 205, 205);
/// Line colours of the joint-entropy curves (matplotlib "tab10" without red and orange, which
/// mark EIP and bands elsewhere).
const PALETTE: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];

/// Text sizes.
const TITLE_SIZE: u32 = 28;
const CAPTION_SIZE: u32 = 22;
const TICK_SIZE: u32 = 17;
const AXIS_DESC_SIZE: u32 = 20;
const LEGEND_SIZE: u32 = 18;
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
        Figure::Series => render_series(root, id),
        Figure::Entropy => render_entropy(root, id),
        Figure::JointEntropy => render_joint_entropy(root, id),
        Figure::ParallelCoordinates => render_parallel(root, id),
        Figure::RandomSubsets => render_random_subsets(root, id),
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

fn legend_font() -> TextStyle<'static> {
    TextStyle::from((FONT, LEGEND_SIZE).into_font()).color(&BLACK)
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
        let (tw, _) = body.estimate_text_size(&entry.label, &font).map_err(msg)?;
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

/// Label placement that avoids overlaps: boxes in absolute pixel coordinates.
struct Placer {
    taken: Vec<[i32; 4]>,
    bounds: [i32; 4],
}

impl Placer {
    fn new((xs, ys): (std::ops::Range<i32>, std::ops::Range<i32>)) -> Self {
        Self {
            taken: Vec::new(),
            bounds: [xs.start, ys.start, xs.end, ys.end],
        }
    }

    /// Marks a box `[x0, y0, x1, y1]` as occupied.
    fn occupy(&mut self, b: [i32; 4]) {
        self.taken.push(b);
    }

    /// Picks the first of `offsets` (top-left corner of a `size` box relative to `anchor`)
    /// whose box is inside the bounds and free, else the first; occupies it and returns the
    /// offset.
    fn place(
        &mut self,
        anchor: (i32, i32),
        size: (u32, u32),
        offsets: &[(i32, i32)],
    ) -> (i32, i32) {
        let (w, h) = (size.0 as i32, size.1 as i32);
        let boxed = |(dx, dy): (i32, i32)| {
            let x0 = anchor.0 + dx;
            let y0 = anchor.1 + dy;
            [x0, y0, x0 + w, y0 + h]
        };
        let inside = |b: &[i32; 4]| {
            b[0] >= self.bounds[0]
                && b[1] >= self.bounds[1]
                && b[2] <= self.bounds[2]
                && b[3] <= self.bounds[3]
        };
        let free = |b: &[i32; 4]| {
            self.taken
                .iter()
                .all(|t| b[2] + 1 < t[0] || t[2] + 1 < b[0] || b[3] + 1 < t[1] || t[3] + 1 < b[1])
        };
        let chosen = offsets
            .iter()
            .copied()
            .find(|&o| {
                let b = boxed(o);
                inside(&b) && free(&b)
            })
            .or_else(|| offsets.iter().copied().find(|&o| inside(&boxed(o))))
            .unwrap_or(offsets.first().copied().unwrap_or((0, 0)));
        self.occupy(boxed(chosen));
        chosen
    }
}

/// A chart with `f64` axes.
type Chart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Draws `text` with a white backing box, its top-left corner `offset` pixels from the data
/// point `at`.
fn draw_label<DB: DrawingBackend>(
    chart: &Chart<DB>,
    at: (f64, f64),
    text: &str,
    style: &TextStyle,
    (dx, dy): (i32, i32),
    (w, h): (u32, u32),
) -> Result<(), String> {
    let style = style.clone().pos(Pos::new(HPos::Left, VPos::Top));
    let elem = EmptyElement::at(at)
        + Rectangle::new(
            [(dx - 3, dy - 2), (dx + w as i32 + 3, dy + h as i32 + 2)],
            WHITE.mix(0.85).filled(),
        )
        + Text::new(text.to_string(), (dx, dy), style);
    chart.plotting_area().draw(&elem).map_err(msg)
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
        .light_line_style(GRID_LIGHT)
        .bold_line_style(GRID_BOLD)
        .x_label_formatter(if integer_x { &integer } else { &plain })
        .y_label_formatter(if integer_y { &integer } else { &plain });
    mesh.draw().map_err(msg)
}

/// A tick label: as few decimals as the value needs (up to 6), no trailing zeros.
fn format_tick(v: f64) -> String {
    if !v.is_finite() {
        return String::new();
    }
    let s = format!("{v:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".to_string()
    } else {
        s.to_string()
    }
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

/// Smallest and largest finite value, if any.
fn min_max(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    values
        .filter(|v| v.is_finite())
        .fold(None, |acc, v| match acc {
            None => Some((v, v)),
            Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
        })
}

/// `range` widened by `frac` of its span on each side; degenerate or missing ranges get a
/// unit span.
fn pad_range(range: Option<(f64, f64)>, frac: f64) -> (f64, f64) {
    match range {
        None => (0.0, 1.0),
        Some((lo, hi)) if hi - lo > 0.0 => {
            let pad = frac * (hi - lo);
            (lo - pad, hi + pad)
        }
        Some((lo, _)) => {
            let half = 0.5 * lo.abs().max(1.0);
            (lo - half, lo + half)
        }
    }
}

/// The (x, y) points split into runs of finite values, so gaps break the line.
fn finite_runs(points: impl Iterator<Item = (f64, f64)>) -> Vec<Vec<(f64, f64)>> {
    let mut runs = Vec::new();
    let mut run = Vec::new();
    for (x, y) in points {
        if x.is_finite() && y.is_finite() {
            run.push((x, y));
        } else if !run.is_empty() {
            runs.push(std::mem::take(&mut run));
        }
    }
    if !run.is_empty() {
        runs.push(run);
    }
    runs
}

/// Panel letter: a, b, …, z, then numbers.
fn panel_letter(k: usize) -> String {
    match u8::try_from(k) {
        Ok(k) if k < 26 => char::from(b'a' + k).to_string(),
        _ => (k + 1).to_string(),
    }
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

/// Offsets (top-left corner relative to the anchor) to try for a `w`×`h` label next to a
/// marker of radius `r`: right and left of it, above, below, then further out.
fn around(w: i32, h: i32, r: i32) -> Vec<(i32, i32)> {
    let right = r + 4;
    let left = -w - r - 4;
    let mut offsets = Vec::new();
    for step in 0..4 {
        let up = -h - r - step * (h + 6);
        let down = r + step * (h + 6);
        offsets.extend([(right, up), (left, up), (right, down), (left, down)]);
        if step == 0 {
            offsets.extend([(right, -h / 2), (left, -h / 2)]);
        }
    }
    offsets
}

/// Offsets that stack a `w`×`h` label above an anchor (bar tops), then beside it.
fn above(w: i32, h: i32) -> Vec<(i32, i32)> {
    let mut offsets: Vec<(i32, i32)> = (0..5).map(|k| (-w / 2, -h - 6 - k * (h + 4))).collect();
    offsets.extend([
        (6, -h - 6),
        (-w - 6, -h - 6),
        (6, -2 * h - 10),
        (-w - 6, -2 * h - 10),
    ]);
    offsets
}

// ---------------------------------------------------------------------------------------
// Figure 1: series with PIP, EIP and falsification bands
// ---------------------------------------------------------------------------------------

fn render_series<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    id: &Identification,
) -> Result<(), String> {
    let entries = [
        Entry::new("measured", Swatch::Line(MEASURED_COLOUR, 2)),
        Entry::new("PIP", Swatch::HollowCircle(PIP_COLOUR)),
        Entry::new(
            "EIP (number = selection order)",
            Swatch::FilledCircle(EIP_COLOUR),
        ),
        Entry::new(
            "admissible predictions at the EIP: measured + [low, high] threshold",
            Swatch::ErrorBar(BAND_COLOUR),
        ),
    ];
    let title = format!(
        "Measured series: {} PIP ({} distance), {} EIP",
        id.candidates.len(),
        id.pip_distance,
        id.eip.len()
    );
    let body = frame(root, &title, &entries)?;
    if id.series.is_empty() {
        return centred_note(&body, "no measured series", PIP_COLOUR);
    }
    let panels = body.split_evenly((id.series.len(), 1));
    for (k, panel) in panels.iter().enumerate() {
        series_panel(panel, id, k)?;
    }
    Ok(())
}

/// One panel of the series figure: series `k`.
fn series_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    id: &Identification,
    k: usize,
) -> Result<(), String> {
    let Some(s) = id.series.get(k) else {
        return Ok(());
    };
    let dt = if s.sample_rate_hz.is_finite() && s.sample_rate_hz > 0.0 {
        1.0 / s.sample_rate_hz
    } else {
        1.0
    };
    let time: Vec<f64> = (0..s.values_kn.len())
        .map(|i| s.t0_s + i as f64 * dt)
        .collect();
    let order = eip_order(id);
    let pips: Vec<(usize, _)> = id
        .candidates
        .iter()
        .enumerate()
        .filter(|(_, c)| c.series == k)
        .collect();
    let eips: Vec<(usize, _)> = pips
        .iter()
        .filter_map(|&(i, c)| order.get(i).copied().flatten().map(|n| (n, c)))
        .collect();

    let (t_lo, t_hi) = pad_range(
        min_max(
            time.iter()
                .copied()
                .chain(pips.iter().map(|(_, c)| c.time_s)),
        ),
        0.015,
    );
    let (y_lo, y_hi) = pad_range(
        min_max(
            s.values_kn
                .iter()
                .copied()
                .chain(pips.iter().map(|(_, c)| c.measured_kn))
                .chain(eips.iter().flat_map(|(_, c)| {
                    [
                        c.measured_kn + c.threshold_low_kn,
                        c.measured_kn + c.threshold_high_kn,
                    ]
                })),
        ),
        0.1,
    );

    let caption = format!("({}) {}", panel_letter(k), s.sensor);
    let mut chart = chart_builder(area)
        .caption(caption, (FONT, CAPTION_SIZE))
        .build_cartesian_2d(t_lo..t_hi, y_lo..y_hi)
        .map_err(msg)?;
    draw_mesh(&mut chart, "time (s)", "force (kN)", false, false)?;

    let line = ShapeStyle::from(&MEASURED_COLOUR).stroke_width(2);
    chart
        .draw_series(
            finite_runs(time.iter().copied().zip(s.values_kn.iter().copied()))
                .into_iter()
                .map(|run| PathElement::new(run, line)),
        )
        .map_err(msg)?;

    // Falsification bands at the EIP, with caps.
    let band = ShapeStyle::from(&BAND_COLOUR).stroke_width(2);
    for (_, c) in &eips {
        let lo = c.measured_kn + c.threshold_low_kn;
        let hi = c.measured_kn + c.threshold_high_kn;
        if !(c.time_s.is_finite() && lo.is_finite() && hi.is_finite()) {
            continue;
        }
        let cap = |y: f64| {
            EmptyElement::at((c.time_s, y)) + PathElement::new(vec![(-6, 0), (6, 0)], band)
        };
        chart
            .plotting_area()
            .draw(&PathElement::new(
                vec![(c.time_s, lo), (c.time_s, hi)],
                band,
            ))
            .map_err(msg)?;
        chart.plotting_area().draw(&cap(lo)).map_err(msg)?;
        chart.plotting_area().draw(&cap(hi)).map_err(msg)?;
    }

    let hollow = ShapeStyle::from(&PIP_COLOUR).stroke_width(2);
    chart
        .draw_series(
            pips.iter()
                .map(|(_, c)| Circle::new((c.time_s, c.measured_kn), 5, hollow)),
        )
        .map_err(msg)?;
    chart
        .draw_series(
            eips.iter()
                .map(|(_, c)| Circle::new((c.time_s, c.measured_kn), 6, EIP_COLOUR.filled())),
        )
        .map_err(msg)?;

    // Selection-order numbers, placed clear of the markers, the bands and each other.
    let font = annotation_font(&EIP_LABEL_COLOUR);
    let mut placer = Placer::new(chart.plotting_area().get_pixel_range());
    for (_, c) in &pips {
        let (x, y) = chart.backend_coord(&(c.time_s, c.measured_kn));
        placer.occupy([x - 7, y - 7, x + 7, y + 7]);
    }
    for (_, c) in &eips {
        let (x, y0) = chart.backend_coord(&(c.time_s, c.measured_kn + c.threshold_high_kn));
        let (_, y1) = chart.backend_coord(&(c.time_s, c.measured_kn + c.threshold_low_kn));
        placer.occupy([x - 7, y0.min(y1), x + 7, y0.max(y1)]);
    }
    for (n, c) in &eips {
        let text = n.to_string();
        let size = area.estimate_text_size(&text, &font).map_err(msg)?;
        let anchor = chart.backend_coord(&(c.time_s, c.measured_kn));
        let offset = placer.place(anchor, size, &around(size.0 as i32, size.1 as i32, 7));
        draw_label(
            &chart,
            (c.time_s, c.measured_kn),
            &text,
            &font,
            offset,
            size,
        )?;
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------
// Figure 2: entropy at every PIP
// ---------------------------------------------------------------------------------------

fn render_entropy<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    id: &Identification,
) -> Result<(), String> {
    let entries = [
        Entry::new("PIP", Swatch::Bar(BAR_COLOUR)),
        Entry::new("EIP (number = selection order)", Swatch::Bar(EIP_COLOUR)),
    ];
    let n = id.candidates.len();
    let title = format!("Entropy of the bank's predictions at each of the {n} PIP");
    let body = frame(root, &title, &entries)?;
    if n == 0 {
        return centred_note(&body, "no PIP", PIP_COLOUR);
    }
    let order = eip_order(id);
    let entropy = |e: f64| if e.is_finite() && e > 0.0 { e } else { 0.0 };
    let e_max = id
        .candidates
        .iter()
        .map(|c| entropy(c.entropy_bits))
        .fold(0.0, f64::max);
    let y_hi = if e_max > 0.0 { e_max * 1.25 } else { 1.0 };
    let mut chart = chart_builder(&body)
        .build_cartesian_2d(-0.7..n as f64 - 0.3, 0.0..y_hi)
        .map_err(msg)?;
    draw_mesh(&mut chart, "PIP index", "entropy (bits)", true, false)?;

    chart
        .draw_series(id.candidates.iter().enumerate().map(|(i, c)| {
            let colour = if order[i].is_some() {
                EIP_COLOUR
            } else {
                BAR_COLOUR
            };
            let x = i as f64;
            Rectangle::new(
                [(x - 0.38, 0.0), (x + 0.38, entropy(c.entropy_bits))],
                colour.filled(),
            )
        }))
        .map_err(msg)?;

    let mut placer = Placer::new(chart.plotting_area().get_pixel_range());
    // Series boundaries, when the candidates are grouped by series.
    let mut runs: Vec<(usize, usize, usize)> = Vec::new(); // (series, first, last)
    for (i, c) in id.candidates.iter().enumerate() {
        match runs.last_mut() {
            Some(run) if run.0 == c.series => run.2 = i,
            _ => runs.push((c.series, i, i)),
        }
    }
    let mut distinct: Vec<usize> = runs.iter().map(|r| r.0).collect();
    distinct.sort_unstable();
    distinct.dedup();
    if runs.len() > 1 && distinct.len() == runs.len() {
        let sep = ShapeStyle::from(&REFERENCE_COLOUR).stroke_width(1);
        for run in &runs[1..] {
            let x = run.1 as f64 - 0.5;
            chart
                .plotting_area()
                .draw(&DashedPathElement::new(
                    vec![(x, 0.0), (x, y_hi)],
                    6,
                    4,
                    sep,
                ))
                .map_err(msg)?;
        }
        let font = TextStyle::from((FONT, LEGEND_SIZE).into_font()).color(&REFERENCE_COLOUR);
        for &(series, first, last) in &runs {
            let name = id
                .series
                .get(series)
                .map_or_else(|| format!("series {series}"), |s| s.sensor.clone());
            let size = body.estimate_text_size(&name, &font).map_err(msg)?;
            let at = (0.5 * (first + last) as f64, y_hi);
            let anchor = chart.backend_coord(&at);
            let offset = placer.place(anchor, size, &[(-(size.0 as i32) / 2, 6)]);
            draw_label(&chart, at, &name, &font, offset, size)?;
        }
    }

    let font = annotation_font(&EIP_LABEL_COLOUR);
    let mut eips: Vec<(usize, usize)> = order
        .iter()
        .enumerate()
        .filter_map(|(i, o)| o.map(|n| (n, i)))
        .collect();
    eips.sort_unstable();
    for (n, i) in eips {
        let text = n.to_string();
        let size = body.estimate_text_size(&text, &font).map_err(msg)?;
        let at = (i as f64, entropy(id.candidates[i].entropy_bits));
        let anchor = chart.backend_coord(&at);
        let offset = placer.place(anchor, size, &above(size.0 as i32, size.1 as i32));
        draw_label(&chart, at, &text, &font, offset, size)?;
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------
// Figure 3: joint entropy curves
// ---------------------------------------------------------------------------------------

fn render_joint_entropy<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    id: &Identification,
) -> Result<(), String> {
    let log2n = if id.bank_instances > 0 {
        (id.bank_instances as f64).log2()
    } else {
        f64::NAN
    };
    let mut entries: Vec<Entry> = id
        .entropy_curves
        .iter()
        .enumerate()
        .map(|(i, c)| Entry::new(c.label.clone(), Swatch::Line(PALETTE[i % PALETTE.len()], 3)))
        .collect();
    if log2n.is_finite() {
        entries.push(Entry::new(
            format!("log2 N (N = {} instances)", id.bank_instances),
            Swatch::Dashed(REFERENCE_COLOUR, 2),
        ));
    }
    if !id.eip.is_empty() {
        entries.push(Entry::new(
            format!(
                "{} EIP selected (stop threshold α = {} bits)",
                id.eip.len(),
                fmt_num(id.alpha_bits, 3)
            ),
            Swatch::Dashed(EIP_COLOUR, 2),
        ));
    }
    let body = frame(root, "Joint entropy of the selected points", &entries)?;

    let n_max = id
        .entropy_curves
        .iter()
        .map(|c| c.joint_entropy_bits.len())
        .max()
        .unwrap_or(0)
        .max(id.eip.len())
        .max(1);
    let y_max = id
        .entropy_curves
        .iter()
        .flat_map(|c| c.joint_entropy_bits.iter().copied())
        .chain([log2n])
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max);
    let y_hi = if y_max > 0.0 { y_max * 1.1 } else { 1.0 };
    let mut chart = chart_builder(&body)
        .build_cartesian_2d(0.5..n_max as f64 + 0.5, 0.0..y_hi)
        .map_err(msg)?;
    draw_mesh(
        &mut chart,
        "number of points",
        "joint entropy (bits)",
        true,
        false,
    )?;

    if !id.eip.is_empty() {
        let x = id.eip.len() as f64;
        chart
            .plotting_area()
            .draw(&DashedPathElement::new(
                vec![(x, 0.0), (x, y_hi)],
                8,
                5,
                ShapeStyle::from(&EIP_COLOUR).stroke_width(2),
            ))
            .map_err(msg)?;
    }
    if log2n.is_finite() {
        chart
            .plotting_area()
            .draw(&DashedPathElement::new(
                vec![(0.5, log2n), (n_max as f64 + 0.5, log2n)],
                10,
                6,
                ShapeStyle::from(&REFERENCE_COLOUR).stroke_width(2),
            ))
            .map_err(msg)?;
    }
    let radius = if n_max > 40 { 2 } else { 4 };
    for (i, curve) in id.entropy_curves.iter().enumerate() {
        let colour = PALETTE[i % PALETTE.len()];
        let points = curve
            .joint_entropy_bits
            .iter()
            .enumerate()
            .map(|(k, &v)| ((k + 1) as f64, v));
        let runs = finite_runs(points.clone());
        chart
            .draw_series(
                runs.into_iter()
                    .map(|run| PathElement::new(run, ShapeStyle::from(&colour).stroke_width(3))),
            )
            .map_err(msg)?;
        chart
            .draw_series(
                points
                    .filter(|(_, v)| v.is_finite())
                    .map(|p| Circle::new(p, radius, colour.filled())),
            )
            .map_err(msg)?;
    }
    if log2n.is_finite() {
        let text = format!("log2 N = {} bits", fmt_num(log2n, 2));
        let font = annotation_font(&REFERENCE_COLOUR);
        let size = body.estimate_text_size(&text, &font).map_err(msg)?;
        draw_label(
            &chart,
            (0.5, log2n),
            &text,
            &font,
            (12, -(size.1 as i32) - 6),
            size,
        )?;
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------
// Figure 4: parallel coordinates of the CMS
// ---------------------------------------------------------------------------------------

/// One axis of the parallel-coordinates plot.
struct ParamAxis {
    name: &'static str,
    value: fn(&InstanceParams) -> f64,
    bounds: fn(&ParamRanges) -> [f64; 2],
}

const PARAM_AXES: [ParamAxis; 5] = [
    ParamAxis {
        name: "L (mm)",
        value: |p| p.length_mm,
        bounds: |r| r.length_mm,
    },
    ParamAxis {
        name: "d (mm)",
        value: |p| p.depth_mm,
        bounds: |r| r.depth_mm,
    },
    ParamAxis {
        name: "c (mm)",
        value: |p| p.curvature_mm,
        bounds: |r| r.curvature_mm,
    },
    ParamAxis {
        name: "X_p (m)",
        value: |p| p.impact_position_m,
        bounds: |r| r.impact_position_m,
    },
    ParamAxis {
        name: "L0 (mm)",
        value: |p| p.l0_mm,
        bounds: |r| r.l0_mm,
    },
];

/// `v` on the axis `[lo, hi]` mapped to 0…1 (0.5 for a degenerate axis).
fn normalise(v: f64, [lo, hi]: [f64; 2]) -> f64 {
    if hi - lo > 0.0 {
        (v - lo) / (hi - lo)
    } else {
        0.5
    }
}

/// The polyline of one instance across the axes.
fn instance_line(p: &InstanceParams, population: &ParamRanges) -> Vec<(f64, f64)> {
    PARAM_AXES
        .iter()
        .enumerate()
        .map(|(i, a)| (i as f64, normalise((a.value)(p), (a.bounds)(population))))
        .collect()
}

/// Tick values strictly inside `[lo, hi]` at a "nice" step (1, 2, 2.5 or 5 × 10^k, about four
/// intervals), leaving out ticks within 8 % of the ends (those carry the min and max labels).
fn inner_ticks(lo: f64, hi: f64) -> Vec<f64> {
    let span = hi - lo;
    if !(span > 0.0 && span.is_finite()) {
        return Vec::new();
    }
    let raw = span / 4.0;
    let p = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 2.5, 5.0, 10.0]
        .iter()
        .map(|m| m * p)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * p);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    (first..=last)
        .map(|k| k as f64 * step)
        .filter(|v| *v - lo > 0.08 * span && hi - *v > 0.08 * span)
        .collect()
}

fn render_parallel<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    id: &Identification,
) -> Result<(), String> {
    let n = id.cms.len();
    let rm = &id.residual_minimisation;
    let mut entries = Vec::with_capacity(2);
    if n > 0 {
        entries.push(Entry::new(
            format!("candidate model (CMS, {n} instances)"),
            Swatch::Line(CMS_COLOUR, 2),
        ));
    }
    entries.push(Entry::new(
        format!(
            "residual minimisation without uncertainties (instance {}, L0 = {} mm)",
            rm.instance,
            fmt_num(rm.l0_mm, 1)
        ),
        Swatch::Dashed(EIP_COLOUR, 3),
    ));
    let title = format!(
        "Identified parameters: {n} of {} instances not falsified",
        id.bank_instances
    );
    let mut body = frame(root, &title, &entries)?;
    if n == 0 {
        let (note, rest) = body.split_vertically(56);
        centred_note(&note, "empty CMS: model class refuted", EIP_COLOUR)?;
        body = rest;
    }
    let mut chart = ChartBuilder::on(&body)
        .margin_top(78)
        .margin_bottom(44)
        .margin_left(70)
        .margin_right(70)
        .build_cartesian_2d(-0.2..4.2, 0.0..1.0)
        .map_err(msg)?;

    let ticks: Vec<Vec<(f64, f64)>> = PARAM_AXES
        .iter()
        .map(|axis| {
            let [lo, hi] = (axis.bounds)(&id.population);
            inner_ticks(lo, hi)
                .into_iter()
                .map(|v| (v, normalise(v, [lo, hi])))
                .collect()
        })
        .collect();

    let alpha = match n {
        0..=60 => 0.9,
        61..=600 => 0.45,
        _ => 0.15,
    };
    let cms_style = ShapeStyle::from(&CMS_COLOUR.mix(alpha)).stroke_width(2);
    chart
        .draw_series(
            id.cms
                .iter()
                .flat_map(|p| finite_runs(instance_line(p, &id.population).into_iter()))
                .map(|run| PathElement::new(run, cms_style)),
        )
        .map_err(msg)?;
    chart
        .draw_series(
            finite_runs(instance_line(rm, &id.population).into_iter())
                .into_iter()
                .map(|run| {
                    DashedPathElement::new(
                        run,
                        12,
                        7,
                        ShapeStyle::from(&EIP_COLOUR).stroke_width(3),
                    )
                }),
        )
        .map_err(msg)?;

    // Axes on top, with tick marks; min and max in real units at the ends, the name above.
    let axis_style = ShapeStyle::from(&BLACK).stroke_width(2);
    let name_font = TextStyle::from((FONT, CAPTION_SIZE).into_font()).color(&BLACK);
    let end_font = TextStyle::from((FONT, LEGEND_SIZE).into_font()).color(&BLACK);
    let tick_font = TextStyle::from((FONT, 16).into_font()).color(&RGBColor(80, 80, 80));
    for (i, axis) in PARAM_AXES.iter().enumerate() {
        let x = i as f64;
        let [lo, hi] = (axis.bounds)(&id.population);
        let span = hi - lo;
        chart
            .plotting_area()
            .draw(&PathElement::new(vec![(x, 0.0), (x, 1.0)], axis_style))
            .map_err(msg)?;
        let marks = [0.0, 1.0]
            .into_iter()
            .chain(ticks[i].iter().map(|&(_, y)| y))
            .map(|y| {
                EmptyElement::at((x, y)) + PathElement::new(vec![(-6, 0), (6, 0)], axis_style)
            });
        for mark in marks {
            chart.plotting_area().draw(&mark).map_err(msg)?;
        }
        // Inner tick labels left of the axis, on a white backing so that they stay readable
        // under many instance lines.
        for &(v, y) in &ticks[i] {
            let text = format_tick(v);
            let size = body.estimate_text_size(&text, &tick_font).map_err(msg)?;
            let offset = (-(size.0 as i32) - 11, -(size.1 as i32) / 2);
            draw_label(&chart, (x, y), &text, &tick_font, offset, size)?;
        }
        let max_text = fmt_axis(hi, span);
        let size = body.estimate_text_size(&max_text, &end_font).map_err(msg)?;
        draw_label(
            &chart,
            (x, 1.0),
            &max_text,
            &end_font,
            (-(size.0 as i32) / 2, -(size.1 as i32) - 10),
            size,
        )?;
        let max_h = size.1 as i32;
        let size = body
            .estimate_text_size(axis.name, &name_font)
            .map_err(msg)?;
        draw_label(
            &chart,
            (x, 1.0),
            axis.name,
            &name_font,
            (-(size.0 as i32) / 2, -max_h - size.1 as i32 - 22),
            size,
        )?;
        let min_text = fmt_axis(lo, span);
        let size = body.estimate_text_size(&min_text, &end_font).map_err(msg)?;
        draw_label(
            &chart,
            (x, 0.0),
            &min_text,
            &end_font,
            (-(size.0 as i32) / 2, 10),
            size,
        )?;
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------
// Figure 5: CMS sizes over random subsets
// ---------------------------------------------------------------------------------------

/// A "nice" bin width (1, 2 or 5 × 10^k) at least `raw`, and at least 1.
fn nice_width(raw: f64) -> usize {
    if !(raw.is_finite() && raw > 1.0) {
        return 1;
    }
    let p = 10f64.powf(raw.log10().floor());
    let w = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * p)
        .find(|w| *w >= raw)
        .unwrap_or(10.0 * p);
    w.ceil() as usize
}

fn render_random_subsets<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    id: &Identification,
) -> Result<(), String> {
    let Some(rs) = &id.random_subsets else {
        return centred_note(root, "no random subsets drawn", PIP_COLOUR);
    };
    let eip_count = id.cms.len();
    let entries = [
        Entry::new(
            format!(
                "random subsets ({} draws of {} PIP)",
                rs.cms_counts.len(),
                rs.size
            ),
            Swatch::Bar(BAR_COLOUR),
        ),
        Entry::new(
            format!("EIP: CMS of {eip_count}"),
            Swatch::Line(EIP_COLOUR, 3),
        ),
        Entry::new(
            format!("mean of random subsets: {}", fmt_num(rs.mean, 1)),
            Swatch::Dashed(REFERENCE_COLOUR, 2),
        ),
    ];
    let body = frame(root, "CMS size with random comparison points", &entries)?;
    if rs.cms_counts.is_empty() {
        return centred_note(&body, "no random subsets drawn", PIP_COLOUR);
    }

    let top = rs
        .cms_counts
        .iter()
        .copied()
        .max()
        .unwrap_or(0)
        .max(eip_count)
        .max(if rs.mean.is_finite() && rs.mean > 0.0 {
            rs.mean.ceil() as usize
        } else {
            0
        });
    let width = nice_width((top + 1) as f64 / 30.0);
    let bins = top / width + 1;
    let mut heights = vec![0usize; bins];
    for &c in &rs.cms_counts {
        heights[(c / width).min(bins - 1)] += 1;
    }
    let y_hi = heights.iter().copied().max().unwrap_or(1).max(1) as f64 * 1.12;
    let x_lo = -0.5;
    let x_hi = (bins * width) as f64 - 0.5;
    let pad = 0.01 * (x_hi - x_lo);
    let mut chart = chart_builder(&body)
        .build_cartesian_2d(x_lo - pad..x_hi + pad, 0.0..y_hi)
        .map_err(msg)?;
    draw_mesh(
        &mut chart,
        "CMS size (instances)",
        "number of subsets",
        true,
        true,
    )?;

    let outline = ShapeStyle::from(&WHITE).stroke_width(1);
    for (b, &h) in heights.iter().enumerate() {
        if h == 0 {
            continue;
        }
        let corners = [
            ((b * width) as f64 - 0.5, 0.0),
            (((b + 1) * width) as f64 - 0.5, h as f64),
        ];
        chart
            .plotting_area()
            .draw(&Rectangle::new(corners, BAR_COLOUR.filled()))
            .map_err(msg)?;
        chart
            .plotting_area()
            .draw(&Rectangle::new(corners, outline))
            .map_err(msg)?;
    }
    let x = eip_count as f64;
    chart
        .plotting_area()
        .draw(&PathElement::new(
            vec![(x, 0.0), (x, y_hi)],
            ShapeStyle::from(&EIP_COLOUR).stroke_width(3),
        ))
        .map_err(msg)?;
    if rs.mean.is_finite() {
        chart
            .plotting_area()
            .draw(&DashedPathElement::new(
                vec![(rs.mean, 0.0), (rs.mean, y_hi)],
                10,
                6,
                ShapeStyle::from(&REFERENCE_COLOUR).stroke_width(2),
            ))
            .map_err(msg)?;
    }
    Ok(())
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

/// Turns a plotting error into its message.
fn msg(e: impl std::fmt::Display) -> String {
    e.to_string()
}

// ---------------------------------------------------------------------------------------
// HTML
// ---------------------------------------------------------------------------------------

/// Escapes `&`, `<`, `>`, `"` and `'` for HTML text and attribute values.
fn escape_html(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + s.len() / 8);
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            other => out.push(other),
        }
    }
    out
}

/// An SVG document made ready to inline in HTML: no XML prolog, doctype or leading comments,
/// no namespace attribute (implied in HTML), and an accessible label.
fn inline_svg(svg: &str, label: &str) -> String {
    let mut s = svg.trim_start();
    while s.starts_with("<?") || s.starts_with("<!") {
        let end = if s.starts_with("<!--") {
            s.find("-->").map(|i| i + 3)
        } else {
            s.find('>').map(|i| i + 1)
        };
        match end {
            Some(end) => s = s[end..].trim_start(),
            None => break,
        }
    }
    let s = s.replacen(" xmlns=\"http://www.w3.org/2000/svg\"", "", 1);
    s.replacen(
        "<svg",
        &format!("<svg role=\"img\" aria-label=\"{}\"", escape_html(label)),
        1,
    )
}

/// Plain CSS of the report.
const CSS: &str = r#"
:root { color-scheme: light; }
body { font-family: system-ui, -apple-system, "Segoe UI", "DejaVu Sans", Arial, sans-serif;
       margin: 0; background: #eef0f3; color: #1d232a; line-height: 1.5; font-size: 16px; }
main { max-width: 1180px; margin: 0 auto; padding: 20px 36px 40px; background: #fff;
       box-shadow: 0 0 12px rgba(0, 0, 0, 0.06); }
h1 { font-size: 1.9rem; margin: 0.3em 0 0.1em; }
h2 { font-size: 1.35rem; margin: 1.8em 0 0.6em; padding-bottom: 0.2em;
     border-bottom: 2px solid #e3e6ea; }
h3 { font-size: 1.1rem; margin: 1.4em 0 0.4em; }
p { max-width: 75em; }
.meta { color: #555; margin-top: 0; }
.verdict { border-left: 6px solid #2c7a3f; background: #f1f8f3; padding: 0.5em 1.2em; }
.verdict.refuted { border-left-color: #c0392b; background: #fdf1ef; }
.hint { border-left: 6px solid #d98c00; background: #fff8e8; padding: 0.6em 1.2em; }
table { border-collapse: collapse; margin: 0.6em 0 1em; font-size: 0.95rem; }
th, td { border-bottom: 1px solid #e3e6ea; padding: 0.3em 0.9em; text-align: left;
         vertical-align: top; }
thead th { background: #f0f2f5; border-bottom: 2px solid #d5d9de; }
td.num, th.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
table.kv th { font-weight: 600; white-space: nowrap; }
tr.total td { font-weight: 600; border-top: 2px solid #d5d9de; }
figure { margin: 1.2em 0 1.8em; }
figure svg { display: block; width: 100%; height: auto; border: 1px solid #e3e6ea; }
figcaption { color: #444; font-size: 0.92rem; margin-top: 0.4em; }
code { font-size: 0.92em; background: #f0f2f5; padding: 0 0.3em; border-radius: 3px;
       overflow-wrap: anywhere; }
details > summary { cursor: pointer; margin: 0.5em 0; }
footer { color: #777; font-size: 0.85rem; margin-top: 3em; }
@media print {
  body { background: #fff; }
  main { box-shadow: none; }
  figure, table { break-inside: avoid; }
}
"#;

/// Parameter ranges over a set of instances (none when empty).
fn ranges_of(instances: &[InstanceParams]) -> Option<ParamRanges> {
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

/// The whole HTML report; `figures` are the rendered SVGs.
fn render_html(id: &Identification, figures: &[(Figure, String)]) -> Result<String, fmt::Error> {
    let e = escape_html;
    let mut h =
        String::with_capacity(64 * 1024 + figures.iter().map(|(_, s)| s.len()).sum::<usize>());
    let mut fig_no = 0;
    let mut figure = |h: &mut String, fig: Figure| -> fmt::Result {
        if let Some((_, svg)) = figures.iter().find(|(f, _)| *f == fig) {
            fig_no += 1;
            writeln!(
                h,
                "<figure id=\"fig-{name}\">\n{svg}<figcaption><strong>Figure {fig_no}.</strong> {caption}</figcaption>\n</figure>",
                name = fig.name(),
                svg = inline_svg(svg, fig.caption()),
                caption = e(fig.caption()),
            )?;
        }
        Ok(())
    };

    writeln!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">"
    )?;
    writeln!(
        h,
        "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">"
    )?;
    writeln!(
        h,
        "<title>Wheel-flat identification – {}</title>",
        e(&id.measurement)
    )?;
    writeln!(h, "<style>{CSS}</style>\n</head>\n<body>\n<main>")?;

    // Header and verdict.
    writeln!(h, "<h1>Wheel-flat identification</h1>")?;
    writeln!(
        h,
        "<p class=\"meta\">Measurement <code>{}</code> · model bank <code>{}</code> ({} instances)</p>",
        e(&id.measurement),
        e(&id.bank_id),
        id.bank_instances
    )?;
    let refuted = if id.model_class_refuted {
        " refuted"
    } else {
        ""
    };
    writeln!(
        h,
        "<section class=\"verdict{refuted}\">\n<h2>Result</h2>\n<p>{}</p>\n</section>",
        e(&id.summary)
    )?;
    writeln!(
        h,
        "<p class=\"hint\"><strong>Maintenance:</strong> {}</p>",
        e(&id.maintenance_hint)
    )?;

    writeln!(h, "<table class=\"kv\">\n<tbody>")?;
    let share = if id.bank_instances > 0 {
        format!(
            " ({} %)",
            fmt_num(100.0 * id.cms.len() as f64 / id.bank_instances as f64, 3)
        )
    } else {
        String::new()
    };
    writeln!(
        h,
        "<tr><th>Candidate model set</th><td>{} of {} instances{share}</td></tr>",
        id.cms.len(),
        id.bank_instances
    )?;
    if id.model_class_refuted {
        writeln!(
            h,
            "<tr><th>Model class</th><td>refuted: every instance was falsified</td></tr>"
        )?;
    }
    if let Some(r) = ranges_of(&id.cms) {
        for (name, range, decimals) in [
            ("Fresh-flat length L0", r.l0_mm, 1),
            ("Flat length L", r.length_mm, 1),
            ("Flat depth d", r.depth_mm, 3),
            ("Curvature c", r.curvature_mm, 3),
            ("Impact position X_p", r.impact_position_m, 3),
        ] {
            let unit = if name.ends_with("X_p") { "m" } else { "mm" };
            writeln!(
                h,
                "<tr><th>{}</th><td>{} {unit}</td></tr>",
                e(name),
                fmt_range(range, decimals)
            )?;
        }
    }
    let rm = &id.residual_minimisation;
    writeln!(
        h,
        "<tr><th>Residual minimisation</th><td>L0 = {} mm (instance {}, no uncertainties)</td></tr>",
        fmt_num(rm.l0_mm, 1),
        rm.instance
    )?;
    writeln!(h, "</tbody>\n</table>")?;

    // Measurement and alignment.
    writeln!(h, "<h2>Measurement and alignment</h2>")?;
    let a = &id.alignment;
    writeln!(h, "<table class=\"kv\">\n<tbody>")?;
    writeln!(h, "<tr><th>Alignment</th><td>{}</td></tr>", e(&a.method))?;
    writeln!(
        h,
        "<tr><th>Shift</th><td>{} ms (bank time = measurement time + shift)</td></tr>",
        fmt_num(1e3 * a.shift_s, 3)
    )?;
    if let Some(c) = a.correlation {
        writeln!(
            h,
            "<tr><th>Correlation at the shift</th><td>{}</td></tr>",
            fmt_num(c, 4)
        )?;
    }
    writeln!(h, "</tbody>\n</table>")?;
    writeln!(
        h,
        "<table>\n<thead><tr><th>Sensor</th><th class=\"num\">Samples</th><th class=\"num\">Rate (Hz)</th>\
         <th class=\"num\">Window (s)</th><th class=\"num\">Peak (kN)</th></tr></thead>\n<tbody>"
    )?;
    for s in &id.series {
        let n = s.values_kn.len();
        let end = if s.sample_rate_hz > 0.0 && n > 0 {
            s.t0_s + (n - 1) as f64 / s.sample_rate_hz
        } else {
            s.t0_s
        };
        let peak = s
            .values_kn
            .iter()
            .copied()
            .filter(|v| v.is_finite())
            .fold(f64::NAN, f64::max);
        writeln!(
            h,
            "<tr><td>{}</td><td class=\"num\">{n}</td><td class=\"num\">{}</td><td class=\"num\">{} – {}</td><td class=\"num\">{}</td></tr>",
            e(&s.sensor),
            fmt_num(s.sample_rate_hz, 0),
            fmt_num(s.t0_s, 4),
            fmt_num(end, 4),
            fmt_num(peak, 1)
        )?;
    }
    writeln!(h, "</tbody>\n</table>")?;
    figure(&mut h, Figure::Series)?;

    // Comparison points.
    writeln!(h, "<h2>Comparison points</h2>")?;
    writeln!(h, "<table class=\"kv\">\n<tbody>")?;
    writeln!(
        h,
        "<tr><th>PIP</th><td>{} per series ({} distance), {} in all</td></tr>",
        id.pips_per_series,
        e(&id.pip_distance),
        id.candidates.len()
    )?;
    let final_h = id
        .eip_joint_entropy_bits
        .last()
        .copied()
        .unwrap_or(f64::NAN);
    writeln!(
        h,
        "<tr><th>EIP</th><td>{} selected; joint entropy {} bits (stop threshold α = {} bits)</td></tr>",
        id.eip.len(),
        fmt_num(final_h, 2),
        fmt_num(id.alpha_bits, 3)
    )?;
    if id.bank_instances > 0 {
        writeln!(
            h,
            "<tr><th>log2 N</th><td>{} bits (the most any set of points can tell apart)</td></tr>",
            fmt_num((id.bank_instances as f64).log2(), 2)
        )?;
    }
    writeln!(
        h,
        "<tr><th>Identification probability φ</th><td>{} (Šídák: {} per point)</td></tr>",
        fmt_num(id.phi, 3),
        fmt_num(id.per_point_probability, 5)
    )?;
    writeln!(h, "</tbody>\n</table>")?;
    writeln!(
        h,
        "<table>\n<thead><tr><th class=\"num\">Order</th><th class=\"num\">PIP</th><th>Sensor</th>\
         <th class=\"num\">Time (s)</th><th class=\"num\">Measured (kN)</th><th class=\"num\">Entropy (bits)</th>\
         <th class=\"num\">Joint entropy (bits)</th><th class=\"num\">Thresholds (kN)</th>\
         <th class=\"num\">Typical cell widening ± (kN)</th><th class=\"num\">Admissible predictions before widening (kN)</th></tr></thead>\n<tbody>"
    )?;
    for (k, &ci) in id.eip.iter().enumerate() {
        let joint = id
            .eip_joint_entropy_bits
            .get(k)
            .copied()
            .unwrap_or(f64::NAN);
        match id.candidates.get(ci) {
            Some(c) => {
                let sensor = id.series.get(c.series).map_or("?", |s| s.sensor.as_str());
                writeln!(
                    h,
                    "<tr><td class=\"num\">{}</td><td class=\"num\">{ci}</td><td>{}</td><td class=\"num\">{}</td>\
                     <td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td>\
                     <td class=\"num\">{}</td><td class=\"num\">{}</td></tr>",
                    k + 1,
                    e(sensor),
                    fmt_num(c.time_s, 5),
                    fmt_num(c.measured_kn, 2),
                    fmt_num(c.entropy_bits, 2),
                    fmt_num(joint, 2),
                    fmt_range([c.threshold_low_kn, c.threshold_high_kn], 2),
                    fmt_num(c.resolution_kn, 2),
                    fmt_range(
                        [c.measured_kn + c.threshold_low_kn, c.measured_kn + c.threshold_high_kn],
                        2
                    ),
                )?;
            }
            None => writeln!(
                h,
                "<tr><td class=\"num\">{}</td><td class=\"num\">{ci}</td><td colspan=\"8\">not a candidate point</td></tr>",
                k + 1
            )?,
        }
    }
    writeln!(h, "</tbody>\n</table>")?;
    figure(&mut h, Figure::Entropy)?;
    figure(&mut h, Figure::JointEntropy)?;

    // Falsification.
    writeln!(h, "<h2>Falsification</h2>")?;
    writeln!(
        h,
        "<table>\n<thead><tr><th>Comparison points</th><th class=\"num\">Points</th><th class=\"num\">CMS</th>\
         <th class=\"num\">L0 (mm)</th><th class=\"num\">L (mm)</th><th class=\"num\">d (mm)</th></tr></thead>\n<tbody>"
    )?;
    for f in &id.falsifications {
        let (l0, l, d) = match &f.ranges {
            Some(r) => (
                fmt_range(r.l0_mm, 1),
                fmt_range(r.length_mm, 1),
                fmt_range(r.depth_mm, 3),
            ),
            None => ("–".to_string(), "–".to_string(), "–".to_string()),
        };
        writeln!(
            h,
            "<tr><td>{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{l0}</td>\
             <td class=\"num\">{l}</td><td class=\"num\">{d}</td></tr>",
            e(&f.method),
            f.points,
            f.cms_count
        )?;
    }
    writeln!(h, "</tbody>\n</table>")?;
    figure(&mut h, Figure::ParallelCoordinates)?;

    writeln!(h, "<h3>Residual minimisation without uncertainties</h3>")?;
    writeln!(
        h,
        "<p>The instance that minimises the residual over the EIP, ignoring uncertainties \
         (paper §4.4); compare its L0 with the CMS range.</p>"
    )?;
    write_instances(&mut h, std::slice::from_ref(rm))?;

    if !id.cms.is_empty() {
        const MAX_ROWS: usize = 500;
        writeln!(
            h,
            "<details>\n<summary>Candidate model set: {} instances{}</summary>",
            id.cms.len(),
            if id.cms.len() > MAX_ROWS {
                format!(" (first {MAX_ROWS} shown; all are in identification.json)")
            } else {
                String::new()
            }
        )?;
        write_instances(&mut h, &id.cms[..id.cms.len().min(MAX_ROWS)])?;
        writeln!(h, "</details>")?;
    }

    // Random subsets.
    writeln!(h, "<h2>Random comparison points</h2>")?;
    match &id.random_subsets {
        Some(rs) => {
            let eip_count = id.cms.len();
            writeln!(h, "<table class=\"kv\">\n<tbody>")?;
            writeln!(
                h,
                "<tr><th>Subsets</th><td>{} draws of {} points from the {} PIP (seed {})</td></tr>",
                rs.subsets,
                rs.size,
                id.candidates.len(),
                rs.seed
            )?;
            writeln!(
                h,
                "<tr><th>CMS size</th><td>mean {}, median {}; with the EIP: {eip_count}</td></tr>",
                fmt_num(rs.mean, 1),
                fmt_num(rs.median, 1)
            )?;
            if !rs.cms_counts.is_empty() {
                let at_most = rs.cms_counts.iter().filter(|&&c| c <= eip_count).count();
                writeln!(
                    h,
                    "<tr><th>Subsets as good as the EIP</th><td>{at_most} of {} ({} %) have a CMS of at most {eip_count}</td></tr>",
                    rs.cms_counts.len(),
                    fmt_num(100.0 * at_most as f64 / rs.cms_counts.len() as f64, 1)
                )?;
            }
            writeln!(h, "</tbody>\n</table>")?;
            figure(&mut h, Figure::RandomSubsets)?;
        }
        None => writeln!(h, "<p>Not computed for this identification.</p>")?,
    }

    // Timings.
    writeln!(h, "<h2>Timings</h2>")?;
    writeln!(h, "<table>\n<thead><tr><th>Stage</th><th class=\"num\">Wall-clock (ms)</th></tr></thead>\n<tbody>")?;
    for (stage, ms) in &id.timings_ms {
        writeln!(
            h,
            "<tr><td>{}</td><td class=\"num\">{}</td></tr>",
            e(stage),
            fmt_num(*ms, 1)
        )?;
    }
    let total: f64 = id.timings_ms.iter().map(|(_, ms)| ms).sum();
    writeln!(
        h,
        "<tr class=\"total\"><td>total</td><td class=\"num\">{}</td></tr>",
        fmt_num(total, 1)
    )?;
    writeln!(h, "</tbody>\n</table>")?;

    writeln!(
        h,
        "<footer>wheelflat {} · error-domain model falsification after Cao et al. · \
         the full result is in <code>{JSON_FILE}</code> next to this file.</footer>",
        env!("CARGO_PKG_VERSION")
    )?;
    writeln!(h, "</main>\n</body>\n</html>")?;
    Ok(h)
}

/// A table of instances (parameters in real units).
fn write_instances(h: &mut String, instances: &[InstanceParams]) -> fmt::Result {
    writeln!(
        h,
        "<table>\n<thead><tr><th class=\"num\">Instance</th><th class=\"num\">L (mm)</th><th class=\"num\">d (mm)</th>\
         <th class=\"num\">c (mm)</th><th class=\"num\">X_p (m)</th><th class=\"num\">L0 (mm)</th></tr></thead>\n<tbody>"
    )?;
    for p in instances {
        writeln!(
            h,
            "<tr><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td>\
             <td class=\"num\">{}</td><td class=\"num\">{}</td></tr>",
            p.instance,
            fmt_num(p.length_mm, 1),
            fmt_num(p.depth_mm, 3),
            fmt_num(p.curvature_mm, 3),
            fmt_num(p.impact_position_m, 3),
            fmt_num(p.l0_mm, 1)
        )?;
    }
    writeln!(h, "</tbody>\n</table>")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::result::{
        Alignment, CandidatePoint, EntropyCurve, Falsification, MeasuredSeries, RandomSubsets,
    };

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
        q(
            4.0 + 55.0 * g(0.018, 0.006)
                + 70.0 * g(impact, 0.0012)
                + 45.0 * g(0.046, 0.006)
                + ripple,
        )
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
                    ranges: ranges_of(&cms),
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
            maintenance_hint:
                "Remove the wheelset from service within 24 h (GM/RT2466: L0 > 50 mm).".into(),
            timings_ms: vec![
                ("load".into(), 12.5),
                ("pip".into(), 0.8),
                ("entropy".into(), 310.2),
                ("falsify".into(), 95.0),
            ],
        }
    }

    fn dir_entries(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = fs::read_dir(dir)
            .expect("read dir")
            .map(|e| {
                e.expect("dir entry")
                    .file_name()
                    .to_string_lossy()
                    .into_owned()
            })
            .collect();
        names.sort();
        names
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
    fn escaping_and_inlining() {
        assert_eq!(
            escape_html(r#"a<b & "c" 'd'>"#),
            "a&lt;b &amp; &quot;c&quot; &#39;d&#39;&gt;"
        );
        let svg = "<?xml version=\"1.0\"?>\n<!-- x > y -->\n<svg width=\"1\" xmlns=\"http://www.w3.org/2000/svg\"></svg>";
        assert_eq!(
            inline_svg(svg, "a<b"),
            "<svg role=\"img\" aria-label=\"a&lt;b\" width=\"1\"></svg>"
        );
    }

    #[test]
    fn helpers() {
        assert_eq!(nice_width(0.3), 1);
        assert_eq!(nice_width(1.4), 2);
        assert_eq!(nice_width(3.2), 5);
        assert_eq!(nice_width(14.0), 20);
        assert_eq!(fmt_num(-0.0001, 2), "0.00");
        assert_eq!(fmt_num(f64::NAN, 2), "–");
        assert_eq!(fmt_range([41.04, 54.0], 1), "41.0 – 54.0");
        assert_eq!(format_tick(0.0150), "0.015");
        assert_eq!(format_tick(-0.0), "0");
        assert_eq!(panel_letter(1), "b");
        assert_eq!(fmt_axis(2.0, 1.9), "2");
        assert_eq!(fmt_axis(17.888, 62.1), "17.9");
        assert_eq!(fmt_axis(120.0, 100.0), "120");
        assert!((normalise(5.0, [0.0, 10.0]) - 0.5).abs() < 1e-12);
        assert!((normalise(5.0, [1.0, 1.0]) - 0.5).abs() < 1e-12);
        let ticks: Vec<String> = inner_ticks(0.1, 2.0).into_iter().map(format_tick).collect();
        assert_eq!(ticks, ["0.5", "1", "1.5"]);
        let ticks: Vec<String> = inner_ticks(17.9, 80.0)
            .into_iter()
            .map(format_tick)
            .collect();
        assert_eq!(ticks, ["40", "60"]);
        assert!(inner_ticks(1.0, 1.0).is_empty());
    }
}
