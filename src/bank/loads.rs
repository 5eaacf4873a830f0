//! A family's load band: banks of one calibration at car-body masses across a band, so that
//! a pass is compared with a bank of its own load (docs/bank.md "Bank families:
//! every load"). The band is given as factors of the calibration's car-body mass
//! (`--loads 0.6:1.1:0.5`: 0.6 and 1.1 × `vehicle.car_body_mass_kg`); a pass's load is
//! read from its record ([`crate::identify::detect::load`]) and picks the member nearest it in static
//! wheel load.

use crate::model::calibration::VehicleParams;
use serde::{Deserialize, Serialize};

/// How much lighter (relative, in static wheel load) than the member it is compared with a
/// pass's load may be: measured 2026-11-26 (`studies/src/bin/load_study`, 200 converged passes a
/// load): the coverage at each offset is in docs/bank.md, "Bank families: every load".
pub(crate) const LOAD_TOLERANCE_LIGHTER: f64 = 0.15;
/// How much heavier than its member a pass's load may be: coverage 1.000 at +14.9 % and at
/// +29.7 % (the same study).
pub(crate) const LOAD_TOLERANCE_HEAVIER: f64 = 0.30;
/// The most load members a family may have (per speed).
pub(crate) const MAX_LOADS: usize = 20;

/// Car-body masses from `from` to `to` every `step`, as factors of `car_body_mass_kg`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LoadBand {
    /// Lowest factor.
    pub from: f64,
    /// Highest factor.
    pub to: f64,
    /// Spacing.
    pub step: f64,
    /// The car-body mass the factors multiply (kg): the calibration's.
    pub car_body_mass_kg: f64,
}

impl LoadBand {
    /// Parses `FROM:TO:STEP` (factors of the calibration's car-body mass, e.g. `0.6:1.1:0.5`),
    /// checked against `vehicle` ([`LoadBand::check`]).
    // Err(String): a clap value parser's message, or `BankError::LoadBand`'s reason.
    pub fn parse(text: &str, vehicle: &VehicleParams) -> Result<LoadBand, String> {
        let v = super::band::parse_from_to_step(
            text,
            "in factors of the car-body mass (e.g. `0.6:1.1:0.5`)",
            "",
        )?;
        let band = LoadBand {
            from: v[0],
            to: v[1],
            step: if (v[1] - v[0]).abs() < 1e-9 {
                1.0
            } else {
                v[2]
            },
            car_body_mass_kg: vehicle.car_body_mass_kg,
        };
        band.check(vehicle).map_err(|e| format!("`{text}`: {e}"))?;
        Ok(band)
    }

    /// Factors in (0, 5], multiples of 0.01, FROM ≤ TO, STEP > 0 reaching TO, at most
    /// [`MAX_LOADS`] members, and every load between two members within the tolerances of one
    /// of them ([`admissible`]; in static wheel load, with `vehicle`'s other masses).
    // Err(String): a clap value parser's message, or `BankError::LoadBand`'s reason.
    pub fn check(&self, vehicle: &VehicleParams) -> Result<(), String> {
        let (a, b, s) = (self.from, self.to, self.step);
        let hundredth = |x: f64| ((x * 100.0).round() - x * 100.0).abs() < 1e-6;
        if !(a > 0.0 && a <= 5.0 && b > 0.0 && b <= 5.0) {
            return Err("factors must lie in (0, 5]".into());
        }
        if !(hundredth(a) && hundredth(b) && hundredth(s)) {
            return Err("factors and step must be multiples of 0.01".into());
        }
        if b < a {
            return Err(format!("TO {b} is below FROM {a}"));
        }
        if s < 0.01 - 1e-9 {
            return Err(format!("STEP {s} must be at least 0.01"));
        }
        let n = super::band::count(a, b, s);
        if n > MAX_LOADS {
            return Err(format!(
                "{n} loads, more than the {MAX_LOADS} a family may have"
            ));
        }
        if ((a + (n - 1) as f64 * s) - b).abs() > 1e-6 {
            return Err(format!(
                "STEP {s} does not reach TO {b} from FROM {a} in whole steps"
            ));
        }
        if !(self.car_body_mass_kg > 0.0 && self.car_body_mass_kg.is_finite()) {
            return Err(format!("car-body mass {} kg", self.car_body_mass_kg));
        }
        // Between two members, the lower one serves passes up to its heavier tolerance and
        // the upper one down to its lighter: the two must meet.
        let loads: Vec<f64> = self
            .factors()
            .iter()
            .map(|&f| self.wheel_load_kn(f, vehicle))
            .collect();
        for p in loads.windows(2) {
            let (up, down) = (
                p[0] * (1.0 + LOAD_TOLERANCE_HEAVIER),
                p[1] * (1.0 - LOAD_TOLERANCE_LIGHTER),
            );
            if up < down - 1e-9 {
                return Err(format!(
                    "STEP {s} leaves {up:.1}–{down:.1} kN a wheel between the members at {:.1} and {:.1} kN uncovered (a pass may be at most {:.1} % lighter and {:.0} % heavier than its member, measured, docs/bank.md); use a smaller STEP",
                    p[0],
                    p[1],
                    LOAD_TOLERANCE_LIGHTER * 100.0,
                    LOAD_TOLERANCE_HEAVIER * 100.0
                ));
            }
        }
        Ok(())
    }

    /// The member factors, rounded to 0.01.
    pub fn factors(&self) -> Vec<f64> {
        let n = super::band::count(self.from, self.to, self.step);
        (0..n)
            .map(|k| ((self.from + k as f64 * self.step) * 100.0).round() / 100.0)
            .collect()
    }

    /// The static wheel load (kN) at factor `f` of the band's car-body mass, with `vehicle`'s
    /// other masses.
    pub fn wheel_load_kn(&self, f: f64, vehicle: &VehicleParams) -> f64 {
        VehicleParams {
            car_body_mass_kg: f * self.car_body_mass_kg,
            ..vehicle.clone()
        }
        .static_wheel_load_n()
            / 1e3
    }
}

impl std::fmt::Display for LoadBand {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "car-body mass {}–{} × {} kg every {}",
            self.from, self.to, self.car_body_mass_kg, self.step
        )
    }
}

/// How far a pass showing `shown_kn` is from a member at `member_kn`, as a fraction of the
/// tolerance on its side (≤ 1: admissible): the heavier side is wider (measured).
pub(crate) fn admissible(member_kn: f64, shown_kn: f64) -> f64 {
    let off = shown_kn / member_kn - 1.0;
    if off >= 0.0 {
        off / LOAD_TOLERANCE_HEAVIER
    } else {
        -off / LOAD_TOLERANCE_LIGHTER
    }
}

/// The member among `loads_kn` (static wheel loads, kN, increasing) a pass whose record shows
/// `shown_kn` is compared with: the one it is nearest by [`admissible`], if admissible; else
/// `Err` with the range the members cover (kN).
pub(crate) fn nearest_load(loads_kn: &[f64], shown_kn: f64) -> Result<usize, [f64; 2]> {
    let k = nearest_however_far(loads_kn, shown_kn);
    if admissible(loads_kn[k], shown_kn) <= 1.0 + 1e-12 {
        Ok(k)
    } else {
        Err([
            loads_kn[0] * (1.0 - LOAD_TOLERANCE_LIGHTER),
            loads_kn[loads_kn.len() - 1] * (1.0 + LOAD_TOLERANCE_HEAVIER),
        ])
    }
}

/// The member [`nearest_load`] would take, however far (diagnosis).
pub(crate) fn nearest_however_far(loads_kn: &[f64], shown_kn: f64) -> usize {
    (0..loads_kn.len())
        .min_by(|&a, &b| {
            admissible(loads_kn[a], shown_kn).total_cmp(&admissible(loads_kn[b], shown_kn))
        })
        .expect("a family has members")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_band_is_parsed_checked_and_spaced_by_the_tolerance() {
        let v = crate::model::Calibration::default().vehicle;
        let b = LoadBand::parse("0.6:1.1:0.5", &v).unwrap();
        assert_eq!(b.factors(), vec![0.6, 1.1]);
        assert!((b.car_body_mass_kg - v.car_body_mass_kg).abs() < 1e-9);
        assert!(LoadBand::parse("1:1:0", &v).unwrap().factors() == vec![1.0]);
        assert!(LoadBand::parse("0.6:1.4", &v).is_err());
        assert!(LoadBand::parse("1.4:0.6:0.4", &v).is_err());
        assert!(LoadBand::parse("0.6:1.4:0.3", &v).is_err());
        // 0.6 serves up to 34.8 × 1.3 = 45.3 kN, 1.2 down to 56.9 × 0.85 = 48.4 kN: a gap,
        // refused with what is left uncovered.
        let e = LoadBand::parse("0.6:1.2:0.6", &v).unwrap_err();
        assert!(
            e.contains("45.3–48.4 kN") && e.contains("use a smaller STEP"),
            "{e}"
        );
    }

    #[test]
    fn the_nearest_member_is_taken_within_the_tolerance_and_refused_beyond() {
        let loads = [35.0, 49.5, 64.0];
        // 47 kN is 34 % above the first member, 5 % below the second: the second.
        assert_eq!(nearest_load(&loads, 47.0), Ok(1));
        // 40 kN is 19 % below the second (beyond its lighter side), 14 % above the first.
        assert_eq!(nearest_load(&loads, 40.0), Ok(0));
        assert_eq!(nearest_load(&loads, 50.0), Ok(1));
        assert_eq!(nearest_load(&loads, 70.0), Ok(2));
        let e = nearest_load(&loads, 90.0).unwrap_err();
        assert!((e[1] - 64.0 * (1.0 + LOAD_TOLERANCE_HEAVIER)).abs() < 1e-9);
        assert!(nearest_load(&loads, 29.0).is_err());
    }
}
