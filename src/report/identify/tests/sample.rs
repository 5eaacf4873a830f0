//! A hand-made identification (two series of 300 samples, 20 PIP, 6 EIP, 15 candidate
//! instances, 200 random subsets), for looking at the report's layout without a bank
//! (`examples/identify_preview.rs`) and for the report's tests.

use crate::identify::answer::identification::Identification;
use crate::identify::answer::result::{
    Alignment, CandidatePoint, EntropyCurve, Falsification, InstanceParams, MeasuredSeries, Method,
    ParamRanges, RandomSubsets,
};
use crate::identify::answer::sizing::Sizing;
use crate::report::canvas::min_max;

/// Sample rate of the hand-made series (Hz).
pub(super) const RATE_HZ: f64 = 5000.0;
/// Samples per series.
pub(super) const SAMPLES: usize = 300;
/// The verdict text (with characters HTML must escape).
pub(super) const SUMMARY: &str =
    "The flat is L0 = 41–54 mm long (fresh-flat length < 60 mm & d < 1 mm); \
                       15 of 50000 instances remain \"candidate\" models.";

/// `v` rounded to 9 decimals. serde_json is built without its `float_roundtrip` feature,
/// so its parser may be one ulp off for 17-digit numbers; measured data with realistic
/// precision (≤ 15 significant digits) round-trips exactly.
pub(super) fn q(v: f64) -> f64 {
    (v * 1e9).round() / 1e9
}

/// Smooth rail-pad pulses: a wheel passing (broad bump), the flat's impact (sharp peak
/// with a decaying ripple), and the second wheel.
pub(super) fn pulse(t: f64, impact: f64) -> f64 {
    let g = |c: f64, w: f64| (-((t - c) / w).powi(2)).exp();
    let ripple = if t > impact {
        8.0 * (-(t - impact) / 0.004).exp()
            * (2.0 * std::f64::consts::PI * 450.0 * (t - impact)).sin()
    } else {
        0.0
    };
    q(4.0 + 55.0 * g(0.018, 0.006) + 70.0 * g(impact, 0.0012) + 45.0 * g(0.046, 0.006) + ripple)
}

/// The detection step on the sample's series against the pulse without its impact (the
/// good wheel), with the default table.
fn detection(series: &[MeasuredSeries]) -> crate::identify::Detection {
    let template: Vec<f32> = (0..SAMPLES)
        .map(|i| pulse(i as f64 / RATE_HZ, 1.0) as f32)
        .collect();
    let templates: Vec<&[f32]> = series.iter().map(|_| template.as_slice()).collect();
    crate::identify::detect::detect(
        series,
        &templates,
        crate::identify::detect::TableBounds::of(
            &crate::model::calibration::IdentificationParams::default(),
        ),
    )
}

/// Parameter ranges over a set of instances: their hull (none when empty). The report used
/// to show these for the CMS; the identification reports the union of cells, which is wider.
pub(super) fn hull_of(instances: &[InstanceParams]) -> Option<ParamRanges> {
    let range =
        |f: fn(&InstanceParams) -> f64| min_max(instances.iter().map(f)).map(|(lo, hi)| [lo, hi]);
    Some(ParamRanges {
        length_mm: range(|p| p.length_mm)?,
        depth_mm: range(|p| p.depth_mm)?,
        curvature_mm: range(|p| p.curvature_mm)?,
        impact_position_m: range(|p| p.impact_position_m)?,
        l0_mm: range(|p| p.l0_mm)?,
        flat_wheels: {
            let mut w: Vec<_> = instances.iter().map(|p| p.flat_wheel).collect();
            w.sort_by_key(|w| w.index());
            w.dedup();
            w
        },
        impact: None,
    })
}

/// Candidate instance `k` (parameters spread smoothly around L0 ≈ 42 mm).
pub(super) fn instance(k: u32) -> InstanceParams {
    let f = f64::from(k);
    let depth = q(0.55 + 0.02 * (f * 1.7).sin().abs() + 0.01 * f / 15.0);
    InstanceParams {
        instance: 1000 + 313 * k,
        length_mm: q(48.0 + 6.0 * (f * 0.9).sin()),
        depth_mm: depth,
        curvature_mm: q(0.2 + 0.15 * (f * 2.3).cos().abs()),
        impact_position_m: q(0.9 + 0.35 * (f * 0.37).sin()),
        l0_mm: q((8.0 * depth * 400.0).sqrt()),
        flat_wheel: crate::model::WheelPosition::Trailing,
    }
}

/// A realistic hand-made identification: 2 series of 300 samples, 20 PIP, 6 EIP,
/// 15 CMS instances, 200 random subsets.
pub(super) fn identification() -> Identification {
    let impacts = [0.0265, 0.0305];
    let series: Vec<MeasuredSeries> = ["rps1", "rps2"]
        .iter()
        .zip(impacts)
        .map(|(name, impact)| MeasuredSeries {
            sensor: (*name).to_string(),
            t0_s: 0.0,
            sample_rate_hz: RATE_HZ,
            values_kn: (0..SAMPLES)
                .map(|i| pulse(i as f64 / RATE_HZ, impact))
                .collect(),
        })
        .collect();
    // 10 PIP per series, in PIP order: the end points, then the peaks and the ripple.
    let pip_samples = [0, 299, 132, 90, 230, 150, 141, 160, 60, 200];
    let mut candidates = Vec::new();
    for (s, ser) in series.iter().enumerate() {
        for (order, &i) in pip_samples.iter().enumerate() {
            let i = if s == 1 && i > 0 && i < 299 {
                i + 20
            } else {
                i
            };
            let t = q(i as f64 / RATE_HZ);
            let entropy = if order < 2 {
                0.0
            } else {
                q(1.5 + 3.0 * ((order as f64) * 0.7 + s as f64).sin().abs())
            };
            candidates.push(CandidatePoint {
                series: s,
                sample: i,
                time_s: t,
                measured_kn: ser.values_kn[i],
                pip_order: order,
                entropy_bits: entropy,
                threshold_low_kn: q(-9.0 - 0.04 * ser.values_kn[i]),
                threshold_high_kn: q(7.0 + 0.03 * ser.values_kn[i]),
                resolution_kn: q(0.4 + 0.01 * ser.values_kn[i]),
            });
        }
    }
    let eip = vec![16, 5, 14, 6, 12, 7];
    let curve = |n: usize, cap: f64, rate: f64| -> Vec<f64> {
        (1..=n)
            .map(|k| q(cap * (1.0 - (-(k as f64) / rate).exp())))
            .collect()
    };
    let cms: Vec<InstanceParams> = (0..15).map(instance).collect();
    let counts: Vec<usize> = (0..200u64)
        .map(|k| {
            // A skewed, deterministic spread around 180.
            let u = ((k * 7919 + 13) % 200) as f64 / 200.0;
            (20.0 + 420.0 * u * u + 60.0 * u) as usize
        })
        .collect();
    let mean = q(counts.iter().sum::<usize>() as f64 / counts.len() as f64);
    let mut sorted = counts.clone();
    sorted.sort_unstable();
    let median = 0.5 * (sorted[99] + sorted[100]) as f64;
    let population = ParamRanges {
        length_mm: [20.0, 120.0],
        depth_mm: [0.1, 2.0],
        curvature_mm: [0.0, 1.0],
        impact_position_m: [0.0, 3.0],
        l0_mm: [
            q((8.0f64 * 0.1 * 400.0).sqrt()),
            q((8.0f64 * 2.0 * 400.0).sqrt()),
        ],
        flat_wheels: vec![crate::model::WheelPosition::Trailing],
        impact: None,
    };
    let detected = detection(&series);
    Identification {
        measurement: "measurements/2019-03-14_train7_axle3.parquet".into(),
        speed: crate::identify::answer::result::SpeedUse {
            pass_km_per_h: Some(49.6),
            bank_km_per_h: 50.0,
        },
        load: Some(crate::identify::detect::load::LoadEstimate {
            wheel_load_kn: 47.9,
            interval_kn: [43.6, 52.7],
            car_body_mass_kg: 7173.0,
            bank_wheel_load_kn: 49.5,
            mean_level: 1.03,
            sensors: 2,
            between_members_kn: None,
        }),
        bank_id: "bank-50000-4b1e".into(),
        bank_instances: 50_000,
        population,
        alignment: Alignment {
            method: crate::identify::answer::result::AlignmentMethod::CrossCorrelation,
            shift_s: 0.01234,
            correlation: Some(0.987),
        },
        series,
        pip_distance: crate::identify::input::pip::PipDistance::Vertical,
        pips_per_series: 10,
        phi: 0.95,
        sizing: Some(Sizing {
            candidates,
            eip,
            eip_joint_entropy_bits: vec![4.4, 7.1, 9.0, 10.3, 11.1, 11.6],
            envelope: Vec::new(),
            alpha_bits: 0.05,
            entropy_curves: vec![
                EntropyCurve {
                    label: "rps1".into(),
                    joint_entropy_bits: curve(10, 7.7, 2.5),
                },
                EntropyCurve {
                    label: "rps2".into(),
                    joint_entropy_bits: curve(10, 11.2, 2.8),
                },
                EntropyCurve {
                    label: "rps1+rps2".into(),
                    joint_entropy_bits: curve(20, 12.2, 2.6),
                },
            ],
            per_point_probability: q(0.95f64.powf(1.0 / 6.0)),
            cms: cms.clone(),
            wheel_ranges: Vec::new(),
            falsifications: vec![
                Falsification {
                    method: Method::Eip {
                        envelope: false,
                        departures: false,
                    },
                    points: 6,
                    cms_count: 15,
                    ranges: hull_of(&cms),
                },
                Falsification {
                    method: Method::Equidistant,
                    points: 6,
                    cms_count: 412,
                    ranges: Some(ParamRanges {
                        length_mm: [30.0, 90.0],
                        depth_mm: [0.3, 1.2],
                        curvature_mm: [0.0, 1.0],
                        impact_position_m: [0.0, 3.0],
                        l0_mm: [31.0, 62.0],
                        flat_wheels: vec![crate::model::WheelPosition::Trailing],
                        impact: None,
                    }),
                },
                Falsification {
                    method: Method::RandomSubsets { subsets: 200 },
                    points: 20,
                    cms_count: 0,
                    ranges: None,
                },
            ],
            residual_minimisation: Some(InstanceParams {
                instance: 4242,
                length_mm: 44.0,
                depth_mm: 0.52,
                curvature_mm: 0.31,
                impact_position_m: 1.1,
                l0_mm: q((8.0f64 * 0.52 * 400.0).sqrt()),
                flat_wheel: crate::model::WheelPosition::Trailing,
            }),
            random_subsets: Some(RandomSubsets {
                subsets: 200,
                size: 6,
                cms_counts: counts,
                mean,
                median,
                seed: 7,
            }),
            model_class_refuted: false,
            below_population: false,
            shared_gains_fallback: false,
        }),
        detection: Some(detected),
        roughness: None,
        comparison: Default::default(),
        summary: SUMMARY.into(),
        maintenance_hint: "Remove the wheelset from service within 24 h (GM/RT2466: L0 > 50 mm)."
            .into(),
        severity: None,
        timings_ms: vec![
            ("load".into(), 12.5),
            ("pip".into(), 0.8),
            ("entropy".into(), 310.2),
            ("falsify".into(), 95.0),
        ],
        refinement: None,
    }
}

/// Paper-sized: 30 PIP per series, 18 EIP crowded after the impact, 500 candidate instances.
pub(super) fn dense() -> Identification {
    let mut id = identification();
    let z = id.sizing.as_mut().expect("the sample is sized");
    z.candidates.clear();
    for s in 0..2 {
        for j in 0..30usize {
            let i = if j < 2 {
                j * 299
            } else {
                110 + (j * 7 + s * 3) % 120
            };
            let m = id.series[s].values_kn[i];
            z.candidates.push(CandidatePoint {
                series: s,
                sample: i,
                time_s: q(i as f64 / RATE_HZ),
                measured_kn: m,
                pip_order: j,
                entropy_bits: if j < 2 {
                    0.0
                } else {
                    q(2.0 + 3.0 * ((j * 13 + s) as f64).sin().abs())
                },
                threshold_low_kn: q(-9.0 - 0.04 * m),
                threshold_high_kn: q(7.0 + 0.03 * m),
                resolution_kn: 0.5,
            });
        }
    }
    z.eip = vec![
        58, 33, 40, 12, 45, 50, 9, 36, 31, 47, 52, 38, 5, 42, 55, 3, 34, 44,
    ];
    z.cms = (0..500).map(instance).collect();
    id
}
