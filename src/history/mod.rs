//! A wheel's history: each pass stored in a results database ([`db`]), what it says of each
//! wheel of its bogie ([`record`]), and the passes of one wheel fused into one answer
//! ([`fuse`]) — the flat's (L, d, c) must fit every pass, so the joint answer narrows as the
//! passes come (docs/history.md).

pub mod alarms;
pub(crate) mod consist;
pub(crate) mod db;
pub(crate) mod fuse;
mod grid;
mod groups;
pub(crate) mod record;
mod rules;
pub(crate) mod view;
mod write;

pub use alarms::{AlarmBody, AlarmCounts, AlarmRow, AlarmStatus, DriftLine, BODY_SCHEMA};
pub use db::export::{ExportAlarm, ExportPass, ExportWheel, NewestIds};
pub use db::failures::{Failure, FailureKind};
pub use db::tally::Tally;
pub use db::{Db, DbError, StoredPass, Window, SCHEMA_VERSION};
pub use fuse::{fuse, fuse_grouped, Agreement, FusionRule, Joint};
pub use record::{Claim, PassMeta, PassRecord, Space, WheelPass};
pub use rules::{AlarmPlan, Rule};
pub use view::{BankUse, PassDetail, PassRow, WheelOutcome, WheelRow};
