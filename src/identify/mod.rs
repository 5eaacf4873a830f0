//! Identification from the bank (paper §2–3, docs/model.md §7–8): perceptually important points
//! of the measured series, joint-entropy selection, error-domain model falsification.
//!
//! [`Identifier::new`] opens what is reused across measurements (the memory-mapped bank, its
//! parameters, the Monte Carlo uncertainty samples); [`Identifier::identify`] is the per-
//! measurement path: align, PIP, read the candidate columns, entropy selection, falsify.

// From the ground up, each using only those below it: the errors and the optional parts
// (`error`, `extras`); the error domain (`domain`: the uncertainty table, the thresholds, the
// cells and the falsification rule); the pass as the bank sees it (`input`); the state kept
// between passes and its accessors (`identifier`); where to compare (`select`) and detection
// (`detect`); what the answer says (`answer`); the stages of a pass (`prepare`, the sizing
// `stages` with the allowance's steps (`allowance`) and their shared-gain stage (`shared_stage`), the whole `pipeline`); and the refinement beside it (`refine`). This file only
// declares them and names the public paths.
mod allowance;
pub(crate) mod answer;
pub(crate) mod detect;
pub(crate) mod domain;
pub(crate) mod error;
mod extras;
mod identifier;
pub(crate) mod input;
mod pipeline;
mod prepare;
pub mod refine;
pub(crate) mod select;
mod shared_stage;
mod stages;
pub mod synth;

// The public modules of the stages, under the paths they had before the stage folders.
pub use answer::json;
pub use answer::result;
pub use detect::out_of_round;
pub use detect::roughness;
pub use domain::falsify;
pub use input::compare;
pub use select::envelope;

pub use answer::identification::Identification;
pub use answer::severity::{FlatVerdict, Severity, SeverityRange};
pub use answer::sizing::Sizing;
pub use identifier::Identifier;
pub use input::measurement::Measurement;

pub use error::IdentifyError;
pub use extras::Extras;

pub use compare::Comparison;
pub use detect::spike::SpikeTest;
pub use detect::{Detection, DetectionLimit};
pub use result::WheelRanges;
pub use roughness::RoughnessUse;

pub use answer::ranges::wheels_of;
pub use detect::family::Members;
pub use domain::cells::{unit_points, Cells};
pub use domain::uncertainty::{CombinedUncertainty, ThresholdCurve};
