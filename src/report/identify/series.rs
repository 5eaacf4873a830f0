//! Figure 1 (paper Figs. 12, 13, 15): each measured series with its PIPs, the EIP numbered in
//! selection order, and the falsification band at each EIP.

use crate::report::canvas::DrawResult;
use plotters::coord::Shift;
use plotters::prelude::*;

use super::{
    annotation_font, centred_note, chart_builder, draw_mesh, eip_order, frame, Entry, Swatch,
    BAND_COLOUR, CAPTION_SIZE, EIP_COLOUR, EIP_LABEL_COLOUR, ENVELOPE_COLOUR, MEASURED_COLOUR,
    PIP_COLOUR,
};
use crate::identify::answer::identification::Identification;
use crate::identify::answer::result::CandidatePoint;
use crate::report::canvas::{
    around, draw_label, finite_runs, min_max, msg, pad_range, text_size, Placer, FONT,
};

pub(super) fn render_series<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    id: &Identification,
) -> DrawResult {
    let Some(z) = &id.sizing else {
        // Not sized: the measured series alone.
        let entries = [Entry::new("measured", Swatch::Line(MEASURED_COLOUR, 2))];
        let title = "Measured series (no flat detected: not sized, no comparison points)";
        return panels(&frame(root, title, &entries)?, id);
    };
    let mut entries = vec![
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
    if !z.envelope.is_empty() {
        entries.push(Entry::new(
            "envelope point: the window's max or min (tick) and its admissible band",
            Swatch::Line(ENVELOPE_COLOUR, 3),
        ));
    }
    let title = format!(
        "Measured series: {} PIP ({} distance), {} EIP, {} envelope points",
        z.candidates.len(),
        id.pip_distance,
        z.eip.len(),
        z.envelope.len()
    );
    panels(&frame(root, &title, &entries)?, id)
}

/// The series' panels, one under the other, in `body`.
fn panels<DB: DrawingBackend>(body: &DrawingArea<DB, Shift>, id: &Identification) -> DrawResult {
    if id.series.is_empty() {
        return centred_note(body, "no measured series", PIP_COLOUR);
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
) -> DrawResult {
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
    // The points of a sized pass on this series; none for a pass that was not sized.
    let (pips, eips, envelope) = match &id.sizing {
        Some(z) => {
            let order = eip_order(z);
            let pips: Vec<(usize, &CandidatePoint)> = z
                .candidates
                .iter()
                .enumerate()
                .filter(|(_, c)| c.series == k)
                .collect();
            let eips: Vec<(usize, &CandidatePoint)> = pips
                .iter()
                .filter_map(|&(i, c)| order.get(i).copied().flatten().map(|n| (n, c)))
                .collect();
            let envelope: Vec<_> = z.envelope.iter().filter(|e| e.series == k).collect();
            (pips, eips, envelope)
        }
        None => (Vec::new(), Vec::new(), Vec::new()),
    };
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
                }))
                .chain(envelope.iter().flat_map(|e| {
                    [
                        e.measured_kn + e.threshold_low_kn,
                        e.measured_kn + e.threshold_high_kn,
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

    // Envelope points: the admissible band as a green bar with caps at the window's centre,
    // the window's measured extreme as a short thick tick (a window is 1.6 ms, too short to
    // see on a whole record, so the marks have a fixed size in pixels).
    let env_band = ShapeStyle::from(&ENVELOPE_COLOUR.mix(0.6)).stroke_width(2);
    let env_tick = ShapeStyle::from(&ENVELOPE_COLOUR).stroke_width(3);
    for e in &envelope {
        let tc = s.t0_s + e.sample as f64 * dt;
        let (lo, hi) = (
            e.measured_kn + e.threshold_low_kn,
            e.measured_kn + e.threshold_high_kn,
        );
        if !(tc.is_finite() && lo.is_finite() && hi.is_finite()) {
            continue;
        }
        let area = chart.plotting_area();
        area.draw(&PathElement::new(vec![(tc, lo), (tc, hi)], env_band))
            .map_err(msg)?;
        for y in [lo, hi] {
            area.draw(
                &(EmptyElement::at((tc, y)) + PathElement::new(vec![(-4, 0), (4, 0)], env_band)),
            )
            .map_err(msg)?;
        }
        area.draw(
            &(EmptyElement::at((tc, e.measured_kn))
                + PathElement::new(vec![(-9, 0), (9, 0)], env_tick)),
        )
        .map_err(msg)?;
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
        let size = text_size(area, &text, &font)?;
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

/// Panel letter: a, b, …, z, then numbers.
fn panel_letter(k: usize) -> String {
    match u8::try_from(k) {
        Ok(k) if k < 26 => char::from(b'a' + k).to_string(),
        _ => (k + 1).to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn panels_are_lettered() {
        assert_eq!(panel_letter(1), "b");
    }
}
