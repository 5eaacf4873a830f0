//! The fleet store: every site's passes in one PostgreSQL database (docs/fleet.md).
//!
//! - [`connect`]: the store's address (a `postgresql://` URL without its password), the
//!   password from a file or the environment, TLS with the operator's CA.
//! - [`schema`]: the store's tables as versioned migrations (`migrations/*.sql`), applied by
//!   `wheelflat fleet migrate`; a store of another version is refused by name.
//! - [`roles`]: one login a site (it inserts and reads its own rows only: row-level
//!   security), readers, the workshop.
//! - [`ship`]: a site's SQLite sent on, at least once, idempotent by (site, row id) and by
//!   the pass's key, in the order it was stored, one transaction a batch.
//! - [`read`]: a wheel's passes at every site, the wheels needing action, each site's health.
//! - [`across`]: a wheel's passes fused across sites, naming a site that disagrees.
//! - [`findings`]: what the workshop measured, and how the passes before it fared.

pub mod across;
pub mod connect;
mod error;
pub mod findings;
pub mod read;
pub mod roles;
pub mod schema;
pub mod ship;
pub mod words;

pub use across::{across_report, across_sites, AcrossSites, SiteVerdict};
pub use connect::{FleetTarget, Password};
pub use error::FleetError;
pub use findings::{Finding, FindingRow, Judged, Validation, ValidationRow};
pub use read::{FleetReader, SiteHealth, SitePass, WheelLatest};
pub use roles::LoginKind;
pub use schema::FLEET_SCHEMA_VERSION;
pub use ship::{Shipped, Shipper};
