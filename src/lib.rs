//! # wheelflat
//!
//! Identifies the size of a wheel flat from rail-pad force measurements, with the
//! uncertainties stated (error-domain model falsification, Cao et al.).
//!
//! The workflow:
//! 1. [`model`]: simulate the vertical train–track system (Timoshenko–Rayleigh rail on
//!    discrete pads, sleepers and ballast; pitch-plane half bogie; Hertz contact; a flat).
//! 2. Later layers bank the predictions of a whole model population, identify flat sizes
//!    from measurements, and diagnose model gaps.
//!
//! The binary `wheelflat` (`src/main.rs` and its `cli` modules, not part of this library)
//! drives it all; [`report`] words and plots the results.
#![deny(clippy::float_cmp)]
#![warn(unreachable_pub)]

pub mod alarm;
pub mod atomic;
pub mod audit;
pub mod bank;
pub mod diagnose;
pub mod fleet;
pub mod history;
pub mod identify;
pub mod model;
pub mod pass;
pub mod report;
pub mod serve;
pub mod site;
mod stopwatch;
pub mod train;
