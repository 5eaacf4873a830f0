//! The vertical train–track model (MODEL.md §1–6, paper §4.2): calibration, rail finite
//! elements, vehicle, Hertz contact, wheel flat and the time integrator.
//!
//! Kernels here do no I/O; the simulator fills buffers it is given.

pub mod banded;
pub mod calibration;
pub mod contact;
pub mod flat;
pub mod integrator;
pub mod track;
pub mod vehicle;

pub use calibration::{Calibration, CalibrationError, CheckedCalibration, Effect, WheelPosition};
pub use flat::{Flat, FlatError};
pub use integrator::{Level, Record, Response, SimError, Simulator, State, Workspace};
