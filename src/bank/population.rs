//! The model population: a Hammersley point set over the calibration's parameter ranges
//! (docs/model.md §5 and §8, paper §4.3.3).
//!
//! Point i of N in the unit 4-cube is `((i + ½)/N, φ₂(i), φ₃(i), φ₅(i))`, `φ_b` the radical
//! inverse in base b, mapped to (L, d, c/c_max, X_p). The curvature is sampled as a fraction of
//! its largest admissible value, `c = c_lo + u·(min(c_hi, d/2) − c_lo)` with `u < 1`, so every
//! instance honours `c < d/2` (paper Eq. 9). When the population lists the flat's wheels, a
//! fifth coordinate φ₇(i) picks one. A non-zero seed applies a Cranley–Patterson
//! rotation (a seeded shift modulo 1) to the last three coordinates; seed 0 is the plain set.

use crate::model::calibration::PopulationParams;
use crate::model::{Flat, FlatError, WheelPosition};

/// The flat parameters of one model instance, in the units people read (mm, m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlatSample {
    /// Flat length L (mm).
    pub length_mm: f64,
    /// Flat depth d (mm).
    pub depth_mm: f64,
    /// Curvature parameter c (mm), `c < d/2`.
    pub curvature_mm: f64,
    /// Impact position X_p (m).
    pub impact_position_m: f64,
    /// The wheel carrying the flat, when the population spreads it over wheels (else the
    /// calibration's `vehicle.flat_wheel`).
    pub wheel: Option<WheelPosition>,
}

impl FlatSample {
    /// The flat of this instance on its wheel (`default_wheel` when the population does not
    /// choose one).
    pub fn flat(&self, default_wheel: WheelPosition) -> Result<Flat, FlatError> {
        let f = Flat::from_mm(
            self.length_mm,
            self.depth_mm,
            self.curvature_mm,
            self.impact_position_m,
        )?;
        Ok(f.on_wheel(self.wheel.unwrap_or(default_wheel)))
    }
}

/// A Hammersley population of `n` instances.
#[derive(Debug, Clone, PartialEq)]
pub struct Population {
    n: usize,
    shift: [f64; 4],
    ranges: PopulationParams,
}

/// Radical inverse of `i` in base `b`: the digits of i mirrored about the radix point.
fn radical_inverse(b: u64, mut i: u64) -> f64 {
    let inv = 1.0 / b as f64;
    let mut f = inv;
    let mut x = 0.0;
    while i > 0 {
        x += (i % b) as f64 * f;
        i /= b;
        f *= inv;
    }
    x
}

pub(crate) use crate::model::random::uniform;

impl Population {
    /// The population of `n` instances over `ranges` (checked by the calibration).
    pub fn new(ranges: &PopulationParams, n: usize, seed: u64) -> Population {
        let mut state = seed;
        let shift = if seed == 0 {
            [0.0; 4]
        } else {
            std::array::from_fn(|_| uniform(&mut state))
        };
        Population {
            n,
            shift,
            ranges: ranges.clone(),
        }
    }

    /// Number of instances.
    pub fn len(&self) -> usize {
        self.n
    }

    /// True for an empty population.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// The unit-cube point of instance `i`.
    pub fn unit_point(&self, i: usize) -> [f64; 4] {
        let i64 = i as u64;
        let rot = |u: f64, s: f64| (u + s).fract();
        [
            (i as f64 + 0.5) / self.n as f64,
            rot(radical_inverse(2, i64), self.shift[0]),
            rot(radical_inverse(3, i64), self.shift[1]),
            rot(radical_inverse(5, i64), self.shift[2]),
        ]
    }

    /// The flat of instance `i`.
    pub fn instance(&self, i: usize) -> FlatSample {
        let u = self.unit_point(i);
        let r = &self.ranges;
        let lerp = |range: [f64; 2], t: f64| range[0] + t * (range[1] - range[0]);
        let depth_mm = lerp(r.depth_mm, u[1]);
        let c_max = r.curvature_mm[1].min(depth_mm / 2.0);
        // The wheel: a fifth coordinate, φ₇(i), split evenly between the wheels listed.
        let wheel = r.flat_wheels.as_ref().map(|w| {
            let v = (radical_inverse(7, i as u64) + self.shift[3]).fract();
            w[((v * w.len() as f64) as usize).min(w.len() - 1)]
        });
        FlatSample {
            length_mm: lerp(r.length_mm, u[0]),
            depth_mm,
            curvature_mm: r.curvature_mm[0] + u[2] * (c_max - r.curvature_mm[0]),
            impact_position_m: lerp(r.impact_position_m, u[3]),
            wheel,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Calibration;

    #[test]
    fn radical_inverse_mirrors_digits() {
        assert!((radical_inverse(2, 1) - 0.5).abs() < 1e-15);
        // 6 = 110b → 0.011b = 0.375.
        assert!((radical_inverse(2, 6) - 0.375).abs() < 1e-15);
        // 5 = 12₃ → 0.21₃ = 2/3 + 1/9.
        assert!((radical_inverse(3, 5) - (2.0 / 3.0 + 1.0 / 9.0)).abs() < 1e-15);
    }

    #[test]
    fn instances_stay_in_range_and_honour_c_below_half_d() {
        let p = Calibration::paper_profile().population;
        for seed in [0, 7] {
            let pop = Population::new(&p, 5000, seed);
            for i in 0..pop.len() {
                let f = pop.instance(i);
                assert!((10.0..=200.0).contains(&f.length_mm));
                assert!((0.1..=1.0).contains(&f.depth_mm));
                assert!(f.curvature_mm >= 0.0 && f.curvature_mm < f.depth_mm / 2.0);
                assert!((12.0..=13.0).contains(&f.impact_position_m));
            }
        }
    }

    #[test]
    fn hammersley_is_evenly_spread() {
        // Each coordinate puts N/10 points (±2 %) in every tenth of the range: a property of a
        // low-discrepancy set that a random sample of 10,000 misses by ~10 %.
        let pop = Population::new(&Calibration::paper_profile().population, 10_000, 0);
        for dim in 0..4 {
            let mut bins = [0usize; 10];
            for i in 0..pop.len() {
                bins[(pop.unit_point(i)[dim] * 10.0) as usize] += 1;
            }
            assert!(
                bins.iter().all(|&b| b.abs_diff(1000) <= 20),
                "dim {dim}: {bins:?}"
            );
        }
    }
}
