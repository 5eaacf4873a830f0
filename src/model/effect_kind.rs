//! The kinds of the effect library, as the calibration names them (`kind = "voided_sleeper"`):
//! what the diagnosis ranks and compares, never a string.

use super::effect::Effect;
use serde::{Deserialize, Serialize};

/// An effect's kind: [`Effect`]'s variants without their parameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EffectKind {
    /// [`Effect::VoidedSleeper`].
    VoidedSleeper,
    /// [`Effect::PadStiffness`].
    PadStiffness,
    /// [`Effect::BallastStiffness`].
    BallastStiffness,
    /// [`Effect::RailDip`].
    RailDip,
    /// [`Effect::RailIrregularity`].
    RailIrregularity,
    /// [`Effect::WheelOutOfRound`].
    WheelOutOfRound,
    /// [`Effect::SensorGain`].
    SensorGain,
    /// [`Effect::TimeOffset`].
    TimeOffset,
    /// [`Effect::CarBodyBounce`].
    CarBodyBounce,
    /// [`Effect::SecondFlat`].
    SecondFlat,
    /// [`Effect::SpeedDeviation`].
    SpeedDeviation,
}

impl EffectKind {
    /// Every kind, in the library's order.
    pub const ALL: [EffectKind; 11] = [
        EffectKind::VoidedSleeper,
        EffectKind::PadStiffness,
        EffectKind::BallastStiffness,
        EffectKind::RailDip,
        EffectKind::RailIrregularity,
        EffectKind::WheelOutOfRound,
        EffectKind::SensorGain,
        EffectKind::TimeOffset,
        EffectKind::CarBodyBounce,
        EffectKind::SecondFlat,
        EffectKind::SpeedDeviation,
    ];

    /// The name the calibration and the JSON use.
    pub fn as_str(self) -> &'static str {
        match self {
            EffectKind::VoidedSleeper => "voided_sleeper",
            EffectKind::PadStiffness => "pad_stiffness",
            EffectKind::BallastStiffness => "ballast_stiffness",
            EffectKind::RailDip => "rail_dip",
            EffectKind::RailIrregularity => "rail_irregularity",
            EffectKind::WheelOutOfRound => "wheel_out_of_round",
            EffectKind::SensorGain => "sensor_gain",
            EffectKind::TimeOffset => "time_offset",
            EffectKind::CarBodyBounce => "car_body_bounce",
            EffectKind::SecondFlat => "second_flat",
            EffectKind::SpeedDeviation => "speed_deviation",
        }
    }
}

impl std::fmt::Display for EffectKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

impl Effect {
    /// This effect's kind.
    pub fn kind(&self) -> EffectKind {
        match self {
            Effect::VoidedSleeper { .. } => EffectKind::VoidedSleeper,
            Effect::PadStiffness { .. } => EffectKind::PadStiffness,
            Effect::BallastStiffness { .. } => EffectKind::BallastStiffness,
            Effect::RailDip { .. } => EffectKind::RailDip,
            Effect::RailIrregularity { .. } => EffectKind::RailIrregularity,
            Effect::WheelOutOfRound { .. } => EffectKind::WheelOutOfRound,
            Effect::SensorGain { .. } => EffectKind::SensorGain,
            Effect::TimeOffset { .. } => EffectKind::TimeOffset,
            Effect::CarBodyBounce { .. } => EffectKind::CarBodyBounce,
            Effect::SecondFlat { .. } => EffectKind::SecondFlat,
            Effect::SpeedDeviation { .. } => EffectKind::SpeedDeviation,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_kind_is_named_as_the_calibration_tags_its_effect() {
        // The serde tag of an effect and its kind's name agree, for every kind.
        let effects = [
            "kind = \"voided_sleeper\"\nsleeper = 17\ngap_mm = 0.5",
            "kind = \"second_flat\"\nwheel = \"trailing\"\nlength_mm = 40.0\ndepth_mm = 0.2\nimpact_position_m = 12.4",
            "kind = \"speed_deviation\"\nfraction = 0.01",
        ];
        for text in effects {
            let e: Effect = toml::from_str(text).unwrap();
            assert!(
                text.starts_with(&format!("kind = \"{}\"", e.kind())),
                "{text}"
            );
        }
        for k in EffectKind::ALL {
            let json = serde_json::to_string(&k).unwrap();
            assert_eq!(json, format!("\"{k}\""));
        }
    }
}
