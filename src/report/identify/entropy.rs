//! Figure 2 (paper Fig. 14): the entropy of the bank's predictions at every PIP; figure 3
//! (paper Fig. 16): the joint entropy as points are added, per sensor set.

use crate::report::canvas::DrawResult;
use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;

use super::{
    annotation_font, centred_note, chart_builder, draw_mesh, eip_order, fmt_num, frame, Entry,
    Swatch, BAR_COLOUR, EIP_COLOUR, EIP_LABEL_COLOUR, PALETTE, PIP_COLOUR, REFERENCE_COLOUR,
};
use crate::identify::answer::identification::Identification;
use crate::identify::answer::sizing::Sizing;
use crate::report::canvas::{
    above, draw_label, finite_runs, msg, text_size, Placer, FONT, LEGEND_SIZE,
};

pub(super) fn render_entropy<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    id: &Identification,
    z: &Sizing,
) -> DrawResult {
    let entries = [
        Entry::new("PIP", Swatch::Bar(BAR_COLOUR)),
        Entry::new("EIP (number = selection order)", Swatch::Bar(EIP_COLOUR)),
    ];
    let n = z.candidates.len();
    let title = format!("Entropy of the bank's predictions at each of the {n} PIP");
    let body = frame(root, &title, &entries)?;
    if n == 0 {
        return centred_note(&body, "no PIP", PIP_COLOUR);
    }
    let order = eip_order(z);
    let entropy = |e: f64| if e.is_finite() && e > 0.0 { e } else { 0.0 };
    let e_max = z
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
        .draw_series(z.candidates.iter().enumerate().map(|(i, c)| {
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
    for (i, c) in z.candidates.iter().enumerate() {
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
            let size = text_size(&body, &name, &font)?;
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
        let size = text_size(&body, &text, &font)?;
        let at = (i as f64, entropy(z.candidates[i].entropy_bits));
        let anchor = chart.backend_coord(&at);
        let offset = placer.place(anchor, size, &above(size.0 as i32, size.1 as i32));
        draw_label(&chart, at, &text, &font, offset, size)?;
    }
    Ok(())
}

pub(super) fn render_joint_entropy<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    id: &Identification,
    z: &Sizing,
) -> DrawResult {
    let log2n = if id.bank_instances > 0 {
        (id.bank_instances as f64).log2()
    } else {
        f64::NAN
    };
    let mut entries: Vec<Entry> = z
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
    if !z.eip.is_empty() {
        entries.push(Entry::new(
            format!(
                "{} EIP selected (stop threshold α = {} bits)",
                z.eip.len(),
                fmt_num(z.alpha_bits, 3)
            ),
            Swatch::Dashed(EIP_COLOUR, 2),
        ));
    }
    let body = frame(root, "Joint entropy of the selected points", &entries)?;

    let n_max = z
        .entropy_curves
        .iter()
        .map(|c| c.joint_entropy_bits.len())
        .max()
        .unwrap_or(0)
        .max(z.eip.len())
        .max(1);
    let y_max = z
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

    if !z.eip.is_empty() {
        let x = z.eip.len() as f64;
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
    for (i, curve) in z.entropy_curves.iter().enumerate() {
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
        let size = text_size(&body, &text, &font)?;
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
