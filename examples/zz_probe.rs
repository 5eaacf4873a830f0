use wheelflat::bank::Bank;
use wheelflat::diagnose::{self, suite};
use wheelflat::identify::{Extras, Identifier};
use wheelflat::model::{Calibration, Effect::*, WheelPosition};
fn main() {
    let cal = Calibration::narrow_profile().check().unwrap();
    let id = Identifier::new(Bank::open(std::path::Path::new("/tmp/sbank")).unwrap(), cal.identification.clone()).unwrap();
    let es = vec![
        PadStiffness { sleeper: 16, factor: 0.15 }, PadStiffness { sleeper: 16, factor: 8.0 },
        RailDip { position_m: 11.9, length_m: 0.5, depth_mm: 1.0 }, RailDip { position_m: 11.9, length_m: 0.5, depth_mm: 1.5 },
        RailIrregularity { wavelength_m: 0.5, amplitude_mm: 0.3, phase_deg: 30.0 }, RailIrregularity { wavelength_m: 0.5, amplitude_mm: 0.6, phase_deg: 30.0 },
        RailIrregularity { wavelength_m: 3.0, amplitude_mm: 1.0, phase_deg: 120.0 }, RailIrregularity { wavelength_m: 3.0, amplitude_mm: 2.0, phase_deg: 120.0 },
        WheelOutOfRound { wheel: WheelPosition::Leading, order: 5, amplitude_mm: 0.4, phase_deg: 0.0 },
        WheelOutOfRound { wheel: WheelPosition::Leading, order: 5, amplitude_mm: 0.8, phase_deg: 0.0 },
        TimeOffset { offset_ms: 10.0 }, TimeOffset { offset_ms: -15.0 }, TimeOffset { offset_ms: 25.0 },
        CarBodyBounce { amplitude: 0.3, frequency_hz: 1.2, phase_deg: 40.0 }, CarBodyBounce { amplitude: 0.4, frequency_hz: 1.5, phase_deg: 40.0 },
    ];
    for e in es {
        let case = suite::Case { name: format!("{e:?}"), hidden: suite::Hidden::Effect(e), flat: [58.0, 0.47, 0.04, 12.41], seed: 5 };
        let (m, _) = suite::measurement(&cal, &case).unwrap();
        let ident = id.identify(&m, None, Extras { baselines: false, curves: false }).unwrap();
        let l = diagnose::locate(&id, &ident).unwrap();
        println!("{:<90} outside {:>5} gap {:.3} cms {}", case.name, l.samples_outside, l.gap_rms_kn, ident.cms.len());
    }
}
