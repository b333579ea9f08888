//! Unit tests of [`super`] (`window`).

use super::*;
use crate::base::math::invert;

/// The load's response read from a window's curvature moves a load whose moment is off
/// most of the way back, and lowers the fit: a window recorded from the monitor model
/// (the controller's gain halved, friction 0.1) under a spring carrying 120 N·m, the
/// problem under the same spring carrying 124 N·m, the faults not moved; then a step of
/// the gain alone, the load moved with it, fits better than the load left where it is.
#[test]
fn the_polish_moves_the_load_with_the_faults() {
    use crate::preflight::actuator::ActuatorRecord;
    use crate::preflight::fdi::{OnboardMeasured, TEST_SAMPLES};
    let record = ActuatorRecord::REFERENCE;
    let test = record.test.chirp_only();
    let model = MonitorModel::new(
        record.params,
        &crate::Calibration::reference_actuator(&test),
    )
    .with_test(&test);
    let period = record.params.control_period;
    let sampler = model.sampler();
    let command: std::vec::Vec<f32> = (0..TEST_SAMPLES)
        .map(|i| synthetic_command(&sampler, 1.0e-3, period, i))
        .collect();
    let mut genes = *FaultVector::NOMINAL.as_array();
    (genes[0], genes[7]) = (0.1, 0.0);
    let truth = FaultVector::new(genes).unwrap();
    let stiffness = 1.4 * record.params.aero_stiffness;
    let load = WindowLoad::spring(stiffness, 120.0);
    let mut measured = std::boxed::Box::new(OnboardMeasured::ZEROED);
    measured.set_filter(LowPass::for_control_period(period).unwrap());
    measured.clear_for(test);
    let full = RecordedCommand::new(&command);
    record_monitor_window(
        &model,
        &truth,
        &load,
        &full,
        TEST_SAMPLES,
        0.3,
        &mut measured,
    )
    .unwrap();
    let kept: std::vec::Vec<f32> = command.iter().step_by(COMMAND_STRIDE).copied().collect();
    // The fit is sharp in the moment (where the gear reverses): a few N·m off.
    let off = WindowLoad::spring(stiffness, 124.0);
    let problem = WindowProblem::new(
        &measured,
        RecordedCommand::kept_every(COMMAND_STRIDE, &kept),
        model,
        off,
    )
    .unwrap();

    let (_, response, _) = run_to_end(problem.curvature_and_load_stepwise(&truth, off));
    let moved = run_to_end(response.step_stepwise(off, &truth, &truth));
    assert!(
        (moved.moment - 120.0).abs() < 0.6 * 4.0,
        "moment moved to {}",
        moved.moment
    );
    assert!(
        (moved.stiffness / stiffness - 1.0).abs() < 0.01,
        "{moved:?}"
    );
    assert!(
        problem.evaluate_under(&truth, moved).error
            < 0.5 * problem.evaluate_under(&truth, off).error
    );

    // From the gain read 0.06 under the load best for it, the step to the true gain
    // with the load moved fits better than the step alone.
    let mut high = genes;
    high[7] = 0.06;
    let high = FaultVector::new(high).unwrap();
    let (fitted, _) = problem.fit_load(&high, stiffness);
    let mut at_high = problem.clone();
    at_high.set_load(fitted);
    let (_, response, _) = run_to_end(at_high.curvature_and_load_stepwise(&high, fitted));
    let stepped = run_to_end(response.step_stepwise(fitted, &high, &truth));
    let with_load = at_high.evaluate_under(&truth, stepped).error;
    let without = at_high.evaluate_under(&truth, fitted).error;
    assert!(with_load < without, "{with_load} against {without}");
}

#[test]
fn recorded_command_holds_its_last_sample() {
    let samples = [1.0f32, 2.0, 3.0];
    let c = RecordedCommand::new(&samples);
    assert_eq!(c.position_at(1), 2.0);
    assert_eq!(c.position_at(7), 3.0);
    assert_eq!(RecordedCommand::new(&[]).position_at(0), 0.0);
    assert_eq!((c.len(), RecordedCommand::new(&[]).len()), (3, 0));
}

/// A command kept every fourth sample is exact at the kept samples, on the line between
/// them, holds its last value past them, spans up to its last kept sample; keeping a
/// chirp-like command every fourth sample departs from it by less than its bound.
#[test]
fn a_command_kept_every_fourth_sample() {
    let kept = [0.0f32, 4.0, 2.0];
    let c = RecordedCommand::kept_every(4, &kept);
    let at: [f32; 11] = core::array::from_fn(|i| c.position_at(i));
    assert_eq!(at, [0.0, 1.0, 2.0, 3.0, 4.0, 3.5, 3.0, 2.5, 2.0, 2.0, 2.0]);
    assert_eq!(c.len(), 9);
    // 15 Hz at 5 mrad sampled at 10 kHz: within 1 µrad of the full command.
    let full: [f32; 2000] = core::array::from_fn(|i| {
        5e-3 * crate::base::math::sin(2.0 * core::f32::consts::PI * 15.0 * i as f32 * 1e-4)
    });
    let mut store = [0.0f32; 500];
    for (slot, &x) in store.iter_mut().zip(full.iter().step_by(COMMAND_STRIDE)) {
        *slot = x;
    }
    let c = RecordedCommand::kept_every(COMMAND_STRIDE, &store);
    assert_eq!(c.len(), 1997);
    let worst = (0..c.len()).fold(0.0f32, |m, i| m.max((c.position_at(i) - full[i]).abs()));
    assert!(worst < 1.0e-6, "{worst}");
}

/// A window's model is the chirp-only test's: one with the preflight's standstill segment
/// is refused (its evaluation steps the motion only), the same model without it is not.
#[test]
fn a_model_with_a_standstill_segment_is_refused() {
    use crate::preflight::actuator::ActuatorRecord;
    use crate::preflight::fdi::OnboardMeasured;
    let record = ActuatorRecord::REFERENCE;
    let calibration = crate::Calibration::reference_actuator(&record.test);
    let with_segment = MonitorModel::new(record.params, &calibration).with_test(&record.test);
    assert!(with_segment.lead_samples() > 0);
    let chirp = record.test.chirp_only();
    let chirp_model = MonitorModel::new(record.params, &calibration).with_test(&chirp);
    let period = record.params.control_period;
    let sampler = chirp_model.sampler();
    let command: std::vec::Vec<f32> = (0..2000)
        .map(|i| synthetic_command(&sampler, 1.0e-3, period, i))
        .collect();
    let mut measured = std::boxed::Box::new(OnboardMeasured::ZEROED);
    measured.set_filter(LowPass::for_control_period(period).unwrap());
    measured.clear_for(chirp);
    let load = WindowLoad::spring(record.params.aero_stiffness, 0.0);
    let full = RecordedCommand::new(&command);
    record_monitor_window(
        &chirp_model,
        &FaultVector::NOMINAL,
        &load,
        &full,
        command.len(),
        0.3,
        &mut measured,
    )
    .unwrap();
    assert!(matches!(
        WindowProblem::new(&measured, full, with_segment, load),
        Err(WindowError::Standstill)
    ));
    assert!(WindowProblem::new(&measured, full, chirp_model, load).is_ok());
}

/// A loaded start is an equilibrium: under a steady command the model holds the moment
/// with a steady current and the shafts do not move; the same start without the moment
/// gives no current. Fails if the start's gear flank, surface angle, current or
/// integrators disagree with each other.
#[test]
fn a_loaded_start_holds_still() {
    use crate::physics::params::ActuatorParams;
    use crate::{Calibration, ShaftAngles};
    let params = ActuatorParams::REFERENCE;
    let model =
        MonitorModel::new(params, &Calibration::REFERENCE_ACTUATOR).with_load_stiffness(6.5e4);
    let start = ShaftAngles {
        motor: 1.3,
        user: 2.0e-3,
        currents: [0.0; 3],
    };
    for (moment, backlash) in [(150.0f32, 0.0f32), (-80.0, 0.4), (0.0, 0.0)] {
        let mut genes = *FaultVector::NOMINAL.as_array();
        genes[1] = backlash;
        let k = FaultVector::saturating(genes);
        let (m, mut run) = model.start_loaded_run(&k, start, moment, start.user);
        let first = run.next_sample(&m, start.user);
        let held = moment / (params.gear_ratio * model.torque_constant());
        assert!(
            (first.current - held).abs() < 0.02 * held.abs() + 1e-6,
            "{moment}: {first:?}"
        );
        let mut last = first;
        for _ in 0..2000 {
            last = run.next_sample(&m, start.user);
        }
        assert!(
            (last.current - first.current).abs() < 0.01 * held.abs() + 1e-3,
            "{moment}: {last:?}"
        );
        assert!(
            (last.user_angle - start.user).abs() < 1e-6,
            "{moment}: {last:?}"
        );
        assert!(
            (last.motor_angle - start.motor).abs() < 1e-4,
            "{moment}: {last:?}"
        );
    }
}

/// The recurrence gives Legendre's closed forms (P2 … P5 at a few points).
#[test]
fn legendre_polynomials() {
    for x in [-1.0f32, -0.3, 0.0, 0.55, 1.0] {
        let p = legendre(x);
        let x2 = x * x;
        let closed = [
            1.0,
            x,
            1.5 * x2 - 0.5,
            x * (2.5 * x2 - 1.5),
            (35.0 * x2 * x2 - 30.0 * x2 + 3.0) / 8.0,
            x * (63.0 * x2 * x2 - 70.0 * x2 + 15.0) / 8.0,
        ];
        for (a, b) in p.iter().zip(&closed) {
            assert!((a - b).abs() < 1e-5, "x {x}: {a} vs {b}");
        }
    }
}

/// The second-order expansion about a block's centre gives every polynomial within
/// 10⁻⁴ across the block, anywhere on the axis (the trend's moment and the projections
/// rest on it); fails if a derivative's recurrence is off.
#[test]
#[allow(clippy::needless_range_loop)] // three arrays read at one index
fn a_blocks_expansion_gives_the_polynomials() {
    let step = axis_step(5520);
    let half = 0.5 * (DRIFT_BLOCK - 1) as f32 * step;
    for centre in [-1.0 + half, -0.62, 0.0, 0.37, 1.0 - half] {
        let b = TaylorBlock::at(centre);
        for u in [-half, -0.3 * half, 0.0, 0.8 * half, half] {
            let exact = legendre(centre + u);
            for j in 0..DRIFT_TERMS {
                let t = b.value[j] + u * b.slope[j] + 0.5 * u * u * b.bend[j];
                assert!(
                    (t - exact[j]).abs() < 1e-4,
                    "x {centre}+{u}, P{j}: {t} vs {}",
                    exact[j]
                );
            }
        }
    }
    // The derivatives' closed forms at one point: P2′ = 3x, P3″ = 15x.
    let b = TaylorBlock::at(0.4);
    assert!(
        (b.slope[2] - 1.2).abs() < 1e-5 && (b.bend[3] - 6.0).abs() < 1e-5,
        "{b:?}"
    );
}

/// A block closed and the next opened in one pass gives, bit for bit, what the projections'
/// sums, the polynomials' recurrences and the trend's three dot products give taken apart.
#[test]
fn opening_a_block_in_one_pass_keeps_the_bits_of_its_parts() {
    let trend = [0.3, -1.7, 0.02, 4.0, -0.6, 0.0, 2.5e-3, -8.0, 0.9, 1.1];
    let sums = (0.31, -2.4e-3, 7.7e-5);
    let mut one_pass = ResidualSums::new(&trend);
    for (k, x) in [-0.991f32, -0.62, 0.0, 0.37, 0.9973]
        .into_iter()
        .enumerate()
    {
        let closed = one_pass.block;
        let mut projections = one_pass.projections;
        let moment = one_pass.next_block(sums, x, &trend);

        closed.add_to(&mut projections, sums);
        let value = legendre(x);
        let (mut slope, mut bend) = ([0.0f32; DRIFT_TERMS], [0.0f32; DRIFT_TERMS]);
        slope[1] = 1.0;
        for n in 1..DRIFT_TERMS - 1 {
            let f = (2 * n + 1) as f32;
            slope[n + 1] = slope[n - 1] + f * value[n];
            bend[n + 1] = bend[n - 1] + f * slope[n];
        }
        let parts = (
            dot(&trend, &value) - one_pass.at_start,
            dot(&trend, &slope),
            0.5 * dot(&trend, &bend),
        );
        let bits = |a: &[f32]| a.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&one_pass.projections), bits(&projections), "block {k}");
        assert_eq!(bits(&one_pass.block.value), bits(&value), "block {k}");
        assert_eq!(bits(&one_pass.block.slope), bits(&slope), "block {k}");
        assert_eq!(bits(&one_pass.block.bend), bits(&bend), "block {k}");
        assert_eq!(
            bits(&[moment.0, moment.1, moment.2]),
            bits(&[parts.0, parts.1, parts.2]),
            "block {k}"
        );
    }
}

#[test]
fn golden_finds_a_parabolas_minimum() {
    let mut search = GoldenSearch::new((-3.0, 5.0));
    let mut asked = 0;
    while let Some(x) = search.ask() {
        search.tell((x - 1.25) * (x - 1.25) + 2.0);
        asked += 1;
    }
    assert_eq!(asked, GOLDEN_STEPS);
    let (x, fx) = search.best();
    assert!((x - 1.25).abs() < 0.03, "{x}");
    assert!((fx - 2.0).abs() < 1e-3);
}

#[test]
#[allow(clippy::needless_range_loop)] // a matrix product written as one
fn inverse_of_a_gram_matrix() {
    // A symmetric, diagonally dominant matrix: the Gram matrix's kind.
    let m: [[f64; DRIFT_TERMS]; DRIFT_TERMS] = core::array::from_fn(|i| {
        core::array::from_fn(|j| {
            if i == j {
                4.0 + i as f64
            } else {
                0.3 / (1.0 + (i + j) as f64)
            }
        })
    });
    let inv = invert(&m).expect("regular");
    for i in 0..DRIFT_TERMS {
        for j in 0..DRIFT_TERMS {
            let x: f64 = (0..DRIFT_TERMS).map(|k| m[i][k] * inv[k][j]).sum();
            let want = if i == j { 1.0 } else { 0.0 };
            assert!((x - want).abs() < 1e-5, "{i},{j}: {x}");
        }
    }
    assert!(invert(&[[0.0; DRIFT_TERMS]; DRIFT_TERMS]).is_none());
}

/// What a flight's windows hold of a preflight: nothing when it was not trusted; its shorts,
/// eccentricity and demagnetization with the covariance of its deviations (each
/// `HELD_ERROR_SCALE` times) and correlations when it was; the friction's deviation without
/// the day's healthy friction's share, in quadrature.
#[test]
fn a_preflight_reading_is_held_with_its_covariance_less_the_days_friction() {
    let mut k = *FaultVector::NOMINAL.as_array();
    (k[0], k[2]) = (0.3, 0.2);
    let k = FaultVector::new(k).unwrap();
    let std = [0.05, 0.01, 0.02, 0.02, 0.02, 0.03, f32::NAN, 0.04, 0.01];
    let mut correlation = [[0.0f32; FAULT_COUNT]; FAULT_COUNT];
    for (i, row) in correlation.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    (correlation[0][2], correlation[2][0]) = (0.5, 0.5);
    let untrusted =
        HeldComponents::from_preflight_reading(&k, false, Some((&std, &correlation)), 0.0);
    assert_eq!(untrusted, HeldComponents::NONE);
    let plain = HeldComponents::from_preflight_reading(&k, true, Some((&std, &correlation)), 0.0);
    assert!(plain.holds(2) && !plain.holds(0));
    let c = plain.covariance();
    let s = |i: usize, sd: f32| sd * HELD_ERROR_SCALE[i];
    assert!((c[2][2] - s(2, 0.02).powi(2)).abs() < 1e-9, "{}", c[2][2]);
    assert!((c[0][2] - 0.5 * s(0, 0.05) * s(2, 0.02)).abs() < 1e-9);
    assert_eq!(c[6][6], 0.0, "an undetermined deviation counts as none");
    // The day's healthy friction's share (0.03 of the friction's 0.05) leaves 0.04.
    let less = HeldComponents::from_preflight_reading(&k, true, Some((&std, &correlation)), 0.03);
    let c = less.covariance();
    assert!((c[0][0] - s(0, 0.04).powi(2)).abs() < 1e-8, "{}", c[0][0]);
    assert!((c[0][2] - 0.5 * s(0, 0.04) * s(2, 0.02)).abs() < 1e-8);
    assert_eq!(c[2][2], plain.covariance()[2][2]);
    // Without its uncertainty, the values alone.
    let bare = HeldComponents::from_preflight_reading(&k, true, None, 0.03);
    assert_eq!(bare, HeldComponents::of_preflight(&k));
}
