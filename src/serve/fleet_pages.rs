//! The fleet's pages and their routes (`serve --fleet`):
//!
//! | page | JSON | what |
//! |---|---|---|
//! | `/` | `/api/fleet` | wheels needing action at any site, each site's health, the newest findings |
//! | `/wheel?id=…` | `/api/wheel?id=…` | a wheel across sites (`&last=`); its trend `/wheel/trend.svg?id=…` |
//! | `/findings` | `/api/findings` | the workshop's validation table (`?days=`) |
//! | `/metrics` | | shipping lag and pending passes per site (Prometheus text) |
//! | `/health` | | the store answers |

use super::fleet::{
    findings_view, fleet_metrics, fleet_view, fleet_wheel_view, FleetSettings, FleetState,
    FleetView, FleetWheelView, WHEEL_LAST,
};
use super::layout::{l0_words, range_badges, respond, wheel_href};
use super::routes::{blocking, query, Refusal};
use crate::fleet::findings::Validation;
use crate::fleet::words::{age, time};
use crate::fleet::FleetError;
use axum::extract::{Query, State};
use axum::http::{HeaderMap, StatusCode};
use axum::response::{IntoResponse, Json, Response};
use axum::routing::get;
use axum::Router;
use maud::{html, Markup};
use serde::Deserialize;
use std::sync::Arc;

type Shared = Arc<FleetState>;

/// The fleet server's routes (connects now: refused when the store cannot be read).
pub fn fleet_router(settings: FleetSettings) -> Result<Router, FleetError> {
    let token = settings.token.clone().map(Arc::new);
    let state = Arc::new(FleetState::new(settings)?);
    Ok(Router::new()
        .route("/", get(fleet_page))
        .route("/api/fleet", get(fleet_json))
        .route("/wheel", get(wheel_page))
        .route("/api/wheel", get(wheel_json))
        .route("/wheel/trend.svg", get(wheel_trend))
        .route("/findings", get(findings_page))
        .route("/api/findings", get(findings_json))
        .route("/metrics", get(metrics))
        .route("/health", get(health))
        .fallback(|| async { (StatusCode::NOT_FOUND, "no such page\n") })
        .with_state(state)
        .layer(axum::middleware::from_fn_with_state(
            token,
            super::access::require_token,
        )))
}

type Q<T> = Result<Query<T>, axum::extract::rejection::QueryRejection>;

async fn fleet_data(state: Shared) -> Result<FleetView, Refusal> {
    blocking(move || fleet_view(&state)).await
}

async fn fleet_page(State(state): State<Shared>, headers: HeaderMap) -> Result<Response, Refusal> {
    let v = fleet_data(state).await?;
    Ok(respond(&headers, "fleet", fleet_html(&v)))
}

async fn fleet_json(State(state): State<Shared>) -> Result<Response, Refusal> {
    Ok(Json(fleet_data(state).await?).into_response())
}

/// `/wheel?id=&last=`.
#[derive(Debug, Deserialize)]
struct WheelQuery {
    id: String,
    last: Option<usize>,
}

async fn wheel_data(state: Shared, q: Q<WheelQuery>) -> Result<FleetWheelView, Refusal> {
    let q = query(q)?;
    let last = q.last.unwrap_or(WHEEL_LAST);
    if !(1..=1000).contains(&last) || q.id.is_empty() || q.id.len() > 200 {
        return Err(Refusal::BadQuery(format!(
            "id must be 1–200 characters and last in 1–1000 (got {} characters, last {last})",
            q.id.len()
        )));
    }
    let id = q.id.clone();
    blocking(move || fleet_wheel_view(&state, &q.id, last))
        .await?
        .ok_or_else(|| Refusal::NotFound(format!("no pass of wheel `{id}` at any site")))
}

async fn wheel_page(
    State(state): State<Shared>,
    headers: HeaderMap,
    q: Q<WheelQuery>,
) -> Result<Response, Refusal> {
    let v = wheel_data(state, q).await?;
    let title = format!("wheel {}", v.report.wheel);
    Ok(respond(&headers, &title, wheel_html(&v)))
}

async fn wheel_json(State(state): State<Shared>, q: Q<WheelQuery>) -> Result<Response, Refusal> {
    Ok(Json(wheel_data(state, q).await?).into_response())
}

async fn wheel_trend(State(state): State<Shared>, q: Q<WheelQuery>) -> Result<Response, Refusal> {
    super::routes::trend_svg(wheel_data(state, q).await?.report).await
}

/// `/findings?days=`.
#[derive(Debug, Deserialize)]
struct FindingsQuery {
    days: Option<f64>,
}

async fn findings_data(state: Shared, q: Q<FindingsQuery>) -> Result<Validation, Refusal> {
    let days = query(q)?.days.unwrap_or(30.0);
    if !(1.0..=365.0).contains(&days) {
        return Err(Refusal::BadQuery(format!(
            "days {days}: must lie in [1, 365]"
        )));
    }
    blocking(move || findings_view(&state, days)).await
}

async fn findings_page(
    State(state): State<Shared>,
    headers: HeaderMap,
    q: Q<FindingsQuery>,
) -> Result<Response, Refusal> {
    let v = findings_data(state, q).await?;
    Ok(respond(&headers, "findings", findings_html(&v)))
}

async fn findings_json(
    State(state): State<Shared>,
    q: Q<FindingsQuery>,
) -> Result<Response, Refusal> {
    Ok(Json(findings_data(state, q).await?).into_response())
}

async fn metrics(State(state): State<Shared>) -> Result<Response, Refusal> {
    Ok(super::routes::metrics_response(
        blocking(move || fleet_metrics(&state)).await?,
    ))
}

async fn health(State(state): State<Shared>) -> Result<Response, Refusal> {
    blocking(move || state.read(|r| r.wheel_count())).await?;
    Ok("ok\n".into_response())
}

fn fleet_html(v: &FleetView) -> Markup {
    html! {
        h1 { "Fleet" }
        p.note { (v.sites.len()) " sites, " (v.wheels) " named wheels. " a href="/findings" { "The workshop's findings against the passes" } " · " a href="/api/fleet" { "JSON" } }
        h2 { "Wheels needing action (" (v.action.len()) ")" }
        @if v.action.is_empty() { p { "No wheel's newest pass allows inspect or urgent." } }
        @else {
            table id="action" {
                tr { th { "wheel" } th { "classes" } th { "L0" } th { "newest pass" } th { "site" } th { "passes (all sites)" } }
                @for w in &v.action {
                    tr {
                        td { a href=(wheel_href(&w.wheel_id)) { (w.wheel_id) } }
                        td { (range_badges(w.severity)) }
                        td { (l0_words(w.l0_mm)) }
                        td { (time(w.time_s)) }
                        td { (w.site) }
                        td.num { (w.passes) }
                    }
                }
            }
        }
        h2 { "Sites" }
        table id="sites" {
            tr { th { "site" } th { "newest pass" } th { "bank" } th { "bank in use for" } th { "refused (24 h)" } th { "drift alarms (7 d)" } th { "pending" } th { "shipping lag" } }
            @for s in &v.sites {
                tr {
                    td { (s.site) }
                    td { (s.newest_pass_s.map_or("—".into(), time)) }
                    td { (s.bank_id.clone().unwrap_or_else(|| "—".into())) }
                    td { (s.bank_since_s.map_or("—".into(), |t| age(v.now_s - t))) }
                    td.num { (s.refusals_24h) }
                    td.num { (s.drift_alarms_7d) }
                    td.num { (s.pending.map_or("—".into(), |p| p.to_string())) }
                    td class={ @if s.lag_s.is_none_or(|l| l > 600.0) { "changed" } } { (s.lag_s.map_or("never shipped".into(), age)) }
                }
            }
        }
        h2 { "Newest findings" }
        (findings_list(&v.findings))
    }
}

fn findings_list(f: &[crate::fleet::FindingRow]) -> Markup {
    html! {
        @if f.is_empty() { p { "No finding entered yet (" code { "wheelflat found" } ")." } }
        @else {
            table id="findings" {
                tr { th { "wheel" } th { "day" } th { "L" } th { "d" } th { "note" } th { "by" } }
                @for r in f {
                    tr {
                        td { a href=(wheel_href(&r.finding.wheel_id)) { (r.finding.wheel_id) } }
                        td { (r.finding.found_on) }
                        td.num { (format!("{:.1} mm", r.finding.length_mm)) }
                        td.num { (format!("{:.2} mm", r.finding.depth_mm)) }
                        td { (r.finding.note) }
                        td { (r.entered_by) }
                    }
                }
            }
        }
    }
}

fn wheel_html(v: &FleetWheelView) -> Markup {
    let r = &v.report;
    let q = form_urlencoded::Serializer::new(String::new())
        .append_pair("id", &r.wheel)
        .finish();
    html! {
        h1 { "Wheel " (r.wheel) " across sites" }
        p id="joint" {
            "Joint answer over " (r.passes.len()) " passes at " (v.across.sites.len()) " sites: L0 "
            (l0_words(r.joint.l0_mm)) " " (range_badges(r.joint.severity)) ". " (r.joint.words)
        }
        @if !v.across.disagreeing.is_empty() {
            p.changed id="disagreeing" { "Disagreeing: " (v.across.disagreeing.join(", ")) " — its passes and the other sites' allow no common flat." }
        }
        @if let Some(c) = &v.across.change { p.changed { "The flat " (c) "." } }
        p.note { a href={"/api/wheel?" (q)} { "JSON" } }
        div.figure { img.figure src={"/wheel/trend.svg?" (q)} alt={"trend of wheel " (r.wheel)} width="1200" height="900"; }
        h2 { "Passes (oldest first)" }
        table id="wheel-passes" {
            tr { th { "#" } th { "site" } th { "time" } th { "claim" } th { "L0" } th { "classes" } th { "in the joint answer" } }
            @for (i, p) in r.passes.iter().enumerate() {
                tr {
                    td.num { (p.pass) }
                    td { (v.sites_of_passes[i]) }
                    td { (p.time) }
                    td { (p.claim.as_str()) }
                    td { (l0_words(p.l0_mm)) }
                    td { (range_badges(p.severity)) }
                    td { @if r.joint.passes_used.contains(&i) { "used" } @else if r.joint.passes_silent.contains(&i) { "silent" } @else { "left out" } }
                }
            }
        }
    }
}

fn findings_html(v: &Validation) -> Markup {
    html! {
        h1 { "The workshop's findings against the passes before them" }
        p.note {
            "Each pass of the " (v.days_before) " days before a finding: held when its answer allows the measured flat (L, d), missed when not, silent when refuted or unseen. "
            a href="/api/findings" { "JSON" }
        }
        table id="validation" {
            tr { th { "scope" } th { "findings" } th { "passes" } th { "held" } th { "missed" } th { "silent" } th { "sized a flat" } th { "one class" } th { "class held" } th { "median L0 width" } th { "fused held" } }
            @for r in &v.rows {
                tr {
                    td { (r.scope) }
                    td.num { (r.findings) } td.num { (r.passes) } td.num { (r.held) } td.num { (r.missed) }
                    td.num { (r.silent) } td.num { (r.sized) } td.num { (r.one_class) } td.num { (r.class_held) }
                    td.num { (r.median_width_mm.map_or("—".into(), |w| format!("{w:.1} mm"))) }
                    td.num { (r.fused_held) "/" (r.findings) }
                }
            }
        }
    }
}
