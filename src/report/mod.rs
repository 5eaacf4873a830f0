//! Plots and tables for people.

pub mod audit;
pub(crate) mod canvas;
pub mod diagnose;
pub mod history;
pub mod identify;
pub(crate) mod plot;
pub mod response;
pub mod tables;
pub mod train;

pub use plot::{draw_pad_forces, PadForcePlot, PlotError, Series};

/// The sorted file names in a folder (for the report tests).
#[cfg(test)]
pub(crate) fn dir_entries(dir: &std::path::Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .expect("read dir")
        .map(|e| {
            e.expect("dir entry")
                .file_name()
                .to_string_lossy()
                .into_owned()
        })
        .collect();
    names.sort();
    names
}
