//! The wheel flat: its geometry (paper Eq. 9) and where it strikes the rail.

use super::wheel::WheelPosition;

use thiserror::Error;

/// Errors in flat parameters.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum FlatError {
    /// A parameter is not finite or out of its physical range.
    #[error("invalid flat parameter `{name}` = {value}: {reason}")]
    Invalid {
        /// Parameter name with unit, e.g. `length_mm`.
        name: &'static str,
        /// The value given.
        value: f64,
        /// Why it is rejected.
        reason: String,
    },
}

/// A validated wheel flat (SI units): `L > 0`, `d > 0`, `0 ≤ c < d/2`, finite `X_p`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Flat {
    length_m: f64,
    depth_m: f64,
    curvature_m: f64,
    impact_position_m: f64,
    wheel: Option<WheelPosition>,
}

impl Flat {
    /// A flat from sizes in millimetres and the impact position in metres (the units people use).
    pub fn from_mm(
        length_mm: f64,
        depth_mm: f64,
        curvature_mm: f64,
        impact_position_m: f64,
    ) -> Result<Flat, FlatError> {
        let bad = |name, value, reason: &str| FlatError::Invalid {
            name,
            value,
            reason: reason.to_string(),
        };
        for (name, v) in [
            ("length_mm", length_mm),
            ("depth_mm", depth_mm),
            ("curvature_mm", curvature_mm),
            ("impact_position_m", impact_position_m),
        ] {
            if !v.is_finite() {
                return Err(bad(name, v, "must be a finite number"));
            }
        }
        if length_mm <= 0.0 {
            return Err(bad("length_mm", length_mm, "must be positive"));
        }
        if depth_mm <= 0.0 {
            return Err(bad("depth_mm", depth_mm, "must be positive"));
        }
        if curvature_mm < 0.0 {
            return Err(bad("curvature_mm", curvature_mm, "must not be negative"));
        }
        if curvature_mm >= depth_mm / 2.0 {
            return Err(bad(
                "curvature_mm",
                curvature_mm,
                &format!("must be below d/2 = {} mm so that the trajectory stays non-negative (paper Eq. 9)", depth_mm / 2.0),
            ));
        }
        Ok(Flat {
            length_m: length_mm * 1e-3,
            depth_m: depth_mm * 1e-3,
            curvature_m: curvature_mm * 1e-3,
            impact_position_m,
            wheel: None,
        })
    }

    /// The same flat on a given wheel (without one, the calibration's `vehicle.flat_wheel`).
    pub fn on_wheel(self, wheel: WheelPosition) -> Flat {
        Flat {
            wheel: Some(wheel),
            ..self
        }
    }

    /// The wheel it is on, when set on the flat itself.
    pub fn wheel(&self) -> Option<WheelPosition> {
        self.wheel
    }

    /// Flat length L (m).
    pub fn length_m(&self) -> f64 {
        self.length_m
    }

    /// Flat depth d (m).
    pub fn depth_m(&self) -> f64 {
        self.depth_m
    }

    /// Curvature parameter c (m).
    pub fn curvature_m(&self) -> f64 {
        self.curvature_m
    }

    /// Impact position X_p (m).
    pub fn impact_position_m(&self) -> f64 {
        self.impact_position_m
    }

    /// Length of a fresh flat with this depth, `L0 = sqrt(8·d·R_w)` (paper §4.3.3), in metres.
    pub fn fresh_length_m(&self, wheel_radius_m: f64) -> f64 {
        (8.0 * self.depth_m * wheel_radius_m).sqrt()
    }

    /// Length of a fresh flat of depth `depth_mm` on a wheel of radius `wheel_radius_m`,
    /// `L0 = sqrt(8·d·R_w)` (paper §4.3.3), in millimetres: the one formula for L0 from a
    /// depth in mm (ranges of depths, population bounds), where [`Flat::fresh_length_m`]
    /// serves a flat.
    pub fn fresh_length_mm(depth_mm: f64, wheel_radius_m: f64) -> f64 {
        (8.0 * depth_mm * wheel_radius_m * 1e3).sqrt()
    }

    /// Wheel-centre drop along the flat, paper Eq. 9:
    /// `z_tr(s) = d/2·(1 − cos(2πs/L)) − c/4·(1 − cos(4πs/L))` for `0 ≤ s ≤ L`, else 0.
    pub fn profile(&self, s: f64) -> f64 {
        if !(0.0..=self.length_m).contains(&s) {
            return 0.0;
        }
        let p = std::f64::consts::TAU * s / self.length_m;
        self.depth_m / 2.0 * (1.0 - p.cos()) - self.curvature_m / 4.0 * (1.0 - (2.0 * p).cos())
    }

    /// Drop of the flat wheel's centre when the wheel is at `x` (m): the flat strikes at
    /// `X_p + n·2πR_w` for every integer n (once per revolution).
    pub fn trajectory(&self, x: f64, wheel_radius_m: f64) -> f64 {
        let circumference = std::f64::consts::TAU * wheel_radius_m;
        let n = ((x - self.impact_position_m) / circumference).floor();
        self.profile(x - (self.impact_position_m + n * circumference))
    }

    /// Positions (m) where the flat starts to strike, for strikes overlapping `[x0, x1]`.
    pub fn strikes_between(&self, x0: f64, x1: f64, wheel_radius_m: f64) -> Vec<f64> {
        let circumference = std::f64::consts::TAU * wheel_radius_m;
        let n0 = ((x0 - self.length_m - self.impact_position_m) / circumference).ceil() as i64;
        let n1 = ((x1 - self.impact_position_m) / circumference).floor() as i64;
        (n0..=n1)
            .map(|n| self.impact_position_m + n as f64 * circumference)
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn curvature_must_stay_below_half_depth() {
        let e = Flat::from_mm(60.0, 0.5, 0.25, 12.4)
            .unwrap_err()
            .to_string();
        assert!(e.contains("curvature_mm") && e.contains("0.25"), "{e}");
        assert!(Flat::from_mm(60.0, 0.5, 0.249, 12.4).is_ok());
    }

    #[test]
    fn profile_peaks_at_depth_mid_flat_and_vanishes_at_ends() {
        let f = Flat::from_mm(60.0, 0.5, 0.1, 12.4).unwrap();
        // s = L/2: d/2·2 − c/4·(1 − cos 2π) = d.
        assert!((f.profile(0.03) - 0.5e-3).abs() < 1e-15);
        assert!(f.profile(0.0).abs() < 1e-18 && f.profile(0.06).abs() < 1e-15);
        assert!(f.profile(0.07) == 0.0);
    }

    #[test]
    fn profile_is_non_negative_when_c_below_half_d() {
        let f = Flat::from_mm(100.0, 0.4, 0.199, 12.0).unwrap();
        for i in 0..=1000 {
            assert!(f.profile(0.1 * i as f64 / 1000.0) >= -1e-18);
        }
    }

    #[test]
    fn strikes_once_per_revolution() {
        let f = Flat::from_mm(60.0, 0.5, 0.1, 12.4).unwrap();
        let c = std::f64::consts::TAU * 0.4;
        let s = f.strikes_between(5.0, 15.0, 0.4);
        assert_eq!(s.len(), 4);
        for w in s.windows(2) {
            assert!((w[1] - w[0] - c).abs() < 1e-12);
        }
        assert!(s.iter().any(|x| (x - 12.4).abs() < 1e-12));
        // The trajectory repeats one circumference later.
        assert!((f.trajectory(12.43, 0.4) - f.trajectory(12.43 + c, 0.4)).abs() < 1e-15);
    }

    #[test]
    fn fresh_flat_length() {
        let f = Flat::from_mm(60.0, 0.5, 0.1, 12.4).unwrap();
        assert!((f.fresh_length_m(0.4) - (8.0f64 * 0.5e-3 * 0.4).sqrt()).abs() < 1e-15);
    }

    #[test]
    fn fresh_flat_length_from_a_depth_in_mm_agrees_with_the_flat_s() {
        // d = 0.5 mm, R_w = 0.4 m: L0 = sqrt(8 · 0.5 · 400) mm = 40 mm.
        assert!((Flat::fresh_length_mm(0.5, 0.4) - 40.0).abs() < 1e-12);
        let f = Flat::from_mm(60.0, 0.37, 0.1, 12.4).unwrap();
        let from_flat = f.fresh_length_m(0.43) * 1e3;
        assert!((Flat::fresh_length_mm(0.37, 0.43) - from_flat).abs() < 1e-12);
    }
}
