//! The integrator's step schedule: coarse steps where the wheels roll on round tread, fine
//! steps from shortly before each flat strike (and each wheel's arrival at a rail dip) until
//! well after the landing impact.
//!
//! Time is cut into coarse intervals `[j·dt_c, (j+1)·dt_c]`, `dt_c = 1/(rate·n_c)`, so every
//! output sample `k/rate` falls on an interval boundary. An interval that overlaps a fine
//! zone is taken as `n_f` fine steps of `dt_c/n_f`, one that does not as one coarse step:
//! the fine zones are widened to whole coarse intervals, never split. The zone margins are
//! settings of the calibration (`integration.fine_before_strike_s`, `fine_after_strike_s`),
//! chosen by the convergence study.

use super::calibration::IntegrationParams;
use super::effect::Effect;
use super::flat::Flat;

/// Which step size to take.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Level {
    /// The coarse step (round wheel rolling).
    Coarse,
    /// The fine step (flat strike and impact).
    Fine,
}

/// The fine zones of one run and the strikes they come from.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Schedule {
    /// Times at which the flat starts to strike (s).
    pub strike_times_s: Vec<f64>,
    /// Time windows `(from, to)` (s) in which fine steps are taken.
    pub fine_zones_s: Vec<(f64, f64)>,
}

impl Schedule {
    /// The step size for the coarse interval `[t0_s, t1_s]`: fine when it overlaps a zone.
    #[inline]
    pub fn level(&self, t0_s: f64, t1_s: f64) -> Level {
        if self.fine_zones_s.iter().any(|&(a, b)| a < t1_s && b > t0_s) {
            Level::Fine
        } else {
            Level::Coarse
        }
    }

    /// Steps `[coarse, fine]` taken over `coarse_intervals` intervals of `dt_coarse_s` with
    /// `fine_per_coarse` fine steps in each fine one (the integrator's loop, without physics).
    pub fn step_counts(
        &self,
        coarse_intervals: usize,
        dt_coarse_s: f64,
        fine_per_coarse: usize,
    ) -> [usize; 2] {
        let mut steps = [0, 0];
        for j in 0..coarse_intervals {
            let (t0, t1) = (j as f64 * dt_coarse_s, (j + 1) as f64 * dt_coarse_s);
            match self.level(t0, t1) {
                Level::Coarse => steps[0] += 1,
                Level::Fine => steps[1] += fine_per_coarse,
            }
        }
        steps
    }
}

/// The strikes of `flat` on a wheel that starts at `x0_m` and rolls at `speed_m_per_s` up to
/// `t_end_s`, and their fine zones: a strike starting at `t = (x_s − x0)/v` is covered from
/// `t − fine_before_strike_s` to `t + L/v + fine_after_strike_s`.
pub(crate) fn strike_zones(
    flat: &Flat,
    x0_m: f64,
    speed_m_per_s: f64,
    wheel_radius_m: f64,
    t_end_s: f64,
    integ: &IntegrationParams,
) -> Schedule {
    let x1 = x0_m + speed_m_per_s * t_end_s;
    let strikes = flat.strikes_between(x0_m, x1, wheel_radius_m);
    let times: Vec<f64> = strikes
        .iter()
        .map(|xs| (xs - x0_m) / speed_m_per_s)
        .collect();
    let zones = times
        .iter()
        .map(|t| {
            (
                t - integ.fine_before_strike_s,
                t + flat.length_m() / speed_m_per_s + integ.fine_after_strike_s,
            )
        })
        .collect();
    Schedule {
        strike_times_s: times,
        fine_zones_s: zones,
    }
}

/// Fine zones around the rail dips of `effects`: from each wheel's arrival at a dip to its
/// leaving it, widened like a strike's (none for a dip of no depth).
pub(crate) fn dip_zones(
    effects: &[Effect],
    wheel_start_m: [f64; 2],
    speed_m_per_s: f64,
    integ: &IntegrationParams,
) -> Vec<(f64, f64)> {
    let mut zones = Vec::new();
    for (x_in, x_out) in effects.iter().filter_map(Effect::dip_span_m) {
        for x0 in wheel_start_m {
            let t_in = (x_in - x0) / speed_m_per_s;
            let t_out = (x_out - x0) / speed_m_per_s;
            zones.push((
                t_in - integ.fine_before_strike_s,
                t_out + integ.fine_after_strike_s,
            ));
        }
    }
    zones
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Calibration, Flat, Record, Simulator};
    use std::f64::consts::TAU;

    /// Tolerance on times (s): rounding of sums of a few hundred steps.
    const TIME_TOL_S: f64 = 1e-12;

    fn integ() -> IntegrationParams {
        Calibration::default().integration // fine 1 ms before, 10 ms after
    }

    #[test]
    fn one_zone_per_strike_from_before_the_strike_to_after_the_flat() {
        // R_w = 0.4 m, v = 10 m/s, the wheel from 6 m for 1 s (to 16 m), X_p = 12.4 m:
        // strikes at 12.4 + n·2πR_w over the run, t = (x_s − 6)/v, zones
        // [t − 1 ms, t + L/v + 10 ms].
        let flat = Flat::from_mm(60.0, 0.5, 0.1, 12.4).unwrap();
        let (v, r) = (10.0, 0.4);
        let s = strike_zones(&flat, 6.0, v, r, 1.0, &integ());
        let revolution_s = TAU * r / v;
        assert_eq!(s.strike_times_s.len(), 4);
        assert_eq!(s.fine_zones_s.len(), 4);
        assert!(s
            .strike_times_s
            .iter()
            .any(|t| (t - 0.64).abs() < TIME_TOL_S));
        for w in s.strike_times_s.windows(2) {
            assert!((w[1] - w[0] - revolution_s).abs() < TIME_TOL_S);
        }
        for (t, (a, b)) in s.strike_times_s.iter().zip(&s.fine_zones_s) {
            assert!((a - (t - 0.001)).abs() < TIME_TOL_S);
            assert!((b - (t + 0.006 + 0.010)).abs() < TIME_TOL_S);
        }
    }

    #[test]
    fn fine_intervals_cover_a_zone_in_whole_coarse_intervals() {
        // One zone [0.01234, 0.02345] s, dt_c = 1 ms: intervals 12 to 23 overlap it, so
        // fine steps run from 12 ms to 24 ms, both on coarse (and so on output-sample)
        // boundaries; 12 intervals of 10 fine steps and 88 coarse ones in 100 ms.
        let s = Schedule {
            strike_times_s: Vec::new(),
            fine_zones_s: vec![(0.01234, 0.02345)],
        };
        let dt = 1e-3;
        let fine: Vec<usize> = (0..100)
            .filter(|&j| s.level(j as f64 * dt, (j + 1) as f64 * dt) == Level::Fine)
            .collect();
        assert_eq!(fine, (12..=23).collect::<Vec<_>>());
        assert_eq!(s.step_counts(100, dt, 10), [88, 120]);
        // A zone inside one interval still makes that interval fine.
        let inside = Schedule {
            strike_times_s: Vec::new(),
            fine_zones_s: vec![(0.0502, 0.0503)],
        };
        assert_eq!(inside.step_counts(100, dt, 10), [99, 10]);
        // Zones ending or starting on an interval boundary (exact binary times, dt = 0.5 s)
        // leave the interval beyond that boundary coarse: [3, 5] s is intervals 6 to 9.
        let touching = Schedule {
            strike_times_s: Vec::new(),
            fine_zones_s: vec![(3.0, 5.0)],
        };
        assert_eq!(touching.level(2.5, 3.0), Level::Coarse);
        assert_eq!(touching.level(3.0, 3.5), Level::Fine);
        assert_eq!(touching.level(5.0, 5.5), Level::Coarse);
        assert_eq!(touching.step_counts(20, 0.5, 10), [16, 40]);
    }

    #[test]
    fn dips_get_one_zone_per_wheel_and_none_without_depth() {
        // Wheels from 6 m and 3.5 m at 10 m/s over a dip [9.8, 10.2] m.
        let dip = |depth_mm| Effect::RailDip {
            position_m: 10.0,
            length_m: 0.4,
            depth_mm,
        };
        let zones = dip_zones(&[dip(0.5), dip(0.0)], [6.0, 3.5], 10.0, &integ());
        assert_eq!(zones.len(), 2);
        let expected = [(0.38 - 0.001, 0.42 + 0.010), (0.63 - 0.001, 0.67 + 0.010)];
        for ((a, b), (ea, eb)) in zones.iter().zip(expected) {
            assert!((a - ea).abs() < TIME_TOL_S && (b - eb).abs() < TIME_TOL_S);
        }
    }

    #[test]
    fn a_run_takes_the_scheduled_steps_and_covers_its_span() {
        let cal = Calibration::narrow_profile().check().unwrap();
        let sim = Simulator::new(&cal).unwrap();
        let flat = Flat::from_mm(60.0, 0.5, 0.1, 12.4).unwrap();
        let rate = cal.output.sample_rate_hz;
        let t_end = cal.end_sample() as f64 / rate;
        let schedule = sim.schedule(Some(&flat), t_end);
        let intervals = cal.end_sample() * cal.integration.coarse_steps_per_sample;
        let nf = cal.integration.fine_steps_per_coarse;
        let steps = schedule.step_counts(intervals, cal.dt_coarse_s(), nf);
        assert!(steps[1] > 0 && steps[1].is_multiple_of(nf));
        // The steps span the run exactly: coarse·dt_c + fine·dt_f = t_end.
        let covered = steps[0] as f64 * cal.dt_coarse_s() + steps[1] as f64 * cal.dt_fine_s();
        assert!((covered - t_end).abs() < 1e-9, "{covered} vs {t_end}");
        let resp = sim.run(Some(&flat), Record::default()).unwrap();
        assert_eq!(resp.steps, steps);
        assert_eq!(resp.strike_times_s, schedule.strike_times_s);
        assert_eq!(resp.len(), cal.end_sample() - resp.first_sample);
        // A good wheel on a plain track rolls on coarse steps only.
        let good = sim.schedule(None, t_end);
        assert_eq!(
            good.step_counts(intervals, cal.dt_coarse_s(), nf),
            [intervals, 0]
        );
    }
}
