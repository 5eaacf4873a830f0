//! What one pass says about each wheel of its bogie, in the form the fusion needs: the claim
//! (no flat, a flat below the population, a flat on the other wheel, a flat here with its
//! surviving cells, the model refuted, not seen), the L0 range and classes, and the cells.

use crate::identify::{Detection, Identification, Identifier, Severity, SeverityRange};
use crate::model::{Flat, WheelPosition};
use serde::{Deserialize, Serialize};

/// What one pass says about one wheel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Claim {
    /// No flat detected at this pass.
    None,
    /// A flat detected, smaller than every flat of the bank's population.
    Below,
    /// The flat this pass finds is on the other wheel.
    OtherWheel,
    /// A flat on this wheel, sized by the pass's surviving cells.
    Flat,
    /// A flat on this wheel or on the other (survivors carry it on both).
    FlatOrOther,
    /// Every instance falsified: the pass says nothing of the size (something the model lacks).
    Refuted,
    /// These sensors cannot see this wheel's flats at this pass.
    NotSeen,
}

impl Claim {
    /// Every claim, in the order of [`Claim::as_str`].
    pub const ALL: [Claim; 7] = [
        Claim::None,
        Claim::Below,
        Claim::OtherWheel,
        Claim::Flat,
        Claim::FlatOrOther,
        Claim::Refuted,
        Claim::NotSeen,
    ];

    /// The name the database and the JSON use.
    pub fn as_str(self) -> &'static str {
        match self {
            Claim::None => "none",
            Claim::Below => "below",
            Claim::OtherWheel => "other-wheel",
            Claim::Flat => "flat",
            Claim::FlatOrOther => "flat-or-other",
            Claim::Refuted => "refuted",
            Claim::NotSeen => "not-seen",
        }
    }

    /// The claim of a stored name.
    pub fn parse(s: &str) -> Option<Claim> {
        Claim::ALL.into_iter().find(|c| c.as_str() == s)
    }

    /// Whether the pass says anything of this wheel's flat (refuted and unseen passes do not:
    /// the fusion leaves them out and names them).
    pub fn informative(self) -> bool {
        !matches!(self, Claim::Refuted | Claim::NotSeen)
    }

    /// Whether the claim allows a good wheel or a flat below the population.
    pub fn allows_small(self) -> bool {
        matches!(
            self,
            Claim::None | Claim::Below | Claim::OtherWheel | Claim::FlatOrOther
        )
    }
}

/// The sizing space a pass was identified in: the population's bounds and the wheel radius
/// that turns a depth into the fresh-flat length L0 = sqrt(8·d·R_w).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Space {
    /// L bounds (mm).
    pub length_mm: [f64; 2],
    /// d bounds (mm).
    pub depth_mm: [f64; 2],
    /// c bounds (mm).
    pub curvature_mm: [f64; 2],
    /// Wheel radius (m).
    pub wheel_radius_m: f64,
}

impl Space {
    /// L0 (mm) of a depth (mm).
    pub fn l0_mm(&self, depth_mm: f64) -> f64 {
        Flat::fresh_length_mm(depth_mm.max(0.0), self.wheel_radius_m)
    }

    /// The smallest L0 of the population (mm): a flat below it is `below`.
    pub fn floor_l0_mm(&self) -> f64 {
        self.l0_mm(self.depth_mm[0])
    }
}

/// One wheel at one pass.
#[derive(Debug, Clone, PartialEq)]
pub struct WheelPass {
    /// The wheel of the bogie.
    pub wheel: WheelPosition,
    /// What the pass says of it.
    pub claim: Claim,
    /// The claim's L0 range (mm): its cells', `[0, floor]` below the population.
    pub l0_mm: Option<[f64; 2]>,
    /// The classes the claim spans (none for a wheel not seen).
    pub severity: Option<SeverityRange>,
    /// The bank's sizing space.
    pub space: Space,
    /// For a wheel with no flat detected: the pass's detection limit (mm), below which a
    /// flat may have gone unseen (so the fusion allows flats of smaller L0).
    pub limit_l0_mm: Option<f64>,
    /// The surviving cells with the flat on this wheel: `[L_lo, L_hi, d_lo, d_hi, c_lo,
    /// c_hi]` (mm).
    pub boxes: Vec<[f32; 6]>,
    /// The impact of the flat on this wheel: the range of its peak wheel–rail force over the
    /// static wheel load (the dynamic ratio), from the bank's stored peaks of the surviving
    /// instances; none for a wheel without a sized flat (and for passes stored before schema 2).
    pub dynamic_ratio: Option<[f64; 2]>,
}

/// One pass of one bogie, as the results database stores it.
#[derive(Debug, Clone, PartialEq)]
pub struct PassRecord {
    /// What the pass is besides its wheels: key, time, files, bank, speed, load, bogie.
    pub meta: PassMeta,
    /// Leading, then trailing wheel.
    pub wheels: [WheelPass; 2],
}

impl PassRecord {
    /// The record of one identification against `identifier`'s bank.
    pub fn of(
        id: &Identification,
        identifier: &Identifier,
        bogie_id: Option<&str>,
        key: String,
        time_s: f64,
    ) -> PassRecord {
        let meta = PassMeta {
            key,
            time_s,
            measurement: id.measurement.clone(),
            bank_id: id.bank_id.clone(),
            speed_km_per_h: id.speed.pass_km_per_h,
            bank_speed_km_per_h: id.speed.bank_km_per_h,
            load_kn: id.load.as_ref().map(|l| l.wheel_load_kn),
            bogie_id: bogie_id.map(str::to_string),
            summary: id.summary.clone(),
            result_dir: None,
            answer_ms: None,
        };
        let detection = id.detection.as_ref();
        PassRecord::of_parts(meta, detection, Some(id), identifier)
    }

    /// The record of a pass from its parts: the detection step's outcome and, when a flat was
    /// detected, the identification that sized it (a train's bogie keeps them apart).
    pub fn of_parts(
        meta: PassMeta,
        detection: Option<&Detection>,
        sized: Option<&Identification>,
        identifier: &Identifier,
    ) -> PassRecord {
        let cal = &identifier.bank().metadata().calibration;
        let space = Space {
            length_mm: cal.population.length_mm,
            depth_mm: cal.population.depth_mm,
            curvature_mm: cal.population.curvature_mm,
            wheel_radius_m: cal.vehicle.wheel_radius_m,
        };
        let wheels = [WheelPosition::Leading, WheelPosition::Trailing]
            .map(|w| wheel_pass(detection, sized, identifier, w, space));
        PassRecord { meta, wheels }
    }
}

/// What a pass record says besides its wheels.
#[derive(Debug, Clone, PartialEq)]
pub struct PassMeta {
    /// What makes the pass itself: the SHA-256 of its record (and the bogie's place in a
    /// train). A pass stored twice (a restart between storing and moving the file) is one.
    pub key: String,
    /// When the pass was identified (Unix seconds, UTC).
    pub time_s: f64,
    /// The measurement file.
    pub measurement: String,
    /// The bank (member) it was compared with.
    pub bank_id: String,
    /// The pass's speed (km/h), when stated.
    pub speed_km_per_h: Option<f64>,
    /// The bank's speed (km/h).
    pub bank_speed_km_per_h: f64,
    /// The wheel load read from the record (kN).
    pub load_kn: Option<f64>,
    /// The bogie measured, when named.
    pub bogie_id: Option<String>,
    /// The pass's verdict in words.
    pub summary: String,
    /// The folder its result was written into (`identification.json`, the report), when
    /// one was.
    pub result_dir: Option<String>,
    /// How long the answer took (ms): from the measurement read to its result written
    /// (a train's: the whole train's, on each bogie), when timed.
    pub answer_ms: Option<f64>,
}

/// What a pass says of `wheel`: from its detection step and, when it detected a flat, the
/// identification that sized it.
fn wheel_pass(
    detection: Option<&Detection>,
    sized: Option<&Identification>,
    identifier: &Identifier,
    wheel: WheelPosition,
    space: Space,
) -> WheelPass {
    let s = identifier.settings();
    let detected = detection.is_none_or(|d| d.flat_detected);
    let limit = detection.and_then(|d| d.limit.as_ref());
    let unseen = limit.is_some_and(|l| {
        l.l0_mm.is_none()
            || l.wheels
                .iter()
                .any(|w| w.wheel == wheel && w.l0_mm.is_none())
    });
    // A refined answer's own cells where there are some (`identify --refine`), else the bank's.
    let refined = sized
        .and_then(|id| id.refinement.as_ref())
        .map(|r| r.cells.as_slice())
        .filter(|c| !c.is_empty());
    if let (Some(cells), true) = (refined, detected) {
        return refined_wheel(cells, wheel, space, s);
    }
    // The sizing, with the identification it belongs to (its population).
    let sizing = sized.and_then(|id| id.sizing.as_ref().map(|z| (id, z)));
    let here = sizing.and_then(|(_, z)| z.wheel_ranges.iter().find(|w| w.wheel == wheel));
    let other = sizing.is_some_and(|(_, z)| z.wheel_ranges.iter().any(|w| w.wheel != wheel));
    let claim = match sizing {
        _ if !detected && unseen => Claim::NotSeen,
        _ if !detected => Claim::None,
        None => Claim::Refuted,
        Some((id, z)) if z.below_population => match id.population.flat_wheels.contains(&wheel) {
            true => Claim::Below,
            false => Claim::None,
        },
        Some((_, z)) if z.model_class_refuted || z.cms.is_empty() => Claim::Refuted,
        Some(_) => match (here.is_some(), other) {
            (true, true) => Claim::FlatOrOther,
            (true, false) => Claim::Flat,
            _ => Claim::OtherWheel,
        },
    };
    let floor = space.floor_l0_mm();
    let (l0_mm, severity) = match (claim, here) {
        (Claim::None | Claim::OtherWheel, _) => (None, Some(SeverityRange::single(Severity::None))),
        (Claim::Below, _) => (
            Some([0.0, floor]),
            Some(SeverityRange::of_l0(
                [0.0, floor],
                s.urgent_l0_mm,
                s.inspect_l0_mm,
            )),
        ),
        (Claim::Flat | Claim::FlatOrOther, Some(w)) => (
            Some(w.ranges.l0_mm),
            Some(SeverityRange::of_ranges(&w.ranges, s)),
        ),
        (Claim::NotSeen, _) => (None, None),
        _ => (None, Some(SeverityRange::single(Severity::Inspect))),
    };
    let boxes = match (claim, sizing) {
        (Claim::Flat | Claim::FlatOrOther, Some((_, z))) => z
            .cms
            .iter()
            .filter(|c| c.flat_wheel == wheel)
            .filter_map(|c| identifier.index_of_instance(c.instance))
            .map(|k| identifier.cell_box(k).map(|v| v as f32))
            .collect(),
        _ => Vec::new(),
    };
    let limit_l0_mm = match claim {
        Claim::None if !detected => limit.and_then(|l| {
            l.wheels
                .iter()
                .find(|w| w.wheel == wheel)
                .map_or(l.l0_mm, |w| w.l0_mm)
        }),
        _ => None,
    };
    let dynamic_ratio = match claim {
        Claim::Flat | Claim::FlatOrOther => {
            here.and_then(|w| w.ranges.impact).map(|i| i.dynamic_ratio)
        }
        _ => None,
    };
    WheelPass {
        wheel,
        claim,
        l0_mm,
        severity,
        space,
        limit_l0_mm,
        boxes,
        dynamic_ratio,
    }
}

/// What a refined answer says of `wheel`: its surviving flats' cells.
fn refined_wheel(
    cells: &[([f64; 6], WheelPosition)],
    wheel: WheelPosition,
    space: Space,
    s: &crate::model::calibration::IdentificationParams,
) -> WheelPass {
    let boxes: Vec<[f32; 6]> = cells
        .iter()
        .filter(|c| c.1 == wheel)
        .map(|c| c.0.map(|v| v as f32))
        .collect();
    let other = cells.iter().any(|c| c.1 != wheel);
    let claim = match (boxes.is_empty(), other) {
        (false, true) => Claim::FlatOrOther,
        (false, false) => Claim::Flat,
        (true, _) => Claim::OtherWheel,
    };
    let d = boxes
        .iter()
        .fold([f64::INFINITY, f64::NEG_INFINITY], |r, b| {
            [r[0].min(f64::from(b[2])), r[1].max(f64::from(b[3]))]
        });
    let l0_mm = (!boxes.is_empty()).then(|| [space.l0_mm(d[0]), space.l0_mm(d[1])]);
    let severity = match l0_mm {
        Some(l0) => SeverityRange::of_l0(l0, s.urgent_l0_mm, s.inspect_l0_mm),
        None => SeverityRange::single(Severity::None),
    };
    WheelPass {
        wheel,
        claim,
        l0_mm,
        severity: Some(severity),
        space,
        limit_l0_mm: None,
        boxes,
        dynamic_ratio: None,
    }
}

/// The boxes as stored: little-endian f32, six a box.
pub(crate) fn boxes_to_bytes(boxes: &[[f32; 6]]) -> Vec<u8> {
    boxes
        .iter()
        .flat_map(|b| b.iter().flat_map(|v| v.to_le_bytes()))
        .collect()
}

/// The boxes of stored bytes; `None` when the length is not a whole number of boxes or a
/// box is not finite and ordered.
pub(crate) fn boxes_from_bytes(bytes: &[u8]) -> Option<Vec<[f32; 6]>> {
    if !bytes.len().is_multiple_of(24) {
        return None;
    }
    let boxes: Vec<[f32; 6]> = bytes
        .chunks_exact(24)
        .map(|c| {
            std::array::from_fn(|i| {
                f32::from_le_bytes([c[4 * i], c[4 * i + 1], c[4 * i + 2], c[4 * i + 3]])
            })
        })
        .collect();
    boxes
        .iter()
        .all(|b| b.iter().all(|v| v.is_finite()) && (0..3).all(|t| b[2 * t] <= b[2 * t + 1]))
        .then_some(boxes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn claims_and_boxes_round_trip() {
        for c in Claim::ALL {
            assert_eq!(Claim::parse(c.as_str()), Some(c));
        }
        assert_eq!(Claim::parse("flat?"), None);
        let b = vec![
            [10.0, 20.0, 0.1, 0.2, 0.0, 0.05],
            [30.5, 31.0, 0.5, 0.6, 0.1, 0.2],
        ];
        assert_eq!(boxes_from_bytes(&boxes_to_bytes(&b)), Some(b));
        assert_eq!(boxes_from_bytes(&[0u8; 23]), None);
        // A box whose bounds are out of order is refused.
        let bad = boxes_to_bytes(&[[20.0, 10.0, 0.1, 0.2, 0.0, 0.05]]);
        assert_eq!(boxes_from_bytes(&bad), None);
    }
}
