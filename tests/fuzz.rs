//! Fuzzing the readers of untrusted input with proptest: the measurement CSV parser, the
//! calibration parser and checker, the trigger-file reader, and the decoders of the files a
//! bank keeps beside its shards (column layout, neighbour graph, `CURRENT`). Each target gets
//! random bytes and random mutations (flipped bits, cut, inserted, repeated and swapped spans)
//! of a valid input, and must return a result or an error: never panic, never run long.
//!
//! CI runs `WHEELFLAT_FUZZ_CASES` cases per target (default 2,000); a long run is
//! `WHEELFLAT_FUZZ_CASES=1000000 cargo test --release --test fuzz` (times in
//! docs/performance.md). A failure prints the shrunk input that caused it.

use proptest::prelude::*;
use std::path::Path;
use wheelflat::bank::layout::{Layout, ShardLayout};
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

/// Random bytes, or a mutated valid input.
fn input(seed: Vec<u8>) -> impl Strategy<Value = Vec<u8>> {
    prop_oneof![
        1 => proptest::collection::vec(any::<u8>(), 0..2048),
        4 => proptest::collection::vec(edit(), 1..6).prop_map(move |e| apply(&seed, &e)),
    ]
}

fn measurement_seed() -> Vec<u8> {
    let mut s =
        String::from("# laser_trigger_s = 0.25\n# speed_km_per_h = 50\ntime_s,rps1_kn,rps2_kn\n");
    for k in 0..120 {
        let t = k as f64 / 2500.0;
        s.push_str(&format!(
            "{t:.6},{:.3},{:.3}\n",
            40.0 + (k as f64).sin(),
            12.5
        ));
    }
    s.into_bytes()
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
    fn measurement_csv(bytes in input(measurement_seed())) {
        let text = String::from_utf8_lossy(&bytes);
        let _ = Measurement::from_csv(Path::new("m.csv"), &text, 2500.0);
    }

    #[test]
    fn calibration_toml(bytes in input(Calibration::default().to_toml_string().into_bytes())) {
        let text = String::from_utf8_lossy(&bytes);
        if let Ok(c) = Calibration::from_toml_str(&text) {
            let _ = c.check();
        }
    }

    #[test]
    fn trigger_file(bytes in input(b"time_s\n0.10\n0.22\n1.30\n1.42\n".to_vec())) {
        let text = String::from_utf8_lossy(&bytes);
        let _ = wheelflat::train::read_triggers(Path::new("t.csv"), &text);
    }

    #[test]
    fn column_layout(bytes in input(layout_seed())) {
        let _ = Layout::decode(Path::new("layout.bin"), &bytes, "v-0123456789abcdef");
    }

    #[test]
    fn neighbour_graph(bytes in input(wheelflat::bank::neighbours::encode(
        "v-0123456789abcdef",
        &(0..10 * wheelflat::bank::neighbours::NEIGHBOURS as u32).map(|v| v % 10).collect::<Vec<_>>(),
    ))) {
        let _ = wheelflat::bank::neighbours::decode(Path::new("n.bin"), &bytes, "v-0123456789abcdef", 10);
    }

    #[test]
    fn current_pointer(bytes in input(wheelflat::bank::version::current_text("v-0123456789abcdef", b"{}").into_bytes())) {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("CURRENT"), &bytes).unwrap();
        if let Ok(Some(c)) = wheelflat::bank::version::read_current(dir.path()) {
            // Whatever it accepts names a directory directly inside the bank.
            prop_assert_eq!(c.version.parent(), Some(dir.path()));
        }
    }
}
