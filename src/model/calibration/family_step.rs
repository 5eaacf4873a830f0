//! The check of `population.family_load_step`, the car-body step of a site's family over
//! loads (`calibrate` writes it; `bank generate --loads auto` reads it; docs/calibration.md
//! "The family's load step").

use super::CalibrationError;

/// A step in 0.01–0.8 (factors of the car-body mass), a multiple of 0.01, or none.
pub(super) fn check(step: Option<f64>) -> Result<(), CalibrationError> {
    let Some(step) = step else {
        return Ok(());
    };
    let hundredths = step * 100.0;
    if !(0.01..=0.8).contains(&step) || (hundredths - hundredths.round()).abs() > 1e-6 {
        return Err(CalibrationError::Invalid {
            key: "population.family_load_step".into(),
            value: step.to_string(),
            reason: "a factor of the car-body mass in 0.01–0.8, a multiple of 0.01".into(),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_step_off_the_hundredths_or_outside_the_band_is_refused_by_name() {
        assert!(check(None).is_ok() && check(Some(0.2)).is_ok() && check(Some(0.05)).is_ok());
        for bad in [0.0, 0.005, 0.9, 0.125, f64::NAN] {
            let e = check(Some(bad)).unwrap_err().to_string();
            assert!(e.contains("population.family_load_step"), "{bad}: {e}");
        }
    }
}
