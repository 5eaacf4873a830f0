//! Detection before sizing, measured (issue 36; docs/identification.md, "Detection"):
//! `cargo run --release -p wheelflat-studies --bin detection_study -- BANK GOOD FLATS TINY [AT_LIMIT] [SEED]`.
//!
//! Every pass is simulated with the bank's calibration at the converged reference's mesh and
//! step (`Calibration::converged_reference`), at a speed drawn within ±3 % of the bank's, and
//! perturbed per the paper's Eq. 1 (`synth`: model errors with their sign, gain, noise,
//! resolution; one seed a pass); then `Identifier::identify` answers it, as `identify`,
//! `watch` and `train` do. Three sets:
//! - GOOD good wheels: how often "no flat detected" (the false-alarm rate is the rest);
//! - FLATS flats of the bank's population (L, d, c uniform with c < d/2, X_p and wheel from
//!   the population): detected, by 5 mm L0 bin, and at the detection limit the good wheels
//!   were told;
//! - TINY flats below the population (d 0.01–0.09 mm, c ≤ d/10, L 5–30 mm): detected, and the
//!   severity of the answers;
//! - AT_LIMIT flats of the population with L0 within 1 mm above the detection limit a good
//!   wheel of the bank is told (L, c, X_p and wheel as for FLATS): detected.
//!
//! One line per pass, then the summary. Passes run on the rayon pool.
use rayon::prelude::*;
use std::path::Path;
use wheelflat::bank::Bank;
use wheelflat::identify::synth::{synthesize_pass, FieldNoise};
use wheelflat::identify::{Extras, Identifier, Measurement, Severity};
use wheelflat::model::{Flat, WheelPosition};

/// The LCG draw the other studies use (uniform in [0, 1)).
fn uniform(state: &mut u64) -> f64 {
    *state = state
        .wrapping_mul(6_364_136_223_846_793_005)
        .wrapping_add(1_442_695_040_888_963_407);
    (*state >> 11) as f64 / (1u64 << 53) as f64
}

#[derive(Clone, Copy, PartialEq)]
enum Set {
    Good,
    Flat,
    Tiny,
    AtLimit,
}

struct Pass {
    set: Set,
    speed: f64,
    flat: Option<Flat>,
    seed: u64,
}

struct Answer {
    detected: bool,
    limit_l0: Option<f64>,
    excess_kn: f64,
    /// With the departure rule, then without: (severity by the L0 rule, L0 range, truth
    /// inside the ranges, severity by the impact rule, dynamic-ratio range).
    sized: [Sized; 2],
    /// The true dynamic ratio (the converged simulation's peak contact force over the static
    /// wheel load).
    truth_ratio: f64,
}

type Sized = (Severity, Option<[f64; 2]>, bool, Severity, Option<[f64; 2]>);

/// The class a value falls in under limits `[inspect, urgent]`.
fn class(v: f64, limits: [f64; 2]) -> Severity {
    Severity::of_upper_l0(v, limits[1], limits[0])
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let usage = "usage: detection_study BANK GOOD FLATS TINY [AT_LIMIT] [SEED]";
    let dir = args.get(1).expect(usage);
    let count = |i: usize| -> usize { args.get(i).expect(usage).parse().expect(usage) };
    let (good, flats, tiny) = (count(2), count(3), count(4));
    let at_limit: usize = args.get(5).map_or(0, |s| s.parse().expect(usage));
    let seed: u64 = args.get(6).map_or(36, |s| s.parse().expect(usage));
    let bank = Bank::open(Path::new(dir)).expect("open bank");
    let cal = bank.metadata().calibration.clone();
    let settings = cal.identification.clone();
    let identifier = Identifier::new(bank, settings.clone()).expect("identifier");
    let without = Identifier::new(
        Bank::open(Path::new(dir)).expect("open bank"),
        wheelflat::model::calibration::IdentificationParams {
            falsify_at_departures: false,
            ..settings.clone()
        },
    )
    .expect("identifier");
    let pop = cal.population.clone();
    let wheels = pop
        .flat_wheels
        .clone()
        .unwrap_or_else(|| vec![cal.vehicle.flat_wheel]);

    let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 36;
    let mut passes = Vec::new();
    // The limit a good wheel of this bank is told (every pass of the bank's speed and sensors
    // is told the same, from the departures table).
    let told = identifier
        .detection_limit(
            &(0..cal.sensors.pad.len()).collect::<Vec<_>>(),
            &identifier.table_bounds(),
        )
        .expect("the departures table")
        .l0_mm
        .unwrap_or(f64::NAN);
    let radius_mm = cal.vehicle.wheel_radius_m * 1e3;
    let sets = [
        (Set::Good, good),
        (Set::Flat, flats),
        (Set::Tiny, tiny),
        (Set::AtLimit, at_limit),
    ];
    for (set, n) in sets {
        for _ in 0..n {
            let u = |s: &mut u64, r: [f64; 2]| r[0] + (r[1] - r[0]) * uniform(s);
            let speed = cal.run.speed_km_per_h * u(&mut state, [0.97, 1.03]);
            let xp = u(&mut state, pop.impact_position_m);
            let wheel: WheelPosition = wheels
                [((uniform(&mut state) * wheels.len() as f64) as usize).min(wheels.len() - 1)];
            let flat = match set {
                Set::Good => None,
                Set::Flat => loop {
                    let l = u(&mut state, pop.length_mm);
                    let d = u(&mut state, pop.depth_mm);
                    let c = u(&mut state, pop.curvature_mm);
                    if let Ok(f) = Flat::from_mm(l, d, c, xp) {
                        break Some(f.on_wheel(wheel));
                    }
                },
                Set::AtLimit => loop {
                    // L0 = √(8·d·R): d for an L0 in [limit, limit + 1] mm.
                    let l0 = u(&mut state, [told, told + 1.0]);
                    let d = l0 * l0 / (8.0 * radius_mm);
                    let l = u(&mut state, pop.length_mm);
                    let c = u(&mut state, pop.curvature_mm);
                    if let Ok(f) = Flat::from_mm(l, d, c, xp) {
                        break Some(f.on_wheel(wheel));
                    }
                },
                Set::Tiny => {
                    let d = u(&mut state, [0.01, 0.09]);
                    let c = u(&mut state, [0.0, d / 10.0]);
                    let l = u(&mut state, [5.0, 30.0]);
                    Some(
                        Flat::from_mm(l, d, c, xp)
                            .expect("a tiny flat")
                            .on_wheel(wheel),
                    )
                }
            };
            passes.push(Pass {
                set,
                speed,
                flat,
                seed: (uniform(&mut state) * 1e9) as u64,
            });
        }
    }

    let static_load_n = cal.vehicle.static_wheel_load_n();
    let answers: Vec<Answer> = passes
        .par_iter()
        .enumerate()
        .map(|(k, p)| {
            let mut c = cal.converged_reference();
            c.run.speed_km_per_h = p.speed;
            let c = c.check().expect("a valid calibration");
            let syn = synthesize_pass(&c, p.flat.as_ref(), p.seed, true, FieldNoise::TABLE)
                .expect("simulated");
            let m = Measurement::from_csv(
                Path::new(&format!("pass-{k}.csv")),
                &syn.csv,
                c.output.sample_rate_hz,
            )
            .expect("a measurement");
            let judge = |who: &Identifier| {
                let id = who.identify(&m, None, Extras::NONE).expect("identified");
                let det = id.detection.clone().expect("detection ran");
                let ranges = id.cms_ranges().cloned();
                let l0 = if id.below_population() {
                    Some([0.0, id.population.l0_mm[0]])
                } else {
                    ranges.as_ref().map(|r| r.l0_mm)
                };
                let severity = match (det.flat_detected, l0) {
                    (false, _) => Severity::None,
                    (true, Some([_, u])) => {
                        Severity::of_upper_l0(u, settings.urgent_l0_mm, settings.inspect_l0_mm)
                    }
                    (true, None) => Severity::Inspect,
                };
                let t = &syn.truth;
                let inside = match (&ranges, id.below_population()) {
                    (_, true) => t.l0_mm < id.population.l0_mm[0],
                    (Some(r), _) => wheelflat_studies::coverage::holds_truth(r, t, false),
                    (None, _) => false,
                };
                let ratio = ranges
                    .as_ref()
                    .and_then(|r| r.impact)
                    .map(|i| i.dynamic_ratio);
                let by_impact = match (det.flat_detected, id.below_population(), ratio) {
                    (false, ..) => Severity::None,
                    (true, true, _) => severity,
                    (true, false, Some([_, u])) => Severity::of_upper_ratio(
                        u,
                        settings.urgent_dynamic_ratio,
                        settings.inspect_dynamic_ratio,
                    ),
                    (true, false, None) => Severity::Inspect,
                };
                (det, (severity, l0, inside, by_impact, ratio))
            };
            let (det, with) = judge(&identifier);
            let (_, plain) = judge(&without);
            Answer {
                detected: det.flat_detected,
                limit_l0: det.limit.as_ref().and_then(|l| l.l0_mm),
                excess_kn: det.worst().map_or(f64::NAN, |w| w.excess_kn),
                sized: [with, plain],
                truth_ratio: syn.truth.peak_contact_kn * 1e3 / static_load_n,
            }
        })
        .collect();

    let words = |s: &Sized| {
        format!(
            "{:<8} {:>9} {:<5} {:<8} {:>11}",
            s.0,
            s.1.map_or("-".into(), |r| format!("[{:.0},{:.0}]", r[0], r[1])),
            s.2,
            s.3,
            s.4.map_or("-".into(), |r| format!("[{:.2},{:.2}]", r[0], r[1])),
        )
    };
    println!("pass set  speed    L_mm   d_mm   c_mm  X_p_m  wheel     L0_mm | detected excess_kn limit_L0 | departure rule: L0 rule, L0, inside, impact rule, ratio | without: the same | true ratio");
    for (k, (p, a)) in passes.iter().zip(&answers).enumerate() {
        let f = p.flat.as_ref();
        let mm = |g: fn(&Flat) -> f64| f.map_or(0.0, |f| g(f) * 1e3);
        println!(
            "{k:>4} {:<4} {:5.1} {:7.1} {:6.3} {:6.3} {:6.3} {:<9} {:6.1} | {:<8} {:9.2} {:>8} | {} | {} | {:.2}",
            match p.set {
                Set::Good => "good",
                Set::Flat => "flat",
                Set::Tiny => "tiny",
                Set::AtLimit => "edge",
            },
            p.speed,
            mm(Flat::length_m),
            mm(Flat::depth_m),
            mm(Flat::curvature_m),
            f.map_or(0.0, Flat::impact_position_m),
            f.and_then(|f| f.wheel()).map_or("-", |w| w.name()),
            f.map_or(0.0, |f| f.fresh_length_m(cal.vehicle.wheel_radius_m) * 1e3),
            a.detected,
            a.excess_kn,
            a.limit_l0.map_or("-".into(), |l| format!("{l:.0}")),
            words(&a.sized[0]),
            words(&a.sized[1]),
            a.truth_ratio,
        );
    }
    let of = |set: Set| -> Vec<(&Pass, &Answer)> {
        passes
            .iter()
            .zip(&answers)
            .filter(|(p, _)| p.set == set)
            .collect()
    };
    let l0 = |p: &Pass| {
        p.flat
            .map_or(0.0, |f| f.fresh_length_m(cal.vehicle.wheel_radius_m) * 1e3)
    };
    let good_set = of(Set::Good);
    let quiet = good_set.iter().filter(|(_, a)| !a.detected).count();
    let limits: Vec<f64> = good_set.iter().filter_map(|(_, a)| a.limit_l0).collect();
    let limit = limits.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    println!(
        "good wheels: {quiet} of {} 'no flat detected' ({:.1} %); detection limit told: L0 {:.0}–{:.0} mm",
        good_set.len(),
        100.0 * quiet as f64 / good_set.len().max(1) as f64,
        limits.iter().copied().fold(f64::INFINITY, f64::min),
        limit,
    );
    let flat_set = of(Set::Flat);
    let mut bin = 15.0;
    while bin < 60.0 {
        let inside: Vec<_> = flat_set
            .iter()
            .filter(|(p, _)| (bin..bin + 5.0).contains(&l0(p)))
            .collect();
        if !inside.is_empty() {
            let hit = inside.iter().filter(|(_, a)| a.detected).count();
            println!(
                "flats L0 [{bin:.0}, {:.0}) mm: detected {hit} of {}",
                bin + 5.0,
                inside.len()
            );
        }
        bin += 5.0;
    }
    let judge = |pred: &dyn Fn(&Pass) -> bool, name: &str| {
        let v: Vec<_> = flat_set.iter().filter(|(p, _)| pred(p)).collect();
        let hit = v.iter().filter(|(_, a)| a.detected).count();
        println!(
            "flats {name}: detected {hit} of {} ({:.1} %)",
            v.len(),
            100.0 * hit as f64 / v.len().max(1) as f64
        );
    };
    judge(&|p| l0(p) >= 25.0, "with L0 ≥ 25 mm");
    if limit.is_finite() {
        judge(
            &|p| l0(p) >= limit,
            &format!("at or above the largest limit told ({limit:.0} mm)"),
        );
    }
    judge(&|_| true, "all");
    for (v, rule) in ["with the departure rule", "without it"].iter().enumerate() {
        let sized: Vec<_> = flat_set.iter().filter(|(_, a)| a.detected).collect();
        let inside = sized.iter().filter(|(_, a)| a.sized[v].2).count();
        let mut widths: Vec<f64> = sized
            .iter()
            .filter_map(|(_, a)| a.sized[v].1.map(|r| r[1] - r[0]))
            .collect();
        widths.sort_by(f64::total_cmp);
        let refuted = sized.iter().filter(|(_, a)| a.sized[v].1.is_none()).count();
        let under = sized
            .iter()
            .filter(|(p, a)| {
                let truth =
                    Severity::of_upper_l0(l0(p), settings.urgent_l0_mm, settings.inspect_l0_mm);
                a.sized[v].0 < truth
            })
            .count();
        println!(
            "flats sized {rule}: truth inside {inside} of {} ({:.1} %), median L0 width {:.1} mm, refuted {refuted}, severity under-stated {under}",
            sized.len(),
            100.0 * inside as f64 / sized.len().max(1) as f64,
            widths.get(widths.len() / 2).copied().unwrap_or(f64::NAN),
        );
    }
    // Both maintenance rules on the sized flats (with the departure rule): right (the class
    // acted on is the truth's), decisive (the range spans one class), under-stated.
    let l0_limits = [settings.inspect_l0_mm, settings.urgent_l0_mm];
    let ratio_limits = [
        settings.inspect_dynamic_ratio,
        settings.urgent_dynamic_ratio,
    ];
    for (name, is_l0) in [("L0 rule", true), ("impact rule", false)] {
        let sized: Vec<_> = flat_set.iter().filter(|(_, a)| a.detected).collect();
        let (mut right, mut decisive, mut under) = (0, 0, 0);
        for (p, a) in &sized {
            let s = &a.sized[0];
            let (said, range, truth, limits) = if is_l0 {
                (s.0, s.1, class(l0(p), l0_limits), l0_limits)
            } else {
                (s.3, s.4, class(a.truth_ratio, ratio_limits), ratio_limits)
            };
            right += usize::from(said == truth);
            under += usize::from(said < truth);
            decisive +=
                usize::from(range.is_some_and(|r| class(r[0], limits) == class(r[1], limits)));
        }
        println!(
            "flats, {name}: right {right} of {n}, decisive {decisive} of {n}, under-stated {under}",
            n = sized.len()
        );
    }
    let edge = of(Set::AtLimit);
    let hit = edge.iter().filter(|(_, a)| a.detected).count();
    println!(
        "flats at the detection limit told ({told:.0}–{:.0} mm): detected {hit} of {}",
        told + 1.0,
        edge.len()
    );
    let tiny_set = of(Set::Tiny);
    let hit = tiny_set.iter().filter(|(_, a)| a.detected).count();
    for (v, rule) in ["with the departure rule", "without it"].iter().enumerate() {
        for (name, pick) in [("L0 rule", 0), ("impact rule", 1)] {
            let count_of = |s: Severity| {
                tiny_set
                    .iter()
                    .filter(|(_, a)| if pick == 0 { a.sized[v].0 } else { a.sized[v].3 } == s)
                    .count()
            };
            println!(
                "tiny flats {rule}, {name}: detected {hit} of {}; severity none {}, monitor {}, inspect {}, urgent {}",
                tiny_set.len(),
                count_of(Severity::None),
                count_of(Severity::Monitor),
                count_of(Severity::Inspect),
                count_of(Severity::Urgent),
            );
        }
    }
}
