//! The monitor model behaves the way physics says, for each fault alone, and never blows up.

use proptest::prelude::*;
use shared::conditioning::commutation_sector;
use shared::monitor::MonitorSample;
use shared::{ActuatorParams, Calibration, FaultVector, MonitorModel};

const N: usize = 5000;

fn model() -> MonitorModel {
    MonitorModel::new(ActuatorParams::REFERENCE, &Calibration::IDENTITY)
}

fn run(k: [f32; 9]) -> Vec<MonitorSample> {
    let mut out = Vec::with_capacity(N);
    model().run(&FaultVector::new(k).unwrap(), N, |s| out.push(*s));
    out
}

fn with(index: usize, value: f32) -> [f32; 9] {
    let mut k = *FaultVector::NOMINAL.as_array();
    k[index] = value;
    k
}

fn current_rms(trace: &[MonitorSample]) -> f32 {
    (trace.iter().map(|s| s.current * s.current).sum::<f32>() / trace.len() as f32).sqrt()
}

/// RMS tracking error relative to the RMS command, over samples `range`.
fn tracking_error(trace: &[MonitorSample], range: std::ops::Range<usize>) -> f32 {
    let t = &trace[range];
    let e: f32 = t.iter().map(|s| (s.command - s.user_angle).powi(2)).sum();
    let c: f32 = t.iter().map(|s| s.command.powi(2)).sum();
    (e / c).sqrt()
}

#[test]
fn nominal_run_tracks_the_chirp() {
    let t = run(*FaultVector::NOMINAL.as_array());
    // First half (0 → 7.5 Hz, 4 × below the position bandwidth): close tracking.
    let low = tracking_error(&t, 0..N / 2);
    // Whole chirp (up to 15 Hz): the lag grows but the actuator follows.
    let all = tracking_error(&t, 0..N);
    assert!(low < 0.15, "low-frequency tracking error {low}");
    assert!(all < 0.35, "whole-chirp tracking error {all}");
    let peak = t.iter().map(|s| s.user_angle.abs()).fold(0.0, f32::max);
    assert!(
        (0.8 * 5e-3..1.2 * 5e-3).contains(&peak),
        "peak user angle {peak}"
    );
    // Currents well above ripple and noise, yet below the drive's limit.
    let rms = current_rms(&t);
    assert!((0.5..10.0).contains(&rms), "current rms {rms}");
    assert!(t
        .iter()
        .all(|s| s.current.abs() < ActuatorParams::REFERENCE.max_current));
}

#[test]
fn more_friction_draws_more_current() {
    let r: Vec<f32> = [0.0, 0.5, 1.0]
        .iter()
        .map(|&k| current_rms(&run(with(0, k))))
        .collect();
    assert!(r[0] < r[1] && r[1] < r[2], "{r:?}");
}

#[test]
fn lower_proportional_gain_tracks_worse() {
    let e: Vec<f32> = [0.0, 0.5, 1.0]
        .iter()
        .map(|&k| tracking_error(&run(with(7, k)), 0..N))
        .collect();
    assert!(e[0] > e[1] && e[1] > e[2], "{e:?}");
}

#[test]
fn more_backlash_lets_the_surface_lag_and_draws_more_current() {
    let traces: Vec<_> = [0.0, 0.5, 1.0].iter().map(|&k| run(with(1, k))).collect();
    let e: Vec<f32> = traces.iter().map(|t| tracking_error(t, 0..N)).collect();
    let r: Vec<f32> = traces.iter().map(|t| current_rms(t)).collect();
    assert!(e[0] < e[2], "{e:?}");
    assert!(r[0] < r[1] && r[1] < r[2], "{r:?}");
}

/// Mean |current| in the sectors where phase A conducts divided by the mean where it floats.
fn phase_a_current_ratio(trace: &[MonitorSample]) -> f32 {
    let p = ActuatorParams::REFERENCE.pole_pairs;
    let (mut on, mut n_on, mut off, mut n_off) = (0.0, 0, 0.0, 0);
    for s in &trace[N / 5..] {
        if commutation_sector(p * s.motor_angle) % 3 == 0 {
            off += s.current.abs();
            n_off += 1;
        } else {
            on += s.current.abs();
            n_on += 1;
        }
    }
    (on / n_on as f32) / (off / n_off as f32)
}

#[test]
fn short_circuit_of_a_phase_needs_more_current_while_that_phase_conducts() {
    // Fewer healthy turns → less torque per ampere while phase A conducts → the speed loop
    // asks for more current in exactly those sectors.
    let healthy = phase_a_current_ratio(&run(with(2, 0.0)));
    let shorted = phase_a_current_ratio(&run(with(2, 0.5)));
    assert!(
        shorted > healthy * 1.1,
        "healthy {healthy}, shorted {shorted}"
    );
}

#[test]
fn eccentricity_raises_current_where_the_gap_weakens_the_coupling() {
    // Matched shape (per-phase air-gap permeance under each phase's coils): with φ = 0 the
    // smallest gap faces phase A's coils, so the pairs with A conducting couple more strongly
    // and those without A (sectors 0 and 3: B and C conduct, away from the small gap) less.
    // Where the coupling is weaker the speed loop needs more current.
    let p = ActuatorParams::REFERENCE.pole_pairs;
    let nominal = run(with(5, 0.0));
    let faulty = run(with(5, 0.5));
    let (mut weak, mut n_weak, mut strong, mut n_strong) = (0.0, 0, 0.0, 0);
    for (a, b) in nominal.iter().zip(&faulty).skip(N / 5) {
        if a.current.abs() < 0.3 {
            continue;
        }
        let ratio = b.current.abs() / a.current.abs();
        if commutation_sector(p * b.motor_angle) % 3 == 0 {
            weak += ratio;
            n_weak += 1;
        } else {
            strong += ratio;
            n_strong += 1;
        }
    }
    let (weak, strong) = (weak / n_weak as f32, strong / n_strong as f32);
    assert!(
        weak > strong * 1.1,
        "weak-gap ratio {weak}, strong-gap ratio {strong}"
    );
}

#[test]
fn same_fault_vector_same_bits() {
    let k = [0.3, 0.2, 0.1, 0.0, 0.4, 0.6, 0.9, 0.2, 0.0];
    let a: Vec<u32> = run(k).iter().map(|s| s.current.to_bits()).collect();
    let b: Vec<u32> = run(k).iter().map(|s| s.current.to_bits()).collect();
    assert_eq!(a, b);
}

#[test]
fn simulate_matches_run() {
    let k = FaultVector::new([0.3, 0.2, 0.1, 0.0, 0.4, 0.6, 0.9, 0.2, 0.0]).unwrap();
    let mut out = [0.0f32; 1234];
    model().simulate(&k, &mut out);
    let mut via_run = Vec::new();
    model().run(&k, out.len(), |s| via_run.push(s.current));
    assert_eq!(out.to_vec(), via_run);
    assert_eq!(model().test_samples(), N);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn every_fault_vector_simulates_finitely(k in prop::array::uniform9(0.0f32..=1.0)) {
        let trace = run(k);
        for s in &trace {
            prop_assert!(s.current.is_finite() && s.motor_angle.is_finite() && s.user_angle.is_finite());
            prop_assert!(s.current.abs() <= 100.0, "current {}", s.current);
            prop_assert!(s.user_angle.abs() < 0.1, "user angle {}", s.user_angle);
        }
    }
}

#[test]
fn corner_fault_vectors_simulate_finitely() {
    for bits in 0u32..512 {
        let k: [f32; 9] = std::array::from_fn(|i| if bits >> i & 1 == 1 { 1.0 } else { 0.0 });
        for s in run(k) {
            assert!(s.current.is_finite() && s.motor_angle.is_finite(), "{k:?}");
        }
    }
}

#[test]
fn a_run_starts_where_the_measured_test_began_with_the_gear_relaxed() {
    use shared::ShaftAngles;
    let m = model();
    let ratio = ActuatorParams::REFERENCE.gear_ratio;
    // Large play (k2 = 1: ±5e-4 rad): the motor at 1e-4 rad (user side) leaves the surface at
    // its load's rest inside the play, so all of the measured 3e-5 rad is transducer offset.
    let start = ShaftAngles {
        motor: 1.0e-4 * ratio,
        user: 3.0e-5,
        currents: [0.0; 3],
    };
    let mut first = None;
    m.run_from(&FaultVector::new(with(1, 1.0)).unwrap(), start, 1, |s| {
        first = Some(*s)
    });
    let first = first.unwrap();
    assert_eq!(first.motor_angle, start.motor);
    assert_eq!(
        first.user_angle, start.user,
        "the transducer reads what was measured"
    );
    // With the nominal play (±5e-6 rad) the surface must sit within the play of the motor,
    // not at the measured 3e-5 rad: taken literally, that would start the gear compressed by
    // 6e-5 rad (600 N·m) and launch the surface by ~6e-4 rad within 2 ms. Relaxed, it only
    // moves as the controller drives it (a few µrad).
    let mut trace = Vec::new();
    m.run_from(&FaultVector::NOMINAL, start, 20, |s| trace.push(*s));
    assert!((trace[0].user_angle - start.user).abs() < 1.0e-10);
    let jump = (trace[19].user_angle - trace[0].user_angle).abs();
    assert!(jump < 5.0e-5, "surface moved {jump} rad in 2 ms");
    // From zero, `run_from` is `run`.
    let mut a = Vec::new();
    let mut b = Vec::new();
    m.run(&FaultVector::NOMINAL, 500, |s| a.push(s.current));
    m.run_from(&FaultVector::NOMINAL, ShaftAngles::ZERO, 500, |s| {
        b.push(s.current)
    });
    assert_eq!(a, b);
}

/// The day's healthy friction as a nuisance (`MonitorModel::with_friction_floor`): a floor of
/// 1 plays the fault vector bit for bit; below it, the solver's vector that reads as a
/// fault plays the same torque as that fault at the day's friction, and a solver's friction
/// below the healthy point reads as no fault with the healthy friction below the estimate.
#[test]
fn the_healthy_friction_below_the_days_estimate_is_a_nuisance_not_a_fault() {
    let k = FaultVector::new(with(0, 0.3)).unwrap();
    let mut plain = Vec::new();
    model().run(&k, 2000, |s| plain.push(s.current.to_bits()));
    let mut floor_one = Vec::new();
    model()
        .with_friction_floor(1.0)
        .run(&k, 2000, |s| floor_one.push(s.current.to_bits()));
    assert_eq!(plain, floor_one);

    let m = model().with_friction_floor(0.6);
    assert_eq!(m.friction_floor(), 0.6);
    let solver = m.solver_vector(&k);
    assert!((m.reading(&solver).friction() - 0.3).abs() < 1e-6);
    let mut floored = Vec::new();
    m.run(&solver, 2000, |s| floored.push(s.current));
    let worst = plain
        .iter()
        .zip(&floored)
        .map(|(a, b)| (f32::from_bits(*a) - b).abs())
        .fold(0.0f32, f32::max);
    assert!(worst < 1e-3, "{worst}");
    // The healthy point reads healthy at the estimate; below it, healthy at less.
    let healthy = m.solver_vector(&FaultVector::NOMINAL);
    assert_eq!(m.reading(&healthy).friction(), 0.0);
    assert!((m.healthy_friction_read(&healthy) - 1.0).abs() < 1e-6);
    let mut low = *healthy.as_array();
    low[0] = 0.0;
    let low = FaultVector::new(low).unwrap();
    assert_eq!(m.reading(&low).friction(), 0.0);
    assert!((m.healthy_friction_read(&low) - 0.6).abs() < 1e-6);
    assert!((m.reading_scale() - 1.2).abs() < 1e-6);
}

/// A drive that slews to its current reference's steps (`with_reference_steps`) draws more
/// current in the direction of motion, the less the higher its bus (a drag `∝ power/V²`),
/// and none without steps.
#[test]
fn reference_steps_draw_current_in_the_direction_of_motion_less_on_a_higher_bus() {
    let excess = |params: ActuatorParams, power: f32| -> f32 {
        let base = MonitorModel::new(params, &Calibration::IDENTITY);
        let k = FaultVector::NOMINAL;
        let mut quiet = Vec::with_capacity(N);
        base.run(&k, N, |s| quiet.push(*s));
        let mut stepped = Vec::with_capacity(N);
        base.with_reference_steps(power)
            .run(&k, N, |s| stepped.push(*s));
        // The current's excess, signed by the motor's direction, averaged.
        quiet
            .windows(2)
            .zip(&stepped[1..])
            .map(|(q, s)| {
                (s.current - q[1].current) * (q[1].motor_angle - q[0].motor_angle).signum()
            })
            .sum::<f32>()
            / (N - 1) as f32
    };
    let nominal = ActuatorParams::REFERENCE;
    let doubled = ActuatorParams {
        dc_bus_voltage: 2.0 * nominal.dc_bus_voltage,
        ..nominal
    };
    let at_nominal = excess(nominal, 2.0);
    let at_doubled = excess(doubled, 2.0);
    assert!(
        at_nominal > 0.0,
        "excess in the direction of motion {at_nominal} A"
    );
    // A quarter of it at twice the bus: the loops answer a small drag linearly.
    let ratio = at_doubled / at_nominal;
    assert!(
        (0.15..0.35).contains(&ratio),
        "twice the bus: {ratio} of the excess"
    );
    let model = model();
    assert_eq!(model.with_reference_steps(0.0), model);
    // No bus: no shortfall to play, rather than a NaN drag.
    let unpowered = MonitorModel::new(
        ActuatorParams {
            dc_bus_voltage: 0.0,
            ..nominal
        },
        &Calibration::IDENTITY,
    );
    assert_eq!(unpowered.with_reference_steps(2.0), unpowered);
}
