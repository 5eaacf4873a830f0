//! What every figure and page of the report shares: the embedded font and text sizes, the
//! colours, data ranges and gap-aware lines, label placement, tick and number formatting,
//! the one HTML escaper, and PNG figures written atomically (through
//! [`crate::atomic::temporary_sibling`], then renamed into place).

use std::fs;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::{register_font, FontStyle};

/// The embedded font, registered as the `sans-serif` family (there is no system font lookup).
static FONT_BYTES: &[u8] = include_bytes!(concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/assets/DejaVuSans.ttf"
));

/// Font family used for every text in the figures.
/// What drawing a figure returns. The error is plotters' message as text: plotters' errors are
/// generic over the drawing backend (`DrawingAreaErrorKind<B::ErrorType>`), and the only thing
/// done with one is to print it under the name of the file being drawn (`ReportError`).
pub(crate) type DrawResult<T = ()> = Result<T, String>;

pub(crate) const FONT: &str = "sans-serif";

/// Size of legend labels (pixels).
pub(crate) const LEGEND_SIZE: u32 = 18;

/// Distinct line colours (the matplotlib "tab10" palette).
pub(crate) const TAB10: [RGBColor; 10] = [
    TAB_BLUE,
    TAB_ORANGE,
    TAB_GREEN,
    TAB_RED,
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];
/// "tab10" blue: measured or main lines.
pub(crate) const TAB_BLUE: RGBColor = RGBColor(31, 119, 180);
/// "tab10" orange: bands and second lines.
pub(crate) const TAB_ORANGE: RGBColor = RGBColor(255, 127, 14);
/// "tab10" green: what passes.
pub(crate) const TAB_GREEN: RGBColor = RGBColor(44, 160, 44);
/// "tab10" red: what falsifies or is selected.
pub(crate) const TAB_RED: RGBColor = RGBColor(214, 39, 40);
/// Light grid lines of the single-figure plots.
pub(crate) const GRID_LIGHT: RGBColor = RGBColor(235, 235, 235);
/// Bold grid lines.
pub(crate) const GRID_BOLD: RGBColor = RGBColor(205, 205, 205);

/// Errors from drawing a figure. Every variant names the file that was to be written.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The path does not end in `.png` or `.svg`.
    #[error("{}: unsupported plot format (the file name must end in .png or .svg)", path.display())]
    UnsupportedExtension {
        /// The requested output path.
        path: PathBuf,
    },
    /// The data cannot be plotted (empty or non-finite time axis, mismatched lengths).
    #[error("{}: cannot plot the data: {message}", path.display())]
    InvalidData {
        /// The requested output path.
        path: PathBuf,
        /// What is wrong with the data.
        message: String,
    },
    /// The embedded font could not be registered with the plotting library.
    #[error("{}: the embedded font assets/DejaVuSans.ttf could not be loaded", path.display())]
    Font {
        /// The requested output path.
        path: PathBuf,
    },
    /// The plotting library failed while drawing or encoding the figure.
    #[error("{}: drawing the plot failed: {message}", path.display())]
    Draw {
        /// The requested output path.
        path: PathBuf,
        /// The plotting library's error message.
        message: String,
    },
    /// Writing or renaming the output file failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file being written.
        path: PathBuf,
        /// The underlying I/O error.
        #[source]
        source: std::io::Error,
    },
}

/// Registers the embedded font once; returns whether it is available.
pub(crate) fn ensure_font() -> bool {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    *REGISTERED.get_or_init(|| register_font(FONT, FontStyle::Normal, FONT_BYTES).is_ok())
}

/// Style of legend labels: [`LEGEND_SIZE`], black.
pub(crate) fn legend_font() -> TextStyle<'static> {
    TextStyle::from((FONT, LEGEND_SIZE).into_font()).color(&BLACK)
}

/// Width and height in pixels of `text` set in `font` on `area`.
pub(crate) fn text_size<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    text: &str,
    font: &TextStyle,
) -> DrawResult<(u32, u32)> {
    area.estimate_text_size(text, font).map_err(msg)
}

/// Width in pixels of `text` set in `font` on `area`.
pub(crate) fn text_width<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    text: &str,
    font: &TextStyle,
) -> DrawResult<u32> {
    text_size(area, text, font).map(|(w, _)| w)
}

/// Turns a plotting error into its message.
pub(crate) fn msg(e: impl std::fmt::Display) -> String {
    e.to_string()
}

/// Draws a PNG of `size` at `path` with `draw` (on a white background): to
/// [`crate::atomic::temporary_sibling`] (unique per process and call, so two writers of one
/// file never share a temporary), then renamed into place. On error the temporary is removed
/// and an existing file at `path` is untouched. Checks the font first.
///
/// # Errors
/// [`PlotError::Font`], [`PlotError::Draw`] (drawing or encoding failed, the folder is
/// missing) or [`PlotError::Io`] (the rename failed), each naming `path`.
pub(crate) fn render_png(
    path: &Path,
    size: (u32, u32),
    draw: impl FnOnce(&DrawingArea<BitMapBackend, Shift>) -> DrawResult,
) -> Result<(), PlotError> {
    if !ensure_font() {
        return Err(PlotError::Font {
            path: path.to_path_buf(),
        });
    }
    let tmp = crate::atomic::temporary_sibling(path);
    let result = (|| -> DrawResult {
        let root = BitMapBackend::new(&tmp, size).into_drawing_area();
        root.fill(&WHITE).map_err(msg)?;
        draw(&root)?;
        root.present().map_err(msg)
    })();
    if let Err(message) = result {
        // Best effort: the temporary may not exist if drawing failed before saving.
        let _ = fs::remove_file(&tmp);
        return Err(PlotError::Draw {
            path: path.to_path_buf(),
            message,
        });
    }
    fs::rename(&tmp, path).map_err(|source| {
        let _ = fs::remove_file(&tmp);
        PlotError::Io {
            path: path.to_path_buf(),
            source,
        }
    })
}

/// Draws an SVG of `size` with `draw` (on a white background) into a string, for a page
/// that embeds it. Checks the font first (legends are measured with it).
pub(crate) fn render_svg(
    size: (u32, u32),
    draw: impl FnOnce(&DrawingArea<SVGBackend, Shift>) -> DrawResult,
) -> DrawResult<String> {
    if !ensure_font() {
        return Err("the embedded font could not be registered".into());
    }
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, size).into_drawing_area();
        root.fill(&WHITE).map_err(msg)?;
        draw(&root)?;
        root.present().map_err(msg)?;
    }
    Ok(out)
}

/// Escapes `&`, `<`, `>`, `"` and `'` for HTML text and attribute values: the one escaper
/// of every page the report writes.
pub(crate) fn escape_html(s: &str) -> String {
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

/// Smallest and largest finite value, if any.
pub(crate) fn min_max(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    values
        .filter(|v| v.is_finite())
        .fold(None, |acc, v| match acc {
            None => Some((v, v)),
            Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
        })
}

/// `range` widened by `frac` of its span on each side; degenerate or missing ranges get a
/// unit span.
pub(crate) fn pad_range(range: Option<(f64, f64)>, frac: f64) -> (f64, f64) {
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

/// The (x, y) points split into runs of finite points, so gaps break the line.
pub(crate) fn finite_runs(points: impl Iterator<Item = (f64, f64)>) -> Vec<Vec<(f64, f64)>> {
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

/// A tick label: as few decimals as the value needs (up to 6), no trailing zeros.
pub(crate) fn format_tick(v: f64) -> String {
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

/// A chart with `f64` axes.
pub(crate) type Chart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Draws `text` with a white backing box, its top-left corner `offset` pixels from the data
/// point `at`.
pub(crate) fn draw_label<DB: DrawingBackend>(
    chart: &Chart<DB>,
    at: (f64, f64),
    text: &str,
    style: &TextStyle,
    (dx, dy): (i32, i32),
    (w, h): (u32, u32),
) -> DrawResult {
    let style = style.clone().pos(Pos::new(HPos::Left, VPos::Top));
    let elem = EmptyElement::at(at)
        + Rectangle::new(
            [(dx - 3, dy - 2), (dx + w as i32 + 3, dy + h as i32 + 2)],
            WHITE.mix(0.85).filled(),
        )
        + Text::new(text.to_string(), (dx, dy), style);
    chart.plotting_area().draw(&elem).map_err(msg)
}

/// Label placement that avoids overlaps: boxes in absolute pixel coordinates.
pub(crate) struct Placer {
    taken: Vec<[i32; 4]>,
    bounds: [i32; 4],
}

impl Placer {
    /// A placer for labels inside the pixel ranges `(xs, ys)`, nothing taken yet.
    pub(crate) fn new((xs, ys): (Range<i32>, Range<i32>)) -> Self {
        Self {
            taken: Vec::new(),
            bounds: [xs.start, ys.start, xs.end, ys.end],
        }
    }

    /// Marks a box `[x0, y0, x1, y1]` as occupied.
    pub(crate) fn occupy(&mut self, b: [i32; 4]) {
        self.taken.push(b);
    }

    /// Picks the first of `offsets` (top-left corner of a `size` box relative to `anchor`)
    /// whose box is inside the bounds and free, else the first; occupies it and returns the
    /// offset.
    pub(crate) fn place(
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

/// Offsets (top-left corner relative to the anchor) to try for a `w`×`h` label next to a
/// marker of radius `r`: right and left of it, above, below, then further out.
pub(crate) fn around(w: i32, h: i32, r: i32) -> Vec<(i32, i32)> {
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
pub(crate) fn above(w: i32, h: i32) -> Vec<(i32, i32)> {
    let mut offsets: Vec<(i32, i32)> = (0..5).map(|k| (-w / 2, -h - 6 - k * (h + 4))).collect();
    offsets.extend([
        (6, -h - 6),
        (-w - 6, -h - 6),
        (6, -2 * h - 10),
        (-w - 6, -2 * h - 10),
    ]);
    offsets
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaps_split_the_line() {
        let t = [0.0, 1.0, 2.0, 3.0, 4.0];
        let v = [1.0, f64::NAN, 2.0, 3.0, f64::INFINITY];
        let runs = finite_runs(t.iter().copied().zip(v.iter().copied()));
        assert_eq!(runs.len(), 2);
        assert_eq!(runs[0].len(), 1);
        assert_eq!(runs[1].len(), 2);
    }

    #[test]
    fn escaping() {
        assert_eq!(
            escape_html(r#"a<b & "c" 'd'>"#),
            "a&lt;b &amp; &quot;c&quot; &#39;d&#39;&gt;"
        );
    }

    #[test]
    fn ranges() {
        assert_eq!(
            min_max([3.0, f64::NAN, -1.0].into_iter()),
            Some((-1.0, 3.0))
        );
        assert_eq!(min_max([f64::NAN].into_iter()), None);
        assert_eq!(pad_range(None, 0.1), (0.0, 1.0));
        assert_eq!(pad_range(Some((2.0, 2.0)), 0.1), (1.0, 3.0));
    }

    #[test]
    fn png_leaves_no_temporary_on_error() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("f.png");
        let err = render_png(&path, (10, 10), |_| Err("no".into())).unwrap_err();
        assert!(
            matches!(&err, PlotError::Draw { path: p, .. } if *p == path),
            "{err:?}"
        );
        render_png(&path, (10, 10), |_| Ok(())).expect("draw");
        let names: Vec<_> = fs::read_dir(dir.path())
            .expect("read dir")
            .map(|e| e.expect("entry").file_name())
            .collect();
        assert_eq!(names, ["f.png"]);
    }
}
