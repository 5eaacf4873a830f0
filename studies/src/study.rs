//! What the issue-11 study examples share: the arguments `BANK CASES SEED [same|finer|converged] …`,
//! the bank, its calibration and the model the cases' measurements are simulated with.

use crate::coverage::{self, severity_class};
use std::path::Path;
use wheelflat::bank::schema::SensorAxis;
use wheelflat::bank::Bank;
use wheelflat::identify::synth::Truth;
use wheelflat::identify::{Extras, Identification, Identifier};
use wheelflat::model::{CheckedCalibration, Flat, Record, Simulator};

/// A study's bank and cases.
pub struct Study {
    /// The bank.
    pub bank: Bank,
    /// Its calibration.
    pub cal: CheckedCalibration,
    /// The model the measurements are simulated with (the bank's, or the finer one).
    pub meas_cal: CheckedCalibration,
    /// Seeded cases.
    pub cases: usize,
    /// Their seed.
    pub seed: u64,
    args: Vec<String>,
}

impl Study {
    /// Reads `BANK CASES SEED [same|finer|converged]` from the command line; `usage` names the rest.
    pub fn from_args(usage: &str) -> Study {
        let args: Vec<String> = std::env::args().collect();
        if args.len() < 4 {
            panic!(
                "usage: {} BANK CASES SEED [same|finer|converged] {usage}",
                args[0]
            );
        }
        let (bank, cal) = open_bank(&args[1]);
        let finer = args.get(4).is_some_and(|s| s == "finer");
        let converged = args.get(4).is_some_and(|s| s == "converged");
        Study {
            meas_cal: if converged {
                coverage::converged_model(&cal)
            } else {
                coverage::measurement_model(&cal, finer)
            },
            cases: args[2].parse().expect("CASES"),
            seed: args[3].parse().expect("SEED"),
            bank,
            cal,
            args,
        }
    }

    /// Argument `i` (1-based, as on the command line) parsed, or `default` when absent.
    pub fn arg<T: std::str::FromStr>(&self, i: usize, default: T) -> T
    where
        T::Err: std::fmt::Debug,
    {
        self.args
            .get(i)
            .map_or(default, |s| s.parse().expect("a number"))
    }

    /// The bank-only identifier of the study's bank, its calibration and the measurement
    /// model.
    pub fn into_identifier(self) -> (Identifier, CheckedCalibration, CheckedCalibration) {
        let id = Identifier::new(self.bank, self.cal.identification.clone()).unwrap();
        (id, self.cal, self.meas_cal)
    }

    /// Whether argument `i` is `word`.
    pub fn flag(&self, i: usize, word: &str) -> bool {
        self.args.get(i).is_some_and(|s| s == word)
    }
}

/// One seeded case identified by the bank-only method, with what a comparison at every sample
/// needs.
pub struct WholeCase {
    /// The bank-only identification.
    pub out: Identification,
    /// The case's truth.
    pub truth: Truth,
    /// The truth's severity class.
    pub class: usize,
    /// Per-sample probability, Šídák over every sample of every identified window.
    pub p: f64,
    /// Each identified series' bank axis.
    pub axes: Vec<usize>,
}

impl WholeCase {
    /// Case `case` of `flat`, its measurement simulated with `meas_cal` (seed `seed + case`).
    pub fn new(
        id: &Identifier,
        meas_cal: &CheckedCalibration,
        flat: &Flat,
        seed: u64,
        case: usize,
    ) -> WholeCase {
        let cal = &id.bank().metadata().calibration;
        let (insp, urg) = (
            cal.identification.inspect_l0_mm,
            cal.identification.urgent_l0_mm,
        );
        let (m, truth) = coverage::case(meas_cal, flat, seed, case).unwrap();
        let out = id.identify(&m, None, Extras::NONE).unwrap();
        let total: usize = out.series.iter().map(|s| s.values_kn.len()).sum();
        let bank_axes = &id.bank().metadata().sensors;
        WholeCase {
            class: severity_class(truth.l0_mm, insp, urg),
            p: out.phi.powf(1.0 / total.max(1) as f64),
            axes: out
                .series
                .iter()
                .map(|s| bank_axes.iter().position(|x| x.name == s.sensor).unwrap())
                .collect(),
            out,
            truth,
        }
    }
}

/// The bank in `dir` and its stored calibration, checked.
pub fn open_bank(dir: &str) -> (Bank, CheckedCalibration) {
    let bank = Bank::open(Path::new(dir)).expect("bank");
    let cal = bank
        .metadata()
        .calibration
        .clone()
        .check()
        .expect("calibration");
    (bank, cal)
}

/// `flat` simulated by `sim`: each bank axis's window in kN, rounded to f32 as the bank
/// stores it; `None` when the simulation fails.
pub fn windows_kn(sim: &Simulator, axes: &[SensorAxis], flat: &Flat) -> Option<Vec<Vec<f64>>> {
    let resp = sim.run(Some(flat), Record::default()).ok()?;
    Some(
        axes.iter()
            .enumerate()
            .map(|(si, a)| {
                resp.window(si, a.first_sample, a.samples)
                    .iter()
                    .map(|v| (v / 1e3) as f32 as f64)
                    .collect()
            })
            .collect(),
    )
}

/// Uniform [0, 1) from a 64-bit LCG step of `state` (the studies' own draws; the crate's
/// generator is internal to it).
pub fn uniform(state: &mut u64) -> f64 {
    *state = state
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    (*state >> 11) as f64 / (1u64 << 53) as f64
}

/// `cases` flats drawn uniformly over `pop`'s L, d, c (capped below d/2) and X_p with
/// [`uniform`] from `seed` (at least 1): the discretisation and landing studies' draws.
pub fn uniform_flats(
    pop: &wheelflat::model::calibration::PopulationParams,
    cases: usize,
    seed: u64,
) -> Vec<Flat> {
    let mut state = seed.max(1);
    (0..cases)
        .map(|_| {
            let mut u = |r: [f64; 2]| r[0] + uniform(&mut state) * (r[1] - r[0]);
            let l = u(pop.length_mm);
            let d = u(pop.depth_mm);
            let c = u(pop.curvature_mm).min(0.49 * d);
            let x = u(pop.impact_position_m);
            Flat::from_mm(l, d, c, x).expect("a flat of the population")
        })
        .collect()
}

/// splitmix64 → uniform in [0, 1) (the oracle and history studies' draws).
pub fn splitmix_uniform(state: &mut u64) -> f64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
}

/// Writes case `k`'s synthetic pass into `cache` as `case-k.csv` and its truth as
/// `case-k.truth.json` (the studies' pass caches).
pub fn write_case(cache: &Path, k: usize, syn: &wheelflat::identify::synth::Synthetic) {
    std::fs::write(
        cache.join(format!("case-{k}.truth.json")),
        serde_json::to_string_pretty(&syn.truth).expect("a truth serialises"),
    )
    .expect("the cache is writable");
    std::fs::write(cache.join(format!("case-{k}.csv")), &syn.csv).expect("the cache is writable");
}

/// `settings` with `WHEELS=round|auto|disc|…` applied to `wheel_roughness` when set.
pub fn wheels_from_env(
    mut settings: wheelflat::model::calibration::IdentificationParams,
) -> wheelflat::model::calibration::IdentificationParams {
    if let Ok(w) = std::env::var("WHEELS") {
        settings.wheel_roughness =
            serde_json::from_str(&format!("\"{w}\"")).expect("WHEELS names a class or auto");
    }
    settings
}

/// The arguments `BANK CACHE CASES SEED …` of the studies that cache their passes: the bank,
/// its calibration, the cache folder (created), the cases, the seed, and every argument.
pub fn cached_args(
    name: &str,
    rest: &str,
) -> (
    Bank,
    CheckedCalibration,
    std::path::PathBuf,
    usize,
    u64,
    Vec<String>,
) {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 5 {
        panic!("usage: {name} BANK CACHE CASES SEED {rest}");
    }
    let (bank, cal) = open_bank(&args[1]);
    let cache = std::path::PathBuf::from(&args[2]);
    std::fs::create_dir_all(&cache).expect("cache folder");
    let cases: usize = args[3].parse().expect("CASES");
    let seed: u64 = args[4].parse().expect("SEED");
    (bank, cal, cache, cases, seed, args)
}

/// The contact filter a study simulates surfaces with: `FILTER=default` (patch and rolling
/// circle), else none (the raw trace, as the independent implementation uses it).
pub fn filter_from_env() -> wheelflat::model::ContactFilter {
    match std::env::var("FILTER").as_deref() {
        Ok("default") => wheelflat::model::ContactFilter::DEFAULT,
        _ => wheelflat::model::ContactFilter {
            patch: false,
            rolling_circle: false,
        },
    }
}

/// Draws the physics of one pass onto `base` (a copy), from `state` (issue 56): wheel,
/// bogie masses and bogie inertia ×[0.95, 1.05], primary stiffness and damping ×[0.9, 1.1]
/// (the paper's Table 3), the Hertz flexibility G ×[0.9, 1.1], pad damping ×[0.7, 1.3],
/// sleeper mass ×[0.9, 1.1].
pub fn physics(
    base: &wheelflat::model::Calibration,
    state: &mut u64,
) -> wheelflat::model::Calibration {
    let mut c = base.clone();
    let mut f = |lo: f64, hi: f64| lo + splitmix_uniform(state) * (hi - lo);
    c.vehicle.wheel_mass_kg *= f(0.95, 1.05);
    c.vehicle.bogie_mass_kg *= f(0.95, 1.05);
    c.vehicle.bogie_pitch_inertia_kg_m2 *= f(0.95, 1.05);
    c.vehicle.primary_stiffness_n_per_m *= f(0.9, 1.1);
    c.vehicle.primary_damping_ns_per_m *= f(0.9, 1.1);
    let ch = base.clone().check().expect("defaults").hertz_constant();
    // C_H = G^-1.5: G scaled by s scales C_H by s^-1.5.
    c.contact.hertz_constant_n_per_m1_5 = Some(ch * f(0.9, 1.1).powf(-1.5));
    c.track.pad_damping_ns_per_m *= f(0.7, 1.3);
    c.track.sleeper_mass_kg *= f(0.9, 1.1);
    c
}

/// One physics-varied pass's draws, in the order the validation sets were made with
/// (`physics_passes`, and a wheel's in `history_study PHYSICS=1`): the vehicle, contact and
/// track ([`physics`]), the car body ×[0.6, 1.4] (returned), the uncertainty table's model
/// sources set to zero (the measurement's own sources only are drawn), and a tread roughness
/// class among disc, composite and cast-iron (used where the pass is rough).
pub fn physics_draw(
    base: &wheelflat::model::Calibration,
    state: &mut u64,
) -> (
    wheelflat::model::Calibration,
    f64,
    wheelflat::model::surface::RoughnessClass,
) {
    use wheelflat::model::calibration::UncertaintyGroup;
    use wheelflat::model::surface::RoughnessClass;
    let mut cal = physics(base, state);
    let body = 0.6 + 0.8 * splitmix_uniform(state);
    cal.vehicle.car_body_mass_kg *= body;
    for u in &mut cal.identification.uncertainty {
        if u.group == UncertaintyGroup::Model {
            (u.min, u.max) = (0.0, 0.0);
        }
    }
    let class = [
        RoughnessClass::Disc,
        RoughnessClass::Composite,
        RoughnessClass::CastIron,
    ][(splitmix_uniform(state) * 3.0) as usize % 3];
    (cal, body, class)
}
