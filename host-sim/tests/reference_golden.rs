//! The reference model's traces, truth, rig recording and energy bits for six seeded runs
//! (three fault vectors, on the ground and in cruise, with 20 % I_ref noise) against stored
//! digests: a change to the reference model's arithmetic — or to the order of its random
//! draws — moves every stored table, and must be made knowingly. The digests were taken
//! before the external-drive hook (`ReferenceModel::simulate_driven`) was added.

use host_sim::plant::aero::{FlightPhase, FlightWindow, Turbulence};
use host_sim::plant::reference::{ReferenceModel, ReferenceSettings, Scenario};
use shared::FaultVector;

const CASES: [[f32; 9]; 3] = [
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0],
    [0.4, 0.4, 0.2, 0.1, 0.05, 0.2, 0.75, 0.6, 0.0],
    [0.0, 0.0, 0.5, 0.0, 0.0, 0.0, 0.5, 0.5, 0.2],
];

/// An FNV-style digest of the runs' f64 bits, per (case, in flight).
const DIGESTS: [[u64; 2]; 3] = [
    [0xf99a58f075c74ece, 0x5a26ec649f0751e5],
    [0x12769992ab9a7bc1, 0x4f49d26bbafb0fe3],
    [0x26b4778f94a8fdff, 0x5fa9c7856078f6c5],
];

#[test]
fn seeded_reference_runs_keep_their_bits() {
    for (c, f) in CASES.iter().enumerate() {
        for (w, flight) in [false, true].into_iter().enumerate() {
            let mut rm = ReferenceModel::new(ReferenceSettings::REFERENCE).with_recording(40_000.0);
            if flight {
                rm = rm.with_flight(Some(FlightWindow {
                    phase: FlightPhase::Cruise,
                    turbulence: Turbulence::Light,
                }));
            }
            let mut scenario = Scenario::new(FaultVector::new(*f).expect("a valid vector"));
            scenario.seed = 7 + c as u64;
            scenario.current_ref_noise = 0.2;
            let sim = rm.simulate(&scenario);
            let mut h: u64 = 1_469_598_103_934_665_603;
            let mut eat = |x: f64| {
                h ^= x.to_bits();
                h = h.wrapping_mul(1_099_511_628_211);
            };
            for s in sim.trace.samples() {
                s.phase_currents.into_iter().for_each(&mut eat);
                eat(s.motor_angle);
                eat(s.user_angle);
                eat(s.bus_voltage.unwrap_or(0.0));
            }
            for t in &sim.truth {
                eat(t.user_angle);
                eat(t.current_ref);
                t.applied_voltages.into_iter().for_each(&mut eat);
            }
            for r in &sim.recording {
                r.phase_currents.into_iter().for_each(&mut eat);
            }
            eat(sim.energy.copper_loss);
            assert_eq!(h, DIGESTS[c][w], "case {c}, in flight {flight}");
        }
    }
}
