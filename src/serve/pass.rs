//! One pass's page: its verdict, what it said of each wheel (claim, L0 range, classes, the
//! detection limit, the surviving cells), the figures and report its command wrote when their
//! folder is still there, and the record to download.

use super::layout::{l0_words, number, range_badges, wheel_href};
use super::state::AppState;
use crate::history::{Claim, DbError, PassRow, Space};
use crate::identify::SeverityRange;
use maud::{html, Markup};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// The kinds of file of a result folder the server hands out (by extension).
const SERVED_EXTENSIONS: [&str; 5] = ["html", "png", "svg", "json", "csv"];
/// The largest result file served (bytes).
pub(super) const MAX_RESULT_FILE_BYTES: u64 = 32 << 20;
/// The most files of a result folder listed.
const MAX_RESULT_FILES: usize = 100;

/// One wheel of the pass, whole.
#[derive(Debug, Clone, Serialize)]
pub(super) struct WheelDetail {
    /// `leading` or `trailing`.
    pub(super) wheel: String,
    /// Its id, when the bogie was named.
    pub(super) wheel_id: Option<String>,
    /// What the pass said of it.
    pub(super) claim: Claim,
    /// The claim's L0 range (mm).
    pub(super) l0_mm: Option<[f64; 2]>,
    /// Its classes.
    pub(super) severity: Option<SeverityRange>,
    /// The detection limit on L0 (mm) when no flat was detected.
    pub(super) limit_l0_mm: Option<f64>,
    /// The sizing space of the bank.
    pub(super) space: Space,
    /// The surviving cells: `[L_lo, L_hi, d_lo, d_hi, c_lo, c_hi]` (mm).
    pub(super) cells: Vec<[f32; 6]>,
    /// The flat's dynamic-ratio range, when sized.
    pub(super) dynamic_ratio: Option<[f64; 2]>,
}

/// The pass page's numbers (the JSON at `/api/pass/<id>`, and the record to download).
#[derive(Debug, Clone, Serialize)]
pub(super) struct PassView {
    /// The pass.
    pub(super) pass: PassRow,
    /// Leading, then trailing.
    pub(super) wheels: Vec<WheelDetail>,
    /// The files of its result folder the server hands out (`/pass/<id>/files/<name>`); empty
    /// when the folder is gone or was never written.
    pub(super) result_files: Vec<String>,
    /// The files of its report drawn by the server (`/pass/<id>/drawn/<name>`), when the result
    /// folder holds `identification.json` and no `report.html` and the page was asked for.
    pub(super) drawn_files: Vec<String>,
    /// Why the report could not be drawn, when it could not.
    pub(super) drawn_error: Option<String>,
}

/// Reads a pass's numbers; none for no such pass. With `draw`, a report its command did not
/// draw is drawn ([`super::drawn`]).
pub(super) fn pass_view(
    state: &AppState,
    id: i64,
    draw: bool,
) -> Result<Option<PassView>, DbError> {
    let Some(d) = state.read(|db| db.pass_detail(id))? else {
        return Ok(None);
    };
    let wheels = d
        .wheels
        .iter()
        .map(|s| WheelDetail {
            wheel: s.wheel.wheel.name().to_string(),
            wheel_id: d
                .row
                .bogie_id
                .as_ref()
                .map(|b| format!("{b}/{}", s.wheel.wheel.name())),
            claim: s.wheel.claim,
            l0_mm: s.wheel.l0_mm,
            severity: s.wheel.severity,
            limit_l0_mm: s.wheel.limit_l0_mm,
            space: s.wheel.space,
            cells: s.wheel.boxes.clone(),
            dynamic_ratio: s.wheel.dynamic_ratio,
        })
        .collect();
    let result_files = d
        .row
        .result_dir
        .as_deref()
        .map(|dir| served_files(Path::new(dir)))
        .unwrap_or_default();
    let (mut drawn_files, mut drawn_error) = (Vec::new(), None);
    if let (true, Some(dir)) = (draw, d.row.result_dir.as_deref()) {
        let has = |n: &str| result_files.iter().any(|f| f == n);
        if has("identification.json") && !has("report.html") {
            match state
                .drawn
                .draw(id, &Path::new(dir).join("identification.json"))
            {
                Ok(drawn) => drawn_files = served_files(&drawn),
                Err(e) => drawn_error = Some(e),
            }
        }
    }
    Ok(Some(PassView {
        pass: d.row,
        wheels,
        result_files,
        drawn_files,
        drawn_error,
    }))
}

/// The files of `dir` handed out: regular files (not links) with a served extension, at most
/// [`MAX_RESULT_FILE_BYTES`], by name; none when the folder cannot be read.
fn served_files(dir: &Path) -> Vec<String> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut names: Vec<String> = entries
        .filter_map(Result::ok)
        .filter(|e| {
            e.file_type().is_ok_and(|t| t.is_file())
                && e.metadata().is_ok_and(|m| m.len() <= MAX_RESULT_FILE_BYTES)
        })
        .filter_map(|e| e.file_name().to_str().map(str::to_string))
        .filter(|n| {
            !n.starts_with('.')
                && Path::new(n)
                    .extension()
                    .and_then(|x| x.to_str())
                    .is_some_and(|x| SERVED_EXTENSIONS.contains(&x))
        })
        .collect();
    names.sort();
    names.truncate(MAX_RESULT_FILES);
    names
}

/// The file `name` of the pass's result folder (or, `drawn`, of its drawn report), when the
/// server hands it out: the name must be one [`served_files`] lists (so no other path is
/// reachable).
pub(super) fn result_file(
    state: &AppState,
    v: &PassView,
    name: &str,
    drawn: bool,
) -> Option<PathBuf> {
    if drawn {
        return v
            .drawn_files
            .iter()
            .any(|n| n == name)
            .then(|| state.drawn.dir(v.pass.pass_id).join(name));
    }
    let dir = v.pass.result_dir.as_deref()?;
    v.result_files
        .iter()
        .any(|n| n == name)
        .then(|| Path::new(dir).join(name))
}

/// The content type of a served file.
pub(super) fn content_type(name: &str) -> &'static str {
    match Path::new(name).extension().and_then(|x| x.to_str()) {
        Some("html") => "text/html; charset=utf-8",
        Some("png") => "image/png",
        Some("svg") => "image/svg+xml",
        Some("json") => "application/json",
        _ => "text/csv; charset=utf-8",
    }
}

/// The pass page's main part.
pub(super) fn pass_html(v: &PassView) -> Markup {
    let p = &v.pass;
    let id = p.pass_id;
    html! {
        h1 { "Pass " (id) ": " (p.time) }
        p id="summary" { (p.summary) }
        table id="pass-meta" {
            tr { th { "measurement" } td { (p.measurement) } }
            tr { th { "bogie" } td { (p.bogie_id.as_deref().unwrap_or("— (not named: in no wheel's history)")) } }
            tr { th { "speed" } td { (number(p.speed_km_per_h, 1)) " km/h" } }
            tr { th { "wheel load" } td { (number(p.load_kn, 1)) " kN" } }
            tr { th { "bank" } td { code { (p.bank_id) } } }
            tr { th { "result folder" } td { (p.result_dir.as_deref().unwrap_or("— (not recorded)")) } }
        }
        h2 { "Wheels" }
        table id="pass-wheels" {
            tr { th { "wheel" } th { "claim" } th { "L0" } th { "classes" } th { "dynamic ratio" } th { "detection limit" } th { "surviving cells" } }
            @for w in &v.wheels {
                tr {
                    td { @match &w.wheel_id { Some(wid) => { a href=(wheel_href(wid)) { (wid) } } None => { (w.wheel) } } }
                    td { (w.claim.as_str()) }
                    td { (l0_words(w.l0_mm)) }
                    td { (range_badges(w.severity)) }
                    td { (w.dynamic_ratio.map_or("—".into(), |d| format!("[{:.2}, {:.2}]", d[0], d[1]))) }
                    td { (w.limit_l0_mm.map_or("—".into(), |l| format!("L0 {l:.0} mm"))) }
                    td.num { (w.cells.len()) }
                }
            }
        }
        p { a href={"/pass/" (id) "/record.json"} download={"pass-" (id) ".json"} { "Download the record (JSON)" } }
        h2 { "Report" }
        @if v.result_files.is_empty() {
            p.note { "The folder its command wrote is not there any more (or was never recorded): the stored answer above is the pass." }
        } @else {
            @for (files, route) in [(&v.result_files, "files"), (&v.drawn_files, "drawn")] {
                @if files.iter().any(|n| n == "report.html") {
                    p { a href={"/pass/" (id) "/" (route) "/report.html"} { "The pass's report" }
                        @if route == "drawn" { span.note { " (drawn by this server from its identification.json)" } } }
                }
            }
            @if let Some(e) = &v.drawn_error { p.note { (e) } }
            ul { @for n in &v.result_files { li { a href={"/pass/" (id) "/files/" (n)} { (n) } } } }
            @for (files, route) in [(&v.result_files, "files"), (&v.drawn_files, "drawn")] {
                @for n in files.iter().filter(|n| n.ends_with(".png")) {
                    figure { img.figure src={"/pass/" (id) "/" (route) "/" (n)} alt=(n); figcaption.note { (n) } }
                }
            }
        }
    }
}
