//! The all-zero constants the firmware keeps in `.bss` (`OnboardMeasured::ZEROED`,
//! `CurvatureRun::IDLE`, `RamStore::ZEROED`) behave, once set up in place, exactly as the
//! values built the ordinary way: the same bits out.

use shared::fdi::{record_monitor_trace, OnboardMeasured};
use shared::fitness::CurvatureRun;
use shared::health::RamStore;
use shared::test_design::PreflightTest;
use shared::{ActuatorParams, Calibration, FaultVector, FitnessProblem, LowPass, MonitorModel};

fn filter() -> LowPass {
    LowPass::for_control_period(ActuatorParams::REFERENCE.control_period).unwrap()
}

fn model() -> MonitorModel {
    MonitorModel::new(
        ActuatorParams::REFERENCE,
        &Calibration::REFERENCE_ACTUATOR_STEPS,
    )
}

/// A measured buffer recorded from the monitor model at `k` into `measured`.
fn record(measured: &mut OnboardMeasured, k: &FaultVector) {
    record_monitor_trace(&model(), k, measured).unwrap();
}

#[test]
fn a_zeroed_buffer_set_up_in_place_conditions_as_a_new_one() {
    let k = FaultVector::new([0.1, 0.2, 0.1, 0.0, 0.05, 0.1, 0.3, 0.4, 0.0]).unwrap();
    let mut fresh = Box::new(OnboardMeasured::for_test(
        filter(),
        PreflightTest::STANDSTILL,
    ));
    record(&mut fresh, &k);

    let mut zeroed = Box::new(OnboardMeasured::ZEROED);
    assert!(zeroed.samples().is_empty());
    zeroed.set_filter(filter());
    zeroed.clear_for(PreflightTest::STANDSTILL);
    record(&mut zeroed, &k);

    assert_eq!(zeroed.test(), fresh.test());
    let bits = |m: &OnboardMeasured| m.samples().iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&zeroed), bits(&fresh));
    assert_eq!(
        zeroed.inv_kappa().unwrap().to_bits(),
        fresh.inv_kappa().unwrap().to_bits()
    );
}

#[test]
fn an_idle_curvature_run_restarted_gives_the_sums_of_a_started_one() {
    let truth = FaultVector::new([0.0, 0.3, 0.0, 0.0, 0.0, 0.2, 0.5, 0.5, 0.0]).unwrap();
    let mut measured = Box::new(OnboardMeasured::for_test(
        filter(),
        PreflightTest::STANDSTILL,
    ));
    record(&mut measured, &truth);
    let problem = FitnessProblem::new(
        &measured,
        ActuatorParams::REFERENCE,
        &Calibration::REFERENCE_ACTUATOR_STEPS,
    )
    .unwrap();
    let samples = measured.samples().len();

    let mut started = problem.start_curvature(&truth);
    let a = problem.continue_curvature(&mut started, samples).unwrap();

    let mut idle = Box::new(CurvatureRun::IDLE);
    problem.restart_curvature(&mut idle, &truth);
    let b = problem.continue_curvature(&mut idle, samples).unwrap();
    assert_eq!(a, b);
}

#[test]
fn a_zeroed_store_erased_in_place_is_an_erased_store() {
    let mut store = RamStore::<4>::ZEROED;
    assert!(store.as_bytes().iter().all(|&b| b == 0));
    store.erase();
    assert_eq!(store, RamStore::<4>::erased());
}
