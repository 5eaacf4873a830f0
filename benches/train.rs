//! Whole-train speed (issue #6's goal: a 12-bogie train identified in ≤ 1 s end to end from a
//! 50k bank). Uses the train-profile bank at `$WHEELFLAT_BENCH_TRAIN_BANK` (the README's
//! figure: the 50k train-profile bank), else builds a 2,500-instance one under
//! `target/bench-train-bank`. The train: 12 bogies, flats on bogie 2 leading, 7 trailing and
//! 11 leading, seed 4. Timed: align and identify every bogie, the good-wheel checks, the table.

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use std::path::{Path, PathBuf};
use wheelflat::bank::{self, Bank, GenerateOptions, Quiet, StorageFormat};
use wheelflat::identify::{Identifier, Measurement};
use wheelflat::model::Calibration;
use wheelflat::train::{self, TrainSpec};

fn bench_train(c: &mut Criterion) {
    let dir = std::env::var_os("WHEELFLAT_BENCH_TRAIN_BANK")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            let cal = Calibration::train_profile().check().unwrap();
            let d = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/bench-train-bank");
            let opts = GenerateOptions {
                instances: 2500,
                seed: 0,
                shard_size: 2500,
                machine_shard: None,
                format: StorageFormat::default(),
                simulate_missing: true,
                tables: false,
            };
            bank::generate(&cal, &d, &opts, &Quiet).unwrap();
            d
        });
    let bank = Bank::open(&dir).unwrap();
    let n = bank.instances();
    let cal = bank.metadata().calibration.clone().check().unwrap();
    let id = Identifier::new(bank, cal.identification.clone()).unwrap();
    let flats = train::default_flats();
    let syn = train::synthesize_train(&cal, &TrainSpec::twelve_bogies(flats, 4)).unwrap();
    let m = Measurement::from_csv(Path::new("train.csv"), &syn.csv, 2500.0).unwrap();
    let times = train::read_triggers(Path::new("t.csv"), &syn.triggers_csv).unwrap();
    let bogies = train::bogies_from_triggers(&cal, Path::new("t.csv"), &times).unwrap();
    let ids = vec![&id; bogies.len()];
    let mut group = c.benchmark_group("train");
    group.sample_size(10);
    group.bench_function(format!("identify_12_bogies_{n}_instances"), |b| {
        b.iter(|| train::identify_bogies(&ids, black_box(&m), &bogies).unwrap())
    });
    group.finish();
}

criterion_group!(benches, bench_train);
criterion_main!(benches);
