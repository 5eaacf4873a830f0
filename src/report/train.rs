//! The whole-train result for people and spreadsheets: the wheel table as CSV, as text and
//! as a self-contained HTML page ([`crate::train`] computes, this module renders).

use super::canvas::escape_html;
use crate::train::TrainResult;

/// The table as CSV.
pub fn table_csv(r: &TrainResult) -> String {
    let mut s = String::from(
        "car,bogie,wheel,flat,l0_min_mm,l0_max_mm,cms_count,severity,speed_km_per_h,bank_speed_km_per_h,refined_l0_min_mm,refined_l0_max_mm,load_kn,load_min_kn,load_max_kn,bank_load_kn,severity_classes,wheel_id\n",
    );
    for w in &r.wheels {
        let (lo, hi) = w.l0_mm.map_or((String::new(), String::new()), |[a, b]| {
            (format!("{a:.1}"), format!("{b:.1}"))
        });
        let (v, vb) = r
            .bogies
            .get(w.bogie.wrapping_sub(1))
            .map_or((f64::NAN, f64::NAN), |b| {
                (b.speed_km_per_h, b.bank_speed_km_per_h)
            });
        let load = r
            .bogies
            .get(w.bogie.wrapping_sub(1))
            .and_then(|b| b.load.as_ref())
            .map_or(",,,".to_string(), |l| {
                format!(
                    "{:.1},{:.1},{:.1},{:.1}",
                    l.wheel_load_kn, l.interval_kn[0], l.interval_kn[1], l.bank_wheel_load_kn
                )
            });
        let (rlo, rhi) = w
            .refined_l0_mm
            .map_or((String::new(), String::new()), |[a, b]| {
                (format!("{a:.1}"), format!("{b:.1}"))
            });
        s += &format!(
            "{},{},{},{},{lo},{hi},{},{},{v:.2},{vb},{rlo},{rhi},{load},{},{}\n",
            w.car,
            w.bogie,
            w.wheel.name(),
            w.flat,
            w.cms_count,
            w.severity,
            w.classes.map_or(String::new(), |c| c.short()),
            w.wheel_id.as_deref().unwrap_or("")
        );
    }
    s
}

/// The bogies' speeds (from their triggers) and the banks they were compared with, grouped
/// by bank: `speeds: bogies 1–4 at 44.1–45.2 km/h against the 44 km/h bank; …`.
pub fn speeds_line(r: &TrainResult) -> String {
    let mut groups: Vec<(f64, Vec<&crate::train::BogieResult>)> = Vec::new();
    for b in &r.bogies {
        match groups
            .iter_mut()
            .find(|g| g.0.to_bits() == b.bank_speed_km_per_h.to_bits())
        {
            Some(g) => g.1.push(b),
            None => groups.push((b.bank_speed_km_per_h, vec![b])),
        }
    }
    let parts: Vec<String> = groups
        .iter()
        .map(|(vb, bs)| {
            let (lo, hi) = bs.iter().fold((f64::MAX, f64::MIN), |(l, h), b| {
                (l.min(b.speed_km_per_h), h.max(b.speed_km_per_h))
            });
            let names: Vec<String> = bs.iter().map(|b| b.bogie.to_string()).collect();
            format!(
                "bogie{} {} at {lo:.1}–{hi:.1} km/h against the {vb} km/h bank",
                if bs.len() == 1 { "" } else { "s" },
                names.join(", ")
            )
        })
        .collect();
    format!("speeds: {}", parts.join("; "))
}

/// The wheel load each bogie's part of the record shows, and the bank's it was compared at:
/// `loads (kN a wheel, read from the record): bogie 1 47.9 (bank 49.5), bogie 2 36.0 (bank 34.8)`.
pub fn loads_line(r: &TrainResult) -> String {
    let parts: Vec<String> = r
        .bogies
        .iter()
        .filter_map(|b| {
            b.load.as_ref().map(|l| {
                format!(
                    "bogie {} {:.1} ({:.1}–{:.1}; bank {:.1})",
                    b.bogie,
                    l.wheel_load_kn,
                    l.interval_kn[0],
                    l.interval_kn[1],
                    l.bank_wheel_load_kn
                )
            })
        })
        .collect();
    format!(
        "loads (kN a wheel, read from the record, {:.0} % interval): {}",
        crate::identify::detect::load::LOAD_INTERVAL_PROBABILITY * 100.0,
        parts.join(", ")
    )
}

/// A wheel's L0 range, and its refined range after an arrow when it was refined:
/// `[36, 51] → [39, 45]`.
fn l0_text(w: &crate::train::WheelRow) -> String {
    let range = |[a, b]: [f64; 2]| format!("[{a:.0}, {b:.0}]");
    match (w.l0_mm, w.refined_l0_mm) {
        (Some(l), Some(r)) => format!("{} → {}", range(l), range(r)),
        (Some(l), None) => range(l),
        _ => "—".into(),
    }
}

/// A wheel's severity for people: `urgent`, or `inspect-urgent (act as urgent)`.
fn severity_text(w: &crate::train::WheelRow) -> String {
    match w.classes {
        Some(c) if !c.decisive() => format!("{} (act as {})", c.short(), c.acted_on()),
        _ => w.severity.to_string(),
    }
}

/// A wheel's bogie for people: its place, and its id from the consist when given (`5 4711-5`).
fn bogie_text(w: &crate::train::WheelRow) -> String {
    match w.wheel_id.as_deref().and_then(|id| id.rsplit_once('/')) {
        Some((bogie, _)) => format!("{} {bogie}", w.bogie),
        None => w.bogie.to_string(),
    }
}

/// The table for people.
pub fn table_text(r: &TrainResult) -> String {
    let width = r
        .wheels
        .iter()
        .map(|w| bogie_text(w).chars().count())
        .max()
        .unwrap_or(0)
        .max(6);
    let mut s = format!(
        "{:<4} {:<width$} {:<9} {:<8} {:<20} {:>7}  {}\n",
        "car", "bogie", "wheel", "flat", "L0 (mm)", "CMS", "severity"
    );
    // (A refined wheel's L0 column reads `bank-only → refined`.)
    for w in &r.wheels {
        let l0 = l0_text(w);
        s += &format!(
            "{:<4} {:<width$} {:<9} {:<8} {:<20} {:>7}  {}\n",
            w.car,
            bogie_text(w),
            w.wheel.name(),
            w.flat,
            l0,
            w.cms_count,
            severity_text(w)
        );
    }
    s
}

/// The HTML section (a self-contained page).
pub fn table_html(r: &TrainResult) -> String {
    let esc = escape_html;
    let mut h = String::from(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>wheelflat: train</title>\n<style>body{font-family:sans-serif;margin:2em}table{border-collapse:collapse}td,th{border:1px solid #bbb;padding:4px 8px}td.num{text-align:right}.urgent{background:#f8d0d0}.inspect{background:#fbe7c0}.monitor{background:#e8f0d8}</style></head><body>\n",
    );
    h += &format!(
        "<h1>Whole-train identification</h1>\n<p>Recording <code>{}</code>, bank <code>{}</code>, {} bogies in {:.0} ms.</p>\n<h2>Wheels</h2>\n<table><thead><tr><th>car</th><th>bogie</th><th>wheel</th><th>flat</th><th>L0 (mm)</th><th>CMS</th><th>severity</th></tr></thead><tbody>\n",
        esc(&r.recording),
        esc(&r.bank_id),
        r.bogies.len(),
        r.total_ms
    );
    for w in &r.wheels {
        let l0 = esc(&l0_text(w));
        h += &format!(
            "<tr class=\"{}\"><td class=\"num\">{}</td><td class=\"num\">{}</td><td>{}</td><td>{}</td><td>{l0}</td><td class=\"num\">{}</td><td>{}</td></tr>\n",
            esc(w.severity.as_str()),
            w.car,
            esc(&bogie_text(w)),
            w.wheel.name(),
            esc(w.flat.as_str()),
            w.cms_count,
            esc(&severity_text(w))
        );
    }
    h += &format!(
        "</tbody></table>\n<p>{}.</p>\n<p>Severity rule: {}.</p>\n",
        esc(&format!("{} — {}", speeds_line(r), loads_line(r))),
        esc(&r.severity_rule)
    );
    for w in &r.warnings {
        h += &format!("<p><strong>Warning:</strong> {}</p>\n", esc(w));
    }
    h += "<h2>Bogies</h2>\n<ul>\n";
    for b in &r.bogies {
        let text = match &b.identification {
            None => format!(
                "no flat detected: all {} samples within the good wheel's bounds (closest {:.2} kN inside){}",
                b.detection.samples,
                -b.detection.worst().map_or(0.0, |w| w.excess_kn),
                b.detection
                    .limit
                    .as_ref()
                    .and_then(|l| l.l0_mm)
                    .map_or(String::new(), |l0| format!("; detection limit L0 {l0:.0} mm"))
            ),
            Some(id) => format!(
                "flat detected ({:.2} kN beyond the good wheel's bounds); {}",
                b.detection.worst().map_or(0.0, |w| w.excess_kn),
                id.summary
            ),
        };
        h += &format!("<li>bogie {}: {}</li>\n", b.bogie, esc(&text));
    }
    h += "</ul>\n</body></html>\n";
    h
}
