//! The two wheels of the half bogie: which one carries a flat or an out-of-round tread.

use serde::{Deserialize, Serialize};

/// Which wheel of the half bogie carries the flat.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum WheelPosition {
    /// The wheel ahead in the direction of travel.
    Leading,
    /// The wheel behind (the paper's and docs/model.md's default).
    Trailing,
}

impl WheelPosition {
    /// Index of the wheel in the vehicle's wheel arrays (0 = leading, 1 = trailing).
    pub fn index(self) -> usize {
        match self {
            WheelPosition::Leading => 0,
            WheelPosition::Trailing => 1,
        }
    }

    /// The wheel of a stored code (the bank's `flat_wheel` column): 0 leading, else trailing.
    pub fn from_code(code: u8) -> WheelPosition {
        if code == 0 {
            WheelPosition::Leading
        } else {
            WheelPosition::Trailing
        }
    }

    /// The name people and files use: `leading` or `trailing`.
    pub fn name(self) -> &'static str {
        match self {
            WheelPosition::Leading => "leading",
            WheelPosition::Trailing => "trailing",
        }
    }
}
