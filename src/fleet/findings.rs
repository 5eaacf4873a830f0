//! The workshop's findings: what was measured on a pulled wheelset (flat length and depth,
//! or no flat), and how the passes before it fared — per site and for the fleet, the field's
//! own validation table beside the simulated one (docs/fleet.md, "Findings").
//!
//! A pass **held** a finding when its answer allows the measured flat: one of its cells
//! spans the measured (L, d) (any c), or, for a good wheel or a flat below the population,
//! a claim that allows small flats (no flat: below its detection limit). Refuted and unseen
//! passes say nothing and are counted apart. No tolerance is added to the workshop's
//! figures: a flat measured on a cell's edge counts as held, one a hair outside as missed.

use super::{across_sites, FleetError, FleetReader, FleetTarget, SitePass};
use crate::history::{Claim, FusionRule, Window};
use crate::identify::{Severity, SeverityRange};
use postgres::Client;
use serde::Serialize;
use std::path::Path;

/// The largest findings CSV read (bytes).
pub const MAX_CSV_BYTES: u64 = 16 << 20;
/// The longest note kept (characters).
pub const MAX_NOTE_CHARS: usize = 500;
/// The longest wheel id (characters).
pub const MAX_WHEEL_ID_CHARS: usize = 200;

/// A finding as entered.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Finding {
    /// `<bogie_id>/leading` or `…/trailing`, as the sites name it.
    pub wheel_id: String,
    /// The day the wheelset was measured (`YYYY-MM-DD`).
    pub found_on: String,
    /// Flat length L (mm; 0: no flat).
    pub length_mm: f64,
    /// Flat depth d (mm; 0: no flat).
    pub depth_mm: f64,
    /// The workshop's words.
    pub note: String,
}

impl Finding {
    /// A finding checked: a wheel id, a real date, L in [0, 500] mm, d in [0, 20] mm, both
    /// zero or both positive. `source` names where it came from in errors (`file:line`).
    pub fn new(
        source: &str,
        wheel_id: &str,
        found_on: &str,
        length_mm: &str,
        depth_mm: &str,
        note: &str,
    ) -> Result<Finding, FleetError> {
        let bad = |key: &'static str, value: &str, why: &str| FleetError::Finding {
            source_name: source.to_string(),
            key,
            value: value.to_string(),
            why: why.to_string(),
        };
        let wheel = wheel_id.trim();
        if wheel.is_empty() || wheel.chars().count() > MAX_WHEEL_ID_CHARS {
            return Err(bad("wheel", wheel_id, "a wheel id of 1–200 characters"));
        }
        let date = chrono::NaiveDate::parse_from_str(found_on.trim(), "%Y-%m-%d")
            .map_err(|_| bad("date", found_on, "a day as YYYY-MM-DD"))?;
        let number = |key: &'static str, v: &str, max: f64| -> Result<f64, FleetError> {
            let x: f64 = v.trim().parse().map_err(|_| bad(key, v, "not a number"))?;
            if !(0.0..=max).contains(&x) {
                return Err(bad(key, v, &format!("outside [0, {max}] mm")));
            }
            Ok(x)
        };
        let length_mm = number("length_mm", length_mm, 500.0)?;
        let depth_mm = number("depth_mm", depth_mm, 20.0)?;
        if (length_mm > 0.0) != (depth_mm > 0.0) {
            return Err(bad(
                "depth_mm",
                &format!("{depth_mm} with length {length_mm}"),
                "a flat has both a length and a depth; no flat is 0 and 0",
            ));
        }
        if note.chars().count() > MAX_NOTE_CHARS {
            return Err(bad(
                "note",
                &note.chars().take(40).collect::<String>(),
                "longer than 500 characters",
            ));
        }
        Ok(Finding {
            wheel_id: wheel.to_string(),
            found_on: date.format("%Y-%m-%d").to_string(),
            length_mm,
            depth_mm,
            note: note.to_string(),
        })
    }

    /// The day's end (Unix seconds, UTC): passes before it came before the finding.
    pub fn day_end_s(&self) -> f64 {
        chrono::NaiveDate::parse_from_str(&self.found_on, "%Y-%m-%d")
            .ok()
            .and_then(|d| d.and_hms_opt(0, 0, 0))
            .map_or(0.0, |t| t.and_utc().timestamp() as f64 + 86_400.0)
    }
}

/// The findings in a CSV file (header `wheel_id,date,length_mm,depth_mm[,note]`), every
/// row checked; the first bad one refused naming the file, line, key and value.
pub fn read_csv(path: &Path) -> Result<Vec<Finding>, FleetError> {
    let file_err = |why: String| FleetError::File {
        what: "findings CSV",
        path: path.to_path_buf(),
        why,
    };
    let meta = std::fs::metadata(path).map_err(|e| file_err(e.to_string()))?;
    if meta.len() > MAX_CSV_BYTES {
        return Err(file_err(format!(
            "{} bytes, more than {MAX_CSV_BYTES}",
            meta.len()
        )));
    }
    let mut reader = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .flexible(false)
        .from_path(path)
        .map_err(|e| file_err(e.to_string()))?;
    let headers = reader
        .headers()
        .map_err(|e| file_err(e.to_string()))?
        .clone();
    let col = |name: &str| headers.iter().position(|h| h == name);
    let (Some(w), Some(d), Some(l), Some(dp)) = (
        col("wheel_id"),
        col("date"),
        col("length_mm"),
        col("depth_mm"),
    ) else {
        return Err(file_err(format!(
            "header `{}`: needs wheel_id, date, length_mm, depth_mm (and may have note)",
            headers.iter().collect::<Vec<_>>().join(",")
        )));
    };
    let note = col("note");
    let mut out = Vec::new();
    for rec in reader.records() {
        let rec = rec.map_err(|e| file_err(e.to_string()))?;
        let line = rec.position().map_or(0, |p| p.line());
        let source = format!("{}:{line}", path.display());
        out.push(Finding::new(
            &source,
            &rec[w],
            &rec[d],
            &rec[l],
            &rec[dp],
            note.map_or("", |n| &rec[n]),
        )?);
    }
    Ok(out)
}

/// Stores findings in one transaction (the workshop's login); (new, already stored: same
/// wheel and day).
pub fn insert(
    client: &mut Client,
    target: &FleetTarget,
    findings: &[Finding],
) -> Result<(usize, usize), FleetError> {
    let mut tx = client
        .transaction()
        .map_err(target.sql("starting a transaction"))?;
    let mut new = 0;
    for f in findings {
        new += tx
            .execute(
                "INSERT INTO fleet.findings (wheel_id, found_on, length_mm, depth_mm, note)
                 VALUES ($1, ($2::text)::date, $3, $4, $5) ON CONFLICT (wheel_id, found_on) DO NOTHING",
                &[&f.wheel_id, &f.found_on, &f.length_mm, &f.depth_mm, &f.note],
            )
            .map_err(target.sql("storing a finding"))? as usize;
    }
    tx.commit().map_err(target.sql("committing the findings"))?;
    Ok((new, findings.len() - new))
}

/// A stored finding.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FindingRow {
    /// The finding.
    pub finding: Finding,
    /// Who entered it.
    pub entered_by: String,
}

/// How one pass fared against a finding.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Judged {
    /// The wheel.
    pub wheel_id: String,
    /// The site.
    pub site: String,
    /// Whether the workshop found a flat (d > 0).
    pub flat: bool,
    /// The pass's time (Unix seconds).
    pub time_s: f64,
    /// Held (true), missed (false), or silent (refuted, not seen: none).
    pub held: Option<bool>,
    /// The pass's classes.
    pub severity: Option<SeverityRange>,
    /// Whether the measured flat's class is among them.
    pub class_held: bool,
    /// Its L0 width (mm), for a pass that sized a flat.
    pub width_mm: Option<f64>,
}

/// One row of the validation table.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ValidationRow {
    /// A site's name, or `fleet`.
    pub scope: String,
    /// Findings with a pass of this scope before them.
    pub findings: usize,
    /// Passes before a finding.
    pub passes: usize,
    /// Of them, held.
    pub held: usize,
    /// Missed.
    pub missed: usize,
    /// Refuted or not seen.
    pub silent: usize,
    /// Passes of a real flat (d > 0) that sized it, and of those with one class.
    pub sized: usize,
    /// … with one class.
    pub one_class: usize,
    /// Passes whose classes hold the measured flat's class.
    pub class_held: usize,
    /// The median L0 width (mm) of the passes that sized a real flat.
    pub median_width_mm: Option<f64>,
    /// Findings whose fused answer (the passes of this scope before it) allows the measured
    /// flat.
    pub fused_held: usize,
}

/// The findings, every pass before each and the table.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Validation {
    /// The days before a finding whose passes are judged.
    pub days_before: f64,
    /// Each pass judged.
    pub judged: Vec<Judged>,
    /// Per site, then the fleet.
    pub rows: Vec<ValidationRow>,
}

impl FleetReader {
    /// The findings stored, newest first, at most `limit`.
    pub fn findings(&mut self, limit: i64) -> Result<Vec<FindingRow>, FleetError> {
        let target = self.target().clone();
        let rows = self
            .client()
            .query(
                "SELECT wheel_id, found_on::text, length_mm, depth_mm, note, entered_by::text
                 FROM fleet.findings ORDER BY found_on DESC, id DESC LIMIT $1",
                &[&limit.clamp(1, 100_000)],
            )
            .map_err(target.sql("reading findings"))?;
        Ok(rows
            .iter()
            .map(|r| FindingRow {
                finding: Finding {
                    wheel_id: r.get(0),
                    found_on: r.get(1),
                    length_mm: r.get(2),
                    depth_mm: r.get(3),
                    note: r.get(4),
                },
                entered_by: r.get(5),
            })
            .collect())
    }
}

/// The class of a measured flat (none for no flat), by its fresh length L0 = sqrt(8·d·R_w).
fn measured_class(f: &Finding, p: &SitePass, limits: [f64; 2]) -> Severity {
    if f.depth_mm <= 0.0 {
        return Severity::None;
    }
    Severity::of_upper_l0(p.pass.wheel.space.l0_mm(f.depth_mm), limits[1], limits[0])
}

/// Whether a pass's answer allows the measured flat (none: the pass says nothing).
pub fn holds(f: &Finding, p: &SitePass) -> Option<bool> {
    let w = &p.pass.wheel;
    if !w.claim.informative() {
        return None;
    }
    let small = f.depth_mm <= 0.0 || f.depth_mm < w.space.depth_mm[0];
    let in_cells = w.boxes.iter().any(|b| {
        let (l, d) = (f.length_mm as f32, f.depth_mm as f32);
        b[0] <= l && l <= b[1] && b[2] <= d && d <= b[3]
    });
    Some(match w.claim {
        Claim::None => {
            small
                || w.limit_l0_mm
                    .is_some_and(|lim| w.space.l0_mm(f.depth_mm) < lim)
        }
        Claim::Below | Claim::OtherWheel => small,
        Claim::Flat => in_cells,
        Claim::FlatOrOther => small || in_cells,
        Claim::Refuted | Claim::NotSeen => unreachable!("not informative"),
    })
}

/// Judges the passes of the `days_before` days before each finding (read from the store)
/// and tabulates them per site and for the fleet, with the L0 class limits [inspect, urgent].
pub fn validate(
    reader: &mut FleetReader,
    findings: &[Finding],
    days_before: f64,
    phi: f64,
    limits: [f64; 2],
) -> Result<Validation, FleetError> {
    let mut judged = Vec::new();
    let mut per_finding: Vec<(usize, Vec<SitePass>)> = Vec::new();
    for (i, f) in findings.iter().enumerate() {
        let end = f.day_end_s();
        let passes: Vec<SitePass> = reader
            .wheel_passes(
                &f.wheel_id,
                Window {
                    last: crate::history::db::MAX_WINDOW_PASSES,
                    hours: None,
                },
            )?
            .into_iter()
            .filter(|p| p.pass.time_s < end && p.pass.time_s >= end - days_before * 86_400.0)
            .collect();
        for p in &passes {
            let class = measured_class(f, p, limits);
            judged.push(Judged {
                wheel_id: f.wheel_id.clone(),
                site: p.site.clone(),
                flat: f.depth_mm > 0.0,
                time_s: p.pass.time_s,
                held: holds(f, p),
                severity: p.pass.wheel.severity,
                class_held: p
                    .pass
                    .wheel
                    .severity
                    .is_some_and(|s| s.lowest <= class && class <= s.highest),
                width_mm: matches!(p.pass.wheel.claim, Claim::Flat | Claim::FlatOrOther)
                    .then(|| p.pass.wheel.l0_mm.map(|r| r[1] - r[0]))
                    .flatten(),
            });
        }
        per_finding.push((i, passes));
    }
    let mut scopes: Vec<String> = judged.iter().map(|j| j.site.clone()).collect();
    scopes.sort();
    scopes.dedup();
    let mut rows = Vec::new();
    for scope in scopes.iter().map(Some).chain([None]) {
        let in_scope = |site: &str| scope.is_none_or(|s| s == site);
        let js: Vec<&Judged> = judged.iter().filter(|j| in_scope(&j.site)).collect();
        let sized: Vec<&Judged> = js
            .iter()
            .copied()
            .filter(|j| j.flat && j.width_mm.is_some())
            .collect();
        let mut widths: Vec<f64> = sized.iter().filter_map(|j| j.width_mm).collect();
        widths.sort_by(f64::total_cmp);
        let mut fused_held = 0;
        let mut with_passes = 0;
        for (i, passes) in &per_finding {
            let mine: Vec<SitePass> = passes
                .iter()
                .filter(|p| in_scope(&p.site))
                .cloned()
                .collect();
            if mine.is_empty() {
                continue;
            }
            with_passes += 1;
            let f = &findings[*i];
            let joint = across_sites(&mine, FusionRule::Robust, phi, limits[1], limits[0]).joint;
            let space = mine[0].pass.wheel.space;
            let allowed = if f.depth_mm <= 0.0 {
                joint.allows(None)
            } else {
                (0..=20).any(|k| {
                    let c = space.curvature_mm[0]
                        + (space.curvature_mm[1] - space.curvature_mm[0]) * k as f64 / 20.0;
                    joint.allows(Some([f.length_mm, f.depth_mm, c]))
                })
            };
            fused_held += usize::from(allowed);
        }
        rows.push(ValidationRow {
            scope: scope.cloned().unwrap_or_else(|| "fleet".into()),
            findings: with_passes,
            passes: js.len(),
            held: js.iter().filter(|j| j.held == Some(true)).count(),
            missed: js.iter().filter(|j| j.held == Some(false)).count(),
            silent: js.iter().filter(|j| j.held.is_none()).count(),
            sized: sized.len(),
            one_class: sized
                .iter()
                .filter(|j| j.severity.is_some_and(|s| s.lowest == s.highest))
                .count(),
            class_held: js.iter().filter(|j| j.class_held).count(),
            median_width_mm: (!widths.is_empty()).then(|| widths[widths.len() / 2]),
            fused_held,
        });
    }
    Ok(Validation {
        days_before,
        judged,
        rows,
    })
}
