//! The landing allowance's steps at the points a pass compares (docs/identification.md,
//! "Discretisation error"): every instance's largest step between adjacent samples there,
//! read from the bank beside the points' own columns.

use crate::identify::domain::discretisation::Steps;
use crate::identify::domain::falsify;
use crate::identify::error::IdentifyError;
use crate::identify::identifier::Identifier;

impl Identifier {
    /// Every instance's steps at the sample points `at` (bank axis, sample), whose predictions
    /// are `predictions` — from the samples either side, two more columns a point — and at the
    /// envelope windows (their `2·hw + 1` columns each, `env_columns`).
    pub(in crate::identify) fn allowance_steps(
        &self,
        at: &[(usize, usize)],
        predictions: &[&[f32]],
        env_columns: &[&[f32]],
        hw: usize,
    ) -> Result<Steps, IdentifyError> {
        let axes = &self.bank.metadata().sensors;
        let sides: Vec<usize> = at
            .iter()
            .flat_map(|&(b, k)| {
                let last = axes[b].samples - 1;
                [
                    self.bank.sample_index(b, k.saturating_sub(1)),
                    self.bank.sample_index(b, (k + 1).min(last)),
                ]
            })
            .collect();
        let side = self.bank.read_columns(&sides)?;
        let points: Vec<Vec<f32>> = predictions
            .iter()
            .enumerate()
            .map(|(j, g)| falsify::steps(&[&side[2 * j], g, &side[2 * j + 1]]))
            .collect();
        let env: Vec<Vec<f32>> = env_columns.chunks(2 * hw + 1).map(falsify::steps).collect();
        Ok((points, env))
    }
}
