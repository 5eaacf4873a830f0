//! # wheelflat-studies
//!
//! The studies behind wheelflat's docs, apart from the product (`publish = false`): each
//! program in `src/bin/` measures one figure the docs state
//! (`cargo run --release -p wheelflat-studies --bin NAME -- ARGS`), and this library holds
//! what they share: seeded coverage runs ([`coverage`]), the aligned falsification variant
//! ([`aligned`]), the diagnosis acceptance suite ([`suite`]) and the study arguments
//! ([`study`]). The product's tests use [`coverage`] and [`suite`] for their held-out checks.

pub mod aligned;
pub mod coverage;
pub mod study;
pub mod suite;
