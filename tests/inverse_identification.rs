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

/// The monitor model's own trace of `truth` on the product's default test (the standstill
/// segment, then the chirp).
fn trace_of(truth: &FaultVector) -> Box<OnboardMeasured> {
    let params = ActuatorParams::REFERENCE;
    let model = MonitorModel::new(params, &Calibration::IDENTITY);
    let mut measured = Box::new(OnboardMeasured::for_test(
        LowPass::for_control_period(params.control_period).unwrap(),
        PreflightTest::STANDSTILL,
    ));
    record_monitor_trace(&model, truth, &mut measured).unwrap();
    measured
}

/// The fitness of the truth itself on its own trace.
fn identify_fitness_at(truth: [f32; 9]) -> f32 {
    let truth = FaultVector::new(truth).unwrap();
    shared::FitnessProblem::new(
        &*trace_of(&truth),
        ActuatorParams::REFERENCE,
        &Calibration::IDENTITY,
    )
    .unwrap()
    .error(&truth)
}

fn identify(truth: [f32; 9], seed: u64) -> (f32, u32, f32) {
    let params = ActuatorParams::REFERENCE;
    let calibration = Calibration::IDENTITY;
    let truth = FaultVector::new(truth).unwrap();
    let measured = trace_of(&truth);
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
                + shared::weak_magnet::WeakMagnetSearch::work_after_ga(
                    &shared::ActuatorParams::default(),
                    &shared::polish::PolishSettings::FDI
                )
                .0
    );
}

#[test]
fn low_multi_fault_is_identified() {
    let (e_tot, _, _) = identify([0.1, 0.1, 0.1, 0.05, 0.0, 0.1, 0.25, 0.4, 0.0], 1);
    assert!(e_tot <= 0.5, "e_tot {e_tot} %");
}

/// A vector with a large play: backlash 0.6 (a dead zone 60× the nominal play) with
/// friction, shorts and an eccentricity. The flown solver reaches the truth within 0.5 % from
/// every one of GA seeds 1–20 (`cargo run --release -p shared --example inverse_seeds`;
/// docs/accuracy.md). The check: no seed of 1–6 finds a fitness below the truth's (the truth
/// is the fitness's global minimum, so a miss is the optimiser's, not the model's), and every
/// one reaches it within 0.5 %. (A gear contact that damped over the whole step from its
/// first touch made this fitness rugged along the play, and the truth was reached from 5 of
/// the 20 seeds.)
#[test]
fn mixed_multi_fault_has_its_minimum_at_the_truth_and_is_reached() {
    let truth = [0.25, 0.6, 0.0, 0.15, 0.3, 0.35, 0.1, 0.7, 0.0];
    let at_truth = identify_fitness_at(truth);
    let runs: Vec<(f32, u32, f32)> = (1..=6).map(|seed| identify(truth, seed)).collect();
    for (seed, (e_tot, _, fitness)) in runs.iter().enumerate() {
        assert!(
            *fitness >= at_truth,
            "seed {}: fitness {fitness:e} below the truth's {at_truth:e} (e_tot {e_tot} %)",
            seed + 1
        );
        assert!(*e_tot <= 0.5, "seed {}: e_tot {e_tot} %", seed + 1);
    }
}

#[test]
fn a_uniform_demagnetization_is_identified() {
    let truth = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.2];
    let (e_tot, _, _) = identify(truth, 1);
    assert!(e_tot <= 0.5, "e_tot {e_tot} %");
    // And the ninth itself: the paper's e_tot leaves it out.
    let found = Identification::<TEST_SAMPLES, POPULATION>::new(
        &trace_of(&FaultVector::new(truth).unwrap()),
        ActuatorParams::REFERENCE,
        &Calibration::IDENTITY,
        GaSettings::FDI,
        1,
    )
    .unwrap()
    .run()
    .faults;
    assert!((found.demagnetization() - 0.2).abs() <= 0.005, "{found:?}");
}

#[test]
fn healthy_trace_scores_nominal() {
    let (e_tot, _, fitness) = identify(*FaultVector::NOMINAL.as_array(), 1);
    assert!(e_tot <= 0.5, "e_tot {e_tot} %");
    assert!((0.0..1e-6).contains(&fitness), "fitness {fitness}");
}
