//! Synthetic surfaces: roughness drawn from a published one-third-octave spectrum, and
//! out-of-round (polygonal, eccentric) wheels (docs/model.md §5b).
//!
//! **Spectra** (levels `L` in dB re 1 µm per one-third-octave band of wavelength):
//!
//! - rail: the EN ISO 3095:2013 limit spectrum (clause 6.2.5, Figure 2; the TSI Noise
//!   reference-track limit), 22 bands from 40 cm to 0.315 cm;
//! - wheels: CNOSSOS-EU, Commission Directive (EU) 2015/996, Annex, Appendix G, Table G-1
//!   (first table, `L_r,VEH`): cast-iron tread brakes (`c`), composite or sinter tread brakes
//!   (`k`), non-tread (disc) brakes (`n`), used here from 100 cm down to 0.315 cm (the
//!   table's shortest bands are padded with their end values; the contact patch removes
//!   them anyway);
//! - the rough end of tread-braked wheels: the cast-iron spectrum raised by 7.7 dB, to an rms
//!   of 22 µm over those bands, the roughest of the measured real treads that issue's
//!   disclosed passes come from (11–22 µm); the fleet averages of CNOSSOS are 9.1 µm
//!   (cast iron), 2.9 µm (composite), 3.8 µm (disc).
//!
//! **Drawing a surface.** A band of mean square `σ_b² = (1 µm)²·10^(L_b/10)` is spread over
//! the harmonics of the surface's period whose wavelengths fall in the band (edges
//! `λ_b·10^(±1/20)`): each harmonic is `a·cos + b·sin` with `a, b ~ N(0, σ_b²/n_b)`, so the
//! band holds `σ_b²` in expectation and a single wheel varies about it as real wheels do. A
//! wheel's period is its circumference (a band with no harmonic of it is left out: the 100 cm
//! band on a 2.51 m wheel); a rail's is a power of two of samples at least as long as asked,
//! so the roughness does not repeat over the modelled rail.

use super::{SurfaceError, Trace};
use crate::model::random::{gaussian, splitmix64};
use serde::{Deserialize, Serialize};
use std::f64::consts::TAU;

/// A surface roughness class with a published spectrum.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RoughnessClass {
    /// Disc-braked (non-tread-braked) wheels: CNOSSOS-EU `n`.
    Disc,
    /// Composite or sinter tread brakes (K, LL blocks): CNOSSOS-EU `k`.
    Composite,
    /// Cast-iron tread brakes: CNOSSOS-EU `c`.
    CastIron,
    /// The rough end of tread-braked wheels: CNOSSOS-EU `c` + 7.7 dB (22 µm rms).
    CastIronRough,
    /// A rail at the EN ISO 3095:2013 limit spectrum.
    RailIso3095,
}

/// One-third-octave band centres (mm) of the wheel table, 1000 mm to 3.15 mm.
const WHEEL_BANDS_MM: [f64; 26] = [
    1000.0, 800.0, 630.0, 500.0, 400.0, 315.0, 250.0, 200.0, 160.0, 125.0, 100.0, 80.0, 63.0, 50.0,
    40.0, 31.5, 25.0, 20.0, 16.0, 12.5, 10.0, 8.0, 6.3, 5.0, 4.0, 3.15,
];

/// CNOSSOS-EU Table G-1 (Directive (EU) 2015/996, Appendix G), `L_r,VEH`, dB re 1 µm, on
/// [`WHEEL_BANDS_MM`]: cast iron `c`, composite `k`, disc `n`.
const CAST_IRON_DB: [f64; 26] = [
    2.2, 2.2, 2.2, 2.2, 2.2, 2.2, 2.2, 2.2, 2.4, 0.6, 2.6, 5.8, 8.8, 11.1, 11.0, 9.8, 7.5, 5.1,
    3.0, 1.3, 0.2, -0.7, -1.2, -1.0, 0.3, 0.2,
];
const COMPOSITE_DB: [f64; 26] = [
    -4.0, -4.0, -4.0, -4.0, -4.0, -4.0, -4.0, -4.0, -4.0, -4.0, -4.0, -4.3, -4.6, -4.9, -5.2, -6.3,
    -6.8, -7.2, -7.3, -7.3, -7.1, -6.9, -6.7, -6.0, -3.7, -2.4,
];
const DISC_DB: [f64; 26] = [
    -5.9, -5.9, -5.9, -5.9, -5.9, -5.9, 2.3, 2.8, 2.6, 1.2, 2.1, 0.9, -0.3, -1.6, -2.9, -4.9, -7.0,
    -8.6, -9.3, -9.5, -10.1, -10.3, -10.3, -10.8, -10.9, -9.5,
];

/// The rough end's raise of the cast-iron spectrum (dB).
const ROUGH_END_RAISE_DB: f64 = 7.7;

/// EN ISO 3095:2013 limit spectrum (clause 6.2.5, Figure 2): band centres (mm) and levels
/// (dB re 1 µm).
const RAIL_BANDS_MM: [f64; 22] = [
    400.0, 315.0, 250.0, 200.0, 160.0, 125.0, 100.0, 80.0, 63.0, 50.0, 40.0, 31.5, 25.0, 20.0,
    16.0, 12.5, 10.0, 8.0, 6.3, 5.0, 4.0, 3.15,
];
const RAIL_ISO3095_DB: [f64; 22] = [
    17.1, 15.0, 13.0, 11.0, 9.0, 7.0, 4.9, 2.9, 0.9, -1.1, -3.2, -5.0, -5.6, -6.2, -6.8, -7.4,
    -8.0, -8.6, -9.2, -9.8, -10.4, -11.0,
];

impl RoughnessClass {
    /// Every class, smoothest wheel first, the rail last.
    pub const ALL: [RoughnessClass; 5] = [
        RoughnessClass::Disc,
        RoughnessClass::Composite,
        RoughnessClass::CastIron,
        RoughnessClass::CastIronRough,
        RoughnessClass::RailIso3095,
    ];

    /// The wheel classes.
    pub const WHEELS: [RoughnessClass; 4] = [
        RoughnessClass::Disc,
        RoughnessClass::Composite,
        RoughnessClass::CastIron,
        RoughnessClass::CastIronRough,
    ];

    /// The name files and the command line use.
    pub fn name(self) -> &'static str {
        match self {
            RoughnessClass::Disc => "disc",
            RoughnessClass::Composite => "composite",
            RoughnessClass::CastIron => "cast-iron",
            RoughnessClass::CastIronRough => "cast-iron-rough",
            RoughnessClass::RailIso3095 => "rail-iso3095",
        }
    }

    /// The class of a name.
    pub fn from_name(name: &str) -> Option<RoughnessClass> {
        RoughnessClass::ALL.into_iter().find(|c| c.name() == name)
    }

    /// Whether the class is a rail's.
    pub fn is_rail(self) -> bool {
        self == RoughnessClass::RailIso3095
    }

    /// The spectrum: band centres (m) and levels (dB re 1 µm).
    pub fn bands(self) -> Vec<(f64, f64)> {
        let pair = |mm: &[f64], db: &[f64], raise: f64| -> Vec<(f64, f64)> {
            mm.iter()
                .zip(db)
                .map(|(m, d)| (m * 1e-3, d + raise))
                .collect()
        };
        match self {
            RoughnessClass::Disc => pair(&WHEEL_BANDS_MM, &DISC_DB, 0.0),
            RoughnessClass::Composite => pair(&WHEEL_BANDS_MM, &COMPOSITE_DB, 0.0),
            RoughnessClass::CastIron => pair(&WHEEL_BANDS_MM, &CAST_IRON_DB, 0.0),
            RoughnessClass::CastIronRough => {
                pair(&WHEEL_BANDS_MM, &CAST_IRON_DB, ROUGH_END_RAISE_DB)
            }
            RoughnessClass::RailIso3095 => pair(&RAIL_BANDS_MM, &RAIL_ISO3095_DB, 0.0),
        }
    }

    /// The spectrum's rms over its bands, `√Σ σ_b²` (m).
    pub fn rms_m(self) -> f64 {
        self.bands()
            .iter()
            .map(|&(_, db)| 1e-12 * 10f64.powf(db / 10.0))
            .sum::<f64>()
            .sqrt()
    }
}

/// Harmonic `k` of period `period_m` with the mean square its band gives each harmonic, for
/// every band of `bands` (centre m, level dB) that holds at least one harmonic.
fn harmonics(bands: &[(f64, f64)], period_m: f64) -> Vec<(usize, f64)> {
    let edge = 10f64.powf(1.0 / 20.0);
    let mut out = Vec::new();
    for &(centre, db) in bands {
        let (long, short) = (centre * edge, centre / edge);
        // λ_k = P/k in (short, long]  ⇔  k in [P/long, P/short).
        let k0 = (period_m / long).ceil().max(1.0) as usize;
        let k1 = (period_m / short).ceil() as usize;
        let n = k1.saturating_sub(k0);
        if n == 0 {
            continue;
        }
        let per = 1e-12 * 10f64.powf(db / 10.0) / n as f64;
        out.extend((k0..k1).map(|k| (k, per)));
    }
    out
}

/// A trace of `samples` points at the spacing `period_m/points` over a period `period_m`
/// sampled at `points` points: the harmonics drawn with random Gaussian coefficients of their
/// mean squares (seeded), summed by one inverse FFT (rustfft's scalar planner, so the same
/// seed gives the same bits on every CPU), the first `samples` kept.
fn draw(
    what: &str,
    bands: &[(f64, f64)],
    period_m: f64,
    points: usize,
    samples: usize,
    seed: u64,
) -> Result<Trace, SurfaceError> {
    use rustfft::num_complex::Complex;
    let mut state = seed ^ 0x0005_EED0_F5A4_FACE;
    splitmix64(&mut state);
    // x_i = Σ_k a_k·cos(2πki/N) + b_k·sin(2πki/N) = Re Σ_k (a_k − i·b_k)·e^{2πiki/N}.
    let mut spectrum = vec![Complex::new(0.0, 0.0); points];
    for (k, ms) in harmonics(bands, period_m) {
        if k >= points / 2 {
            break;
        }
        let sd = ms.sqrt();
        let (a, b) = (sd * gaussian(&mut state), sd * gaussian(&mut state));
        spectrum[k] = Complex::new(a, -b);
    }
    let fft = rustfft::FftPlannerScalar::new().plan_fft_inverse(points);
    fft.process(&mut spectrum);
    let values = spectrum.iter().take(samples).map(|c| c.re).collect();
    Trace::new(what, period_m / points as f64, values)
}

/// Sample spacing of drawn surfaces (m): 0.5 mm, six samples a wavelength of the shortest band.
pub const DRAWN_SPACING_M: f64 = 5e-4;

/// A wheel's tread of `class`, one revolution of a wheel of radius `wheel_radius_m`, seeded.
pub fn wheel_roughness(
    class: RoughnessClass,
    wheel_radius_m: f64,
    seed: u64,
) -> Result<Trace, SurfaceError> {
    let c = TAU * wheel_radius_m;
    let n = (c / DRAWN_SPACING_M).round() as usize;
    draw(class.name(), &class.bands(), c, n, n, seed)
}

/// A rail of `class` over `length_m`, seeded.
pub fn rail_roughness(
    class: RoughnessClass,
    length_m: f64,
    seed: u64,
) -> Result<Trace, SurfaceError> {
    let n = (length_m.max(1.0) / DRAWN_SPACING_M).ceil() as usize + 1;
    // A period of 2^m samples at the drawn spacing, at least the length asked.
    let points = n.next_power_of_two();
    draw(
        class.name(),
        &class.bands(),
        points as f64 * DRAWN_SPACING_M,
        points,
        n,
        seed,
    )
}

/// One harmonic of an out-of-round wheel: `A·cos(n·2πs/C + φ)` on the radius (order 1 is an
/// eccentric wheel).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Harmonic {
    /// Order n (waves per revolution, 1 to 100).
    pub order: u32,
    /// Amplitude A (m).
    pub amplitude_m: f64,
    /// Phase φ (rad).
    pub phase_rad: f64,
}

/// An out-of-round wheel's tread over one revolution of radius `wheel_radius_m`: the sum of
/// `harmonics` (a polygonal wheel; order 1 an eccentric one).
pub fn out_of_round(harmonics: &[Harmonic], wheel_radius_m: f64) -> Result<Trace, SurfaceError> {
    let c = TAU * wheel_radius_m;
    let n = (c / DRAWN_SPACING_M).round() as usize;
    for h in harmonics {
        if !(1..=100).contains(&h.order)
            || !h.amplitude_m.is_finite()
            || h.amplitude_m.abs() > super::MAX_DEVIATION_M
            || !h.phase_rad.is_finite()
        {
            return Err(SurfaceError::Invalid {
                what: "out-of-round wheel".into(),
                reason: format!(
                    "order {} (1 to 100), amplitude {:.1} µm (within ±{} µm), phase {} rad (finite)",
                    h.order,
                    h.amplitude_m * 1e6,
                    super::MAX_DEVIATION_M * 1e6,
                    h.phase_rad
                ),
            });
        }
    }
    let values = (0..n)
        .map(|i| {
            let s = i as f64 * c / n as f64;
            harmonics
                .iter()
                .map(|h| h.amplitude_m * (f64::from(h.order) * TAU * s / c + h.phase_rad).cos())
                .sum()
        })
        .collect();
    Trace::new("out-of-round wheel", c / n as f64, values)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_classes_rms_are_their_spectra_s() {
        // Sums of the tables' band mean squares (µm): stated in the module docs.
        let rms = |c: RoughnessClass| c.rms_m() * 1e6;
        assert!(
            (rms(RoughnessClass::CastIron) - 9.1).abs() < 0.1,
            "{}",
            rms(RoughnessClass::CastIron)
        );
        assert!((rms(RoughnessClass::CastIronRough) - 22.0).abs() < 0.2);
        assert!((rms(RoughnessClass::Composite) - 2.9).abs() < 0.1);
        assert!((rms(RoughnessClass::Disc) - 3.8).abs() < 0.1);
        assert!((rms(RoughnessClass::RailIso3095) - 11.7).abs() < 0.1);
    }

    #[test]
    fn a_drawn_wheel_holds_its_spectrum_on_average_and_in_each_band() {
        // Over 64 wheels the mean square is the spectrum's less the bands no harmonic of a
        // 2.51 m wheel falls in (the 1000 mm band); the standard error of the mean of 64
        // draws of a sum of ~2,000 harmonics is under 5 % for this spectrum (its long bands
        // hold few harmonics).
        let r = 0.4;
        let c = TAU * r;
        let bands = RoughnessClass::CastIron.bands();
        let expected: f64 = harmonics(&bands, c).iter().map(|h| h.1).sum();
        let mean_square = (0..64)
            .map(|seed| {
                let t = wheel_roughness(RoughnessClass::CastIron, r, seed).unwrap();
                let d = t.deviation_m();
                d.iter().map(|e| e * e).sum::<f64>() / d.len() as f64
            })
            .sum::<f64>()
            / 64.0;
        assert!(
            (mean_square / expected - 1.0).abs() < 0.15,
            "{mean_square} vs {expected}"
        );
        // The 800 mm band holds one harmonic (k = 3: 838 mm); 1000 mm holds none.
        let h = harmonics(&bands, c);
        assert!(h.iter().all(|&(k, _)| k >= 3), "{:?}", &h[..3]);
        // Seeded: the same seed, the same wheel.
        assert_eq!(
            wheel_roughness(RoughnessClass::Disc, r, 5).unwrap(),
            wheel_roughness(RoughnessClass::Disc, r, 5).unwrap()
        );
    }

    #[test]
    fn an_out_of_round_wheel_is_its_harmonics() {
        let r = 0.4;
        let t = out_of_round(
            &[Harmonic {
                order: 6,
                amplitude_m: 30e-6,
                phase_rad: 0.0,
            }],
            r,
        )
        .unwrap();
        let d = t.deviation_m();
        let max = d.iter().fold(0.0f64, |m, v| m.max(*v));
        assert!((max - 30e-6).abs() < 1e-12 && (d[0] - 30e-6).abs() < 1e-15);
        // rms of a sinusoid: A/√2.
        assert!((t.rms_m() - 30e-6 / 2f64.sqrt()).abs() < 1e-9);
        assert!(out_of_round(
            &[Harmonic {
                order: 0,
                amplitude_m: 1e-6,
                phase_rad: 0.0
            }],
            r
        )
        .is_err());
    }
}
