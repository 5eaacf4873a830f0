//! How a folded bank is read (`population.fold_to_one_bay`, docs/bank.md "Folded banks"): its
//! shards hold N instances with X_p over one sleeper bay and the windows of the sensors' pads
//! and of the sleepers up to K before them; [`super::reader::Bank`] presents N·(K+1)
//! instances over the calibration's own sensors, instance `k·N + i` being stored instance `i`
//! shifted by `k` whole bays (its window at sensor `s` is stored instance `i`'s at the pad
//! `k` sleepers before `s`, its X_p `X_p(i) + k·bay` on the revolution).

use super::schema::{sample_column_index, BankMetadata, Parameters, SensorAxis};
use super::BankError;
use crate::model::Calibration;
use std::path::Path;

/// A folded bank's view.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Fold {
    /// Whole-bay shifts beyond the stored bay (K).
    shifts: usize,
    /// The stored axes (the sensors' own first).
    stored_axes: Vec<SensorAxis>,
    /// Per sensor (the calibration's order), its stored axis at each shift 0..=K.
    axes: Vec<Vec<usize>>,
}

impl Fold {
    /// The fold of a bank whose metadata is `meta` (`None`: not folded), and the metadata as
    /// presented: the calibration's sensors only. A stored axis a shift needs and the bank
    /// lacks is a corrupt bank, named.
    pub(crate) fn of(
        meta: BankMetadata,
        path: &Path,
    ) -> Result<(BankMetadata, Option<Fold>), BankError> {
        let cal = &meta.calibration;
        if !cal.population.fold_to_one_bay {
            return Ok((meta, None));
        }
        let shifts = cal.fold_shifts();
        let corrupt = |message: String| BankError::Corrupt {
            path: path.to_path_buf(),
            message,
        };
        let own = cal.sensors.pad.len();
        let stored_axes = meta.sensors.clone();
        let mut axes = Vec::with_capacity(own);
        for (a, pad) in cal.sensors.pad.iter().enumerate() {
            if stored_axes.get(a).map(|x| (&x.name, x.sleeper)) != Some((&pad.name, pad.sleeper)) {
                return Err(corrupt(format!(
                    "folded bank: stored axis {a} is not sensor `{}` on sleeper {}",
                    pad.name, pad.sleeper
                )));
            }
            let per_shift = (0..=shifts)
                .map(|k| {
                    pad.sleeper
                        .checked_sub(k)
                        .and_then(|s| stored_axes.iter().position(|x| x.sleeper == s))
                        .ok_or_else(|| {
                            corrupt(format!(
                                "folded bank: no stored window {k} sleepers before sensor `{}`",
                                pad.name
                            ))
                        })
                })
                .collect::<Result<Vec<usize>, BankError>>()?;
            axes.push(per_shift);
        }
        if meta.flat_free_kn.len() != stored_axes.len() {
            return Err(corrupt(format!(
                "{} flat-free templates for {} stored axes",
                meta.flat_free_kn.len(),
                stored_axes.len()
            )));
        }
        let fold = Fold {
            shifts,
            stored_axes,
            axes,
        };
        let mut shown = meta;
        shown.sensors.truncate(own);
        shown.flat_free_kn.truncate(own);
        Ok((shown, Some(fold)))
    }

    /// Presented instances per stored instance (K + 1).
    pub(crate) fn factor(&self) -> usize {
        self.shifts + 1
    }

    /// The axes as stored.
    pub(crate) fn stored_axes(&self) -> &[SensorAxis] {
        &self.stored_axes
    }

    /// The stored columns behind presented sample columns `indices` (schema indices over the
    /// presented axes `shown`): for each index, its column at shifts 0..=K, in that order.
    pub(crate) fn stored_columns(
        &self,
        shown: &[SensorAxis],
        indices: &[usize],
    ) -> Result<Vec<usize>, BankError> {
        let mut out = Vec::with_capacity(indices.len() * self.factor());
        for &col in indices {
            let (axis, k) =
                axis_sample(shown, col).ok_or(BankError::NotForceColumn { column: col })?;
            out.extend(
                self.axes[axis]
                    .iter()
                    .map(|&stored| sample_column_index(&self.stored_axes, stored, k)),
            );
        }
        Ok(out)
    }

    /// Presented instance `v` of a bank storing `stored` instances: (stored instance, shift).
    pub(crate) fn split(&self, v: usize, stored: usize) -> (usize, usize) {
        (v % stored, v / stored)
    }

    /// The presented instance's windows from its stored instance's (stored axes' order) at
    /// shift `k`: the calibration's sensors' order.
    pub(crate) fn windows(&self, stored: &[Vec<f32>], k: usize) -> Vec<Vec<f32>> {
        self.axes.iter().map(|a| stored[a[k]].clone()).collect()
    }
}

/// A folded population's parameters as read: the stored ones (`p`, N instances) at every
/// whole-bay shift of `cal`, instance `k·N + i` at X_p [`Calibration::folded_position_m`]. The
/// reader presents a folded bank's parameters so, and generation searches the neighbour graph
/// over them.
pub(crate) fn expand(p: Parameters, cal: &Calibration) -> Parameters {
    let n = p.instance.len();
    let mut out = Parameters::default();
    for k in 0..cal.fold_factor() {
        out.instance.extend((0..n).map(|i| (k * n + i) as u32));
        out.length_mm.extend_from_slice(&p.length_mm);
        out.depth_mm.extend_from_slice(&p.depth_mm);
        out.curvature_mm.extend_from_slice(&p.curvature_mm);
        out.impact_position_m.extend(
            p.impact_position_m
                .iter()
                .map(|&x| cal.folded_position_m(x, k)),
        );
        out.l0_mm.extend_from_slice(&p.l0_mm);
        out.flat_wheel.extend_from_slice(&p.flat_wheel);
        out.peak_contact_kn.extend_from_slice(&p.peak_contact_kn);
    }
    out
}

/// The (axis, sample) of schema column `col` over `axes`, if it is a sample column.
fn axis_sample(axes: &[SensorAxis], col: usize) -> Option<(usize, usize)> {
    let mut at = col.checked_sub(1 + super::schema::PARAMETER_COLUMNS.len())?;
    for (a, axis) in axes.iter().enumerate() {
        if at < axis.samples {
            return Some((a, at));
        }
        at -= axis.samples;
    }
    None
}
