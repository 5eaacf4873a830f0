//! Scale-factor study (issue 11): relative errors that are common to every sample of one
//! sensor in one pass (calibration-, gain- and load-type errors) taken as one unknown factor
//! per sensor instead of independently at every point.
//! `cargo run --release -p wheelflat-studies --bin scale_study -- BANK CASES SEED [same|finer] SPLIT [all|eip] [kappa]`
//! SPLIT: none (paper), rel (all relative sources systematic), cal (train system, track
//! calibration, sensor accuracy, measurement additional systematic).
use std::path::Path;
use wheelflat::identify::result::CandidatePoint;
use wheelflat::identify::result::ParamRanges;
use wheelflat::identify::CombinedUncertainty;
use wheelflat::identify::{Extras, Identifier};
use wheelflat::model::calibration::{UncertaintyGroup, UncertaintyKind};
use wheelflat::model::Flat;
use wheelflat_studies::coverage;
use wheelflat_studies::coverage::{judge, method_line, severity_class, Judged};

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let bank = wheelflat::bank::Bank::open(Path::new(&a[1])).expect("bank");
    let cases: usize = a[2].parse().unwrap();
    let seed: u64 = a[3].parse().unwrap();
    let finer = a.get(4).is_some_and(|s| s == "finer");
    let split = a.get(5).cloned().unwrap_or("cal".into());
    let use_all = a.get(6).is_none_or(|s| s == "all");
    let kappa: f64 = a.get(7).map_or(0.5, |s| s.parse().unwrap());
    let cal = bank.metadata().calibration.clone().check().unwrap();
    let meas_cal = coverage::measurement_model(&cal, finer);
    let params = bank.read_parameters().unwrap();
    let pop = cal.population.clone();
    let radius = cal.vehicle.wheel_radius_m;
    let (insp, urg) = (
        cal.identification.inspect_l0_mm,
        cal.identification.urgent_l0_mm,
    );
    // The split of the uncertainty table.
    let systematic = |name: &str, g: UncertaintyGroup, k: UncertaintyKind| -> bool {
        k == UncertaintyKind::Relative
            && match split.as_str() {
                "none" => false,
                "rel" => true,
                _ => match g {
                    UncertaintyGroup::Model => {
                        name == "train system" || name == "track calibration"
                    }
                    UncertaintyGroup::Measurement => true,
                },
            }
    };
    let mut pointwise = cal.identification.clone();
    pointwise
        .uncertainty
        .retain(|u| !systematic(&u.name, u.group, u.kind));
    let (mut em, mut ea) = ([0.0f64; 2], [0.0f64; 2]);
    for u in &cal.identification.uncertainty {
        if systematic(&u.name, u.group, u.kind) {
            let t = if u.group == UncertaintyGroup::Model {
                &mut em
            } else {
                &mut ea
            };
            t[0] += u.min;
            t[1] += u.max;
        }
    }
    // y = g·(1 − e_model)·(1 + a_meas) + point-wise part.
    let f_range = [(1.0 - em[1]) * (1.0 + ea[0]), (1.0 - em[0]) * (1.0 + ea[1])];
    eprintln!(
        "split {split}: systematic factor in [{:.3}, {:.3}], point-wise sources {:?}",
        f_range[0],
        f_range[1],
        pointwise
            .uncertainty
            .iter()
            .map(|u| u.name.as_str())
            .collect::<Vec<_>>()
    );
    let unc = CombinedUncertainty::new(&pointwise);
    let id = Identifier::new(bank, cal.identification.clone()).unwrap();
    let res = id.resolution().unwrap();
    let cells = res.cells;
    let top = Flat::fresh_length_mm(pop.depth_mm[1], radius);
    let mut rows: Vec<(f64, usize, Judged, Judged, f64, usize)> = Vec::new();
    for (case, flat) in coverage::truths(&cal, cases, seed).iter().enumerate() {
        let (m, t) = coverage::case(&meas_cal, flat, seed, case).unwrap();
        let out = id.identify(&m, None, Extras::NONE).unwrap();
        let t0 = std::time::Instant::now();
        // A flat not detected was not sized: no points.
        let (candidates, eip): (&[CandidatePoint], &[usize]) = out
            .sizing
            .as_ref()
            .map_or((&[], &[]), |z| (&z.candidates, &z.eip));
        let idx: Vec<usize> = if use_all {
            (0..candidates.len()).collect()
        } else {
            eip.to_vec()
        };
        let axes = &id.bank().metadata().sensors;
        let cols: Vec<usize> = idx
            .iter()
            .map(|&i| {
                let c = &candidates[i];
                let ax = axes
                    .iter()
                    .position(|x| x.name == out.series[c.series].sensor)
                    .unwrap();
                id.bank().sample_index(ax, c.sample)
            })
            .collect();
        let preds = id.bank().read_columns(&cols).unwrap();
        let p = out.phi.powf(1.0 / idx.len().max(1) as f64);
        let bounds: Vec<(f64, f64)> = idx
            .iter()
            .map(|&i| unc.thresholds(candidates[i].measured_kn, p))
            .collect();
        let nser = out.series.len();
        let n = params.length_mm.len();
        let survivors: Vec<usize> = (0..n)
            .filter(|&k| {
                let mut lo = vec![f_range[0]; nser];
                let mut hi = vec![f_range[1]; nser];
                for (j, &i) in idx.iter().enumerate() {
                    let c = &candidates[i];
                    let g = preds[j][k] as f64;
                    let w = kappa * cells.spread(&preds[j], k) * f_range[1];
                    let y = c.measured_kn;
                    // lo_j − w ≤ F·g − y ≤ hi_j + w
                    let (a, b) = (y + bounds[j].0 - w, y + bounds[j].1 + w);
                    let s = c.series;
                    if g > 1e-9 {
                        lo[s] = lo[s].max(a / g);
                        hi[s] = hi[s].min(b / g);
                    } else if g < -1e-9 {
                        lo[s] = lo[s].max(b / g);
                        hi[s] = hi[s].min(a / g);
                    } else if a > 0.0 || b < 0.0 {
                        return false;
                    }
                    if lo[s] > hi[s] {
                        return false;
                    }
                }
                true
            })
            .collect();
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        let span = |v: &[f64], ti: usize, clamp: [f64; 2]| {
            let (mut lo, mut hi) = (f64::MAX, f64::MIN);
            for &k in &survivors {
                let h = cells.half_extent(k)[ti];
                lo = lo.min(v[k] - h);
                hi = hi.max(v[k] + h);
            }
            [lo.max(clamp[0]), hi.min(clamp[1])]
        };
        let ranges = (!survivors.is_empty()).then(|| {
            let depth_mm = span(&params.depth_mm, 1, pop.depth_mm);
            ParamRanges {
                length_mm: span(&params.length_mm, 0, pop.length_mm),
                depth_mm,
                curvature_mm: span(&params.curvature_mm, 2, pop.curvature_mm),
                impact_position_m: span(&params.impact_position_m, 3, pop.impact_position_m),
                l0_mm: depth_mm.map(|d| Flat::fresh_length_mm(d, radius)),
                flat_wheels: Vec::new(),
                impact: None,
            }
        });
        let judged = judge(ranges.as_ref(), &t, true, insp, urg);
        let base = judge(out.cms_ranges(), &t, false, insp, urg);
        println!(
            "{case:>3} L {:6.1} d {:.3} c {:.3} X {:.3} L0 {:5.1} | base {} [{:5.1},{:5.1}] | scale {:>5} {} [{:5.1},{:5.1}] cls {}/{} {} pts {:.1} ms",
            t.length_mm, t.depth_mm, t.curvature_mm, t.impact_position_m, t.l0_mm,
            base.holds as u8, base.l0_mm[0], base.l0_mm[1], survivors.len(), judged.holds as u8, judged.l0_mm[0], judged.l0_mm[1],
            judged.class_index(), severity_class(t.l0_mm, insp, urg), idx.len(), ms
        );
        rows.push((
            t.l0_mm,
            severity_class(t.l0_mm, insp, urg),
            base,
            judged,
            ms,
            survivors.len(),
        ));
    }
    let truth: Vec<(f64, usize)> = rows.iter().map(|r| (r.0, r.1)).collect();
    let base: Vec<Judged> = rows.iter().map(|r| r.2).collect();
    let new: Vec<Judged> = rows.iter().map(|r| r.3).collect();
    println!("{}", method_line("bank-only", &truth, &base, top));
    println!("{}", method_line("scale", &truth, &new, top));
    let mut t: Vec<f64> = rows.iter().map(|r| r.4).collect();
    t.sort_by(f64::total_cmp);
    println!("scale stage median {:.1} ms", t[t.len() / 2]);
}
