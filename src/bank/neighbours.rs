//! The bank's neighbour graph: every instance's [`NEIGHBOURS`] nearest other instances in the
//! unit cube the population is sampled in (L, d, c/c_max, X_p each mapped to [0, 1]), each axis
//! stretched by how fast the predictions change along it ([`cell_weights`]), among the
//! instances with the flat on the same wheel. Identification widens each instance to its cell
//! from these neighbours (`identify::cells`).
//!
//! The graph depends only on the instances' parameters and the population's ranges, so it is
//! built once, by `bank generate` and `bank merge`, and stored beside the shards as
//! `neighbours.bin`, listed in the manifest with its size and SHA-256. Opening a bank then
//! costs a checked read instead of an N·log N search. Layout (little-endian):
//!
//! ```text
//! magic   b"WFNEIGH2"         8 bytes (b"WFNEIGH1": an earlier, unstretched graph, no weights)
//! n       u64                 instances
//! k       u32                 neighbours per instance
//! id_len  u32, id             the bank id (UTF-8)
//! weights 4 · f64             the axis weights the graph was searched with (L, d, c, X_p)
//! graph   n·k u32             instance i's neighbours at [i·k, (i+1)·k)
//! ```

use super::schema::Parameters;
use super::BankError;
use crate::model::calibration::PopulationParams;
use rayon::prelude::*;
use std::path::Path;

/// Neighbours per instance: two per dimension of the 4-D parameter space.
pub const NEIGHBOURS: usize = 8;

/// The graph's file name inside a version directory.
pub const NEIGHBOURS_FILE: &str = "neighbours.bin";

const MAGIC: &[u8; 8] = b"WFNEIGH2";

/// The magic of the earlier graph format, searched in the plain unit cube.
const EARLIER_MAGIC: &[u8; 8] = b"WFNEIGH1";

/// How fast the predictions at the comparison points change with each flat parameter, in
/// threshold half-widths per millimetre (L, d, c, X_p), measured on the default calibration's
/// 60 mm flat at 50 km/h (docs/performance.md, "What the bank can resolve": L ±5 mm → 1.3–1.4,
/// d ±0.02 mm → 0.6, c ±0.02 mm → 0.45, X_p ±1 mm → 0.6–0.8 half-widths).
pub const SENSITIVITY_PER_MM: [f64; 4] = [0.27, 30.0, 22.5, 0.8];

/// The axis weights of the cells' metric for a population: each unit-cube axis stretched to
/// the threshold half-widths its whole range is worth ([`SENSITIVITY_PER_MM`] × the range;
/// c's unit axis is c/c_max, taken at the middle depth). A Hammersley set is uniform in any
/// box, so in this metric an instance's nearest neighbours lie about equally far in every
/// direction in terms of the predictions, instead of ~20 times farther along X_p.
pub fn cell_weights(pop: &PopulationParams) -> [f64; 4] {
    let span = |r: [f64; 2]| (r[1] - r[0]).max(0.0);
    let mid_depth = 0.5 * (pop.depth_mm[0] + pop.depth_mm[1]);
    let c_span = (pop.curvature_mm[1].min(mid_depth / 2.0) - pop.curvature_mm[0]).max(0.0);
    let w = [
        SENSITIVITY_PER_MM[0] * span(pop.length_mm),
        SENSITIVITY_PER_MM[1] * span(pop.depth_mm),
        SENSITIVITY_PER_MM[2] * c_span,
        SENSITIVITY_PER_MM[3] * span(pop.impact_position_m) * 1e3,
    ];
    // An axis the population does not vary along carries no distance; keep the search's box
    // non-degenerate.
    w.map(|v| v.max(1e-6))
}

/// Whether a graph searched with axis `weights` is the one [`neighbour_graph`] searches for a
/// population (the same weights, bit for bit).
pub fn in_metric_of(weights: [f64; 4], pop: &PopulationParams) -> bool {
    weights.map(f64::to_bits) == cell_weights(pop).map(f64::to_bits)
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
/// the search grows shell by shell until the k-th distance is certain. Ties go to the lower
/// index, so the graph does not depend on the thread count.
pub fn nearest(points: &[[f64; 4]], k: usize) -> Vec<u32> {
    nearest_weighted(points, [1.0; 4], k)
}

/// [`nearest`] in a stretched unit cube: coordinate t counts `weights[t]` times (the distance
/// is `Σ (w_t·Δx_t)²`). The grid has as many cells along each axis as that axis' share of
/// the box needs for cells of about equal width, so a thin box costs no more than a cube.
pub fn nearest_weighted(points: &[[f64; 4]], weights: [f64; 4], k: usize) -> Vec<u32> {
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
    // About two points a cell: a cell side h with Π(w_t / h) = n / 2.
    let volume: f64 = weights.iter().product();
    let h = (volume / (n as f64 / 2.0)).powf(0.25);
    let g: [usize; 4] = weights.map(|w| ((w / h).floor() as usize).clamp(1, 4096));
    let cell_of = |x: [f64; 4]| -> [isize; 4] {
        std::array::from_fn(|t| ((x[t] * g[t] as f64) as isize).clamp(0, g[t] as isize - 1))
    };
    let key = |c: [isize; 4]| {
        ((c[0] as usize * g[1] + c[1] as usize) * g[2] + c[2] as usize) * g[3] + c[3] as usize
    };
    let mut buckets: Vec<Vec<u32>> = vec![Vec::new(); g.iter().product()];
    for (i, x) in points.iter().enumerate() {
        buckets[key(cell_of(*x))].push(i as u32);
    }
    // Cell width along each axis in the stretched metric.
    let width: [f64; 4] = std::array::from_fn(|t| weights[t] / g[t] as f64);
    (0..n)
        .into_par_iter()
        .flat_map_iter(|i| {
            let x = points[i];
            let c = cell_of(x);
            let mut best: Vec<(f64, u32)> = Vec::with_capacity(4 * k);
            let mut r = 1isize;
            loop {
                best.clear();
                let lo: [isize; 4] = std::array::from_fn(|t| (c[t] - r).max(0));
                let hi: [isize; 4] = std::array::from_fn(|t| (c[t] + r).min(g[t] as isize - 1));
                for a in lo[0]..=hi[0] {
                    for b in lo[1]..=hi[1] {
                        for cc in lo[2]..=hi[2] {
                            for d in lo[3]..=hi[3] {
                                for &j in &buckets[key([a, b, cc, d])] {
                                    if j as usize != i {
                                        let y = points[j as usize];
                                        let d2: f64 = (0..4)
                                            .map(|t| (weights[t] * (x[t] - y[t])).powi(2))
                                            .sum();
                                        best.push((d2, j));
                                    }
                                }
                            }
                        }
                    }
                }
                best.sort_by(|p, q| p.0.total_cmp(&q.0).then(p.1.cmp(&q.1)));
                // Every point within `sure` of x is in the searched block: along each axis the
                // block reaches r cells past x's cell, unless it already spans the axis.
                let sure = (0..4)
                    .filter(|&t| !(lo[t] == 0 && hi[t] == g[t] as isize - 1))
                    .map(|t| (r as f64 * width[t]).powi(2))
                    .fold(f64::INFINITY, f64::min);
                if best.len() >= k && best[k - 1].0 <= sure {
                    break;
                }
                r += 1;
            }
            best.truncate(k);
            best.into_iter().map(|(_, j)| j).collect::<Vec<_>>()
        })
        .collect()
}

/// The neighbour graph of a bank's instances: [`NEIGHBOURS`] per instance in the metric of
/// [`cell_weights`], searched among the instances with the flat on the same wheel (the wheel
/// is not a continuous parameter).
pub fn neighbour_graph(p: &Parameters, ranges: &PopulationParams) -> Vec<u32> {
    neighbour_graph_weighted(p, ranges, cell_weights(ranges))
}

/// [`neighbour_graph`] in the unit cube stretched by `weights` (L, d, c, X_p).
pub fn neighbour_graph_weighted(
    p: &Parameters,
    ranges: &PopulationParams,
    weights: [f64; 4],
) -> Vec<u32> {
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
        let nn = nearest_weighted(&sub, weights, NEIGHBOURS);
        for (m, &i) in members.iter().enumerate() {
            for t in 0..NEIGHBOURS {
                neighbours[i * NEIGHBOURS + t] = members[nn[m * NEIGHBOURS + t] as usize] as u32;
            }
        }
    }
    neighbours
}

/// The file bytes of a graph.
pub fn encode(bank_id: &str, weights: [f64; 4], graph: &[u32]) -> Vec<u8> {
    let n = graph.len() / NEIGHBOURS;
    let mut out = Vec::with_capacity(56 + bank_id.len() + graph.len() * 4);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&(n as u64).to_le_bytes());
    out.extend_from_slice(&(NEIGHBOURS as u32).to_le_bytes());
    out.extend_from_slice(&(bank_id.len() as u32).to_le_bytes());
    out.extend_from_slice(bank_id.as_bytes());
    for w in weights {
        out.extend_from_slice(&w.to_le_bytes());
    }
    for v in graph {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out
}

/// A stored neighbour graph and the axis weights it was searched with.
#[derive(Debug, Clone, PartialEq)]
pub struct StoredGraph {
    /// The weights ([1; 4] for a graph of the earlier format).
    pub weights: [f64; 4],
    /// [`NEIGHBOURS`] per instance.
    pub graph: Vec<u32>,
}

/// The graph in a file's bytes, checked against the bank it must belong to: magic, bank id,
/// instance count, neighbours per instance, size, and every index inside the bank.
pub fn decode(
    path: &Path,
    bytes: &[u8],
    bank_id: &str,
    instances: usize,
) -> Result<StoredGraph, BankError> {
    let bad = |message: String| BankError::Corrupt {
        path: path.to_path_buf(),
        message,
    };
    let word = |at: usize, len: usize| {
        bytes
            .get(at..at + len)
            .ok_or_else(|| bad(format!("{} bytes: ends inside the header", bytes.len())))
    };
    let earlier = match word(0, 8)? {
        m if m == MAGIC => false,
        m if m == EARLIER_MAGIC => true,
        _ => return Err(bad("not a wheelflat neighbour graph (bad magic)".into())),
    };
    let n = u64::from_le_bytes(word(8, 8)?.try_into().expect("8 bytes"));
    let k = u32::from_le_bytes(word(16, 4)?.try_into().expect("4 bytes"));
    let id_len = u32::from_le_bytes(word(20, 4)?.try_into().expect("4 bytes")) as usize;
    let id = word(24, id_len.min(256))?;
    if id != bank_id.as_bytes() {
        return Err(bad(format!(
            "belongs to bank {}, not {bank_id}",
            String::from_utf8_lossy(id)
        )));
    }
    if n != instances as u64 || k as usize != NEIGHBOURS {
        return Err(bad(format!(
            "{n} instances × {k} neighbours; the bank has {instances} instances and identification uses {NEIGHBOURS}"
        )));
    }
    let mut start = 24 + id_len;
    let mut weights = [1.0f64; 4];
    if !earlier {
        for (t, w) in weights.iter_mut().enumerate() {
            *w = f64::from_le_bytes(word(start + 8 * t, 8)?.try_into().expect("8 bytes"));
        }
        if weights.iter().any(|w| !(w.is_finite() && *w > 0.0)) {
            return Err(bad(format!(
                "axis weights {weights:?}: each must be positive"
            )));
        }
        start += 32;
    }
    let expected = start + instances * NEIGHBOURS * 4;
    if bytes.len() != expected {
        return Err(bad(format!("{} bytes, expected {expected}", bytes.len())));
    }
    let graph: Vec<u32> = super::layout::u32_values(&bytes[start..]).collect();
    if let Some(v) = graph.iter().find(|&&v| v as usize >= instances) {
        return Err(bad(format!(
            "neighbour index {v} outside the bank's {instances} instances"
        )));
    }
    Ok(StoredGraph { weights, graph })
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

    #[test]
    fn weighted_grid_search_finds_the_same_neighbours_as_brute_force() {
        // A box stretched as the cells' metric stretches the unit cube (one axis 30× the
        // others), and a uniform weighting that must give the plain search's graph.
        let mut state = 9u64;
        let pts: Vec<[f64; 4]> = (0..3000)
            .map(|_| std::array::from_fn(|_| crate::bank::population::uniform(&mut state)))
            .collect();
        let w = [51.0, 27.0, 5.6, 800.0];
        let scaled: Vec<[f64; 4]> = pts
            .iter()
            .map(|x| std::array::from_fn(|t| x[t] * w[t]))
            .collect();
        let nn = nearest_weighted(&pts, w, NEIGHBOURS);
        for i in (0..pts.len()).step_by(29) {
            assert_eq!(
                &nn[i * NEIGHBOURS..(i + 1) * NEIGHBOURS],
                brute(&scaled, i, NEIGHBOURS).as_slice(),
                "point {i}"
            );
        }
        assert_eq!(
            nearest_weighted(&pts, [2.0; 4], NEIGHBOURS),
            nearest(&pts, NEIGHBOURS)
        );
    }

    #[test]
    fn a_graph_reads_back_and_foreign_or_damaged_files_are_refused() {
        let graph: Vec<u32> = (0..5 * NEIGHBOURS as u32).map(|v| v % 5).collect();
        let w = [1.5, 2.0, 0.5, 30.0];
        let bytes = encode("abc", w, &graph);
        let p = Path::new("neighbours.bin");
        let back = decode(p, &bytes, "abc", 5).unwrap();
        assert_eq!((back.weights, back.graph.as_slice()), (w, graph.as_slice()));
        // The earlier format (no weights) reads back with unit weights.
        let mut earlier = EARLIER_MAGIC.to_vec();
        earlier.extend_from_slice(&bytes[8..27]);
        earlier.extend_from_slice(&bytes[59..]);
        let back = decode(p, &earlier, "abc", 5).unwrap();
        assert_eq!((back.weights, back.graph), ([1.0; 4], graph.clone()));
        // Another bank, another size, a cut file, an index outside the bank.
        assert!(decode(p, &bytes, "abd", 5).is_err());
        assert!(decode(p, &bytes, "abc", 6).is_err());
        assert!(decode(p, &bytes[..bytes.len() - 1], "abc", 5).is_err());
        assert!(decode(p, &bytes[..10], "abc", 5).is_err());
        let mut far = bytes.clone();
        let last = far.len() - 4;
        far[last..].copy_from_slice(&9u32.to_le_bytes());
        let err = decode(p, &far, "abc", 5).unwrap_err().to_string();
        assert!(err.contains("outside"), "{err}");
    }
}
