//! # wheelflat-studies
//!
//! The studies behind wheelflat's docs, apart from the product (`publish = false`): each
//! program in `src/bin/` measures one figure the docs state
//! (`cargo run --release -p wheelflat-studies --bin NAME -- ARGS`), and this library holds
//! what they share: the aligned falsification variant ([`aligned`]) and the study arguments
//! ([`study`]). The seeded coverage runs ([`coverage`]) and the diagnosis acceptance suite
//! ([`suite`]) live in `wheelflat-testkit`, which the product's tests use too; they are
//! re-exported here under their old paths.

pub mod aligned;
pub mod study;
pub use wheelflat_testkit::{coverage, suite};
