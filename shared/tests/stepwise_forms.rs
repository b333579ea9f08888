//! The sync and stepwise forms that share their arithmetic in pieces (`invert` and
//! `invert_stepwise`, `exp64` and `exp64_stepwise`, the uncertainty, the day's estimate, the
//! monitor model's run start) give the same bits, and the stepwise forms hand their caller
//! back at least as often as their docs say. Fails if a piece is skipped, repeated or put in
//! another order on one side only, or if a stepwise form runs through without pausing.

use std::future::Future;
use std::task::{Context, Poll, Waker};

use shared::actuator::ActuatorRecord;
use shared::conditioning::ConditionReading;
use shared::conditions::TestConditions;
use shared::fdi::OnboardMeasured;
use shared::math::{exp64, exp64_stepwise, invert, invert_stepwise};
use shared::uncertainty::{Curvature, SystematicError};
use shared::{AdcFrame, FaultVector, LowPass, MonitorModel, ShaftAngles};

/// `future` polled to its end: its output and the polls it took.
fn polled<F: Future>(future: F) -> (F::Output, u32) {
    let mut future = Box::pin(future);
    let mut cx = Context::from_waker(Waker::noop());
    let mut polls = 0;
    loop {
        polls += 1;
        if let Poll::Ready(out) = future.as_mut().poll(&mut cx) {
            return (out, polls);
        }
    }
}

/// A regular 9 × 9 matrix with no zero below its diagonal (every row is eliminated).
fn matrix() -> [[f64; 9]; 9] {
    core::array::from_fn(|i| {
        core::array::from_fn(|j| {
            let (i, j) = (i as f64, j as f64);
            if i == j {
                10.0 + i
            } else {
                1.0 / (1.0 + i + 2.0 * j)
            }
        })
    })
}

#[test]
fn the_inverse_in_steps_is_the_inverse() {
    let m = matrix();
    let (stepped, polls) = polled(invert_stepwise(&m));
    let whole = invert(&m).expect("regular");
    assert_eq!(
        format!("{:?}", stepped.expect("regular")),
        format!("{whole:?}")
    );
    // Two pauses first, then per column: the pivot, four quarters of its division and eight
    // eliminations.
    assert!(polls > 2 + 9 * (1 + 4 + 8), "{polls} polls");
    let singular = [[1.0, 2.0], [2.0, 4.0]];
    assert!(polled(invert_stepwise(&singular)).0.is_none());
    assert!(invert(&singular).is_none());
}

#[test]
fn the_exponential_in_steps_is_the_exponential() {
    for x in [-700.0, -3.7, -1e-9, 0.0, 0.25, 1.0, 7.3, 700.0, 800.0] {
        let (stepped, polls) = polled(exp64_stepwise(x));
        assert_eq!(stepped.to_bits(), exp64(x).to_bits(), "e^{x}");
        assert_eq!(polls, 3);
    }
    assert!(polled(exp64_stepwise(f64::NAN)).0.is_nan());
}

#[test]
fn the_uncertainty_in_steps_is_the_uncertainty() {
    let mut normal = matrix();
    normal[3][3] = 0.0; // one component undetermined
    let curvature = Curvature {
        normal,
        rss: 0.8,
        gradient: [0.0; 9],
        fitted: 500,
    };
    let k = FaultVector::saturating([0.1, 0.0, 0.2, 0.0, 0.0, 0.3, 0.6, 0.5, 0.0]);
    let systematic = SystematicError::NONE;
    let (stepped, polls) = polled(curvature.uncertainty_stepwise(&k, &systematic));
    let whole = curvature.uncertainty(&k);
    assert_eq!(format!("{stepped:?}"), format!("{whole:?}"));
    assert!(whole.is_ok());
    // The inverse's polls, then one per deviation and per correlation of the 8 determined.
    assert!(polls > 8 + 8 * 8, "{polls} polls");
}

#[test]
fn the_day_in_steps_is_the_day() {
    let record = ActuatorRecord::REFERENCE;
    let mut measured = OnboardMeasured::ZEROED;
    measured.set_filter(LowPass::for_control_period(record.params.control_period).unwrap());
    measured.clear_for(record.test);
    // A cold day read by the thermistor (a friction factor and slope of its own), a current
    // that moves.
    for i in 0..2_000 {
        let t = i as f32 * 1e-4;
        let mut frame = AdcFrame::from_f32([(30.0 * t).sin(), -(30.0 * t).sin(), 0.0], 0.0, 0.0);
        frame.conditions = Some(ConditionReading::from_f64(270.0, -25.0));
        measured
            .push_frame(frame, record.params.pole_pairs)
            .unwrap();
    }
    let (stepped, polls) = polled(TestConditions::estimate_stepwise(
        &measured,
        &record.params,
        &record.calibration,
    ));
    let whole = TestConditions::estimate(&measured, &record.params, &record.calibration);
    assert_eq!(format!("{stepped:?}"), format!("{whole:?}"));
    // Five pauses between its pieces, and the grease fit's own.
    assert!(polls > 5, "{polls} polls");
    assert!(
        whole.friction_scale > 1.0 && whole.friction_slope > 0.0,
        "{whole:?}"
    );
}

#[test]
fn a_loaded_run_started_in_steps_is_the_same_run() {
    let record = ActuatorRecord::REFERENCE;
    let model = MonitorModel::new(record.params, &record.calibration).with_test(&record.test);
    assert!(
        model.lead_samples() > 0,
        "the test has a standstill segment"
    );
    // An eccentricity: every bin of the torque table differs.
    let k = FaultVector::saturating([0.2, 0.1, 0.3, 0.0, 0.0, 0.4, 0.3, 0.5, 0.1]);
    let start = ShaftAngles::ZERO;
    let (stepped, polls) = polled(model.start_loaded_run_stepwise(&k, start, 50.0, 0.001));
    let (whole_model, mut whole) = model.start_loaded_run(&k, start, 50.0, 0.001);
    let (stepped_model, mut stepped) = stepped;
    // The preflight's test has a standstill segment: three pairs, then twelve slices of bins.
    assert!(polls > 3 + 12, "{polls} polls");
    for _ in 0..300 {
        let a = whole.next_sample(&whole_model, 0.001);
        let b = stepped.next_sample(&stepped_model, 0.001);
        assert_eq!(a.current.to_bits(), b.current.to_bits());
        assert_eq!(a.motor_angle.to_bits(), b.motor_angle.to_bits());
    }
}
