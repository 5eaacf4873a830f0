//! The column layout stored beside a plain bank (`layout.bin`): reading through it gives
//! exactly what the Parquet decoder gives, compressed banks have none, older banks get one,
//! and a layout or shard that does not match is refused by open and by verify.

use crate::common;
use crate::common::{options, small_calibration};
use std::path::{Path, PathBuf};
use wheelflat::bank::{self, Bank, Codec, GenerateOptions, Outcome, Quiet, StorageFormat};
use wheelflat::model::CheckedCalibration;

/// The schema index of the first force-sample column (after the instance and parameter columns).
const FIRST_SAMPLE: usize = 1 + wheelflat::bank::schema::PARAMETER_COLUMNS.len();

fn calibration() -> CheckedCalibration {
    small_calibration(60).check().unwrap()
}

fn generate(cal: &CheckedCalibration, out: &Path, opts: &GenerateOptions) -> Outcome {
    bank::generate(cal, out, opts, &Quiet).unwrap()
}

fn manifest_of(version: &Path) -> bank::Manifest {
    serde_json::from_str(&std::fs::read_to_string(version.join("manifest.json")).unwrap()).unwrap()
}

fn write_manifest(version: &Path, m: &bank::Manifest) {
    common::write_manifest(version, m);
}

/// A plain bank of 45 instances in three shards; its version directory.
fn plain_bank(dir: &Path) -> PathBuf {
    match generate(&calibration(), dir, &options(45, 16)) {
        Outcome::Complete { version, .. } => version,
        other => panic!("{other:?}"),
    }
}

/// A copy of a version directory whose manifest lists no layout: read through the footers.
fn without_layout(version: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(version).unwrap() {
        let e = e.unwrap();
        if e.file_name() != "layout.bin" {
            std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
        }
    }
    let mut m = manifest_of(to);
    m.layout = None;
    write_manifest(to, &m);
}

#[test]
fn reading_through_the_layout_gives_what_the_decoder_gives() {
    let dir = tempfile::tempdir().unwrap();
    let version = plain_bank(dir.path());
    assert!(manifest_of(&version).layout.is_some());
    let footers = dir.path().join("footers");
    without_layout(&version, &footers);

    let fast = Bank::open(dir.path()).unwrap();
    let slow = Bank::open(&footers).unwrap();
    assert_eq!(fast.metadata(), slow.metadata());
    assert_eq!(
        fast.read_parameters().unwrap(),
        slow.read_parameters().unwrap()
    );
    // Columns in an unsorted order with a repeat, spanning every sensor and both ends.
    let last = fast.sample_index(4, 59);
    let cols = [
        last,
        FIRST_SAMPLE,
        fast.sample_index(2, 30),
        FIRST_SAMPLE,
        fast.sample_index(0, 0),
    ];
    assert_eq!(
        fast.read_columns(&cols).unwrap(),
        slow.read_columns(&cols).unwrap()
    );
    for i in [0, 15, 16, 31, 44] {
        assert_eq!(
            fast.read_instance(i).unwrap(),
            slow.read_instance(i).unwrap(),
            "instance {i}"
        );
    }
    // A parameter column is not a force column, on either path.
    assert!(fast.read_columns(&[2]).is_err());
    assert!(slow.read_columns(&[2]).is_err());
    let (_, problems) = bank::verify(dir.path()).unwrap();
    assert!(problems.is_empty(), "{problems:?}");
}

#[test]
fn a_compressed_bank_has_no_layout_and_reads_the_same() {
    let dir = tempfile::tempdir().unwrap();
    let version = plain_bank(&dir.path().join("plain"));
    let zstd = GenerateOptions {
        format: StorageFormat {
            codec: Codec::Zstd,
            ..StorageFormat::default()
        },
        ..options(45, 16)
    };
    let Outcome::Complete { version: zv, .. } =
        generate(&calibration(), &dir.path().join("zstd"), &zstd)
    else {
        panic!()
    };
    assert!(manifest_of(&zv).layout.is_none());
    assert!(!zv.join("layout.bin").exists());
    let (a, b) = (Bank::open(&version).unwrap(), Bank::open(&zv).unwrap());
    let cols: Vec<usize> = (FIRST_SAMPLE..FIRST_SAMPLE + 300).step_by(13).collect();
    assert_eq!(
        a.read_columns(&cols).unwrap(),
        b.read_columns(&cols).unwrap()
    );
    assert_eq!(a.read_instance(40).unwrap(), b.read_instance(40).unwrap());
}

#[test]
fn a_bank_without_a_layout_gets_one_from_generate() {
    let dir = tempfile::tempdir().unwrap();
    let version = plain_bank(dir.path());
    let stored = std::fs::read(version.join("layout.bin")).unwrap();
    let mut m = manifest_of(&version);
    let entry = m.layout.take().unwrap();
    write_manifest(&version, &m);
    std::fs::remove_file(version.join("layout.bin")).unwrap();
    let before = Bank::open(dir.path()).unwrap().read_instance(20).unwrap();
    let Outcome::UpToDate { upgraded, .. } = generate(&calibration(), dir.path(), &options(45, 16))
    else {
        panic!()
    };
    assert!(upgraded);
    assert_eq!(std::fs::read(version.join("layout.bin")).unwrap(), stored);
    assert_eq!(manifest_of(&version).layout, Some(entry));
    assert_eq!(
        Bank::open(dir.path()).unwrap().read_instance(20).unwrap(),
        before
    );
    let Outcome::UpToDate { upgraded, .. } = generate(&calibration(), dir.path(), &options(45, 16))
    else {
        panic!()
    };
    assert!(!upgraded, "a second run has nothing to add");
}

#[test]
fn a_layout_or_shard_that_does_not_match_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let version = plain_bank(dir.path());
    let layout_path = version.join("layout.bin");
    let good = std::fs::read(&layout_path).unwrap();

    // One flipped bit: the manifest's SHA-256 no longer matches.
    let mut flipped = good.clone();
    let at = flipped.len() - 3;
    flipped[at] ^= 1;
    std::fs::write(&layout_path, &flipped).unwrap();
    let err = Bank::open(dir.path()).unwrap_err().to_string();
    assert!(
        err.contains("layout.bin") && err.contains("sha256"),
        "{err}"
    );

    // A consistent but wrong layout (an offset moved by one value, the manifest updated to
    // match): open trusts the checksum, verify compares it with the footers and refuses it.
    let mut layout =
        bank::Layout::decode(&layout_path, &good, &manifest_of(&version).bank_id).unwrap();
    layout.shards[1].offsets[9] -= 4;
    let bytes = layout.encode();
    std::fs::write(&layout_path, &bytes).unwrap();
    let mut m = manifest_of(&version);
    let entry = m.layout.as_mut().unwrap();
    entry.sha256 = bank::schema::sha256_hex(&bytes);
    entry.bytes = bytes.len() as u64;
    write_manifest(&version, &m);
    let (_, problems) = bank::verify(dir.path()).unwrap();
    assert_eq!(problems.len(), 1, "{problems:?}");
    assert!(
        problems[0].path == layout_path && problems[0].message.contains("does not match"),
        "{problems:?}"
    );

    // Back to the good layout; a shard swapped for another of the same bank (other size):
    // open refuses it, naming the shard.
    std::fs::write(&layout_path, &good).unwrap();
    let mut m = manifest_of(&version);
    let entry = m.layout.as_mut().unwrap();
    entry.sha256 = bank::schema::sha256_hex(&good);
    entry.bytes = good.len() as u64;
    write_manifest(&version, &m);
    Bank::open(dir.path()).unwrap();
    let (s1, s2) = (
        version.join(&m.files[1].name),
        version.join(&m.files[2].name),
    );
    std::fs::copy(&s2, &s1).unwrap();
    let err = Bank::open(dir.path()).unwrap_err().to_string();
    assert!(err.contains(&m.files[1].name), "{err}");
}
