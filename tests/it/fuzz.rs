//! Fuzzing the readers of untrusted input with proptest: the measurement CSV parser, the
//! calibration parser and checker, the trigger-file reader, and the decoders of the files a
//! bank keeps beside its shards (column layout, neighbour graph, `CURRENT`). Each target gets
//! random bytes and random mutations (flipped bits, cut, inserted, repeated and swapped spans)
//! of a valid input, and must return a result or an error: never panic, never run long.
//!
//! The seeds are the files of `fuzz/corpus/<target>/` (add one to teach a target a new shape
//! of input) and, for the binary files, inputs built here. CI runs `WHEELFLAT_FUZZ_CASES`
//! cases per target (default 2,000: it is part of `cargo test`); a long run is
//! `WHEELFLAT_FUZZ_CASES=1000000 cargo test --release --test it fuzz::` (times in
//! docs/performance.md). A failure prints the shrunk input that caused it. (proptest rather
//! than `cargo fuzz`: CI has the stable toolchain only.)

use proptest::prelude::*;
use std::path::Path;
use wheelflat::bank::{Layout, ShardLayout};
use wheelflat::identify::Measurement;
use wheelflat::model::Calibration;

fn cases() -> u32 {
    std::env::var("WHEELFLAT_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(2_000)
}

fn config() -> ProptestConfig {
    ProptestConfig {
        cases: cases(),
        // Shrinking a failure is worth its time; persistence files are not kept.
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

/// One mutation of a byte string.
#[derive(Debug, Clone)]
enum Edit {
    Flip(usize, u8),
    Cut(usize),
    Insert(usize, Vec<u8>),
    Repeat(usize, usize),
    Swap(usize, usize, usize),
}

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        (any::<usize>(), 0u8..8).prop_map(|(p, b)| Edit::Flip(p, b)),
        any::<usize>().prop_map(Edit::Cut),
        (
            any::<usize>(),
            proptest::collection::vec(any::<u8>(), 1..24)
        )
            .prop_map(|(p, v)| Edit::Insert(p, v)),
        (any::<usize>(), 1usize..200).prop_map(|(p, n)| Edit::Repeat(p, n)),
        (any::<usize>(), any::<usize>(), 1usize..64).prop_map(|(a, b, n)| Edit::Swap(a, b, n)),
    ]
}

fn apply(seed: &[u8], edits: &[Edit]) -> Vec<u8> {
    let mut v = seed.to_vec();
    for e in edits {
        let at = |p: usize, len: usize| if len == 0 { 0 } else { p % len };
        match e {
            Edit::Flip(p, b) => {
                if !v.is_empty() {
                    let i = at(*p, v.len());
                    v[i] ^= 1 << b;
                }
            }
            Edit::Cut(p) => v.truncate(at(*p, v.len() + 1)),
            Edit::Insert(p, bytes) => {
                let i = at(*p, v.len() + 1);
                v.splice(i..i, bytes.iter().copied());
            }
            Edit::Repeat(p, n) => {
                let i = at(*p, v.len() + 1);
                let end = (i + n).min(v.len());
                let span = v[i..end].to_vec();
                v.splice(end..end, span);
            }
            Edit::Swap(a, b, n) => {
                let len = v.len();
                if len > 2 * n {
                    let (x, y) = (at(*a, len - n), at(*b, len - n));
                    for k in 0..*n {
                        v.swap(x + k, y + k);
                    }
                }
            }
        }
    }
    v
}

/// Random bytes, or a mutation of one of the seeds.
fn input(seeds: Vec<Vec<u8>>) -> impl Strategy<Value = Vec<u8>> {
    let n = seeds.len();
    prop_oneof![
        1 => proptest::collection::vec(any::<u8>(), 0..2048),
        4 => (0..n, proptest::collection::vec(edit(), 1..6))
            .prop_map(move |(i, e)| apply(&seeds[i], &e)),
    ]
}

/// The files of `fuzz/corpus/<target>/`.
fn corpus(target: &str) -> Vec<Vec<u8>> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fuzz/corpus")
        .join(target);
    let mut seeds: Vec<Vec<u8>> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| std::fs::read(e.unwrap().path()).unwrap())
        .collect();
    seeds.sort();
    assert!(!seeds.is_empty(), "{} holds no seed", dir.display());
    seeds
}

fn layout_seed() -> Vec<u8> {
    Layout {
        bank_id: "v-0123456789abcdef".into(),
        metadata_json: "{\"format_version\":2}".into(),
        widths: vec![4, 8, 8, 4, 4],
        shards: (0..2)
            .map(|s| ShardLayout {
                rows: 3,
                file_bytes: 4000,
                footer_bytes: 900,
                offsets: (0..5).map(|j| 100 + 400 * j + s).collect(),
                crc32: (0..5).map(|j| 7 * j as u32 + s as u32).collect(),
            })
            .collect(),
    }
    .encode()
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn measurement_csv(bytes in input(corpus("measurement_csv"))) {
        let text = String::from_utf8_lossy(&bytes);
        let _ = Measurement::from_csv(Path::new("m.csv"), &text, 2500.0);
    }

    #[test]
    fn calibration_toml(bytes in input(corpus("calibration_toml"))) {
        let text = String::from_utf8_lossy(&bytes);
        if let Ok(c) = Calibration::from_toml_str(&text) {
            let _ = c.check();
        }
    }

    #[test]
    fn trigger_file(bytes in input(corpus("trigger_file"))) {
        let text = String::from_utf8_lossy(&bytes);
        let _ = wheelflat::train::read_triggers(Path::new("t.csv"), &text);
    }

    #[test]
    fn column_layout(bytes in input(vec![layout_seed()])) {
        let _ = Layout::decode(Path::new("layout.bin"), &bytes, "v-0123456789abcdef");
    }

    #[test]
    fn neighbour_graph(bytes in input(vec![wheelflat::bank::neighbours::encode(
        "v-0123456789abcdef",
        [51.3, 27.0, 6.2, 800.0],
        &(0..10 * wheelflat::bank::neighbours::NEIGHBOURS as u32).map(|v| v % 10).collect::<Vec<_>>(),
    )])) {
        let _ = wheelflat::bank::neighbours::decode(Path::new("n.bin"), &bytes, "v-0123456789abcdef", 10);
    }

    #[test]
    fn current_pointer(bytes in input(corpus("current_pointer"))) {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("CURRENT"), &bytes).unwrap();
        if let Ok(Some(c)) = wheelflat::bank::read_current(dir.path()) {
            // Whatever it accepts names a directory directly inside the bank.
            prop_assert_eq!(c.version.parent(), Some(dir.path()));
        }
    }
}
