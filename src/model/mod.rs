//! The vertical train–track model (docs/model.md §1–6, paper §4.2): calibration, rail finite
//! elements, vehicle, Hertz contact, wheel flat, the effect library and the time integrator
//! with its step schedule.
//!
//! Kernels here do no I/O; the simulator fills buffers it is given.

pub mod banded;
pub mod batch;
pub mod calibration;
pub mod contact;
pub mod effect;
pub mod flat;
pub mod integrator;
pub mod lanes;
pub mod response;
pub mod schedule;
pub mod track;
pub mod vehicle;
pub mod wheel;

pub use batch::{batch_key, BatchStats, LANES};
pub use calibration::{Calibration, CalibrationError, CheckedCalibration};
pub use effect::Effect;
pub use flat::{Flat, FlatError};
pub use integrator::{SimError, Simulator, State, Workspace};
pub use lanes::LaneWork;
pub use response::{Record, Response};
pub use schedule::{Level, Schedule};
pub use wheel::WheelPosition;
