//! The effect library (issue #5), verified like the base model: neutral settings change
//! nothing, static equilibrium still holds with a changed pad or ballast, a sensor gain
//! scales exactly its sensor, and the irregularities act where, when and as much as their
//! equations say. Tolerances are stated next to each assertion.

use crate::common::wheelflat_path;
use wheelflat::model::WheelPosition;
use wheelflat::model::{
    Calibration, CheckedCalibration, Effect, Flat, Record, Response, Simulator,
};

fn with(effects: Vec<Effect>) -> CheckedCalibration {
    Calibration {
        effects,
        ..Default::default()
    }
    .check()
    .unwrap()
}

fn run(effects: Vec<Effect>, flat: Option<&Flat>) -> Response {
    Simulator::new(&with(effects))
        .unwrap()
        .run(flat, Record { contact: true })
        .unwrap()
}

fn contact(r: &Response, w: usize) -> &[f64] {
    &r.contact_force_n.as_ref().unwrap()[w]
}

fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

#[test]
fn neutral_effects_change_nothing_bit_for_bit() {
    let base = run(vec![], None);
    for e in [
        Effect::PadStiffness {
            sleeper: 17,
            factor: 1.0,
        },
        Effect::BallastStiffness {
            sleeper: 17,
            factor: 1.0,
        },
        Effect::SensorGain {
            sensor: "rps3".into(),
            factor: 1.0,
        },
        Effect::RailIrregularity {
            wavelength_m: 0.5,
            amplitude_mm: 0.0,
            phase_deg: 30.0,
        },
        Effect::WheelOutOfRound {
            wheel: WheelPosition::Leading,
            order: 8,
            amplitude_mm: 0.0,
            phase_deg: 30.0,
        },
    ] {
        let r = run(vec![e.clone()], None);
        assert_eq!(r.pad_force_n, base.pad_force_n, "{e:?}");
    }
    // A dip of depth 0 is no dip: it adds no fine steps either.
    let r = run(
        vec![Effect::RailDip {
            position_m: 10.2,
            length_m: 0.3,
            depth_mm: 0.0,
        }],
        None,
    );
    assert_eq!(r.pad_force_n, base.pad_force_n);
}

#[test]
fn a_sensor_gain_scales_its_sensor_only() {
    let base = run(vec![], None);
    let r = run(
        vec![Effect::SensorGain {
            sensor: "rps3".into(),
            factor: 1.1,
        }],
        None,
    );
    let i = 2; // rps3
    for (s, (a, b)) in r.pad_force_n.iter().zip(&base.pad_force_n).enumerate() {
        if s == i {
            // Exact to round-off (1e-12 relative).
            assert!(a
                .iter()
                .zip(b)
                .all(|(x, y)| (x - 1.1 * y).abs() <= 1e-12 * y.abs().max(1.0)));
        } else {
            assert_eq!(a, b, "sensor {s}");
        }
    }
}

#[test]
fn static_equilibrium_holds_with_a_changed_pad_or_ballast_and_the_stiffer_support_carries_more() {
    let base_cal = with(vec![]);
    let weight = 2.0 * base_cal.static_wheel_load_n();
    let pad_share = |effects: Vec<Effect>| {
        let cal = with(effects);
        let sim = Simulator::new(&cal).unwrap();
        // Bogie centre over sleeper 17 (wheels at ±1 m), far from the clamped ends.
        let x = 17.0 * cal.track.sleeper_spacing_m;
        let st = sim
            .static_state(
                [
                    x + cal.vehicle.half_wheelbase_m,
                    x - cal.vehicle.half_wheelbase_m,
                ],
                [0.0; 2],
            )
            .unwrap();
        let zeros = vec![0.0; st.u.len()];
        let pads: Vec<f64> = (1..cal.track.bays)
            .map(|k| {
                sim.track()
                    .pad_force(sim.track().pad_dofs(k).unwrap(), &st.u, &zeros)
            })
            .collect();
        let ends = sim.track().end_reactions(&st.u);
        let total: f64 = pads.iter().sum::<f64>() + ends[0] + ends[1];
        // Equilibrium to round-off (1e-9 relative), as for the base model.
        assert!(
            (total / weight - 1.0).abs() < 1e-9,
            "pads + ends {total} vs {weight}"
        );
        pads[15] // sleeper 16, under the leading wheel's neighbourhood
    };
    let base = pad_share(vec![]);
    let stiff_pad = pad_share(vec![Effect::PadStiffness {
        sleeper: 16,
        factor: 2.0,
    }]);
    let soft_pad = pad_share(vec![Effect::PadStiffness {
        sleeper: 16,
        factor: 0.5,
    }]);
    let soft_ballast = pad_share(vec![Effect::BallastStiffness {
        sleeper: 16,
        factor: 0.2,
    }]);
    println!("sleeper 16 load: base {base:.0} N, pad ×2 {stiff_pad:.0}, pad ×0.5 {soft_pad:.0}, ballast ×0.2 {soft_ballast:.0}");
    assert!(stiff_pad > base && base > soft_pad && base > soft_ballast);
    // A stiffer support attracts load, but less than in proportion (its neighbours share it).
    assert!(stiff_pad < 2.0 * base && soft_pad > 0.5 * base);
}

#[test]
fn a_periodic_irregularity_shakes_the_contact_force_at_v_over_lambda() {
    let cal = with(vec![]);
    let lambda = 0.4;
    let base = run(vec![], None);
    let r = run(
        vec![Effect::RailIrregularity {
            wavelength_m: lambda,
            amplitude_mm: 0.05,
            phase_deg: 0.0,
        }],
        None,
    );
    let d: Vec<f64> = contact(&r, 0)
        .iter()
        .zip(contact(&base, 0))
        .map(|(a, b)| a - b)
        .collect();
    // Zero crossings of the force difference over the recorded span: two per wavelength run.
    let crossings = d.windows(2).filter(|w| w[0] * w[1] < 0.0).count() as f64;
    let span_m = d.len() as f64 / cal.output.sample_rate_hz * cal.speed_m_per_s();
    let expected = 2.0 * span_m / lambda;
    println!("crossings {crossings}, expected {expected:.1}");
    // Within 5 % (the response also holds the track's own transients).
    assert!(
        (crossings / expected - 1.0).abs() < 0.05,
        "{crossings} vs {expected}"
    );
}

#[test]
fn a_rail_dip_acts_where_it_lies_and_in_proportion_to_its_depth() {
    let cal = with(vec![]);
    let base = run(vec![], None);
    let dip = |depth_mm| {
        let r = run(
            vec![Effect::RailDip {
                position_m: 10.2,
                length_m: 0.3,
                depth_mm,
            }],
            None,
        );
        let d: Vec<f64> = contact(&r, 0)
            .iter()
            .zip(contact(&base, 0))
            .map(|(a, b)| a - b)
            .collect();
        d
    };
    let (d1, d2) = (dip(0.05), dip(0.1));
    let peak = |d: &[f64]| d.iter().copied().fold(0.0f64, |m, x| m.max(x.abs()));
    let (p1, p2) = (peak(&d1), peak(&d2));
    println!("dip 0.05 mm: {p1:.0} N, 0.1 mm: {p2:.0} N");
    // Small dips, no loss of contact: linear to 5 %.
    assert!((p2 / p1 - 2.0).abs() < 0.1, "{p2} / {p1}");
    // Nothing happens before the leading wheel reaches the dip (1 N).
    let t_arrive = (10.2 - 0.15 - cal.run.leading_wheel_start_m) / cal.speed_m_per_s();
    let k_arrive = (t_arrive * cal.output.sample_rate_hz) as usize;
    let first = base.first_sample;
    let before = k_arrive.saturating_sub(first + 1);
    assert!(
        d2[..before].iter().all(|x| x.abs() < 1.0),
        "force changed before the dip"
    );
}

#[test]
fn an_out_of_round_wheel_shakes_its_own_wheel_most() {
    let base = run(vec![], None);
    let r = run(
        vec![Effect::WheelOutOfRound {
            wheel: WheelPosition::Trailing,
            order: 10,
            amplitude_mm: 0.05,
            phase_deg: 0.0,
        }],
        None,
    );
    let dev = |w| max_abs_diff(contact(&r, w), contact(&base, w));
    let (lead, trail) = (dev(0), dev(1));
    println!("contact force change: leading {lead:.0} N, trailing {trail:.0} N");
    assert!(trail > 3.0 * lead, "trailing {trail} vs leading {lead}");
    // The flat and the out-of-roundness add on the same wheel without error.
    let flat = Flat::from_mm(40.0, 0.3, 0.0, 12.4).unwrap();
    let both = run(
        vec![Effect::WheelOutOfRound {
            wheel: WheelPosition::Trailing,
            order: 10,
            amplitude_mm: 0.05,
            phase_deg: 0.0,
        }],
        Some(&flat),
    );
    assert!(both.pad_force_n.iter().flatten().all(|v| v.is_finite()));
}

#[test]
fn synth_hides_effects_and_names_bad_ones() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.csv");
    let bin = wheelflat_path();
    let ok = std::process::Command::new(&bin)
        .args([
            "synth",
            "--effect",
            "pad_stiffness:sleeper=16,factor=0.5",
            "--effect",
        ])
        .arg("wheel_out_of_round:wheel=leading,order=8,amplitude_mm=0.05")
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        ok.status.success(),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    let truth: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("m.truth.json")).unwrap())
            .unwrap();
    let effects = truth["effects"].as_array().unwrap();
    assert_eq!(effects.len(), 2);
    assert_eq!(effects[0]["kind"], "pad_stiffness");
    assert_eq!(effects[1]["wheel"], "leading");
    for (arg, expected) in [
        ("pad_stiffnes:sleeper=16", "unknown variant `pad_stiffnes`"),
        ("pad_stiffness:sleeper=16,factr=2", "unknown field `factr`"),
        (
            "pad_stiffness:sleeper=99,factor=2",
            "`effects[0].sleeper` = 99: a sleeper of the track, 1 to 33",
        ),
    ] {
        let bad = std::process::Command::new(&bin)
            .args(["synth", "--effect", arg, "--out"])
            .arg(dir.path().join("bad.csv"))
            .output()
            .unwrap();
        let e = String::from_utf8_lossy(&bad.stderr);
        assert!(!bad.status.success() && e.contains(expected), "{arg}: {e}");
        assert!(
            !dir.path().join("bad.csv").exists(),
            "nothing written on error"
        );
    }
}

#[test]
fn a_time_offset_delays_every_sensor_and_no_offset_changes_nothing() {
    let base = run(vec![], None);
    let zero = run(vec![Effect::TimeOffset { offset_ms: 0.0 }], None);
    assert_eq!(zero.pad_force_n, base.pad_force_n);
    let speed0 = run(vec![Effect::SpeedDeviation { fraction: 0.0 }], None);
    assert_eq!(speed0.pad_force_n, base.pad_force_n);
    // One sample (0.4 ms) late: sample k reads the base's sample k − 1, exactly (the run is
    // the same; only its recording starts earlier and ends later).
    let late = run(vec![Effect::TimeOffset { offset_ms: 0.4 }], None);
    assert_eq!(late.first_sample, base.first_sample);
    for (a, b) in late.pad_force_n.iter().zip(&base.pad_force_n) {
        assert_eq!(a.len(), b.len());
        assert_eq!(&a[1..], &b[..b.len() - 1]);
    }
    // Half a sample: halfway between (linear interpolation, to round-off).
    let half = run(vec![Effect::TimeOffset { offset_ms: 0.2 }], None);
    for (a, b) in half.pad_force_n.iter().zip(&base.pad_force_n) {
        for k in 1..a.len() {
            let mid = 0.5 * (b[k - 1] + b[k]);
            assert!(
                (a[k] - mid).abs() < 1e-9 * mid.abs().max(1.0),
                "{} vs {mid}",
                a[k]
            );
        }
    }
}

#[test]
fn a_faster_train_aligned_on_its_trigger_passes_the_sensors_later() {
    let cal = with(vec![]);
    let base = run(vec![], None);
    let fraction = 0.02;
    let fast = run(vec![Effect::SpeedDeviation { fraction }], None);
    // RPS5 (sleeper 15) is the sensor farthest from the laser: the leading wheel's peak there
    // moves by (x_laser − x_rps5)·(1/v − 1/v') once both runs are aligned on the trigger.
    let i = 4;
    let v = cal.speed_m_per_s();
    let d = cal.sensors.laser_trigger_m - cal.sensor_position_m(i);
    let expected = d * (1.0 / v - 1.0 / (v * (1.0 + fraction))) * cal.output.sample_rate_hz;
    let (b, f) = (&base.pad_force_n[i], &fast.pad_force_n[i]);
    // The response spans all five windows; at RPS5 the leading wheel passes first, 2 m (0.14 s,
    // 360 samples) before the trailing one: its peak is the largest of the first 500 samples.
    let argmax = |s: &[f64]| {
        s[..500]
            .iter()
            .enumerate()
            .fold((0, f64::MIN), |m, (k, &x)| if x > m.1 { (k, x) } else { m })
            .0 as f64
    };
    let moved = argmax(f) - argmax(b);
    println!("leading-wheel peak at RPS5 moved {moved} samples, expected {expected:.1}");
    // Within 1.5 samples (peaks are found on the 0.4 ms grid).
    assert!((moved - expected).abs() <= 1.5, "{moved} vs {expected}");
}

#[test]
fn a_car_body_bounce_reaches_the_wheels_as_a_one_mass_oscillator_says() {
    let cal = with(vec![]);
    let base = run(vec![], None);
    let zero = run(
        vec![Effect::CarBodyBounce {
            amplitude: 0.0,
            frequency_hz: 1.5,
            phase_deg: 0.0,
        }],
        None,
    );
    assert_eq!(zero.pad_force_n, base.pad_force_n);
    let (a, f) = (0.1, 1.5);
    let r = run(
        vec![Effect::CarBodyBounce {
            amplitude: a,
            frequency_hz: f,
            phase_deg: 0.0,
        }],
        None,
    );
    let amp = a * cal.vehicle.car_body_mass_kg * cal.vehicle.gravity_m_per_s2;
    // Least-squares fit extra(t) ≈ A·sin(ωt) + B·cos(ωt) of the wheels' extra load.
    let w = std::f64::consts::TAU * f;
    let (mut ss, mut cc, mut sc, mut ys, mut yc) = (0.0, 0.0, 0.0, 0.0, 0.0);
    let mut extra = Vec::new();
    for k in 0..base.len() {
        let t = r.time_s(k);
        let y = contact(&r, 0)[k] + contact(&r, 1)[k] - contact(&base, 0)[k] - contact(&base, 1)[k];
        let (sn, cs) = ((w * t).sin(), (w * t).cos());
        ss += sn * sn;
        cc += cs * cs;
        sc += sn * cs;
        ys += y * sn;
        yc += y * cs;
        extra.push((t, y));
    }
    let det = ss * cc - sc * sc;
    let (fa, fb) = ((ys * cc - yc * sc) / det, (yc * ss - ys * sc) / det);
    let fitted = fa.hypot(fb);
    let lag_deg = fb.atan2(fa).to_degrees();
    let residual = extra
        .iter()
        .map(|&(t, y)| (y - fa * (w * t).sin() - fb * (w * t).cos()).abs())
        .fold(0.0f64, f64::max);
    println!(
        "bounce {amp:.0} N at {f} Hz: wheels carry {fitted:.0} N, phase {lag_deg:+.1}°, largest residual {residual:.0} N"
    );
    // Closed form: the bogie bounces on its two primary springs and dampers over wheels that
    // the far stiffer track and contact hold nearly still, a damped one-mass oscillator driven
    // by a force at f. The force it passes on is the load times
    // T = (1 + 2iζr)/(1 − r² + 2iζr), r = f/f_b, f_b = sqrt(2K₁/M_b)/2π, ζ = C₁/sqrt(2K₁·M_b).
    let v = &cal.vehicle;
    let k = 2.0 * v.primary_stiffness_n_per_m;
    let fb = (k / v.bogie_mass_kg).sqrt() / std::f64::consts::TAU;
    let zeta = 2.0 * v.primary_damping_ns_per_m / (2.0 * (k * v.bogie_mass_kg).sqrt());
    let r2 = f / fb;
    let x = 2.0 * zeta * r2;
    let trans = (1.0 + x * x).sqrt() / ((1.0 - r2 * r2).powi(2) + x * x).sqrt();
    let phase = (x.atan() - x.atan2(1.0 - r2 * r2)).to_degrees();
    println!(
        "bogie bounce {fb:.2} Hz, ζ {zeta:.3}: |T| = {trans:.4}, phase {phase:+.2}°; simulated {:.4}, {lag_deg:+.2}°",
        fitted / amp
    );
    // Within 1 % and 1° of the closed form (the track and contact compliance, 0.2 mm against
    // the suspension's centimetres, and the pitch coupling make the rest).
    assert!(
        (fitted / amp / trans - 1.0).abs() < 0.01,
        "{fitted} N vs {} N",
        trans * amp
    );
    assert!(
        (lag_deg - phase).abs() < 1.0,
        "phase {lag_deg}° vs {phase}°"
    );
    // Little else in the extra load: a start-up remainder under 3 % of the bounce.
    assert!(residual < 0.03 * amp, "residual {residual} N");
}

/// Static state with the bogie centred over sleeper 17 (wheels at ±1 m).
fn centred_static(cal: &CheckedCalibration) -> (Simulator, wheelflat::model::State) {
    let sim = Simulator::new(cal).unwrap();
    let x = 17.0 * cal.track.sleeper_spacing_m;
    let hb = cal.vehicle.half_wheelbase_m;
    let st = sim.static_state([x + hb, x - hb], [0.0; 2]).unwrap();
    (sim, st)
}

fn pad_forces(sim: &Simulator, st: &wheelflat::model::State) -> Vec<f64> {
    let cal = sim.calibration();
    let zeros = vec![0.0; st.u.len()];
    (1..cal.track.bays)
        .map(|k| {
            sim.track()
                .pad_force(sim.track().pad_dofs(k).unwrap(), &st.u, &zeros)
        })
        .collect()
}

#[test]
fn a_voided_sleeper_hangs_from_the_rail_until_its_gap_closes() {
    let base = with(vec![]);
    let weight = 2.0 * base.static_wheel_load_n();
    let (bs, bst) = centred_static(&base);
    let base_pads = pad_forces(&bs, &bst);
    let check = |gap_mm: f64| {
        let cal = with(vec![Effect::VoidedSleeper {
            sleeper: 17,
            gap_mm,
        }]);
        let (sim, st) = centred_static(&cal);
        let pads = pad_forces(&sim, &st);
        let ends = sim.track().end_reactions(&st.u);
        let total: f64 = pads.iter().sum::<f64>() + ends[0] + ends[1];
        // Equilibrium to 1e-9: the pads still carry the whole weight into the sleepers.
        assert!(
            (total / weight - 1.0).abs() < 1e-9,
            "gap {gap_mm}: {total} vs {weight}"
        );
        (pads, st.u[sim.track().pad_dofs(17).unwrap().1])
    };
    // Gap 0 under a loaded sleeper: the ballast is in contact, the same as the linear track
    // to round-off.
    let (p0, _) = check(0.0);
    for (a, b) in p0.iter().zip(&base_pads) {
        assert!((a - b).abs() < 1e-6 * weight, "{a} vs {b}");
    }
    // A gap the sleeper never closes: it hangs from the rail and its pad carries nothing (no
    // sleeper weight in the model), its neighbours take the load.
    let (p10, z10) = check(10.0);
    println!(
        "gap 10 mm: sleeper 17 pad {:.1} N (base {:.0} N), sleeper down {:.3} mm",
        p10[16],
        base_pads[16],
        z10 * 1e3
    );
    assert!(p10[16].abs() < 1e-6 * weight);
    assert!(p10[15] > base_pads[15] && p10[17] > base_pads[17]);
    // A small gap that closes: the sleeper comes down through it and rests on the ballast,
    // carrying less than before.
    let (p01, z01) = check(0.1);
    println!(
        "gap 0.1 mm: sleeper 17 pad {:.0} N, sleeper down {:.3} mm",
        p01[16],
        z01 * 1e3
    );
    assert!(z01 > 0.1e-3 && p01[16] > 0.0 && p01[16] < base_pads[16]);
}

#[test]
fn a_voided_sleeper_under_a_sensor_shows_in_its_pad_force_and_converges_in_time() {
    let run_dt = |effects: Vec<Effect>, coarse_per_sample: usize| {
        let mut c = Calibration {
            effects,
            ..Default::default()
        };
        c.integration.coarse_steps_per_sample = coarse_per_sample;
        Simulator::new(&c.check().unwrap())
            .unwrap()
            .run(None, Record::default())
            .unwrap()
    };
    let void = vec![Effect::VoidedSleeper {
        sleeper: 17,
        gap_mm: 0.3,
    }];
    let base = run_dt(vec![], 1);
    let coarse = run_dt(void.clone(), 1);
    let fine = run_dt(void, 2);
    let i = 2; // rps3 sits on sleeper 17
    let peak = |s: &[f64]| s.iter().copied().fold(f64::MIN, f64::max);
    let (pb, pc, pf) = (
        peak(&base.pad_force_n[i]),
        peak(&coarse.pad_force_n[i]),
        peak(&fine.pad_force_n[i]),
    );
    println!("rps3 peak: base {pb:.0} N, voided {pc:.0} N (dt/2: {pf:.0} N)");
    // The hanging sleeper carries visibly less at its pad (more than 10 %).
    assert!(pc < 0.9 * pb, "{pc} vs {pb}");
    // The unilateral ballast is explicit in one term: halving dt moves the peak by < 1 %.
    assert!((pc / pf - 1.0).abs() < 0.01, "{pc} vs {pf}");
    assert!(coarse.pad_force_n.iter().flatten().all(|v| v.is_finite()));
}

#[test]
fn a_second_flat_on_a_good_wheel_is_the_flat_itself_and_adds_to_a_flat_on_the_other_wheel() {
    // The second flat's drop is the flat's trajectory (paper Eq. 9) on its wheel, with the
    // same fine steps around its strikes: on a good wheel it must reproduce a run of that
    // flat as *the* flat bit for bit.
    let flat = Flat::from_mm(55.0, 0.4, 0.05, 12.35).unwrap();
    let as_flat = run(vec![], Some(&flat.on_wheel(WheelPosition::Trailing)));
    let as_effect = run(
        vec![Effect::SecondFlat {
            wheel: WheelPosition::Trailing,
            length_mm: 55.0,
            depth_mm: 0.4,
            curvature_mm: 0.05,
            impact_position_m: 12.35,
        }],
        None,
    );
    assert_eq!(as_effect.pad_force_n, as_flat.pad_force_n);
    assert_eq!(as_effect.contact_force_n, as_flat.contact_force_n);
    // On the other wheel, the leading one, its strikes show in the leading wheel's contact
    // force: the impact (above the static load by more than 20 %) comes when the leading
    // wheel reaches X_p; the trailing wheel's flat alone leaves the leading wheel's contact
    // force within 5 % of its static load around that time.
    let main = Flat::from_mm(60.0, 0.5, 0.0, 12.45)
        .unwrap()
        .on_wheel(WheelPosition::Trailing);
    let cal = with(vec![]);
    let static_n = cal.static_wheel_load_n();
    let second = Effect::SecondFlat {
        wheel: WheelPosition::Leading,
        length_mm: 50.0,
        depth_mm: 0.4,
        curvature_mm: 0.0,
        impact_position_m: 12.9,
    };
    let one = run(vec![], Some(&main));
    let two = run(vec![second], Some(&main));
    let v = cal.speed_m_per_s();
    let t_strike = (12.9 - cal.run.leading_wheel_start_m) / v;
    let rate = cal.output.sample_rate_hz;
    let around: Vec<usize> = (0..one.len())
        .filter(|&j| {
            let t = (one.first_sample + j) as f64 / rate;
            (t_strike..t_strike + 0.02).contains(&t)
        })
        .collect();
    assert!(!around.is_empty(), "the strike lies in the recording");
    let peak = |r: &Response| around.iter().map(|&j| contact(r, 0)[j]).fold(0.0, f64::max);
    assert!(peak(&one) < 1.05 * static_n, "{} vs {static_n}", peak(&one));
    assert!(peak(&two) > 1.2 * static_n, "{} vs {static_n}", peak(&two));
}

#[test]
fn a_second_flat_longer_than_the_wheel_or_not_a_flat_is_refused_by_key() {
    for (l, d, c) in [(3000.0, 0.4, 0.0), (50.0, -0.1, 0.0), (50.0, 0.4, 0.3)] {
        let e = Calibration {
            effects: vec![Effect::SecondFlat {
                wheel: WheelPosition::Leading,
                length_mm: l,
                depth_mm: d,
                curvature_mm: c,
                impact_position_m: 12.0,
            }],
            ..Default::default()
        }
        .check()
        .unwrap_err()
        .to_string();
        assert!(e.contains("effects[0]"), "{e}");
    }
}
