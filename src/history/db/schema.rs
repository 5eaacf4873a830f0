//! The results database's tables, version by version: what version 1 made, and what each
//! upgrade adds (each run in one transaction; a new database is made as version 1 and upgraded
//! at once, so that one text of each table exists).

/// The tables of version 1 (a new database gets [`UPGRADE_1_TO_2`] and [`UPGRADE_2_TO_3`]
/// after them).
pub(super) const SCHEMA: &str = "
CREATE TABLE passes (
    id INTEGER PRIMARY KEY,
    key TEXT NOT NULL UNIQUE,
    time TEXT NOT NULL,
    time_s REAL NOT NULL,
    measurement TEXT NOT NULL,
    bank_id TEXT NOT NULL,
    speed_km_per_h REAL,
    bank_speed_km_per_h REAL NOT NULL,
    load_kn REAL,
    bogie_id TEXT,
    summary TEXT NOT NULL
);
CREATE TABLE wheel_passes (
    pass_id INTEGER NOT NULL REFERENCES passes(id) ON DELETE CASCADE,
    wheel TEXT NOT NULL CHECK (wheel IN ('leading', 'trailing')),
    wheel_id TEXT,
    claim TEXT NOT NULL,
    l0_min_mm REAL,
    l0_max_mm REAL,
    severity_lowest TEXT,
    severity_highest TEXT,
    limit_l0_mm REAL,
    space TEXT NOT NULL,
    cells INTEGER NOT NULL,
    boxes BLOB NOT NULL,
    PRIMARY KEY (pass_id, wheel)
);
CREATE INDEX wheel_passes_by_wheel ON wheel_passes(wheel_id, pass_id);
CREATE INDEX passes_by_time ON passes(time_s);
";

/// What version 1 lacks: where each pass's result was written, the passes refused or failed. A
/// new database is made as version 1 ([`SCHEMA`]) and upgraded at once, in one transaction:
/// one text of each table.
pub(super) const UPGRADE_1_TO_2: &str = "
ALTER TABLE passes ADD COLUMN result_dir TEXT;
ALTER TABLE wheel_passes ADD COLUMN dynamic_ratio_min REAL;
ALTER TABLE wheel_passes ADD COLUMN dynamic_ratio_max REAL;
CREATE TABLE failures (
    id INTEGER PRIMARY KEY,
    time TEXT NOT NULL,
    time_s REAL NOT NULL,
    measurement TEXT NOT NULL,
    bogie_id TEXT,
    outcome TEXT NOT NULL CHECK (outcome IN ('refused', 'failed')),
    reason TEXT NOT NULL
);
CREATE INDEX failures_by_time ON failures(time_s);
PRAGMA user_version = 2;
";

/// What version 2 lacks: the alarms' outbox (docs/alarms.md) — one row an alarm and a
/// destination, written in the transaction of the pass (or refusal) that raised it, marked
/// `sent` by the sender on a 2xx, `failed` (and retried) otherwise — and how long each pass's
/// answer took (`answer_ms`, the latency `/metrics` shows).
pub(super) const UPGRADE_2_TO_3: &str = "
ALTER TABLE passes ADD COLUMN answer_ms REAL;
CREATE TABLE outbox (
    id INTEGER PRIMARY KEY,
    destination TEXT NOT NULL,
    key TEXT NOT NULL,
    rule TEXT NOT NULL,
    wheel_id TEXT,
    pass_id INTEGER REFERENCES passes(id) ON DELETE SET NULL,
    created TEXT NOT NULL,
    created_s REAL NOT NULL,
    body TEXT NOT NULL,
    status TEXT NOT NULL CHECK (status IN ('pending', 'failed', 'sent')),
    attempts INTEGER NOT NULL DEFAULT 0,
    next_attempt_s REAL NOT NULL,
    last_error TEXT,
    sent_s REAL,
    UNIQUE (destination, key)
);
CREATE INDEX outbox_by_status ON outbox(status, destination, id);
CREATE INDEX outbox_by_rule ON outbox(rule, created_s);
PRAGMA user_version = 3;
";
