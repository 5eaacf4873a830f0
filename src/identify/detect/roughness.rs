//! Rough treads and rails in an identification (docs/detection.md, "Rough wheels"): the
//! roughness class a pass is judged with, and the bound it adds to detection and to every
//! comparison point's thresholds.
//!
//! A rough tread moves the pad forces most at high frequency, which the comparison's average
//! (`B₅`, [`crate::identify::input::compare`]) takes out, and a little below it, most while a wheel is over the
//! sensor. What remains is bounded per bank and class by simulation
//! ([`crate::bank::roughness`]): at a point whose averaged flat-free force is `ḡ`, by
//! `floor + near_wheel·|ḡ|`. The class is the site's statement (`wheel_roughness`) or, with
//! `auto`, read from the pass's own record: its high-frequency level `h` (the robust scale of
//! `x − B₅x` over the loaded samples, the median over the sensors used) picks the smoothest
//! class whose upper level reaches it, `√(h_class² + h_noise²)` with `h_noise` what the table's
//! noise alone gives (15 % above it, for the scale's own spread over a few hundred samples). A
//! pass rougher than the roughest class has that class's bound scaled by its excess
//! `√(h² − h_noise²)/h_class` (the response is linear in the roughness' amplitude). The rail's
//! class cannot be read from a record (its level is mostly below the average's cut-off): the
//! site states it (`rail_roughness`).

use crate::bank::roughness::RoughnessRow;
use crate::identify::detect::TableBounds;
use crate::identify::domain::uncertainty::ThresholdCurve;
use crate::identify::error::IdentifyError;
use crate::identify::identifier::Identifier;
use crate::model::average::BINOMIAL5 as HF_WEIGHTS;
use crate::model::calibration::{IdentificationParams, UncertaintyKind};
use crate::model::surface::RoughnessClass;
use serde::{Deserialize, Serialize};

/// The share by which a noise-only pass's level may exceed the table's noise level (the robust
/// scale's spread over a few hundred samples, median of the sensors).
pub const NOISE_SPREAD: f64 = 0.15;

/// The roughness a pass was judged with.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RoughnessUse {
    /// The wheels' class (`None`: round wheels).
    pub wheel: Option<RoughnessClass>,
    /// The rail's class (`None`: smooth).
    pub rail: Option<RoughnessClass>,
    /// The wheels' class was read from the record (`auto`), not stated.
    pub read_from_record: bool,
    /// The record's high-frequency level `h` (kN; median over the sensors used).
    pub hf_kn: f64,
    /// What the table's noise alone gives (kN).
    pub noise_hf_kn: f64,
    /// The record is rougher than the roughest class: its bound is scaled by the excess.
    #[serde(default)]
    pub beyond_classes: bool,
    /// The record's level lies within the table's noise, where round treads and the smoothest
    /// classes cannot be told apart: the bound is the roughest of those, the comparison sample
    /// by sample (`wheel` names that class).
    #[serde(default)]
    pub within_noise: bool,
    /// The bound's part near a wheel, a fraction of the averaged flat-free force.
    pub near_wheel_fraction: f64,
    /// The bound's floor (kN).
    pub floor_kn: f64,
}

impl RoughnessUse {
    /// No roughness: round wheels on a smooth rail.
    pub fn none(hf_kn: f64, noise_hf_kn: f64) -> RoughnessUse {
        RoughnessUse {
            wheel: None,
            rail: None,
            read_from_record: false,
            hf_kn,
            noise_hf_kn,
            beyond_classes: false,
            within_noise: false,
            near_wheel_fraction: 0.0,
            floor_kn: 0.0,
        }
    }

    /// How a pass judged with this roughness is compared with the bank: through the average
    /// when it allows for any roughness, sample by sample for round wheels on a smooth rail.
    pub fn comparison(&self) -> crate::identify::input::compare::Comparison {
        let rough_treads = self.wheel.is_some() && !self.within_noise;
        if rough_treads || self.rail.is_some() {
            crate::identify::input::compare::Comparison::Binomial5
        } else {
            crate::identify::input::compare::Comparison::Samples
        }
    }

    /// The widening `±(floor + near_wheel·|ḡ|)` (kN) at a point whose averaged flat-free force
    /// is `flat_free_kn`.
    pub fn widening_kn(&self, flat_free_kn: f64) -> f64 {
        self.floor_kn + self.near_wheel_fraction * flat_free_kn.abs()
    }

    /// The table's bounds with this roughness added ([`TableBounds`]).
    pub fn bounds(&self, table: TableBounds) -> TableBounds {
        TableBounds {
            good_wheel_fraction: table.good_wheel_fraction + self.near_wheel_fraction,
            bound_kn: table.bound_kn + self.floor_kn,
            ..table
        }
    }

    /// In words, for the answer's text.
    pub fn words(&self) -> String {
        let wheels = match (self.wheel, self.within_noise) {
            (Some(c), true) => format!("treads within the noise (round up to {})", c.name()),
            (Some(c), false) => format!("{} treads", c.name()),
            (None, _) => "round wheels".to_string(),
        };
        let rail = self.rail.map_or("a smooth rail".to_string(), |c| {
            format!("a {} rail", c.name())
        });
        let how = if self.read_from_record {
            format!(
                "read from the record: high-frequency level {:.2} kN, {:.2} kN from noise alone{}",
                self.hf_kn,
                self.noise_hf_kn,
                if self.beyond_classes {
                    ", rougher than the roughest class: its bound scaled up"
                } else {
                    ""
                }
            )
        } else {
            "as stated".to_string()
        };
        let compared = match self.comparison() {
            crate::identify::input::compare::Comparison::Samples => "compared sample by sample",
            crate::identify::input::compare::Comparison::Binomial5 => {
                "compared through the 5-sample average"
            }
        };
        format!(
            "{wheels} on {rail} ({how}); bound ±({:.2} kN + {:.1} % of the good wheel's force), {compared}",
            self.floor_kn,
            100.0 * self.near_wheel_fraction
        )
    }
}

/// Draws behind [`noise_hf_kn`].
const NOISE_DRAWS: usize = 20_000;

/// The high-frequency level the table's noise alone gives a record (kN): the robust scale of
/// the drawn absolute sources (independent uniforms per sample) through the operator
/// `x − B₅x`, by a seeded Monte Carlo of 20,000 draws (the robust scale of uniform noise is
/// not its standard deviation: 1.28 times it for one uniform).
pub fn noise_hf_kn(settings: &IdentificationParams) -> f64 {
    let sources: Vec<(f64, f64)> = settings
        .uncertainty
        .iter()
        .filter(|u| u.kind == UncertaintyKind::AbsoluteKn)
        .map(|u| (u.min, u.max))
        .collect();
    let h = HF_WEIGHTS.len() / 2;
    let mut state = 0x0015_E4F0_0D5Eu64;
    let draws = (0..NOISE_DRAWS)
        .map(|_| {
            HF_WEIGHTS
                .iter()
                .enumerate()
                .map(|(j, w)| {
                    let c = if j == h { 1.0 - w } else { -w };
                    let e: f64 = sources
                        .iter()
                        .map(|&(lo, hi)| lo + (hi - lo) * crate::model::random::uniform(&mut state))
                        .sum();
                    c * e
                })
                .sum::<f64>()
        })
        .collect();
    crate::bank::roughness::robust_scale(draws)
}

/// The rows a record at the noise's level `noise` cannot tell apart from round treads: those
/// whose upper level lies within `1 + NOISE_SPREAD` of round treads' own.
pub fn within_noise<'a>(rows: &[&'a RoughnessRow], noise: f64) -> Vec<&'a RoughnessRow> {
    let upper =
        |r: &RoughnessRow| (r.hf_kn.powi(2) + ((1.0 + NOISE_SPREAD) * noise).powi(2)).sqrt();
    let band = rows.first().map_or(0.0, |r| upper(r)) * (1.0 + NOISE_SPREAD);
    rows.iter().copied().filter(|r| upper(r) <= band).collect()
}

/// The row and scale a level `h` calls for among `rows` (round first, smoothest class first):
/// the smoothest whose upper level `√(h_class² + (1 + spread)²·h_noise²)` reaches `h`; beyond
/// the roughest, the roughest scaled by `√(h² − h_noise²)/h_class`.
pub fn classify<'a>(rows: &[&'a RoughnessRow], h: f64, noise: f64) -> (&'a RoughnessRow, f64) {
    let upper =
        |r: &RoughnessRow| (r.hf_kn.powi(2) + ((1.0 + NOISE_SPREAD) * noise).powi(2)).sqrt();
    match rows.iter().find(|r| upper(r) >= h) {
        Some(r) => (r, 1.0),
        None => {
            let last = rows[rows.len() - 1];
            let excess = (h * h - noise * noise).max(0.0).sqrt();
            (last, (excess / last.hf_kn.max(1e-9)).max(1.0))
        }
    }
}

impl Identifier {
    /// The roughness a pass whose record's high-frequency level is `hf_kn` is judged with.
    pub fn roughness_use(&self, hf_kn: f64) -> Result<RoughnessUse, IdentifyError> {
        let s = &self.settings;
        // The settings' noise level: one Monte Carlo per identifier, not per pass.
        let noise = *self.noise_hf.get_or_init(|| noise_hf_kn(s));
        let rail = s.rail_roughness.class();
        let stated = s.wheel_roughness.stated();
        if rail.is_none() && stated == Some(None) {
            return Ok(RoughnessUse::none(hf_kn, noise));
        }
        let table = self.roughness_table()?;
        let rows = table.on_rail(rail);
        let (row, scale) = match stated {
            Some(class) => (
                rows.iter()
                    .copied()
                    .find(|r| r.wheel == class)
                    .ok_or_else(|| IdentifyError::NoRoughnessRow {
                        wheels: class.map_or("round", |c| c.name()),
                    })?,
                1.0,
            ),
            None => classify(&rows, hf_kn, noise),
        };
        let mut u = RoughnessUse {
            wheel: row.wheel,
            rail,
            read_from_record: stated.is_none(),
            hf_kn,
            noise_hf_kn: noise,
            beyond_classes: scale > 1.0,
            within_noise: false,
            near_wheel_fraction: scale * row.near_wheel_fraction,
            floor_kn: scale * row.floor_kn,
        };
        // A record at the noise's level cannot tell round treads from the classes whose level
        // lies within it: bounded as the roughest of those.
        let band = within_noise(&rows, noise);
        if stated.is_none() && band.iter().any(|r| r.wheel == row.wheel) {
            u.within_noise = true;
            for r in &band {
                if r.near_wheel_fraction + r.floor_kn > 0.0 {
                    u.wheel = r.wheel.or(u.wheel);
                }
                u.near_wheel_fraction = u.near_wheel_fraction.max(r.near_wheel_fraction);
                u.floor_kn = u.floor_kn.max(r.floor_kn);
            }
        }
        Ok(u)
    }
}

impl Identifier {
    /// The threshold curve of a point measured at `y_kn` whose flat-free prediction is
    /// `flat_free_kn`, in a pass judged with `roughness`: the table's curve widened by its
    /// bounded sources and by the roughness' bound there.
    pub fn point_curve(
        &self,
        roughness: &RoughnessUse,
        y_kn: f64,
        flat_free_kn: f64,
        p: f64,
    ) -> ThresholdCurve {
        let (a, b) = self.uncertainty.good_wheel_widening(flat_free_kn);
        let w = roughness.widening_kn(flat_free_kn);
        self.uncertainty.curve(y_kn, p).widened((a - w, b + w))
    }

    /// The thresholds of a point measured at `y_kn` whose flat-free prediction is
    /// `flat_free_kn`, in a pass judged with `roughness` (as [`Identifier::point_curve`]).
    pub fn point_thresholds(
        &self,
        roughness: &RoughnessUse,
        y_kn: f64,
        flat_free_kn: f64,
        p: f64,
    ) -> (f64, f64) {
        let (lo, hi) = self.uncertainty.thresholds_at(y_kn, flat_free_kn, p);
        let w = roughness.widening_kn(flat_free_kn);
        (lo - w, hi + w)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(wheel: Option<RoughnessClass>, hf: f64) -> RoughnessRow {
        RoughnessRow {
            wheel,
            rail: None,
            passes: 24,
            near_wheel_fraction: hf / 10.0,
            floor_kn: hf,
            hf_kn: hf,
        }
    }

    #[test]
    fn the_table_noise_gives_its_level_through_the_operator() {
        // Uniform ±1 kN and ±0.05 kN: σ² = 4/12 + 0.01/12, Σ(δ − w)² = 0.625² + 2·0.25² +
        // 2·0.0625² = 0.5234375, σ_hf = 0.418 kN. The robust scale of this near-uniform mixture
        // lies between σ (a normal's) and 1.28σ (one uniform's): 0.45–0.50 kN.
        let s = IdentificationParams::default();
        let sigma = ((4.0 + 0.01) / 12.0 * 0.5234375f64).sqrt();
        let h = noise_hf_kn(&s);
        assert!(h > sigma && h < 1.2 * sigma, "{h} vs σ {sigma}");
        // A table without absolute sources gives none.
        let mut quiet = s.clone();
        quiet
            .uncertainty
            .retain(|u| u.kind != UncertaintyKind::AbsoluteKn);
        assert_eq!(noise_hf_kn(&quiet).to_bits(), 0.0f64.to_bits());
    }

    #[test]
    fn a_level_picks_the_smoothest_class_that_reaches_it() {
        use RoughnessClass::*;
        let rows = [
            row(None, 0.0),
            row(Some(Disc), 0.2),
            row(Some(CastIron), 0.8),
            row(Some(CastIronRough), 1.9),
        ];
        let refs: Vec<&RoughnessRow> = rows.iter().collect();
        let noise = 0.42;
        // Noise alone (and up to 15 % above it): round wheels.
        assert_eq!(classify(&refs, 0.45, noise).0.wheel, None);
        assert_eq!(classify(&refs, 0.52, noise).0.wheel, Some(Disc));
        assert_eq!(classify(&refs, 0.9, noise).0.wheel, Some(CastIron));
        let (r, scale) = classify(&refs, 1.5, noise);
        assert_eq!((r.wheel, scale), (Some(CastIronRough), 1.0));
        // Beyond the roughest: scaled by √(h² − noise²)/h_class.
        let (r, scale) = classify(&refs, 4.0, noise);
        assert_eq!(r.wheel, Some(CastIronRough));
        assert!((scale - (16.0f64 - noise * noise).sqrt() / 1.9).abs() < 1e-12);
    }
}
