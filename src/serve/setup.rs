//! The site's setup on the site page (docs/serve.md): the family in use (its speeds and loads), the
//! calibration its banks were built from (voids, sensor gains, the family's load step) and the
//! newest nightly check (`calibrate --check --report BANK/calibration-DATE.json`, as
//! `scripts/regenerate-nightly.sh` writes it): when, and what drifted. Read from the bank
//! folder each time the page is read, every file checked before it is shown.

use crate::alarm::drift::{newest_check, LastCheck};
use crate::bank::family::Family;
use crate::model::Effect;
use maud::{html, Markup};
use serde::Serialize;
use std::path::Path;

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

/// The setup of the bank or family in `dir`.
pub(super) fn setup(dir: &Path) -> SiteSetup {
    let mut s = SiteSetup {
        members: Vec::new(),
        voids: Vec::new(),
        gains: Vec::new(),
        family_load_step: None,
        last_check: newest_check(dir),
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
