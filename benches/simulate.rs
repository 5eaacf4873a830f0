//! Simulator speed: one full-window instance on one core (`simulate_one`, issue #2's goal is
//! ≤ 20 ms), setting a simulator up, and the lockstep batches
//! of bank generation against the single-instance path on the same instances
//! (`batch/single` vs `batch/lanes_8`, instances per second).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::hint::black_box;
use wheelflat::bank::Population;
use wheelflat::model::{batch_key, Calibration, Flat, Record, Simulator, LANES};

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

    c.bench_function("simulator_new", |b| {
        b.iter(|| Simulator::new(black_box(&cal)).unwrap())
    });
}

/// 64 consecutive instances from the middle of the default population (as one shard file
/// holds them), sorted by first strike as bank generation sorts them.
fn batch(c: &mut Criterion) {
    let cal = Calibration::default().check().unwrap();
    let sim = Simulator::new(&cal).unwrap();
    let population = Population::new(&cal.population, 50_000, 0);
    let mut flats: Vec<Flat> = (25_000..25_064)
        .map(|i| population.instance(i).flat(cal.vehicle.flat_wheel).unwrap())
        .collect();
    flats.sort_by(|a, b| batch_key(&sim, Some(a)).total_cmp(&batch_key(&sim, Some(b))));
    let mut g = c.benchmark_group("batch");
    g.sample_size(10);
    g.throughput(Throughput::Elements(flats.len() as u64));
    let mut ws = sim.workspace();
    g.bench_function("single", |b| {
        b.iter(|| {
            for f in &flats {
                black_box(sim.run_with(Some(f), Record::default(), &mut ws).unwrap());
            }
        })
    });
    let mut lanes = sim.lane_workspace::<LANES>();
    g.bench_function("lanes_8", |b| {
        b.iter(|| {
            for chunk in flats.chunks(LANES) {
                let members: Vec<Option<&Flat>> = chunk.iter().map(Some).collect();
                black_box(sim.run_batch(&members, Record::default(), &mut lanes));
            }
        })
    });
    g.finish();
}

criterion_group!(benches, simulate, batch);
criterion_main!(benches);
