//! The preflight in wind (issue 36), through the flown code: a reference-model test of the
//! reference actuator whose parked surface carries a 20 kt wind is named a moved load by the
//! firmware's preflight (on the host) as by the ground tools, and the firmware's re-run policy
//! runs it again at most `Reruns::MAX_TESTS` times; the same actuator in still air is
//! `within`, and is not run again.

use firmware::source::SliceBytes;
use firmware::{Preflight, PreflightSettings, Progress, Report, Reruns, TraceSource};
use host_sim::fdi::identify::identify_for;
use host_sim::plant::aero::GroundWind;
use host_sim::plant::reference::{ReferenceModel, ReferenceSettings, Scenario};
use host_sim::studies::wind::load_moved;
use shared::actuator::ActuatorRecord;
use shared::domain::Domain;
use shared::fdi::OnboardMeasured;
use shared::fitness::CurvatureRun;
use shared::{FaultVector, LowPass};

/// The firmware's report and the ground tools' verdict on one reference-model test.
fn both_verdicts(wind: Option<GroundWind>, seed: u64) -> (Report, Domain) {
    let record = ActuatorRecord::REFERENCE;
    let sim = ReferenceModel::new(ReferenceSettings::REFERENCE)
        .with_test(record.test)
        .with_wind(wind)
        .simulate(&Scenario {
            seed,
            ..Scenario::new(FaultVector::NOMINAL)
        });
    let bytes = sim.trace.to_bin().expect("a binary trace");
    let source = TraceSource::open(SliceBytes::new(&bytes)).expect("a valid trace");
    let settings = PreflightSettings::ONBOARD.for_actuator(&record);
    let filter = LowPass::for_control_period(1.0e-4).expect("the 10 kHz filter exists");
    let mut buffer = Box::new(OnboardMeasured::new(filter));
    let mut curvature = Box::new(CurvatureRun::IDLE);
    let mut preflight =
        Preflight::new(&settings, source, &mut buffer).with_curvature_buffer(&mut curvature);
    let report = loop {
        if let Progress::Finished(report) = preflight.poll().expect("the preflight runs") {
            break report;
        }
    };
    let measured = sim.trace.measured(&record.params).expect("a usable trace");
    let id = identify_for(&measured, &record, settings.seed, false).expect("identified");
    let ground = id.domain(&sim.trace.domain_monitor(&record.params), &record.domain);
    (report, ground)
}

#[test]
fn a_test_in_a_twenty_knot_wind_is_named_and_run_again_a_bounded_number_of_times() {
    let wind = GroundWind::new(20.0, 20.0).expect("a wind");
    let (report, ground) = both_verdicts(Some(wind), 3);
    assert!(load_moved(&report.domain), "{:?}", report.domain);
    assert_eq!(report.domain, ground, "firmware and ground tools disagree");
    let mut reruns = Reruns::new();
    assert!(reruns.again(&report));
    assert!(reruns.again(&report));
    assert!(
        !reruns.again(&report),
        "at most {} tests",
        Reruns::MAX_TESTS
    );
    assert_eq!(reruns.tests(), Reruns::MAX_TESTS);
}

#[test]
fn the_same_test_in_still_air_is_within_and_not_run_again() {
    let (report, ground) = both_verdicts(None, 3);
    assert_eq!(report.domain, Domain::Within);
    assert_eq!(ground, Domain::Within);
    let mut reruns = Reruns::new();
    assert!(!reruns.again(&report));
}
