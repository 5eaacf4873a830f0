//! Figure 4 (paper Fig. 17): the candidate model set in parallel coordinates, each axis
//! spanning the population bounds, with the residual-minimisation optimum dashed.

use crate::report::canvas::DrawResult;
use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;

use super::{
    centred_note, fmt_axis, fmt_num, frame, Entry, Swatch, CAPTION_SIZE, CMS_COLOUR, EIP_COLOUR,
};
use crate::identify::answer::identification::Identification;
use crate::identify::answer::result::{InstanceParams, ParamRanges};
use crate::identify::answer::sizing::Sizing;
use crate::report::canvas::{
    draw_label, finite_runs, format_tick, msg, text_size, FONT, LEGEND_SIZE,
};

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

pub(super) fn render_parallel<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    id: &Identification,
    z: &Sizing,
) -> DrawResult {
    let n = z.cms.len();
    let rm = &z.residual_minimisation;
    let mut entries = Vec::with_capacity(2);
    if n > 0 {
        entries.push(Entry::new(
            format!("candidate model (CMS, {n} instances)"),
            Swatch::Line(CMS_COLOUR, 2),
        ));
    }
    if let Some(rm) = rm {
        entries.push(Entry::new(
            format!(
                "residual minimisation without uncertainties (instance {}, L0 = {} mm)",
                rm.instance,
                fmt_num(rm.l0_mm, 1)
            ),
            Swatch::Dashed(EIP_COLOUR, 3),
        ));
    }
    let title = format!(
        "Identified parameters: {n} of {} instances not falsified",
        id.bank_instances
    );
    let mut body = frame(root, &title, &entries)?;
    if n == 0 {
        let (note, rest) = body.split_vertically(56);
        let why = if z.below_population {
            "empty CMS: the flat is smaller than the population's"
        } else {
            "empty CMS: model class refuted"
        };
        centred_note(&note, why, EIP_COLOUR)?;
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
            z.cms
                .iter()
                .flat_map(|p| finite_runs(instance_line(p, &id.population).into_iter()))
                .map(|run| PathElement::new(run, cms_style)),
        )
        .map_err(msg)?;
    chart
        .draw_series(
            rm.iter()
                .flat_map(|rm| finite_runs(instance_line(rm, &id.population).into_iter()))
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
            let size = text_size(&body, &text, &tick_font)?;
            let offset = (-(size.0 as i32) - 11, -(size.1 as i32) / 2);
            draw_label(&chart, (x, y), &text, &tick_font, offset, size)?;
        }
        let max_text = fmt_axis(hi, span);
        let size = text_size(&body, &max_text, &end_font)?;
        draw_label(
            &chart,
            (x, 1.0),
            &max_text,
            &end_font,
            (-(size.0 as i32) / 2, -(size.1 as i32) - 10),
            size,
        )?;
        let max_h = size.1 as i32;
        let size = text_size(&body, axis.name, &name_font)?;
        draw_label(
            &chart,
            (x, 1.0),
            axis.name,
            &name_font,
            (-(size.0 as i32) / 2, -max_h - size.1 as i32 - 22),
            size,
        )?;
        let min_text = fmt_axis(lo, span);
        let size = text_size(&body, &min_text, &end_font)?;
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axes_normalise_and_tick_inside() {
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
