//! Tables and text for the terminal: the paper-style comparison of an identification, its
//! summary lines, an audited instance's verdict with its JSON and figure panels, and the
//! diagnosis' before/after lines. The CLI prints what these return, nothing more.

use super::audit::{AuditPanel, BandPoint};
use crate::audit::{MeasuredCheck, Resimulation};
use crate::bank::schema::SensorAxis;
use crate::bank::StoredInstance;
use crate::diagnose::{Diagnosis, Stage};
use crate::identify::answer::result::ParamRanges;
use crate::identify::synth::Truth;
use crate::identify::Identification;
use crate::model::WheelPosition;

/// `[lo, hi]` of one parameter of `r` with `digits` decimals, or `—` when the set is empty.
pub fn range_text(
    r: &Option<ParamRanges>,
    f: fn(&ParamRanges) -> [f64; 2],
    digits: usize,
) -> String {
    match r {
        Some(r) => {
            let [lo, hi] = f(r);
            format!("[{lo:.digits$}, {hi:.digits$}]")
        }
        None => "—".into(),
    }
}

/// The paper-style comparison table of an identification.
/// A pass that was not sized (no flat detected) has none: a line says so (and the truth,
/// when given).
pub fn comparison_table(id: &Identification, truth: Option<&Truth>) -> String {
    let truth_line = |t: &Truth| {
        format!(
            "truth: L0 {:.1} mm, L {:.1} mm, d {:.3} mm, X_p {:.3} m\n",
            t.l0_mm, t.length_mm, t.depth_mm, t.impact_position_m
        )
    };
    let Some(z) = &id.sizing else {
        let none = "comparison table: none (no flat detected: the pass was not sized)\n";
        return none.to_string() + &truth.map(truth_line).unwrap_or_default();
    };
    let mut s = format!(
        "{:<44} {:>6} {:>7}  {:<16} {:<16} {:<14}\n",
        "method", "points", "CMS", "L0 (mm)", "L (mm)", "d (mm)"
    );
    // The refined answer, when there is one, as a row of its own after the method's.
    let refined: Option<(String, usize, usize, Option<ParamRanges>)> =
        id.refinement.as_ref().map(|r| {
            (
                format!("refined ({} simulations)", r.simulations),
                z.falsifications.first().map_or(0, |f| f.points),
                r.survivors,
                r.ranges.clone(),
            )
        });
    let rows: Vec<(String, usize, usize, Option<ParamRanges>)> = z
        .falsifications
        .iter()
        .take(1)
        .map(|f| {
            (
                f.method.to_string(),
                f.points,
                f.cms_count,
                f.ranges.clone(),
            )
        })
        .chain(refined)
        .chain(z.falsifications.iter().skip(1).map(|f| {
            (
                f.method.to_string(),
                f.points,
                f.cms_count,
                f.ranges.clone(),
            )
        }))
        .collect();
    for (method, points, cms_count, ranges) in &rows {
        s += &format!(
            "{:<44} {:>6} {:>7}  {:<16} {:<16} {:<14}\n",
            method,
            points,
            cms_count,
            range_text(ranges, |r| r.l0_mm, 0),
            range_text(ranges, |r| r.length_mm, 0),
            range_text(ranges, |r| r.depth_mm, 2)
        );
    }
    if let Some(rm) = &z.residual_minimisation {
        s += &format!(
            "{:<44} {:>6} {:>7}  {:<16} {:<16} {:<14}\n",
            "residual minimisation (no unc.)",
            z.eip.len(),
            1,
            format!("{:.0}", rm.l0_mm),
            format!("{:.0}", rm.length_mm),
            format!("{:.2}", rm.depth_mm)
        );
    }
    if let Some(rs) = &z.random_subsets {
        s += &format!(
            "random subsets: {} draws of {} PIPs, CMS mean {:.1}, median {:.1}\n",
            rs.subsets, rs.size, rs.mean, rs.median
        );
    }
    if let Some(t) = truth {
        s += &truth_line(t);
        for (method, _, _, ranges) in &rows {
            if let Some(r) = ranges {
                let inside = |x: f64, [lo, hi]: [f64; 2]| lo <= x && x <= hi;
                let ok = inside(t.length_mm, r.length_mm) && inside(t.depth_mm, r.depth_mm);
                s += &format!(
                    "  {:<42} truth (L, d) inside its ranges: {}\n",
                    method,
                    if ok { "yes" } else { "NO" }
                );
            }
        }
    }
    s
}

/// The summary lines of an identification: its verdict, the maintenance hint, the alignment
/// and comparison points, and the timings.
pub fn identification_text(id: &Identification) -> String {
    let mut s = format!("{}\n{}\n", id.summary, id.maintenance_hint);
    if let Some(r) = &id.refinement {
        s += &format!("{}\n{}\n", r.summary, r.maintenance_hint);
    }
    if let Some(c) = id
        .refinement
        .as_ref()
        .and_then(|r| r.severity)
        .or(id.severity)
    {
        s += &format!("severity: {}\n", c.words());
    }
    s += &speed_line(&id.speed);
    s.push('\n');
    if let Some(l) = &id.load {
        s += &format!("{}; {}\n", l.words(), l.adjustment_words());
    }
    if let Some(d) = &id.detection {
        s += &detection_line(d);
        s.push('\n');
    }
    if let Some(r) = &id.roughness {
        s += &format!("roughness: {}\n", r.words());
    }
    if let Some(z) = &id.sizing {
        s += &format!(
        "alignment: {} (bank time = file time {:+.4} s{}); {} EIP of {} PIPs{}; per-point probability {:.5}\n",
        id.alignment.method,
        id.alignment.shift_s,
        id.alignment.correlation.map(|c| format!(", correlation {c:.4}")).unwrap_or_default(),
        z.eip.len(),
        z.candidates.len(),
        if z.envelope.is_empty() {
            String::new()
        } else {
            format!(" + {} envelope points", z.envelope.len())
        },
        z.per_point_probability
    );
    } else {
        s += &format!(
            "alignment: {} (bank time = file time {:+.4} s{}); no sizing\n",
            id.alignment.method,
            id.alignment.shift_s,
            id.alignment
                .correlation
                .map(|c| format!(", correlation {c:.4}"))
                .unwrap_or_default(),
        );
    }
    let t: Vec<String> = id
        .timings_ms
        .iter()
        .map(|(n, ms)| format!("{n} {ms:.1} ms"))
        .collect();
    s += &format!("timings: {}\n", t.join(", "));
    s
}

/// The detection step in one line: the verdict, each sensor's gain and the sample nearest the
/// bound (or farthest past it).
pub fn detection_line(d: &crate::identify::Detection) -> String {
    let gains: Vec<String> = d
        .sensors
        .iter()
        .map(|t| {
            format!(
                "{} {:.3}{}",
                t.sensor,
                t.gain,
                if t.gain_outside_table {
                    " (clamped: level outside the table)"
                } else {
                    ""
                }
            )
        })
        .collect();
    let worst = d.worst().map_or(String::new(), |w| {
        format!(
            "; {} {:.2} kN {} the bound at {} {:.4} s",
            if w.excess_kn > 0.0 {
                "flat-free model"
            } else {
                "closest sample"
            },
            w.excess_kn.abs(),
            if w.excess_kn > 0.0 {
                "beyond"
            } else {
                "inside"
            },
            w.sensor,
            w.at_time_s
        )
    });
    format!(
        "detection: {} over {} samples (bound {:.2} kN + {:.1} % of the force{}); gains {}{worst}",
        if d.flat_detected {
            "flat detected"
        } else {
            "no flat detected"
        },
        d.samples,
        d.bounds.absolute_kn + d.bounds.bound_kn + d.bounds.allowance_kn,
        100.0 * d.bounds.fraction(),
        match &d.spike {
            Some(t) => format!(
                "; strike test: largest {:.1} × the level, limit {:.0}",
                t.sensors.iter().map(|x| x.2).fold(0.0, f64::max),
                t.ratio_limit
            ),
            None => String::new(),
        },
        gains.join(", "),
    )
}

/// Which bank a pass was compared with, and at what speed: `speed: pass 49.2 km/h, compared
/// with the 50 km/h bank (its time axis scaled by 0.9840)`.
pub fn speed_line(s: &crate::identify::answer::result::SpeedUse) -> String {
    match s.pass_km_per_h {
        Some(v) if (v - s.bank_km_per_h).abs() > 1e-9 => format!(
            "speed: pass {v} km/h, compared with the {} km/h bank (its time axis scaled by {:.4})",
            s.bank_km_per_h,
            v / s.bank_km_per_h
        ),
        Some(v) => format!("speed: pass {v} km/h, compared with the {v} km/h bank"),
        None => format!(
            "speed: not stated; compared as if at the bank's {} km/h",
            s.bank_km_per_h
        ),
    }
}

/// The verdict of an instance against a measurement, with its points, falsifying ones first.
pub fn audit_table(c: &MeasuredCheck) -> String {
    let mut s = if c.kept {
        let margin = c
            .points
            .iter()
            .map(|p| -p.outside_by_kn)
            .fold(f64::MAX, f64::min);
        format!(
            "against {}: KEPT — inside the admissible residual at all {} comparison points (closest margin {margin:.2} kN); {} the candidate model set\n",
            c.measurement,
            c.points.len(),
            if c.in_cms { "member of" } else { "NOT in" }
        )
    } else if c.falsified_by.is_empty() {
        format!(
            "against {}: RULED OUT by the shared gains — inside the admissible residual at all {} comparison points, but no gain per sensor inside the table's bounds explains it at every point the pass read (docs/model.md, \"Shared gains\"); {} the candidate model set\n",
            c.measurement,
            c.points.len(),
            if c.in_cms { "yet member of" } else { "not in" }
        )
    } else {
        format!(
            "against {}: FALSIFIED at {} of {} comparison points (per-point probability {:.5}); {} the candidate model set\n",
            c.measurement,
            c.falsified_by.len(),
            c.points.len(),
            c.per_point_probability,
            if c.in_cms { "yet member of" } else { "not in" }
        )
    };
    s += &format!(
        "  {:<5} {:<6} {:>9} {:>10} {:>10} {:>9} {:>22} {:>9}  {}\n",
        "EIP",
        "sensor",
        "time (s)",
        "measured",
        "predicted",
        "residual",
        "admissible residual",
        "outside",
        "verdict"
    );
    let mut order: Vec<usize> = c.falsified_by.clone();
    order.extend((0..c.points.len()).filter(|i| !c.falsified_by.contains(i)));
    for i in order {
        let p = &c.points[i];
        s += &format!(
            "  {:<5} {:<6} {:>9.4} {:>10.2} {:>10.2} {:>+9.2} {:>22} {:>+9.2}  {}\n",
            p.order,
            p.sensor,
            p.time_s,
            p.measured_kn,
            p.predicted_kn,
            p.residual_kn,
            format!(
                "[{:+.2}, {:+.2}] ± {:.2}",
                p.threshold_kn[0],
                p.threshold_kn[1],
                p.widening_kn + p.discretisation_kn
            ),
            p.outside_by_kn,
            match (p.outside_by_kn > 0.0, &p.envelope) {
                (true, None) => "falsifies".to_string(),
                (false, None) => "inside".to_string(),
                (true, Some(w)) => format!("falsifies (envelope {w})"),
                (false, Some(w)) => format!("inside (envelope {w})"),
            }
        );
    }
    s
}

/// The line naming an audited instance's parameters, as `audit` prints it first.
pub fn audit_instance_line(stored: &StoredInstance) -> String {
    let [l, d, c, xp, l0, wheel, _] = stored.parameters;
    let wheel = WheelPosition::from_code(wheel as u8).name();
    format!(
        "instance {}: L {l:.2} mm, d {d:.4} mm, c {c:.4} mm, X_p {xp:.4} m, L0 {l0:.1} mm, on the {wheel} wheel",
        stored.instance
    )
}

/// `audit.json`: the instance, its parameters, the bank, the re-simulation and, when judged
/// against a measurement, that check.
pub fn audit_json(
    stored: &StoredInstance,
    bank_id: &str,
    resimulation: &Resimulation,
    measured: Option<&MeasuredCheck>,
) -> serde_json::Value {
    let [l, d, c, xp, l0, wheel, _] = stored.parameters;
    let wheel = WheelPosition::from_code(wheel as u8).name();
    serde_json::json!({
        "instance": stored.instance,
        "parameters": {
            "length_mm": l, "depth_mm": d, "curvature_mm": c,
            "impact_position_m": xp, "l0_mm": l0, "flat_wheel": wheel,
        },
        "bank_id": bank_id,
        "resimulation": resimulation,
        "measured": measured,
    })
}

/// The panels of the audit figure, one per bank sensor: stored and re-simulated series, the
/// measurement on the bank's time axis and, per comparison point, the admissible band of
/// predictions `measured + threshold ∓ (widening + discretisation allowance)`.
pub fn audit_panels<'a>(
    axes: &'a [SensorAxis],
    stored: &'a StoredInstance,
    resimulated: &'a [Vec<f32>],
    identification: Option<&'a Identification>,
    check: Option<&MeasuredCheck>,
) -> Vec<AuditPanel<'a>> {
    axes.iter()
        .enumerate()
        .filter_map(|(ai, axis)| {
            let measured = match identification {
                Some(id) => Some(
                    id.series
                        .iter()
                        .find(|s| s.sensor == axis.name)?
                        .values_kn
                        .as_slice(),
                ),
                None => None,
            };
            let points = check
                .iter()
                .flat_map(|c| c.points.iter())
                .filter(|p| p.sensor == axis.name)
                .map(|p| BandPoint {
                    time_s: p.time_s,
                    predicted_kn: p.predicted_kn,
                    band_kn: [
                        p.measured_kn + p.threshold_kn[0] - p.widening_kn - p.discretisation_kn,
                        p.measured_kn + p.threshold_kn[1] + p.widening_kn + p.discretisation_kn,
                    ],
                    falsifies: p.outside_by_kn > 0.0,
                })
                .collect();
            Some(AuditPanel {
                sensor: &axis.name,
                t0_s: axis.t0_s,
                rate_hz: axis.sample_rate_hz,
                stored: &stored.forces_kn[ai],
                resimulated: &resimulated[ai],
                measured,
                points,
            })
        })
        .collect()
}

/// The audit figure's title: the instance's flat and, against a measurement, its verdict.
pub fn audit_title(stored: &StoredInstance, check: Option<&MeasuredCheck>) -> String {
    let [l, d, c, xp, _, _, _] = stored.parameters;
    let verdict = match check {
        Some(c) if c.kept => "kept",
        Some(_) => "falsified",
        None => "",
    };
    format!(
        "instance {} (L {l:.1} mm, d {d:.3} mm, c {c:.3} mm, X_p {xp:.3} m) {verdict}",
        stored.instance
    )
}

/// One stage of a diagnosis (`before` or `after`) in a line.
fn stage_line(name: &str, s: &Stage) -> String {
    format!(
        "{name:<7} {:>5} of {} samples outside, gap RMS {:.3} kN, residual RMS {:.2} kN, CMS {}, L0 {}\n",
        s.samples_outside,
        s.samples,
        s.gap_rms_kn,
        s.rms_residual_kn,
        s.cms,
        s.l0_mm
            .map_or("— (empty)".into(), |[a, b]| format!("[{a:.1}, {b:.1}] mm"))
    )
}

/// A diagnosis for the terminal: the verdict, before and after, and the first eight of the
/// ranking (ΔBIC to the best, the χ² z-score).
pub fn diagnosis_text(d: &Diagnosis) -> String {
    let mut s = format!("{}\n", d.verdict);
    s += &stage_line("before", &d.before_stage);
    if let Some(o) = &d.surface {
        s += &format!("departure from the round wheel: {}\n", o.words());
    }
    if let Some(added) = &d.added {
        s += &stage_line("after", &added.after_stage);
    }
    if let Some(e) = &d.noise {
        s += &format!(
            "noise from the record: σ {} kN (table {:.3}), AR(1) ρ {:.2} from {} flat-free samples; fits use σ {:.3} kN\n",
            e.sigma_estimated_kn
                .map_or("not estimated".to_string(), |v| format!("{v:.3}")),
            e.sigma_table_kn,
            e.rho,
            e.samples,
            e.sigma_used_kn
        );
    }
    if let Some(n) = &d.naming {
        if let Some(place) = &n.place {
            s += &format!("place of the best: {place}\n");
        }
        if let Some([lo, hi]) = n.second_flat_l0_mm {
            s += &format!("second flat: L0 {lo:.1}–{hi:.1} mm\n");
        }
        if let Some(step) = &n.second {
            s += &format!("two effects, forward selection: {}\n", step.verdict);
        }
        s += &format!("ranking ({}):\n", n.criterion);
        let best = n.ranking.first().map_or(n.no_effect.bic, |c| c.bic);
        for c in n
            .ranking
            .iter()
            .chain(std::iter::once(&n.no_effect))
            .take(8)
        {
            s += &format!(
                "  {:<20} {:<34} ΔBIC {:>10.1}  z {:>7.1}\n",
                c.kind,
                c.location,
                c.bic - best,
                c.chi2_z
            );
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::audit::PointCheck;

    fn point(order: usize, outside_by_kn: f64) -> PointCheck {
        PointCheck {
            order,
            sensor: "rps1".into(),
            sample: 10,
            time_s: 0.5,
            measured_kn: 100.0,
            predicted_kn: 101.0,
            residual_kn: 1.0,
            threshold_kn: [-2.0, 2.0],
            widening_kn: 0.25,
            discretisation_kn: 0.0,
            outside_by_kn,
            envelope: None,
        }
    }

    #[test]
    fn ranges_print_with_their_digits_or_a_dash() {
        assert_eq!(range_text(&None, |r| r.l0_mm, 0), "—");
    }

    #[test]
    fn audit_table_lists_falsifying_points_first() {
        let c = MeasuredCheck {
            measurement: "m.csv".into(),
            kept: false,
            in_cms: false,
            shared_gains_kept: None,
            points: vec![point(1, -0.5), point(2, 1.5), point(3, 0.5)],
            falsified_by: vec![1, 2],
            per_point_probability: 0.99,
        };
        let t = audit_table(&c);
        let lines: Vec<&str> = t.lines().collect();
        assert_eq!(
            lines[0],
            "against m.csv: FALSIFIED at 2 of 3 comparison points (per-point probability 0.99000); not in the candidate model set"
        );
        assert_eq!(lines.len(), 5);
        assert!(lines[2].starts_with("  2 "), "{}", lines[2]);
        assert!(lines[3].starts_with("  3 "), "{}", lines[3]);
        assert!(lines[4].ends_with("inside"), "{}", lines[4]);
        assert!(lines[2].contains("[-2.00, +2.00] ± 0.25"), "{}", lines[2]);
    }

    #[test]
    fn an_instance_inside_every_point_but_no_shared_gain_says_so() {
        let c = MeasuredCheck {
            measurement: "m.csv".into(),
            kept: false,
            in_cms: false,
            shared_gains_kept: Some(false),
            points: vec![point(1, -0.5)],
            falsified_by: vec![],
            per_point_probability: 0.99,
        };
        assert!(audit_table(&c).starts_with(
            "against m.csv: RULED OUT by the shared gains — inside the admissible residual at all 1 comparison points"
        ));
    }

    #[test]
    fn a_kept_instance_names_its_closest_margin() {
        let c = MeasuredCheck {
            measurement: "m.csv".into(),
            kept: true,
            in_cms: true,
            shared_gains_kept: Some(true),
            points: vec![point(1, -0.5), point(2, -0.25)],
            falsified_by: vec![],
            per_point_probability: 0.99,
        };
        assert!(audit_table(&c).starts_with(
            "against m.csv: KEPT — inside the admissible residual at all 2 comparison points (closest margin 0.25 kN); member of the candidate model set\n"
        ));
    }
}
