//! Runs of several instances in lockstep batches ([`super::lanes`]).
//!
//! Each lane follows its own step schedule (coarse steps on round tread, fine ones around its
//! own strikes, [`super::schedule`]), so a lane takes exactly the steps it would take alone:
//! a batch never changes an instance's result. Every round of the batch takes one step size;
//! the lanes whose next step has that size take it, the others wait. The batch keeps a step
//! size while any unfinished lane still needs it: the coarse rounds go on until every lane
//! has reached its next fine zone, the fine rounds until every lane has left it. Lanes whose
//! strikes come at about the same time (sorted by [`batch_key`]) and whose flats are about as
//! long (consecutive instances of a shard) then take nearly every round: lane efficiency,
//! the share of lane-rounds that take a step, 0.99 on a shard of the default population
//! (docs/performance.md, with the rules and groupings that lost).
//!
//! The wide kernel is compiled twice: for AVX2+FMA (chosen at run time where the CPU has
//! them) and for the baseline target. Both give the same bits: every product that is summed
//! is a correctly rounded fused multiply–add, in hardware or in software.

use super::flat::Flat;
use super::integrator::{SimError, Simulator};
use super::lanes::{LaneInputs, LaneState, LaneWork};
use super::response::{Record, Response};
use super::schedule::{Level, Schedule};

/// Lanes of a bank-generation batch: two AVX2 vectors per DOF, so the substitution carries
/// two independent dependency chains (measured against 4 and 16 in docs/performance.md).
pub const LANES: usize = 8;

/// Counts of one batch run: steps each lane took and rounds the batch took.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct BatchStats {
    /// Steps taken by all lanes together.
    pub lane_steps: usize,
    /// Rounds of the batch (each one step of every lane, taken or waited).
    pub rounds: usize,
}

/// Per-lane progress through its schedule.
struct Lane<'a> {
    flat: Option<&'a Flat>,
    schedule: Schedule,
    /// Current coarse interval and fine step within it.
    j: usize,
    m: usize,
    level: Level,
    resp: Response,
    result: Option<Result<(), SimError>>,
}

/// The sort key that lines batch-mates' fine zones up: the flat's first strike time (s), or
/// +∞ for a good wheel.
pub fn batch_key(sim: &Simulator, flat: Option<&Flat>) -> f64 {
    let t_end = sim.end_sample as f64 / sim.cal.output.sample_rate_hz;
    sim.schedule(flat, t_end)
        .strike_times_s
        .first()
        .copied()
        .unwrap_or(f64::INFINITY)
}

impl Simulator {
    /// Simulates up to `B` instances together; one result per flat, in order (each the same,
    /// bit for bit, as [`Simulator::run`] of that flat alone).
    pub fn run_batch<const B: usize>(
        &self,
        flats: &[Option<&Flat>],
        record: Record,
        ws: &mut LaneWork<B>,
    ) -> (Vec<Result<Response, SimError>>, BatchStats) {
        assert!(
            !flats.is_empty() && flats.len() <= B,
            "a batch of {} instances for {B} lanes",
            flats.len()
        );
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
        {
            // SAFETY: the CPU has the features the function is compiled for (checked above).
            return unsafe { self.run_batch_avx2(flats, record, ws) };
        }
        self.run_batch_impl(flats, record, ws)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn run_batch_avx2<const B: usize>(
        &self,
        flats: &[Option<&Flat>],
        record: Record,
        ws: &mut LaneWork<B>,
    ) -> (Vec<Result<Response, SimError>>, BatchStats) {
        self.run_batch_impl(flats, record, ws)
    }

    #[inline(always)]
    fn run_batch_impl<const B: usize>(
        &self,
        flats: &[Option<&Flat>],
        record: Record,
        ws: &mut LaneWork<B>,
    ) -> (Vec<Result<Response, SimError>>, BatchStats) {
        let nc = self.cal.integration.coarse_steps_per_sample;
        let nf = self.cal.integration.fine_steps_per_coarse;
        let (dt_c, dt_f) = (self.coarse.dt, self.fine.dt);
        let rate = self.cal.output.sample_rate_hz;
        // With an output delay, record a margin on both sides and resample at the end.
        let margin = if self.output_delay_s.abs() > 0.0 {
            (self.output_delay_s.abs() * rate).ceil() as usize + 1
        } else {
            0
        };
        let (rec_first, rec_end) = (
            self.first_sample.saturating_sub(margin),
            self.end_sample + margin,
        );
        let samples = rec_end - rec_first;
        let t_end = rec_end as f64 / rate;
        let total_coarse = rec_end * nc;
        let n = self.track.dofs();

        let mut st = LaneState::<B>::zeros(n);
        let mut lanes: Vec<Lane> = Vec::with_capacity(flats.len());
        for (l, &flat) in flats.iter().enumerate() {
            let schedule = self.schedule(flat, t_end);
            let resp = Response {
                sample_rate_hz: rate,
                first_sample: rec_first,
                pad_force_n: vec![Vec::with_capacity(samples); self.sensor_dofs.len()],
                contact_force_n: record
                    .contact
                    .then(|| [Vec::with_capacity(samples), Vec::with_capacity(samples)]),
                peak_contact_force_n: [0.0; 2],
                contact_loss_s: [0.0; 2],
                strike_times_s: schedule.strike_times_s.clone(),
                steps: [0, 0],
            };
            let mut lane = Lane {
                flat,
                level: schedule.level(0.0, dt_c),
                schedule,
                j: 0,
                m: 0,
                resp,
                result: None,
            };
            match self
                .check_flat(flat)
                .and_then(|()| self.initial_state(flat))
            {
                Ok(s) => {
                    for (i, row) in st.u.iter_mut().enumerate() {
                        row[l] = s.u[i];
                    }
                    (st.q[l], st.qd[l], st.qdd[l]) = (s.q, s.qd, s.qdd);
                    st.contact_n[l] = s.contact_n;
                    st.time_s[l] = s.time_s;
                    self.observe(&st, l, 0, rec_first..rec_end, &mut lane.resp);
                    if total_coarse == 0 {
                        lane.result = Some(Ok(()));
                    }
                }
                Err(e) => lane.result = Some(Err(e)),
            }
            lanes.push(lane);
        }

        let mut stats = BatchStats::default();
        let mut level = Level::Coarse;
        let mut input = LaneInputs {
            active: [false; B],
            x: [[0.0; 2]; B],
            z_tr: [[0.0; 2]; B],
        };
        loop {
            // The round keeps the current step size while any unfinished lane needs it.
            let (mut fine, mut coarse) = (false, false);
            for lane in lanes.iter().filter(|l| l.result.is_none()) {
                match lane.level {
                    Level::Fine => fine = true,
                    Level::Coarse => coarse = true,
                }
            }
            level = match (level, fine, coarse) {
                (_, false, false) => break,
                (Level::Fine, true, _) | (_, true, false) => Level::Fine,
                _ => Level::Coarse,
            };
            // Lanes past `lanes.len()` (a short batch) are never set active.
            let mut t_end = [0.0; B];
            for (l, lane) in lanes.iter().enumerate() {
                input.active[l] = lane.result.is_none() && lane.level == level;
                if input.active[l] {
                    t_end[l] = self.lane_step_end(lane, level, nf, dt_c, dt_f);
                    let x = self.wheel_positions(t_end[l]);
                    input.x[l] = x;
                    input.z_tr[l] = self.trajectories(lane.flat, x);
                }
            }
            self.step_lanes(level, &mut st, ws, &input);
            stats.rounds += 1;

            for (l, lane) in lanes.iter_mut().enumerate() {
                if !input.active[l] {
                    continue;
                }
                stats.lane_steps += 1;
                st.time_s[l] = t_end[l];
                let dt = match level {
                    Level::Fine => dt_f,
                    Level::Coarse => dt_c,
                };
                for w in 0..2 {
                    let f = st.contact_n[l][w];
                    lane.resp.peak_contact_force_n[w] = lane.resp.peak_contact_force_n[w].max(f);
                    if f == 0.0 {
                        lane.resp.contact_loss_s[w] += dt;
                    }
                }
                let interval_done = match level {
                    Level::Fine => {
                        lane.m += 1;
                        lane.m == nf
                    }
                    Level::Coarse => true,
                };
                if !interval_done {
                    continue;
                }
                match level {
                    Level::Fine => {
                        lane.m = 0;
                        lane.resp.steps[1] += nf;
                    }
                    Level::Coarse => lane.resp.steps[0] += 1,
                }
                lane.j += 1;
                let j = lane.j;
                if j % nc == 0 {
                    if !st.lane_finite(l) {
                        lane.result = Some(Err(SimError::StepDiverged {
                            time_s: j as f64 * dt_c,
                        }));
                        continue;
                    }
                    self.observe(&st, l, j / nc, rec_first..rec_end, &mut lane.resp);
                }
                if j == total_coarse {
                    lane.result = Some(Ok(()));
                } else {
                    lane.level = lane.schedule.level(j as f64 * dt_c, (j + 1) as f64 * dt_c);
                }
            }
        }

        let results = lanes
            .into_iter()
            .map(|lane| {
                let mut resp = lane.resp;
                lane.result.expect("every lane finishes")?;
                if margin > 0 {
                    resp.delay_onto(self.first_sample..self.end_sample, self.output_delay_s);
                }
                Ok(resp)
            })
            .collect();
        (results, stats)
    }

    /// Time at the end of the lane's next step of `level` (s), computed from the step count
    /// as the single-instance stepper always has.
    #[inline(always)]
    fn lane_step_end(&self, lane: &Lane, level: Level, nf: usize, dt_c: f64, dt_f: f64) -> f64 {
        match level {
            Level::Fine => ((lane.j * nf + lane.m + 1) as f64) * dt_f,
            Level::Coarse => (lane.j + 1) as f64 * dt_c,
        }
    }

    /// Records output sample `k` of lane `l` when it lies in `span`.
    fn observe<const B: usize>(
        &self,
        st: &LaneState<B>,
        l: usize,
        k: usize,
        span: std::ops::Range<usize>,
        resp: &mut Response,
    ) {
        if !span.contains(&k) {
            return;
        }
        for ((out, &(w, s)), gain) in resp
            .pad_force_n
            .iter_mut()
            .zip(&self.sensor_dofs)
            .zip(&self.sensor_gain)
        {
            let f = self
                .track
                .pad_force_from(w, st.u[w][l] - st.u[s][l], st.v[w][l] - st.v[s][l]);
            out.push(gain * f);
        }
        if let Some(c) = resp.contact_force_n.as_mut() {
            c[0].push(st.contact_n[l][0]);
            c[1].push(st.contact_n[l][1]);
        }
    }

    /// Refuses a flat that does not fit on the wheel.
    fn check_flat(&self, flat: Option<&Flat>) -> Result<(), SimError> {
        if let Some(f) = flat {
            let circumference = std::f64::consts::TAU * self.wheel_radius;
            if f.length_m() >= circumference {
                return Err(SimError::FlatTooLong {
                    length_mm: f.length_m() * 1e3,
                    circumference_mm: circumference * 1e3,
                });
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Calibration;

    /// The baseline build (software fused multiply–adds, for CPUs without AVX2+FMA) gives the
    /// bits of the dispatched build: banks do not depend on the CPU. Slow (software FMA), so
    /// two short-window flats, one of them losing contact.
    #[test]
    fn the_baseline_build_gives_the_dispatched_bits() {
        let cal = Calibration::narrow_profile().check().unwrap();
        let sim = Simulator::new(&cal).unwrap();
        let flats = [
            Flat::from_mm(60.0, 0.5, 0.1, 12.4).unwrap(),
            Flat::from_mm(20.0, 1.0, 0.0, 12.2).unwrap(),
        ];
        let members: Vec<Option<&Flat>> = flats.iter().map(Some).collect();
        let record = Record { contact: true };
        let (dispatched, _) = sim.run_batch::<2>(&members, record, &mut sim.lane_workspace());
        let (baseline, _) = sim.run_batch_impl::<2>(&members, record, &mut sim.lane_workspace());
        for (d, b) in dispatched.iter().zip(&baseline) {
            let (d, b) = (d.as_ref().unwrap(), b.as_ref().unwrap());
            for (x, y) in d.pad_force_n.iter().zip(&b.pad_force_n) {
                assert!(x.iter().zip(y).all(|(p, q)| p.to_bits() == q.to_bits()));
            }
            let loss = |r: &Response| r.contact_loss_s.map(f64::to_bits);
            assert_eq!(loss(d), loss(b));
        }
    }
}
