//! Alarms pushed to the people who act (docs/alarms.md): the configuration (`alarms.toml`,
//! checked at start), the webhook sender (JSON over HTTPS, HMAC-SHA256 signed, retried with
//! backoff, in order per destination, at least once), and the newest nightly calibration
//! check read from the bank folder (the drift alarm; `serve`'s page and `/metrics`).
//!
//! The rules themselves, and the outbox the alarms wait in, belong to the results database
//! (`crate::history::alarms`): an alarm is written in the transaction of the pass that
//! raised it. E-mail is not sent (docs/alarms.md says why and how to bridge a webhook to it).
//!
//! - [`config`]: `alarms.toml` read and checked; [`AlarmConfig::plan`] for the writer.
//! - [`deliver`]: the [`Sender`]: a round over the outbox, or a resident loop.
//! - [`sign`]: the signature header.
//! - [`drift`]: the newest nightly check.

pub mod config;
pub mod deliver;
pub mod drift;
mod error;
pub mod sign;

pub use config::AlarmConfig;
pub use deliver::{Outcome, Round, Sender};
pub use error::AlarmError;
