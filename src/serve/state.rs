//! What every request shares: the settings, and the database opened read-only — a few
//! connections kept between requests, each used by one request at a time on the blocking
//! pool (SQLite's write-ahead log lets them read while a writer writes).

use super::access::Token;
use super::error::ServeError;
use crate::history::{Db, DbError, Joint};
use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

/// Connections kept between requests.
const KEPT_CONNECTIONS: usize = 4;
/// Joint answers kept (all forgotten when full).
const KEPT_JOINTS: usize = 4096;

/// What the server serves.
#[derive(Debug, Clone)]
pub struct Settings {
    /// The results database.
    pub db: PathBuf,
    /// The bank or family the site identifies with, when given (the site page says whether the
    /// passes used it).
    pub bank: Option<PathBuf>,
    /// The class limits on L0 (mm): inspect, urgent.
    pub limits_l0_mm: [f64; 2],
    /// The impact rule's limits on the dynamic ratio: inspect, urgent.
    pub limits_dynamic_ratio: [f64; 2],
    /// The confidence the passes are fused at.
    pub phi: f64,
    /// The token requests must show, when set.
    pub token: Option<Token>,
}

impl Settings {
    /// The settings for `db` with the class limits and φ of a calibration's rulebook
    /// (`[maintenance]`), as `history` uses them.
    pub fn new(
        db: PathBuf,
        bank: Option<PathBuf>,
        rules: &crate::model::calibration::IdentificationParams,
        token: Option<Token>,
    ) -> Settings {
        Settings {
            db,
            bank,
            limits_l0_mm: [rules.inspect_l0_mm, rules.urgent_l0_mm],
            limits_dynamic_ratio: [rules.inspect_dynamic_ratio, rules.urgent_dynamic_ratio],
            phi: rules.phi,
            token,
        }
    }
}

/// The shared state of the server.
pub(crate) struct AppState {
    pub(crate) settings: Settings,
    pool: Mutex<Vec<Db>>,
    /// Reports drawn on request.
    pub(crate) drawn: super::drawn::Drawn,
    /// The joint answers of the site page's wheels, by wheel and its newest pass id: a wheel's
    /// answer changes only with a new pass of it (which has a larger id).
    joints: Mutex<HashMap<(String, i64), Option<Joint>>>,
    /// What `/metrics` has counted so far (`super::metrics`).
    pub(crate) counts: Mutex<super::counts::Counts>,
}

impl AppState {
    /// Opens the database once (refused now, with the words of `history`, when it is missing,
    /// not wheelflat's, or newer).
    pub(crate) fn new(settings: Settings) -> Result<Arc<AppState>, ServeError> {
        let db = Db::open_read_only(&settings.db)?;
        Ok(Arc::new(AppState {
            settings,
            pool: Mutex::new(vec![db]),
            drawn: super::drawn::Drawn::new(),
            joints: Mutex::new(HashMap::new()),
            counts: Mutex::new(super::counts::Counts::default()),
        }))
    }

    /// Runs `read` with a connection (one kept, or a new one), and keeps it afterwards.
    pub(crate) fn read<T>(
        &self,
        read: impl FnOnce(&Db) -> Result<T, DbError>,
    ) -> Result<T, DbError> {
        let kept = self.pool.lock().map(|mut p| p.pop()).unwrap_or(None);
        let db = match kept {
            Some(db) => db,
            None => Db::open_read_only(&self.settings.db)?,
        };
        let out = read(&db);
        if let Ok(mut p) = self.pool.lock() {
            if p.len() < KEPT_CONNECTIONS {
                p.push(db);
            }
        }
        out
    }

    /// The joint answer of `wheel_id` whose newest pass is `newest`, computed by `joint` when
    /// not kept.
    pub(crate) fn joint(
        &self,
        wheel_id: &str,
        newest: i64,
        joint: impl FnOnce() -> Result<Option<Joint>, DbError>,
    ) -> Result<Option<Joint>, DbError> {
        let key = (wheel_id.to_string(), newest);
        if let Some(j) = self.joints.lock().ok().and_then(|m| m.get(&key).cloned()) {
            return Ok(j);
        }
        let j = joint()?;
        if let Ok(mut m) = self.joints.lock() {
            if m.len() >= KEPT_JOINTS {
                m.clear();
            }
            m.insert(key, j.clone());
        }
        Ok(j)
    }
}
