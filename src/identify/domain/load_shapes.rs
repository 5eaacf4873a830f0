//! The good wheel's response between a family's loads (docs/identification.md "Load"): the
//! flat-free predictions of the members at one speed, by static wheel load, so that a pass is
//! read and put on its member's load with the prediction **at its own load** — interpolated
//! linearly in load between the two members around it — instead of the member's prediction
//! scaled in proportion. A track is linear in the load except where a sleeper hangs: its gap
//! closes under heavier wheels, and the pad over it changes shape, not only size (docs/calibration.md, "The family's load step").
//!
//! Beyond the band's ends the end member is scaled in proportion (what a single bank does).
//! How far the linear interpolation may be from the response is measured on the family
//! itself ([`LoadShapes::interpolation_error_kn`]).

/// The members' flat-free predictions at one speed, by static wheel load.
#[derive(Debug, Clone)]
pub(crate) struct LoadShapes {
    /// The members' static wheel loads (kN), ascending.
    loads_kn: Vec<f64>,
    /// Per member (in `loads_kn`'s order), per bank axis, the flat-free prediction (kN).
    flat_free_kn: Vec<Vec<Vec<f32>>>,
    /// Per bank axis and sample, how far the interpolation may be from the response (kN;
    /// [`LoadShapes::interpolation_error_kn`]).
    interpolation_kn: Vec<Vec<f64>>,
}

impl LoadShapes {
    /// The shapes of `members` (static wheel load in kN, flat-free predictions per axis);
    /// `None` unless at least two members at distinct loads share the same axes and samples.
    pub(crate) fn new(mut members: Vec<(f64, Vec<Vec<f32>>)>) -> Option<LoadShapes> {
        members.sort_by(|a, b| a.0.total_cmp(&b.0));
        members.dedup_by(|a, b| (a.0 - b.0).abs() < 1e-9);
        let first = members.first()?;
        let same = members.iter().all(|(l, g)| {
            l.is_finite()
                && *l > 0.0
                && g.len() == first.1.len()
                && g.iter().zip(&first.1).all(|(a, b)| a.len() == b.len())
        });
        if members.len() < 2 || !same {
            return None;
        }
        let loads_kn: Vec<f64> = members.iter().map(|m| m.0).collect();
        let flat_free_kn: Vec<Vec<Vec<f32>>> = members.into_iter().map(|m| m.1).collect();
        let interpolation_kn = interpolation_error(&loads_kn, &flat_free_kn);
        Some(LoadShapes {
            loads_kn,
            flat_free_kn,
            interpolation_kn,
        })
    }

    /// The members' loads (kN), ascending.
    pub(crate) fn loads_kn(&self) -> &[f64] {
        &self.loads_kn
    }

    /// The flat-free prediction on `axis` at the static wheel load `load_kn`: between two
    /// members, linear in load; beyond the band, the end member scaled by the load's ratio.
    pub(crate) fn at(&self, axis: usize, load_kn: f64) -> Vec<f64> {
        let n = self.loads_kn.len();
        let of = |k: usize| self.flat_free_kn[k][axis].iter().map(|&g| f64::from(g));
        if load_kn <= self.loads_kn[0] || load_kn >= self.loads_kn[n - 1] {
            let k = if load_kn <= self.loads_kn[0] {
                0
            } else {
                n - 1
            };
            let r = load_kn / self.loads_kn[k];
            return of(k).map(|g| g * r).collect();
        }
        let hi = self.loads_kn.partition_point(|&l| l < load_kn).max(1);
        let lo = hi - 1;
        let w = (load_kn - self.loads_kn[lo]) / (self.loads_kn[hi] - self.loads_kn[lo]);
        of(lo).zip(of(hi)).map(|(a, b)| a + w * (b - a)).collect()
    }

    /// How far linear interpolation in load may be from the members' own response on `axis`,
    /// per sample (kN): measured on the family itself, at every interior member its prediction
    /// against the interpolation of its two neighbours, the largest over the members, and over
    /// the two samples either side (detection may compare through a five-sample average).
    /// That is an interpolation over twice the family's step; where the response is smooth in
    /// load one step's error is a quarter of it, but a hanging sleeper's gap closing is a kink,
    /// and across a kink one step's error can be as large as two steps' (a kink half-way in a
    /// step: both a quarter of the slope's change times the step), so the whole of it is taken.
    /// 0 with fewer than three members (nothing to measure it on).
    pub(crate) fn interpolation_error_kn(&self, axis: usize) -> &[f64] {
        &self.interpolation_kn[axis]
    }

    /// How much the prediction on `axis` changes *shape* (not only size) between the read load
    /// `load_kn` and the ends of its interval `interval_kn`, per sample (kN): for each end, the
    /// prediction there less its least-squares multiple of the prediction at the read load
    /// (what a sensor's fitted level cannot absorb), the larger of the two, and the largest over
    /// two samples either side. 0 on a linear track; beside a hanging sleeper, what a load
    /// misread inside its interval leaves in the record moved to the member's load.
    pub(crate) fn shape_change_kn(
        &self,
        axis: usize,
        load_kn: f64,
        interval_kn: [f64; 2],
    ) -> Vec<f64> {
        let g = self.at(axis, load_kn);
        let gg: f64 = g.iter().map(|x| x * x).sum();
        let mut e = vec![0.0f64; g.len()];
        for end in interval_kn {
            let h = self.at(axis, end);
            let scale = if gg > 0.0 {
                h.iter().zip(&g).map(|(a, b)| a * b).sum::<f64>() / gg
            } else {
                0.0
            };
            for ((x, a), b) in e.iter_mut().zip(&h).zip(&g) {
                *x = x.max((a - scale * b).abs());
            }
        }
        within_two_samples(&e)
    }
}

/// Each sample's largest value within two samples either side (detection may compare through a
/// five-sample average).
fn within_two_samples(e: &[f64]) -> Vec<f64> {
    let n = e.len();
    (0..n)
        .map(|i| {
            e[i.saturating_sub(2)..(i + 3).min(n)]
                .iter()
                .fold(0.0f64, |m, &x| m.max(x))
        })
        .collect()
}

/// [`LoadShapes::interpolation_error_kn`] of members at `loads_kn` (ascending), every axis.
fn interpolation_error(loads_kn: &[f64], flat_free_kn: &[Vec<Vec<f32>>]) -> Vec<Vec<f64>> {
    (0..flat_free_kn[0].len())
        .map(|a| {
            let n = flat_free_kn[0][a].len();
            let mut e = vec![0.0f64; n];
            for k in 1..loads_kn.len().saturating_sub(1) {
                let w = (loads_kn[k] - loads_kn[k - 1]) / (loads_kn[k + 1] - loads_kn[k - 1]);
                let [g0, g1, g2] = [k - 1, k, k + 1].map(|j| &flat_free_kn[j][a]);
                for (i, x) in e.iter_mut().enumerate() {
                    let between = f64::from(g0[i]) + w * f64::from(g2[i] - g0[i]);
                    *x = x.max((f64::from(g1[i]) - between).abs());
                }
            }
            within_two_samples(&e)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One axis, three samples: a response linear in load but for the last sample, which
    /// grows as the load's square (a gap closing).
    fn shapes() -> LoadShapes {
        let at = |l: f64| vec![vec![l as f32, 2.0 * l as f32, (l * l / 40.0) as f32]];
        LoadShapes::new(vec![(60.0, at(60.0)), (30.0, at(30.0)), (45.0, at(45.0))]).unwrap()
    }

    #[test]
    fn between_members_the_prediction_is_linear_in_load_and_beyond_them_proportional() {
        let s = shapes();
        assert_eq!(s.loads_kn(), &[30.0, 45.0, 60.0]);
        // At a member: its own prediction.
        let g = s.at(0, 45.0);
        assert!(
            (g[0] - 45.0).abs() < 1e-5 && (g[2] - 50.625).abs() < 1e-4,
            "{g:?}"
        );
        // Between two: linear (the linear samples exact, the square one between its chords).
        let g = s.at(0, 37.5);
        assert!(
            (g[0] - 37.5).abs() < 1e-5 && (g[1] - 75.0).abs() < 1e-4,
            "{g:?}"
        );
        let chord = 0.5 * (22.5 + 50.625);
        assert!((g[2] - chord).abs() < 1e-4, "{g:?}");
        // Beyond the band: the end member scaled by the load.
        let g = s.at(0, 66.0);
        assert!((g[2] - 90.0 * 1.1).abs() < 1e-3, "{g:?}");
        let g = s.at(0, 27.0);
        assert!((g[0] - 27.0).abs() < 1e-4, "{g:?}");
    }

    #[test]
    fn the_interpolation_error_is_measured_on_the_family_itself() {
        // l²/40 at 45 against the chord from 30 to 60: 50.625 against 56.25, 5.625 kN; the
        // linear samples exact.
        let s = shapes();
        let e = s.interpolation_error_kn(0);
        // Within two samples of the square one: 5.625 kN on all three samples here.
        assert!(e.iter().all(|x| (x - 5.625).abs() < 1e-3), "{e:?}");
        // It bounds one step's error for the square (7.5²/40 = 1.41 kN at 37.5)…
        assert!((s.at(0, 37.5)[2] - 37.5 * 37.5 / 40.0).abs() <= e[2]);
        // …and for a kink half-way in a step (a gap closing at 52.5 kN): one step's error at
        // the kink is as large as the two steps' at the interior member.
        let kink = |l: f64| vec![vec![(2.0 * (l - 52.5).max(0.0)) as f32]];
        let k = LoadShapes::new(vec![
            (45.0, kink(45.0)),
            (60.0, kink(60.0)),
            (75.0, kink(75.0)),
        ])
        .unwrap();
        let two_steps = k.interpolation_error_kn(0)[0];
        let one_step = (k.at(0, 52.5)[0] - 0.0).abs();
        assert!(
            (one_step - 7.5).abs() < 1e-4 && one_step <= two_steps + 1e-9,
            "{one_step} {two_steps}"
        );
    }

    #[test]
    fn a_misread_load_changes_the_shape_only_where_the_response_is_not_proportional() {
        // Proportional in load: a misread changes the size only, which a level absorbs.
        let linear = |l: f64| vec![vec![l as f32, 2.0 * l as f32, 0.5 * l as f32]];
        let s = LoadShapes::new(vec![(30.0, linear(30.0)), (60.0, linear(60.0))]).unwrap();
        let e = s.shape_change_kn(0, 45.0, [40.0, 50.0]);
        assert!(e.iter().all(|&x| x < 1e-5), "{e:?}");
        // A gap closing at 45 kN on the last sample only: from 45 to 50 kN it grows by
        // 2·5 = 10 kN while the others grow in proportion. The least-squares multiple of the
        // prediction at 45 kN, (45, 90, 0), that best matches (50, 100, 10) is 50/45; what it
        // leaves is 10 kN on the last sample and nothing on the others, so the largest over
        // the two samples either side is 10 kN on all three.
        let kink = |l: f64| {
            vec![vec![
                l as f32,
                2.0 * l as f32,
                (2.0 * (l - 45.0).max(0.0)) as f32,
            ]]
        };
        let k = LoadShapes::new(vec![
            (30.0, kink(30.0)),
            (45.0, kink(45.0)),
            (60.0, kink(60.0)),
        ])
        .unwrap();
        let e = k.shape_change_kn(0, 45.0, [45.0, 50.0]);
        assert!(e.iter().all(|&x| (x - 10.0).abs() < 1e-4), "{e:?}");
        // An interval that does not reach the kink: nothing.
        let e = k.shape_change_kn(0, 40.0, [35.0, 45.0]);
        assert!(e.iter().all(|&x| x < 1e-4), "{e:?}");
    }

    #[test]
    fn members_that_disagree_in_shape_or_a_single_member_give_no_shapes() {
        assert!(LoadShapes::new(vec![(30.0, vec![vec![1.0; 3]])]).is_none());
        assert!(
            LoadShapes::new(vec![(30.0, vec![vec![1.0; 3]]), (40.0, vec![vec![1.0; 4]])]).is_none()
        );
        assert!(
            LoadShapes::new(vec![(30.0, vec![vec![1.0; 3]]), (30.0, vec![vec![2.0; 3]])]).is_none()
        );
    }
}
