//! Figure 5 (paper Fig. 18): the CMS size over random subsets of the PIPs, against the CMS
//! size with the EIP.

use crate::report::canvas::DrawResult;
use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;

use super::{
    centred_note, chart_builder, draw_mesh, fmt_num, frame, Entry, Swatch, BAR_COLOUR, EIP_COLOUR,
    PIP_COLOUR, REFERENCE_COLOUR,
};
use crate::identify::answer::sizing::Sizing;
use crate::report::canvas::msg;

/// A "nice" bin width (1, 2 or 5 × 10^k) at least `raw`, and at least 1.
fn nice_width(raw: f64) -> usize {
    if !(raw.is_finite() && raw > 1.0) {
        return 1;
    }
    let p = 10f64.powf(raw.log10().floor());
    let w = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * p)
        .find(|w| *w >= raw)
        .unwrap_or(10.0 * p);
    w.ceil() as usize
}

pub(super) fn render_random_subsets<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    z: &Sizing,
) -> DrawResult {
    let Some(rs) = &z.random_subsets else {
        return centred_note(root, "no random subsets drawn", PIP_COLOUR);
    };
    let eip_count = z.cms.len();
    let entries = [
        Entry::new(
            format!(
                "random subsets ({} draws of {} PIP)",
                rs.cms_counts.len(),
                rs.size
            ),
            Swatch::Bar(BAR_COLOUR),
        ),
        Entry::new(
            format!("EIP: CMS of {eip_count}"),
            Swatch::Line(EIP_COLOUR, 3),
        ),
        Entry::new(
            format!("mean of random subsets: {}", fmt_num(rs.mean, 1)),
            Swatch::Dashed(REFERENCE_COLOUR, 2),
        ),
    ];
    let body = frame(root, "CMS size with random comparison points", &entries)?;
    if rs.cms_counts.is_empty() {
        return centred_note(&body, "no random subsets drawn", PIP_COLOUR);
    }

    let top = rs
        .cms_counts
        .iter()
        .copied()
        .max()
        .unwrap_or(0)
        .max(eip_count)
        .max(if rs.mean.is_finite() && rs.mean > 0.0 {
            rs.mean.ceil() as usize
        } else {
            0
        });
    let width = nice_width((top + 1) as f64 / 30.0);
    let bins = top / width + 1;
    let mut heights = vec![0usize; bins];
    for &c in &rs.cms_counts {
        heights[(c / width).min(bins - 1)] += 1;
    }
    let y_hi = heights.iter().copied().max().unwrap_or(1).max(1) as f64 * 1.12;
    let x_lo = -0.5;
    let x_hi = (bins * width) as f64 - 0.5;
    let pad = 0.01 * (x_hi - x_lo);
    let mut chart = chart_builder(&body)
        .build_cartesian_2d(x_lo - pad..x_hi + pad, 0.0..y_hi)
        .map_err(msg)?;
    draw_mesh(
        &mut chart,
        "CMS size (instances)",
        "number of subsets",
        true,
        true,
    )?;

    let outline = ShapeStyle::from(&WHITE).stroke_width(1);
    for (b, &h) in heights.iter().enumerate() {
        if h == 0 {
            continue;
        }
        let corners = [
            ((b * width) as f64 - 0.5, 0.0),
            (((b + 1) * width) as f64 - 0.5, h as f64),
        ];
        chart
            .plotting_area()
            .draw(&Rectangle::new(corners, BAR_COLOUR.filled()))
            .map_err(msg)?;
        chart
            .plotting_area()
            .draw(&Rectangle::new(corners, outline))
            .map_err(msg)?;
    }
    let x = eip_count as f64;
    chart
        .plotting_area()
        .draw(&PathElement::new(
            vec![(x, 0.0), (x, y_hi)],
            ShapeStyle::from(&EIP_COLOUR).stroke_width(3),
        ))
        .map_err(msg)?;
    if rs.mean.is_finite() {
        chart
            .plotting_area()
            .draw(&DashedPathElement::new(
                vec![(rs.mean, 0.0), (rs.mean, y_hi)],
                10,
                6,
                ShapeStyle::from(&REFERENCE_COLOUR).stroke_width(2),
            ))
            .map_err(msg)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bin_widths_are_nice() {
        assert_eq!(nice_width(0.3), 1);
        assert_eq!(nice_width(1.4), 2);
        assert_eq!(nice_width(3.2), 5);
        assert_eq!(nice_width(14.0), 20);
    }
}
