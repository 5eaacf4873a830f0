//! The model bank on small populations and short windows: determinism across thread counts,
//! resume after interruption, shards, regeneration, the memory-mapped reader, verification,
//! and interoperability with pyarrow.

use crate::common;
use crate::common::{files, options, small_calibration};
use std::io::Write as _;
use std::path::Path;
use wheelflat::bank::{self, Bank, GenerateOptions, Outcome, Quiet};
use wheelflat::model::{CheckedCalibration, Flat, Record, Simulator};

/// Short windows keep the bank small: 5 sensors × 100 samples.
fn bank_calibration() -> CheckedCalibration {
    small_calibration(100).check().unwrap()
}

fn generate_with_threads(
    cal: &CheckedCalibration,
    out: &Path,
    opts: &GenerateOptions,
    threads: usize,
) -> Outcome {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| bank::generate(cal, out, opts, &Quiet))
        .unwrap()
}

#[test]
fn same_inputs_give_identical_bytes_with_one_or_two_threads() {
    let cal = bank_calibration();
    let opts = options(48, 16);
    let a = tempfile::tempdir().unwrap();
    let b = tempfile::tempdir().unwrap();
    generate_with_threads(&cal, a.path(), &opts, 1);
    generate_with_threads(&cal, b.path(), &opts, 2);
    let (sa, sb) = (files(a.path(), &[]), files(b.path(), &[]));
    assert_eq!(
        sa.len(),
        3 + 5,
        "3 shard files + neighbour graph + column layout + manifest + CURRENT + writer lock \
         (the tables a pass needs: their own test, on 2 threads then 1)"
    );
    assert!(sa == sb, "banks differ between 1 and 2 threads");
}

#[test]
fn stored_series_equal_a_fresh_simulation_of_the_instance() {
    let cal = bank_calibration();
    let dir = tempfile::tempdir().unwrap();
    generate_with_threads(&cal, dir.path(), &options(30, 10), 2);
    let bank = Bank::open(dir.path()).unwrap();
    assert_eq!(bank.instances(), 30);
    let params = bank.read_parameters().unwrap();
    assert_eq!(params.instance, (0..30).collect::<Vec<u32>>());
    let sim = Simulator::new(&cal).unwrap();
    let axes = &bank.metadata().sensors;
    for i in [0usize, 17, 29] {
        let flat = Flat::from_mm(
            params.length_mm[i],
            params.depth_mm[i],
            params.curvature_mm[i],
            params.impact_position_m[i],
        )
        .unwrap();
        let resp = sim.run(Some(&flat), Record::default()).unwrap();
        for (s, axis) in axes.iter().enumerate() {
            let cols: Vec<usize> = (0..axis.samples).map(|k| bank.sample_index(s, k)).collect();
            let stored = bank.read_columns(&cols).unwrap();
            let fresh = resp.window(s, axis.first_sample, axis.samples);
            for k in 0..axis.samples {
                assert!(
                    stored[k][i] == (fresh[k] / 1e3) as f32,
                    "instance {i} {} sample {k}",
                    axis.name
                );
            }
        }
        assert!((params.l0_mm[i] - (8.0 * params.depth_mm[i] * 400.0).sqrt()).abs() < 1e-9);
    }
    // Columns come back in the order asked, duplicates included.
    let c = [
        bank.sample_index(1, 50),
        bank.sample_index(0, 3),
        bank.sample_index(1, 50),
    ];
    let v = bank.read_columns(&c).unwrap();
    let w = bank.read_columns(&[c[1]]).unwrap();
    assert!(v[1] == w[0] && v[0] == v[2]);
}

#[test]
fn interrupted_run_resumes_and_ends_byte_identical() {
    let cal = bank_calibration();
    let opts = options(45, 15);
    let whole = tempfile::tempdir().unwrap();
    generate_with_threads(&cal, whole.path(), &opts, 2);

    // An "interrupted" run: the first shard file finished, a half-written temporary left behind.
    let resumed = tempfile::tempdir().unwrap();
    let first = GenerateOptions {
        machine_shard: Some((0, 3)),
        ..opts.clone()
    };
    generate_with_threads(&cal, resumed.path(), &first, 2);
    let version = bank::generate::version_dir(resumed.path(), &cal, &opts);
    std::fs::write(
        version.join(".shard-00001-of-00003.parquet.tmp"),
        b"half a file",
    )
    .unwrap();
    assert!(
        !resumed.path().join("CURRENT").exists(),
        "no pointer before the bank is complete"
    );

    match generate_with_threads(&cal, resumed.path(), &opts, 2) {
        Outcome::Complete {
            simulated, resumed, ..
        } => assert_eq!((simulated, resumed), (30, 15)),
        o => panic!("{o:?}"),
    }
    assert!(
        files(whole.path(), &[]) == files(resumed.path(), &[]),
        "resumed bank differs"
    );
}

/// Regression: a shard file of the same bank id but other metadata (here written with another
/// `[identification]`, which changes the stored calibration and its checksum but not the id)
/// was kept on resume, so one bank's shards could disagree in their metadata.
#[test]
fn resume_simulates_again_a_shard_written_with_other_metadata() {
    let cal = bank_calibration();
    let opts = options(45, 15);
    let whole = tempfile::tempdir().unwrap();
    generate_with_threads(&cal, whole.path(), &opts, 2);

    let mut doc = cal.document().clone();
    doc.identification.phi = 0.9;
    let other = doc.check().unwrap();
    let resumed = tempfile::tempdir().unwrap();
    let first = GenerateOptions {
        machine_shard: Some((0, 3)),
        ..opts.clone()
    };
    generate_with_threads(&other, resumed.path(), &first, 2);
    match generate_with_threads(&cal, resumed.path(), &opts, 2) {
        Outcome::Complete {
            simulated, resumed, ..
        } => assert_eq!((simulated, resumed), (45, 0)),
        o => panic!("{o:?}"),
    }
    assert!(
        files(whole.path(), &[]) == files(resumed.path(), &[]),
        "resumed bank differs"
    );
}

#[test]
fn union_of_shards_equals_a_single_run_and_merge_names_missing_files() {
    let cal = bank_calibration();
    let opts = options(40, 10);
    let single = tempfile::tempdir().unwrap();
    generate_with_threads(&cal, single.path(), &opts, 2);

    let sharded = tempfile::tempdir().unwrap();
    let merge = GenerateOptions {
        simulate_missing: false,
        ..opts.clone()
    };
    generate_with_threads(
        &cal,
        sharded.path(),
        &GenerateOptions {
            machine_shard: Some((1, 2)),
            ..opts.clone()
        },
        1,
    );
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let err = pool
        .install(|| bank::generate(&cal, sharded.path(), &merge, &Quiet))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("shard-00000-of-00004.parquet")
            && err.contains("shard-00001-of-00004.parquet"),
        "{err}"
    );
    assert!(!err.contains("shard-00002"), "{err}");

    generate_with_threads(
        &cal,
        sharded.path(),
        &GenerateOptions {
            machine_shard: Some((0, 2)),
            ..opts.clone()
        },
        2,
    );
    match generate_with_threads(&cal, sharded.path(), &merge, 1) {
        Outcome::Complete { simulated, .. } => assert_eq!(simulated, 0),
        o => panic!("{o:?}"),
    }
    assert!(
        files(single.path(), &[]) == files(sharded.path(), &[]),
        "union of shards differs"
    );
}

#[test]
fn up_to_date_bank_is_left_alone_and_a_new_calibration_builds_beside_it() {
    let cal = bank_calibration();
    let opts = options(12, 6);
    let dir = tempfile::tempdir().unwrap();
    let Outcome::Complete { version: v1, .. } = generate_with_threads(&cal, dir.path(), &opts, 2)
    else {
        panic!()
    };
    let before = files(dir.path(), &[]);
    assert!(matches!(
        generate_with_threads(&cal, dir.path(), &opts, 2),
        Outcome::UpToDate { .. }
    ));
    assert!(before == files(dir.path(), &[]));

    let mut changed = cal.document().clone();
    changed.track.pad_stiffness_n_per_m *= 1.1;
    let changed = changed.check().unwrap();
    let Outcome::Complete { version: v2, .. } =
        generate_with_threads(&changed, dir.path(), &opts, 2)
    else {
        panic!()
    };
    assert_ne!(v1, v2);
    assert!(v1.join("manifest.json").is_file(), "the old version stays");
    let current = std::fs::read_to_string(dir.path().join("CURRENT")).unwrap();
    assert_eq!(
        current.lines().next().unwrap(),
        v2.file_name().unwrap().to_string_lossy()
    );
    let bank = Bank::open(dir.path()).unwrap();
    assert_eq!(bank.metadata().calibration, *changed.document());
}

#[test]
fn corrupt_or_truncated_files_are_named_never_a_panic() {
    let cal = bank_calibration();
    let dir = tempfile::tempdir().unwrap();
    let Outcome::Complete { version, .. } =
        generate_with_threads(&cal, dir.path(), &options(12, 6), 2)
    else {
        panic!()
    };
    let (_, problems) = bank::verify(dir.path()).unwrap();
    assert!(problems.is_empty());

    let f0 = version.join("shard-00000-of-00002.parquet");
    let mut bytes = std::fs::read(&f0).unwrap();
    bytes[1000] ^= 0xff;
    std::fs::write(&f0, &bytes).unwrap();
    let f1 = version.join("shard-00001-of-00002.parquet");
    let len = std::fs::metadata(&f1).unwrap().len();
    std::fs::OpenOptions::new()
        .write(true)
        .open(&f1)
        .unwrap()
        .set_len(len / 2)
        .unwrap();

    let (_, problems) = bank::verify(dir.path()).unwrap();
    assert_eq!(problems.len(), 2);
    assert!(
        problems[0].path == f0 && problems[0].message.contains("checksum mismatch"),
        "{problems:?}"
    );
    assert!(
        problems[1].path == f1 && problems[1].message.contains("truncated"),
        "{problems:?}"
    );
    let err = Bank::open(dir.path()).unwrap_err().to_string();
    assert!(err.contains("shard-00001-of-00002.parquet"), "{err}");

    let err = Bank::open(Path::new("/nonexistent/bank"))
        .unwrap_err()
        .to_string();
    assert!(err.contains("not a wheelflat bank"), "{err}");
}

/// The tables a pass needs (`bank::derived`): built with the bank, before `CURRENT` points at
/// it, so a first pass of every kind reads them and writes nothing; lost or damaged, they are
/// built again by the next `generate`, the same bytes on one thread as on two.
#[test]
fn a_bank_is_built_with_the_tables_a_pass_needs_and_a_first_pass_builds_nothing() {
    use wheelflat::identify::{Comparison, Identifier};
    let cal = common::narrow_calibration();
    let dir = tempfile::tempdir().unwrap();
    let opts = GenerateOptions {
        tables: true,
        ..options(40, 20)
    };
    let Outcome::Complete { version, .. } = generate_with_threads(&cal, dir.path(), &opts, 2)
    else {
        panic!()
    };
    let tables = [
        "departures.bin",
        "departures-binomial5.bin",
        "roughness.json",
        "out-of-round.bin",
    ];
    for t in tables {
        assert!(version.join(t).is_file(), "{t} is built with the bank");
    }
    let built = files(dir.path(), &[]);
    let id = Identifier::new(Bank::open(dir.path()).unwrap(), cal.identification.clone()).unwrap();
    id.departures(Comparison::Samples).unwrap();
    id.departures(Comparison::Binomial5).unwrap();
    id.roughness_table().unwrap();
    id.out_of_round_basis().unwrap();
    assert!(
        built == files(dir.path(), &[]),
        "a first pass found every table: nothing written"
    );
    // Two lost, two damaged: the next generate, on one thread, builds them again byte for byte.
    for t in ["out-of-round.bin", "departures-binomial5.bin"] {
        std::fs::remove_file(version.join(t)).unwrap();
    }
    for t in ["departures.bin", "roughness.json"] {
        let mut bytes = std::fs::read(version.join(t)).unwrap();
        bytes[40] ^= 0x55;
        std::fs::write(version.join(t), &bytes).unwrap();
    }
    assert!(matches!(
        generate_with_threads(&cal, dir.path(), &opts, 1),
        Outcome::UpToDate { upgraded: true, .. }
    ));
    assert!(
        built == files(dir.path(), &[]),
        "rebuilt byte for byte, on one thread as on two"
    );
}

/// A complete 40-instance bank of `cal` in a temporary folder, and its version directory.
fn complete_bank(cal: &CheckedCalibration) -> (tempfile::TempDir, std::path::PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let Outcome::Complete { version, .. } =
        generate_with_threads(cal, dir.path(), &options(40, 16), 2)
    else {
        panic!()
    };
    (dir, version)
}

#[test]
fn the_stored_neighbour_graph_is_the_one_searched_from_the_stored_parameters() {
    let cal = bank_calibration();
    let (dir, version) = complete_bank(&cal);
    let bank = Bank::open(dir.path()).unwrap();
    let searched =
        bank::neighbours::neighbour_graph(&bank.read_parameters().unwrap(), &cal.population);
    assert_eq!(bank.neighbours(), Some(searched.as_slice()));

    // A bank written before the graph was stored: no entry, the reader has none; generate
    // on the up-to-date bank adds it, and then it is the same graph.
    let mut manifest = bank::read_manifest(&version).unwrap();
    manifest.neighbours = None;
    common::write_manifest(&version, &manifest);
    std::fs::remove_file(version.join("neighbours.bin")).unwrap();
    assert_eq!(Bank::open(dir.path()).unwrap().neighbours(), None);
    assert!(matches!(
        generate_with_threads(&cal, dir.path(), &options(40, 16), 1),
        Outcome::UpToDate { .. }
    ));
    assert_eq!(
        Bank::open(dir.path()).unwrap().neighbours(),
        Some(searched.as_slice())
    );

    // One flipped bit in the graph: open and verify refuse it, naming the file.
    let path = version.join("neighbours.bin");
    let mut bytes = std::fs::read(&path).unwrap();
    bytes[100] ^= 1;
    std::fs::write(&path, &bytes).unwrap();
    let err = Bank::open(dir.path()).unwrap_err().to_string();
    assert!(
        err.contains("neighbours.bin") && err.contains("sha256"),
        "{err}"
    );
    let (_, problems) = bank::verify(dir.path()).unwrap();
    assert_eq!(problems.len(), 1, "{problems:?}");
    assert!(problems[0].path == path, "{problems:?}");
}

/// A bank whose graph was written in the earlier format (searched in the plain unit cube,
/// magic `WFNEIGH1`) still opens and verifies, is identified with the graph of today's
/// stretched metric (searched at open), and `generate` on the up-to-date bank replaces the
/// file with today's format and weights.
#[test]
fn an_earlier_neighbour_graph_is_searched_again_and_replaced_by_generate() {
    use wheelflat::bank::neighbours::{cell_weights, neighbour_graph, neighbour_graph_weighted};
    let cal = bank_calibration();
    let (dir, version) = complete_bank(&cal);
    let bank = Bank::open(dir.path()).unwrap();
    let params = bank.read_parameters().unwrap();
    let weights = cell_weights(&cal.population);
    assert_eq!(bank.neighbour_weights(), Some(weights));
    let today = neighbour_graph(&params, &cal.population);
    let plain = neighbour_graph_weighted(&params, &cal.population, [1.0; 4]);
    assert_ne!(today, plain, "the stretched metric changes the graph");
    // Write the plain graph in the earlier format: magic, count, k, id, indices.
    let id = bank.metadata().bank_id.clone();
    let mut bytes = b"WFNEIGH1".to_vec();
    bytes.extend_from_slice(&(params.length_mm.len() as u64).to_le_bytes());
    bytes.extend_from_slice(&(bank::neighbours::NEIGHBOURS as u32).to_le_bytes());
    bytes.extend_from_slice(&(id.len() as u32).to_le_bytes());
    bytes.extend_from_slice(id.as_bytes());
    for v in &plain {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    std::fs::write(version.join("neighbours.bin"), &bytes).unwrap();
    let mut manifest = bank::read_manifest(&version).unwrap();
    let aux = manifest.neighbours.as_mut().unwrap();
    aux.bytes = bytes.len() as u64;
    aux.sha256 = bank::schema::sha256_hex(&bytes);
    common::write_manifest(&version, &manifest);
    let earlier = Bank::open(dir.path()).unwrap();
    assert_eq!(earlier.neighbour_weights(), Some([1.0; 4]));
    assert_eq!(earlier.neighbours(), Some(plain.as_slice()));
    assert!(bank::verify(dir.path()).unwrap().1.is_empty());
    // Identification does not use a graph of another metric: it searches today's.
    let identifier =
        wheelflat::identify::Identifier::new(earlier, cal.identification.clone()).unwrap();
    let cells = identifier.resolution().unwrap().cells;
    for i in 0..params.length_mm.len() {
        assert_eq!(
            cells.neighbours(i),
            &today[i * 8..(i + 1) * 8],
            "instance {i}"
        );
    }
    // generate on the up-to-date bank writes today's graph.
    assert!(matches!(
        generate_with_threads(&cal, dir.path(), &options(40, 16), 1),
        Outcome::UpToDate { .. }
    ));
    let renewed = Bank::open(dir.path()).unwrap();
    assert_eq!(renewed.neighbour_weights(), Some(weights));
    assert_eq!(renewed.neighbours(), Some(today.as_slice()));
    assert!(std::fs::read(version.join("neighbours.bin"))
        .unwrap()
        .starts_with(b"WFNEIGH2"));
}

/// The interop check runs a Python script with pyarrow, with the interpreter in
/// `WHEELFLAT_PYTHON` (`.ci/run` points it at a virtual environment that has pyarrow), else
/// `python3`. Under CI ([`common::under_ci`]) an interpreter without pyarrow fails the test; elsewhere
/// the test is skipped with a notice on the terminal.
#[test]
fn pyarrow_reads_shape_column_names_and_metadata() {
    let (python, missing) = common::python_with("pyarrow");
    if let Some(why) = missing {
        let install = format!(
            "install it with `{python} -m pip install 'pyarrow>=15'`, or run `.ci/run`, which \
             installs it into .ci/venv and sets WHEELFLAT_PYTHON"
        );
        assert!(
            !common::under_ci(),
            "under CI the pyarrow interop check must run, but `{python}` cannot import \
             pyarrow: {why}\n{install}"
        );
        // Written past the test harness's output capture, so that the skip is seen.
        let _ = writeln!(
            std::io::stderr(),
            "pyarrow_reads_shape_column_names_and_metadata skipped: `{python}` cannot import \
             pyarrow; {install}"
        );
        return;
    }
    let cal = bank_calibration();
    let dir = tempfile::tempdir().unwrap();
    generate_with_threads(&cal, dir.path(), &options(20, 10), 2);
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/interop/read_bank.py");
    let out = std::process::Command::new(&python)
        .arg(&script)
        .arg(dir.path())
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("rows 20"), "{stdout}");
    assert!(stdout.contains("columns 508"), "{stdout}");
    assert!(
        stdout.contains("first sample column rps1_t0000"),
        "{stdout}"
    );
    assert!(stdout.contains("metadata instances 20"), "{stdout}");
}
