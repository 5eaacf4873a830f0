//! The floor of issue 63: how far in L0 the flats that truly fit a pass reach, against the
//! bank-only answer and the refined one.
//!
//! `cargo run --release -p wheelflat-studies --bin floor_study -- BANK CACHE FROM:TO [SIMULATIONS]`
//!
//! BANK is a bank or a family (a pass meets its member as `identify` does); CACHE a folder of
//! `physics_passes` (`case-K.csv`, `case-K.truth.json`). Per flat pass, with the pass's own
//! comparison points and thresholds:
//! - bank-only: the answer's L0 range (the union of the surviving cells);
//! - refined: `RefineSettings::default()` (the bounds strategy, 640 simulations at most);
//! - the floor: a settling with **no cell widening** (κ = 0: every flat judged for its own
//!   simulated prediction only) started from the bank's survivors and their neighbours and 64
//!   flats simulated around the truth (L ± 4 mm, d ± 0.02 mm, c ± 0.02 mm, X_p ± 2 mm, the
//!   truth among them), its rounds walking outwards from the deepest and shallowest flats that
//!   pass, with up to SIMULATIONS (default 3000) simulations and a 0.25 mm tolerance. The floor
//!   is the L0 hull of the flats that pass exactly (`kept_l0_mm`): flats that were simulated and
//!   fit, so no answer that holds them can be narrower — a lower bound on the set's extent,
//!   reached by a search, not a proof.
//!
//! `CALIBRATION=F` takes the identification settings from F instead of the bank's (the
//! floor's variants: which part of the error model sets it).
//!
//! Prints one line a case (`case L0 | bank lo hi | refined lo hi sims settled | floor lo hi
//! sims | truth held bank refined`) and the medians of the widths.
use std::path::Path;
use wheelflat::identify::refine::{bank_simulator, refine, refine_from, RefineSettings};
use wheelflat::identify::synth::Truth;
use wheelflat::identify::Members;
use wheelflat::identify::{Extras, Identification};
use wheelflat::model::WheelPosition;

fn l0_range(id: &Identification) -> Option<[f64; 2]> {
    let z = id.sizing.as_ref()?;
    Some(z.falsifications.first()?.ranges.as_ref()?.l0_mm)
}

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    anyhow::ensure!(
        args.len() >= 4,
        "usage: floor_study BANK CACHE FROM:TO [SIMULATIONS]"
    );
    let cache = Path::new(&args[2]);
    let (from, to) = args[3].split_once(':').expect("FROM:TO");
    let (from, to): (usize, usize) = (from.parse()?, to.parse()?);
    let budget: usize = args.get(4).map_or(Ok(3000), |s| s.parse())?;
    // `CALIBRATION=F`: the identification settings from F (the variants of the floor).
    let settings = match std::env::var("CALIBRATION") {
        Ok(f) => Some(
            wheelflat::pass::input::load_calibration(Some(Path::new(&f)))?
                .identification
                .clone(),
        ),
        Err(_) => None,
    };
    let mut members = Members::open(Path::new(&args[1]), settings)?;
    let (mut w_bank, mut w_ref, mut w_floor) = (Vec::new(), Vec::new(), Vec::new());
    let (mut held_bank, mut held_ref, mut n) = (0, 0, 0);
    for case in from..to {
        let csv = cache.join(format!("case-{case}.csv"));
        let truth: Truth = serde_json::from_str(&std::fs::read_to_string(
            cache.join(format!("case-{case}.truth.json")),
        )?)?;
        let Some(wheel) = truth.flat_wheel else {
            continue;
        };
        let (m, k) = wheelflat::pass::input::read_measurement(&mut members, &csv, None, false)?;
        let identifier = members.get(k);
        let id = identifier.identify(&m, None, Extras::NONE)?;
        let Some(bank) = l0_range(&id) else {
            println!("{case:>4} L0 {:5.1} | not sized", truth.l0_mm);
            continue;
        };
        let sim = bank_simulator(identifier)?;
        let refined = refine(identifier, &sim, &id, RefineSettings::default())?;
        let cal = &identifier.bank().metadata().calibration;
        let pop = &cal.population;
        // The truth's strike placed inside the population's X_p range (it strikes once a
        // revolution).
        let turn = 2.0 * std::f64::consts::PI * cal.vehicle.wheel_radius_m;
        let mut xp = truth.impact_position_m;
        while xp > pop.impact_position_m[1] {
            xp -= turn;
        }
        while xp < pop.impact_position_m[0] {
            xp += turn;
        }
        let mut state = 0x9E37_79B9_7F4A_7C15u64 ^ case as u64;
        let mut anchors: Vec<([f64; 4], WheelPosition)> = vec![(
            [truth.length_mm, truth.depth_mm, truth.curvature_mm, xp],
            wheel,
        )];
        for _ in 1..64 {
            let mut u = |h: f64| h * (2.0 * wheelflat_studies::study::uniform(&mut state) - 1.0);
            let d = (truth.depth_mm + u(0.02)).clamp(pop.depth_mm[0], pop.depth_mm[1]);
            let x = [
                (truth.length_mm + u(4.0)).clamp(pop.length_mm[0], pop.length_mm[1]),
                d,
                (truth.curvature_mm + u(0.02)).clamp(0.0, 0.499 * d),
                xp + u(0.002),
            ];
            anchors.push((x, wheel));
        }
        let floor_settings = RefineSettings {
            simulations: budget,
            per_round: 128,
            tolerance_mm: 0.25,
            kappa: Some(0.0),
            ..RefineSettings::default()
        };
        let floor = refine_from(identifier, &sim, &id, floor_settings, &anchors)?;
        let r = refined.ranges.as_ref().map(|r| r.l0_mm);
        let f = floor.kept_l0_mm;
        let holds =
            |x: Option<[f64; 2]>| x.is_some_and(|x| x[0] <= truth.l0_mm && truth.l0_mm <= x[1]);
        n += 1;
        held_bank += usize::from(holds(Some(bank)));
        held_ref += usize::from(holds(r));
        w_bank.push(bank[1] - bank[0]);
        if let Some(r) = r {
            w_ref.push(r[1] - r[0]);
        }
        if let Some(f) = f {
            w_floor.push(f[1] - f[0]);
        }
        let show = |x: Option<[f64; 2]>| {
            x.map_or("       none".into(), |x| {
                format!("{:5.1} {:5.1}", x[0], x[1])
            })
        };
        println!(
            "{case:>4} L0 {:5.1} | bank {} | refined {} {:4} {} | floor {} {:4} | held {} {}",
            truth.l0_mm,
            show(Some(bank)),
            show(r),
            refined.simulations,
            u8::from(refined.bounds_settled == Some(true)),
            show(f),
            floor.simulations,
            u8::from(holds(Some(bank))),
            u8::from(holds(r)),
        );
    }
    println!(
        "flats {n}: held bank {held_bank}, refined {held_ref}; median L0 width bank {:.1} mm, refined {:.1} mm, floor {:.1} mm",
        median(w_bank),
        median(w_ref),
        median(w_floor)
    );
    Ok(())
}
