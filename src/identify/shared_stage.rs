//! The shared-gain stage of [`Identifier::judge`] (docs/model.md §8, "Shared
//! gains"): the survivors of the per-point thresholds judged again at every point the pass
//! read — each PIP candidate and each envelope window's extremes — with one gain per sensor
//! solved for each instance inside the table's relative bounds, and only what is truly per
//! point bounded per point ([`crate::identify::domain::shared_gain`]).

use crate::identify::answer::identification::Identification;
use crate::identify::answer::sizing::Sizing;
use crate::identify::domain::shared_gain::{keep_resolved, measurement_bound_kn, SharedPoint};
use crate::identify::domain::table_bounds::TableBounds;
use crate::identify::error::IdentifyError;
use crate::identify::identifier::Identifier;
use crate::identify::select::envelope;
use crate::identify::select::envelope::EnvelopePoint;

/// What the shared stage reads of a pass: every point with its predictions, and the
/// allowance's shares and steps where the samples are compared one by one.
pub(super) struct SharedInput<'a> {
    /// Each PIP candidate's sensor (its series).
    pub(super) sensors: Vec<usize>,
    /// Every instance's prediction at each candidate.
    pub(super) predictions: &'a [&'a [f32]],
    /// The measured force at each candidate (kN).
    pub(super) measured: &'a [f64],
    /// The flat-free prediction at each candidate (kN).
    pub(super) flat_free: &'a [f64],
    /// The envelope points (a window's maximum, then its minimum) and their predictions.
    pub(super) envelope: (&'a [EnvelopePoint], &'a [Vec<f32>]),
    /// The flat-free peak of each envelope window (kN).
    pub(super) env_flat_free: &'a [f64],
    /// The landing allowance (`None`: none).
    pub(super) allowance: Option<Allowance<'a>>,
    /// The bounds of the pass (the table's, with its roughness).
    pub(super) bounds: TableBounds,
}

/// The landing allowance of the shared stage: each instance's share, and every instance's
/// steps at each candidate and at each envelope window.
#[derive(Clone, Copy)]
pub(super) struct Allowance<'a> {
    pub(super) shares: &'a [f32],
    pub(super) candidates: &'a [Vec<f32>],
    pub(super) windows: &'a [Vec<f32>],
}

impl Identifier {
    /// The instances of `alive` that one gain per sensor explains at every point of `input`.
    pub(super) fn shared_gains(&self, input: &SharedInput<'_>, alive: Vec<u32>) -> Vec<u32> {
        if alive.is_empty() {
            return alive;
        }
        let bound = |ff: f64| measurement_bound_kn(&input.bounds, ff);
        let mut points: Vec<SharedPoint> = (0..input.measured.len())
            .map(|i| SharedPoint {
                sensor: input.sensors[i],
                predictions: input.predictions[i],
                measured_kn: input.measured[i],
                flat_free_kn: input.flat_free[i],
                bound_kn: bound(input.flat_free[i]),
                allowance: input
                    .allowance
                    .map(|a| (a.shares, a.candidates[i].as_slice())),
            })
            .collect();
        let (env, features) = input.envelope;
        points.extend(env.iter().zip(features).enumerate().map(|(j, (e, f))| {
            let ff = input.env_flat_free[j / 2];
            SharedPoint {
                sensor: e.series,
                predictions: f,
                measured_kn: e.measured_kn,
                flat_free_kn: ff,
                bound_kn: bound(ff),
                allowance: input
                    .allowance
                    .map(|a| (a.shares, a.windows[j / 2].as_slice())),
            }
        }));
        let form = self.settings.shared_model_form;
        keep_resolved(&points, &alive, &input.bounds, form, self.resolution())
    }

    /// Whether the shared stage keeps instance `k` of the bank against identification `id`
    /// (sized as `sizing`): the stage rebuilt from what `identification.json` holds — every
    /// PIP candidate and envelope window re-read from the bank — for `audit`. `true` when the
    /// settings have no shared stage or the identification fell back to the per-point answer.
    pub(crate) fn shared_keeps(
        &self,
        id: &Identification,
        sizing: &Sizing,
        k: usize,
    ) -> Result<bool, IdentifyError> {
        if !self.settings.shared_gains || sizing.shared_gains_fallback {
            return Ok(true);
        }
        let axes = &self.bank.metadata().sensors;
        let axis_of = |series: usize| {
            axes.iter()
                .position(|a| a.name == id.series[series].sensor)
                .expect("identified sensors are the bank's")
        };
        let cmp = id.comparison;
        let n = self.bank.instances();
        let read = |points: &[(usize, usize)]| -> Result<Vec<Vec<f32>>, IdentifyError> {
            let mut flat = vec![0.0f32; points.len() * n];
            self.read_compared(points, cmp, &mut flat)?;
            Ok(flat.chunks(n.max(1)).map(<[f32]>::to_vec).collect())
        };
        let cands = &sizing.candidates;
        let at: Vec<(usize, usize)> = cands
            .iter()
            .map(|c| (axis_of(c.series), c.sample))
            .collect();
        let columns = read(&at)?;
        let predictions: Vec<&[f32]> = columns.iter().map(Vec::as_slice).collect();
        let flat_free: Vec<f64> = at
            .iter()
            .map(|&(a, j)| f64::from(self.flat_free(a, cmp)[j]))
            .collect();
        let measured: Vec<f64> = cands.iter().map(|c| c.measured_kn).collect();
        let hw = sizing.envelope.first().map_or(0, |x| x.half_width);
        let mut env_columns = Vec::new();
        let mut env_flat_free = Vec::new();
        for x in sizing.envelope.iter().step_by(2) {
            let a = axis_of(x.series);
            let window: Vec<(usize, usize)> =
                (x.sample - hw..=x.sample + hw).map(|j| (a, j)).collect();
            env_columns.extend(read(&window)?);
            env_flat_free.push(self.flat_free_peak_kn(a, x.sample - hw, x.sample + hw, cmp));
        }
        let windows: Vec<Vec<&[f32]>> = env_columns
            .chunks(2 * hw + 1)
            .map(|w| w.iter().map(Vec::as_slice).collect())
            .collect();
        let features: Vec<Vec<f32>> = sizing
            .envelope
            .iter()
            .enumerate()
            .map(|(j, x)| envelope::feature(&windows[j / 2], x.kind == envelope::Extreme::Max))
            .collect();
        let shares = self
            .discretisation()
            .filter(|_| cmp == crate::identify::input::compare::Comparison::Samples);
        let (cand_steps, env_steps) = match shares {
            Some(_) => {
                let env: Vec<&[f32]> = env_columns.iter().map(Vec::as_slice).collect();
                self.allowance_steps(&at, &predictions, &env, hw, Some(&[k as u32]))?
            }
            None => (Vec::new(), Vec::new()),
        };
        let rough = id
            .roughness
            .clone()
            .unwrap_or_else(|| crate::identify::detect::roughness::RoughnessUse::none(0.0, 0.0));
        let input = SharedInput {
            sensors: cands.iter().map(|c| c.series).collect(),
            predictions: &predictions,
            measured: &measured,
            flat_free: &flat_free,
            envelope: (&sizing.envelope, &features),
            env_flat_free: &env_flat_free,
            allowance: shares.map(|shares| Allowance {
                shares,
                candidates: &cand_steps,
                windows: &env_steps,
            }),
            bounds: rough.bounds(self.bounds),
        };
        Ok(!self.shared_gains(&input, vec![k as u32]).is_empty())
    }
}
