//! What the board's drive and sensors cost a window (`board_emu::sensing`, host only): the
//! board's windows sit at the load model's fitness floor because of its late duties and its
//! coarse encoder and transducer, each of which adds to what the fit leaves unexplained.

use board_emu::sensing::{fly_case, CASES};
use host_sim::files::actuator::Actuator;
use host_sim::plant::aero::FlightPhase;
use shared::window::WindowLimits;
use shared::FaultVector;

#[test]
fn each_coarse_sensor_and_the_late_duties_add_to_a_windows_misfit() {
    let actuator = Actuator::reference();
    let faults = FaultVector::new([0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0]).unwrap();
    let rows: Vec<_> = CASES
        .iter()
        .map(|&case| fly_case(&actuator, case, FlightPhase::Cruise, faults, 3).unwrap())
        .collect();
    let misfit: Vec<f32> = rows.iter().map(|r| r.misfit).collect();
    println!("misfits (board, 20-bit encoder, 20-bit transducer, both, monitor's law): {misfit:?}");
    let [board, fine_encoder, fine_transducer, fine_both, ideal] = misfit[..] else {
        panic!("{} cases", misfit.len());
    };
    // The monitor model's own law on fine sensors flies a window the FDI reads.
    assert_eq!(rows[4].verdict, Ok(()), "{:?}", rows[4]);
    // The board as built is above the window's limit (its windows' floor on the emulator).
    assert!(board > WindowLimits::REFERENCE.max_misfit, "{misfit:?}");
    // Each finer sensor lowers it, both lower it further, and the board's late duties cost
    // what is left above the monitor's law.
    assert!(
        fine_encoder < board && fine_transducer < board,
        "{misfit:?}"
    );
    assert!(
        fine_both < fine_encoder && fine_both < fine_transducer,
        "{misfit:?}"
    );
    assert!(ideal < fine_both, "{misfit:?}");
    // Every drive tracks the window's command alike: the misfit is not a worse flight.
    for r in &rows {
        assert!(r.tracking < 1.0e-3, "{r:?}");
    }
}
