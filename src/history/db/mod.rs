//! The results database: one SQLite file (bundled SQLite, write-ahead log) holding every pass
//! `identify`, `train` and `watch` store with `--db`, readable by the tools operators already
//! have (`sqlite3`, Python, a spreadsheet's ODBC).
//!
//! - **Its own schema, checked.** The file carries `PRAGMA application_id` = `WFLT` and
//!   `user_version` = [`SCHEMA_VERSION`]; a file that is not SQLite, another application's
//!   database, or a newer schema is refused by name before anything is read or written.
//! - **A pass is whole or absent.** Each pass and its two wheels go in one transaction
//!   (`BEGIN IMMEDIATE`, `synchronous = FULL`): a writer killed at any point leaves the file
//!   as it was before that pass or with the whole pass.
//! - **Once.** A pass is keyed by the SHA-256 of its record (and its bogie's place in a
//!   train): storing it again (a restart between storing and moving the file) changes nothing.
//! - **Readers while a writer writes.** The write-ahead log lets `history` read while `watch`
//!   writes; both wait up to [`BUSY_TIMEOUT_MS`] for a lock.
//!
//! Beside it, one file a concern: its schema and upgrades ([`schema`]), reading a stored pass ([`row`]), the passes refused or failed
//! ([`failures`]), the counts `/metrics` keeps ([`tally`]); writing a pass with its
//! alarms is `history/write.rs`, beside the alarms it raises (which read this module).

pub(crate) mod export;
pub(crate) mod failures;
pub(crate) mod row;
mod schema;
pub(crate) mod tally;

use super::rules::AlarmPlan;
use crate::identify::SeverityRange;
pub use row::StoredPass;
use row::{severity_range, RawRow};
use rusqlite::{params, Connection, OpenFlags, TransactionBehavior};
use schema::{SCHEMA, UPGRADE_1_TO_2, UPGRADE_2_TO_3};
use std::path::{Path, PathBuf};

/// `PRAGMA application_id` of a wheelflat results database: `WFLT`.
pub(crate) const APPLICATION_ID: i32 = 0x5746_4C54;
/// The schema this wheelflat writes and reads (3: the alarms' outbox and each pass's answer
/// time; 2: the passes refused or failed, and where a pass's result was written). An older
/// file is upgraded when opened for writing, and read as it is when opened read-only.
pub const SCHEMA_VERSION: i32 = 3;
/// How long a reader or writer waits for another's lock (ms).
pub(crate) const BUSY_TIMEOUT_MS: u64 = 10_000;
/// The most passes one query returns (a window larger than this is cut to the newest).
pub(crate) const MAX_WINDOW_PASSES: usize = 1000;

/// What can go wrong with the database, naming the file.
#[derive(Debug, thiserror::Error)]
pub enum DbError {
    /// The file exists and is not a wheelflat results database.
    #[error("{path} is not a wheelflat results database: {why}")]
    NotOurs {
        /// The file.
        path: PathBuf,
        /// What it is instead.
        why: String,
    },
    /// A newer wheelflat wrote it.
    #[error("{path} has schema version {found}, newer than this wheelflat's {SCHEMA_VERSION}: use the wheelflat that wrote it")]
    Newer {
        /// The file.
        path: PathBuf,
        /// Its schema version.
        found: i32,
    },
    /// There is no database at the path (`history` reads, never creates).
    #[error(
        "no results database at {path} (`identify`, `train` and `watch` create one with --db)"
    )]
    Missing {
        /// The file.
        path: PathBuf,
    },
    /// A stored value is not what this wheelflat writes.
    #[error("{path}: pass {pass}: {what}")]
    Corrupt {
        /// The file.
        path: PathBuf,
        /// The pass row.
        pass: i64,
        /// What is wrong.
        what: String,
    },
    /// SQLite failed.
    #[error("results database {path}: {source}")]
    Sqlite {
        /// The file.
        path: PathBuf,
        /// SQLite's error.
        #[source]
        source: rusqlite::Error,
    },
}

/// A wheel the database knows, for the overview.
#[derive(Debug, Clone, PartialEq)]
pub struct WheelSummary {
    /// `<bogie_id>/leading` or `…/trailing`.
    pub wheel_id: String,
    /// Passes stored.
    pub passes: usize,
    /// The newest pass's time (RFC 3339).
    pub last_time: String,
    /// The newest pass's classes.
    pub last_severity: Option<SeverityRange>,
}

/// Which passes of a wheel `history` fuses: the newest `last`, within `hours` of the newest.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Window {
    /// At most this many passes (the newest).
    pub last: usize,
    /// Only passes within this many hours of the wheel's newest (all when `None`).
    pub hours: Option<f64>,
}

/// An open results database.
pub struct Db {
    pub(super) conn: Connection,
    path: PathBuf,
    /// The file's schema version: [`SCHEMA_VERSION`], or older for an old file opened
    /// read-only.
    pub(super) version: i32,
    /// The alarms raised in the transaction of each pass or refusal stored, when set
    /// ([`Db::raise_alarms`]).
    pub(super) alarms: Option<AlarmPlan>,
}

/// How [`Db::open_with`] opens the file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    /// Read and write; an absent or empty file is made a database.
    Create,
    /// Read and write an existing database.
    Existing,
    /// Read only, never writing (an old schema is read as it is).
    ReadOnly,
}

impl Db {
    /// Opens the database at `path`, creating it (and its schema) when there is no file or an
    /// empty one; refuses a file that is not one.
    pub fn open(path: &Path) -> Result<Db, DbError> {
        Db::open_with(path, Mode::Create)
    }

    /// Opens an existing database for reading and writing (never creates one).
    pub fn open_existing(path: &Path) -> Result<Db, DbError> {
        Db::open_with(path, Mode::Existing)
    }

    /// Opens an existing database read-only (`serve`): SQLite refuses every write on it, and an
    /// older file is read as it is (version 1: no failures, no result folders; version 2: no
    /// alarms, no answer times).
    pub fn open_read_only(path: &Path) -> Result<Db, DbError> {
        Db::open_with(path, Mode::ReadOnly)
    }

    fn open_with(path: &Path, mode: Mode) -> Result<Db, DbError> {
        let create = mode == Mode::Create;
        let sql = |source| DbError::Sqlite {
            path: path.to_path_buf(),
            source,
        };
        let not_ours = |why: String| DbError::NotOurs {
            path: path.to_path_buf(),
            why,
        };
        let meta = std::fs::metadata(path).ok();
        if let Some(m) = &meta {
            if !m.is_file() {
                return Err(not_ours("not a regular file".into()));
            }
        } else if !create {
            return Err(DbError::Missing {
                path: path.to_path_buf(),
            });
        }
        let flags = match mode {
            Mode::Create => OpenFlags::SQLITE_OPEN_READ_WRITE | OpenFlags::SQLITE_OPEN_CREATE,
            Mode::Existing => OpenFlags::SQLITE_OPEN_READ_WRITE,
            Mode::ReadOnly => OpenFlags::SQLITE_OPEN_READ_ONLY,
        } | OpenFlags::SQLITE_OPEN_NO_MUTEX;
        let conn = Connection::open_with_flags(path, flags).map_err(sql)?;
        conn.busy_timeout(std::time::Duration::from_millis(BUSY_TIMEOUT_MS))
            .map_err(sql)?;
        // The first read tells an SQLite file from anything else. One statement reads the
        // three together, from one snapshot: read apart, a reader racing the process that
        // writes the schema saw its tables without its application id.
        let head = conn.query_row(
            "SELECT (SELECT application_id FROM pragma_application_id), \
                    (SELECT user_version FROM pragma_user_version), \
                    (SELECT count(*) FROM sqlite_master)",
            [],
            |r| {
                Ok((
                    r.get::<_, i32>(0)?,
                    r.get::<_, i32>(1)?,
                    r.get::<_, i64>(2)?,
                ))
            },
        );
        let (id, version, tables) = match head {
            Ok(v) => v,
            Err(rusqlite::Error::SqliteFailure(e, _))
                if e.code == rusqlite::ErrorCode::NotADatabase =>
            {
                return Err(not_ours("not an SQLite file".into()));
            }
            Err(e) => return Err(sql(e)),
        };
        if id == 0 && version == 0 && tables == 0 && mode == Mode::ReadOnly {
            return Err(not_ours("an empty file".into()));
        }
        if id == 0 && version == 0 && tables == 0 {
            // An empty SQLite file (or none): made ours. Two processes may both find it empty;
            // the second finds the schema inside its own transaction and leaves it.
            conn.pragma_update(None, "journal_mode", "WAL")
                .map_err(sql)?;
            let mut conn = conn;
            let tx = conn
                .transaction_with_behavior(TransactionBehavior::Immediate)
                .map_err(sql)?;
            let tables: i64 = tx
                .query_row("SELECT count(*) FROM sqlite_master", [], |r| r.get(0))
                .map_err(sql)?;
            if tables == 0 {
                tx.execute_batch(&format!(
                    "{SCHEMA} {UPGRADE_1_TO_2} {UPGRADE_2_TO_3} PRAGMA application_id = {APPLICATION_ID}; PRAGMA user_version = {SCHEMA_VERSION};"
                ))
                .map_err(sql)?;
            }
            tx.commit().map_err(sql)?;
            return Db::finish(conn, path, SCHEMA_VERSION);
        } else if id != APPLICATION_ID {
            return Err(not_ours(format!(
                "an SQLite database of another application (application_id {id:#x}, {tables} schema objects; wheelflat's is {APPLICATION_ID:#x})"
            )));
        } else if version > SCHEMA_VERSION {
            return Err(DbError::Newer {
                path: path.to_path_buf(),
                found: version,
            });
        } else if (1..SCHEMA_VERSION).contains(&version) && mode == Mode::ReadOnly {
            return Db::finish(conn, path, version);
        } else if (1..SCHEMA_VERSION).contains(&version) {
            // Upgraded in one transaction: a second process upgrading at once finds the new
            // version inside its own and leaves it.
            let mut conn = conn;
            let tx = conn
                .transaction_with_behavior(TransactionBehavior::Immediate)
                .map_err(sql)?;
            let now: i32 = tx
                .query_row("PRAGMA user_version", [], |r| r.get(0))
                .map_err(sql)?;
            if now == 1 {
                tx.execute_batch(UPGRADE_1_TO_2).map_err(sql)?;
            }
            if now == 1 || now == 2 {
                tx.execute_batch(UPGRADE_2_TO_3).map_err(sql)?;
            }
            tx.commit().map_err(sql)?;
            return Db::finish(conn, path, SCHEMA_VERSION);
        } else if version != SCHEMA_VERSION {
            return Err(not_ours(format!(
                "schema version {version}, which no wheelflat writes"
            )));
        }
        Db::finish(conn, path, SCHEMA_VERSION)
    }

    /// The settings every connection runs with.
    fn finish(conn: Connection, path: &Path, version: i32) -> Result<Db, DbError> {
        let sql = |source| DbError::Sqlite {
            path: path.to_path_buf(),
            source,
        };
        if !conn.is_readonly(rusqlite::MAIN_DB).map_err(sql)? {
            conn.pragma_update(None, "journal_mode", "WAL")
                .map_err(sql)?;
            conn.pragma_update(None, "synchronous", "FULL")
                .map_err(sql)?;
        }
        conn.pragma_update(None, "foreign_keys", "ON")
            .map_err(sql)?;
        Ok(Db {
            conn,
            path: path.to_path_buf(),
            version,
            alarms: None,
        })
    }

    /// The file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    pub(super) fn sql(&self, source: rusqlite::Error) -> DbError {
        DbError::Sqlite {
            path: self.path.clone(),
            source,
        }
    }

    /// The file's schema version (older than [`SCHEMA_VERSION`] only when opened read-only).
    pub fn schema_version(&self) -> i32 {
        self.version
    }

    /// From now on, raise `plan`'s alarms in the transaction of each pass (`Db::insert`) and
    /// refusal (`Db::insert_failure`) stored: into the outbox, one row a destination.
    pub fn raise_alarms(&mut self, plan: AlarmPlan) {
        self.alarms = Some(plan);
    }

    /// Passes stored (all wheels, named or not).
    pub fn pass_count(&self) -> Result<usize, DbError> {
        self.conn
            .query_row("SELECT count(*) FROM passes", [], |r| r.get::<_, i64>(0))
            .map(|n| n as usize)
            .map_err(|e| self.sql(e))
    }

    /// Every named wheel with its number of passes and newest class, by wheel id.
    pub fn wheels(&self) -> Result<Vec<WheelSummary>, DbError> {
        let mut st = self
            .conn
            .prepare(
                "SELECT wheel_id, n, time, severity_lowest, severity_highest FROM (
                   SELECT w.wheel_id, p.time, w.severity_lowest, w.severity_highest,
                          count(*) OVER (PARTITION BY w.wheel_id) AS n,
                          row_number() OVER (PARTITION BY w.wheel_id
                                             ORDER BY p.time_s DESC, p.id DESC) AS newest
                   FROM wheel_passes w JOIN passes p ON p.id = w.pass_id
                   WHERE w.wheel_id IS NOT NULL)
                 WHERE newest = 1 ORDER BY wheel_id",
            )
            .map_err(|e| self.sql(e))?;
        let rows = st
            .query_map([], |r| {
                Ok((
                    r.get::<_, String>(0)?,
                    r.get::<_, i64>(1)?,
                    r.get::<_, String>(2)?,
                    r.get::<_, Option<String>>(3)?,
                    r.get::<_, Option<String>>(4)?,
                ))
            })
            .map_err(|e| self.sql(e))?;
        let mut out = Vec::new();
        for row in rows {
            let (wheel_id, n, last_time, lo, hi) = row.map_err(|e| self.sql(e))?;
            out.push(WheelSummary {
                wheel_id,
                passes: n as usize,
                last_time,
                last_severity: severity_range(lo.as_deref(), hi.as_deref()),
            });
        }
        Ok(out)
    }

    /// The measurement files of the passes whose every wheel was answered "no flat" or "a
    /// flat below the population" (what good wheels become when the track has drifted from
    /// the bank's), within `hours` of the newest pass stored, newest first, at most `limit`:
    /// what `calibrate --db` reads as the site's good wheels.
    pub fn good_wheel_passes(&self, hours: f64, limit: usize) -> Result<Vec<String>, DbError> {
        let mut st = self
            .conn
            .prepare(
                "SELECT p.measurement FROM passes p
                 WHERE p.time_s >= (SELECT max(time_s) FROM passes) - ?1
                   AND EXISTS (SELECT 1 FROM wheel_passes w WHERE w.pass_id = p.id)
                   AND NOT EXISTS (SELECT 1 FROM wheel_passes w WHERE w.pass_id = p.id AND w.claim NOT IN ('none', 'below'))
                 ORDER BY p.time_s DESC, p.id DESC LIMIT ?2",
            )
            .map_err(|e| self.sql(e))?;
        let rows = st
            .query_map(params![hours * 3600.0, limit as i64], |r| r.get(0))
            .map_err(|e| self.sql(e))?;
        rows.collect::<Result<_, _>>().map_err(|e| self.sql(e))
    }

    /// The passes of one wheel in `window`, oldest first.
    pub fn wheel_passes(&self, wheel_id: &str, window: Window) -> Result<Vec<StoredPass>, DbError> {
        let last = window.last.clamp(1, MAX_WINDOW_PASSES) as i64;
        let mut out = self.stored(
            &format!(
                "{} WHERE w.wheel_id = ?1 ORDER BY p.time_s DESC, p.id DESC LIMIT ?2",
                self.stored_select()
            ),
            params![wheel_id, last],
        )?;
        if let (Some(h), Some(newest)) = (window.hours, out.first().map(|p| p.time_s)) {
            out.retain(|p| p.time_s >= newest - h * 3600.0);
        }
        out.reverse();
        Ok(out)
    }

    /// The wheels of one pass (leading, then trailing), as `history` reads them.
    pub(super) fn stored_wheels_of(&self, pass_id: i64) -> Result<Vec<StoredPass>, DbError> {
        self.stored(
            &format!(
                "{} WHERE w.pass_id = ?1 ORDER BY w.wheel",
                self.stored_select()
            ),
            params![pass_id],
        )
    }

    /// The columns of a stored wheel pass, [`RawRow`]'s order (a version-1 file has no
    /// dynamic ratio).
    fn stored_select(&self) -> String {
        let ratio = if self.version < 2 {
            "NULL, NULL"
        } else {
            "w.dynamic_ratio_min, w.dynamic_ratio_max"
        };
        format!("{STORED_SELECT}, {ratio} {STORED_FROM}")
    }

    /// The stored wheels a query of [`Db::stored_select`] finds, in its order, each checked.
    fn stored(&self, sql: &str, args: impl rusqlite::Params) -> Result<Vec<StoredPass>, DbError> {
        let mut st = self.conn.prepare_cached(sql).map_err(|e| self.sql(e))?;
        let rows = st
            .query_map(args, |r| {
                Ok(RawRow {
                    pass_id: r.get(0)?,
                    time: r.get(1)?,
                    time_s: r.get(2)?,
                    measurement: r.get(3)?,
                    speed: r.get(4)?,
                    bank_speed: r.get(5)?,
                    bank_id: r.get(6)?,
                    wheel: r.get(7)?,
                    claim: r.get(8)?,
                    l0: (r.get(9)?, r.get(10)?),
                    severity: (r.get(11)?, r.get(12)?),
                    limit: r.get(13)?,
                    space: r.get(14)?,
                    cells: r.get(15)?,
                    boxes: r.get(16)?,
                    dynamic_ratio: (r.get(17)?, r.get(18)?),
                })
            })
            .map_err(|e| self.sql(e))?;
        let mut out = Vec::new();
        for row in rows {
            let row = row.map_err(|e| self.sql(e))?;
            let pass = row.pass_id;
            out.push(row.parse().map_err(|what| DbError::Corrupt {
                path: self.path.clone(),
                pass,
                what,
            })?);
        }
        Ok(out)
    }
}

/// The columns of a stored wheel pass but the dynamic ratio ([`Db::stored_select`]).
const STORED_SELECT: &str = "SELECT p.id, p.time, p.time_s, p.measurement, p.speed_km_per_h, p.bank_speed_km_per_h, p.bank_id,
        w.wheel, w.claim, w.l0_min_mm, w.l0_max_mm, w.severity_lowest, w.severity_highest,
        w.limit_l0_mm, w.space, w.cells, w.boxes";
/// The tables [`STORED_SELECT`] reads.
const STORED_FROM: &str = "FROM wheel_passes w JOIN passes p ON p.id = w.pass_id";

/// RFC 3339 in UTC with milliseconds of Unix seconds.
pub(crate) fn rfc3339(time_s: f64) -> String {
    let ms = (time_s * 1e3).round() as i64;
    chrono::DateTime::from_timestamp_millis(ms)
        .map(|t| t.to_rfc3339_opts(chrono::SecondsFormat::Millis, true))
        .unwrap_or_else(|| format!("{time_s}"))
}

/// Now, in Unix seconds.
pub(crate) fn now_s() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}
