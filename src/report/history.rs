//! A wheel's history for people: each stored pass's answer and the joint answer as a table,
//! the same as JSON, and the trend figure (each pass's L0 range over time, the joint range,
//! the class limits).

use super::canvas::{msg, render_png, render_svg, DrawResult};
use super::PlotError;
use crate::history::{Joint, StoredPass};
use plotters::chart::SeriesAnno;
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use serde::Serialize;
use std::path::Path;

/// One pass in the history's JSON.
#[derive(Debug, Clone, Serialize)]
pub struct PassLine {
    /// Its place in the window, 1 = the oldest.
    pub pass: usize,
    /// When it was identified (RFC 3339).
    pub time: String,
    /// The measurement file.
    pub measurement: String,
    /// Its speed (km/h).
    pub speed_km_per_h: Option<f64>,
    /// The bank's speed (km/h).
    pub bank_speed_km_per_h: f64,
    /// What it says of the wheel.
    pub claim: crate::history::Claim,
    /// Its L0 range (mm).
    pub l0_mm: Option<[f64; 2]>,
    /// Its classes.
    pub severity: Option<crate::identify::SeverityRange>,
    /// Surviving cells stored.
    pub cells: usize,
    /// Its flat's dynamic-ratio range (peak wheel–rail force over the static load), when sized.
    pub dynamic_ratio: Option<[f64; 2]>,
}

/// The history's JSON: the wheel, its passes, the joint answer.
#[derive(Debug, Clone, Serialize)]
pub struct HistoryReport {
    /// The wheel id.
    pub wheel: String,
    /// The passes fused, oldest first.
    pub passes: Vec<PassLine>,
    /// The joint answer.
    pub joint: Joint,
    /// The class limits used (mm): inspect, urgent.
    pub limits_l0_mm: [f64; 2],
    /// The impact rule's limits on the dynamic ratio: inspect, urgent.
    pub limits_dynamic_ratio: [f64; 2],
}

impl HistoryReport {
    /// The report of a wheel's stored passes and their joint answer; `limits`: the class
    /// limits on L0 (mm) and on the dynamic ratio, each inspect then urgent.
    pub fn new(wheel: &str, passes: &[StoredPass], joint: Joint, limits: [[f64; 2]; 2]) -> Self {
        HistoryReport {
            wheel: wheel.to_string(),
            passes: passes
                .iter()
                .enumerate()
                .map(|(i, p)| PassLine {
                    pass: i + 1,
                    time: p.time.clone(),
                    measurement: p.measurement.clone(),
                    speed_km_per_h: p.speed_km_per_h,
                    bank_speed_km_per_h: p.bank_speed_km_per_h,
                    claim: p.wheel.claim,
                    l0_mm: p.wheel.l0_mm,
                    severity: p.wheel.severity,
                    cells: p.wheel.boxes.len(),
                    dynamic_ratio: p.wheel.dynamic_ratio,
                })
                .collect(),
            joint,
            limits_l0_mm: limits[0],
            limits_dynamic_ratio: limits[1],
        }
    }

    /// The table and the joint answer for people.
    pub fn text(&self) -> String {
        let mut s = format!(
            "wheel {}: {} passes (oldest first)\n{:<5} {:<24} {:>7}  {:<13} {:<16} {}\n",
            self.wheel,
            self.passes.len(),
            "pass",
            "time",
            "km/h",
            "claim",
            "L0 (mm)",
            "severity"
        );
        for p in &self.passes {
            let l0 = p
                .l0_mm
                .map_or("—".into(), |r| format!("[{:.0}, {:.0}]", r[0], r[1]));
            s += &format!(
                "{:<5} {:<24} {:>7}  {:<13} {:<16} {}\n",
                p.pass,
                p.time,
                p.speed_km_per_h.map_or("—".into(), |v| format!("{v:.1}")),
                p.claim.as_str(),
                l0,
                p.severity.map_or("—".into(), |c| c.words())
            );
        }
        let l0 = self
            .joint
            .l0_mm
            .map_or("—".into(), |r| format!("[{:.0}, {:.0}] mm", r[0], r[1]));
        s += &format!(
            "joint: L0 {l0}; severity {}\n{}\n",
            self.joint.severity.map_or("—".into(), |c| c.words()),
            self.joint.words
        );
        s
    }
}

/// The size of the trend figure (pixels): L0 above, the dynamic ratio below.
const TREND_SIZE: (u32, u32) = (1200, 900);
/// The L0 panel's share of the figure's height (%).
const L0_PANEL_PERCENT: u32 = 72;

/// Draws the trend ([`trend_on`]) as a PNG, written atomically.
pub fn draw_trend(r: &HistoryReport, path: &Path) -> Result<(), PlotError> {
    render_png(path, TREND_SIZE, |root| trend_on(root, r))
}

/// The trend ([`trend_on`]) as an SVG document, for a page.
// Err(String): the plotting library's message; the page says the figure could not be drawn.
pub fn trend_svg(r: &HistoryReport) -> Result<String, String> {
    render_svg(TREND_SIZE, |root| trend_on(root, r))
}

/// Draws the trend: L0 above ([`l0_panel`]), the impact's dynamic ratio below
/// ([`ratio_panel`]), pass by pass on one axis.
fn trend_on<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, r: &HistoryReport) -> DrawResult {
    let split = root.dim_in_pixel().1 * L0_PANEL_PERCENT / 100;
    let (upper, lower) = root.split_vertically(split);
    l0_panel(&upper, r)?;
    ratio_panel(&lower, r)
}

/// A panel's axes: the passes (oldest first) across, `y` up.
fn pass_mesh<DB: DrawingBackend>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    y: &str,
    n: usize,
) -> DrawResult {
    chart
        .configure_mesh()
        .x_desc("pass (oldest first)")
        .y_desc(y)
        .x_labels(n.min(20))
        .x_label_formatter(&|x| format!("{x:.0}"))
        .draw()
        .map_err(msg)
}

/// The top of a panel's axis: over its largest value and a quarter over its upper limit.
fn panel_top(values: impl Iterator<Item = f64>, upper_limit: f64) -> f64 {
    values.fold(upper_limit * 1.25, f64::max) * 1.05
}

/// The inspect and urgent limits' colours.
const LIMIT_COLOURS: [RGBColor; 2] = [RGBColor(220, 150, 0), RGBColor(200, 0, 0)];

/// A class limit at `v` across the `n` passes, dashed; its annotation, for a legend entry.
fn limit_line<'c, 'a, DB: DrawingBackend + 'a>(
    chart: &'c mut ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    n: usize,
    v: f64,
    colour: RGBColor,
) -> Result<&'c mut SeriesAnno<'a, DB>, String> {
    chart
        .draw_series(DashedLineSeries::new(
            [(0.5, v), (n as f64 + 0.5, v)],
            8,
            5,
            colour.stroke_width(2),
        ))
        .map_err(msg)
}

/// Pass `x`'s range `[lo, hi]`, a bar.
fn pass_bar<DB: DrawingBackend>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    x: f64,
    [lo, hi]: [f64; 2],
    colour: RGBColor,
) -> DrawResult {
    chart
        .draw_series(std::iter::once(Rectangle::new(
            [(x - 0.08, lo), (x + 0.08, hi)],
            colour.filled(),
        )))
        .map(|_| ())
        .map_err(msg)
}

/// Each pass's dynamic-ratio range (a bar; none where the pass sized no flat on this wheel)
/// and the impact rule's limits (dashed).
fn ratio_panel<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, r: &HistoryReport) -> DrawResult {
    let n = r.passes.len().max(1);
    let top = panel_top(
        r.passes
            .iter()
            .filter_map(|p| p.dynamic_ratio.map(|d| d[1])),
        r.limits_dynamic_ratio[1],
    );
    let mut chart = ChartBuilder::on(root)
        .margin(20)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(0.5f64..n as f64 + 0.5, 0.0f64..top)
        .map_err(msg)?;
    pass_mesh(&mut chart, "dynamic ratio", n)?;
    for (v, c) in r.limits_dynamic_ratio.into_iter().zip(LIMIT_COLOURS) {
        limit_line(&mut chart, n, v, c)?;
    }
    for (i, p) in r.passes.iter().enumerate() {
        if let Some(d) = p.dynamic_ratio {
            pass_bar(&mut chart, i as f64 + 1.0, d, RGBColor(90, 90, 90))?;
        }
    }
    Ok(())
}

/// Each pass's L0 range (a bar at its place in the window, grey when the joint answer leaves
/// it out), the joint L0 range (a band over the passes it is made of), the class limits
/// (dashed).
fn l0_panel<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, r: &HistoryReport) -> DrawResult {
    let top = panel_top(
        r.passes
            .iter()
            .filter_map(|p| p.l0_mm.map(|l| l[1]))
            .chain(r.joint.l0_mm.map(|l| l[1])),
        r.limits_l0_mm[1],
    );
    let n = r.passes.len().max(1);
    let mut chart = ChartBuilder::on(root)
        .caption(
            format!("wheel {}: L0 per pass and joint", r.wheel),
            ("sans-serif", 26),
        )
        .margin(20)
        .x_label_area_size(50)
        .y_label_area_size(70)
        .build_cartesian_2d(0.5f64..n as f64 + 0.5, 0.0f64..top)
        .map_err(msg)?;
    pass_mesh(&mut chart, "fresh-flat length L0 (mm)", n)?;
    // The joint band over the passes it is made of.
    if let (Some(l0), Some(first), Some(last)) = (
        r.joint.l0_mm,
        r.joint.passes_used.iter().min(),
        r.joint.passes_used.iter().max(),
    ) {
        let (a, b) = (*first as f64 + 0.6, *last as f64 + 1.4);
        chart
            .draw_series(std::iter::once(Rectangle::new(
                [(a, l0[0]), (b, l0[1])],
                RGBColor(120, 170, 230).mix(0.35).filled(),
            )))
            .map_err(msg)?
            .label(format!("joint [{:.0}, {:.0}] mm", l0[0], l0[1]))
            .legend(|(x, y)| {
                Rectangle::new(
                    [(x, y - 5), (x + 15, y + 5)],
                    RGBColor(120, 170, 230).filled(),
                )
            });
    }
    for ((name, v), c) in ["inspect", "urgent"]
        .into_iter()
        .zip(r.limits_l0_mm)
        .zip(LIMIT_COLOURS)
    {
        limit_line(&mut chart, n, v, c)?
            .label(format!("{name} from {v:.0} mm"))
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 15, y)], c.stroke_width(2)));
    }
    for (i, p) in r.passes.iter().enumerate() {
        let x = i as f64 + 1.0;
        let used = r.joint.passes_used.contains(&i);
        let colour = if used { BLACK } else { RGBColor(160, 160, 160) };
        match p.l0_mm {
            Some(l) => pass_bar(&mut chart, x, l, colour)?,
            None => {
                chart
                    .draw_series(std::iter::once(Circle::new((x, 0.0), 6, colour.filled())))
                    .map_err(msg)?;
            }
        }
        chart
            .draw_series(std::iter::once(Text::new(
                p.claim.as_str().to_string(),
                (x - 0.2, top * 0.97),
                ("sans-serif", 16).into_font(),
            )))
            .map_err(msg)?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK)
        .position(SeriesLabelPosition::LowerRight)
        .draw()
        .map_err(msg)?;
    Ok(())
}
