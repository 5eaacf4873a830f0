//! The figures' common layout: sizes, colours and fonts, the title-and-legend frame, legend
//! swatches, the mesh, notes, and number formats; every figure of the report draws with them.

use crate::report::canvas::DrawResult;
use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::super::canvas::{
    format_tick, legend_font, msg, text_width, Chart, FONT, GRID_BOLD, TAB10, TAB_BLUE, TAB_ORANGE,
    TAB_RED,
};
use crate::identify::answer::sizing::Sizing;

// ---------------------------------------------------------------------------------------
// Figures: common layout
// ---------------------------------------------------------------------------------------

/// Width of every figure (pixels, also the SVG view box).
pub(super) const WIDTH: u32 = 1400;
/// Height of one panel of the series figure.
pub(super) const SERIES_PANEL_HEIGHT: u32 = 380;

/// Colours.
pub(super) const MEASURED_COLOUR: RGBColor = TAB_BLUE;
pub(super) const PIP_COLOUR: RGBColor = RGBColor(70, 70, 70);
pub(super) const EIP_COLOUR: RGBColor = TAB_RED;
pub(super) const EIP_LABEL_COLOUR: RGBColor = RGBColor(150, 20, 20);
pub(super) const BAND_COLOUR: RGBColor = TAB_ORANGE;
pub(super) const ENVELOPE_COLOUR: RGBColor = RGBColor(44, 160, 44);
pub(super) const BAR_COLOUR: RGBColor = RGBColor(120, 155, 195);
pub(super) const CMS_COLOUR: RGBColor = RGBColor(125, 125, 125);
pub(super) const REFERENCE_COLOUR: RGBColor = RGBColor(40, 40, 40);
/// Light grid lines, fainter than the single figures' (the bold ones are shared).
pub(super) const GRID_FAINT: RGBColor = RGBColor(243, 243, 243);
/// Line colours of the joint-entropy curves (matplotlib "tab10" without red and orange, which
/// mark EIP and bands elsewhere).
pub(super) const PALETTE: [RGBColor; 6] =
    [TAB10[0], TAB10[2], TAB10[4], TAB10[5], TAB10[6], TAB10[9]];

/// Text sizes.
pub(super) const TITLE_SIZE: u32 = 28;
pub(super) const CAPTION_SIZE: u32 = 22;
pub(super) const TICK_SIZE: u32 = 17;
pub(super) const AXIS_DESC_SIZE: u32 = 20;
pub(super) const ANNOTATION_SIZE: u32 = 17;

/// Legend layout (pixels): length of a line sample, gap sample–label, gap between entries,
/// height of a row.
pub(super) const LEGEND_SAMPLE: u32 = 34;
pub(super) const LEGEND_GAP: u32 = 8;
pub(super) const LEGEND_SPACING: u32 = 34;
pub(super) const LEGEND_ROW: u32 = 30;

/// How a legend entry is drawn.
#[derive(Debug, Clone, Copy)]
pub(super) enum Swatch {
    Line(RGBColor, u32),
    Dashed(RGBColor, u32),
    HollowCircle(RGBColor),
    FilledCircle(RGBColor),
    Bar(RGBColor),
    ErrorBar(RGBColor),
}

/// One legend entry.
pub(super) struct Entry {
    label: String,
    swatch: Swatch,
}

impl Entry {
    pub(super) fn new(label: impl Into<String>, swatch: Swatch) -> Self {
        Self {
            label: label.into(),
            swatch,
        }
    }
}

pub(super) fn annotation_font(colour: &'static RGBColor) -> TextStyle<'static> {
    TextStyle::from((FONT, ANNOTATION_SIZE).into_font()).color(colour)
}

/// The title, then a legend row (wrapped when needed) under it; returns the area left for the
/// plot.
pub(super) fn frame<DB: DrawingBackend>(
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
pub(super) fn draw_swatch<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    swatch: Swatch,
    x: i32,
    y: i32,
) -> DrawResult {
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
pub(super) fn centred_note<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    text: &str,
    colour: RGBColor,
) -> DrawResult {
    let (w, h) = area.dim_in_pixel();
    let style = TextStyle::from((FONT, 30).into_font())
        .color(&colour)
        .pos(Pos::new(HPos::Center, VPos::Center));
    area.draw(&Text::new(text, ((w / 2) as i32, (h / 2) as i32), style))
        .map_err(msg)
}

/// Axes, grid and axis descriptions; `integer_x` / `integer_y` hide fractional tick labels.
pub(super) fn draw_mesh<DB: DrawingBackend>(
    chart: &mut Chart<DB>,
    x_desc: &str,
    y_desc: &str,
    integer_x: bool,
    integer_y: bool,
) -> DrawResult {
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
pub(super) fn chart_builder<'a, 'b, DB: DrawingBackend>(
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
pub(super) fn eip_order(z: &Sizing) -> Vec<Option<usize>> {
    let mut order = vec![None; z.candidates.len()];
    for (k, &c) in z.eip.iter().enumerate() {
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
pub(super) fn fmt_num(v: f64, decimals: usize) -> String {
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
pub(super) fn fmt_axis(v: f64, span: f64) -> String {
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
pub(super) fn fmt_range([lo, hi]: [f64; 2], decimals: usize) -> String {
    format!("{} – {}", fmt_num(lo, decimals), fmt_num(hi, decimals))
}
