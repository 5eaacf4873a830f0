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
//! each mapped to [0, 1]), where Hammersley points are uniformly spread, with each axis
//! stretched by how fast the predictions change along it
//! ([`crate::bank::neighbours::cell_weights`]): the cells are then about as wide in every
//! direction in terms of the predictions (about 5 mm of X_p, 14 mm of L and 0.13 mm of d on
//! the default bank), instead of 67 mm of X_p in the plain cube.

use crate::bank::Parameters;
use crate::model::calibration::PopulationParams;

pub use crate::bank::neighbours::unit_points;
pub(crate) use crate::bank::neighbours::{nearest, NEIGHBOURS};

/// The neighbour graph of a bank's instances and each instance's cell extent.
#[derive(Debug, Clone)]
pub struct Cells {
    k: usize,
    neighbours: Vec<u32>,
    /// Every instance's (L, d, c, X_p): its cell's extent is computed when asked for (only
    /// the survivors' are, so opening a bank does not pay for 50,000).
    coords: Vec<[f64; 4]>,
}

impl Cells {
    /// The cells of a bank's instances, from the neighbour graph stored with the bank
    /// (`neighbours`, see [`crate::bank::neighbours`]) or, for a bank without one, searched
    /// now. Instances with the flat on different wheels are never neighbours.
    pub fn new(p: &Parameters, ranges: &PopulationParams, neighbours: Option<&[u32]>) -> Cells {
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
        let graph = match neighbours {
            Some(g) => g.to_vec(),
            None => crate::bank::neighbours::neighbour_graph(p, ranges),
        };
        Cells::from_neighbours(graph, coords)
    }

    /// The cells of any point set: `unit` places the points for the neighbour search, `coords`
    /// (L, d, c, X_p) give the cells' physical extents.
    pub fn from_points(unit: &[[f64; 4]], coords: &[[f64; 4]]) -> Cells {
        Cells::from_neighbours(nearest(unit, NEIGHBOURS), coords.to_vec())
    }

    /// Cells from a neighbour list (the same number per point) and the points' (L, d, c, X_p).
    pub(crate) fn from_neighbours(neighbours: Vec<u32>, coords: Vec<[f64; 4]>) -> Cells {
        // Neighbours per instance: the graph's length over the instances (NEIGHBOURS for a
        // bank's stored graph; studies may give more).
        let k = if coords.is_empty() {
            NEIGHBOURS
        } else {
            (neighbours.len() / coords.len()).max(1)
        };
        assert_eq!(
            neighbours.len(),
            k * coords.len(),
            "a neighbour graph holds the same number of neighbours for every instance"
        );
        Cells {
            k,
            neighbours,
            coords,
        }
    }

    /// Instances covered.
    pub fn len(&self) -> usize {
        self.coords.len()
    }

    /// True when no instance is covered.
    pub fn is_empty(&self) -> bool {
        self.coords.is_empty()
    }

    /// The neighbours of instance `i`.
    pub fn neighbours(&self, i: usize) -> &[u32] {
        &self.neighbours[i * self.k..(i + 1) * self.k]
    }

    /// Half-way to the farthest neighbour in L (mm), d (mm), c (mm), X_p (m).
    pub fn half_extent(&self, i: usize) -> [f64; 4] {
        let x = self.coords[i];
        let mut h = [0.0f64; 4];
        for &j in self.neighbours(i) {
            let y = self.coords[j as usize];
            for t in 0..4 {
                h[t] = h[t].max(0.5 * (y[t] - x[t]).abs());
            }
        }
        h
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
