//! Lockstep batches (issue 12): a lane gives the bits of its single-instance run whatever its
//! batch-mates, lane count and position, with and without the calibration's effects; a lane
//! that fails leaves the others alone; sorted batch-mates take nearly every round.

use wheelflat::model::{
    batch_key, BatchStats, Calibration, CheckedCalibration, Effect, Flat, Record, Response,
    SimError, Simulator, WheelPosition,
};

/// Flats that exercise every branch of the step: mid-size, short and deep (loses contact),
/// long and shallow, on the leading wheel, a good wheel, and one too long for the wheel.
fn flats() -> Vec<Option<Flat>> {
    let f = |l, d, c, x| Some(Flat::from_mm(l, d, c, x).unwrap());
    vec![
        f(60.0, 0.5, 0.1, 12.4),
        f(20.0, 1.0, 0.0, 12.4),
        f(200.0, 0.2, 0.05, 12.7),
        Some(
            Flat::from_mm(40.0, 0.3, 0.1, 12.05)
                .unwrap()
                .on_wheel(WheelPosition::Leading),
        ),
        None,
        f(35.0, 0.8, 0.2, 11.9),
        f(3000.0, 0.5, 0.1, 12.4),
    ]
}

/// Bit-for-bit equality of two responses (`==` on f64 would equate 0.0 and −0.0).
fn same_bits(a: &Response, b: &Response) -> bool {
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    a.pad_force_n.len() == b.pad_force_n.len()
        && a.pad_force_n
            .iter()
            .zip(&b.pad_force_n)
            .all(|(x, y)| bits(x) == bits(y))
        && match (&a.contact_force_n, &b.contact_force_n) {
            (Some(x), Some(y)) => (0..2).all(|w| bits(&x[w]) == bits(&y[w])),
            (None, None) => true,
            _ => false,
        }
        && bits(&a.peak_contact_force_n) == bits(&b.peak_contact_force_n)
        && bits(&a.contact_loss_s) == bits(&b.contact_loss_s)
        && a.steps == b.steps
        && a.first_sample == b.first_sample
        && a.strike_times_s == b.strike_times_s
}

fn check_batches(cal: &CheckedCalibration) {
    let sim = Simulator::new(cal).unwrap();
    let flats = flats();
    let record = Record { contact: true };
    let single: Vec<Result<Response, SimError>> =
        flats.iter().map(|f| sim.run(f.as_ref(), record)).collect();
    let refs: Vec<Option<&Flat>> = flats.iter().map(Option::as_ref).collect();
    // All seven in 8 lanes, reversed in 8, and in pairs of 2 lanes.
    let (all8, _) = sim.run_batch::<8>(&refs, record, &mut sim.lane_workspace());
    let reversed: Vec<Option<&Flat>> = refs.iter().rev().copied().collect();
    let (mut rev8, _) = sim.run_batch::<8>(&reversed, record, &mut sim.lane_workspace());
    rev8.reverse();
    let mut pairs = Vec::new();
    let mut ws2 = sim.lane_workspace::<2>();
    for chunk in refs.chunks(2) {
        pairs.extend(sim.run_batch::<2>(chunk, record, &mut ws2).0);
    }
    for (name, batched) in [
        ("8 lanes", &all8),
        ("8 lanes reversed", &rev8),
        ("2 lanes", &pairs),
    ] {
        for (k, (s, b)) in single.iter().zip(batched).enumerate() {
            match (s, b) {
                (Ok(s), Ok(b)) => assert!(same_bits(s, b), "{name}: flat {k} differs"),
                (Err(s), Err(b)) => assert_eq!(s.to_string(), b.to_string()),
                _ => panic!("{name}: flat {k}: single {s:?} vs batched {b:?}"),
            }
        }
    }
    assert!(matches!(single[6], Err(SimError::FlatTooLong { .. })));
    let lost = single[1].as_ref().unwrap().contact_loss_s[1];
    assert!(
        lost > 1e-3,
        "the 20 × 1.0 mm flat leaves the rail ({lost} s)"
    );
}

#[test]
fn a_lane_gives_its_single_run_bits_in_any_batch() {
    check_batches(&Calibration::default().check().unwrap());
}

#[test]
fn a_lane_gives_its_single_run_bits_with_every_kind_of_effect() {
    // Effects that act in the step (voided sleeper, car-body bounce, rail dip with its fine
    // zones) and on the output (sensor gain, time offset: recorded with margins and resampled).
    let cal = Calibration {
        effects: vec![
            Effect::VoidedSleeper {
                sleeper: 21,
                gap_mm: 0.5,
            },
            Effect::CarBodyBounce {
                amplitude: 0.05,
                frequency_hz: 1.5,
                phase_deg: 30.0,
            },
            Effect::RailDip {
                position_m: 13.0,
                length_m: 0.5,
                depth_mm: 0.3,
            },
            Effect::SensorGain {
                sensor: "rps2".into(),
                factor: 1.05,
            },
            Effect::TimeOffset { offset_ms: 0.7 },
        ],
        ..Calibration::default()
    };
    check_batches(&cal.check().unwrap());
}

#[test]
fn batch_mates_sorted_by_first_strike_take_nearly_every_round() {
    // 64 consecutive instances of the default population, as a shard holds them. The counts
    // are deterministic (no timing): lane efficiency = lane steps / (lanes × rounds).
    let cal = Calibration::default().check().unwrap();
    let sim = Simulator::new(&cal).unwrap();
    let population = wheelflat::bank::Population::new(&cal.population, 50_000, 0);
    let mut flats: Vec<Flat> = (30_000..30_064)
        .map(|i| population.instance(i).flat(cal.vehicle.flat_wheel).unwrap())
        .collect();
    flats.sort_by(|a, b| batch_key(&sim, Some(a)).total_cmp(&batch_key(&sim, Some(b))));
    let mut ws = sim.lane_workspace::<8>();
    let mut total = BatchStats::default();
    for chunk in flats.chunks(8) {
        let members: Vec<Option<&Flat>> = chunk.iter().map(Some).collect();
        let (results, stats) = sim.run_batch::<8>(&members, Record::default(), &mut ws);
        assert!(results.iter().all(Result::is_ok));
        total.lane_steps += stats.lane_steps;
        total.rounds += stats.rounds;
    }
    let efficiency = total.lane_steps as f64 / (8 * total.rounds) as f64;
    eprintln!("lane efficiency {efficiency:.3}");
    // Measured 0.99 (docs/performance.md); below 0.9 the batches would lose a tenth.
    assert!(efficiency >= 0.9, "lane efficiency {efficiency:.3}");
}
