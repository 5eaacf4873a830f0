//! Reference problems with known answers for the train–track model: closed forms
//! (beam on elastic foundation, pinned–pinned frequency, Hertz, static equilibrium),
//! conservation (energy without damping) and refined runs (dt and mesh convergence).
//! Every tolerance is stated next to its assertion.

use wheelflat::model::{Calibration, CheckedCalibration, Flat, Level, Record, Response, Simulator};
use wheelflat::model::{RailSection, Support, TrackModel};

fn default_cal() -> CheckedCalibration {
    Calibration::default().check().unwrap()
}

fn peak(v: &[f64]) -> f64 {
    v.iter().copied().fold(f64::MIN, f64::max)
}

fn pad_sum(sim: &Simulator, u: &[f64]) -> f64 {
    let cal = sim.calibration();
    let zeros = vec![0.0; u.len()];
    (1..cal.track.bays)
        .map(|k| {
            sim.track()
                .pad_force(sim.track().pad_dofs(k).unwrap(), u, &zeros)
        })
        .sum()
}

#[test]
fn static_equilibrium_pads_and_end_reactions_carry_the_vehicle_weight() {
    let cal = default_cal();
    let sim = Simulator::new(&cal).unwrap();
    let weight = 2.0 * cal.static_wheel_load_n();
    // At t = 0 (trailing wheel 3.5 m from the clamped end) the ends carry a little load.
    let s0 = sim.initial_state(None).unwrap();
    let ends = sim.track().end_reactions(&s0.u);
    let total = pad_sum(&sim, &s0.u) + ends[0] + ends[1];
    println!("static: pads + ends = {total:.6} N, weight {weight:.6} N, ends {ends:?}");
    // Tolerance 0.1 % (issue #2); the linear solve makes it exact to round-off.
    assert!(
        (total / weight - 1.0).abs() < 1e-3,
        "pads + ends = {total} N vs {weight} N"
    );
    assert!(
        (total / weight - 1.0).abs() < 1e-9,
        "round-off level expected: {total} vs {weight}"
    );
    // With the bogie mid-rail the pads alone carry the weight to within 0.1 %.
    let mid = sim.static_state([13.0, 10.5], [0.0, 0.0]).unwrap();
    let pads = pad_sum(&sim, &mid.u);
    println!(
        "static, bogie mid-rail: pads = {pads:.3} N ({:+.2e} relative)",
        pads / weight - 1.0
    );
    assert!(
        (pads / weight - 1.0).abs() < 1e-3,
        "pads = {pads} N vs {weight} N"
    );
}

/// Closed form: deflection under a point load `F` on an infinite Timoshenko beam on a Winkler
/// foundation of modulus `k` (N/m²). Away from the load `EI·w'''' − (EI·k/κGA)·w'' + k·w = 0`,
/// so `w = Re(C·e^{rx})` for x > 0 with `EI·r⁴ − (EI·k/κGA)·r² + k = 0`, Re r < 0.
/// With `Q = k·Re(C·e^{rx}/r)` (from `Q' = k·w`, `Q(∞) = 0`) and `ψ = w' − Q/κGA`, the
/// conditions at the load are symmetry `ψ(0) = 0` and `Q(0⁺) = −F/2`; `w(0) = Re C`.
/// Reduces to `F·β/(2k)`, `β = (k/4EI)^¼`, when κGA → ∞.
fn timoshenko_winkler_deflection(f: f64, k: f64, ei: f64, kga: f64) -> f64 {
    use nalgebra::{Complex, Matrix2, Vector2};
    let b = k / kga;
    let disc = Complex::new(b * b - 4.0 * k / ei, 0.0).sqrt();
    let r2 = (Complex::new(b, 0.0) - disc) / 2.0;
    let mut r = r2.sqrt();
    if r.re > 0.0 {
        r = -r;
    }
    // ψ(0) = Re(C·(r − k/(κGA·r))) = 0 ; Re(k·C/r) = −F/2, with C = c1 + i·c2.
    let p = r - Complex::new(k / kga, 0.0) / r;
    let q = Complex::new(k, 0.0) / r;
    let m = Matrix2::new(p.re, -p.im, q.re, -q.im);
    let c = m.try_inverse().unwrap() * Vector2::new(0.0, -f / 2.0);
    c[0]
}

#[test]
fn static_deflection_matches_beam_on_elastic_foundation_with_dense_supports() {
    // Dense supports: 0.1 m spacing, pad and ballast scaled so that the foundation modulus
    // k = K_series / a equals the default track's (42.86 MN/m per 0.7 m = 61.2 MN/m²).
    let mut c = Calibration::default();
    let a = 0.1;
    c.track.sleeper_spacing_m = a;
    c.track.bays = 240;
    c.track.pad_stiffness_n_per_m *= a / 0.7;
    c.track.ballast_stiffness_n_per_m *= a / 0.7;
    for (i, s) in c.sensors.pad.iter_mut().enumerate() {
        s.sleeper = 100 + i;
    }
    c.output.window_samples = 200;
    let cal = c.check().unwrap();
    let t = &cal.track;
    let k_series = t.pad_stiffness_n_per_m * t.ballast_stiffness_n_per_m
        / (t.pad_stiffness_n_per_m + t.ballast_stiffness_n_per_m);
    let k = k_series / a;
    let section = RailSection::from_calibration(&cal);
    let f = cal.static_wheel_load_n();
    for (label, x) in [("on a support", 12.0), ("mid-span", 12.05)] {
        let track = TrackModel::new(&cal, 2, Support::Elastic);
        let mut u = vec![0.0; track.dofs()];
        let (idx, n) = track.locate(x);
        for j in 0..4 {
            if idx[j] != usize::MAX {
                u[idx[j]] += n[j] * f;
            }
        }
        track.k.factor().unwrap().solve_in_place(&mut u);
        let w = track.deflection_at(&u, x) + track.interior_compliance_at(x) * f;
        let exact = timoshenko_winkler_deflection(f, k, section.ei, section.kga);
        let eb = f * (k / (4.0 * section.ei)).powf(0.25) / (2.0 * k);
        println!(
            "BOEF {label}: FE {w:.6e} m, Timoshenko-Winkler {exact:.6e} m ({:+.3}%), EB {eb:.6e} m",
            (w / exact - 1.0) * 100.0
        );
        // Tolerance 2 % (issue #2); measured 0.04 %.
        assert!(
            (w / exact - 1.0).abs() < 0.02,
            "{label}: FE {w:e} m vs Timoshenko–Winkler {exact:e} m"
        );
        // Shear deformation matters here: the Euler–Bernoulli value is several % lower.
        assert!(
            exact > eb * 1.01,
            "shear should add deflection: {exact:e} vs EB {eb:e}"
        );
    }
    // Euler–Bernoulli limit (very stiff in shear) against w0 = F·β/(2k).
    let mut c2 = cal.document().clone();
    c2.track.shear_modulus_pa *= 1e6;
    let cal2 = c2.check().unwrap();
    let s2 = RailSection::from_calibration(&cal2);
    let track = TrackModel::new(&cal2, 2, Support::Elastic);
    let mut u = vec![0.0; track.dofs()];
    let (idx, n) = track.locate(12.0);
    for j in 0..4 {
        if idx[j] != usize::MAX {
            u[idx[j]] += n[j] * f;
        }
    }
    track.k.factor().unwrap().solve_in_place(&mut u);
    let eb = f * (k / (4.0 * s2.ei)).powf(0.25) / (2.0 * k);
    let w = track.deflection_at(&u, 12.0);
    println!(
        "BOEF EB limit: FE {w:.6e} m, closed form {eb:.6e} m ({:+.3}%)",
        (w / eb - 1.0) * 100.0
    );
    assert!(
        (w / eb - 1.0).abs() < 0.02,
        "EB limit: FE {w:e} vs closed form {eb:e}"
    );
}

/// Lowest root ω of the Timoshenko–Rayleigh frequency equation for a simply supported span
/// with wavenumber `k = π/a`:
/// `(ρI·ρA/κGA)·ω⁴ − (ρA + ρI·k² + EI·ρA·k²/κGA)·ω² + EI·k⁴ = 0`.
fn timoshenko_pinned_pinned_hz(s: &RailSection, span: f64) -> f64 {
    let k = std::f64::consts::PI / span;
    let a = s.rho_i * s.rho_a / s.kga;
    let b = s.rho_a + s.rho_i * k * k + s.ei * s.rho_a * k * k / s.kga;
    let c = s.ei * k.powi(4);
    let w2 = (b - (b * b - 4.0 * a * c).sqrt()) / (2.0 * a);
    w2.sqrt() / std::f64::consts::TAU
}

fn lowest_frequency_hz(track: &TrackModel) -> f64 {
    let k = track.k.to_dense();
    let m = track.m.to_dense();
    let l = m.cholesky().unwrap();
    let linv = l.l().try_inverse().unwrap();
    let sym = &linv * k * linv.transpose();
    let sym = (&sym + sym.transpose()) * 0.5;
    let eig = nalgebra::SymmetricEigen::new(sym);
    let min = eig.eigenvalues.iter().copied().fold(f64::MAX, f64::min);
    min.sqrt() / std::f64::consts::TAU
}

#[test]
fn pinned_pinned_frequency_on_rigid_supports_matches_timoshenko() {
    let cal = default_cal();
    let s = RailSection::from_calibration(&cal);
    let exact = timoshenko_pinned_pinned_hz(&s, cal.track.sleeper_spacing_m);
    let euler_bernoulli = (std::f64::consts::PI / cal.track.sleeper_spacing_m).powi(2)
        * (s.ei / s.rho_a).sqrt()
        / std::f64::consts::TAU;
    for e in [4, 8] {
        let f = lowest_frequency_hz(&TrackModel::new(&cal, e, Support::Rigid));
        println!("pinned-pinned, {e} el/bay: FE {f:.2} Hz, Timoshenko {exact:.2} Hz ({:+.3}%), EB {euler_bernoulli:.2} Hz", (f / exact - 1.0) * 100.0);
        // Tolerance 2 % (issue #2); measured +0.75 % with 4 and +0.19 % with 8 elements per bay.
        assert!(
            (f / exact - 1.0).abs() < 0.02,
            "{e} elements/bay: {f:.1} Hz vs {exact:.1} Hz"
        );
    }
    // The check is sharp: shear and rotary inertia lower the frequency by > 5 % here.
    assert!(
        exact < 0.95 * euler_bernoulli,
        "{exact} vs EB {euler_bernoulli}"
    );
}

#[test]
fn hertz_compression_at_rest_matches_closed_form_and_stays_static() {
    let cal = default_cal();
    let sim = Simulator::new(&cal).unwrap();
    let x = [12.2, 9.7];
    let mut state = sim.static_state(x, [0.0, 0.0]).unwrap();
    let mut ws = sim.workspace();
    for _ in 0..500 {
        sim.step(Level::Fine, &mut state, &mut ws, x, [0.0, 0.0]);
    }
    let w = cal.static_wheel_load_n();
    let expected = (w / cal.hertz_constant()).powf(2.0 / 3.0);
    let delta = sim.compression(&state, x, [0.0, 0.0]);
    for (i, (f, d)) in state.contact_n.iter().zip(delta).enumerate() {
        // Tolerance 1e-6 relative: a state in equilibrium must stay there.
        assert!((f / w - 1.0).abs() < 1e-6, "wheel {i}: F = {f} N");
        assert!(
            (d / expected - 1.0).abs() < 1e-6,
            "wheel {i}: δ = {d} vs {expected}"
        );
    }
}

#[test]
fn energy_is_conserved_without_damping() {
    let mut c = Calibration::default();
    c.track.pad_damping_ns_per_m = 0.0;
    c.track.ballast_damping_ns_per_m = 0.0;
    c.vehicle.primary_damping_ns_per_m = 0.0;
    let cal = c.check().unwrap();
    let sim = Simulator::new(&cal).unwrap();
    let x = [12.2, 9.7];
    let z = [0.0, 0.0];
    let mut state = sim.static_state(x, z).unwrap();
    // Kick: the trailing wheel moves down at 0.2 m/s (a hard but contact-keeping knock).
    state.qd[3] = 0.2;
    let e0 = sim.energy(&state, x, z);
    let kick = 0.5 * cal.vehicle.wheel_mass_kg * 0.2 * 0.2;
    let mut ws = sim.workspace();
    let mut worst: f64 = 0.0;
    for _ in 0..4000 {
        sim.step(Level::Fine, &mut state, &mut ws, x, z);
        worst = worst.max((sim.energy(&state, x, z) - e0).abs());
    }
    println!(
        "energy: worst drift {worst:.3e} J of kick {kick} J ({:.2e} relative)",
        worst / kick
    );
    // Newmark average acceleration conserves the energy of the linear parts exactly; the Hertz
    // spring is nonlinear, so a small error remains. Tolerance: 0.1 % of the kick energy (13 J)
    // over 0.16 s.
    assert!(worst < 1e-3 * kick, "energy drift {worst:e} J of {kick} J");
}

fn run(cal: &CheckedCalibration, flat: Option<&Flat>) -> Response {
    Simulator::new(cal)
        .unwrap()
        .run(flat, Record::default())
        .unwrap()
}

fn refined(cal: &CheckedCalibration) -> CheckedCalibration {
    let mut c = cal.document().clone();
    c.integration.elements_per_bay *= 2;
    c.integration.coarse_steps_per_sample *= 2;
    c.check().unwrap()
}

#[test]
fn halving_dt_and_doubling_the_mesh_changes_the_rps2_peak_by_less_than_one_percent() {
    let cal = default_cal();
    let fine = refined(&cal);
    let rps2 = cal.sensor_index("rps2").unwrap();
    for (l, d, c, xp) in [
        (60.0, 0.5, 0.1, 12.4),
        (60.0, 0.5, 0.1, 12.55),
        (200.0, 0.2, 0.05, 12.7),
    ] {
        let flat = Flat::from_mm(l, d, c, xp).unwrap();
        let a = peak(&run(&cal, Some(&flat)).pad_force_n[rps2]);
        let b = peak(&run(&fine, Some(&flat)).pad_force_n[rps2]);
        println!(
            "convergence L {l} d {d} xp {xp}: RPS2 peak {a:.1} N, refined {b:.1} N ({:+.3}%)",
            (a / b - 1.0) * 100.0
        );
        // Tolerance 1 % (issue #2); measured < 0.1 %.
        assert!(
            (a / b - 1.0).abs() < 0.01,
            "L {l} d {d}: {a} vs refined {b}"
        );
    }
    let a = peak(&run(&cal, None).pad_force_n[rps2]);
    let b = peak(&run(&fine, None).pad_force_n[rps2]);
    assert!((a / b - 1.0).abs() < 0.01, "good wheel: {a} vs refined {b}");
}

/// Wheel passages seen by one sensor: the highest sample of each run of samples above
/// `floor`. (A wheel crossing a point support makes a small cusp in the force, so plain local
/// maxima are not one per wheel.)
fn peaks_above(v: &[f64], floor: f64) -> Vec<usize> {
    let mut peaks = Vec::new();
    let mut j = 0;
    while j < v.len() {
        if v[j] <= floor {
            j += 1;
            continue;
        }
        let start = j;
        while j < v.len() && v[j] > floor {
            j += 1;
        }
        let best = (start..j).fold(start, |b, k| if v[k] > v[b] { k } else { b });
        peaks.push(best);
    }
    peaks
}

#[test]
fn good_wheel_gives_two_peaks_per_sensor_at_each_wheels_static_share() {
    let cal = default_cal();
    let sim = Simulator::new(&cal).unwrap();
    let resp = sim.run(None, Record::default()).unwrap();
    let dt_wheels = 2.0 * cal.vehicle.half_wheelbase_m / cal.speed_m_per_s();
    for (i, series) in resp.pad_force_n.iter().enumerate() {
        let p = peaks_above(series, 0.5 * peak(series));
        assert_eq!(
            p.len(),
            2,
            "sensor {}: peaks at {:?}",
            cal.sensors.pad[i].name,
            p
        );
        let gap = (p[1] - p[0]) as f64 / cal.output.sample_rate_hz;
        // Peaks one wheelbase apart in time, to within two samples.
        assert!(
            (gap - dt_wheels).abs() < 2.0 / cal.output.sample_rate_hz,
            "gap {gap} s vs {dt_wheels} s"
        );
        // Each peak is that wheel's quasi-static share on this pad: the static pad force with
        // the wheel right above the sensor (5 % tolerance for dynamics at 50 km/h; measured < 0.3 %).
        let xs = cal.sensor_position_m(i);
        let (w, s) = sim.track().pad_dofs(cal.sensors.pad[i].sleeper).unwrap();
        for (j, x) in [(p[0], [xs, xs - 2.5]), (p[1], [xs + 2.5, xs])] {
            let st = sim.static_state(x, [0.0, 0.0]).unwrap();
            let share = sim.track().pad_force((w, s), &st.u, &st.v);
            println!(
                "good wheel {} peak {:.1} N vs static share {share:.1} N ({:+.2}%)",
                cal.sensors.pad[i].name,
                series[j],
                (series[j] / share - 1.0) * 100.0
            );
            assert!(
                (series[j] / share - 1.0).abs() < 0.05,
                "peak {} vs static share {share}",
                series[j]
            );
        }
    }
}

#[test]
fn peak_force_grows_with_depth_at_fixed_length() {
    let cal = default_cal();
    let sim = Simulator::new(&cal).unwrap();
    let mut last = 0.0;
    for d in [0.1, 0.3, 0.5, 0.7, 0.9] {
        let flat = Flat::from_mm(100.0, d, 0.0, 12.4).unwrap();
        let r = sim.run(Some(&flat), Record::default()).unwrap();
        let p = r
            .pad_force_n
            .iter()
            .map(|s| peak(s))
            .fold(f64::MIN, f64::max);
        assert!(p > last, "d = {d} mm: peak {p} N not above {last} N");
        last = p;
    }
}

#[test]
fn loss_of_contact_is_reported_for_a_large_flat_only() {
    let cal = default_cal();
    let sim = Simulator::new(&cal).unwrap();
    let big = sim
        .run(
            Some(&Flat::from_mm(20.0, 1.0, 0.0, 12.4).unwrap()),
            Record::default(),
        )
        .unwrap();
    assert!(
        big.contact_loss_s[1] > 1e-3,
        "trailing wheel off the rail for {} s",
        big.contact_loss_s[1]
    );
    assert!(big.peak_contact_force_n[1] > 3.0 * cal.static_wheel_load_n());
    let good = sim.run(None, Record::default()).unwrap();
    assert_eq!(good.contact_loss_s, [0.0, 0.0]);
    let small = sim
        .run(
            Some(&Flat::from_mm(60.0, 0.1, 0.0, 12.4).unwrap()),
            Record::default(),
        )
        .unwrap();
    assert_eq!(small.contact_loss_s, [0.0, 0.0]);
}
