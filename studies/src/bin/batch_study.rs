//! Batch size and grouping of the lockstep simulator (docs/performance.md, "Batched
//! generation").
//!
//! Simulates the same instances of the default population (an evenly spaced subset of the
//! 50,000) on one thread with each lane count and with and without sorting by first strike,
//! and prints a Markdown table: instances per second, the lane efficiency (steps taken by the
//! lanes / (lanes × rounds)) and whether every result equals the one-lane run bit for bit.
//!
//! `cargo run --release -p wheelflat-studies --bin batch_study [instances [first]]` (default 400 spread over
//! the population; `first`: the first instances, as one shard file holds them)

use std::time::Instant;
use wheelflat::bank::Population;
use wheelflat::model::{batch_key, BatchStats, Calibration, Flat, Record, Response, Simulator};

fn run<const B: usize>(
    sim: &Simulator,
    flats: &[Flat],
    sorted: bool,
) -> (f64, BatchStats, Vec<Response>) {
    let mut order: Vec<usize> = (0..flats.len()).collect();
    if sorted {
        let keys: Vec<f64> = flats.iter().map(|f| batch_key(sim, Some(f))).collect();
        order.sort_by(|&a, &b| keys[a].total_cmp(&keys[b]).then(a.cmp(&b)));
    }
    let mut ws = sim.lane_workspace::<B>();
    let mut out: Vec<Option<Response>> = vec![None; flats.len()];
    let mut total = BatchStats::default();
    let t0 = Instant::now();
    for batch in order.chunks(B) {
        let members: Vec<Option<&Flat>> = batch.iter().map(|&k| Some(&flats[k])).collect();
        let (res, stats) = sim.run_batch::<B>(&members, Record::default(), &mut ws);
        total.lane_steps += stats.lane_steps;
        total.rounds += stats.rounds * B;
        for (&k, r) in batch.iter().zip(res) {
            out[k] = Some(r.expect("default instances simulate"));
        }
    }
    let rate = flats.len() as f64 / t0.elapsed().as_secs_f64();
    (rate, total, out.into_iter().map(Option::unwrap).collect())
}

fn main() {
    let count: usize = std::env::args()
        .nth(1)
        .map(|a| a.parse().expect("instances: a number"))
        .unwrap_or(400);
    let consecutive = std::env::args().nth(2).is_some_and(|a| a == "first");
    let cal = Calibration::default().check().expect("defaults are valid");
    let sim = Simulator::new(&cal).expect("default model");
    let population = Population::new(&cal.population, 50_000, 0);
    let flats: Vec<Flat> = (0..count)
        .map(|k| {
            population
                .instance(if consecutive { k } else { k * 50_000 / count })
                .flat(cal.vehicle.flat_wheel)
                .expect("population flats are valid")
        })
        .collect();
    println!("{count} instances of the default population, one thread\n");
    println!("| lanes | sorted by first strike | instances/s | lane efficiency | same bits as one lane |");
    println!("|---|---|---|---|---|");
    let (r1, s1, reference) = run::<1>(&sim, &flats, false);
    let eff = |s: BatchStats| s.lane_steps as f64 / s.rounds as f64;
    println!("| 1 | — | {r1:.1} | {:.3} | — |", eff(s1));
    macro_rules! row {
        ($b:literal, $sorted:expr) => {{
            let (r, s, out) = run::<$b>(&sim, &flats, $sorted);
            let same = out == reference;
            println!(
                "| {} | {} | {r:.1} | {:.3} | {} |",
                $b,
                if $sorted { "yes" } else { "no" },
                eff(s),
                if same { "yes" } else { "NO" }
            );
        }};
    }
    row!(4, false);
    row!(8, false);
    row!(8, true);
}
