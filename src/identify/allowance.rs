//! The landing allowance's steps at the points a pass compares (docs/identification.md,
//! "Discretisation error"): every instance's largest step between adjacent samples there,
//! read from the bank beside the points' own columns.
//!
//! The columns either side of a point are read a block of points at a time into one reused
//! buffer and folded into the steps at once, never kept (docs/performance.md, "Identification
//! speed"); where only some instances are still judged (the shared stage after falsification)
//! only their values are read ([`crate::bank::Bank::gather_columns`]) and only their steps
//! written (the vectors are still one value an instance: ~12 MB zeroed a two-sensor pass).

use crate::identify::domain::discretisation::Steps;
use crate::identify::domain::falsify;
use crate::identify::error::IdentifyError;
use crate::identify::identifier::Identifier;

/// Points whose side columns are read at a time (2 × 8 columns of 50,000: 3.2 MB).
const BLOCK: usize = 8;

impl Identifier {
    /// Every instance's steps at the sample points `at` (bank axis, sample), whose predictions
    /// are `predictions` — from the samples either side, two more columns a point — and at the
    /// envelope windows (their `2·hw + 1` columns each, `env_columns`). With `only`, the point
    /// steps are those instances' alone (the others' 0), read from their values alone.
    pub(in crate::identify) fn allowance_steps(
        &self,
        at: &[(usize, usize)],
        predictions: &[&[f32]],
        env_columns: &[&[f32]],
        hw: usize,
        only: Option<&[u32]>,
    ) -> Result<Steps, IdentifyError> {
        let axes = &self.bank.metadata().sensors;
        let n = self.bank.instances();
        let side_of = |&(b, k): &(usize, usize)| {
            let last = axes[b].samples - 1;
            [
                self.bank.sample_index(b, k.saturating_sub(1)),
                self.bank.sample_index(b, (k + 1).min(last)),
            ]
        };
        let mut points: Vec<Vec<f32>> = Vec::with_capacity(at.len());
        match only {
            None => {
                let mut side = vec![0.0f32; 2 * BLOCK.min(at.len()) * n];
                for (block, g) in at.chunks(BLOCK).zip(predictions.chunks(BLOCK)) {
                    let sides: Vec<usize> = block.iter().flat_map(side_of).collect();
                    let side = &mut side[..sides.len() * n];
                    self.bank.read_columns_flat(&sides, side)?;
                    for (j, g) in g.iter().enumerate() {
                        let before = &side[2 * j * n..(2 * j + 1) * n];
                        let after = &side[(2 * j + 1) * n..(2 * j + 2) * n];
                        points.push(falsify::steps(&[before, g, after]));
                    }
                }
            }
            Some(alive) => {
                // The survivors' values alone, where they lie in the mapped shards.
                let m = alive.len();
                let sides: Vec<usize> = at.iter().flat_map(side_of).collect();
                let mut side = vec![0.0f32; sides.len() * m];
                self.bank.gather_columns(&sides, alive, &mut side)?;
                for (j, g) in predictions.iter().enumerate() {
                    let (before, after) = (&side[2 * j * m..], &side[(2 * j + 1) * m..]);
                    let mut s = vec![0.0f32; n];
                    for (i, &k) in alive.iter().enumerate() {
                        let k = k as usize;
                        s[k] = falsify::largest_step([before[i], g[k], after[i]]);
                    }
                    points.push(s);
                }
            }
        }
        let env: Vec<Vec<f32>> = env_columns.chunks(2 * hw + 1).map(falsify::steps).collect();
        Ok((points, env))
    }
}
