//! The audit figure: per sensor, an instance's stored series, its re-simulation and the
//! measurement, with the comparison points and the admissible band of predictions at each.

use super::canvas::{
    min_max, msg, render_png, PlotError, FONT, GRID_LIGHT, TAB_BLUE, TAB_GREEN, TAB_ORANGE, TAB_RED,
};
use crate::report::canvas::DrawResult;
use plotters::prelude::*;
use std::path::Path;

/// One comparison point in a panel.
#[derive(Debug, Clone, Copy)]
pub struct BandPoint {
    /// Bank time (s).
    pub time_s: f64,
    /// The instance's prediction (kN).
    pub predicted_kn: f64,
    /// Admissible predictions `[measured + low − widening, measured + high + widening]` (kN).
    pub band_kn: [f64; 2],
    /// The point falsifies the instance.
    pub falsifies: bool,
}

/// One sensor's panel.
#[derive(Debug, Clone)]
pub struct AuditPanel<'a> {
    /// Sensor.
    pub sensor: &'a str,
    /// Time of the first sample (s).
    pub t0_s: f64,
    /// Sample rate (Hz).
    pub rate_hz: f64,
    /// Stored series (kN).
    pub stored: &'a [f32],
    /// Re-simulated series (kN).
    pub resimulated: &'a [f32],
    /// Measured series on the bank's time axis (kN), when auditing against a measurement.
    pub measured: Option<&'a [f64]>,
    /// Comparison points on this sensor.
    pub points: Vec<BandPoint>,
}

const STORED: RGBColor = TAB_BLUE;
const RESIM: RGBColor = TAB_ORANGE;
const MEASURED: RGBColor = RGBColor(40, 40, 40);
const KEPT: RGBColor = TAB_GREEN;
const FALSIFIES: RGBColor = TAB_RED;

/// Draws the figure as a PNG at `path` (written beside it, then renamed into place).
pub fn draw_audit(title: &str, panels: &[AuditPanel], path: &Path) -> Result<(), PlotError> {
    if panels.is_empty() {
        return Err(PlotError::InvalidData {
            path: path.to_path_buf(),
            message: "no sensor to draw".into(),
        });
    }
    let height = 120 + 380 * panels.len() as u32;
    render_png(path, (1400, height), |root| {
        let root = root.titled(title, (FONT, 28)).map_err(msg)?;
        for (panel, area) in panels.iter().zip(root.split_evenly((panels.len(), 1))) {
            draw_panel(&area, panel)?;
        }
        Ok(())
    })
}

fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    p: &AuditPanel,
) -> DrawResult {
    let t = |k: usize| p.t0_s + k as f64 / p.rate_hz;
    let n = p.stored.len().max(1);
    let values = p
        .stored
        .iter()
        .chain(p.resimulated)
        .map(|&v| v as f64)
        .chain(p.measured.into_iter().flatten().copied())
        .chain(p.points.iter().flat_map(|b| b.band_kn));
    let (lo, hi) = min_max(values).unwrap_or((0.0, 1.0));
    let pad = 0.05 * (hi - lo).max(1.0);
    let mut chart = ChartBuilder::on(area)
        .caption(p.sensor, (FONT, 22))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(t(0)..t(n - 1), (lo - pad)..(hi + pad))
        .map_err(msg)?;
    chart
        .configure_mesh()
        .x_desc("bank time (s)")
        .y_desc("pad force (kN)")
        .label_style((FONT, 16))
        .axis_desc_style((FONT, 18))
        .light_line_style(GRID_LIGHT)
        .draw()
        .map_err(msg)?;
    let line = |v: &[f32]| -> Vec<(f64, f64)> {
        v.iter()
            .enumerate()
            .filter(|(_, x)| x.is_finite())
            .map(|(k, &x)| (t(k), x as f64))
            .collect()
    };
    chart
        .draw_series(std::iter::once(PathElement::new(
            line(p.stored),
            STORED.stroke_width(3),
        )))
        .map_err(msg)?
        .label("stored in the bank")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], STORED.stroke_width(3)));
    chart
        .draw_series(std::iter::once(PathElement::new(
            line(p.resimulated),
            RESIM.stroke_width(1),
        )))
        .map_err(msg)?
        .label("re-simulated")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RESIM.stroke_width(1)));
    if let Some(m) = p.measured {
        chart
            .draw_series(std::iter::once(PathElement::new(
                m.iter()
                    .enumerate()
                    .filter(|(_, x)| x.is_finite())
                    .map(|(k, &x)| (t(k), x))
                    .collect::<Vec<_>>(),
                MEASURED.stroke_width(1),
            )))
            .map_err(msg)?
            .label("measured")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], MEASURED.stroke_width(1)));
    }
    for b in &p.points {
        let colour = if b.falsifies { FALSIFIES } else { KEPT };
        chart
            .draw_series([
                PathElement::new(
                    vec![(b.time_s, b.band_kn[0]), (b.time_s, b.band_kn[1])],
                    colour.stroke_width(3),
                ),
                PathElement::new(
                    vec![(b.time_s, b.predicted_kn), (b.time_s, b.predicted_kn)],
                    colour.stroke_width(1),
                ),
            ])
            .map_err(msg)?;
        chart
            .draw_series(std::iter::once(Circle::new(
                (b.time_s, b.predicted_kn),
                5,
                colour.filled(),
            )))
            .map_err(msg)?;
    }
    if !p.points.is_empty() {
        chart
            .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())
            .map_err(msg)?
            .label("comparison point: admissible band, prediction (red: falsifies)")
            .legend(|(x, y)| Circle::new((x + 10, y), 5, KEPT.filled()));
    }
    chart
        .configure_series_labels()
        .label_font((FONT, 16))
        .background_style(WHITE.mix(0.6))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperRight)
        .draw()
        .map_err(msg)
}
