//! The grid the fusion marks each pass's hypotheses on: bins over the population's (L, d, c),
//! plus "no flat" and "a flat below the population".

use super::record::{Claim, Space, WheelPass};

/// Grid bins in L, d and c over the population (d finest: L0 is read from it; 0.01 mm of d is
/// under 0.5 mm of L0 above 20 mm).
pub(super) const BINS: [usize; 3] = [64, 90, 16];

/// The grid over the passes' populations.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Grid {
    lo: [f64; 3],
    step: [f64; 3],
    pub(super) space: Space,
}

impl Grid {
    pub(super) fn over(passes: &[&WheelPass]) -> Grid {
        let mut space = passes[0].space;
        for p in passes {
            let s = p.space;
            for (a, b) in [
                (&mut space.length_mm, s.length_mm),
                (&mut space.depth_mm, s.depth_mm),
                (&mut space.curvature_mm, s.curvature_mm),
            ] {
                *a = [a[0].min(b[0]), a[1].max(b[1])];
            }
        }
        let r = [space.length_mm, space.depth_mm, space.curvature_mm];
        Grid {
            lo: r.map(|r| r[0]),
            step: std::array::from_fn(|t| ((r[t][1] - r[t][0]) / BINS[t] as f64).max(1e-12)),
            space,
        }
    }

    pub(super) fn len(&self) -> usize {
        BINS.iter().product()
    }

    pub(super) fn bin(&self, t: usize, v: f64) -> usize {
        (((v - self.lo[t]) / self.step[t]).floor().max(0.0) as usize).min(BINS[t] - 1)
    }

    pub(super) fn index(&self, x: [f64; 3]) -> Option<usize> {
        let r = [
            self.space.length_mm,
            self.space.depth_mm,
            self.space.curvature_mm,
        ];
        (0..3)
            .all(|t| (r[t][0]..=r[t][1]).contains(&x[t]))
            .then(|| self.flat(std::array::from_fn(|t| self.bin(t, x[t]))))
    }

    pub(super) fn flat(&self, i: [usize; 3]) -> usize {
        (i[0] * BINS[1] + i[1]) * BINS[2] + i[2]
    }

    pub(super) fn unflat(&self, k: usize) -> [usize; 3] {
        [
            k / (BINS[1] * BINS[2]),
            (k / BINS[2]) % BINS[1],
            k % BINS[2],
        ]
    }

    /// The bounds of bin `i` along axis `t`.
    pub(super) fn bounds(&self, t: usize, i: usize) -> [f64; 2] {
        let a = self.lo[t] + i as f64 * self.step[t];
        [a, a + self.step[t]]
    }
}

/// A set of hypotheses: no flat, below the population, grid cells.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Hyp {
    pub(super) none: bool,
    pub(super) below: bool,
    bits: Vec<u64>,
}

impl Hyp {
    pub(super) fn empty(grid: &Grid) -> Hyp {
        Hyp {
            none: false,
            below: false,
            bits: vec![0; grid.len().div_ceil(64)],
        }
    }

    pub(super) fn get(&self, i: usize) -> bool {
        self.bits[i / 64] >> (i % 64) & 1 == 1
    }

    pub(super) fn set(&mut self, i: usize) {
        self.bits[i / 64] |= 1 << (i % 64);
    }

    pub(super) fn any_flat(&self) -> bool {
        self.bits.iter().any(|&w| w != 0)
    }

    pub(super) fn is_empty(&self) -> bool {
        !self.none && !self.below && !self.any_flat()
    }

    pub(super) fn and(&self, o: &Hyp) -> Hyp {
        Hyp {
            none: self.none && o.none,
            below: self.below && o.below,
            bits: self.bits.iter().zip(&o.bits).map(|(a, b)| a & b).collect(),
        }
    }

    /// What a pass allows.
    pub(super) fn of(p: &WheelPass, grid: &Grid) -> Hyp {
        let mut h = Hyp::empty(grid);
        h.none = p.claim.allows_small();
        h.below = p.claim.allows_small();
        for b in &p.boxes {
            let lo: [usize; 3] = std::array::from_fn(|t| grid.bin(t, f64::from(b[2 * t])));
            let hi: [usize; 3] = std::array::from_fn(|t| grid.bin(t, f64::from(b[2 * t + 1])));
            for i in lo[0]..=hi[0] {
                for j in lo[1]..=hi[1] {
                    for k in lo[2]..=hi[2] {
                        h.set(grid.flat([i, j, k]));
                    }
                }
            }
        }
        // A clean pass cannot rule out a flat below its detection limit.
        if let (Claim::None, Some(limit)) = (p.claim, p.limit_l0_mm) {
            for j in 0..BINS[1] {
                if p.space.l0_mm(grid.bounds(1, j)[0]) < limit {
                    for i in 0..BINS[0] {
                        for k in 0..BINS[2] {
                            h.set(grid.flat([i, j, k]));
                        }
                    }
                }
            }
        }
        h
    }

    /// The L0 interval (mm) the set spans: 0 for no flat, [0, floor] below.
    pub(super) fn l0(&self, grid: &Grid) -> Option<[f64; 2]> {
        let mut r: Option<[f64; 2]> = (self.none || self.below).then_some([0.0, 0.0]);
        if self.below {
            r = Some([0.0, grid.space.floor_l0_mm()]);
        }
        if let Some(d) = self.ranges(grid).map(|x| x[1]) {
            let f = [grid.space.l0_mm(d[0]), grid.space.l0_mm(d[1])];
            r = Some(r.map_or(f, |r| [r[0].min(f[0]), r[1].max(f[1])]));
        }
        r
    }

    /// The L, d, c ranges of the grid cells held.
    pub(super) fn ranges(&self, grid: &Grid) -> Option<[[f64; 2]; 3]> {
        let mut r = [[f64::INFINITY, f64::NEG_INFINITY]; 3];
        let mut any = false;
        for (w, &word) in self.bits.iter().enumerate() {
            let mut bits = word;
            while bits != 0 {
                let k = w * 64 + bits.trailing_zeros() as usize;
                bits &= bits - 1;
                any = true;
                let i = grid.unflat(k);
                for t in 0..3 {
                    let b = grid.bounds(t, i[t]);
                    r[t] = [r[t][0].min(b[0]), r[t][1].max(b[1])];
                }
            }
        }
        let pop = [
            grid.space.length_mm,
            grid.space.depth_mm,
            grid.space.curvature_mm,
        ];
        any.then(|| std::array::from_fn(|t| [r[t][0].max(pop[t][0]), r[t][1].min(pop[t][1])]))
    }
}

/// The hypotheses held by at least `need` of `hyps`.
pub(super) fn at_least(hyps: &[&Hyp], need: usize, grid: &Grid) -> Hyp {
    let mut out = Hyp::empty(grid);
    out.none = hyps.iter().filter(|h| h.none).count() >= need;
    out.below = hyps.iter().filter(|h| h.below).count() >= need;
    let mut count = vec![0u16; grid.len()];
    for h in hyps {
        for (w, &word) in h.bits.iter().enumerate() {
            let mut bits = word;
            while bits != 0 {
                count[w * 64 + bits.trailing_zeros() as usize] += 1;
                bits &= bits - 1;
            }
        }
    }
    for (k, &c) in count.iter().enumerate() {
        if c as usize >= need {
            out.set(k);
        }
    }
    out
}

pub(super) fn all_of<'a>(hyps: impl Iterator<Item = &'a Hyp>, grid: &Grid) -> Hyp {
    let mut out: Option<Hyp> = None;
    for h in hyps {
        out = Some(match out {
            None => h.clone(),
            Some(o) => o.and(h),
        });
    }
    out.unwrap_or_else(|| Hyp::empty(grid))
}
