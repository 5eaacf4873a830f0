//! A resident process's bank brought into memory before its first pass (`watch`): every page
//! of the mapped shards read once, so the first pass finds the columns it reads in the page
//! cache and mapped into the process, as the hundredth does (docs/performance.md, "A day's
//! traffic"). A one-shot `identify` does not: it reads only the columns its pass needs.

use super::reader::Bank;
use rayon::prelude::*;

/// The page size the touches step by (a larger kernel page is touched more than once).
const PAGE: usize = 4096;

impl Bank {
    /// Reads one byte of every page of the mapped shard files (the files in parallel);
    /// returns the bytes brought in.
    pub fn warm(&self) -> u64 {
        self.files
            .par_iter()
            .map(|f| {
                let bytes: &[u8] = &f.bytes;
                let sum = bytes
                    .iter()
                    .step_by(PAGE)
                    .fold(0u8, |s, &b| s.wrapping_add(b));
                std::hint::black_box(sum);
                bytes.len() as u64
            })
            .sum()
    }
}
