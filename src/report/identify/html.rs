//! The self-contained `report.html`: the verdict, the numbers and the figures inlined as SVG,
//! with its CSS. Every range it shows is one the [`Identification`] carries, so the page and
//! `identification.json` agree.

use std::fmt::{self, Write as _};

use super::{fmt_num, fmt_range, Figure, JSON_FILE};
use crate::identify::answer::identification::Identification;
use crate::identify::answer::result::InstanceParams;
use crate::identify::answer::sizing::Sizing;
use crate::report::canvas::escape_html;

/// An SVG document made ready to inline in HTML: no XML prolog, doctype or leading comments,
/// no namespace attribute (implied in HTML), and an accessible label.
pub(super) fn inline_svg(svg: &str, label: &str) -> String {
    let mut s = svg.trim_start();
    while s.starts_with("<?") || s.starts_with("<!") {
        let end = if s.starts_with("<!--") {
            s.find("-->").map(|i| i + 3)
        } else {
            s.find('>').map(|i| i + 1)
        };
        match end {
            Some(end) => s = s[end..].trim_start(),
            None => break,
        }
    }
    let s = s.replacen(" xmlns=\"http://www.w3.org/2000/svg\"", "", 1);
    s.replacen(
        "<svg",
        &format!("<svg role=\"img\" aria-label=\"{}\"", escape_html(label)),
        1,
    )
}

/// Plain CSS of the report.
const CSS: &str = r#"
:root { color-scheme: light; }
body { font-family: system-ui, -apple-system, "Segoe UI", "DejaVu Sans", Arial, sans-serif;
       margin: 0; background: #eef0f3; color: #1d232a; line-height: 1.5; font-size: 16px; }
main { max-width: 1180px; margin: 0 auto; padding: 20px 36px 40px; background: #fff;
       box-shadow: 0 0 12px rgba(0, 0, 0, 0.06); }
h1 { font-size: 1.9rem; margin: 0.3em 0 0.1em; }
h2 { font-size: 1.35rem; margin: 1.8em 0 0.6em; padding-bottom: 0.2em;
     border-bottom: 2px solid #e3e6ea; }
h3 { font-size: 1.1rem; margin: 1.4em 0 0.4em; }
p { max-width: 75em; }
.meta { color: #555; margin-top: 0; }
.verdict { border-left: 6px solid #2c7a3f; background: #f1f8f3; padding: 0.5em 1.2em; }
.verdict.refuted { border-left-color: #c0392b; background: #fdf1ef; }
.hint { border-left: 6px solid #d98c00; background: #fff8e8; padding: 0.6em 1.2em; }
table { border-collapse: collapse; margin: 0.6em 0 1em; font-size: 0.95rem; }
th, td { border-bottom: 1px solid #e3e6ea; padding: 0.3em 0.9em; text-align: left;
         vertical-align: top; }
thead th { background: #f0f2f5; border-bottom: 2px solid #d5d9de; }
td.num, th.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
table.kv th { font-weight: 600; white-space: nowrap; }
tr.total td { font-weight: 600; border-top: 2px solid #d5d9de; }
figure { margin: 1.2em 0 1.8em; }
figure svg { display: block; width: 100%; height: auto; border: 1px solid #e3e6ea; }
figcaption { color: #444; font-size: 0.92rem; margin-top: 0.4em; }
code { font-size: 0.92em; background: #f0f2f5; padding: 0 0.3em; border-radius: 3px;
       overflow-wrap: anywhere; }
details > summary { cursor: pointer; margin: 0.5em 0; }
footer { color: #777; font-size: 0.85rem; margin-top: 3em; }
@media print {
  body { background: #fff; }
  main { box-shadow: none; }
  figure, table { break-inside: avoid; }
}
"#;

/// The whole HTML report; `figures` are the rendered SVGs.
pub(super) fn render_html(
    id: &Identification,
    figures: &[(Figure, String)],
) -> Result<String, fmt::Error> {
    let e = escape_html;
    let mut h =
        String::with_capacity(64 * 1024 + figures.iter().map(|(_, s)| s.len()).sum::<usize>());
    let mut fig_no = 0;
    let mut figure = |h: &mut String, fig: Figure| -> fmt::Result {
        if let Some((_, svg)) = figures.iter().find(|(f, _)| *f == fig) {
            fig_no += 1;
            writeln!(
                h,
                "<figure id=\"fig-{name}\">\n{svg}<figcaption><strong>Figure {fig_no}.</strong> {caption}</figcaption>\n</figure>",
                name = fig.name(),
                svg = inline_svg(svg, fig.caption()),
                caption = e(fig.caption()),
            )?;
        }
        Ok(())
    };

    writeln!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">"
    )?;
    writeln!(
        h,
        "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">"
    )?;
    writeln!(
        h,
        "<title>Wheel-flat identification – {}</title>",
        e(&id.measurement)
    )?;
    writeln!(h, "<style>{CSS}</style>\n</head>\n<body>\n<main>")?;

    // Header and verdict.
    writeln!(h, "<h1>Wheel-flat identification</h1>")?;
    writeln!(
        h,
        "<p class=\"meta\">Measurement <code>{}</code> · model bank <code>{}</code> ({} instances)</p>",
        e(&id.measurement),
        e(&id.bank_id),
        id.bank_instances
    )?;
    if let Some(l) = &id.load {
        writeln!(h, "<p class=\"meta\">{}</p>", e(&l.words()))?;
    }
    let refuted = if id.model_class_refuted() {
        " refuted"
    } else {
        ""
    };
    writeln!(
        h,
        "<section class=\"verdict{refuted}\">\n<h2>Result</h2>\n<p>{}</p>\n</section>",
        e(&id.summary)
    )?;
    writeln!(
        h,
        "<p class=\"hint\"><strong>Maintenance:</strong> {}</p>",
        e(&id.maintenance_hint)
    )?;
    if let Some(c) = id.severity {
        writeln!(
            h,
            "<p class=\"hint\"><strong>Severity:</strong> {}</p>",
            e(&c.words())
        )?;
    }
    if let Some(r) = &id.refinement {
        writeln!(
            h,
            "<section class=\"verdict\">\n<h2>Refined</h2>\n<p>{}</p>\n<p class=\"hint\">{}</p>\n</section>",
            e(&r.summary),
            e(&r.maintenance_hint)
        )?;
    }

    writeln!(h, "<table class=\"kv\">\n<tbody>")?;
    match &id.sizing {
        Some(z) => write_candidate_set(&mut h, id, z)?,
        None => writeln!(
            h,
            "<tr><th>Candidate model set</th><td>none: no flat detected, so the bank was not searched</td></tr>"
        )?,
    }
    writeln!(h, "</tbody>\n</table>")?;

    // Measurement and alignment.
    writeln!(h, "<h2>Measurement and alignment</h2>")?;
    let a = &id.alignment;
    writeln!(h, "<table class=\"kv\">\n<tbody>")?;
    writeln!(
        h,
        "<tr><th>Alignment</th><td>{}</td></tr>",
        e(&a.method.to_string())
    )?;
    writeln!(
        h,
        "<tr><th>Shift</th><td>{} ms (bank time = measurement time + shift)</td></tr>",
        fmt_num(1e3 * a.shift_s, 3)
    )?;
    if let Some(c) = a.correlation {
        writeln!(
            h,
            "<tr><th>Correlation at the shift</th><td>{}</td></tr>",
            fmt_num(c, 4)
        )?;
    }
    writeln!(h, "</tbody>\n</table>")?;
    writeln!(
        h,
        "<table>\n<thead><tr><th>Sensor</th><th class=\"num\">Samples</th><th class=\"num\">Rate (Hz)</th>\
         <th class=\"num\">Window (s)</th><th class=\"num\">Peak (kN)</th></tr></thead>\n<tbody>"
    )?;
    for s in &id.series {
        let n = s.values_kn.len();
        let end = if s.sample_rate_hz > 0.0 && n > 0 {
            s.t0_s + (n - 1) as f64 / s.sample_rate_hz
        } else {
            s.t0_s
        };
        let peak = s
            .values_kn
            .iter()
            .copied()
            .filter(|v| v.is_finite())
            .fold(f64::NAN, f64::max);
        writeln!(
            h,
            "<tr><td>{}</td><td class=\"num\">{n}</td><td class=\"num\">{}</td><td class=\"num\">{} – {}</td><td class=\"num\">{}</td></tr>",
            e(&s.sensor),
            fmt_num(s.sample_rate_hz, 0),
            fmt_num(s.t0_s, 4),
            fmt_num(end, 4),
            fmt_num(peak, 1)
        )?;
    }
    writeln!(h, "</tbody>\n</table>")?;
    figure(&mut h, Figure::Series)?;
    if let Some(d) = &id.detection {
        writeln!(h, "<h2>Detection</h2>")?;
        writeln!(h, "<p>{}</p>", e(&crate::report::tables::detection_line(d)))?;
        if let Some(r) = &id.roughness {
            writeln!(h, "<p>Roughness: {}</p>", e(&r.words()))?;
        }
        figure(&mut h, Figure::Detection)?;
    }

    match &id.sizing {
        Some(z) => write_sizing(&mut h, id, z, &mut figure)?,
        None => writeln!(
            h,
            "<h2>Comparison points</h2>\n<p>None: no flat was detected, so the pass was not sized \
             (no comparison points, no candidate model set; the detection above gives the \
             pass's detection limit).</p>"
        )?,
    }

    // Timings.
    writeln!(h, "<h2>Timings</h2>")?;
    writeln!(h, "<table>\n<thead><tr><th>Stage</th><th class=\"num\">Wall-clock (ms)</th></tr></thead>\n<tbody>")?;
    for (stage, ms) in &id.timings_ms {
        writeln!(
            h,
            "<tr><td>{}</td><td class=\"num\">{}</td></tr>",
            e(stage),
            fmt_num(*ms, 1)
        )?;
    }
    let total: f64 = id.timings_ms.iter().map(|(_, ms)| ms).sum();
    writeln!(
        h,
        "<tr class=\"total\"><td>total</td><td class=\"num\">{}</td></tr>",
        fmt_num(total, 1)
    )?;
    writeln!(h, "</tbody>\n</table>")?;

    writeln!(
        h,
        "<footer>wheelflat {} · error-domain model falsification after Cao et al. · \
         the full result is in <code>{JSON_FILE}</code> next to this file.</footer>",
        env!("CARGO_PKG_VERSION")
    )?;
    writeln!(h, "</main>\n</body>\n</html>")?;
    Ok(h)
}

/// The rows of the candidate model set in the result table (a sized pass).
fn write_candidate_set(h: &mut String, id: &Identification, z: &Sizing) -> fmt::Result {
    let e = escape_html;
    let share = if id.bank_instances > 0 {
        format!(
            " ({} %)",
            fmt_num(100.0 * z.cms.len() as f64 / id.bank_instances as f64, 3)
        )
    } else {
        String::new()
    };
    writeln!(
        h,
        "<tr><th>Candidate model set</th><td>{} of {} instances{share}</td></tr>",
        z.cms.len(),
        id.bank_instances
    )?;
    if z.model_class_refuted {
        writeln!(
            h,
            "<tr><th>Model class</th><td>refuted: every instance was falsified</td></tr>"
        )?;
    }
    // The ranges as the identification reports them (the union of cells), never recomputed
    // here: the page once showed the hull of the survivors, narrower than the JSON's.
    if let Some(r) = z.cms_ranges() {
        for (name, range, decimals) in [
            ("Fresh-flat length L0", r.l0_mm, 1),
            ("Flat length L", r.length_mm, 1),
            ("Flat depth d", r.depth_mm, 3),
            ("Curvature c", r.curvature_mm, 3),
            ("Impact position X_p", r.impact_position_m, 3),
        ] {
            let unit = if name.ends_with("X_p") { "m" } else { "mm" };
            writeln!(
                h,
                "<tr><th>{}</th><td>{} {unit}</td></tr>",
                e(name),
                fmt_range(range, decimals)
            )?;
        }
    }
    if let Some(rm) = &z.residual_minimisation {
        writeln!(
            h,
            "<tr><th>Residual minimisation</th><td>L0 = {} mm (instance {}, no uncertainties)</td></tr>",
            fmt_num(rm.l0_mm, 1),
            rm.instance
        )?;
    }
    Ok(())
}

/// The sections of a sized pass: its comparison points, their entropies, falsification, the
/// candidate model set and the random comparison points; `figure` inlines a figure.
fn write_sizing(
    h: &mut String,
    id: &Identification,
    z: &Sizing,
    figure: &mut dyn FnMut(&mut String, Figure) -> fmt::Result,
) -> fmt::Result {
    let e = escape_html;
    // Comparison points.
    writeln!(h, "<h2>Comparison points</h2>")?;
    writeln!(h, "<table class=\"kv\">\n<tbody>")?;
    writeln!(
        h,
        "<tr><th>PIP</th><td>{} per series ({} distance), {} in all</td></tr>",
        id.pips_per_series,
        e(id.pip_distance.as_str()),
        z.candidates.len()
    )?;
    let final_h = z.eip_joint_entropy_bits.last().copied().unwrap_or(f64::NAN);
    writeln!(
        h,
        "<tr><th>EIP</th><td>{} selected; joint entropy {} bits (stop threshold α = {} bits)</td></tr>",
        z.eip.len(),
        fmt_num(final_h, 2),
        fmt_num(z.alpha_bits, 3)
    )?;
    if id.bank_instances > 0 {
        writeln!(
            h,
            "<tr><th>log2 N</th><td>{} bits (the most any set of points can tell apart)</td></tr>",
            fmt_num((id.bank_instances as f64).log2(), 2)
        )?;
    }
    writeln!(
        h,
        "<tr><th>Identification probability φ</th><td>{} (Šídák: {} per point)</td></tr>",
        fmt_num(id.phi, 3),
        fmt_num(z.per_point_probability, 5)
    )?;
    writeln!(h, "</tbody>\n</table>")?;
    writeln!(
        h,
        "<table>\n<thead><tr><th class=\"num\">Order</th><th class=\"num\">PIP</th><th>Sensor</th>\
         <th class=\"num\">Time (s)</th><th class=\"num\">Measured (kN)</th><th class=\"num\">Entropy (bits)</th>\
         <th class=\"num\">Joint entropy (bits)</th><th class=\"num\">Thresholds (kN)</th>\
         <th class=\"num\">Typical cell widening ± (kN)</th><th class=\"num\">Admissible predictions before widening (kN)</th></tr></thead>\n<tbody>"
    )?;
    for (k, &ci) in z.eip.iter().enumerate() {
        let joint = z.eip_joint_entropy_bits.get(k).copied().unwrap_or(f64::NAN);
        match z.candidates.get(ci) {
            Some(c) => {
                let sensor = id.series.get(c.series).map_or("?", |s| s.sensor.as_str());
                writeln!(
                    h,
                    "<tr><td class=\"num\">{}</td><td class=\"num\">{ci}</td><td>{}</td><td class=\"num\">{}</td>\
                     <td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td>\
                     <td class=\"num\">{}</td><td class=\"num\">{}</td></tr>",
                    k + 1,
                    e(sensor),
                    fmt_num(c.time_s, 5),
                    fmt_num(c.measured_kn, 2),
                    fmt_num(c.entropy_bits, 2),
                    fmt_num(joint, 2),
                    fmt_range([c.threshold_low_kn, c.threshold_high_kn], 2),
                    fmt_num(c.resolution_kn, 2),
                    fmt_range(
                        [c.measured_kn + c.threshold_low_kn, c.measured_kn + c.threshold_high_kn],
                        2
                    ),
                )?;
            }
            None => writeln!(
                h,
                "<tr><td class=\"num\">{}</td><td class=\"num\">{ci}</td><td colspan=\"8\">not a candidate point</td></tr>",
                k + 1
            )?,
        }
    }
    writeln!(h, "</tbody>\n</table>")?;
    figure(h, Figure::Entropy)?;
    figure(h, Figure::JointEntropy)?;

    // Falsification.
    writeln!(h, "<h2>Falsification</h2>")?;
    writeln!(
        h,
        "<table>\n<thead><tr><th>Comparison points</th><th class=\"num\">Points</th><th class=\"num\">CMS</th>\
         <th class=\"num\">L0 (mm)</th><th class=\"num\">L (mm)</th><th class=\"num\">d (mm)</th></tr></thead>\n<tbody>"
    )?;
    for f in &z.falsifications {
        let (l0, l, d) = match &f.ranges {
            Some(r) => (
                fmt_range(r.l0_mm, 1),
                fmt_range(r.length_mm, 1),
                fmt_range(r.depth_mm, 3),
            ),
            None => ("–".to_string(), "–".to_string(), "–".to_string()),
        };
        writeln!(
            h,
            "<tr><td>{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{l0}</td>\
             <td class=\"num\">{l}</td><td class=\"num\">{d}</td></tr>",
            e(&f.method.to_string()),
            f.points,
            f.cms_count
        )?;
    }
    writeln!(h, "</tbody>\n</table>")?;
    figure(h, Figure::ParallelCoordinates)?;

    if let Some(rm) = &z.residual_minimisation {
        writeln!(h, "<h3>Residual minimisation without uncertainties</h3>")?;
        writeln!(
            h,
            "<p>The instance that minimises the residual over the EIP, ignoring uncertainties \
             (paper §4.4); compare its L0 with the CMS range.</p>"
        )?;
        write_instances(h, std::slice::from_ref(rm))?;
    }

    if !z.cms.is_empty() {
        const MAX_ROWS: usize = 500;
        writeln!(
            h,
            "<details>\n<summary>Candidate model set: {} instances{}</summary>",
            z.cms.len(),
            if z.cms.len() > MAX_ROWS {
                format!(" (first {MAX_ROWS} shown; all are in identification.json)")
            } else {
                String::new()
            }
        )?;
        write_instances(h, &z.cms[..z.cms.len().min(MAX_ROWS)])?;
        writeln!(h, "</details>")?;
    }

    // Random subsets.
    writeln!(h, "<h2>Random comparison points</h2>")?;
    match &z.random_subsets {
        Some(rs) => {
            let eip_count = z.cms.len();
            writeln!(h, "<table class=\"kv\">\n<tbody>")?;
            writeln!(
                h,
                "<tr><th>Subsets</th><td>{} draws of {} points from the {} PIP (seed {})</td></tr>",
                rs.subsets,
                rs.size,
                z.candidates.len(),
                rs.seed
            )?;
            writeln!(
                h,
                "<tr><th>CMS size</th><td>mean {}, median {}; with the EIP: {eip_count}</td></tr>",
                fmt_num(rs.mean, 1),
                fmt_num(rs.median, 1)
            )?;
            if !rs.cms_counts.is_empty() {
                let at_most = rs.cms_counts.iter().filter(|&&c| c <= eip_count).count();
                writeln!(
                    h,
                    "<tr><th>Subsets as good as the EIP</th><td>{at_most} of {} ({} %) have a CMS of at most {eip_count}</td></tr>",
                    rs.cms_counts.len(),
                    fmt_num(100.0 * at_most as f64 / rs.cms_counts.len() as f64, 1)
                )?;
            }
            writeln!(h, "</tbody>\n</table>")?;
            figure(h, Figure::RandomSubsets)?;
        }
        None => writeln!(h, "<p>Not computed for this identification.</p>")?,
    }

    Ok(())
}

/// A table of instances (parameters in real units).
fn write_instances(h: &mut String, instances: &[InstanceParams]) -> fmt::Result {
    writeln!(
        h,
        "<table>\n<thead><tr><th class=\"num\">Instance</th><th class=\"num\">L (mm)</th><th class=\"num\">d (mm)</th>\
         <th class=\"num\">c (mm)</th><th class=\"num\">X_p (m)</th><th class=\"num\">L0 (mm)</th></tr></thead>\n<tbody>"
    )?;
    for p in instances {
        writeln!(
            h,
            "<tr><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td>\
             <td class=\"num\">{}</td><td class=\"num\">{}</td></tr>",
            p.instance,
            fmt_num(p.length_mm, 1),
            fmt_num(p.depth_mm, 3),
            fmt_num(p.curvature_mm, 3),
            fmt_num(p.impact_position_m, 3),
            fmt_num(p.l0_mm, 1)
        )?;
    }
    writeln!(h, "</tbody>\n</table>")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escaping_and_inlining() {
        assert_eq!(
            escape_html(r#"a<b & "c" 'd'>"#),
            "a&lt;b &amp; &quot;c&quot; &#39;d&#39;&gt;"
        );
        let svg = "<?xml version=\"1.0\"?>\n<!-- x > y -->\n<svg width=\"1\" xmlns=\"http://www.w3.org/2000/svg\"></svg>";
        assert_eq!(
            inline_svg(svg, "a<b"),
            "<svg role=\"img\" aria-label=\"a&lt;b\" width=\"1\"></svg>"
        );
    }
}
