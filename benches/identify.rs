//! Identification speed (issue #4's goals: one measurement from the 50k bank ≤ 50 ms end to
//! end — align, PIP, read columns, entropy selection, falsify — and one falsification pass
//! ≤ 0.5 ms). Uses the bank at `$WHEELFLAT_BENCH_BANK` (the README's figures: the default 50k
//! bank), else builds a 2,500-instance bank under `target/bench-bank`. The measurement is a
//! synthetic 60 mm × 0.5 mm flat on RPS1 and RPS2, the paper's two working sensors (60 PIPs).
//! The refinement stage (`identify --refine`) is timed separately, on all five sensors.

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use std::path::{Path, PathBuf};
use wheelflat::bank::{self, Bank, GenerateOptions, Quiet, StorageFormat};
use wheelflat::identify::falsify::{falsify, Discretisation, Point};
use wheelflat::identify::{synth, Extras, Identifier, Measurement};
use wheelflat::model::{Calibration, Flat};

fn bench_identify(c: &mut Criterion) {
    let dir = std::env::var_os("WHEELFLAT_BENCH_BANK")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            let cal = Calibration::default().check().unwrap();
            let d = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/bench-bank");
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
    let cal = bank.metadata().calibration.clone().check().unwrap();
    let n = bank.instances();
    let id = Identifier::new(bank, cal.identification.clone()).unwrap();
    let flat = Flat::from_mm(60.0, 0.5, 0.1, 12.4).unwrap();
    let syn = synth::synthesize(&cal, &flat, 1, true).unwrap();
    let m =
        Measurement::from_csv(Path::new("bench.csv"), &syn.csv, cal.output.sample_rate_hz).unwrap();
    let sensors = vec!["rps1".to_string(), "rps2".to_string()];
    let quick = Extras::NONE;
    c.bench_function(&format!("identify_one_measurement_{n}_instances"), |b| {
        b.iter(|| id.identify(black_box(&m), Some(&sensors), quick).unwrap())
    });

    // One falsification pass over the whole bank with the measurement's EIP.
    let whole = id.identify(&m, Some(&sensors), quick).unwrap();
    let r = whole
        .sizing
        .as_ref()
        .expect("the bench's flat is detected and sized");
    let axes = &id.bank().metadata().sensors;
    // Each EIP point's bank column, `d` samples from it (kept inside the window).
    let columns_at = |d: isize| -> Vec<usize> {
        r.eip
            .iter()
            .map(|&e| {
                let cp = &r.candidates[e];
                let s = axes
                    .iter()
                    .position(|a| a.name == whole.series[cp.series].sensor)
                    .unwrap();
                let last = axes[s].samples as isize - 1;
                id.bank()
                    .sample_index(s, (cp.sample as isize + d).clamp(0, last) as usize)
            })
            .collect()
    };
    let cols = columns_at(0);
    let predictions = id.bank().read_columns(&cols).unwrap();
    // The discretisation allowance's steps, as identification reads them (the samples either
    // side of each EIP point; the envelope windows' own columns).
    let side = |d: isize| id.bank().read_columns(&columns_at(d)).unwrap();
    let (before, after) = (side(-1), side(1));
    let eip_steps: Vec<Vec<f32>> = (0..cols.len())
        .map(|j| wheelflat::identify::falsify::steps(&[&before[j], &predictions[j], &after[j]]))
        .collect();
    let p = r.per_point_probability;
    let curves: Vec<_> = r
        .eip
        .iter()
        .map(|&e| id.threshold_curve(r.candidates[e].measured_kn, p))
        .chain(
            r.envelope
                .iter()
                .map(|x| id.threshold_curve(x.measured_kn, p)),
        )
        .collect();
    // The envelope points' features: each window's extreme over its bank columns.
    let (features, env_steps): (Vec<Vec<f32>>, Vec<Vec<f32>>) = r
        .envelope
        .iter()
        .map(|x| {
            let axis = id
                .bank()
                .metadata()
                .sensors
                .iter()
                .position(|a| a.name == whole.series[x.series].sensor)
                .unwrap();
            let cols: Vec<usize> = (x.sample - x.half_width..=x.sample + x.half_width)
                .map(|k| id.bank().sample_index(axis, k))
                .collect();
            let data = id.bank().read_columns(&cols).unwrap();
            let refs: Vec<&[f32]> = data.iter().map(Vec::as_slice).collect();
            (
                wheelflat::identify::envelope::feature(
                    &refs,
                    x.kind == wheelflat::identify::envelope::Extreme::Max,
                ),
                wheelflat::identify::falsify::steps(&refs),
            )
        })
        .unzip();
    let mut points: Vec<Point> = r
        .eip
        .iter()
        .zip(&predictions)
        .zip(&curves)
        .enumerate()
        .map(|(j, ((&e, g), c))| Point {
            predictions: g,
            measured_kn: r.candidates[e].measured_kn,
            low_kn: r.candidates[e].threshold_low_kn,
            high_kn: r.candidates[e].threshold_high_kn,
            curve: Some(c),
            discretisation: Discretisation::of(id.discretisation(), &eip_steps, j),
        })
        .collect();
    points.extend(
        wheelflat::identify::envelope::as_points(&r.envelope, &features, &curves[r.eip.len()..])
            .into_iter()
            .enumerate()
            .map(|(j, p)| Point {
                discretisation: Discretisation::of(id.discretisation(), &env_steps, j),
                ..p
            }),
    );
    c.bench_function(
        &format!("falsification_pass_{}_points_{n}_instances", points.len()),
        |b| b.iter(|| falsify(black_box(&points), id.resolution())),
    );

    // The opt-in refinement stage (issue 11: ≤ 2 s on 2 cores), timed on its own: 640
    // simulations in 2 rounds around this measurement's survivors, five sensors.
    let all = id.identify(&m, None, quick).unwrap();
    let sim = wheelflat::model::Simulator::new(&cal).unwrap();
    let settings = wheelflat::identify::refine::RefineSettings::default();
    let mut group = c.benchmark_group("refine");
    group.sample_size(10);
    group.bench_function(
        format!("refine_{}_simulations_{n}_instances", settings.simulations),
        |b| {
            b.iter(|| {
                wheelflat::identify::refine::refine(&id, &sim, black_box(&all), settings).unwrap()
            })
        },
    );
    group.finish();
}

criterion_group!(benches, bench_identify);
criterion_main!(benches);
