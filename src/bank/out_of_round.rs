//! How an out-of-round wheel moves a bank's good-wheel prediction (docs/detection.md,
//! "Out-of-round wheels"): the response of every bank axis to one harmonic of the wheel's
//! radius, per wheel, order and phase, from which identification fits an eccentric or
//! polygonal wheel to a pass before it sizes a flat.
//!
//! A harmonic `A·cos(n·θ + φ) = A·cos φ·cos(nθ) − A·sin φ·sin(nθ)` is a sum of two basis
//! shapes, and the pad forces respond to amplitudes of tens of µm linearly (the Hertz spring's
//! stiffness changes by under 1 % over such a drop; measured: docs/detection.md): so for each
//! wheel and order `1 ..= MAX_ORDER` the bank's calibration is simulated twice, with
//! `A₀·cos(nθ)` and `A₀·sin(nθ)` on that wheel alone (`A₀` = [`BASIS_AMPLITUDE_M`], the
//! default contact filter: an out-of-round wheel's wavelengths, 126 mm and longer, pass it),
//! and the departure from the round wheel's run is kept per bank axis, per µm. The basis
//! depends only on the bank's calibration: it is computed when a pass first needs it (about
//! 3 s on two cores) and kept beside the shards as `out-of-round.bin` (f32 values, the bank
//! id, a CRC-32; checked as read and computed again when it fails: a cache, reported by
//! `bank verify` when damaged).

use super::reader::Bank;
use super::schema::SensorAxis;
use super::BankError;
use crate::model::surface::{out_of_round, Harmonic};
use crate::model::{
    CheckedCalibration, ContactFilter, Record, Simulator, Surfaces, WheelPosition, WheelSurface,
};
use rayon::prelude::*;
use std::path::PathBuf;

/// The basis' file name inside a version directory.
pub(crate) const OUT_OF_ROUND_FILE: &str = "out-of-round.bin";

/// The file's first bytes.
const MAGIC: &[u8; 8] = b"WFOOR\x00\x01\n";

/// The highest order fitted (orders 1 to 20: wavelengths down to 126 mm on the default wheel).
pub const MAX_ORDER: u32 = 20;

/// The amplitude the basis is simulated with (m): 20 µm.
pub const BASIS_AMPLITUDE_M: f64 = 2e-5;

/// Where the basis wheel's `θ = 0` touches the rail (m): the phase a fit reports is relative
/// to it.
pub const BASIS_TOUCH_M: f64 = 0.0;

/// One wheel's response to one order: per bank axis, the departure (kN per µm) of `cos(nθ)`
/// and of `sin(nθ)`.
#[derive(Debug, Clone, PartialEq)]
pub struct OrderResponse {
    /// The wheel.
    pub wheel: WheelPosition,
    /// The order `n`.
    pub order: u32,
    /// Per bank axis: the cosine shape's departure, kN per µm.
    pub cos_kn_per_um: Vec<Vec<f64>>,
    /// Per bank axis: the sine shape's departure, kN per µm.
    pub sin_kn_per_um: Vec<Vec<f64>>,
}

/// A bank's out-of-round basis: every wheel and order.
#[derive(Debug, Clone, PartialEq)]
pub struct OutOfRoundBasis {
    /// Leading wheel's orders first, then the trailing wheel's.
    pub responses: Vec<OrderResponse>,
}

/// Simulates the basis of a bank of calibration `cal` on its axes `axes` (axes whose sensor
/// the calibration lacks get empty windows).
pub fn compute(
    cal: &CheckedCalibration,
    axes: &[SensorAxis],
) -> Result<OutOfRoundBasis, BankError> {
    let sim = Simulator::new(cal)?;
    let index: Vec<Option<usize>> = axes.iter().map(|a| cal.sensor_index(&a.name)).collect();
    let windows = |r: &crate::model::Response| -> Vec<Vec<f64>> {
        axes.iter()
            .zip(&index)
            .map(|(a, i)| i.map_or(Vec::new(), |i| super::roughness::window_kn(r, i, a)))
            .collect()
    };
    let round = windows(&sim.run(None, Record::default())?);
    let radius = cal.vehicle.wheel_radius_m;
    let jobs: Vec<(WheelPosition, u32, bool)> = [WheelPosition::Leading, WheelPosition::Trailing]
        .into_iter()
        .flat_map(|w| (1..=MAX_ORDER).flat_map(move |n| [(w, n, false), (w, n, true)]))
        .collect();
    let per_um = 1.0 / (BASIS_AMPLITUDE_M * 1e6);
    let runs: Vec<Vec<Vec<f64>>> = jobs
        .par_iter()
        .map(
            |&(wheel, order, sine)| -> Result<Vec<Vec<f64>>, BankError> {
                // sin(nθ) = cos(nθ − π/2).
                let phase_rad = if sine {
                    -std::f64::consts::FRAC_PI_2
                } else {
                    0.0
                };
                let trace = out_of_round(
                    &[Harmonic {
                        order,
                        amplitude_m: BASIS_AMPLITUDE_M,
                        phase_rad,
                    }],
                    radius,
                )
                .map_err(crate::model::SimError::from)?;
                let surfaces = Surfaces {
                    wheels: vec![WheelSurface {
                        wheel,
                        trace,
                        touch_x_m: BASIS_TOUCH_M,
                    }],
                    rail: None,
                };
                let r = sim
                    .clone()
                    .with_surfaces(&surfaces, ContactFilter::DEFAULT)?
                    .run(None, Record::default())?;
                Ok(windows(&r)
                    .into_iter()
                    .zip(&round)
                    .map(|(w, g)| w.iter().zip(g).map(|(y, g)| (y - g) * per_um).collect())
                    .collect())
            },
        )
        .collect::<Result<_, _>>()?;
    let responses = jobs
        .chunks(2)
        .zip(runs.chunks(2))
        .map(|(j, r)| OrderResponse {
            wheel: j[0].0,
            order: j[0].1,
            cos_kn_per_um: r[0].clone(),
            sin_kn_per_um: r[1].clone(),
        })
        .collect();
    Ok(OutOfRoundBasis { responses })
}

/// Where a bank keeps its basis.
pub(crate) fn path(bank: &Bank) -> PathBuf {
    bank.dir().join(OUT_OF_ROUND_FILE)
}

/// The file's bytes: magic, bank id, the axes' lengths, then per response its wheel, order and
/// both shapes on every axis (f32, little-endian), then the CRC-32 of everything before it.
pub(crate) fn encode(bank_id: &str, b: &OutOfRoundBasis) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&(bank_id.len() as u32).to_le_bytes());
    out.extend_from_slice(bank_id.as_bytes());
    let lens: Vec<usize> = b.responses.first().map_or(Vec::new(), |r| {
        r.cos_kn_per_um.iter().map(Vec::len).collect()
    });
    out.extend_from_slice(&(lens.len() as u32).to_le_bytes());
    for l in &lens {
        out.extend_from_slice(&(*l as u32).to_le_bytes());
    }
    out.extend_from_slice(&(b.responses.len() as u32).to_le_bytes());
    for r in &b.responses {
        out.push(r.wheel.index() as u8);
        out.extend_from_slice(&r.order.to_le_bytes());
        for v in r.cos_kn_per_um.iter().chain(&r.sin_kn_per_um).flatten() {
            out.extend_from_slice(&(*v as f32).to_le_bytes());
        }
    }
    let crc = crc32fast::hash(&out);
    out.extend_from_slice(&crc.to_le_bytes());
    out
}

/// Decodes and checks a file's bytes against the bank it must belong to (its id and, when
/// given, its axes' lengths); the reason when it does not.
// Err(String): the message of the caller's `BankError::Corrupt` (the file).
pub(crate) fn decode(
    bytes: &[u8],
    bank_id: &str,
    axes: Option<&[SensorAxis]>,
) -> Result<OutOfRoundBasis, String> {
    if bytes.len() < MAGIC.len() + 4 || &bytes[..MAGIC.len()] != MAGIC {
        return Err("not an out-of-round basis (magic)".into());
    }
    let (body, crc) = bytes.split_at(bytes.len() - 4);
    if crc32fast::hash(body).to_le_bytes() != crc {
        return Err("CRC-32 mismatch".into());
    }
    let mut at = MAGIC.len();
    // Err(String): the message of the caller's `BankError::Corrupt` (the file).
    let mut take = |n: usize| -> Result<&[u8], String> {
        let s = body.get(at..at + n).ok_or("truncated")?;
        at += n;
        Ok(s)
    };
    let u32_of = |b: &[u8]| u32::from_le_bytes(b.try_into().expect("4 bytes")) as usize;
    let id_len = u32_of(take(4)?);
    if take(id_len)? != bank_id.as_bytes() {
        return Err("another bank's basis".into());
    }
    let n_axes = u32_of(take(4)?);
    let lens: Vec<usize> = (0..n_axes)
        .map(|_| take(4).map(u32_of))
        .collect::<Result<_, _>>()?;
    if let Some(axes) = axes {
        let expected: Vec<usize> = axes.iter().map(|a| a.samples).collect();
        if lens != expected {
            return Err(format!(
                "axes of {lens:?} samples, the bank's are {expected:?}"
            ));
        }
    }
    let count = u32_of(take(4)?);
    if count != 2 * MAX_ORDER as usize {
        return Err(format!("{count} responses, expected {}", 2 * MAX_ORDER));
    }
    let mut responses = Vec::with_capacity(count);
    for _ in 0..count {
        let wheel = match take(1)?[0] {
            0 => WheelPosition::Leading,
            1 => WheelPosition::Trailing,
            w => return Err(format!("wheel {w}")),
        };
        let order = u32_of(take(4)?) as u32;
        // Err(String): the message of the caller's `BankError::Corrupt` (the file).
        let mut shape = || -> Result<Vec<Vec<f64>>, String> {
            lens.iter()
                .map(|&l| {
                    let v: Vec<f64> = take(4 * l)?
                        .chunks_exact(4)
                        .map(|c| f64::from(f32::from_le_bytes(c.try_into().expect("4 bytes"))))
                        .collect();
                    match v.iter().all(|x| x.is_finite()) {
                        true => Ok(v),
                        false => Err("a value that is not finite".to_string()),
                    }
                })
                .collect()
        };
        let cos_kn_per_um = shape()?;
        let sin_kn_per_um = shape()?;
        responses.push(OrderResponse {
            wheel,
            order,
            cos_kn_per_um,
            sin_kn_per_um,
        });
    }
    if at != body.len() {
        return Err("bytes after the last response".into());
    }
    Ok(OutOfRoundBasis { responses })
}

/// The stored basis when it passes its checks; else simulated from the bank's calibration and
/// stored for the next process (a read-only bank only costs that time again). `bank generate`
/// builds it with the bank ([`super::derived`]), so a first pass finds it.
pub fn load_or_compute(bank: &Bank) -> Result<OutOfRoundBasis, BankError> {
    load_or_build(bank, super::cache::Store::BestEffort).map(|(b, _)| b)
}

/// [`load_or_compute`] with the store's failure handled as `store` says; also whether the
/// basis was simulated.
pub(crate) fn load_or_build(
    bank: &Bank,
    store: super::cache::Store,
) -> Result<(OutOfRoundBasis, bool), BankError> {
    let meta = bank.metadata();
    let p = path(bank);
    if let Ok(bytes) = std::fs::read(&p) {
        if let Ok(b) = decode(&bytes, &meta.bank_id, Some(&meta.sensors)) {
            return Ok((b, false));
        }
    }
    let cal = meta
        .calibration
        .clone()
        .check()
        .map_err(|source| BankError::DerivedCalibration {
            context: "the bank's calibration, for its out-of-round basis".into(),
            source,
        })?;
    let b = compute(&cal, &meta.sensors)?;
    store.write(&p, &encode(&meta.bank_id, &b))?;
    Ok((b, true))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn axis(samples: usize) -> SensorAxis {
        SensorAxis {
            name: "rps1".into(),
            sleeper: 16,
            position_m: 12.0,
            sample_rate_hz: 2500.0,
            first_sample: 0,
            t0_s: 0.0,
            samples,
        }
    }

    fn basis() -> OutOfRoundBasis {
        let responses = [WheelPosition::Leading, WheelPosition::Trailing]
            .into_iter()
            .flat_map(|w| {
                (1..=MAX_ORDER).map(move |n| OrderResponse {
                    wheel: w,
                    order: n,
                    cos_kn_per_um: vec![vec![0.5 * f64::from(n), -0.25]],
                    sin_kn_per_um: vec![vec![0.125, f64::from(n)]],
                })
            })
            .collect();
        OutOfRoundBasis { responses }
    }

    #[test]
    fn a_basis_reads_back_and_a_damaged_one_is_refused() {
        let bytes = encode("abc", &basis());
        assert_eq!(decode(&bytes, "abc", Some(&[axis(2)])).unwrap(), basis());
        assert!(decode(&bytes, "abd", Some(&[axis(2)]))
            .unwrap_err()
            .contains("another bank"));
        assert!(decode(&bytes, "abc", Some(&[axis(3)]))
            .unwrap_err()
            .contains("axes"));
        for i in [0, 12, bytes.len() / 2, bytes.len() - 1] {
            let mut bad = bytes.clone();
            bad[i] ^= 0x40;
            assert!(decode(&bad, "abc", Some(&[axis(2)])).is_err(), "byte {i}");
        }
        assert!(decode(&bytes[..bytes.len() - 9], "abc", Some(&[axis(2)])).is_err());
    }
}
