//! The vertical train–track model (docs/model.md §1–6, paper §4.2): calibration, rail finite
//! elements, vehicle, Hertz contact, wheel flat, the effect library and the time integrator
//! with its step schedule.
//!
//! Kernels here do no I/O; the simulator fills buffers it is given.

pub mod average;
pub(crate) mod banded;
pub(crate) mod batch;
pub mod calibration;
pub(crate) mod contact;
pub(crate) mod effect;
mod effect_kind;
pub(crate) mod flat;
pub(crate) mod integrator;
pub(crate) mod lanes;
mod rail_element;
pub(crate) mod random;
pub mod response;
pub(crate) mod schedule;
pub mod surface;
pub(crate) mod track;
pub(crate) mod vehicle;
pub(crate) mod wheel;

pub use batch::{batch_key, BatchStats, LANES};
pub use calibration::{Calibration, CalibrationError, CheckedCalibration};
pub use effect::Effect;
pub use effect_kind::EffectKind;
pub use flat::{Flat, FlatError};
pub use integrator::{
    SimError, Simulator, State, Workspace, SURFACE_PIT_DEPTH_M, SURFACE_STEP_TRAVEL_M,
};
pub use lanes::LaneWork;
pub use response::{Record, Response};
pub use schedule::{Level, Schedule};
pub use surface::{ContactFilter, RailSurface, Surfaces, Trace, WheelSurface};
pub use track::{RailSection, Support, TrackModel};
pub use wheel::WheelPosition;
