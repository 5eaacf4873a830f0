//! Some instances' values of some columns, read where they lie in the mapped shards: the
//! work of a read in proportion to the instances asked for, not to the bank (the steps of the
//! landing allowance for the survivors of falsification, docs/performance.md, "Identification
//! speed"). A bank read through its layout checks each column's CRC-32 at its first read in
//! the process, as [`Bank::read_columns_flat`] does; one read through its footers decodes
//! the columns whole.

use super::layout::f32_values;
use super::reader::Bank;
use super::BankError;

impl Bank {
    /// The values of sample columns `indices` (schema indices) at `instances`: `out[j·m + i]`
    /// is column `indices[j]` at instance `instances[i]` (m = `instances.len()`).
    pub fn gather_columns(
        &self,
        indices: &[usize],
        instances: &[u32],
        out: &mut [f32],
    ) -> Result<(), BankError> {
        let m = instances.len();
        if out.len() != indices.len() * m {
            return Err(BankError::BufferSize {
                values: out.len(),
                columns: indices.len(),
                instances: m,
            });
        }
        let Some(layout) = &self.layout else {
            // Footers only: decode the columns whole, then pick.
            let n = self.instances();
            let mut whole = vec![0.0f32; indices.len() * n];
            self.read_columns_flat(indices, &mut whole)?;
            for (j, col) in whole.chunks(n.max(1)).enumerate() {
                for (o, &k) in out[j * m..(j + 1) * m].iter_mut().zip(instances) {
                    *o = col[k as usize];
                }
            }
            return Ok(());
        };
        let n_stored = self.stored_instances();
        let (stored, factor) = match &self.fold {
            Some(fold) => (
                fold.stored_columns(&self.metadata.sensors, indices)?,
                fold.factor(),
            ),
            None => (indices.to_vec(), 1),
        };
        // Where each stored instance lies: (shard, row), by the shards' rows.
        let starts: Vec<usize> = self
            .files
            .iter()
            .scan(0, |at, f| {
                let s = *at;
                *at += f.rows;
                Some(s)
            })
            .collect();
        // Each instance's (shift, shard, row), found once for every column.
        let places: Vec<(usize, usize, usize)> = instances
            .iter()
            .map(|&k| {
                let (i, shift) = match &self.fold {
                    Some(fold) => fold.split(k as usize, n_stored),
                    None => (k as usize, 0),
                };
                let s = starts.partition_point(|&st| st <= i) - 1;
                (shift, s, i - starts[s])
            })
            .collect();
        for (j, o) in out.chunks_mut(m.max(1)).enumerate().take(indices.len()) {
            for (v, &(shift, s, row)) in o.iter_mut().zip(&places) {
                let bytes = self.column_values(layout, s, stored[j * factor + shift])?;
                f32_values(&bytes[row * 4..row * 4 + 4], std::slice::from_mut(v));
            }
        }
        Ok(())
    }
}
