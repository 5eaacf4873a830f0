//! Identification from the bank (paper §2–3, MODEL.md §7–8): perceptually important points
//! of the measured series, joint-entropy selection, error-domain model falsification.

pub mod result;

pub use result::Identification;
