//! Inverse check: traces made by the monitor model itself at known fault vectors are
//! identified by the onboard FDI (same sizes, settings and code as the firmware) with
//! e_tot ≤ 0.5 %. This proves the conditioning, fitness and optimiser before the reference
//! model exists; it is not the accuracy goal, which is against the reference model.

use shared::fdi::{
    record_monitor_trace, Identification, OnboardMeasured, POPULATION, TEST_SAMPLES,
};
use shared::metrics::total_error;
use shared::test_design::PreflightTest;
use shared::{ActuatorParams, Calibration, FaultVector, GaSettings, LowPass, MonitorModel};

fn identify(truth: [f32; 9], seed: u64) -> (f32, u32, f32) {
    let params = ActuatorParams::REFERENCE;
    let calibration = Calibration::IDENTITY;
    let model = MonitorModel::new(params, &calibration);
    let truth = FaultVector::new(truth).unwrap();
    // The product's default test: the standstill segment, then the chirp.
    let mut measured = Box::new(OnboardMeasured::for_test(
        LowPass::for_control_period(params.control_period).unwrap(),
        PreflightTest::STANDSTILL,
    ));
    record_monitor_trace(&model, &truth, &mut measured).unwrap();
    let mut id = Identification::<TEST_SAMPLES, POPULATION>::new(
        &measured,
        params,
        &calibration,
        GaSettings::FDI,
        seed,
    )
    .unwrap();
    let result = id.run();
    let e_tot = total_error(&result.faults, &truth);
    println!(
        "truth {:?}\n found {:?}\n e_tot {e_tot:.4} %, {} evaluations, fitness {:.3e}, {:?}",
        truth.as_array(),
        result.faults.as_array(),
        result.evaluations,
        result.fitness,
        result.stop_reason
    );
    (e_tot, result.evaluations, result.fitness)
}

#[test]
fn single_fault_short_circuit_is_identified() {
    let (e_tot, evaluations, _) = identify([0.0, 0.0, 0.4, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0], 1);
    assert!(e_tot <= 0.5, "e_tot {e_tot} %");
    assert!(
        evaluations
            <= GaSettings::FDI.max_evaluations
                + shared::polish::PolishSettings::FDI.max_evaluations()
    );
}

#[test]
fn low_multi_fault_is_identified() {
    let (e_tot, _, _) = identify([0.1, 0.1, 0.1, 0.05, 0.0, 0.1, 0.25, 0.4, 0.0], 1);
    assert!(e_tot <= 0.5, "e_tot {e_tot} %");
}

#[test]
fn mixed_multi_fault_is_identified() {
    let (e_tot, _, _) = identify([0.25, 0.6, 0.0, 0.15, 0.3, 0.35, 0.1, 0.7, 0.0], 1);
    assert!(e_tot <= 0.5, "e_tot {e_tot} %");
}

#[test]
fn healthy_trace_scores_nominal() {
    let (e_tot, _, fitness) = identify(*FaultVector::NOMINAL.as_array(), 1);
    assert!(e_tot <= 0.5, "e_tot {e_tot} %");
    assert!((0.0..1e-6).contains(&fitness), "fitness {fitness}");
}
