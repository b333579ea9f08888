//! The inverse check's multimodal vector over GA seeds 1–20: how often the flown solver (GA
//! and polish) reaches the truth's basin on the monitor model's own trace (e_tot ≤ 0.5 %).
//! `cargo run --release -p shared --example inverse_seeds` (about 10 s); the figure is quoted
//! in `tests/inverse_identification.rs` and docs/accuracy.md.

use shared::fdi::{
    record_monitor_trace, Identification, OnboardMeasured, POPULATION, TEST_SAMPLES,
};
use shared::metrics::total_error;
use shared::test_design::PreflightTest;
use shared::{ActuatorParams, Calibration, FaultVector, GaSettings, LowPass, MonitorModel};

fn main() {
    let params = ActuatorParams::REFERENCE;
    let calibration = Calibration::IDENTITY;
    let model = MonitorModel::new(params, &calibration);
    let truth =
        FaultVector::new([0.25, 0.6, 0.0, 0.15, 0.3, 0.35, 0.1, 0.7, 0.0]).expect("in range");
    let Ok(filter) = LowPass::for_control_period(params.control_period) else {
        return;
    };
    let mut measured = Box::new(OnboardMeasured::for_test(filter, PreflightTest::STANDSTILL));
    if record_monitor_trace(&model, &truth, &mut measured).is_err() {
        return;
    }
    let mut reached = 0;
    let mut line = String::new();
    for seed in 1..=20 {
        let Ok(mut id) = Identification::<TEST_SAMPLES, POPULATION>::new(
            &measured,
            params,
            &calibration,
            GaSettings::FDI,
            seed,
        ) else {
            return;
        };
        let e_tot = total_error(&id.run().faults, &truth);
        reached += u32::from(e_tot <= 0.5);
        line += &format!(" {e_tot:.2}");
    }
    println!("truth {:?}", truth.as_array());
    println!("e_tot [%] by seed:{line}");
    println!("reached (≤ 0.5 %) in {reached} of 20 seeds");
}
