//! A speed band (`--speeds FROM:TO:STEP`): the train speeds a bank family has members at
//! ([`super::family`]); its load counterpart is [`super::loads::LoadBand`].

use serde::{Deserialize, Serialize};

/// How far (relative) a pass's speed may be from the member it is compared with, the pass's
/// time axis scaled to the member's speed ([`crate::identify::Measurement::at_speed`]):
/// measured 2026-11-24 (`studies/src/bin/speed_study`, 100 cases, docs/bank.md "Speed"): coverage
/// 0.94–0.95 at ±3 % against 0.95 at the member's own speed, 0.91–0.92 at ±4 %. (Without the
/// scaling it is 0.25 already at ±1 %.)
pub const SPEED_TOLERANCE: f64 = 0.03;
/// The most members a family may have.
pub const MAX_MEMBERS: usize = 200;

/// Speeds from `from` to `to` every `step` (km/h), each a multiple of 0.1 km/h.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SpeedBand {
    /// Lowest member speed (km/h).
    pub from_km_per_h: f64,
    /// Highest member speed (km/h).
    pub to_km_per_h: f64,
    /// Spacing (km/h).
    pub step_km_per_h: f64,
}

impl SpeedBand {
    /// Parses `FROM:TO:STEP` (km/h), e.g. `40:60:2`, checked: speeds within the calibration's
    /// [1, 500] km/h, multiples of 0.1 km/h, FROM ≤ TO, STEP > 0, at most [`MAX_MEMBERS`]
    /// members, and no speed in the band farther than [`SPEED_TOLERANCE`] from a member.
    // Err(String): a clap value parser's message, or `BankError::SpeedBand`'s.
    pub fn parse(text: &str) -> Result<SpeedBand, String> {
        let v = super::band::parse_from_to_step(text, "in km/h (e.g. `40:60:2`)", " of km/h")?;
        let band = SpeedBand {
            from_km_per_h: v[0],
            to_km_per_h: v[1],
            step_km_per_h: v[2],
        };
        band.check().map_err(|e| format!("`{text}`: {e}"))?;
        Ok(band)
    }

    /// The checks of [`SpeedBand::parse`].
    // Err(String): a clap value parser's message, or `BankError::SpeedBand`'s.
    pub fn check(&self) -> Result<(), String> {
        let (a, b, s) = (self.from_km_per_h, self.to_km_per_h, self.step_km_per_h);
        let tenth = |x: f64| ((x * 10.0).round() - x * 10.0).abs() < 1e-6;
        if !(1.0..=500.0).contains(&a) || !(1.0..=500.0).contains(&b) {
            return Err("speeds must lie in [1, 500] km/h".into());
        }
        if !(tenth(a) && tenth(b) && tenth(s)) {
            return Err("speeds and step must be multiples of 0.1 km/h".into());
        }
        if b < a {
            return Err(format!("TO {b} is below FROM {a}"));
        }
        if s <= 0.0 || (s < 0.1 - 1e-9) {
            return Err(format!("STEP {s} must be at least 0.1 km/h"));
        }
        let n = super::band::count(a, b, s);
        if n > MAX_MEMBERS {
            return Err(format!(
                "{n} members, more than the {MAX_MEMBERS} a family may have"
            ));
        }
        if ((a + (n - 1) as f64 * s) - b).abs() > 1e-6 {
            return Err(format!(
                "STEP {s} does not reach TO {b} from FROM {a} in whole steps"
            ));
        }
        // Every speed between two members must be within the tolerance of one of them: the
        // worst is the gap's middle, judged against the lower member.
        if n > 1 && s / 2.0 > SPEED_TOLERANCE * a + 1e-9 {
            return Err(format!(
                "STEP {s} km/h leaves {:.2} km/h between {a} km/h and the next member, more than the {:.0} % ({:.2} km/h) a pass may be off its member (measured, docs/bank.md); use a STEP of at most {:.1} km/h",
                s / 2.0,
                SPEED_TOLERANCE * 100.0,
                SPEED_TOLERANCE * a,
                (2.0 * SPEED_TOLERANCE * a * 10.0 + 1e-9).floor() / 10.0
            ));
        }
        Ok(())
    }

    /// The member speeds, rounded to 0.1 km/h.
    pub fn speeds(&self) -> Vec<f64> {
        let n = super::band::count(self.from_km_per_h, self.to_km_per_h, self.step_km_per_h);
        (0..n)
            .map(|k| ((self.from_km_per_h + k as f64 * self.step_km_per_h) * 10.0).round() / 10.0)
            .collect()
    }
}

impl std::fmt::Display for SpeedBand {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}–{} km/h every {} km/h",
            self.from_km_per_h, self.to_km_per_h, self.step_km_per_h
        )
    }
}
