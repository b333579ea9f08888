//! The sensor checks' statistics over paper Tables I and II (3 seeds each) on the reference
//! actuator, with an optional injected sensor fault: what the limits in `shared::domain`
//! were chosen from. `cargo run --release -p host-sim --example sensor_statistics [KIND[:SIZE]]`
//! prints per run: (equal encoder readings, largest encoder step [rad], mean and RMS of the
//! phase currents' sum [A], transducer disagreement [rad]) and the sensor verdict.

use host_sim::plant::reference::{ReferenceModel, ReferenceSettings, Scenario, SensorFault};
use host_sim::studies::campaign::{TABLE_1, TABLE_2};
use shared::{ActuatorParams, FaultVector};
fn main() {
    let p = ActuatorParams::REFERENCE;
    let fault = std::env::args()
        .nth(1)
        .map(|a| SensorFault::parse(&a).unwrap());
    for case in TABLE_1.iter().chain(TABLE_2.iter()) {
        for seed in 0..3 {
            let rm = ReferenceModel::new(ReferenceSettings::REFERENCE).with_sensor_fault(fault);
            let sim = rm.simulate(&Scenario {
                faults: FaultVector::new(case.faults).unwrap(),
                current_ref_noise: case.noise,
                seed,
            });
            let m = sim.trace.domain_monitor(&p);
            println!(
                "{:28} {seed} {:?} {:?}",
                case.name,
                m.sensor_statistics(),
                m.sensor_fault()
            );
        }
    }
}
