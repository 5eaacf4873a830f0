//! The site's setup on the site page (issue 57): the family in use (its speeds and loads), the
//! calibration its banks were built from (voids, sensor gains, the family's load step) and the
//! newest nightly check (`calibrate --check --report BANK/calibration-DATE.json`, as
//! `scripts/regenerate-nightly.sh` writes it): when, and what drifted. Read from the bank
//! folder each time the page is read, every file checked before it is shown.

use crate::bank::family::Family;
use crate::model::Effect;
use crate::site::drift::Drifted;
use maud::{html, Markup};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The largest check report read (a report is a few kilobytes).
const MAX_REPORT_BYTES: u64 = 16 << 20;

/// What the site runs on.
#[derive(Debug, Clone, Serialize)]
pub(super) struct SiteSetup {
    /// The members: `(speed km/h, car-body factor when over loads, static wheel load kN)`.
    pub(super) members: Vec<(f64, Option<f64>, f64)>,
    /// The voided sleepers the calibration states: `(sleeper, gap mm)`.
    pub(super) voids: Vec<(usize, f64)>,
    /// The sensor gains it states: `(sensor, factor)`.
    pub(super) gains: Vec<(String, f64)>,
    /// The family's load step it states (`population.family_load_step`).
    pub(super) family_load_step: Option<f64>,
    /// The newest nightly check in the bank folder.
    pub(super) last_check: Option<LastCheck>,
    /// Why the family or its calibration cannot be read, when it cannot.
    pub(super) unreadable: Option<String>,
}

/// The newest `calibration-*.json` in the bank folder.
#[derive(Debug, Clone, Serialize)]
pub(super) struct LastCheck {
    /// Its file name (the date the nightly script put in it).
    pub(super) file: String,
    /// What drifted (empty: nothing); `None` for a report of `calibrate` without `--check`.
    pub(super) drifted: Option<Vec<Drifted>>,
    /// Why it cannot be read, when it cannot.
    pub(super) unreadable: Option<String>,
}

/// The part of a report the page shows.
#[derive(Deserialize)]
struct Report {
    #[serde(default)]
    check: Option<Vec<Drifted>>,
}

/// The setup of the bank or family in `dir`.
pub(super) fn setup(dir: &Path) -> SiteSetup {
    let mut s = SiteSetup {
        members: Vec::new(),
        voids: Vec::new(),
        gains: Vec::new(),
        family_load_step: None,
        last_check: last_check(dir),
        unreadable: None,
    };
    let opened = Family::open(dir).and_then(|(family, single)| {
        let bank = match single {
            Some(b) => b,
            None => family.members[0].open()?,
        };
        Ok((family, bank))
    });
    match opened {
        Ok((family, bank)) => {
            s.members = family
                .members
                .iter()
                .map(|m| (m.speed_km_per_h, m.load_factor, m.wheel_load_kn))
                .collect();
            let cal = &bank.metadata().calibration;
            for e in &cal.effects {
                match e {
                    Effect::VoidedSleeper { sleeper, gap_mm } => s.voids.push((*sleeper, *gap_mm)),
                    Effect::SensorGain { sensor, factor } => {
                        s.gains.push((sensor.clone(), *factor))
                    }
                    _ => {}
                }
            }
            s.family_load_step = cal.population.family_load_step;
        }
        Err(e) => s.unreadable = Some(e.to_string()),
    }
    s
}

/// The newest `calibration-*.json` in `dir` (by name: the nightly script dates them), read.
fn last_check(dir: &Path) -> Option<LastCheck> {
    let newest = std::fs::read_dir(dir)
        .ok()?
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with("calibration-") && n.ends_with(".json"))
        .max()?;
    let path = dir.join(&newest);
    let read = || -> Result<Option<Vec<Drifted>>, String> {
        let bytes = std::fs::metadata(&path).map_err(|e| e.to_string())?.len();
        if bytes > MAX_REPORT_BYTES {
            return Err(format!(
                "{bytes} bytes, more than a report's {MAX_REPORT_BYTES}"
            ));
        }
        let text = std::fs::read_to_string(&path).map_err(|e| e.to_string())?;
        let r: Report = serde_json::from_str(&text).map_err(|e| format!("not a report: {e}"))?;
        Ok(r.check)
    };
    Some(match read() {
        Ok(drifted) => LastCheck {
            file: newest,
            drifted,
            unreadable: None,
        },
        Err(e) => LastCheck {
            file: newest,
            drifted: None,
            unreadable: Some(e),
        },
    })
}

/// The setup's part of the site page.
pub(super) fn setup_html(s: &SiteSetup) -> Markup {
    html! {
        h2 { "Site calibration" }
        @if let Some(e) = &s.unreadable { p { span.changed { "cannot be read: " (e) } } }
        p {
            (s.members.len()) " member(s): "
            @for (i, (v, f, w)) in s.members.iter().enumerate() {
                @if i > 0 { ", " }
                (format!("{v:.1} km/h")) @if let Some(f) = f { (format!(" × {f:.2} car body ({w:.1} kN a wheel)")) }
            }
            @if let Some(step) = s.family_load_step { (format!("; the site's load step {step:.2}")) }
        }
        p {
            "Voided sleepers: "
            @if s.voids.is_empty() { "none stated" }
            @for (i, (k, g)) in s.voids.iter().enumerate() { @if i > 0 { ", " } (format!("sleeper {k}: {g:.2} mm")) }
            ". Sensor gains: "
            @if s.gains.is_empty() { "none stated" }
            @for (i, (n, f)) in s.gains.iter().enumerate() { @if i > 0 { ", " } (format!("{n} × {f:.3}")) }
            "."
        }
        p {
            "Last nightly check: "
            @match &s.last_check {
                None => { span.note { "none in the bank folder" } }
                Some(c) => {
                    code { (c.file) } ": "
                    @if let Some(e) = &c.unreadable { span.changed { "cannot be read: " (e) } }
                    @else if let Some(d) = &c.drifted {
                        @if d.is_empty() { "no drift" } @else {
                            span.changed { "drifted: " }
                            @for (i, x) in d.iter().enumerate() {
                                @if i > 0 { "; " }
                                (format!("{} was {:.3}, now {:.3} [{:.3}, {:.3}]", x.what, x.was, x.now[0], x.now[1], x.now[2]))
                            }
                        }
                    } @else { "a calibration, not a check" }
                }
            }
        }
    }
}
