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
//! The binary `wheelflat` drives it all; [`cli`] holds its commands and [`report`] its plots.
#![deny(clippy::float_cmp)]

pub mod atomic;
pub mod audit;
pub mod bank;
pub mod cli;
pub mod diagnose;
pub mod history;
pub mod identify;
pub mod model;
pub mod report;
pub mod train;
