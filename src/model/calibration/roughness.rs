//! The roughness an identification allows for: the wheels' class and the rail's
//! (`[identification]` `wheel_roughness`, `rail_roughness`; docs/detection.md, "Rough wheels").

use super::IdentificationParams;
use crate::model::surface::RoughnessClass;
use serde::{Deserialize, Serialize};

/// The wheels' roughness class an identification allows for
/// ([`super::IdentificationParams::wheel_roughness`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum WheelRoughness {
    /// Read from each pass's record.
    #[default]
    Auto,
    /// Round wheels with a smooth tread.
    Round,
    /// Disc-braked wheels (CNOSSOS-EU `n`).
    Disc,
    /// Composite or sinter tread brakes (CNOSSOS-EU `k`).
    Composite,
    /// Cast-iron tread brakes (CNOSSOS-EU `c`).
    CastIron,
    /// The rough end of tread-braked wheels.
    CastIronRough,
}

impl WheelRoughness {
    /// The class stated (`None`: `auto`; `Some(None)`: round wheels).
    pub fn stated(self) -> Option<Option<RoughnessClass>> {
        match self {
            WheelRoughness::Auto => None,
            WheelRoughness::Round => Some(None),
            WheelRoughness::Disc => Some(Some(RoughnessClass::Disc)),
            WheelRoughness::Composite => Some(Some(RoughnessClass::Composite)),
            WheelRoughness::CastIron => Some(Some(RoughnessClass::CastIron)),
            WheelRoughness::CastIronRough => Some(Some(RoughnessClass::CastIronRough)),
        }
    }
}

/// The site's rail roughness ([`super::IdentificationParams::rail_roughness`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RailRoughness {
    /// A smooth rail.
    #[default]
    Smooth,
    /// A rail at the EN ISO 3095 limit spectrum.
    Iso3095,
}

impl RailRoughness {
    /// The rail's class (`None`: smooth).
    pub fn class(self) -> Option<RoughnessClass> {
        match self {
            RailRoughness::Smooth => None,
            RailRoughness::Iso3095 => Some(RoughnessClass::RailIso3095),
        }
    }
}

impl IdentificationParams {
    /// Whether the site states round wheels on a smooth rail: passes are then judged sample by
    /// sample with no roughness bound, detection included, as every pass was before roughness
    /// was allowed for.
    pub fn round_wheels_stated(&self) -> bool {
        self.wheel_roughness == WheelRoughness::Round
            && self.rail_roughness == RailRoughness::Smooth
    }
}
