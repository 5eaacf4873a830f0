//! The parameter ranges an identification reports: of a set of surviving instances (the
//! union of their cells, or their hull) and of the whole population, with L0 from the depth
//! bounds through [`Flat::fresh_length_mm`].

use crate::bank::Parameters;
use crate::identify::answer::result::{ImpactRange, InstanceParams, ParamRanges};
use crate::identify::domain::cells::Cells;
use crate::identify::identifier::Identifier;
use crate::model::calibration::PopulationParams;
use crate::model::{Calibration, Flat, WheelPosition};

/// The parameter ranges of a set of instances: the union of their cells when `cells` is
/// given (what the bank can resolve), else the hull of the instances themselves.
pub(crate) fn ranges_of(
    params: &Parameters,
    cells: Option<&Cells>,
    population: &PopulationParams,
    (wheel_radius_m, static_wheel_load_kn): (f64, f64),
    members: impl Iterator<Item = usize> + Clone,
) -> Option<ParamRanges> {
    members.clone().next()?;
    let r = |v: &[f64], t: usize, clamp: [f64; 2]| {
        let [lo, hi] = members.clone().fold([f64::MAX, f64::MIN], |[lo, hi], k| {
            let h = cells.map_or(0.0, |c| c.half_extent(k)[t]);
            [lo.min(v[k] - h), hi.max(v[k] + h)]
        });
        [lo.max(clamp[0]), hi.min(clamp[1])]
    };
    let depth_mm = r(&params.depth_mm, 1, population.depth_mm);
    let l0 = |d: f64| Flat::fresh_length_mm(d, wheel_radius_m);
    Some(ParamRanges {
        length_mm: r(&params.length_mm, 0, population.length_mm),
        depth_mm,
        curvature_mm: r(&params.curvature_mm, 2, population.curvature_mm),
        impact_position_m: r(&params.impact_position_m, 3, population.impact_position_m),
        l0_mm: [l0(depth_mm[0]), l0(depth_mm[1])],
        flat_wheels: wheels_of(members.clone().map(|k| params.flat_wheel[k])),
        impact: impact_of(params, cells, static_wheel_load_kn, members),
    })
}

/// The impact range of a set of instances: over the instances and, with `cells`, the
/// neighbours their cells reach (the flats between instances make impacts between theirs).
/// `None` for a bank without stored peak forces.
fn impact_of(
    params: &Parameters,
    cells: Option<&Cells>,
    static_wheel_load_kn: f64,
    members: impl Iterator<Item = usize>,
) -> Option<ImpactRange> {
    let peak = &params.peak_contact_kn;
    if peak.len() != params.length_mm.len() {
        return None;
    }
    let mut range = [f64::INFINITY, f64::NEG_INFINITY];
    for k in members {
        let cell = cells.map_or(&[][..], |c| c.neighbours(k));
        for j in std::iter::once(k).chain(cell.iter().map(|&j| j as usize)) {
            range = [range[0].min(peak[j]), range[1].max(peak[j])];
        }
    }
    range[0].is_finite().then(|| ImpactRange {
        peak_contact_kn: range,
        dynamic_ratio: range.map(|f| f / static_wheel_load_kn),
    })
}

/// The distinct wheels among stored wheel codes, leading first.
pub fn wheels_of(codes: impl Iterator<Item = u8>) -> Vec<WheelPosition> {
    let mut seen = [false; 2];
    for c in codes {
        seen[usize::from(c != 0)] = true;
    }
    [WheelPosition::Leading, WheelPosition::Trailing]
        .into_iter()
        .filter(|w| seen[w.index()])
        .collect()
}

/// The parameters of instance `k`.
pub(crate) fn instance(params: &Parameters, k: usize) -> InstanceParams {
    InstanceParams {
        instance: params.instance[k],
        length_mm: params.length_mm[k],
        depth_mm: params.depth_mm[k],
        curvature_mm: params.curvature_mm[k],
        impact_position_m: params.impact_position_m[k],
        l0_mm: params.l0_mm[k],
        flat_wheel: WheelPosition::from_code(params.flat_wheel[k]),
    }
}

/// The population bounds of a bank's calibration (the axes of the parallel-coordinates plot):
/// its ranges, L0 from the depth bounds, and the wheels that may carry the flat.
pub(crate) fn population_ranges(cal: &Calibration) -> ParamRanges {
    let p = &cal.population;
    let l0 = |d: f64| Flat::fresh_length_mm(d, cal.vehicle.wheel_radius_m);
    ParamRanges {
        length_mm: p.length_mm,
        depth_mm: p.depth_mm,
        curvature_mm: p.curvature_mm,
        impact_position_m: p.impact_position_m,
        l0_mm: [l0(p.depth_mm[0]), l0(p.depth_mm[1])],
        flat_wheels: p
            .flat_wheels
            .clone()
            .unwrap_or_else(|| vec![cal.vehicle.flat_wheel]),
        impact: None,
    }
}

impl crate::identify::identifier::Identifier {
    /// The index of the instance numbered `id` in the bank as read (its number itself for
    /// every bank wheelflat writes; searched otherwise).
    pub fn index_of_instance(&self, id: u32) -> Option<usize> {
        let ids = &self.params.instance;
        match ids.get(id as usize) {
            Some(&x) if x == id => Some(id as usize),
            _ => ids.iter().position(|&x| x == id),
        }
    }

    /// The cell of instance `k` in (L, d, c): `[L_lo, L_hi, d_lo, d_hi, c_lo, c_hi]` (mm),
    /// half-way to its farthest neighbour each way, clamped to the population — what the bank
    /// can resolve around it (the same extents the reported ranges are the union of). The
    /// results database stores a pass's surviving cells so that passes can be fused.
    pub fn cell_box(&self, k: usize) -> [f64; 6] {
        let pop = &self.bank.metadata().calibration.population;
        let h = self.cells.half_extent(k);
        let x = [
            self.params.length_mm[k],
            self.params.depth_mm[k],
            self.params.curvature_mm[k],
        ];
        let clamp = [pop.length_mm, pop.depth_mm, pop.curvature_mm];
        let mut b = [0.0; 6];
        for t in 0..3 {
            b[2 * t] = (x[t] - h[t]).max(clamp[t][0]);
            b[2 * t + 1] = (x[t] + h[t]).min(clamp[t][1]);
        }
        b
    }
}

impl Identifier {
    /// The parameter ranges a set of instances stands for.
    pub(in crate::identify) fn ranges(
        &self,
        members: impl Iterator<Item = usize> + Clone,
    ) -> Option<ParamRanges> {
        let cal = &self.bank.metadata().calibration;
        ranges_of(
            &self.params,
            self.resolution().map(|r| r.cells),
            &cal.population,
            (
                cal.vehicle.wheel_radius_m,
                cal.vehicle.static_wheel_load_n() / 1e3,
            ),
            members,
        )
    }
}
