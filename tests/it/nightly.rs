//! The nightly loop end to end (docs/calibration.md, "Drift and the nightly rebuild"): a
//! site whose pad stiffness drops 20 % is found from one night's traffic in the results
//! database, the bank is rebuilt from the new calibration while `watch` keeps answering, and
//! the good wheels the old bank calls flats are quiet again, its flats still sized (about
//! 15 s: two small banks and 80 passes through `watch`).

use crate::common::{
    answered, collect_stdout, drop_file, names_in, narrow_calibration, wait_for, wheelflat_path,
};
use std::path::Path;
use std::process::{Command, Stdio};
use wheelflat::identify::synth::{synthesize, synthesize_pass, FieldNoise};
use wheelflat::identify::Identification;
use wheelflat::model::{Calibration, Flat};

/// Good-wheel pass `k` of calibration `c` (car body 0.9–1.2×: inside one bank's load
/// tolerance with the load's read error, −15 % at 0.86× measured here; errors per Eq. 1).
fn good_pass(c: &Calibration, k: usize) -> String {
    let mut c = c.clone();
    c.vehicle.car_body_mass_kg *= 0.9 + 0.3 * ((k * 7919) % 101) as f64 / 100.0;
    synthesize_pass(
        &c.check().unwrap(),
        None,
        900 + k as u64,
        true,
        FieldNoise::TABLE,
    )
    .unwrap()
    .csv
}

/// Flat `k` of the narrow population on calibration `c`: its CSV and true L0 (mm).
fn flat_pass(c: &Calibration, k: usize) -> (String, f64) {
    let x = k as f64;
    let flat = Flat::from_mm(
        45.0 + (x * 7.3) % 30.0,
        0.35 + (x * 0.037) % 0.2,
        0.03,
        12.32 + (x * 0.013) % 0.16,
    )
    .unwrap();
    let s = synthesize(&c.clone().check().unwrap(), &flat, 300 + k as u64, true).unwrap();
    (s.csv, s.truth.l0_mm)
}

/// How many of the passes `stems` were answered "no flat" (in `out`).
fn quiet(out: &Path, stems: &[String]) -> usize {
    stems
        .iter()
        .filter(|stem| {
            let text = std::fs::read_to_string(out.join(stem).join("identification.json"))
                .unwrap_or_else(|e| panic!("{stem}: {e}"));
            let id: Identification = serde_json::from_str(&text).unwrap();
            id.detection.as_ref().is_some_and(|d| !d.flat_detected)
        })
        .count()
}

/// How many of `names`' answers (in `out`) hold their true L0.
fn held(out: &Path, names: &[(String, f64)]) -> usize {
    names
        .iter()
        .filter(|(stem, l0)| {
            let text = std::fs::read_to_string(out.join(stem).join("identification.json"))
                .unwrap_or_else(|e| panic!("{stem}: {e}"));
            let id: Identification = serde_json::from_str(&text).unwrap();
            id.cms_ranges()
                .is_some_and(|r| r.l0_mm[0] <= *l0 && *l0 <= r.l0_mm[1])
        })
        .count()
}

fn cli(args: &[&str], paths: &[&Path]) -> std::process::Output {
    let mut c = Command::new(wheelflat_path());
    c.args(args);
    for p in paths {
        c.arg(p);
    }
    c.output().unwrap()
}

#[test]
fn a_pad_that_drops_is_found_by_one_nights_traffic_and_the_bank_follows() {
    let tmp = tempfile::tempdir().unwrap();
    let before = narrow_calibration().document().clone();
    let mut after = before.clone();
    after.track.pad_stiffness_n_per_m *= 0.8;
    let before_toml = tmp.path().join("before.toml");
    std::fs::write(&before_toml, before.to_toml_string()).unwrap();
    let bank = tmp.path().join("bank");
    let generate = |toml: &Path| {
        let mut c = Command::new(wheelflat_path());
        c.args(["bank", "generate", "--defer-tables", "--instances", "1200"])
            .arg("--calibration")
            .arg(toml)
            .arg("--out")
            .arg(&bank)
            .stdout(Stdio::null())
            .stderr(Stdio::null());
        c
    };
    assert!(generate(&before_toml).status().unwrap().success());
    let (inbox, out, db) = (
        tmp.path().join("inbox"),
        tmp.path().join("out"),
        tmp.path().join("results.sqlite"),
    );
    std::fs::create_dir_all(&inbox).unwrap();
    let mut watcher = Command::new(wheelflat_path())
        .args(["watch", "--poll-ms", "20", "--bank"])
        .arg(&bank)
        .arg("--inbox")
        .arg(&inbox)
        .arg("--out")
        .arg(&out)
        .arg("--db")
        .arg(&db)
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .unwrap();
    let log_lines = collect_stdout(&mut watcher);
    let dropped = std::cell::Cell::new(0);
    let mut drop = |name: String, text: &str| {
        drop_file(&inbox, &name, text);
        dropped.set(dropped.get() + 1);
        dropped.get()
    };
    let failed = inbox.join("failed");
    let answered = |n: usize| answered(&inbox, n);
    let flats = |c: &Calibration, tag: &str, drop: &mut dyn FnMut(String, &str) -> usize| {
        (0..10)
            .map(|k| {
                let (csv, l0) = flat_pass(c, k);
                let stem = format!("{tag}-flat-{k:02}");
                drop(format!("{stem}.csv"), &csv);
                (stem, l0)
            })
            .collect::<Vec<_>>()
    };

    // Last week: the site as banked; its flats on the bank.
    let a = flats(&before, "a", &mut drop);
    // Tonight: the pads have dropped 20 %: 40 good wheels and the same flats.
    let goods = |ks: std::ops::Range<usize>, drop: &mut dyn FnMut(String, &str) -> usize| {
        ks.map(|k| {
            drop(format!("night-{k:02}.csv"), &good_pass(&after, k));
            format!("night-{k:02}")
        })
        .collect::<Vec<_>>()
    };
    let night = goods(0..40, &mut drop);
    let b = flats(&after, "b", &mut drop);
    wait_for(300, "the night's passes", answered(dropped.get()));

    // The nightly check, from the results database.
    let new = tmp.path().join("new.toml");
    let check = cli(
        &["calibrate", "--check", "--db"],
        &[
            &db,
            Path::new("--calibration"),
            &before_toml,
            Path::new("--out"),
            &new,
            Path::new("--report"),
            &tmp.path().join("night.json"),
        ],
    );
    let text = String::from_utf8_lossy(&check.stdout).to_string()
        + &String::from_utf8_lossy(&check.stderr);
    println!("{text}");
    assert_eq!(check.status.code(), Some(3), "{text}");
    assert!(text.contains("drifted: support stiffness factor"), "{text}");
    assert!(text.contains("answered \"no flat\" or"), "{text}");

    // The rebuild, while passes keep arriving.
    let mut regen = generate(&new).spawn().unwrap();
    for k in 40..45 {
        drop(format!("night-{k:02}.csv"), &good_pass(&after, k));
        std::thread::sleep(std::time::Duration::from_millis(200));
    }
    assert!(regen.wait().unwrap().success());
    wait_for(
        120,
        "the passes during the rebuild",
        answered(dropped.get()),
    );
    // After the switch: tonight's flats again, and ten more good wheels.
    let c = flats(&after, "c", &mut drop);
    let morning = goods(50..60, &mut drop);
    wait_for(120, "the flats on the new bank", answered(dropped.get()));
    crate::common::terminate(&watcher);
    assert!(watcher.wait().unwrap().success());
    let lines = log_lines.join().unwrap();
    assert!(
        lines.iter().any(|l| l.contains("bank switched to")),
        "{lines:?}"
    );
    let why: Vec<String> = names_in(&failed)
        .iter()
        .filter(|n| n.ends_with(".error.txt"))
        .map(|n| std::fs::read_to_string(failed.join(n)).unwrap())
        .collect();
    assert!(why.is_empty(), "{why:?}");
    let (ha, hb, hc) = (held(&out, &a), held(&out, &b), held(&out, &c));
    let (q_old, q_new) = (quiet(&out, &night), quiet(&out, &morning));
    println!(
        "flats held: before the drop {ha}/10, after it on the old bank {hb}/10, on the rebuilt bank {hc}/10; good wheels quiet: on the old bank {q_old}/40, on the rebuilt one {q_new}/10"
    );
    // What the drop broke: the good wheels (measured: 34 of 40 "a flat below the
    // population", severity inspect, on the old bank; the test asks for most).
    assert!(2 * q_old < night.len(), "old bank: {q_old} of 40 quiet");
    // Restored: the rebuilt bank's good wheels quiet, and it holds the drifted site's flats as
    // the old bank held the site's before (one flat of ten either way: the 1,200-instance
    // banks' own scatter).
    assert!(q_new >= 9, "rebuilt bank: {q_new} of 10 quiet");
    assert!(hc + 1 >= ha, "before {ha}, rebuilt {hc}");
}
