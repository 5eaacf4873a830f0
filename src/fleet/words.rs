//! The fleet's answers in words for the terminal: times, ages, the sites' verdicts on a wheel
//! and the workshop's validation table.

use super::{AcrossSites, Validation};

/// Now (Unix seconds).
pub fn now_s() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}

/// A time as `YYYY-MM-DD HH:MMZ` (UTC).
pub fn time(t_s: f64) -> String {
    chrono::DateTime::from_timestamp(t_s as i64, 0).map_or_else(
        || format!("{t_s}"),
        |t| t.format("%Y-%m-%d %H:%MZ").to_string(),
    )
}

/// A duration in the unit that reads best: `42 s`, `12 min`, `3.5 h`, `4.2 d`.
pub fn age(s: f64) -> String {
    if s < 120.0 {
        format!("{s:.0} s")
    } else if s < 7200.0 {
        format!("{:.0} min", s / 60.0)
    } else if s < 2.0 * 86_400.0 {
        format!("{:.1} h", s / 3600.0)
    } else {
        format!("{:.1} d", s / 86_400.0)
    }
}

/// What each site's passes say beside the others', and a change across sites.
pub fn across_text(a: &AcrossSites) -> String {
    let mut out = String::from("sites:\n");
    for s in &a.sites {
        let verdict = match s.agrees {
            Some(true) => "agrees with the other sites",
            Some(false) => "DISAGREES: its passes and the other sites' allow no common flat",
            None => "no verdict (the only site, silent, or the flat changed over time)",
        };
        out.push_str(&format!(
            "  {:<20} {:>4} passes  {verdict}\n",
            s.site, s.passes
        ));
    }
    if let Some(c) = &a.change {
        out.push_str(&format!("across sites: the flat {c}\n"));
    }
    out
}

/// The validation table: per site and for the fleet.
pub fn validation_table(v: &Validation) -> String {
    let mut out = format!(
        "the passes of the {} days before each finding:\n{:<20} {:>8} {:>7} {:>6} {:>7} {:>7} {:>6} {:>10} {:>10} {:>13}\n",
        v.days_before,
        "scope", "findings", "passes", "held", "missed", "silent", "sized", "one class", "class held", "median width"
    );
    for r in &v.rows {
        out.push_str(&format!(
            "{:<20} {:>8} {:>7} {:>6} {:>7} {:>7} {:>6} {:>10} {:>10} {:>13}   fused held {}/{}\n",
            r.scope,
            r.findings,
            r.passes,
            r.held,
            r.missed,
            r.silent,
            r.sized,
            r.one_class,
            r.class_held,
            r.median_width_mm
                .map_or("—".into(), |w| format!("{w:.1} mm")),
            r.fused_held,
            r.findings
        ));
    }
    out
}

/// A wheel's passes at every site, oldest first, one line each (site, time, claim, L0,
/// classes), then the joint answer.
pub fn passes_text(
    wheel: &str,
    passes: &[super::SitePass],
    joint: &crate::history::Joint,
) -> String {
    let mut s = format!(
        "wheel {wheel}: {} passes at every site (oldest first)\n{:<5} {:<16} {:<24} {:<13} {:<16} {}\n",
        passes.len(),
        "pass",
        "site",
        "time",
        "claim",
        "L0 (mm)",
        "classes"
    );
    for (i, p) in passes.iter().enumerate() {
        let w = &p.pass.wheel;
        s += &format!(
            "{:<5} {:<16} {:<24} {:<13} {:<16} {}\n",
            i + 1,
            p.site,
            p.pass.time,
            w.claim.as_str(),
            w.l0_mm
                .map_or("—".into(), |r| format!("[{:.0}, {:.0}]", r[0], r[1])),
            w.severity.map_or("—".into(), |c| c.words())
        );
    }
    s += &format!(
        "joint: L0 {}; classes {}\n{}\n",
        joint
            .l0_mm
            .map_or("—".into(), |r| format!("[{:.0}, {:.0}] mm", r[0], r[1])),
        joint.severity.map_or("—".into(), |c| c.words()),
        joint.words
    );
    s
}
