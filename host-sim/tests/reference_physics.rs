//! The reference model behaves like the actuator it stands for: it tracks the chirp, each
//! fault alone moves the equivalent current the way physics says, energy is conserved, signs
//! are right, and a seed fixes every bit.

use host_sim::plant::reference::{ReferenceModel, ReferenceSettings, Scenario, Simulation};
use shared::conditioning::commutation_signs;
use shared::test_design::PreflightTest;
use shared::FaultVector;

/// The paper's test: these checks are about the chirp (the standstill segment has its own
/// in `test_designs.rs`).
fn rm() -> ReferenceModel {
    ReferenceModel::new(ReferenceSettings::REFERENCE).with_test(PreflightTest::PAPER)
}

fn run(k: [f32; 9]) -> Simulation {
    rm().simulate(&Scenario::new(
        FaultVector::new(k).expect("valid fault vector"),
    ))
}

const HEALTHY: [f32; 9] = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0];

fn with(index: usize, value: f32) -> [f32; 9] {
    let mut k = HEALTHY;
    k[index] = value;
    k
}

/// Equivalent current (two conducting phases, signed) of each truth sample [A].
fn equivalent(sim: &Simulation) -> Vec<f64> {
    sim.truth
        .iter()
        .map(|t| {
            let s = commutation_signs(4.0 * t.motor_angle as f32);
            0.5 * (0..3)
                .map(|x| f64::from(s[x]) * t.phase_currents[x])
                .sum::<f64>()
        })
        .collect()
}

fn rms(v: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x * x, n + 1));
    (s / n as f64).sqrt()
}

/// Relative RMS tracking error of the user shaft over the first `fraction` of the test.
fn tracking_error(sim: &Simulation, fraction: f64) -> f64 {
    let n = (sim.trace.samples().len() as f64 * fraction) as usize;
    let err = rms(sim.trace.samples()[..n]
        .iter()
        .zip(&sim.truth)
        .map(|(s, t)| s.command - t.user_angle));
    err / rms(sim.trace.samples()[..n].iter().map(|s| s.command))
}

#[test]
fn healthy_actuator_tracks_the_chirp() {
    let sim = run(HEALTHY);
    assert_eq!(sim.trace.samples().len(), 5000);
    let first_half = tracking_error(&sim, 0.5);
    let whole = tracking_error(&sim, 1.0);
    assert!(first_half < 0.2, "first half: {first_half}");
    assert!(whole < 0.4, "whole test: {whole}");
    // The motor shaft follows the user shaft through the gear (within the play and twist).
    for t in &sim.truth {
        assert!((t.motor_angle / 500.0 - t.user_angle).abs() < 1e-4, "{t:?}");
    }
}

#[test]
fn floating_neutral_keeps_the_phase_currents_balanced() {
    let sim = run([0.3, 0.2, 0.4, 0.1, 0.0, 0.3, 0.2, 0.7, 0.0]);
    for t in &sim.truth {
        let sum: f64 = t.phase_currents.iter().sum();
        assert!(sum.abs() < 1e-9, "{t:?}");
    }
}

#[test]
fn positive_current_reference_gives_positive_torque() {
    let sim = run(HEALTHY);
    // I_ref(k) is the reference for period k; compare with the torque one period later.
    let pairs: Vec<(f64, f64)> = sim
        .truth
        .windows(2)
        .filter(|w| w[0].current_ref.abs() > 0.5)
        .map(|w| (w[0].current_ref, w[1].motor_torque))
        .collect();
    let agree = pairs
        .iter()
        .filter(|(i, t)| i.signum() == t.signum())
        .count();
    assert!(pairs.len() > 1000);
    assert!(
        agree as f64 > 0.98 * pairs.len() as f64,
        "{agree}/{}",
        pairs.len()
    );
    // And the hysteresis drive holds the conducting current near its reference.
    let eq = equivalent(&sim);
    let mut deviations: Vec<f64> = sim
        .truth
        .iter()
        .zip(eq.iter().skip(1))
        .map(|(t, i)| (t.current_ref - i).abs())
        .collect();
    deviations.sort_by(f64::total_cmp);
    let median = deviations[deviations.len() / 2];
    assert!(median < 0.2, "median |I_ref − i_eq| = {median} A");
}

#[test]
fn energy_is_conserved() {
    for k in [HEALTHY, [0.5, 0.5, 0.3, 0.0, 0.2, 0.4, 0.8, 0.3, 0.0]] {
        let e = run(k).energy;
        eprintln!("{e:?}");
        let electrical = e.copper_loss + e.magnetic + e.converted;
        let rel = (e.electrical_input - electrical).abs() / e.electrical_input;
        assert!(rel < 0.01, "electrical side off by {rel}: {e:?}");
        let rel = (e.converted - e.shaft_work).abs() / e.converted;
        assert!(rel < 0.01, "air gap off by {rel}: {e:?}");
        let mechanical = e.mechanical_loss + e.mechanical_stored + e.contact_release;
        let rel = (e.shaft_work - mechanical).abs() / e.shaft_work;
        assert!(rel < 0.02, "mechanical side off by {rel}: {e:?}");
        assert!(e.copper_loss > 0.0 && e.mechanical_loss > 0.0);
    }
}

#[test]
fn healthy_coupling_is_trapezoidal_and_follows_the_commutation_table() {
    let shapes = rm().coupling_shapes(&FaultVector::NOMINAL);
    let n = shapes[0].len();
    let at = |phase: usize, theta_e_deg: f64| {
        let theta_m = theta_e_deg / 4.0;
        shapes[phase][((theta_m / 360.0).rem_euclid(1.0) * n as f64) as usize % n]
    };
    // In every sector the conducting phases see a flat top of the sign they conduct with.
    for sector in 0..6 {
        let centre = 60.0 * sector as f64;
        let signs = commutation_signs((centre as f32).to_radians());
        for (x, &sign) in signs.iter().enumerate() {
            if sign != 0 {
                let v = at(x, centre);
                assert!(
                    (v - f64::from(sign)).abs() < 1e-9,
                    "phase {x}, {centre}°: {v}"
                );
            }
        }
    }
    // Ramps between flat tops: phase A crosses zero at 0° and 180°.
    assert!(at(0, 0.0).abs() < 0.02 && at(0, 180.0).abs() < 0.02);
}

#[test]
fn eccentricity_strengthens_the_phase_at_the_minimum_air_gap() {
    // k7 = 0.5: the minimum gap faces phase A's coils.
    let shapes = rm().coupling_shapes(&FaultVector::new(with(5, 0.6)).unwrap());
    let mean_abs =
        |p: usize| shapes[p].iter().map(|x| x.abs()).sum::<f64>() / shapes[p].len() as f64;
    let healthy = rm().coupling_shapes(&FaultVector::NOMINAL);
    let healthy_mean = healthy[0].iter().map(|x| x.abs()).sum::<f64>() / healthy[0].len() as f64;
    assert!(mean_abs(0) > 1.1 * healthy_mean, "A {}", mean_abs(0));
    assert!(mean_abs(1) < healthy_mean && mean_abs(2) < healthy_mean);
    // …and, with the minimum gap off the group's centre (k7 = 0.75: 90° away), it varies with
    // rotor angle within phase A's flat top as the magnet edges cross its coils.
    let shapes = rm().coupling_shapes(
        &FaultVector::new({
            let mut k = with(5, 0.6);
            k[6] = 0.75;
            k
        })
        .unwrap(),
    );
    let n = shapes[0].len();
    let flat: Vec<f64> = (0..n)
        .filter(|&j| {
            let deg = (360.0 * 4.0 * j as f64 / n as f64).rem_euclid(360.0);
            (40.0..140.0).contains(&deg)
        })
        .map(|j| shapes[0][j])
        .collect();
    let (lo, hi) = flat
        .iter()
        .fold((f64::MAX, f64::MIN), |(l, h), &x| (l.min(x), h.max(x)));
    assert!(hi - lo > 0.05, "flat top spread {}", hi - lo);
}

/// Mean |i_eq| over the samples whose sector has phase `floating` not conducting (or, with
/// `conducting`, those where it conducts).
fn sector_current(sim: &Simulation, phase: usize, conducting: bool) -> f64 {
    let eq = equivalent(sim);
    let mut sum = 0.0;
    let mut n = 0;
    for (t, i) in sim.truth.iter().zip(&eq) {
        let s = commutation_signs(4.0 * t.motor_angle as f32);
        if (s[phase] != 0) == conducting && t.motor_speed.abs() > 50.0 {
            sum += i.abs();
            n += 1;
        }
    }
    sum / n as f64
}

#[test]
fn each_fault_alone_moves_the_current_as_physics_says() {
    let healthy = run(HEALTHY);
    let healthy_rms = rms(equivalent(&healthy).into_iter());

    // More friction: more current.
    let friction = run(with(0, 1.0));
    assert!(rms(equivalent(&friction).into_iter()) > 1.02 * healthy_rms);

    // More backlash: the user shaft lags more.
    let backlash = run(with(1, 1.0));
    assert!(tracking_error(&backlash, 0.5) > 1.1 * tracking_error(&healthy, 0.5));

    // Short circuit on A: less torque per amp where A conducts → more current there,
    // relative to the sectors where A floats.
    let short = run(with(2, 0.5));
    let ratio = |s: &Simulation| sector_current(s, 0, true) / sector_current(s, 0, false);
    assert!(
        ratio(&short) > 1.1 * ratio(&healthy),
        "{} vs {}",
        ratio(&short),
        ratio(&healthy)
    );

    // Eccentricity with the minimum gap at phase A: more torque per amp where A conducts.
    let ecc = run(with(5, 0.6));
    assert!(
        ratio(&ecc) < 0.95 * ratio(&healthy),
        "{} vs {}",
        ratio(&ecc),
        ratio(&healthy)
    );

    // Gain drift: a lower K_p tracks worse, a higher one better.
    let low = run(with(7, 0.0));
    let high = run(with(7, 1.0));
    assert!(tracking_error(&low, 0.5) > 1.2 * tracking_error(&healthy, 0.5));
    assert!(tracking_error(&high, 0.5) < 0.9 * tracking_error(&healthy, 0.5));
}

#[test]
fn a_seed_fixes_every_bit_and_noise_follows_it() {
    let scenario = |seed, noise| Scenario {
        faults: FaultVector::new([0.2, 0.3, 0.1, 0.0, 0.0, 0.2, 0.3, 0.6, 0.0]).unwrap(),
        current_ref_noise: noise,
        seed,
    };
    let a = rm().simulate(&scenario(7, 0.5));
    let b = rm().simulate(&scenario(7, 0.5));
    assert_eq!(a, b);
    let c = rm().simulate(&scenario(8, 0.5));
    assert_ne!(a.trace, c.trace);
    // Process noise at 50 % of the nominal I_ref RMS moves I_ref well beyond sensor noise.
    let quiet = rm().simulate(&scenario(7, 0.0));
    let diff = rms(a
        .truth
        .iter()
        .zip(&quiet.truth)
        .map(|(x, y)| x.current_ref - y.current_ref));
    let nominal = rm().nominal_current_ref_rms();
    assert!(
        diff > 0.2 * nominal && diff < 1.5 * nominal,
        "diff {diff}, nominal {nominal}"
    );
}

#[test]
fn every_corner_of_the_fault_space_simulates_finitely() {
    for corner in [
        [1.0f32; 9],
        [0.0; 9],
        [1.0, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0],
    ] {
        let sim = run(corner);
        for s in sim.trace.samples() {
            assert!(s.phase_currents.iter().all(|x| x.is_finite()));
            assert!(s.motor_angle.is_finite() && s.user_angle.is_finite());
        }
    }
}
