//! The bank's resolution: every instance stands for the cell of parameter space around it.
//!
//! The bank holds a finite Hammersley sample; a real flat lies between instances, and where
//! the predictions change fast with the parameters (the impact transients move with X_p) the
//! instance nearest the truth can predict several kN away from the truth. EDMF's promise (the
//! truth survives with probability φ) holds for the truth's own prediction, so each instance
//! is judged for its cell: it is falsified at a point only if the measured value lies outside
//! the thresholds widened by the spread of predictions across the cell,
//! `Δ_i = κ · max_j |g_j − g_i|` over its `K` nearest neighbours j. With κ = ½ the widening
//! is what a linear change of g would give half-way to the farthest neighbour, about the
//! edge of the cell, in either direction. The parameter ranges of the candidate model set are
//! the union of the surviving instances' cells (half-way to each neighbour), so they state
//! what the bank can resolve, not just where its surviving samples happen to sit.
//!
//! Neighbours are searched in the unit cube the population is sampled in (L, d, c/c_max, X_p
//! each mapped to [0, 1]), where Hammersley points are uniformly spread.

use crate::bank::Parameters;
use crate::model::calibration::PopulationParams;
use rayon::prelude::*;

/// Neighbours per instance: two per dimension of the 4-D parameter space.
pub const NEIGHBOURS: usize = 8;

/// The neighbour graph of a bank's instances and each instance's cell extent.
#[derive(Debug, Clone)]
pub struct Cells {
    k: usize,
    neighbours: Vec<u32>,
    /// Half-way to the farthest neighbour in each of L, d, c, X_p (physical units).
    half_extent: Vec<[f64; 4]>,
}

/// Unit-cube coordinates of every instance (the space the population was sampled in).
pub fn unit_points(p: &Parameters, r: &PopulationParams) -> Vec<[f64; 4]> {
    let unit = |v: f64, range: [f64; 2]| {
        if range[1] > range[0] {
            (v - range[0]) / (range[1] - range[0])
        } else {
            0.0
        }
    };
    (0..p.length_mm.len())
        .map(|k| {
            let c_max = r.curvature_mm[1].min(p.depth_mm[k] / 2.0);
            [
                unit(p.length_mm[k], r.length_mm),
                unit(p.depth_mm[k], r.depth_mm),
                unit(p.curvature_mm[k], [r.curvature_mm[0], c_max]),
                unit(p.impact_position_m[k], r.impact_position_m),
            ]
        })
        .collect()
}

/// The `k` nearest other points of every point (Euclidean, unit cube), by a uniform grid:
/// the search grows shell by shell until the k-th distance is certain.
pub fn nearest(points: &[[f64; 4]], k: usize) -> Vec<u32> {
    let n = points.len();
    if n <= k {
        // Everyone is everyone's neighbour; the missing places repeat the point itself.
        return (0..n)
            .flat_map(|i| {
                (0..k).map(move |t| match t {
                    t if t + 1 >= n => i as u32,
                    t if t < i => t as u32,
                    t => t as u32 + 1,
                })
            })
            .collect();
    }
    let g = ((n as f64 / 2.0).powf(0.25).floor() as usize).max(1);
    let cell_of = |x: f64| ((x * g as f64) as isize).clamp(0, g as isize - 1);
    let key = |c: [isize; 4]| {
        ((c[0] as usize * g + c[1] as usize) * g + c[2] as usize) * g + c[3] as usize
    };
    let mut buckets: Vec<Vec<u32>> = vec![Vec::new(); g.pow(4)];
    for (i, x) in points.iter().enumerate() {
        buckets[key(x.map(cell_of))].push(i as u32);
    }
    let width = 1.0 / g as f64;
    (0..n)
        .into_par_iter()
        .flat_map_iter(|i| {
            let x = points[i];
            let c = x.map(cell_of);
            let mut best: Vec<(f64, u32)> = Vec::with_capacity(4 * k);
            let mut r = 1isize;
            loop {
                best.clear();
                let lo = c.map(|v| (v - r).max(0));
                let hi = c.map(|v| (v + r).min(g as isize - 1));
                for a in lo[0]..=hi[0] {
                    for b in lo[1]..=hi[1] {
                        for cc in lo[2]..=hi[2] {
                            for d in lo[3]..=hi[3] {
                                for &j in &buckets[key([a, b, cc, d])] {
                                    if j as usize != i {
                                        let y = points[j as usize];
                                        let d2: f64 = (0..4).map(|t| (x[t] - y[t]).powi(2)).sum();
                                        best.push((d2, j));
                                    }
                                }
                            }
                        }
                    }
                }
                best.sort_by(|p, q| p.0.total_cmp(&q.0).then(p.1.cmp(&q.1)));
                // Every point within r·width of x is in the searched block.
                let sure = (r as f64 * width).powi(2);
                let whole = r as usize >= g;
                if best.len() >= k && (best[k - 1].0 <= sure || whole) {
                    break;
                }
                r += 1;
            }
            best.truncate(k);
            best.into_iter().map(|(_, j)| j).collect::<Vec<_>>()
        })
        .collect()
}

impl Cells {
    /// The cells of a bank's instances. Instances with the flat on different wheels are
    /// never neighbours (the wheel is not a continuous parameter).
    pub fn new(p: &Parameters, ranges: &PopulationParams) -> Cells {
        let coords: Vec<[f64; 4]> = (0..p.length_mm.len())
            .map(|i| {
                [
                    p.length_mm[i],
                    p.depth_mm[i],
                    p.curvature_mm[i],
                    p.impact_position_m[i],
                ]
            })
            .collect();
        let unit = unit_points(p, ranges);
        let mut neighbours = vec![0u32; unit.len() * NEIGHBOURS];
        for wheel in [0u8, 1] {
            let members: Vec<usize> = (0..unit.len())
                .filter(|&i| p.flat_wheel.get(i).copied().unwrap_or(1) == wheel)
                .collect();
            if members.is_empty() {
                continue;
            }
            let sub: Vec<[f64; 4]> = members.iter().map(|&i| unit[i]).collect();
            let nn = nearest(&sub, NEIGHBOURS);
            for (m, &i) in members.iter().enumerate() {
                for t in 0..NEIGHBOURS {
                    neighbours[i * NEIGHBOURS + t] =
                        members[nn[m * NEIGHBOURS + t] as usize] as u32;
                }
            }
        }
        Cells::from_neighbours(neighbours, &coords)
    }

    /// The cells of any point set: `unit` places the points for the neighbour search, `coords`
    /// (L, d, c, X_p) give the cells' physical extents.
    pub fn from_points(unit: &[[f64; 4]], coords: &[[f64; 4]]) -> Cells {
        Cells::from_neighbours(nearest(unit, NEIGHBOURS), coords)
    }

    /// Cells from a neighbour list (`NEIGHBOURS` per point) and the points' (L, d, c, X_p).
    fn from_neighbours(neighbours: Vec<u32>, coords: &[[f64; 4]]) -> Cells {
        let k = NEIGHBOURS;
        let half_extent = (0..coords.len())
            .map(|i| {
                let x = coords[i];
                let mut h = [0.0f64; 4];
                for &j in &neighbours[i * k..(i + 1) * k] {
                    let y = coords[j as usize];
                    for t in 0..4 {
                        h[t] = h[t].max(0.5 * (y[t] - x[t]).abs());
                    }
                }
                h
            })
            .collect();
        Cells {
            k,
            neighbours,
            half_extent,
        }
    }

    /// Instances covered.
    pub fn len(&self) -> usize {
        self.half_extent.len()
    }

    /// True when no instance is covered.
    pub fn is_empty(&self) -> bool {
        self.half_extent.is_empty()
    }

    /// The neighbours of instance `i`.
    pub fn neighbours(&self, i: usize) -> &[u32] {
        &self.neighbours[i * self.k..(i + 1) * self.k]
    }

    /// Half-way to the farthest neighbour in L (mm), d (mm), c (mm), X_p (m).
    pub fn half_extent(&self, i: usize) -> [f64; 4] {
        self.half_extent[i]
    }

    /// `max_j |g_j − g_i|` over the neighbours of `i`, at one point (kN).
    pub fn spread(&self, predictions: &[f32], i: usize) -> f64 {
        let gi = predictions[i];
        self.neighbours(i)
            .iter()
            .map(|&j| (predictions[j as usize] - gi).abs())
            .fold(0.0f32, f32::max) as f64
    }

    /// Whether some neighbour of `i` predicts at least `need` kN away from it at one point
    /// (`spread ≥ need` without always visiting every neighbour).
    #[inline]
    pub fn spread_reaches(&self, predictions: &[f32], i: usize, need: f64) -> bool {
        let gi = predictions[i] as f64;
        self.neighbours(i)
            .iter()
            .any(|&j| (predictions[j as usize] as f64 - gi).abs() >= need)
    }

    /// The median spread over `anchors` instances spread evenly through the bank: the
    /// typical resolution of the bank at one point (kN).
    pub fn typical_spread(&self, predictions: &[f32], anchors: usize) -> f64 {
        let n = self.len();
        if n == 0 {
            return 0.0;
        }
        let step = (n / anchors.clamp(1, n)).max(1);
        let mut s: Vec<f64> = (0..n)
            .step_by(step)
            .map(|i| self.spread(predictions, i))
            .collect();
        let mid = s.len() / 2;
        *s.select_nth_unstable_by(mid, f64::total_cmp).1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn brute(points: &[[f64; 4]], i: usize, k: usize) -> Vec<u32> {
        let mut d: Vec<(f64, u32)> = (0..points.len())
            .filter(|&j| j != i)
            .map(|j| {
                let d2: f64 = (0..4).map(|t| (points[i][t] - points[j][t]).powi(2)).sum();
                (d2, j as u32)
            })
            .collect();
        d.sort_by(|p, q| p.0.total_cmp(&q.0).then(p.1.cmp(&q.1)));
        d.into_iter().take(k).map(|(_, j)| j).collect()
    }

    #[test]
    fn grid_search_finds_the_same_neighbours_as_brute_force() {
        let mut state = 5u64;
        let pts: Vec<[f64; 4]> = (0..3000)
            .map(|_| std::array::from_fn(|_| crate::bank::population::uniform(&mut state)))
            .collect();
        let nn = nearest(&pts, NEIGHBOURS);
        for i in (0..pts.len()).step_by(37) {
            assert_eq!(
                &nn[i * NEIGHBOURS..(i + 1) * NEIGHBOURS],
                brute(&pts, i, NEIGHBOURS).as_slice(),
                "point {i}"
            );
        }
    }
}
