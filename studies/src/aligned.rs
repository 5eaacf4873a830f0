//! Impact position as a time shift: falsification over aligned cells.
//!
//! At the comparison points that carry information (the impact transients) the prediction
//! moves by about a threshold half-width per millimetre of impact position X_p, far finer than
//! a 4-D Hammersley bank resolves (its instances are ~67 mm apart in X_p for 50,000). Moving the
//! impact by δ is, to first order, the same flat-induced response `r = g − g_flat-free` delayed
//! by δ/v. A delay by a whole number n of output samples (δ = n·v/f_s, 5.56 mm at 50 km/h and
//! 2.5 kHz) needs no interpolation, and its error against direct simulation grows with |δ|
//! (measured by `studies/src/bin/shift_error.rs`, see docs/identification.md); a fractional delay
//! interpolates an under-sampled impact and costs as much as the shift saves.
//!
//! So each instance i stands for its own (L, d, c) and for every impact position
//! `X_p,i + n·Δs`, |n| ≤ N: a *line* of virtual instances. The sub-sample part of X_p (the
//! phase `φ = X_p / Δs mod 1`) is resolved by the bank itself: instances are neighbours when
//! they are close in (L, d, c, φ) and their X_p lie within reach of an integer shift. The cell
//! widening compares each neighbour's flat-induced response *aligned* to i (delayed by the
//! whole samples between their impact positions) with i's, so the widening measures what L, d,
//! c and the phase change, not what the impact position moves:
//!
//! `pass(i, n, p) ⇔ T_low − w ≤ T(k) + r_i(k − n) − y ≤ T_high + w`,
//! `w = κ·max_j |r_j(k − n + m_ij) − r_i(k − n)| + ε_s·|n·Δs|·|r_i(k − n)|`,
//!
//! where `m_ij = round((X_p,j − X_p,i)/Δs)` and ε_s is the shift error per millimetre of shift
//! relative to the flat-induced force. An instance survives when one shift n passes at every
//! point; its X_p range is that of its passing shifts.

use rayon::prelude::*;
use wheelflat::bank::Parameters;
use wheelflat::identify::result::ParamRanges;
use wheelflat::identify::unit_points;
use wheelflat::identify::Identifier;
use wheelflat::model::calibration::PopulationParams;

/// Neighbours per instance in (L, d, c, φ).
pub const NEIGHBOURS: usize = 8;

/// Settings of the aligned falsification.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AlignedSettings {
    /// Largest shift of an instance's impact position (m): N = round(reach / Δs).
    pub reach_m: f64,
    /// Cell widening factor κ on the aligned neighbour spread.
    pub kappa: f64,
    /// Shift error per millimetre of shift, as a fraction of the flat-induced force.
    pub shift_error_per_mm: f64,
}

impl Default for AlignedSettings {
    fn default() -> Self {
        AlignedSettings {
            reach_m: 0.034,
            kappa: 0.5,
            shift_error_per_mm: 0.003,
        }
    }
}

/// The aligned neighbour graph of a bank.
#[derive(Debug, Clone)]
pub struct AlignedCells {
    /// Δs = v / f_s (m): the impact-position step of a one-sample delay.
    pub step_m: f64,
    /// N: the largest shift in samples.
    pub max_shift: i32,
    neighbours: Vec<u32>,
    offsets: Vec<i16>,
    max_offset: i32,
    half_extent: Vec<[f64; 3]>,
}

impl AlignedCells {
    /// Builds the graph: for every instance the `NEIGHBOURS` nearest in (L, d, c, φ) (unit
    /// ranges, φ circular) among the instances of the same wheel whose X_p lies within `reach`.
    pub fn new(p: &Parameters, pop: &PopulationParams, step_m: f64, reach_m: f64) -> AlignedCells {
        let n = p.length_mm.len();
        let unit = unit_points(p, pop);
        let phase: Vec<f64> = p
            .impact_position_m
            .iter()
            .map(|x| (x / step_m).rem_euclid(1.0))
            .collect();
        let mut order: Vec<u32> = (0..n as u32).collect();
        order.sort_by(|&a, &b| {
            p.impact_position_m[a as usize]
                .total_cmp(&p.impact_position_m[b as usize])
                .then(a.cmp(&b))
        });
        let xs: Vec<f64> = order
            .iter()
            .map(|&i| p.impact_position_m[i as usize])
            .collect();
        let k = NEIGHBOURS;
        let lists: Vec<Vec<(u32, i16)>> = (0..n)
            .into_par_iter()
            .map(|i| {
                let x = p.impact_position_m[i];
                let lo = xs.partition_point(|&v| v < x - reach_m);
                let hi = xs.partition_point(|&v| v <= x + reach_m);
                let wheel = p.flat_wheel.get(i).copied();
                let mut best: Vec<(f64, u32)> = Vec::with_capacity(k + 1);
                for &j in &order[lo..hi] {
                    let j = j as usize;
                    if j == i || p.flat_wheel.get(j).copied() != wheel {
                        continue;
                    }
                    let dphi = (phase[i] - phase[j]).abs();
                    let dphi = dphi.min(1.0 - dphi);
                    let d2 = (0..3)
                        .map(|t| (unit[i][t] - unit[j][t]).powi(2))
                        .sum::<f64>()
                        + dphi * dphi;
                    if best.len() < k || d2 < best[k - 1].0 {
                        let at = best.partition_point(|b| (b.0, b.1) < (d2, j as u32));
                        best.insert(at, (d2, j as u32));
                        best.truncate(k);
                    }
                }
                best.iter()
                    .map(|&(_, j)| {
                        let m = ((p.impact_position_m[j as usize] - x) / step_m).round();
                        (j, m as i16)
                    })
                    .collect()
            })
            .collect();
        let mut neighbours = Vec::with_capacity(n * k);
        let mut offsets = Vec::with_capacity(n * k);
        let mut half_extent = Vec::with_capacity(n);
        for (i, list) in lists.iter().enumerate() {
            let mut h = [0.0f64; 3];
            for t in 0..k {
                // Too few instances within reach: the missing places repeat i itself.
                let (j, m) = list.get(t).copied().unwrap_or((i as u32, 0));
                neighbours.push(j);
                offsets.push(m);
                let (a, b) = (
                    [p.length_mm[i], p.depth_mm[i], p.curvature_mm[i]],
                    [
                        p.length_mm[j as usize],
                        p.depth_mm[j as usize],
                        p.curvature_mm[j as usize],
                    ],
                );
                for s in 0..3 {
                    h[s] = h[s].max(0.5 * (a[s] - b[s]).abs());
                }
            }
            half_extent.push(h);
        }
        AlignedCells {
            step_m,
            max_shift: (reach_m / step_m).round() as i32,
            max_offset: offsets.iter().map(|m| (*m as i32).abs()).max().unwrap_or(0),
            neighbours,
            offsets,
            half_extent,
        }
    }

    /// The neighbours of `i` with their whole-sample offsets `m_ij`.
    pub fn neighbours(&self, i: usize) -> impl Iterator<Item = (usize, i32)> + '_ {
        let r = i * NEIGHBOURS..(i + 1) * NEIGHBOURS;
        self.neighbours[r.clone()]
            .iter()
            .zip(&self.offsets[r])
            .map(|(&j, &m)| (j as usize, m as i32))
    }

    /// Half-way to the farthest neighbour in L, d, c (mm).
    pub fn half_extent(&self, i: usize) -> [f64; 3] {
        self.half_extent[i]
    }

    /// The largest |m_ij|.
    pub fn max_offset(&self) -> i32 {
        self.max_offset
    }
}

/// One comparison point with the bank columns around it.
#[derive(Debug, Clone)]
pub struct ShiftPoint<'a> {
    /// Sample of the point in its window.
    pub sample: usize,
    /// Bank columns of the window's samples `first..first + columns.len()`.
    pub columns: Vec<&'a [f32]>,
    /// First sample of `columns`.
    pub first: usize,
    /// The flat-free prediction of the whole window (kN).
    pub template: &'a [f32],
    /// Measured value (kN).
    pub measured_kn: f64,
    /// Thresholds on prediction − measurement (kN).
    pub low_kn: f64,
    /// Upper threshold (kN).
    pub high_kn: f64,
}

impl ShiftPoint<'_> {
    /// r_i at window sample `s` (None outside the columns read).
    #[inline]
    fn response_at(&self, i: usize, s: isize) -> Option<f64> {
        let at = s - self.first as isize;
        if at < 0 || at as usize >= self.columns.len() {
            return None;
        }
        Some(self.columns[at as usize][i] as f64 - self.template[s as usize] as f64)
    }

    #[inline]
    fn passes(&self, cells: &AlignedCells, st: &AlignedSettings, i: usize, n: i32) -> bool {
        let s = self.sample as isize - n as isize;
        let Some(r) = self.response_at(i, s) else {
            return false;
        };
        let g = self.template[self.sample] as f64 + r;
        let resid = g - self.measured_kn;
        let shift_w = st.shift_error_per_mm * (n as f64 * cells.step_m * 1e3).abs() * r.abs();
        let (lo, hi) = (self.low_kn - shift_w, self.high_kn + shift_w);
        if resid >= lo && resid <= hi {
            return true;
        }
        if st.kappa <= 0.0 {
            return false;
        }
        let need = if resid > hi { resid - hi } else { lo - resid } / st.kappa;
        cells.neighbours(i).any(|(j, m)| {
            self.response_at(j, s + m as isize)
                .is_some_and(|rj| (rj - r).abs() >= need)
        })
    }
}

/// A surviving instance with its passing shifts `[n_min, n_max]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Survivor {
    /// Instance row.
    pub row: u32,
    /// Smallest passing shift.
    pub n_min: i32,
    /// Largest passing shift.
    pub n_max: i32,
}

/// Falsifies every instance over its shifts.
pub fn falsify_aligned(
    points: &[ShiftPoint],
    cells: &AlignedCells,
    st: &AlignedSettings,
    instances: usize,
) -> Vec<Survivor> {
    let nmax = cells.max_shift;
    (0..instances as u32)
        .into_par_iter()
        .filter_map(|i| {
            let mut lo = None;
            let mut hi = None;
            for n in -nmax..=nmax {
                if points.iter().all(|p| p.passes(cells, st, i as usize, n)) {
                    lo.get_or_insert(n);
                    hi = Some(n);
                }
            }
            Some(Survivor {
                row: i,
                n_min: lo?,
                n_max: hi?,
            })
        })
        .collect()
}

/// The ranges reported for physical bounds `[lo, hi]` of L, d, c (mm) and X_p (m), clamped to
/// the population, with L0 from the depth bounds.
pub fn bounds_to_ranges(
    b: [[f64; 2]; 4],
    pop: &PopulationParams,
    wheel_radius_m: f64,
    wheels: Vec<wheelflat::model::WheelPosition>,
) -> ParamRanges {
    let clamp = |v: [f64; 2], c: [f64; 2]| [v[0].max(c[0]), v[1].min(c[1])];
    let depth_mm = clamp(b[1], pop.depth_mm);
    let l0 = |d: f64| wheelflat::model::Flat::fresh_length_mm(d, wheel_radius_m);
    ParamRanges {
        length_mm: clamp(b[0], pop.length_mm),
        depth_mm,
        curvature_mm: clamp(b[2], pop.curvature_mm),
        impact_position_m: b[3],
        l0_mm: [l0(depth_mm[0]), l0(depth_mm[1])],
        flat_wheels: wheels,
        impact: None,
    }
}

/// The union of bounds.
pub fn union(all: impl Iterator<Item = [[f64; 2]; 4]>) -> Option<[[f64; 2]; 4]> {
    all.reduce(|k, b| std::array::from_fn(|t| [k[t][0].min(b[t][0]), k[t][1].max(b[t][1])]))
}

/// The parameter ranges of aligned survivors: the union of their (L, d, c) cells and of
/// the impact positions of their passing shifts (± half a step).
pub fn aligned_ranges(
    id: &Identifier,
    cells: &AlignedCells,
    survivors: &[Survivor],
) -> Option<ParamRanges> {
    let cal = &id.bank().metadata().calibration;
    let p = id.params();
    let b = union(survivors.iter().map(|s| {
        let i = s.row as usize;
        let h = cells.half_extent(i);
        let v = [p.length_mm[i], p.depth_mm[i], p.curvature_mm[i]];
        let x = p.impact_position_m[i];
        [
            [v[0] - h[0], v[0] + h[0]],
            [v[1] - h[1], v[1] + h[1]],
            [v[2] - h[2], v[2] + h[2]],
            [
                x + (s.n_min as f64 - 0.5) * cells.step_m,
                x + (s.n_max as f64 + 0.5) * cells.step_m,
            ],
        ]
    }))?;
    let wheels =
        wheelflat::identify::wheels_of(survivors.iter().map(|s| p.flat_wheel[s.row as usize]));
    Some(bounds_to_ranges(
        b,
        &cal.population,
        cal.vehicle.wheel_radius_m,
        wheels,
    ))
}

/// Which comparison points the aligned falsification uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AlignedPoints {
    /// The joint-entropy points of the identification.
    Eip,
    /// Every PIP.
    AllPips,
}

/// What the aligned falsification found for one measurement.
#[derive(Debug, Clone)]
pub struct AlignedOutcome {
    /// The bank-only identification it starts from (its PIPs and EIP).
    pub base: wheelflat::identify::Identification,
    /// Surviving instances and shifts.
    pub survivors: Vec<Survivor>,
    /// Their parameter ranges.
    pub ranges: Option<ParamRanges>,
    /// Comparison points used.
    pub points: usize,
    /// Bank columns read.
    pub columns: usize,
    /// Time to read the columns (ms).
    pub read_ms: f64,
    /// Time of the falsification (ms).
    pub falsify_ms: f64,
}

/// Identifies `m` as [`Identifier::identify`] does, then falsifies over aligned cells.
pub fn identify_aligned(
    id: &Identifier,
    m: &wheelflat::identify::Measurement,
    sensors: Option<&[String]>,
    cells: &AlignedCells,
    st: &AlignedSettings,
    which: AlignedPoints,
) -> Result<AlignedOutcome, wheelflat::identify::IdentifyError> {
    let base = id.identify(m, sensors, wheelflat::identify::Extras::NONE)?;
    let meta = id.bank().metadata();
    let axes: Vec<usize> = base
        .series
        .iter()
        .map(|s| {
            meta.sensors
                .iter()
                .position(|a| a.name == s.sensor)
                .expect("an identification keeps only the bank's sensors")
        })
        .collect();
    // A pass that was not sized (no flat detected) has no points to compare at.
    let candidates: &[wheelflat::identify::result::CandidatePoint] =
        base.sizing.as_ref().map_or(&[], |z| &z.candidates);
    let chosen: Vec<usize> = match which {
        AlignedPoints::Eip => base
            .sizing
            .as_ref()
            .map_or_else(Vec::new, |z| z.eip.clone()),
        AlignedPoints::AllPips => (0..candidates.len()).collect(),
    };
    let prob = base.phi.powf(1.0 / chosen.len().max(1) as f64);
    let reach = (cells.max_shift + cells.max_offset()) as usize;
    let clock = std::time::Instant::now();
    let mut cols: Vec<usize> = Vec::new();
    let mut spans = Vec::new();
    for &c in &chosen {
        let cp = &candidates[c];
        let len = base.series[cp.series].values_kn.len();
        let first = cp.sample.saturating_sub(reach);
        let end = (cp.sample + reach + 1).min(len);
        spans.push((cp.series, first, end));
        for s in first..end {
            cols.push(id.bank().sample_index(axes[cp.series], s));
        }
    }
    cols.sort_unstable();
    cols.dedup();
    let uniq = cols;
    let data = id.bank().read_columns(&uniq)?;
    let read_ms = clock.elapsed().as_secs_f64() * 1e3;
    let col = |c: usize| data[uniq.binary_search(&c).expect("read")].as_slice();
    let points: Vec<ShiftPoint> = chosen
        .iter()
        .zip(&spans)
        .map(|(&c, &(si, first, end))| {
            let cp = &candidates[c];
            let (lo, hi) = id.thresholds(cp.measured_kn, prob);
            ShiftPoint {
                sample: cp.sample,
                columns: (first..end)
                    .map(|s| col(id.bank().sample_index(axes[si], s)))
                    .collect(),
                first,
                template: &meta.flat_free_kn[axes[si]],
                measured_kn: cp.measured_kn,
                low_kn: lo,
                high_kn: hi,
            }
        })
        .collect();
    let clock = std::time::Instant::now();
    let survivors = falsify_aligned(&points, cells, st, id.bank().instances());
    let falsify_ms = clock.elapsed().as_secs_f64() * 1e3;
    let ranges = aligned_ranges(id, cells, &survivors);
    Ok(AlignedOutcome {
        base,
        survivors,
        ranges,
        points: chosen.len(),
        columns: uniq.len(),
        read_ms,
        falsify_ms,
    })
}

/// The aligned neighbour graph of this identifier's bank.
pub fn aligned_cells(id: &Identifier, reach_m: f64) -> AlignedCells {
    let cal = &id.bank().metadata().calibration;
    let step = cal.run.speed_km_per_h / 3.6 / cal.output.sample_rate_hz;
    AlignedCells::new(id.params(), &cal.population, step, reach_m)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(xs: &[[f64; 4]]) -> Parameters {
        Parameters {
            instance: (0..xs.len() as u32).collect(),
            length_mm: xs.iter().map(|x| x[0]).collect(),
            depth_mm: xs.iter().map(|x| x[1]).collect(),
            curvature_mm: xs.iter().map(|x| x[2]).collect(),
            impact_position_m: xs.iter().map(|x| x[3]).collect(),
            l0_mm: vec![0.0; xs.len()],
            flat_wheel: vec![1; xs.len()],
            peak_contact_kn: vec![0.0; xs.len()],
        }
    }

    fn population() -> PopulationParams {
        let mut p = wheelflat::model::Calibration::default().population;
        p.length_mm = [10.0, 200.0];
        p.depth_mm = [0.1, 1.0];
        p.curvature_mm = [0.0, 0.05];
        p.impact_position_m = [12.0, 13.0];
        p
    }

    /// The neighbours are the nearest in (L, d, c, φ) among the instances within reach, with
    /// the whole-sample offsets between their impact positions; checked against brute force.
    #[test]
    fn neighbours_are_the_nearest_within_reach_with_their_offsets() {
        let mut state = 7u64;
        let mut u = || crate::study::splitmix_uniform(&mut state);
        let xs: Vec<[f64; 4]> = (0..400)
            .map(|_| [10.0 + 190.0 * u(), 0.2 + 0.8 * u(), 0.1 * u(), 12.0 + u()])
            .collect();
        let (p, pop) = (params(&xs), population());
        let (step, reach) = (0.005, 0.1);
        let cells = AlignedCells::new(&p, &pop, step, reach);
        let unit = unit_points(&p, &pop);
        for i in (0..xs.len()).step_by(23) {
            let mut all: Vec<(f64, usize)> = (0..xs.len())
                .filter(|&j| j != i && (xs[j][3] - xs[i][3]).abs() <= reach)
                .map(|j| {
                    let (a, b) = (
                        (xs[i][3] / step).rem_euclid(1.0),
                        (xs[j][3] / step).rem_euclid(1.0),
                    );
                    let dphi = (a - b).abs().min(1.0 - (a - b).abs());
                    let d2 = (0..3)
                        .map(|t| (unit[i][t] - unit[j][t]).powi(2))
                        .sum::<f64>()
                        + dphi * dphi;
                    (d2, j)
                })
                .collect();
            all.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            let got: Vec<(usize, i32)> = cells.neighbours(i).collect();
            for (t, &(j, m)) in got.iter().enumerate() {
                assert_eq!(j, all[t].1, "instance {i}, neighbour {t}");
                assert_eq!(m, ((xs[j][3] - xs[i][3]) / step).round() as i32);
            }
        }
    }

    /// A measurement that is an instance's response delayed by three samples keeps that
    /// instance at exactly the shift n = 3, and no other shift within reach (thresholds far
    /// smaller than a one-sample change of the pulse).
    #[test]
    fn a_delayed_response_is_found_at_its_whole_sample_shift() {
        let xs = [[50.0, 0.5, 0.0, 12.5], [150.0, 0.9, 0.0, 12.5]];
        let (p, pop) = (params(&xs), population());
        let cells = AlignedCells::new(&p, &pop, 0.005, 0.03);
        assert_eq!(cells.max_shift, 6);
        let len = 60;
        let template = vec![10.0f32; len];
        let pulse = |k: usize, a: f32| 10.0 + a * (-((k as f32 - 30.0) / 2.0).powi(2)).exp();
        let columns: Vec<Vec<f32>> = (0..len)
            .map(|k| vec![pulse(k, 40.0), pulse(k, 80.0)])
            .collect();
        let points: Vec<ShiftPoint> = (25..40)
            .map(|k| ShiftPoint {
                sample: k,
                columns: columns.iter().map(Vec::as_slice).collect(),
                first: 0,
                template: &template,
                measured_kn: pulse(k - 3, 40.0) as f64,
                low_kn: -0.5,
                high_kn: 0.5,
            })
            .collect();
        let st = AlignedSettings {
            kappa: 0.0,
            shift_error_per_mm: 0.0,
            ..AlignedSettings::default()
        };
        let kept = falsify_aligned(&points, &cells, &st, 2);
        assert_eq!(
            kept,
            vec![Survivor {
                row: 0,
                n_min: 3,
                n_max: 3
            }]
        );
    }
}
