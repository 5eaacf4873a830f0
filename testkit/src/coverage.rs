//! Coverage study: seeded synthetic measurements with known flats, identified against a bank;
//! how often the truth lies inside the candidate model set's ranges (EDMF promises φ), how
//! wide those ranges are, and the same for the baselines.

use std::path::Path;
use wheelflat::bank::Population;
use wheelflat::identify::result::ParamRanges;
use wheelflat::identify::synth::{synthesize, Truth};
use wheelflat::identify::Severity;
use wheelflat::identify::{Extras, Identifier, IdentifyError, Measurement};
use wheelflat::model::{CheckedCalibration, Flat};

/// One synthetic case and what each method made of it.
#[derive(Debug, Clone, PartialEq)]
pub struct CaseResult {
    /// Case number.
    pub case: usize,
    /// True L, d, X_p, L0.
    pub truth: [f64; 4],
    /// EIP: CMS size, truth inside the (L, d) ranges, L0 range.
    pub eip: (usize, bool, Option<[f64; 2]>),
    /// Equidistant points: the same.
    pub equidistant: (usize, bool, Option<[f64; 2]>),
    /// Mean CMS size over the random subsets.
    pub random_mean: f64,
    /// Residual minimisation: its L0 (mm).
    pub rm_l0_mm: f64,
    /// Comparison points used.
    pub points: usize,
}

/// Truths drawn inside the bank's population ranges, kept a little away from the edges (a
/// truth on the boundary of the sampled box cannot be surrounded by instances).
pub fn truths(cal: &CheckedCalibration, cases: usize, seed: u64) -> Vec<Flat> {
    truths_within(cal, cases, seed, 0.05)
}

/// Truths drawn inside the bank's population ranges with a margin of `inset` (a fraction of
/// each range) kept from the edges of L, d and X_p; `inset` 0 draws over the whole population
/// (issue 32: no edge may refute a truth inside it).
pub fn truths_within(cal: &CheckedCalibration, cases: usize, seed: u64, inset: f64) -> Vec<Flat> {
    let mut inner = cal.population.clone();
    let shrink = |r: [f64; 2]| [r[0] + inset * (r[1] - r[0]), r[1] - inset * (r[1] - r[0])];
    inner.length_mm = shrink(inner.length_mm);
    inner.depth_mm = shrink(inner.depth_mm);
    inner.impact_position_m = shrink(inner.impact_position_m);
    // A different, shifted low-discrepancy set: truths fall between the bank's instances.
    let pop = Population::new(&inner, cases, seed.max(1));
    (0..cases)
        .map(|i| {
            let s = pop.instance(i);
            let f = Flat::from_mm(s.length_mm, s.depth_mm, s.curvature_mm, s.impact_position_m)
                .expect("population honours c < d/2");
            // On the wheel the population draws (the calibration's when it draws none).
            f.on_wheel(s.wheel.unwrap_or(cal.vehicle.flat_wheel))
        })
        .collect()
}

/// Why a seeded case could not be made or identified.
#[derive(Debug, thiserror::Error)]
pub enum CaseError {
    /// The simulation failed.
    #[error(transparent)]
    Simulate(#[from] wheelflat::model::SimError),
    /// The measurement could not be read back, or identification refused it.
    #[error(transparent)]
    Identify(#[from] IdentifyError),
}

/// One seeded case: the measurement of `flat` simulated with `model` and perturbed per the
/// uncertainty table (seed `seed + case`), read at the model's sample rate, and its truth.
pub fn case(
    model: &CheckedCalibration,
    flat: &Flat,
    seed: u64,
    case: usize,
) -> Result<(Measurement, Truth), CaseError> {
    let syn = synthesize(model, flat, seed.wrapping_add(case as u64), true)?;
    let m = Measurement::from_csv(
        Path::new(&format!("case-{case}.csv")),
        &syn.csv,
        model.output.sample_rate_hz,
    )?;
    Ok((m, syn.truth))
}

/// Whether `r` holds the truth: its L and d, and with `all` also its c and X_p.
pub fn holds_truth(r: &ParamRanges, t: &Truth, all: bool) -> bool {
    let within = |b: [f64; 2], v: f64| b[0] <= v && v <= b[1];
    within(r.length_mm, t.length_mm)
        && within(r.depth_mm, t.depth_mm)
        && (!all
            || (within(r.curvature_mm, t.curvature_mm)
                && within(r.impact_position_m, t.impact_position_m)))
}

/// Runs the study; `cal` is the bank's calibration (with the uncertainty table to perturb by).
pub fn run(
    identifier: &Identifier,
    cal: &CheckedCalibration,
    cases: usize,
    seed: u64,
    baselines: bool,
) -> Result<Vec<CaseResult>, CaseError> {
    let mut out = Vec::with_capacity(cases);
    for (k, flat) in truths(cal, cases, seed).iter().enumerate() {
        let (m, t) = case(cal, flat, seed, k)?;
        let id = identifier.identify(
            &m,
            None,
            Extras {
                baselines,
                curves: false,
                as_recorded: false,
            },
        )?;
        let inside = |r: Option<&ParamRanges>| r.is_some_and(|r| holds_truth(r, &t, false));
        let judge = |f: Option<&wheelflat::identify::result::Falsification>| match f {
            Some(f) => (
                f.cms_count,
                inside(f.ranges.as_ref()),
                f.ranges.as_ref().map(|r| r.l0_mm),
            ),
            None => (0, false, None),
        };
        // A flat not detected was not sized: no CMS, no L0, no points.
        let z = id.sizing.as_ref();
        out.push(CaseResult {
            case: k,
            truth: [t.length_mm, t.depth_mm, t.impact_position_m, t.l0_mm],
            eip: judge(z.and_then(|z| z.falsifications.first())),
            equidistant: judge(z.and_then(|z| {
                z.falsifications
                    .iter()
                    .find(|f| f.method == wheelflat::identify::result::Method::Equidistant)
            })),
            random_mean: z
                .and_then(|z| z.random_subsets.as_ref())
                .map_or(f64::NAN, |r| r.mean),
            rm_l0_mm: z
                .and_then(|z| z.residual_minimisation.as_ref())
                .map_or(f64::NAN, |r| r.l0_mm),
            points: z.map_or(0, |z| z.eip.len()),
        });
    }
    Ok(out)
}

/// Summary figures of a study: (coverage, median L0 width of non-empty CMS, median CMS size).
pub fn summarise(
    results: &[CaseResult],
    pick: impl Fn(&CaseResult) -> (usize, bool, Option<[f64; 2]>),
) -> (f64, f64, f64) {
    let n = results.len().max(1) as f64;
    let covered = results.iter().filter(|r| pick(r).1).count() as f64 / n;
    let median = |mut v: Vec<f64>| {
        if v.is_empty() {
            return f64::NAN;
        }
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let widths = results
        .iter()
        .filter_map(|r| pick(r).2.map(|w| w[1] - w[0]))
        .collect();
    let sizes = results.iter().map(|r| pick(r).0 as f64).collect();
    (covered, median(widths), median(sizes))
}

/// One method's answer on one case of a study, judged against the truth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Judged {
    /// The truth lies inside the reported ranges.
    pub holds: bool,
    /// The reported L0 range (NaN when every instance is falsified).
    pub l0_mm: [f64; 2],
    /// The class the answer calls (an empty answer calls urgent).
    pub class: Severity,
}

impl Judged {
    /// The class as the studies' tables print it: 0 monitor, 1 inspect, 2 urgent.
    pub fn class_index(&self) -> usize {
        class_index(self.class)
    }
}

/// A class as the studies' tables print it: 0 monitor (or none), 1 inspect, 2 urgent.
pub fn class_index(s: Severity) -> usize {
    match s {
        Severity::None | Severity::Monitor => 0,
        Severity::Inspect => 1,
        Severity::Urgent => 2,
    }
}

/// A method's answer judged against the truth (`all`: c and X_p must be inside too; an empty
/// answer holds nothing and calls urgent).
pub fn judge(
    r: Option<&ParamRanges>,
    t: &Truth,
    all: bool,
    inspect_mm: f64,
    urgent_mm: f64,
) -> Judged {
    match r {
        Some(r) => Judged {
            holds: holds_truth(r, t, all),
            l0_mm: r.l0_mm,
            class: Severity::of_upper_l0(r.l0_mm[1], urgent_mm, inspect_mm),
        },
        None => Judged {
            holds: false,
            l0_mm: [f64::NAN; 2],
            class: Severity::Urgent,
        },
    }
}

/// The severity class of an L0 (0 monitor, 1 inspect, 2 urgent) by the product's rule
/// ([`Severity::of_upper_l0`]) with the settings' limits.
pub fn severity_class(l0_mm: f64, inspect_mm: f64, urgent_mm: f64) -> usize {
    class_index(Severity::of_upper_l0(l0_mm, urgent_mm, inspect_mm))
}

/// The issue-11 line of one method over a study: coverage, median L0 width, share of the
/// cases with a true L0 under 50 mm whose upper bound is below the population's top `top_mm`,
/// severity right and under-called. `truth` holds each case's (true L0, true class).
pub fn method_line(name: &str, truth: &[(f64, usize)], answers: &[Judged], top_mm: f64) -> String {
    let k = answers.len().max(1) as f64;
    let cov = answers.iter().filter(|a| a.holds).count() as f64 / k;
    let mut w: Vec<f64> = answers
        .iter()
        .map(|a| a.l0_mm[1] - a.l0_mm[0])
        .filter(|w| w.is_finite())
        .collect();
    w.sort_by(f64::total_cmp);
    let under: Vec<usize> = (0..truth.len()).filter(|&i| truth[i].0 < 50.0).collect();
    let below = under
        .iter()
        .filter(|&&i| answers[i].l0_mm[1] < top_mm - 0.05)
        .count() as f64
        / under.len().max(1) as f64;
    let right = (0..answers.len())
        .filter(|&i| answers[i].class_index() == truth[i].1)
        .count() as f64
        / k;
    let under_called = (0..answers.len())
        .filter(|&i| answers[i].class_index() < truth[i].1)
        .count();
    let refuted = answers.iter().filter(|a| a.l0_mm[0].is_nan()).count();
    format!(
        "{name}: coverage {cov:.3}, refuted {refuted}, median L0 width {:.1} mm, upper below top {below:.2} (of {} with L0 < 50), severity right {right:.2}, under-called {under_called}",
        w.get(w.len() / 2).copied().unwrap_or(f64::NAN),
        under.len()
    )
}

/// The severity limits of a study and the population's top L0: (inspect, urgent, top) in mm.
pub fn severity_limits(cal: &CheckedCalibration) -> (f64, f64, f64) {
    (
        cal.identification.inspect_l0_mm,
        cal.identification.urgent_l0_mm,
        Flat::fresh_length_mm(cal.population.depth_mm[1], cal.vehicle.wheel_radius_m),
    )
}

/// The model a study's measurements are simulated with: the bank's own (`finer` false), or
/// [`finer_model`] for model-form error.
pub fn measurement_model(cal: &CheckedCalibration, finer: bool) -> CheckedCalibration {
    if finer {
        finer_model(cal)
    } else {
        cal.clone()
    }
}

/// The converged reference of `cal` ([`wheelflat::model::Calibration::converged_reference`]):
/// measurements that carry the bank's whole discretisation error, as a field record does.
pub fn converged_model(cal: &CheckedCalibration) -> CheckedCalibration {
    cal.document()
        .converged_reference()
        .check()
        .expect("the converged mesh and step keep a valid calibration")
}

/// The finer model that measurements with model-form error are simulated with: twice the
/// elements per bay and half the time steps of `cal` (issue 11's second acceptance set).
pub fn finer_model(cal: &CheckedCalibration) -> CheckedCalibration {
    let mut d = cal.document().clone();
    d.integration.elements_per_bay *= 2;
    d.integration.coarse_steps_per_sample *= 2;
    d.check()
        .expect("doubling the mesh and halving the steps keeps a valid calibration")
}
