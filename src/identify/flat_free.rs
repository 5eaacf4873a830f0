//! The good-wheel check of a measurement against the bank's flat-free prediction (train).

use super::result::FlatFreeCheck;
use super::{Identifier, IdentifyError, Measurement, Prepared};

impl Identifier {
    /// The good-wheel check ([`FlatFreeCheck`]): the bank's flat-free prediction (computed,
    /// not sampled: no cell widening) against the measurement at every PIP, with thresholds
    /// for the target probability `phi` over that many points (Šídák). The relative sources
    /// scale with the larger of prediction and measurement (model errors are fractions of the
    /// predicted force, measurement errors of the measured one). `phi` = the settings' φ
    /// judges one measurement alone; a larger one spreads a family-wise φ over several (a
    /// whole train). Milliseconds: no bank column is read.
    pub fn check_flat_free(
        &self,
        m: &Measurement,
        sensors: Option<&[String]>,
        phi: f64,
    ) -> Result<FlatFreeCheck, IdentifyError> {
        let Prepared {
            used,
            series,
            cands,
            ..
        } = self.prepare(m, sensors)?;
        let template = &self.bank.metadata().flat_free_kn;
        let p = phi.powf(1.0 / cands.len().max(1) as f64);
        let mut outside = 0;
        let mut worst: Option<(String, f64, f64, f64, f64)> = None;
        for &(si, k, _) in &cands {
            let ser = &series[si];
            let y = ser.values_kn[k];
            let g = template[used[si].1][k] as f64;
            let base = if g.abs() > y.abs() { g } else { y };
            let (lo, hi) = self.uncertainty.thresholds(base, p);
            let r = g - y;
            let beyond = (r - hi).max(lo - r);
            if beyond > 0.0 {
                outside += 1;
            }
            if worst.as_ref().is_none_or(|w| beyond > w.4) {
                let t = ser.t0_s + k as f64 / ser.sample_rate_hz;
                worst = Some((ser.sensor.clone(), t, y, g, beyond));
            }
        }
        Ok(FlatFreeCheck {
            points: cands.len(),
            per_point_probability: p,
            outside,
            worst,
            passes: outside == 0,
        })
    }
}
