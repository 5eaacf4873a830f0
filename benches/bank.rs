//! Bank speed: generation throughput (instances/s on all cores, issue #3's goal ≥ 100/s on
//! this 2-core machine) and the identifier's hot path, reading 60 arbitrary force columns of a
//! bank through the memory map (goal ≤ 10 ms for 50,000 instances).
//!
//! The read benches use the bank at `$WHEELFLAT_BENCH_BANK` when set (the README's figures
//! come from the full 50k default bank: `wheelflat bank generate --out bank`), else they
//! build a 2,500-instance bank under `target/bench-bank` once.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::hint::black_box;
use std::path::PathBuf;
use wheelflat::bank::{self, Bank, GenerateOptions, Quiet, StorageFormat};
use wheelflat::model::Calibration;

fn options(instances: usize, shard_size: usize) -> GenerateOptions {
    GenerateOptions {
        instances,
        seed: 0,
        shard_size,
        machine_shard: None,
        format: StorageFormat::default(),
        simulate_missing: true,
        tables: false,
    }
}

fn bench_bank(c: &mut Criterion) {
    let cal = Calibration::default().check().unwrap();
    let mut g = c.benchmark_group("bank");
    g.sample_size(10);
    let n = 128;
    g.throughput(Throughput::Elements(n as u64));
    g.bench_function("generate_128_instances_all_cores", |b| {
        b.iter(|| {
            let dir = tempfile::tempdir().unwrap();
            bank::generate(&cal, dir.path(), &options(n, 64), &Quiet).unwrap()
        })
    });
    g.finish();

    let dir = std::env::var_os("WHEELFLAT_BENCH_BANK")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            let d = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/bench-bank");
            bank::generate(&cal, &d, &options(2500, 2500), &Quiet).unwrap();
            d
        });
    let bank = Bank::open(&dir).unwrap();
    let sensors = bank.metadata().sensors.len();
    let samples = bank.metadata().sensors[0].samples;
    let cols: Vec<usize> = (0..60)
        .map(|j| bank.sample_index(j % sensors, (j * 7919 + 13) % samples))
        .collect();
    let name = format!("read_60_columns_{}_instances", bank.instances());
    let mut buffer = vec![0.0f32; cols.len() * bank.instances()];
    c.bench_function(&name, |b| {
        b.iter(|| {
            bank.read_columns_flat(black_box(&cols), &mut buffer)
                .unwrap()
        })
    });
    c.bench_function(&format!("open_{}_instances", bank.instances()), |b| {
        b.iter(|| Bank::open(black_box(&dir)).unwrap())
    });
}

criterion_group!(benches, bench_bank);
criterion_main!(benches);
