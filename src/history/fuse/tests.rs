//! Tests of the fusion.
use super::*;
use crate::history::record::Space;
use crate::model::WheelPosition;

fn space() -> Space {
    Space {
        length_mm: [10.0, 200.0],
        depth_mm: [0.1, 1.0],
        curvature_mm: [0.0, 0.5],
        wheel_radius_m: 0.46,
    }
}

/// A flat pass whose cells form one box around (L, d), c over [0, 0.1].
fn flat(l: [f32; 2], d: [f32; 2]) -> WheelPass {
    let s = space();
    WheelPass {
        wheel: WheelPosition::Leading,
        claim: Claim::Flat,
        l0_mm: Some([s.l0_mm(d[0].into()), s.l0_mm(d[1].into())]),
        severity: None,
        space: s,
        limit_l0_mm: None,
        boxes: vec![[l[0], l[1], d[0], d[1], 0.0, 0.1]],
        dynamic_ratio: None,
    }
}

fn good() -> WheelPass {
    WheelPass {
        claim: Claim::None,
        boxes: Vec::new(),
        l0_mm: None,
        ..flat([0.0, 0.0], [0.1, 0.1])
    }
}

const TRUTH: [f64; 3] = [60.0, 0.5, 0.05];

#[test]
fn the_joint_answer_is_narrower_than_each_pass_and_holds_the_truth() {
    let passes = [
        flat([40.0, 80.0], [0.40, 0.60]),
        flat([50.0, 90.0], [0.45, 0.65]),
        flat([30.0, 70.0], [0.35, 0.55]),
    ];
    let j = fuse(&passes, FusionRule::All, 0.95, 40.0, 25.0);
    assert_eq!(j.agreement, Agreement::Consistent);
    assert!(j.allows(Some(TRUTH)));
    let d = j.depth_mm.unwrap();
    // [0.45, 0.55] up to one grid bin (0.01 mm) each side.
    assert!(
        (d[0] - 0.45).abs() <= 0.011 && (d[1] - 0.55).abs() <= 0.011,
        "{d:?}"
    );
    assert!(!j.no_flat && !j.below);
}

#[test]
fn one_pass_that_lost_the_truth_cannot_take_it_out_under_all_but_one() {
    let passes = [
        flat([40.0, 80.0], [0.40, 0.60]),
        flat([150.0, 190.0], [0.40, 0.60]), // lost it: another length
        flat([30.0, 70.0], [0.35, 0.55]),
    ];
    let robust = fuse(&passes, FusionRule::Robust, 0.95, 40.0, 25.0);
    assert!(robust.allows(Some(TRUTH)), "{}", robust.words);
    // Under `all` the odd pass is named and the others' answer kept.
    let strict = fuse(&passes, FusionRule::All, 0.95, 40.0, 25.0);
    assert_eq!(
        strict.agreement,
        Agreement::OddPass { pass: 1 },
        "{}",
        strict.words
    );
    assert!(strict.allows(Some(TRUTH)));
    assert!(strict.words.contains("pass 2 has nothing in common"));
}

#[test]
fn a_flat_that_grew_is_reported_as_changed_not_as_an_empty_answer() {
    let s = space();
    let passes = [
        good(),
        flat([20.0, 40.0], [0.12, 0.16]), // L0 about 21–24 mm
        flat([20.0, 45.0], [0.11, 0.17]),
        flat([60.0, 90.0], [0.60, 0.80]), // L0 about 47–54 mm
        flat([55.0, 95.0], [0.62, 0.85]),
    ];
    let j = fuse(&passes, FusionRule::Robust, 0.95, 40.0, 25.0);
    assert_eq!(
        j.agreement,
        Agreement::Changed {
            since: 3,
            grew: true
        },
        "{}",
        j.words
    );
    assert_eq!(j.passes_used, vec![3, 4]);
    let sev = j.severity.unwrap();
    assert_eq!(sev.highest, Severity::Urgent);
    assert!(
        j.words.starts_with("CHANGED: the flat grew after pass 3"),
        "{}",
        j.words
    );
    assert!(j.l0_mm.unwrap()[0] > s.l0_mm(0.55));
}

#[test]
fn good_passes_keep_a_good_wheel_good_and_refuted_passes_are_named() {
    let refuted = WheelPass {
        claim: Claim::Refuted,
        severity: Some(SeverityRange::single(Severity::Inspect)),
        ..good()
    };
    let j = fuse(
        &[good(), refuted, good(), good()],
        FusionRule::Robust,
        0.95,
        40.0,
        25.0,
    );
    assert_eq!(j.agreement, Agreement::Consistent);
    assert_eq!(j.passes_silent, vec![1]);
    assert!(j.no_flat && j.allows(None));
    // No pass found a flat: a good wheel's answer, `none`; the refuted pass is named.
    assert_eq!(j.severity, Some(SeverityRange::single(Severity::None)));
    assert!(j.words.contains("pass 2 left out"));
    // No pass with anything to say: no joint answer, the refuted pass inspected.
    let none = fuse(
        &[WheelPass {
            claim: Claim::Refuted,
            ..good()
        }],
        FusionRule::All,
        0.95,
        40.0,
        25.0,
    );
    assert_eq!(none.agreement, Agreement::NoInformation);
}

#[test]
fn the_passes_that_may_have_lost_the_truth_follow_the_binomial() {
    // φ = 0.95: one of 3–7 passes, two of 8–16, three from 17; none of one or two.
    let k: Vec<usize> = (1..=18).map(|n| allowed_misses(n, 0.95)).collect();
    assert_eq!(
        k,
        vec![0, 0, 1, 1, 1, 1, 1, 2, 2, 2, 2, 2, 2, 2, 2, 2, 3, 3]
    );
    assert_eq!(allowed_misses(5, 1.0), 0);
}

#[test]
fn a_clean_pass_allows_flats_below_its_detection_limit() {
    let mut clean = good();
    clean.limit_l0_mm = Some(30.0);
    let passes = [clean, flat([20.0, 40.0], [0.12, 0.16])];
    let j = fuse(&passes, FusionRule::All, 0.95, 40.0, 25.0);
    assert_eq!(j.agreement, Agreement::Consistent, "{}", j.words);
    assert!(j.allows(Some([30.0, 0.14, 0.05])));
    // Clean passes alone allow those flats but act as a good wheel.
    let mut clean = good();
    clean.limit_l0_mm = Some(30.0);
    let j = fuse(
        &[clean.clone(), clean.clone(), clean],
        FusionRule::Robust,
        0.95,
        40.0,
        25.0,
    );
    assert!(j.allows(None) && j.allows(Some([30.0, 0.14, 0.05])));
    assert_eq!(j.severity, Some(SeverityRange::single(Severity::None)));
}
