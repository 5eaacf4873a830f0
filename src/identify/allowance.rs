//! The landing allowance's steps at the points a pass compares (docs/identification.md,
//! "Discretisation error"): every instance's largest step between adjacent samples there,
//! read from the bank beside the points' own columns.

use crate::identify::answer::result::MeasuredSeries;
use crate::identify::domain::discretisation::Steps;
use crate::identify::domain::falsify;
use crate::identify::error::IdentifyError;
use crate::identify::identifier::Identifier;
use crate::identify::input::pip::Candidate;

impl Identifier {
    /// Every instance's steps at the EIP points `order` (indices into the candidates `cands`,
    /// whose predictions are `predictions`) — from the samples either side, two more columns a
    /// point — and at the envelope windows (their `2·hw + 1` columns each, `env_columns`).
    #[allow(clippy::too_many_arguments)]
    pub(in crate::identify) fn allowance_steps(
        &self,
        used: &[(usize, usize)],
        series: &[MeasuredSeries],
        cands: &[Candidate],
        order: &[usize],
        predictions: &[&[f32]],
        env_columns: &[&[f32]],
        hw: usize,
    ) -> Result<Steps, IdentifyError> {
        let sides: Vec<usize> = order
            .iter()
            .flat_map(|&i| {
                let Candidate {
                    series: si,
                    sample: k,
                    ..
                } = cands[i];
                let (b, last) = (used[si].1, series[si].values_kn.len() - 1);
                [
                    self.bank.sample_index(b, k.saturating_sub(1)),
                    self.bank.sample_index(b, (k + 1).min(last)),
                ]
            })
            .collect();
        let side = self.bank.read_columns(&sides)?;
        let eip: Vec<Vec<f32>> = order
            .iter()
            .enumerate()
            .map(|(j, &i)| falsify::steps(&[&side[2 * j], predictions[i], &side[2 * j + 1]]))
            .collect();
        let env: Vec<Vec<f32>> = env_columns.chunks(2 * hw + 1).map(falsify::steps).collect();
        Ok((eip, env))
    }
}
