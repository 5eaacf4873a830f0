//! Plots and tables for people.

pub mod audit;
pub mod canvas;
pub mod diagnose;
pub mod identify;
pub mod plot;
pub mod response;
pub mod tables;
pub mod train;

pub use plot::{draw_pad_forces, PadForcePlot, PlotError, Series};
