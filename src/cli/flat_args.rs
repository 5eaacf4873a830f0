//! The flat of `simulate` and `synth`: its size, where it strikes, on which wheel, or none.

use anyhow::Result;
use clap::Args;
use wheelflat::model::{Flat, WheelPosition};

// A flat, or none.
#[derive(Debug, Args)]
pub(super) struct FlatArgs {
    /// Flat length L (mm).
    #[arg(long = "l-mm", default_value_t = 60.0)]
    pub length_mm: f64,
    /// Flat depth d (mm).
    #[arg(long = "d-mm", default_value_t = 0.5)]
    pub depth_mm: f64,
    /// Curvature parameter c (mm), 0 ≤ c < d/2.
    #[arg(long = "c-mm", default_value_t = 0.1)]
    pub curvature_mm: f64,
    /// Impact position X_p (m from the left rail end).
    #[arg(long = "xp-m", default_value_t = 12.4)]
    pub impact_position_m: f64,
    /// The wheel carrying the flat: `leading` or `trailing` (default: the calibration's
    /// `vehicle.flat_wheel`).
    #[arg(long, value_parser = parse_wheel)]
    pub wheel: Option<WheelPosition>,
    /// Simulate a good wheel (no flat): the flat-free signature.
    #[arg(long, conflicts_with_all = ["length_mm", "depth_mm", "curvature_mm", "impact_position_m", "wheel"])]
    pub no_flat: bool,
}

/// `leading` or `trailing`.
// Err(String): a clap value parser: clap names the argument and prints the message.
fn parse_wheel(text: &str) -> Result<WheelPosition, String> {
    match text {
        "leading" => Ok(WheelPosition::Leading),
        "trailing" => Ok(WheelPosition::Trailing),
        _ => Err(format!("`{text}` is not a wheel: leading or trailing")),
    }
}

impl FlatArgs {
    /// The flat these arguments describe, checked; `None` for `--no-flat`.
    pub fn flat(&self) -> Result<Option<Flat>> {
        if self.no_flat {
            return Ok(None);
        }
        let flat = Flat::from_mm(
            self.length_mm,
            self.depth_mm,
            self.curvature_mm,
            self.impact_position_m,
        )?;
        Ok(Some(match self.wheel {
            Some(w) => flat.on_wheel(w),
            None => flat,
        }))
    }
}
