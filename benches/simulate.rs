//! Simulator speed: one full-window instance on one core (`simulate_one`, issue #2's goal is
//! ≤ 20 ms), and the cost of single coarse and fine integration steps.

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use wheelflat::model::{Calibration, Flat, Level, Record, Simulator};

fn simulate(c: &mut Criterion) {
    let cal = Calibration::default().check().unwrap();
    let sim = Simulator::new(&cal).unwrap();
    let mut ws = sim.workspace();
    let mut g = c.benchmark_group("simulate");
    g.sample_size(30);
    for (name, flat) in [
        (
            "simulate_one",
            Some(Flat::from_mm(60.0, 0.5, 0.1, 12.4).unwrap()),
        ),
        (
            "simulate_one_short_deep",
            Some(Flat::from_mm(20.0, 1.0, 0.0, 12.4).unwrap()),
        ),
        (
            "simulate_one_long_shallow",
            Some(Flat::from_mm(200.0, 0.2, 0.05, 12.7).unwrap()),
        ),
        ("simulate_one_good_wheel", None),
    ] {
        g.bench_function(name, |b| {
            b.iter(|| {
                sim.run_with(black_box(flat.as_ref()), Record::default(), &mut ws)
                    .unwrap()
            })
        });
    }
    g.finish();

    let x = [12.2, 9.7];
    let mut state = sim.static_state(x, [0.0, 0.0]).unwrap();
    for (name, level) in [("step_coarse", Level::Coarse), ("step_fine", Level::Fine)] {
        c.bench_function(name, |b| {
            b.iter(|| sim.step(level, &mut state, &mut ws, black_box(x), [0.0, 0.0]))
        });
    }
    c.bench_function("simulator_new", |b| {
        b.iter(|| Simulator::new(black_box(&cal)).unwrap())
    });
}

criterion_group!(benches, simulate);
criterion_main!(benches);
