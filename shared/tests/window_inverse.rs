//! The window identification's inverse check (issue 36): a window of flight recorded from the
//! monitor model itself — the flight control computer's corrections with the chirp on top, a
//! hinge spring of its own stiffness carrying a moment, known faults — is identified by
//! `shared::window::identify`, the code the host runs on every window (and a controller
//! would): the faults come back, the window is `within`, and the work stays inside its
//! stated bound. Fails if the load search, the GAs, the polish or the verdicts disagree with
//! the model they wrap.

use shared::actuator::ActuatorRecord;
use shared::fdi::{OnboardMeasured, POPULATION, TEST_SAMPLES};
use shared::test_design::PreflightTest;
use shared::window::{
    identify, record_monitor_window, synthetic_command, RecordedCommand, WindowLimits, WindowLoad,
    WindowProblem, CURVATURE_RUNS, LOAD_SEARCH_EVALUATIONS,
};
use shared::{Calibration, FaultVector, LowPass, MonitorModel};

/// The chirp-only test a window carries and the monitor model on it.
fn model() -> (MonitorModel, PreflightTest) {
    let record = ActuatorRecord::REFERENCE;
    let test = record.test.chirp_only();
    let model =
        MonitorModel::new(record.params, &Calibration::reference_actuator(&test)).with_test(&test);
    (model, test)
}

#[test]
fn a_window_recorded_from_the_monitor_model_is_identified() {
    let record = ActuatorRecord::REFERENCE;
    let (model, test) = model();
    let period = record.params.control_period;
    let sampler = model.sampler();
    let command: Vec<f32> = (0..TEST_SAMPLES)
        .map(|i| synthetic_command(&sampler, 1.0e-3, period, i))
        .collect();
    // Friction 0.2 and a gain drift, a hinge spring 1.4 times the actuator's carrying 120 N·m.
    let mut genes = *FaultVector::NOMINAL.as_array();
    (genes[0], genes[7]) = (0.2, 0.6);
    let truth = FaultVector::new(genes).unwrap();
    let load = WindowLoad::spring(1.4 * record.params.aero_stiffness, 120.0);
    let mut measured = Box::new(OnboardMeasured::ZEROED);
    measured.set_filter(LowPass::for_control_period(period).unwrap());
    measured.clear_for(test);
    record_monitor_window(&model, &truth, &load, &command, 0.3, &mut measured).unwrap();
    assert_eq!(measured.samples().len(), TEST_SAMPLES);

    let guess = WindowLoad::spring(record.params.aero_stiffness, 0.0);
    let problem =
        WindowProblem::new(&measured, RecordedCommand::new(&command), model, guess).unwrap();
    // At the truth the fit is (almost) exact; at the nominal vector it is not.
    let at_truth = problem.evaluate_under(&truth, load).error;
    let at_nominal = problem.evaluate_under(&FaultVector::NOMINAL, load).error;
    assert!(at_truth < 1e-3 * at_nominal, "{at_truth} vs {at_nominal}");

    let reading =
        identify::<_, POPULATION>(&problem, record.ga, 1, &WindowLimits::REFERENCE).unwrap();
    let found = reading.faults;
    assert!(
        (found.friction() - 0.2).abs() < 0.03,
        "friction {}",
        found.friction()
    );
    assert!(
        (found.as_array()[7] - 0.6).abs() < 0.03,
        "gain drift {found:?}"
    );
    assert!(
        (reading.load.stiffness / load.stiffness - 1.0).abs() < 0.1,
        "stiffness {} vs {}",
        reading.load.stiffness,
        load.stiffness
    );
    assert_eq!(reading.verdict, Ok(()), "{reading:?}");
    let (u, _) = reading.uncertainty.expect("a determined curvature");
    assert!(u.covers(&truth)[0] == Some(true), "{u:?}");
    // The work: two load searches, two GA runs within their settings' budget, the polish.
    let bound =
        2 * LOAD_SEARCH_EVALUATIONS as u32 + 2 * record.ga.max_evaluations + 7 * CURVATURE_RUNS + 6;
    assert!(
        reading.evaluations <= bound,
        "{} > {bound}",
        reading.evaluations
    );
}
