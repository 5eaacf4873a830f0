//! `wheelflat serve`: a read-only web view of a results database for the people who watch a
//! site — the wheels that need action first, every wheel, the passes of the last hours with
//! their outcome, a wheel's trend and joint answer, one pass's report — each page with a JSON
//! endpoint beside it carrying the same numbers (docs/serve.md).
//!
//! - [`access`]: where it may listen (localhost, or elsewhere only with a token) and the token
//!   check.
//! - [`state`]: the database opened read-only, a few connections kept for the requests.
//! - [`site`], [`wheel`], [`pass`]: each page's numbers (the JSON) and its HTML; [`setup`]:
//!   the site page's family, calibration and newest nightly check.
//! - [`layout`]: the page around them, the class colours, the refresh without reloading.
//! - [`drawn`]: a pass's report drawn on request when its command wrote only the JSON.
//! - [`fleet`], [`fleet_pages`]: `serve --fleet`, the fleet store's pages (docs/fleet.md).
//! - [`alarms`]: the alarms' counts and newest rows; [`metrics`]: `/metrics`, the Prometheus
//!   text format (also served alone by `watch --metrics`: [`run_metrics`]).
//!
//! Reads run on the blocking pool under SQLite's write-ahead log: they never block a
//! `watch --db` writing beside them, and every list a page shows is bounded.

pub mod access;
mod alarms;
mod counts;
mod drawn;
mod error;
mod fleet;
mod fleet_pages;
mod layout;
mod metrics;
mod pass;
mod routes;
mod setup;
mod site;
pub(crate) mod state;
mod wheel;

pub use access::{check_listen, Token};
pub use error::ServeError;
pub use fleet::FleetSettings;
pub use fleet_pages::fleet_router;
pub use routes::{metrics_router, router};
pub use state::Settings;

use std::net::SocketAddr;

/// Serves `settings`' database on `listen` until SIGINT or SIGTERM; `ready` is told the
/// address bound (the port when `listen` asked for port 0).
pub fn run(
    settings: Settings,
    listen: SocketAddr,
    ready: impl FnOnce(SocketAddr),
) -> Result<(), ServeError> {
    check_listen(listen, settings.token.is_some())?;
    let app = router(settings)?;
    serve_app(app, listen, ready)
}

/// Serves the fleet store's pages (`serve --fleet`) on `listen` until SIGINT or SIGTERM.
pub fn run_fleet(
    settings: FleetSettings,
    listen: SocketAddr,
    ready: impl FnOnce(SocketAddr),
) -> Result<(), ServeError> {
    check_listen(listen, settings.token.is_some())?;
    let app = fleet_router(settings)?;
    serve_app(app, listen, ready)
}

fn serve_app(
    app: axum::Router,
    listen: SocketAddr,
    ready: impl FnOnce(SocketAddr),
) -> Result<(), ServeError> {
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(ServeError::Runtime)?;
    runtime.block_on(async move {
        let (listener, bound) = bind(listen).await?;
        ready(bound);
        axum::serve(listener, app)
            .with_graceful_shutdown(stopped())
            .await
            .map_err(ServeError::Runtime)
    })
}

/// A listener on `listen` and the address it bound (port 0: the one the system chose).
async fn bind(listen: SocketAddr) -> Result<(tokio::net::TcpListener, SocketAddr), ServeError> {
    let bind_error = |source| ServeError::Bind {
        addr: listen,
        source,
    };
    let listener = tokio::net::TcpListener::bind(listen)
        .await
        .map_err(bind_error)?;
    let bound = listener.local_addr().map_err(bind_error)?;
    Ok((listener, bound))
}

/// Resolves on SIGINT or SIGTERM.
async fn stopped() {
    use tokio::signal::unix::{signal, SignalKind};
    let term = async {
        match signal(SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    tokio::select! {
        _ = tokio::signal::ctrl_c() => {}
        _ = term => {}
    }
}

/// Serves `/metrics` (and `/health`) of `settings`' database on `listen` — a localhost
/// address: this server has no token — on a thread of its own, for `watch --metrics`; the
/// address bound, once listening. Runs until the process ends.
pub fn run_metrics(settings: Settings, listen: SocketAddr) -> Result<SocketAddr, ServeError> {
    check_listen(listen, false)?;
    let app = metrics_router(settings)?;
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(ServeError::Runtime)?;
    let (listener, bound) = runtime.block_on(bind(listen))?;
    std::thread::Builder::new()
        .name("metrics".into())
        .spawn(move || {
            // The scrape's database work runs on this runtime's blocking pool.
            let _ = runtime.block_on(async move { axum::serve(listener, app).await });
        })
        .map_err(ServeError::Runtime)?;
    Ok(bound)
}
