//! # wheelflat-testkit
//!
//! What the product's tests and the studies share, apart from both (`publish = false`): the
//! seeded held-out coverage runs ([`coverage`]: truths drawn over a bank's population,
//! simulated on another mesh, identified and judged) and the diagnosis acceptance suite
//! ([`suite`]: hidden effects, their cases and outcomes), and where a landing is judged
//! ([`landing`]). The tests depend on this crate, not on the studies.

pub mod coverage;
pub mod landing;
pub mod pg;
pub mod suite;
