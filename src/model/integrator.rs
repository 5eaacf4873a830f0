//! Time integration of the coupled train–track system.
//!
//! Newmark average acceleration (β = 1/4, γ = 1/2: unconditionally stable, no numerical
//! damping, energy-conserving for linear systems) on the track and the vehicle, with the
//! two nonlinear Hertz contacts solved implicitly at the end of every step.
//!
//! Per step, with `ũ = u + dt·v + dt²/4·a`, `ṽ = v + dt/2·a`:
//!
//! `(M + dt/2·C + dt²/4·K)·a_{n+1} = f_{n+1} − C·ṽ − K·ũ`
//!
//! The track and the vehicle are linear, so the contact compression at the end of the step
//! is the contact-free prediction minus the contact forces times precomputed compliances.
//! That leaves two scalar unknowns per step (the contact forces), solved by Newton in
//! [`super::contact::solve_contact_pair`]; the final accelerations then come from a second
//! substitution with the forces added. The effective matrices are factored once per
//! time-step size. The step itself is [`super::lanes`] (several instances at once; a run is a
//! batch of one, [`super::batch`]).
//!
//! Two step sizes are used: a coarse one where the wheels roll on round tread, a fine one
//! from shortly before each flat strike until well after the landing impact ([`super::schedule`]).
//! The effects of the calibration enter through their terms in [`super::effect`].
//!
//! A run fills caller-provided buffers and allocates nothing per step; parallelism over
//! batches lives one level up.

use super::banded::BandError;
use super::calibration::CheckedCalibration;
use super::contact::hertz_compression;
use super::effect;
use super::flat::Flat;
use super::lanes::{Coupling, LaneInputs, LaneState, LaneWork, StepLevel, Stepper};
pub(crate) use super::response::{Record, Response};
pub(crate) use super::schedule::Level;
use super::schedule::{dip_zones, strike_zones, Schedule};
use super::surface::{contact_semi_length_m, ContactFilter, SurfaceDrops, SurfaceError, Surfaces};
use super::track::{Support, TrackModel};
use super::vehicle::{mul4, wheel, VehicleModel};
use std::sync::Arc;
use thiserror::Error;

/// Errors of the simulator.
#[derive(Debug, Error)]
pub enum SimError {
    /// A system matrix failed to factor (a calibration with a singular or indefinite model).
    #[error("the track model cannot be factored: {0}")]
    Singular(#[from] BandError),
    /// The state became non-finite.
    #[error("integration diverged at t = {time_s} s")]
    StepDiverged {
        /// Time of the first non-finite state.
        time_s: f64,
    },
    /// A derived calibration could not be set up.
    #[error("cannot set up the simulation: {0}")]
    Setup(String),
    /// A wheel or rail surface does not fit the model.
    #[error(transparent)]
    Surface(#[from] SurfaceError),
    /// The flat is longer than the wheel circumference.
    #[error("flat length {length_mm} mm exceeds the wheel circumference {circumference_mm} mm")]
    FlatTooLong {
        /// Flat length (mm).
        length_mm: f64,
        /// Wheel circumference (mm).
        circumference_mm: f64,
    },
}

/// The longest travel of a coarse step over a surface (m): beyond it a run with surfaces takes
/// fine steps throughout (1 mm: the bank's 400 µs step travels 5.6 mm at 50 km/h, more than
/// the contact patch's semi-length; the converged reference's 20 µs travels 0.28 mm).
pub const SURFACE_STEP_TRAVEL_M: f64 = 1e-3;

/// A surface pit deeper than this (m, 50 µm, beyond roughness) is stepped finely around its
/// strikes, as a flat is.
pub const SURFACE_PIT_DEPTH_M: f64 = 5e-5;

/// Full dynamic state of track and vehicle at one instant.
#[derive(Debug, Clone, PartialEq)]
pub struct State {
    /// Time (s).
    pub time_s: f64,
    /// Track displacements, velocities, accelerations.
    pub u: Vec<f64>,
    /// Track velocities.
    pub v: Vec<f64>,
    /// Track accelerations.
    pub a: Vec<f64>,
    /// Vehicle displacements `[z_b, φ, z_w1, z_w2]`.
    pub q: [f64; 4],
    /// Vehicle velocities.
    pub qd: [f64; 4],
    /// Vehicle accelerations.
    pub qdd: [f64; 4],
    /// Contact forces `[leading, trailing]` (N, compression positive).
    pub contact_n: [f64; 2],
}

/// Scratch buffers for [`Simulator::step`] and [`Simulator::run_with`] (one lane); make one
/// per thread and reuse it.
pub type Workspace = LaneWork<1>;

/// A ready-to-run simulator for one calibration: matrices assembled and factored once,
/// shared (read-only) by every instance simulated with it.
#[derive(Debug, Clone)]
pub struct Simulator {
    pub(super) cal: CheckedCalibration,
    pub(super) track: TrackModel,
    pub(super) vehicle: VehicleModel,
    pub(super) coarse: StepLevel,
    pub(super) fine: StepLevel,
    /// `K` and `C` as sparse rows for the step's right-hand side.
    pub(super) coupling: Coupling,
    pub(super) sensor_dofs: Vec<(usize, usize)>,
    /// Gain of each sensor's reading (1 but for a `sensor_gain` effect).
    pub(super) sensor_gain: Vec<f64>,
    pub(super) c_h: f64,
    speed: f64,
    wheel_start: [f64; 2],
    pub(super) wheel_radius: f64,
    pub(super) first_sample: usize,
    pub(super) end_sample: usize,
    /// Output delay τ (s): the series read `F(t − τ)` (time-offset and speed-deviation
    /// effects; 0 otherwise).
    pub(super) output_delay_s: f64,
    /// The wheels' and the rail's surfaces as each wheel's drop, when the run has any
    /// ([`Simulator::with_surfaces`]).
    surface: Option<Arc<SurfaceDrops>>,
}

impl Simulator {
    /// Assembles and factors the model of a calibration.
    pub fn new(cal: &CheckedCalibration) -> Result<Simulator, SimError> {
        let bays = cal
            .integration
            .bay_elements(cal.track.bays, cal.track.sleeper_spacing_m);
        let track = TrackModel::with_bays(cal, &bays, Support::Elastic);
        // The stepper's sweeps are written for the band of rail nodes with their sleepers.
        if track.k.half_bandwidth() != 4 {
            return Err(SimError::Setup(format!(
                "track band of half-width {} (the stepper needs 4)",
                track.k.half_bandwidth()
            )));
        }
        let vehicle = VehicleModel::new(cal);
        let coarse = Self::level(&track, &vehicle, cal.dt_coarse_s())?;
        let fine = Self::level(&track, &vehicle, cal.dt_fine_s())?;
        let sensor_dofs = cal
            .sensors
            .pad
            .iter()
            .map(|s| {
                track
                    .pad_dofs(s.sleeper)
                    .expect("checked calibration puts sensors on sleepers")
            })
            .collect();
        let sensor_gain = cal
            .sensors
            .pad
            .iter()
            .map(|p| effect::sensor_gain(&cal.effects, &p.name))
            .collect();
        let lead = cal.run.leading_wheel_start_m;
        let first_sample = (0..cal.sensors.pad.len())
            .map(|i| cal.window_start_sample(i))
            .min()
            .unwrap_or(0);
        // Speed and output delay of the clock effects.
        let (speed, output_delay_s) = effect::clock(
            &cal.effects,
            cal.speed_m_per_s(),
            cal.sensors.laser_trigger_m - lead,
        );
        Ok(Simulator {
            c_h: cal.hertz_constant(),
            speed,
            output_delay_s,
            wheel_start: [lead, lead - 2.0 * cal.vehicle.half_wheelbase_m],
            wheel_radius: cal.vehicle.wheel_radius_m,
            first_sample,
            end_sample: cal.end_sample(),
            cal: cal.clone(),
            coupling: Coupling::new(&track),
            track,
            vehicle,
            coarse,
            fine,
            sensor_dofs,
            sensor_gain,
            surface: None,
        })
    }

    /// This simulator with wheel and rail surfaces (docs/model.md §5b), their drop tabulated
    /// once over each wheel's travel through the contact filter `filter`. Runs then take fine
    /// steps wherever a coarse step would travel more than [`SURFACE_STEP_TRAVEL_M`], and
    /// around every pit deeper than [`SURFACE_PIT_DEPTH_M`] as around a flat's strikes.
    pub fn with_surfaces(
        mut self,
        surfaces: &Surfaces,
        filter: ContactFilter,
    ) -> Result<Simulator, SimError> {
        if surfaces.is_empty() {
            self.surface = None;
            return Ok(self);
        }
        surfaces.check(self.wheel_radius)?;
        let t_end = (self.end_sample as f64 + 2.0) / self.cal.output.sample_rate_hz
            + self.output_delay_s.abs();
        let spans = std::array::from_fn(|w| {
            (
                self.wheel_start[w] - 0.05,
                self.wheel_start[w] + self.speed * t_end + 0.05,
            )
        });
        let a = contact_semi_length_m(self.wheel_radius, self.cal.static_wheel_load_n(), self.c_h);
        self.surface = Some(Arc::new(SurfaceDrops::new(
            surfaces,
            spans,
            self.wheel_radius,
            a,
            filter,
        )));
        Ok(self)
    }

    /// Whether this simulator carries surfaces.
    pub fn has_surfaces(&self) -> bool {
        self.surface.is_some()
    }

    fn level(track: &TrackModel, vehicle: &VehicleModel, dt: f64) -> Result<StepLevel, SimError> {
        let eff = track
            .m
            .add_scaled(0.5 * dt, &track.c)
            .add_scaled(0.25 * dt * dt, &track.k);
        let ldl = eff.factor()?;
        let n = track.dofs();
        let mut a_inv = vec![0.0; n * n];
        let mut col = vec![0.0; n];
        for j in 0..n {
            col.fill(0.0);
            col[j] = 1.0;
            ldl.solve_in_place(&mut col);
            for i in 0..n {
                a_inv[i * n + j] = col[i];
            }
        }
        Ok(StepLevel {
            dt,
            ldl,
            a_inv,
            veh_inv: vehicle.effective_inverse(dt),
        })
    }

    /// The calibration this simulator was built for.
    pub fn calibration(&self) -> &CheckedCalibration {
        &self.cal
    }

    /// The assembled track.
    pub fn track(&self) -> &TrackModel {
        &self.track
    }

    /// The vehicle model.
    pub fn vehicle(&self) -> &VehicleModel {
        &self.vehicle
    }

    /// A workspace sized for this model.
    pub fn workspace(&self) -> Workspace {
        self.lane_workspace()
    }

    /// A workspace for batches of `B` lanes ([`Simulator::run_batch`]).
    pub fn lane_workspace<const B: usize>(&self) -> LaneWork<B> {
        LaneWork::new(self.track.dofs())
    }

    /// Positions of the two wheels at time `t` (m).
    #[inline]
    pub fn wheel_positions(&self, t: f64) -> [f64; 2] {
        [
            self.wheel_start[0] + self.speed * t,
            self.wheel_start[1] + self.speed * t,
        ]
    }

    /// Advances the active lanes of `st` by one step of `level` ([`super::lanes`]).
    #[inline(always)]
    pub(super) fn step_lanes<const B: usize>(
        &self,
        level: Level,
        st: &mut LaneState<B>,
        ws: &mut LaneWork<B>,
        input: &LaneInputs<B>,
    ) {
        let v = &self.cal.vehicle;
        let stepper = Stepper {
            level: match level {
                Level::Coarse => &self.coarse,
                Level::Fine => &self.fine,
            },
            track: &self.track,
            vehicle: &self.vehicle,
            coupling: &self.coupling,
            c_h: self.c_h,
            effects: &self.cal.effects,
            weight_n: v.car_body_mass_kg * v.gravity_m_per_s2,
        };
        stepper.step(st, ws, input);
    }

    /// Index of the wheel carrying `flat`: its own, else the calibration's.
    fn flat_wheel(&self, flat: &Flat) -> usize {
        flat.wheel().unwrap_or(self.cal.vehicle.flat_wheel).index()
    }

    /// Wheel-centre drop `z_tr` under each wheel at positions `x`: the flat, plus the rail and
    /// wheel irregularities of the calibration's effects.
    #[inline]
    pub(super) fn trajectories(&self, flat: Option<&Flat>, x: [f64; 2]) -> [f64; 2] {
        let mut z = [0.0; 2];
        if let Some(f) = flat {
            let w = self.flat_wheel(f);
            z[w] = f.trajectory(x[w], self.wheel_radius);
        }
        for e in &self.cal.effects {
            for (w, zw) in z.iter_mut().enumerate() {
                *zw += e.wheel_drop_m(w, x[w], self.wheel_radius);
            }
        }
        if let Some(s) = &self.surface {
            for (w, zw) in z.iter_mut().enumerate() {
                *zw += s.drop_m(w, x[w]);
            }
        }
        z
    }

    /// Static equilibrium with the wheels at `x` and flat drops `z_tr` (no dynamics):
    /// each wheel carries the static load `W` (the bogie is symmetric), the rail solves
    /// `K·u = Σ N_iᵀ·W`, the Hertz springs are compressed by `(W/C_H)^(2/3)`.
    pub fn static_state(&self, x: [f64; 2], z_tr: [f64; 2]) -> Result<State, SimError> {
        let w = self.cal.static_wheel_load_n();
        let n = self.track.dofs();
        let mut u = vec![0.0; n];
        for &xi in &x {
            let (idx, sh) = self.track.locate(xi);
            for a in 0..4 {
                if idx[a] != usize::MAX {
                    u[idx[a]] += sh[a] * w;
                }
            }
        }
        let ldl = self.track.k.factor()?;
        ldl.solve_in_place(&mut u);
        // Voided sleepers: where a sleeper comes down through its gap, its ballast pushes back
        // K_b·(z − g). One unilateral spring is solved exactly through its own compliance;
        // several are swept until they agree.
        if !self.track.voided.is_empty() {
            let columns: Vec<Vec<f64>> = self
                .track
                .voided
                .iter()
                .map(|&(sd, ..)| {
                    let mut e = vec![0.0; n];
                    e[sd] = 1.0;
                    ldl.solve_in_place(&mut e);
                    e
                })
                .collect();
            let mut forces = vec![0.0; columns.len()];
            for _sweep in 0..50 {
                let mut changed = 0.0f64;
                for (j, &(sd, gap, kb, _)) in self.track.voided.iter().enumerate() {
                    let c = columns[j][sd];
                    // Displacement without this spring's current force.
                    let z0 = u[sd] + forces[j] * c;
                    let f = if z0 > gap {
                        kb * ((z0 + c * kb * gap) / (1.0 + c * kb) - gap)
                    } else {
                        0.0
                    };
                    for (ui, ci) in u.iter_mut().zip(&columns[j]) {
                        *ui -= (f - forces[j]) * ci;
                    }
                    changed = changed.max((f - forces[j]).abs());
                    forces[j] = f;
                }
                if changed <= 1e-9 * w {
                    break;
                }
            }
        }
        let delta = hertz_compression(self.c_h, w);
        let wheels: [f64; 2] = std::array::from_fn(|i| {
            let rail =
                self.track.deflection_at(&u, x[i]) + self.track.interior_compliance_at(x[i]) * w;
            rail + delta + z_tr[i]
        });
        Ok(State {
            time_s: 0.0,
            u,
            v: vec![0.0; n],
            a: vec![0.0; n],
            q: self.vehicle.static_state(wheels),
            qd: [0.0; 4],
            qdd: [0.0; 4],
            contact_n: [w, w],
        })
    }

    /// The state at t = 0: static equilibrium with the wheels at their start positions.
    pub fn initial_state(&self, flat: Option<&Flat>) -> Result<State, SimError> {
        let x = self.wheel_positions(0.0);
        self.static_state(x, self.trajectories(flat, x))
    }

    /// Advances `state` by one step of the given level, with the wheels at `x` and the flat
    /// drops `z_tr` at the end of the step: the one-lane case of the batched step
    /// ([`super::lanes`]), the same arithmetic as every run.
    pub fn step(
        &self,
        level: Level,
        state: &mut State,
        ws: &mut Workspace,
        x: [f64; 2],
        z_tr: [f64; 2],
    ) {
        let mut lane = LaneState::<1> {
            time_s: [state.time_s],
            u: state.u.iter().map(|&u| [u]).collect(),
            v: state.v.iter().map(|&v| [v]).collect(),
            a: state.a.iter().map(|&a| [a]).collect(),
            q: [state.q],
            qd: [state.qd],
            qdd: [state.qdd],
            contact_n: [state.contact_n],
        };
        let input = LaneInputs {
            active: [true],
            x: [x],
            z_tr: [z_tr],
        };
        self.step_lanes(level, &mut lane, ws, &input);
        for (i, ((u, v), a)) in lane.u.iter().zip(&lane.v).zip(&lane.a).enumerate() {
            (state.u[i], state.v[i], state.a[i]) = (u[0], v[0], a[0]);
        }
        (state.q, state.qd, state.qdd) = (lane.q[0], lane.qd[0], lane.qdd[0]);
        state.contact_n = lane.contact_n[0];
        state.time_s = lane.time_s[0];
    }

    /// Total mechanical energy (J) of a state with the wheels at `x`: kinetic + strain of the
    /// track and suspension + Hertz potential `2/5·C_H·δ^2.5` − work potential of the constant
    /// vehicle loads. Conserved by [`Simulator::step`] when all dampers are zero and the
    /// wheels do not move.
    pub fn energy(&self, s: &State, x: [f64; 2], z_tr: [f64; 2]) -> f64 {
        let n = self.track.dofs();
        let mut tmp = vec![0.0; n];
        self.track.m.mul_vec(&s.v, &mut tmp);
        let kinetic_track: f64 = 0.5 * s.v.iter().zip(&tmp).map(|(a, b)| a * b).sum::<f64>();
        self.track.k.mul_vec(&s.u, &mut tmp);
        let strain_track: f64 = 0.5 * s.u.iter().zip(&tmp).map(|(a, b)| a * b).sum::<f64>();
        let kinetic_veh: f64 = (0..4)
            .map(|i| 0.5 * self.vehicle.mass[i] * s.qd[i] * s.qd[i])
            .sum();
        let kq = mul4(&self.vehicle.k, &s.q);
        let strain_veh: f64 = 0.5 * (0..4).map(|i| s.q[i] * kq[i]).sum::<f64>();
        let load: f64 = (0..4).map(|i| self.vehicle.load[i] * s.q[i]).sum();
        let hertz: f64 = (0..2)
            .map(|i| {
                // Hertz spring plus the (massless) element interior in series with it.
                let d = s.q[wheel(i)] - self.track.deflection_at(&s.u, x[i]) - z_tr[i];
                let f = s.contact_n[i];
                let g = self.track.interior_compliance_at(x[i]);
                if f > 0.0 {
                    0.4 * self.c_h * hertz_compression(self.c_h, f).powf(2.5) + 0.5 * g * f * f
                } else {
                    debug_assert!(d <= 0.0 || g > 0.0);
                    0.0
                }
            })
            .sum();
        kinetic_track + strain_track + kinetic_veh + strain_veh + hertz - load
    }

    /// Compression of each Hertz spring in `state` with the wheels at `x` (m): wheel
    /// displacement minus the rail deflection under it (nodal interpolation plus the element
    /// interior's deflection under the contact force) minus the flat's drop.
    pub fn compression(&self, s: &State, x: [f64; 2], z_tr: [f64; 2]) -> [f64; 2] {
        std::array::from_fn(|i| {
            let interior = self.track.interior_compliance_at(x[i]) * s.contact_n[i];
            s.q[wheel(i)] - self.track.deflection_at(&s.u, x[i]) - interior - z_tr[i]
        })
    }

    /// The step schedule of a run of `flat` (or a good wheel) up to `t_end_s`: fine zones
    /// around every strike of the flat and every wheel's passage over a rail dip.
    pub fn schedule(&self, flat: Option<&Flat>, t_end_s: f64) -> Schedule {
        let mut schedule = match flat {
            Some(f) => strike_zones(
                f,
                self.wheel_start[self.flat_wheel(f)],
                self.speed,
                self.wheel_radius,
                t_end_s,
                &self.cal.integration,
            ),
            None => Schedule::default(),
        };
        for second in self
            .cal
            .effects
            .iter()
            .filter_map(effect::Effect::second_flat)
        {
            let zones = strike_zones(
                &second,
                self.wheel_start[self.flat_wheel(&second)],
                self.speed,
                self.wheel_radius,
                t_end_s,
                &self.cal.integration,
            );
            schedule.fine_zones_s.extend(zones.fine_zones_s);
        }
        schedule.fine_zones_s.extend(dip_zones(
            &self.cal.effects,
            self.wheel_start,
            self.speed,
            &self.cal.integration,
        ));
        if let Some(s) = &self.surface {
            let integ = &self.cal.integration;
            if self.speed * self.cal.dt_coarse_s() > SURFACE_STEP_TRAVEL_M {
                schedule.fine_zones_s.push((-1.0, t_end_s + 1.0));
            } else {
                for w in 0..2 {
                    for (a, b) in s.deep_spans(w, SURFACE_PIT_DEPTH_M) {
                        schedule.fine_zones_s.push((
                            (a - self.wheel_start[w]) / self.speed - integ.fine_before_strike_s,
                            (b - self.wheel_start[w]) / self.speed + integ.fine_after_strike_s,
                        ));
                    }
                }
            }
        }
        schedule
    }

    /// Simulates one instance (a flat, or a good wheel with `None`) from static equilibrium at
    /// t = 0 to the end of the last sensor window.
    pub fn run(&self, flat: Option<&Flat>, record: Record) -> Result<Response, SimError> {
        let mut ws = self.workspace();
        self.run_with(flat, record, &mut ws)
    }

    /// [`Simulator::run`] with a caller-provided workspace: a batch of one
    /// ([`Simulator::run_batch`]).
    pub fn run_with(
        &self,
        flat: Option<&Flat>,
        record: Record,
        ws: &mut Workspace,
    ) -> Result<Response, SimError> {
        let (mut results, _) = self.run_batch::<1>(&[flat], record, ws);
        results.pop().expect("one result per flat")
    }
}
