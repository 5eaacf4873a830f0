//! The detection figure (docs/detection.md): per sensor, the residual after the sensor's gain,
//! `y − a·g`, against the good wheel's bound `±b` at every sample, the sample nearest the bound
//! (or farthest past it) marked. A good wheel stays inside the band; a flat's strikes leave it.

use crate::report::canvas::DrawResult;
use plotters::coord::Shift;
use plotters::prelude::*;

use super::{
    centred_note, chart_builder, draw_mesh, frame, Entry, Swatch, BAND_COLOUR, CAPTION_SIZE,
    EIP_COLOUR, MEASURED_COLOUR,
};
use crate::identify::answer::identification::Identification;
use crate::identify::answer::result::MeasuredSeries;
use crate::identify::detect::{Detection, SensorTest};
use crate::report::canvas::{finite_runs, min_max, msg, pad_range, FONT};

/// Whether `id` carries what the figure draws: a detection with each sensor's flat-free
/// prediction.
pub(super) fn is_available(id: &Identification) -> bool {
    id.detection
        .as_ref()
        .is_some_and(|d| d.sensors.iter().any(|s| !s.flat_free_kn.is_empty()))
}

pub(super) fn render_detection<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    id: &Identification,
) -> DrawResult {
    let entries = vec![
        Entry::new(
            "residual after the sensor's gain: measured − gain × good-wheel prediction",
            Swatch::Line(MEASURED_COLOUR, 2),
        ),
        Entry::new("the good wheel's bound ±b", Swatch::Line(BAND_COLOUR, 2)),
        Entry::new(
            "sample nearest the bound, or farthest past it",
            Swatch::FilledCircle(EIP_COLOUR),
        ),
    ];
    let title = match &id.detection {
        Some(d) if d.flat_detected => "Detection: a flat detected (the residual leaves the bound)",
        Some(_) => "Detection: no flat detected (every sample within the bound)",
        None => "Detection",
    };
    let body = frame(root, title, &entries)?;
    let Some(d) = id.detection.as_ref().filter(|_| is_available(id)) else {
        return centred_note(&body, "no detection data", MEASURED_COLOUR);
    };
    let panels = body.split_evenly((d.sensors.len().max(1), 1));
    for (panel, t) in panels.iter().zip(&d.sensors) {
        if let Some(s) = id.series.iter().find(|s| s.sensor == t.sensor) {
            sensor_panel(panel, d, t, s)?;
        }
    }
    Ok(())
}

/// One sensor's panel.
fn sensor_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    d: &Detection,
    t: &SensorTest,
    s: &MeasuredSeries,
) -> DrawResult {
    let dt = if s.sample_rate_hz > 0.0 {
        1.0 / s.sample_rate_hz
    } else {
        1.0
    };
    let n = s.values_kn.len().min(t.flat_free_kn.len());
    let time: Vec<f64> = (0..n).map(|k| s.t0_s + k as f64 * dt).collect();
    let residual: Vec<f64> = (0..n)
        .map(|k| s.values_kn[k] - t.gain * t.flat_free_kn[k])
        .collect();
    let bound: Vec<f64> = (0..n)
        .map(|k| d.bounds.bound_kn(t.gain, t.flat_free_kn[k]))
        .collect();
    let (t_lo, t_hi) = pad_range(min_max(time.iter().copied()), 0.015);
    let (y_lo, y_hi) = pad_range(
        min_max(
            residual
                .iter()
                .copied()
                .chain(bound.iter().copied())
                .chain(bound.iter().map(|b| -b)),
        ),
        0.1,
    );
    let caption = format!(
        "{}: gain {:.3}{}, {:.2} kN {} the bound",
        t.sensor,
        t.gain,
        if t.gain_outside_table {
            " (clamped: level outside the table)"
        } else {
            ""
        },
        t.excess_kn.abs(),
        if t.excess_kn > 0.0 { "past" } else { "inside" },
    );
    let mut chart = chart_builder(area)
        .caption(caption, (FONT, CAPTION_SIZE))
        .build_cartesian_2d(t_lo..t_hi, y_lo..y_hi)
        .map_err(msg)?;
    draw_mesh(&mut chart, "time (s)", "residual (kN)", false, false)?;
    let band = ShapeStyle::from(&BAND_COLOUR).stroke_width(2);
    for sign in [1.0, -1.0] {
        chart
            .draw_series(
                finite_runs(time.iter().copied().zip(bound.iter().map(|b| sign * b)))
                    .into_iter()
                    .map(|run| PathElement::new(run, band)),
            )
            .map_err(msg)?;
    }
    let line = ShapeStyle::from(&MEASURED_COLOUR).stroke_width(1);
    chart
        .draw_series(
            finite_runs(time.iter().copied().zip(residual.iter().copied()))
                .into_iter()
                .map(|run| PathElement::new(run, line)),
        )
        .map_err(msg)?;
    if t.at_time_s.is_finite() && t.residual_kn.is_finite() {
        chart
            .draw_series([Circle::new(
                (t.at_time_s, t.residual_kn),
                6,
                EIP_COLOUR.filled(),
            )])
            .map_err(msg)?;
    }
    Ok(())
}
