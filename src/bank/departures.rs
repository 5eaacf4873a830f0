//! How far each instance's prediction departs from the bank's flat-free prediction, per
//! sensor: the largest `|g_i,k − g_free,k|` over the sensor's window and the flat-free force
//! at that sample. Identification's detection step (`identify::detect`) turns these into the
//! detection limit of a pass (the smallest flat it would have shown) without reading the bank's
//! columns: the table is 2 × sensors × N f32 (2 MB for 50,000 instances and five sensors).
//!
//! The table depends only on the bank's contents, so it is derived once and kept beside the
//! shards as `departures.bin` (written by `bank generate` when it completes a version, or by
//! the first identification that needs it). A rough pass is compared through the 5-sample
//! binomial average (`identify::compare`): its table, of the averaged predictions against the
//! averaged flat-free one, is `departures-binomial5.bin`, the same layout. It is a cache, not part of the manifest: a file
//! that fails its checks (magic, bank id, sizes, CRC-32) is computed again, never trusted.
//! Layout (little-endian):
//!
//! ```text
//! magic    b"WFDEPAR1"        8 bytes
//! n        u64                instances
//! sensors  u32                sensors (the bank's axis order)
//! id_len   u32, id            the bank id (UTF-8)
//! values   sensors · 2 · n f32  per sensor: n departures (kN), then n flat-free forces (kN)
//! crc      u32                CRC-32 of everything before it
//! ```

use super::reader::Bank;
use super::BankError;
use rayon::prelude::*;
use std::path::PathBuf;

/// The table's file name inside a version directory.
pub(crate) const DEPARTURES_FILE: &str = "departures.bin";

/// The averaged table's file name inside a version directory.
pub(crate) const AVERAGED_DEPARTURES_FILE: &str = "departures-binomial5.bin";

const MAGIC: &[u8; 8] = b"WFDEPAR1";

/// Columns read at a time while computing (64 × 50,000 × 4 B = 12.8 MB).
const BLOCK_COLUMNS: usize = 64;

/// Each instance's largest departure from the flat-free prediction, per sensor.
#[derive(Debug, Clone, PartialEq)]
pub struct Departures {
    /// Instances.
    pub instances: usize,
    /// Per sensor (bank axis order), per instance: the largest `|g − g_free|` (kN).
    pub departure_kn: Vec<Vec<f32>>,
    /// Per sensor, per instance: `|g_free|` at that sample (kN).
    pub flat_free_kn: Vec<Vec<f32>>,
}

/// The departures of every instance of `bank`, read column block by column block, of the
/// predictions through the centred average `weights` (`[1.0]`: the samples as stored).
pub(crate) fn compute(bank: &Bank, weights: &[f64]) -> Result<Departures, BankError> {
    let meta = bank.metadata();
    let n = bank.instances();
    let h = weights.len() / 2;
    let mut departure_kn = Vec::with_capacity(meta.sensors.len());
    let mut flat_free_kn = Vec::with_capacity(meta.sensors.len());
    let mut buffer = vec![0.0f32; BLOCK_COLUMNS * n];
    let mut stored = vec![0.0f32; (BLOCK_COLUMNS + 2 * h) * n];
    for (s, axis) in meta.sensors.iter().enumerate() {
        let raw: Vec<f64> = meta.flat_free_kn[s].iter().map(|&g| f64::from(g)).collect();
        let template: Vec<f32> = crate::model::average::centred_average(&raw, weights)
            .into_iter()
            .map(|g| g as f32)
            .collect();
        let mut dep = vec![0.0f32; n];
        let mut force = vec![0.0f32; n];
        for start in (0..axis.samples).step_by(BLOCK_COLUMNS) {
            let ks: Vec<usize> = (start..(start + BLOCK_COLUMNS).min(axis.samples)).collect();
            let block = &mut buffer[..ks.len() * n];
            if h == 0 {
                let cols: Vec<usize> = ks.iter().map(|&k| bank.sample_index(s, k)).collect();
                bank.read_columns_flat(&cols, block)?;
            } else {
                // The stored samples the block's averages reach, then each average.
                let lo = start.saturating_sub(h);
                let hi = (ks[ks.len() - 1] + h).min(axis.samples - 1);
                let cols: Vec<usize> = (lo..=hi).map(|k| bank.sample_index(s, k)).collect();
                let reach = &mut stored[..cols.len() * n];
                bank.read_columns_flat(&cols, reach)?;
                for (j, &k) in ks.iter().enumerate() {
                    let (first, w) = crate::model::average::weights_at(k, axis.samples, weights);
                    let out = &mut block[j * n..(j + 1) * n];
                    for (i, o) in out.iter_mut().enumerate() {
                        *o = w
                            .iter()
                            .enumerate()
                            .map(|(t, w)| w * f64::from(reach[(first + t - lo) * n + i]))
                            .sum::<f64>() as f32;
                    }
                }
            }
            const CHUNK: usize = 4096;
            dep.par_chunks_mut(CHUNK)
                .zip(force.par_chunks_mut(CHUNK))
                .enumerate()
                .for_each(|(c, (dep, force))| {
                    let from = c * CHUNK;
                    for (j, &k) in ks.iter().enumerate() {
                        let t = template[k];
                        let col = &block[j * n + from..j * n + from + dep.len()];
                        for ((d, f), &g) in dep.iter_mut().zip(force.iter_mut()).zip(col) {
                            let x = (g - t).abs();
                            if x > *d {
                                *d = x;
                                *f = t.abs();
                            }
                        }
                    }
                });
        }
        departure_kn.push(dep);
        flat_free_kn.push(force);
    }
    Ok(Departures {
        instances: n,
        departure_kn,
        flat_free_kn,
    })
}

/// The file's bytes.
pub(crate) fn encode(bank_id: &str, d: &Departures) -> Vec<u8> {
    let mut out = Vec::with_capacity(32 + bank_id.len() + 8 * d.instances * d.departure_kn.len());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&(d.instances as u64).to_le_bytes());
    out.extend_from_slice(&(d.departure_kn.len() as u32).to_le_bytes());
    out.extend_from_slice(&(bank_id.len() as u32).to_le_bytes());
    out.extend_from_slice(bank_id.as_bytes());
    for (dep, force) in d.departure_kn.iter().zip(&d.flat_free_kn) {
        for v in dep.iter().chain(force) {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    let crc = crc32fast::hash(&out);
    out.extend_from_slice(&crc.to_le_bytes());
    out
}

/// Decodes and checks a file's bytes against the bank it must belong to; the reason when it
/// does not.
// Err(String): the message of the caller's `BankError::Corrupt` (the file).
pub(crate) fn decode(
    bytes: &[u8],
    bank_id: &str,
    instances: usize,
    sensors: usize,
) -> Result<Departures, String> {
    let header = 8 + 8 + 4 + 4;
    if bytes.len() < header + 4 || &bytes[..8] != MAGIC {
        return Err("not a departures table (magic)".into());
    }
    let (body, crc) = bytes.split_at(bytes.len() - 4);
    if crc32fast::hash(body).to_le_bytes() != crc {
        return Err("CRC-32 mismatch".into());
    }
    let u64_at = |o: usize| u64::from_le_bytes(body[o..o + 8].try_into().expect("8 bytes"));
    let u32_at = |o: usize| u32::from_le_bytes(body[o..o + 4].try_into().expect("4 bytes"));
    let (n, s, id_len) = (u64_at(8), u32_at(16) as usize, u32_at(20) as usize);
    if n != instances as u64 || s != sensors {
        return Err(format!(
            "{n} instances × {s} sensors, the bank has {instances} × {sensors}"
        ));
    }
    let values = header + id_len;
    if body.len() != values + 8 * instances * sensors || &body[header..values] != bank_id.as_bytes()
    {
        return Err("another bank's table, or truncated".into());
    }
    let floats = |bytes: &[u8]| -> Vec<f32> {
        bytes
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")))
            .collect()
    };
    let mut departure_kn = Vec::with_capacity(sensors);
    let mut flat_free_kn = Vec::with_capacity(sensors);
    for per_sensor in body[values..]
        .chunks_exact(8 * instances.max(1))
        .take(sensors)
    {
        let (dep, force) = per_sensor.split_at(4 * instances);
        let (dep, force) = (floats(dep), floats(force));
        if dep.iter().chain(&force).any(|v| !v.is_finite() || *v < 0.0) {
            return Err("a value that is negative or not finite".into());
        }
        departure_kn.push(dep);
        flat_free_kn.push(force);
    }
    Ok(Departures {
        instances,
        departure_kn,
        flat_free_kn,
    })
}

/// Checks a stored table against the bank it lies in (`bank verify`): magic, CRC-32, bank id,
/// instances, and a size that fits the sensor count it states.
// Err(String): the message of the caller's `BankError::Corrupt` (the file).
pub(crate) fn check(bytes: &[u8], bank_id: &str, instances: usize) -> Result<(), String> {
    let sensors = bytes.get(16..20).map_or(0, |b| {
        u32::from_le_bytes(b.try_into().expect("4 bytes")) as usize
    });
    decode(bytes, bank_id, instances, sensors).map(|_| ())
}

/// Where a bank keeps its table of the predictions through the average `weights`.
pub(crate) fn path(bank: &Bank, weights: &[f64]) -> PathBuf {
    bank.dir().join(if weights.len() > 1 {
        AVERAGED_DEPARTURES_FILE
    } else {
        DEPARTURES_FILE
    })
}

/// The stored table of the predictions through the average `weights` when it passes its
/// checks; else computed from the bank (about a second for 50,000 instances; the averaged
/// one a few) and stored for the next process. A version directory that cannot be written
/// only costs that time again. `bank generate` builds it with the bank
/// ([`super::derived`]), so a first pass finds it.
pub(crate) fn load_or_compute(bank: &Bank, weights: &[f64]) -> Result<Departures, BankError> {
    load_or_build(bank, weights, super::cache::Store::BestEffort).map(|(d, _)| d)
}

/// [`load_or_compute`] with the store's failure handled as `store` says; also whether the
/// table was computed.
pub(crate) fn load_or_build(
    bank: &Bank,
    weights: &[f64],
    store: super::cache::Store,
) -> Result<(Departures, bool), BankError> {
    let meta = bank.metadata();
    let p = path(bank, weights);
    if let Ok(bytes) = std::fs::read(&p) {
        if let Ok(d) = decode(&bytes, &meta.bank_id, bank.instances(), meta.sensors.len()) {
            return Ok((d, false));
        }
    }
    let d = compute(bank, weights)?;
    store.write(&p, &encode(&meta.bank_id, &d))?;
    Ok((d, true))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table() -> Departures {
        Departures {
            instances: 3,
            departure_kn: vec![vec![1.0, 2.0, 3.0], vec![0.5, 0.0, 7.25]],
            flat_free_kn: vec![vec![10.0, 11.0, 12.0], vec![0.0, 1.0, 2.0]],
        }
    }

    #[test]
    fn a_table_reads_back_bit_for_bit() {
        let bytes = encode("abc", &table());
        assert_eq!(decode(&bytes, "abc", 3, 2).unwrap(), table());
    }

    #[test]
    fn a_damaged_or_foreign_table_is_refused() {
        let bytes = encode("abc", &table());
        assert!(decode(&bytes, "abd", 3, 2).is_err(), "another bank id");
        assert!(decode(&bytes, "abc", 4, 2).is_err(), "another size");
        assert!(
            decode(&bytes[..bytes.len() - 5], "abc", 3, 2).is_err(),
            "truncated"
        );
        assert!(check(&bytes, "abc", 3).is_ok());
        assert!(check(&bytes[..bytes.len() - 5], "abc", 3).is_err());
        assert!(check(&bytes[..10], "abc", 3).is_err());
        for at in [0, 9, 30, bytes.len() - 10] {
            let mut bad = bytes.clone();
            bad[at] ^= 0x10;
            assert!(decode(&bad, "abc", 3, 2).is_err(), "byte {at} flipped");
        }
    }
}
