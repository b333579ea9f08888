//! Preflight FDI firmware for the actuator controller (STM32F405, Cortex-M4F).
//!
//! This first version proves the target: it links `shared` into a Cortex-M4F image, runs one
//! monitor-model evaluation of the healthy actuator and exits through semihosting (status 0
//! if the simulated current is finite). The preflight task (acquire → condition → identify →
//! report under embassy, defmt over semihosting) replaces it in the firmware issue. On the
//! host the crate compiles to a stub so that `cargo test --workspace` stays runnable.
#![cfg_attr(target_os = "none", no_std)]
#![cfg_attr(target_os = "none", no_main)]

#[cfg(target_os = "none")]
mod target {
    use cortex_m_rt::entry;
    use cortex_m_semihosting::debug::{exit, EXIT_FAILURE, EXIT_SUCCESS};
    use shared::{ActuatorParams, Calibration, FaultVector, MonitorModel};

    #[entry]
    fn main() -> ! {
        let model = MonitorModel::new(ActuatorParams::REFERENCE, &Calibration::IDENTITY);
        let mut finite = true;
        model.run(&FaultVector::NOMINAL, model.test_samples(), |s| {
            finite &= s.current.is_finite()
        });
        exit(if finite { EXIT_SUCCESS } else { EXIT_FAILURE });
        #[allow(clippy::empty_loop)]
        loop {}
    }

    #[panic_handler]
    fn panic(_: &core::panic::PanicInfo) -> ! {
        exit(EXIT_FAILURE);
        #[allow(clippy::empty_loop)]
        loop {}
    }
}

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!("firmware: this binary runs on the Cortex-M4F; build it with `cargo fw-build`.");
}
