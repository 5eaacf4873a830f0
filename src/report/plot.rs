//! Rail-pad force plots: the measured (or simulated) force at each rail-pad sensor
//! against time, with the instants at which the wheel flat strikes the rail, and
//! optionally the wheel–rail contact forces in a second panel.
//!
//! Output is PNG or SVG, chosen by the file extension, and is written atomically: the
//! figure is drawn to a hidden temporary file next to the target and renamed into place,
//! so a reader never sees a half-written plot.

use crate::report::canvas::DrawResult;
use std::path::Path;

use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// The figure error, at its old path.
pub use super::canvas::PlotError;
/// The shared figure helpers, also at their old path (`report::plot`).
pub(crate) use super::canvas::{ensure_font, render_png, FONT};
use super::canvas::{
    finite_runs, legend_font, min_max, msg, text_width, GRID_BOLD, GRID_LIGHT, TAB10,
};

/// Figure size without the contact panel (pixels, also the SVG view box).
const SIZE_SINGLE: (u32, u32) = (1400, 800);
/// Figure size with the contact-force panel below.
const SIZE_WITH_CONTACT: (u32, u32) = (1400, 1100);

/// Colour of the dashed flat-strike markers.
const STRIKE_COLOUR: RGBColor = RGBColor(60, 60, 60);

/// One force signal to plot, e.g. one rail-pad sensor.
#[derive(Debug, Clone, Copy)]
pub struct Series<'a> {
    /// Legend label, e.g. `"rps1"`.
    pub label: &'a str,
    /// Force in kN, one value per entry of the plot's time axis. Non-finite values leave
    /// a gap in the line.
    pub values_kn: &'a [f64],
}

/// A rail-pad force figure: forces at each sensor against time (top panel), and
/// optionally the wheel–rail contact forces (bottom panel).
#[derive(Debug, Clone)]
pub struct PadForcePlot<'a> {
    /// Figure title.
    pub title: &'a str,
    /// Common time axis in s; every series has the same length. Must be non-empty and finite.
    pub time_s: &'a [f64],
    /// One series per rail-pad sensor, e.g. `"rps1"` … `"rps5"`, drawn in distinct colours.
    pub series: Vec<Series<'a>>,
    /// Instants (s) at which the wheel flat strikes the rail; drawn as thin dashed vertical
    /// lines (legend entry "flat strike"). Instants outside the time axis are skipped.
    pub strike_times_s: &'a [f64],
    /// Optional wheel–rail contact forces in kN of the (leading, trailing) wheel on the same
    /// time axis, drawn in a second panel below the rail-pad forces.
    pub contact_kn: Option<[&'a [f64]; 2]>,
}

/// Output format, from the file extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Format {
    Png,
    Svg,
}

impl Format {
    fn of(path: &Path) -> Option<Self> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "png" => Some(Self::Png),
            "svg" => Some(Self::Svg),
            _ => None,
        }
    }
}

/// One line of a panel: label, values, colour.
struct Curve<'a> {
    label: &'a str,
    values: &'a [f64],
    colour: RGBColor,
}

/// One panel of the figure.
struct Panel<'a> {
    y_label: &'a str,
    curves: Vec<Curve<'a>>,
}

/// Draws `plot` to `path`: a PNG (1400×800, or 1400×1100 with the contact panel) when the
/// path ends in `.png`, an SVG of the same size when it ends in `.svg`.
///
/// The top panel shows the rail-pad force (kN) of every sensor against time (s) with a
/// legend, its y range running from `min(0, smallest value)` to 1.1 × the largest value;
/// the flat strikes inside the time range are marked by dashed vertical lines. With
/// [`PadForcePlot::contact_kn`] a bottom panel shows the leading and trailing wheel–rail
/// contact forces.
///
/// The file is written atomically (temporary sibling, then rename); on error no file and
/// no temporary are left behind, and an existing file at `path` is untouched.
///
/// # Errors
/// [`PlotError::UnsupportedExtension`] for other extensions (nothing is written),
/// [`PlotError::InvalidData`] for an empty or non-finite time axis or a series whose length
/// differs from it, [`PlotError::Font`], [`PlotError::Draw`] or [`PlotError::Io`] when
/// drawing or writing fails.
pub fn draw_pad_forces(plot: &PadForcePlot, path: &Path) -> Result<(), PlotError> {
    let format = Format::of(path).ok_or_else(|| PlotError::UnsupportedExtension {
        path: path.to_path_buf(),
    })?;
    validate(plot).map_err(|message| PlotError::InvalidData {
        path: path.to_path_buf(),
        message,
    })?;
    if !ensure_font() {
        return Err(PlotError::Font {
            path: path.to_path_buf(),
        });
    }

    let size = if plot.contact_kn.is_some() {
        SIZE_WITH_CONTACT
    } else {
        SIZE_SINGLE
    };
    match format {
        Format::Png => render_png(path, size, |root| render(root, plot)),
        Format::Svg => {
            let mut svg = String::new();
            {
                let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
                render(&root, plot)
                    .and_then(|()| root.present().map_err(msg))
                    .map_err(|message| PlotError::Draw {
                        path: path.to_path_buf(),
                        message,
                    })?;
            }
            crate::atomic::write_atomically(path, svg.as_bytes()).map_err(|source| PlotError::Io {
                path: path.to_path_buf(),
                source,
            })
        }
    }
}

/// Checks lengths and the time axis; the message says what is wrong.
fn validate(plot: &PadForcePlot) -> DrawResult {
    let n = plot.time_s.len();
    if n == 0 {
        return Err("the time axis is empty".into());
    }
    if plot.time_s.iter().any(|t| !t.is_finite()) {
        return Err("the time axis contains non-finite values".into());
    }
    for s in &plot.series {
        if s.values_kn.len() != n {
            return Err(format!(
                "series {:?} has {} values but the time axis has {n}",
                s.label,
                s.values_kn.len()
            ));
        }
    }
    if let Some(contact) = plot.contact_kn {
        for (name, values) in ["leading", "trailing"].iter().zip(contact) {
            if values.len() != n {
                return Err(format!(
                    "the {name} contact force has {} values but the time axis has {n}",
                    values.len()
                ));
            }
        }
    }
    Ok(())
}

/// Draws the whole figure on `root`.
fn render<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, plot: &PadForcePlot) -> DrawResult {
    root.fill(&WHITE).map_err(msg)?;
    let body = root
        .margin(12, 0, 0, 0)
        .titled(plot.title, (FONT, 30).into_font().color(&BLACK))
        .map_err(msg)?;

    let (t_min, t_max) = min_max(plot.time_s.iter().copied()).unwrap_or((0.0, 1.0));
    let (t_min, t_max) = if t_max > t_min {
        (t_min, t_max)
    } else {
        (t_min - 0.5, t_max + 0.5)
    };
    let strikes: Vec<f64> = plot
        .strike_times_s
        .iter()
        .copied()
        .filter(|t| t.is_finite() && *t >= t_min && *t <= t_max)
        .collect();

    let pads = Panel {
        y_label: "rail-pad force (kN)",
        curves: plot
            .series
            .iter()
            .enumerate()
            .map(|(i, s)| Curve {
                label: s.label,
                values: s.values_kn,
                colour: TAB10[i % TAB10.len()],
            })
            .collect(),
    };
    let contact = plot.contact_kn.map(|[leading, trailing]| Panel {
        y_label: "contact force (kN)",
        curves: vec![
            Curve {
                label: "leading wheel",
                values: leading,
                colour: TAB10[0],
            },
            Curve {
                label: "trailing wheel",
                values: trailing,
                colour: TAB10[3],
            },
        ],
    });

    // One legend column, as wide as the longest label of either panel, so that the
    // panels' time axes line up.
    let font = legend_font();
    let mut widest = if strikes.is_empty() {
        0
    } else {
        text_width(&body, STRIKE_LABEL, &font)?
    };
    for curve in pads
        .curves
        .iter()
        .chain(contact.iter().flat_map(|p| &p.curves))
    {
        widest = widest.max(text_width(&body, curve.label, &font)?);
    }
    let legend_width =
        LEGEND_INSET + LEGEND_PAD + LEGEND_SAMPLE + LEGEND_GAP + widest + LEGEND_PAD + LEGEND_INSET;

    match &contact {
        None => draw_panel(
            &body,
            plot.time_s,
            (t_min, t_max),
            &pads,
            &strikes,
            legend_width,
        ),
        Some(contact) => {
            let (_, h) = body.dim_in_pixel();
            let (top, bottom) = body.split_vertically(h * 62 / 100);
            draw_panel(
                &top,
                plot.time_s,
                (t_min, t_max),
                &pads,
                &strikes,
                legend_width,
            )?;
            draw_panel(
                &bottom,
                plot.time_s,
                (t_min, t_max),
                contact,
                &strikes,
                legend_width,
            )
        }
    }
}

/// Legend label of the strike markers.
const STRIKE_LABEL: &str = "flat strike";
/// Legend layout (pixels): gap on either side of the legend box, inner padding, length of the
/// line sample, gap between sample and label, height of one entry.
const LEGEND_INSET: u32 = 10;
const LEGEND_PAD: u32 = 12;
const LEGEND_SAMPLE: u32 = 32;
const LEGEND_GAP: u32 = 10;
const LEGEND_ROW: u32 = 28;
/// Top margin of each panel's chart (the legend box is aligned with it).
const PANEL_MARGIN_TOP: u32 = 10;

/// One legend entry: label, line style, dashed or solid.
struct LegendEntry<'a> {
    label: &'a str,
    style: ShapeStyle,
    dashed: bool,
}

/// Draws one panel: axes, curves, strike markers, and its legend in a column on the right
/// (outside the axes, so it never hides a force peak).
fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    time: &[f64],
    (t_min, t_max): (f64, f64),
    panel: &Panel,
    strikes: &[f64],
    legend_width: u32,
) -> DrawResult {
    let (w, _) = area.dim_in_pixel();
    let (chart_area, legend_area) = area.split_horizontally(w.saturating_sub(legend_width));
    let (y_min, y_max) = force_range(panel.curves.iter().map(|c| c.values));
    let mut chart = ChartBuilder::on(&chart_area)
        .margin_top(PANEL_MARGIN_TOP)
        .margin_bottom(10)
        .margin_left(15)
        .margin_right(10)
        .x_label_area_size(60)
        .y_label_area_size(90)
        .build_cartesian_2d(t_min..t_max, y_min..y_max)
        .map_err(msg)?;
    chart
        .configure_mesh()
        .x_desc("time (s)")
        .y_desc(panel.y_label)
        .x_labels(12)
        .y_labels(8)
        .label_style((FONT, 18))
        .axis_desc_style((FONT, 22))
        .light_line_style(GRID_LIGHT)
        .bold_line_style(GRID_BOLD)
        .draw()
        .map_err(msg)?;

    let mut legend = Vec::with_capacity(panel.curves.len() + 1);
    for curve in &panel.curves {
        let style = ShapeStyle::from(&curve.colour).stroke_width(2);
        chart
            .draw_series(
                finite_runs(time.iter().copied().zip(curve.values.iter().copied()))
                    .into_iter()
                    .map(move |run| PathElement::new(run, style)),
            )
            .map_err(msg)?;
        legend.push(LegendEntry {
            label: curve.label,
            style,
            dashed: false,
        });
    }

    if !strikes.is_empty() {
        let style = ShapeStyle::from(&STRIKE_COLOUR).stroke_width(1);
        chart
            .draw_series(
                strikes
                    .iter()
                    .map(|&t| DashedPathElement::new(vec![(t, y_min), (t, y_max)], 6, 4, style)),
            )
            .map_err(msg)?;
        legend.push(LegendEntry {
            label: STRIKE_LABEL,
            style,
            dashed: true,
        });
    }

    draw_legend(&legend_area, &legend)
}

/// Draws a boxed legend at the top of `area`.
fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: &[LegendEntry],
) -> DrawResult {
    if entries.is_empty() {
        return Ok(());
    }
    let (w, _) = area.dim_in_pixel();
    let left = LEGEND_INSET as i32;
    let right = w.saturating_sub(LEGEND_INSET) as i32;
    let top = PANEL_MARGIN_TOP as i32;
    let bottom = top + (LEGEND_PAD + LEGEND_ROW * entries.len() as u32) as i32;
    area.draw(&Rectangle::new(
        [(left, top), (right, bottom)],
        ShapeStyle::from(&RGBColor(120, 120, 120)).stroke_width(1),
    ))
    .map_err(msg)?;
    let text_style = legend_font().pos(Pos::new(HPos::Left, VPos::Center));
    let x0 = left + LEGEND_PAD as i32;
    let x1 = x0 + LEGEND_SAMPLE as i32;
    for (i, entry) in entries.iter().enumerate() {
        let y = top + (LEGEND_PAD / 2 + LEGEND_ROW * i as u32 + LEGEND_ROW / 2) as i32;
        if entry.dashed {
            area.draw(&DashedPathElement::new(
                vec![(x0, y), (x1, y)],
                6,
                4,
                entry.style,
            ))
        } else {
            area.draw(&PathElement::new(vec![(x0, y), (x1, y)], entry.style))
        }
        .map_err(msg)?;
        area.draw(&Text::new(
            entry.label,
            (x1 + LEGEND_GAP as i32, y),
            text_style.clone(),
        ))
        .map_err(msg)?;
    }
    Ok(())
}

/// The y range of a force panel: `min(0, smallest)` to 1.1 × the largest finite value,
/// widened when degenerate.
fn force_range<'a>(curves: impl Iterator<Item = &'a [f64]>) -> (f64, f64) {
    let Some((lo, hi)) = min_max(curves.flat_map(|v| v.iter().copied())) else {
        return (0.0, 1.0);
    };
    let lo = lo.min(0.0);
    let hi = if hi > 0.0 {
        1.1 * hi
    } else {
        hi + 0.1 * hi.abs()
    };
    if hi > lo {
        (lo, hi)
    } else {
        (lo, lo + 1.0)
    }
}

#[cfg(test)]
mod tests;
