//! The grease's viscosity ratio against 20 °C under each law of the physics family, at the
//! reference actuator's two-part grease (×10 at −40 °C): `cargo run --release -p host-sim
//! --example viscosity_laws` (instant).
use host_sim::plant::bridge::{ThermalLaws, ViscosityLaw};

fn main() {
    let base = ThermalLaws::NDFEB_GREASED.with_two_part_grease(&shared::ActuatorParams::REFERENCE);
    println!("| °C | Arrhenius | Walther | Vogel–Fulcher |\n| ---: | ---: | ---: | ---: |");
    for c in [-60.0, -45.0, -40.0, -25.0, -10.0, 0.0, 20.0, 50.0, 75.0] {
        let r = |law| {
            ThermalLaws {
                viscosity_law: law,
                ..base
            }
            .viscosity_ratio(c)
        };
        println!(
            "| {c} | {:.2} | {:.2} | {:.2} |",
            r(ViscosityLaw::Arrhenius),
            r(ViscosityLaw::Walther),
            r(ViscosityLaw::VogelFulcher)
        );
    }
}
