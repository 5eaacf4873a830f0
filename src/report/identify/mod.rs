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

use crate::report::canvas::DrawResult;
use std::fmt;
use std::fs;
use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;

use super::canvas::{ensure_font, msg, render_png, PlotError};
use crate::identify::answer::identification::Identification;
use layout::*;

mod detection;
mod entropy;
mod html;
mod layout;
mod parallel;
mod series;
mod subsets;
#[cfg(test)]
mod tests;

/// File name of the JSON result inside the report folder.
pub use crate::identify::json::JSON_FILE;
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
    /// The identification could not be serialised to JSON (`identification.json`, written
    /// beside the result: [`crate::identify::json`]).
    #[error(transparent)]
    Json(crate::identify::json::WriteError),
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

impl From<crate::identify::json::WriteError> for ReportError {
    fn from(e: crate::identify::json::WriteError) -> ReportError {
        use crate::identify::json::WriteError;
        match e {
            WriteError::Io { path, source } => ReportError::Io { path, source },
            e @ WriteError::Json { .. } => ReportError::Json(e),
        }
    }
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

    /// Whether `id` has the data for this figure: the series always; the detection when
    /// its sensors' flat-free predictions are there; the points, the entropies and the
    /// candidate model set only for a sized pass ([`Identification::sizing`]); the random
    /// subsets only when they were computed.
    pub fn is_available(self, id: &Identification) -> bool {
        match self {
            Figure::Series => true,
            Figure::Detection => detection::is_available(id),
            Figure::Entropy | Figure::JointEntropy | Figure::ParallelCoordinates => {
                id.sizing.is_some()
            }
            Figure::RandomSubsets => id
                .sizing
                .as_ref()
                .is_some_and(|z| z.random_subsets.is_some()),
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
    let json = id.write_json(dir)?;
    let (figures, html) = write_figures_and_html(id, dir)?;
    Ok(ReportFiles {
        json,
        html,
        figures,
    })
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

/// The sizing a figure of it draws (checked by [`Figure::is_available`] before).
fn sized(id: &Identification) -> Result<&crate::identify::Sizing, String> {
    id.sizing
        .as_ref()
        .ok_or_else(|| "the pass was not sized (no flat detected)".to_string())
}

/// Draws the whole of `fig` on `root`.
fn render<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    id: &Identification,
    fig: Figure,
) -> DrawResult {
    root.fill(&WHITE).map_err(msg)?;
    match fig {
        Figure::Series => series::render_series(root, id),
        Figure::Detection => detection::render_detection(root, id),
        Figure::Entropy => entropy::render_entropy(root, id, sized(id)?),
        Figure::JointEntropy => entropy::render_joint_entropy(root, id, sized(id)?),
        Figure::ParallelCoordinates => parallel::render_parallel(root, id, sized(id)?),
        Figure::RandomSubsets => subsets::render_random_subsets(root, sized(id)?),
    }
}
