//! The paths the server answers, each page with its JSON beside it:
//!
//! | page | JSON | what |
//! |---|---|---|
//! | `/` | `/api/site` | the site (`?bogie=&class=&hours=`) |
//! | `/wheel?id=…` | `/api/wheel?id=…` | a wheel (`&last=&hours=&rule=`); its trend `/wheel/trend.svg?id=…` |
//! | `/pass/<id>` | `/api/pass/<id>` | a pass; its record `/pass/<id>/record.json`, its files `/pass/<id>/files/<name>`, its drawn report `/pass/<id>/drawn/<name>` |
//! | | `/api/alarms` | the alarms (`?status=&last=`) |
//! | `/metrics` | | the Prometheus text format (docs/alarms.md) |
//! | `/health` | | the database opens and answers |
//!
//! Only GET (and HEAD); a bad path or query is answered 4xx with the reason, a database that
//! cannot be read 503.

use super::alarms::{alarms_view, AlarmsQuery};
use super::error::ServeError;
use super::layout::respond;
use super::metrics::metrics_text;
use super::pass::{content_type, pass_html, pass_view, result_file, MAX_RESULT_FILE_BYTES};
use super::site::{site_html, site_view, SiteQuery};
use super::state::{AppState, Settings};
use super::wheel::{wheel_html, wheel_view, WheelQuery};
use axum::extract::{Path, Query, State};
use axum::http::{header, HeaderMap, StatusCode};
use axum::response::{IntoResponse, Json, Response};
use axum::routing::get;
use axum::Router;
use std::sync::Arc;

type Shared = Arc<AppState>;

/// The server's routes over `settings`' database (opened now: refused, with `history`'s
/// words, when missing, not wheelflat's, or newer).
pub fn router(settings: Settings) -> Result<Router, ServeError> {
    let token = settings.token.clone().map(Arc::new);
    let state = AppState::new(settings)?;
    count_in_background(&state);
    Ok(Router::new()
        .route("/", get(site_page))
        .route("/api/site", get(site_json))
        .route("/wheel", get(wheel_page))
        .route("/api/wheel", get(wheel_json))
        .route("/wheel/trend.svg", get(wheel_trend))
        .route("/pass/{id}", get(pass_page))
        .route("/api/pass/{id}", get(pass_json))
        .route("/pass/{id}/record.json", get(pass_record))
        .route("/pass/{id}/files/{name}", get(pass_file))
        .route("/pass/{id}/drawn/{name}", get(drawn_file))
        .route("/api/alarms", get(alarms_json))
        .route("/metrics", get(metrics))
        .route("/health", get(health))
        .fallback(not_found)
        .with_state(state)
        .layer(axum::middleware::from_fn_with_state(
            token,
            super::access::require_token,
        )))
}

/// `/metrics` and `/health` alone (`watch --metrics`), over `settings`' database.
pub fn metrics_router(settings: Settings) -> Result<Router, ServeError> {
    let state = AppState::new(settings)?;
    count_in_background(&state);
    Ok(Router::new()
        .route("/metrics", get(metrics))
        .route("/health", get(health))
        .fallback(not_found)
        .with_state(state))
}

/// Counts the database once for `/metrics` on a thread of its own, so that the first scrape
/// reads only what is new (the whole of a large database takes a quarter of a second,
/// docs/alarms.md); a database that cannot be read now is read again by the first scrape.
fn count_in_background(state: &Shared) {
    let state = Arc::clone(state);
    let _ = std::thread::Builder::new()
        .name("metrics-count".into())
        .spawn(move || metrics_text(&state));
}

/// Why a request gets no page (the fleet's pages too: `fleet_pages`).
pub(super) enum Refusal {
    /// 400: a query out of its range.
    BadQuery(String),
    /// 404: nothing there.
    NotFound(String),
    /// 503: the database (or the fleet store) cannot be read now.
    Unavailable(String),
    /// 500: the request's work stopped (a defect).
    Internal(String),
}

impl IntoResponse for Refusal {
    fn into_response(self) -> Response {
        let (code, words) = match self {
            Refusal::BadQuery(w) => (StatusCode::BAD_REQUEST, w),
            Refusal::NotFound(w) => (StatusCode::NOT_FOUND, w),
            Refusal::Unavailable(w) => (StatusCode::SERVICE_UNAVAILABLE, w),
            Refusal::Internal(w) => (StatusCode::INTERNAL_SERVER_ERROR, w),
        };
        (code, format!("{words}\n")).into_response()
    }
}

/// Runs blocking database work on the blocking pool; its error is a 503 with its words.
pub(super) async fn blocking<T: Send + 'static, E: std::fmt::Display + Send + 'static>(
    work: impl FnOnce() -> Result<T, E> + Send + 'static,
) -> Result<T, Refusal> {
    match tokio::task::spawn_blocking(work).await {
        Ok(r) => r.map_err(|e| Refusal::Unavailable(e.to_string())),
        Err(e) => Err(Refusal::Internal(format!(
            "the request's work stopped: {e}"
        ))),
    }
}

/// A query that did not parse (axum's words) or is out of range.
pub(super) fn query<T>(
    q: Result<Query<T>, axum::extract::rejection::QueryRejection>,
) -> Result<T, Refusal> {
    q.map(|Query(q)| q)
        .map_err(|e| Refusal::BadQuery(e.body_text()))
}

async fn site_data(
    state: Shared,
    q: Result<Query<SiteQuery>, axum::extract::rejection::QueryRejection>,
) -> Result<super::site::SiteView, Refusal> {
    let q = query(q)?;
    q.check().map_err(Refusal::BadQuery)?;
    blocking(move || site_view(&state, q)).await
}

async fn site_page(
    State(state): State<Shared>,
    headers: HeaderMap,
    q: Result<Query<SiteQuery>, axum::extract::rejection::QueryRejection>,
) -> Result<Response, Refusal> {
    let v = site_data(state, q).await?;
    Ok(respond(&headers, "site", site_html(&v)))
}

async fn site_json(
    State(state): State<Shared>,
    q: Result<Query<SiteQuery>, axum::extract::rejection::QueryRejection>,
) -> Result<Response, Refusal> {
    Ok(Json(site_data(state, q).await?).into_response())
}

async fn wheel_data(
    state: Shared,
    q: Result<Query<WheelQuery>, axum::extract::rejection::QueryRejection>,
) -> Result<super::wheel::WheelView, Refusal> {
    let q = query(q)?;
    q.check().map_err(Refusal::BadQuery)?;
    let id = q.id.clone();
    blocking(move || wheel_view(&state, q)).await?.ok_or_else(|| {
        Refusal::NotFound(format!(
            "no pass of wheel `{id}` (wheels are `<bogie_id>/leading` or `…/trailing`; the site page lists them)"
        ))
    })
}

async fn wheel_page(
    State(state): State<Shared>,
    headers: HeaderMap,
    q: Result<Query<WheelQuery>, axum::extract::rejection::QueryRejection>,
) -> Result<Response, Refusal> {
    let v = wheel_data(state, q).await?;
    let title = format!("wheel {}", v.report.wheel);
    Ok(respond(&headers, &title, wheel_html(&v)))
}

async fn wheel_json(
    State(state): State<Shared>,
    q: Result<Query<WheelQuery>, axum::extract::rejection::QueryRejection>,
) -> Result<Response, Refusal> {
    Ok(Json(wheel_data(state, q).await?).into_response())
}

async fn wheel_trend(
    State(state): State<Shared>,
    q: Result<Query<WheelQuery>, axum::extract::rejection::QueryRejection>,
) -> Result<Response, Refusal> {
    trend_svg(wheel_data(state, q).await?.report).await
}

/// A wheel's trend figure drawn on the blocking pool, as SVG (the fleet's wheel page too).
pub(super) async fn trend_svg(
    report: crate::report::history::HistoryReport,
) -> Result<Response, Refusal> {
    let svg = tokio::task::spawn_blocking(move || crate::report::history::trend_svg(&report))
        .await
        .map_err(|e| Refusal::Internal(format!("the figure's work stopped: {e}")))?
        .map_err(|e| Refusal::Internal(format!("the trend could not be drawn: {e}")))?;
    Ok(([(header::CONTENT_TYPE, "image/svg+xml")], svg).into_response())
}

/// A pass id in a path: a positive integer.
fn pass_id(raw: &str) -> Result<i64, Refusal> {
    raw.parse::<i64>()
        .ok()
        .filter(|&i| i > 0)
        .ok_or_else(|| Refusal::BadQuery(format!("`{raw}` is not a pass id (a positive integer)")))
}

async fn pass_data(state: Shared, raw: &str, draw: bool) -> Result<super::pass::PassView, Refusal> {
    let id = pass_id(raw)?;
    blocking(move || pass_view(&state, id, draw))
        .await?
        .ok_or_else(|| Refusal::NotFound(format!("no pass {id} in the database")))
}

async fn pass_page(
    State(state): State<Shared>,
    headers: HeaderMap,
    Path(id): Path<String>,
) -> Result<Response, Refusal> {
    let v = pass_data(state, &id, true).await?;
    let title = format!("pass {}", v.pass.pass_id);
    Ok(respond(&headers, &title, pass_html(&v)))
}

async fn pass_json(
    State(state): State<Shared>,
    Path(id): Path<String>,
) -> Result<Response, Refusal> {
    Ok(Json(pass_data(state, &id, false).await?).into_response())
}

async fn pass_record(
    State(state): State<Shared>,
    Path(id): Path<String>,
) -> Result<Response, Refusal> {
    let v = pass_data(state, &id, false).await?;
    let disposition = format!("attachment; filename=\"pass-{}.json\"", v.pass.pass_id);
    let mut r = Json(v).into_response();
    if let Ok(d) = disposition.parse() {
        r.headers_mut().insert(header::CONTENT_DISPOSITION, d);
    }
    Ok(r)
}

async fn pass_file(
    State(state): State<Shared>,
    Path((id, name)): Path<(String, String)>,
) -> Result<Response, Refusal> {
    hand_out(state, &id, &name, false).await
}

async fn drawn_file(
    State(state): State<Shared>,
    Path((id, name)): Path<(String, String)>,
) -> Result<Response, Refusal> {
    hand_out(state, &id, &name, true).await
}

/// A file of a pass's result folder (or, `drawn`, of its drawn report), at most
/// [`MAX_RESULT_FILE_BYTES`].
async fn hand_out(state: Shared, id: &str, name: &str, drawn: bool) -> Result<Response, Refusal> {
    let v = pass_data(state.clone(), id, drawn).await?;
    let path = result_file(&state, &v, name, drawn).ok_or_else(|| {
        Refusal::NotFound(format!(
            "pass {} has no file `{name}` to hand out (its page lists those it has)",
            v.pass.pass_id
        ))
    })?;
    let bytes = tokio::task::spawn_blocking(move || {
        use std::io::Read;
        let f = std::fs::File::open(&path)?;
        let mut bytes = Vec::new();
        f.take(MAX_RESULT_FILE_BYTES + 1).read_to_end(&mut bytes)?;
        Ok::<_, std::io::Error>(bytes)
    })
    .await
    .map_err(|e| Refusal::Internal(format!("reading the file stopped: {e}")))?
    .map_err(|e| Refusal::NotFound(format!("`{name}` cannot be read now: {e}")))?;
    if bytes.len() as u64 > MAX_RESULT_FILE_BYTES {
        return Err(Refusal::NotFound(format!(
            "`{name}` grew past {MAX_RESULT_FILE_BYTES} bytes: not handed out"
        )));
    }
    Ok(([(header::CONTENT_TYPE, content_type(name))], bytes).into_response())
}

async fn alarms_json(
    State(state): State<Shared>,
    q: Result<Query<AlarmsQuery>, axum::extract::rejection::QueryRejection>,
) -> Result<Response, Refusal> {
    let q = query(q)?;
    let last = q.last().map_err(Refusal::BadQuery)?;
    let v = blocking(move || state.read(|db| alarms_view(db, q.status, last))).await?;
    Ok(Json(v).into_response())
}

async fn metrics(State(state): State<Shared>) -> Result<Response, Refusal> {
    Ok(metrics_response(
        blocking(move || metrics_text(&state)).await?,
    ))
}

/// Metrics text as the Prometheus text format's response (the fleet's `/metrics` too).
pub(super) fn metrics_response(text: String) -> Response {
    (
        [(
            header::CONTENT_TYPE,
            "text/plain; version=0.0.4; charset=utf-8",
        )],
        text,
    )
        .into_response()
}

async fn health(State(state): State<Shared>) -> Result<Response, Refusal> {
    let path = state.settings.db.display().to_string();
    let n = blocking(move || state.read(|db| db.pass_count())).await?;
    Ok(Json(serde_json::json!({"database": path, "passes": n})).into_response())
}

async fn not_found(uri: axum::http::Uri) -> Refusal {
    Refusal::NotFound(format!(
        "nothing at {}: the pages are /, /wheel?id=…, /pass/<id> (and their JSON under /api/)",
        uri.path()
    ))
}
