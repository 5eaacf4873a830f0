//! Whole-record judging under model-form error (issue 11): can any rule for comparing *every
//! sample* keep the truth (coverage) and still rule out the flats of a higher severity class
//! (the severity ceiling)?
//!
//! For each seeded case two things are judged at every sample of every sensor window, Šídák
//! over all N samples (per-point probability `φ^(1/N)`, the prediction's own thresholds where
//! it is the larger force, as falsification judges), with no cell widening:
//! - **the truth as the bank's model simulates it** — the best any bank or refinement can
//!   hold. With `finer` measurements the difference is model-form error; a rule that rejects
//!   this flat loses the case whatever the population;
//! - **the bank-only answer's candidates of a higher class than the truth**, deepest first (at
//!   most `MAX_CHECKED`): one that passes means an answer judged by this rule and keeping every
//!   flat it cannot exclude over-calls the case.
//!
//! Rules: `plain`; `smooth below f` (both series filtered ¼, ½, ¼ where the smoothed
//! measured force is below f kN, plain elsewhere; `smooth` when f is infinite); `shift w` (a
//! sample passes when the thresholds around the measurement meet the prediction's range over
//! ±w samples: timing tolerance); `rate b` (thresholds widened by
//! b × the prediction's largest change to a neighbouring sample); `slow h` (only samples where
//! that change is below h threshold half-widths are compared); `every n` and `n busiest`
//! (plain on a subset of samples, Šídák over the subset: every n-th sample, or the n where the
//! measurement departs most from its mean over ±10 samples).
//!
//! `cargo run --release -p wheelflat-studies --bin whole_record -- BANK CASES SEED [same|finer] [MAX_CHECKED]`
//! (`SHOW_FAILS=1` prints every sample at which the truth's own simulation fails;
//! `CELL_SIMS=n` adds n flats simulated in the cell of each of the 20 higher-class candidates
//! nearest the class limit; results in docs/severity.md).
use wheelflat_studies::study;

use rayon::prelude::*;
use study::{windows_kn, Study, WholeCase};
use wheelflat::identify::Identifier;
use wheelflat::model::{Flat, Simulator};
use wheelflat_studies::coverage::{self, severity_class};

#[derive(Clone, Copy, Debug)]
enum Rule {
    Plain,
    Shift(usize),
    Rate(f64),
    Slow(f64),
    /// Both series smoothed by the three-tap [1, 2, 1]/4 filter (zero at the Nyquist
    /// frequency) where the smoothed measured force is below this many kN (infinite: every
    /// sample), plain elsewhere (the rail's ringing after the wheels have passed is small; the
    /// impacts are not).
    SmoothBelow(f64),
    /// Plain at every n-th sample only, Šídák over those.
    Every(usize),
    /// Plain at the n samples (over all windows) where the measurement departs most from
    /// its own mean over ±10 samples, Šídák over those.
    Busiest(usize),
}

impl Rule {
    fn name(&self) -> String {
        match self {
            Rule::Plain => "plain".into(),
            Rule::Shift(w) => format!("shift ±{w}"),
            Rule::Rate(b) => format!("rate {b}"),
            Rule::Slow(h) => format!("slow < {h}"),
            Rule::SmoothBelow(f) if f.is_infinite() => "smooth [1,2,1]/4".into(),
            Rule::SmoothBelow(f) => format!("smooth below {f} kN"),
            Rule::Every(n) => format!("every {n}th sample"),
            Rule::Busiest(n) => format!("{n} busiest samples"),
        }
    }
}

const RULES: [Rule; 14] = [
    Rule::Plain,
    Rule::SmoothBelow(f64::INFINITY),
    Rule::SmoothBelow(5.0),
    Rule::Every(10),
    Rule::Busiest(500),
    Rule::Busiest(200),
    Rule::Shift(1),
    Rule::Shift(2),
    Rule::Rate(0.5),
    Rule::Rate(1.0),
    Rule::Rate(2.0),
    Rule::Slow(2.0),
    Rule::Slow(1.0),
    Rule::Slow(0.5),
];

/// Whether prediction `g` (one sensor window, kN) passes measured `y` under `rule`.
fn passes(id: &Identifier, y: &[f64], g: &[f64], p: f64, rule: Rule) -> bool {
    let n = y.len().min(g.len());
    if let Rule::SmoothBelow(f) = rule {
        let smooth_at = |x: &[f64], k: usize| {
            0.25 * x[k.saturating_sub(1)] + 0.5 * x[k] + 0.25 * x[(k + 1).min(n - 1)]
        };
        return (0..n).all(|k| {
            let ys = smooth_at(y, k);
            let (yv, gv) = if ys.abs() < f {
                (ys, smooth_at(g, k))
            } else {
                (y[k], g[k])
            };
            let (lo, hi) = id.band(yv, gv, p);
            (lo..=hi).contains(&(gv - yv))
        });
    }
    (0..n).all(|k| {
        let change = [k.wrapping_sub(1), k + 1]
            .iter()
            .filter(|&&j| j < n)
            .map(|&j| (g[j] - g[k]).abs())
            .fold(0.0, f64::max);
        let (lo, hi) = id.band(y[k], g[k], p);
        let inside = |gv: f64, lo: f64, hi: f64| (lo..=hi).contains(&(gv - y[k]));
        match rule {
            Rule::Plain => inside(g[k], lo, hi),
            Rule::Shift(w) => {
                let win = &g[k.saturating_sub(w)..(k + w + 1).min(n)];
                let gmin = win.iter().copied().fold(f64::INFINITY, f64::min);
                let gmax = win.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                // Some value of the window's range lies within the band around y.
                gmax - y[k] >= lo && gmin - y[k] <= hi
            }
            Rule::Rate(b) => inside(g[k], lo - b * change, hi + b * change),
            Rule::Slow(h) => change >= h * 0.5 * (hi - lo) || inside(g[k], lo, hi),
            Rule::SmoothBelow(_) => unreachable!("smoothed above"),
            Rule::Every(_) | Rule::Busiest(_) => unreachable!("judged on their samples"),
        }
    })
}

fn main() {
    let study = Study::from_args("[MAX_CHECKED]");
    let (cases, seed) = (study.cases, study.seed);
    let max_checked: usize = study.arg(5, 400);
    let (id, cal, meas_cal) = study.into_identifier();
    let (insp, urg, _) = coverage::severity_limits(&cal);
    let axes = id.bank().metadata().sensors.clone();
    let sim = Simulator::new(&cal).unwrap();
    // Per rule: cases whose truth fails, cases where a higher-class candidate passes.
    // A flat's windows as the bank stores them (kN, rounded to f32).
    let record = |flat: &Flat| windows_kn(&sim, &axes, flat);
    // CELL_SIMS=n: also n flats simulated in the cell of each of the 20 higher-class
    // candidates nearest the class limit, kept where their own L0 is of a higher class.
    let cell_sims: usize = std::env::var("CELL_SIMS").map_or(0, |v| v.parse().unwrap());
    let radius = cal.vehicle.wheel_radius_m;
    let pop = cal.population.clone();
    let mut truth_fails = vec![0usize; RULES.len()];
    let mut higher = vec![0usize; RULES.len()];
    for (case, flat) in coverage::truths(&cal, cases, seed).iter().enumerate() {
        let c = WholeCase::new(&id, &meas_cal, flat, seed, case);
        let (out, t, cls, p, used) = (&c.out, &c.truth, c.class, c.p, &c.axes);
        let truth_kn = record(flat).unwrap();
        if std::env::var_os("SHOW_FAILS").is_some() {
            for (ser, &ax) in out.series.iter().zip(used) {
                let (y, g) = (&ser.values_kn, &truth_kn[ax]);
                for k in 0..y.len().min(g.len()) {
                    let (lo, hi) = id.band(y[k], g[k], p);
                    if !(lo..=hi).contains(&(g[k] - y[k])) {
                        let nb = |j: usize| g.get(j).copied().unwrap_or(f64::NAN);
                        println!(
                            "    case {case} {} k {k}: y {:.1} g {:.1} band [{:.1}, {:.1}] g[k-2..k+2] {:.1} {:.1} {:.1} {:.1} {:.1}",
                            ser.sensor, y[k], g[k], lo, hi,
                            nb(k.wrapping_sub(2)), nb(k.wrapping_sub(1)), g[k], nb(k + 1), nb(k + 2)
                        );
                    }
                }
            }
        }
        // The samples a subset rule compares: (series, sample) pairs.
        let subset = |rule: Rule| -> Vec<(usize, usize)> {
            match rule {
                Rule::Every(n) => out
                    .series
                    .iter()
                    .enumerate()
                    .flat_map(|(si, ser)| (0..ser.values_kn.len()).step_by(n).map(move |k| (si, k)))
                    .collect(),
                Rule::Busiest(n) => {
                    let mut all: Vec<(f64, usize, usize)> = Vec::new();
                    for (si, ser) in out.series.iter().enumerate() {
                        let y = &ser.values_kn;
                        for k in 0..y.len() {
                            let w = &y[k.saturating_sub(10)..(k + 11).min(y.len())];
                            let mean = w.iter().sum::<f64>() / w.len() as f64;
                            all.push(((y[k] - mean).abs(), si, k));
                        }
                    }
                    all.sort_by(|a, b| b.0.total_cmp(&a.0));
                    all.iter().take(n).map(|&(_, si, k)| (si, k)).collect()
                }
                _ => Vec::new(),
            }
        };
        let judge = |g: &[Vec<f64>], rule: Rule| {
            if let Rule::Every(_) | Rule::Busiest(_) = rule {
                let at = subset(rule);
                let p = out.phi.powf(1.0 / at.len().max(1) as f64);
                return at.iter().all(|&(si, k)| {
                    let (y, gk) = (out.series[si].values_kn[k], g[used[si]][k]);
                    let (lo, hi) = id.band(y, gk, p);
                    (lo..=hi).contains(&(gk - y))
                });
            }
            out.series
                .iter()
                .zip(used)
                .all(|(ser, &ax)| passes(&id, &ser.values_kn, &g[ax], p, rule))
        };
        let mut members = out.sizing.as_ref().map_or_else(Vec::new, |z| z.cms.clone());
        members.sort_by(|x, y| y.l0_mm.total_cmp(&x.l0_mm));
        let mut higher_members: Vec<Vec<Vec<f64>>> = members
            .iter()
            .take_while(|s| severity_class(s.l0_mm, insp, urg) > cls)
            .take(max_checked)
            .map(|s| {
                let stored = id.bank().read_instance(s.instance as usize).unwrap();
                stored
                    .forces_kn
                    .iter()
                    .map(|f| f.iter().map(|&v| v as f64).collect())
                    .collect()
            })
            .collect();
        if cell_sims > 0 {
            let cells = id.resolution().expect("the bank has cells").cells;
            let mut near: Vec<_> = members
                .iter()
                .filter(|s| severity_class(s.l0_mm, insp, urg) > cls)
                .collect();
            near.sort_by(|x, y| x.l0_mm.total_cmp(&y.l0_mm));
            near.truncate(20);
            let mut state = seed ^ (case as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15);
            let mut uniform = move || 2.0 * study::uniform(&mut state) - 1.0;
            let mut flats = Vec::new();
            for s in near {
                let h = cells.half_extent(s.instance as usize);
                for _ in 0..cell_sims {
                    let l =
                        (s.length_mm + h[0] * uniform()).clamp(pop.length_mm[0], pop.length_mm[1]);
                    let d = (s.depth_mm + h[1] * uniform()).clamp(pop.depth_mm[0], pop.depth_mm[1]);
                    let c = (s.curvature_mm + h[2] * uniform())
                        .clamp(pop.curvature_mm[0], pop.curvature_mm[1])
                        .min(0.49 * d);
                    let x = (s.impact_position_m + h[3] * uniform())
                        .clamp(pop.impact_position_m[0], pop.impact_position_m[1]);
                    let l0 = Flat::fresh_length_mm(d, radius);
                    if severity_class(l0, insp, urg) > cls {
                        if let Ok(f) = Flat::from_mm(l, d, c, x) {
                            flats.push(f.on_wheel(s.flat_wheel));
                        }
                    }
                }
            }
            higher_members.extend(flats.par_iter().filter_map(&record).collect::<Vec<_>>());
        }
        let mut line = format!(
            "{case:>3} L {:6.1} d {:.3} c {:.3} L0 {:5.1} cls {cls} higher {:>3} |",
            t.length_mm,
            t.depth_mm,
            t.curvature_mm,
            t.l0_mm,
            higher_members.len()
        );
        for (r, &rule) in RULES.iter().enumerate() {
            let ok = judge(&truth_kn, rule);
            let hi = higher_members.iter().any(|g| judge(g, rule));
            truth_fails[r] += usize::from(!ok);
            higher[r] += usize::from(hi);
            line += &format!(
                " {}{}",
                if ok { 'T' } else { '-' },
                if hi { 'H' } else { '.' }
            );
        }
        println!("{line}");
    }
    println!("\n| rule | truth (bank model) rejected | higher class passes | truth kept (no widening) | severity right at most |");
    println!("|---|---|---|---|---|");
    for (r, rule) in RULES.iter().enumerate() {
        println!(
            "| {} | {} of {cases} | {} of {cases} | {:.2} | {:.2} |",
            rule.name(),
            truth_fails[r],
            higher[r],
            1.0 - truth_fails[r] as f64 / cases as f64,
            1.0 - higher[r] as f64 / cases as f64
        );
    }
}
