//! Unit tests of [`super`] (`uncertainty`).

use super::*;

fn diagonal(values: [f64; FAULT_COUNT]) -> [[f64; FAULT_COUNT]; FAULT_COUNT] {
    let mut m = [[0.0; FAULT_COUNT]; FAULT_COUNT];
    for i in 0..FAULT_COUNT {
        m[i][i] = values[i];
    }
    m
}

#[test]
fn a_diagonal_curvature_gives_its_standard_deviations() {
    // s² = rss / (n − p) = 8 / (109 − 9) = 0.08; std_i = √(0.08 / d_i).
    let c = Curvature {
        gradient: [0.0; FAULT_COUNT],
        normal: diagonal([8.0, 2.0, 0.5, 8.0, 8.0, 8.0, 8.0, 0.08, 2.0]),
        rss: 8.0,
        fitted: 109,
    };
    let k = FaultVector::new([0.5, 0.5, 0.5, 0.0, 0.0, 0.5, 0.5, 0.5, 0.0]).unwrap();
    let (u, corr) = c.uncertainty(&k).unwrap();
    let expect = [0.1, 0.2, 0.4, 0.1, 0.1, 0.1, 0.1, 1.0, 0.2];
    for i in 0..FAULT_COUNT {
        assert!(
            (u.std[i] - expect[i] * INFLATION).abs() < 1e-6,
            "{i}: {:?}",
            u.std
        );
        assert!((corr[i][i] - 1.0).abs() < 1e-6);
    }
    // The interval is clamped to [0, 1].
    assert!((u.lower[0] - (0.5 - Z90 * 0.1 * INFLATION).max(0.0)).abs() < 1e-6);
    assert!((u.upper[0] - (0.5 + Z90 * 0.1 * INFLATION).min(1.0)).abs() < 1e-6);
    assert_eq!(u.lower[3], 0.0); // clamped
    assert_eq!(u.upper[7], 1.0);
    assert_eq!(u.worst_correlation, 0.0);
    assert!(u.covers(&k).iter().all(|c| *c == Some(true)));
}

#[test]
fn widening_scales_the_deviations_and_redraws_the_intervals() {
    let u = Uncertainty {
        std: [0.01, f32::NAN, 0.2, 0.01, 0.01, 0.01, 0.1, 0.02, 0.01],
        lower: [0.0; FAULT_COUNT],
        upper: [1.0; FAULT_COUNT],
        worst_correlation: 0.3,
        worst_pair: (0, 7),
        residual_std: 0.5,
        magnet_std: f32::NAN,
    };
    let k = FaultVector::new([0.1, 0.0, 0.9, 0.0, 0.0, 0.0, 0.95, 0.5, 0.0]).unwrap();
    let mut factors = [1.0; FAULT_COUNT];
    (factors[0], factors[1], factors[2], factors[6]) = (2.0, 5.0, 3.0, 2.0);
    let w = u.widened(&k, &factors);
    assert_eq!(w.std[0], 0.02);
    assert!((w.lower[0] - (0.1 - Z90 * 0.02)).abs() < 1e-6);
    assert!((w.upper[0] - (0.1 + Z90 * 0.02)).abs() < 1e-6);
    // Undetermined stays undetermined, its interval untouched.
    assert!(w.std[1].is_nan());
    assert_eq!((w.lower[1], w.upper[1]), (0.0, 1.0));
    // Clamped to [0, 1], except the circular phase.
    assert_eq!((w.lower[2], w.upper[2]), (0.0, 1.0));
    assert!((w.std[2] - 0.6).abs() < 1e-6);
    assert!(w.upper[6] > 1.0);
    // A factor of one redraws the interval around k at the same deviation.
    assert_eq!(w.std[7], 0.02);
    assert!((w.lower[7] - (0.5 - Z90 * 0.02)).abs() < 1e-6);
    assert_eq!(
        (w.worst_correlation, w.worst_pair, w.residual_std),
        (0.3, (0, 7), 0.5)
    );
}

#[test]
fn a_flat_component_is_undetermined_and_correlations_are_found() {
    let mut normal = diagonal([4.0, 4.0, 4.0, 4.0, 4.0, 4.0, 0.0, 4.0, 4.0]);
    // Shorts A and C nearly the same direction.
    normal[2][4] = 3.96;
    normal[4][2] = 3.96;
    let c = Curvature {
        gradient: [0.0; FAULT_COUNT],
        normal,
        rss: 1.0,
        fitted: 1000,
    };
    let k = FaultVector::new([0.0, 0.0, 0.2, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0]).unwrap();
    let (u, corr) = c.uncertainty(&k).unwrap();
    assert!(u.std[6].is_nan());
    assert_eq!(u.covers(&k)[6], None);
    assert_eq!(u.worst_pair, (2, 4));
    assert!((u.worst_correlation - 0.99).abs() < 1e-4);
    // Short A at 0.2 with a wide interval, entangled with short C: ambiguous.
    let verdicts = u.assess(&k, &corr);
    assert_eq!(verdicts[2], Assessment::Ambiguous { with: 4 });
    assert_eq!(verdicts[0], Assessment::Healthy);
    assert_eq!(verdicts[6], Assessment::NotApplicable);
}

#[test]
fn a_preflight_adds_its_systematic_error_in_quadrature_and_keeps_the_correlations() {
    // The gain drift's and short A's deviations 0.0045 and 0.03 before the error is added.
    let mut normal = diagonal([4.0, 4.0, 4.0, 4.0, 4.0, 4.0, 4.0, 4.0, 4.0]);
    normal[1][7] = 1.0;
    normal[7][1] = 1.0;
    let c = Curvature {
        gradient: [0.0; FAULT_COUNT],
        normal,
        rss: 1.0,
        fitted: 1000,
    };
    let k = FaultVector::new([0.0, 0.4, 0.0, 0.0, 0.0, 0.0, 0.5, 0.615, 0.0]).unwrap();
    let (own, own_corr) = c.uncertainty(&k).unwrap();
    let reference = SystematicError::REFERENCE_ACTUATOR;
    let (pre, pre_corr) = c.preflight_uncertainty(&k, &reference).unwrap();
    assert!(reads_play(&k));
    let systematic = preflight_systematic(&k, &reference);
    assert_eq!(systematic[7], PLAY_GAIN_DRIFT_SYSTEMATIC);
    for (i, e) in systematic.iter().enumerate() {
        let want = (own.std[i] * own.std[i] + e * e).sqrt();
        assert!(
            (pre.std[i] - want).abs() < 1e-7,
            "{i}: {} {want}",
            pre.std[i]
        );
        if *e == 0.0 {
            // Exactly the curvature's: a window's deviations, which take none, keep
            // their bits.
            assert_eq!(pre.std[i].to_bits(), own.std[i].to_bits(), "{i}");
            assert_eq!(pre.lower[i].to_bits(), own.lower[i].to_bits(), "{i}");
        } else {
            assert!(pre.std[i] > own.std[i], "{i}");
            assert!((pre.upper[i] - (k.as_array()[i] + Z90 * pre.std[i])).abs() < 1e-6);
        }
    }
    assert!(pre.std[7] > own.std[7]);
    assert_eq!(pre_corr, own_corr);
    assert_eq!(pre.worst_pair, own.worst_pair);
    // Table II medium's gain drift, read 0.018 high at a play's typical deviation 0.0045,
    // is outside its interval with the systematic error of all runs, inside with a play's.
    let (read, own) = (0.618f32, 0.0045f32);
    let with = |e: f32| read - Z90 * (own * own + e * e).sqrt();
    assert!(with(SYSTEMATIC[7]) > 0.6);
    assert!(with(PLAY_GAIN_DRIFT_SYSTEMATIC) <= 0.6);
    // Without a play read, the same curvature takes the systematic error of all runs.
    let mut no_play = *k.as_array();
    no_play[1] = 0.04;
    let no_play = FaultVector::new(no_play).unwrap();
    assert!(!reads_play(&no_play));
    let (pre, _) = c.preflight_uncertainty(&no_play, &reference).unwrap();
    let (own, _) = c.uncertainty(&no_play).unwrap();
    let want = (own.std[7] * own.std[7] + SYSTEMATIC[7] * SYSTEMATIC[7]).sqrt();
    assert!((pre.std[7] - want).abs() < 1e-7, "{} {want}", pre.std[7]);
    assert_eq!(preflight_systematic(&no_play, &reference), SYSTEMATIC);
}

#[test]
fn a_friction_the_days_healthy_friction_can_explain_is_not_proven() {
    let c = Curvature {
        gradient: [0.0; FAULT_COUNT],
        normal: diagonal([4.0e4; FAULT_COUNT]),
        rss: 1.0,
        fitted: 101,
    };
    let mut k = [0.0; FAULT_COUNT];
    k[0] = 0.3;
    k[6] = 0.5;
    let k = FaultVector::new(k).unwrap();
    let record = SystematicError::REFERENCE_ACTUATOR;
    let (own, corr) = c.preflight_uncertainty(&k, &record).unwrap();
    assert_eq!(own.assess(&k, &corr)[0], Assessment::Faulty);
    // A cold day's law, ±12 K of gearbox: ln(friction) ±0.34.
    let day = SystematicError {
        gear_temperature_spread: 12.0,
        ..record
    }
    .on_day(0.34 / 12.0);
    let (pre, corr) = c.preflight_uncertainty(&k, &day).unwrap();
    let nuisance = 0.5 * 1.6 * 0.34;
    let want = (own.std[0] * own.std[0] + nuisance * nuisance).sqrt();
    assert!((pre.std[0] - want).abs() < 1e-5, "{} {want}", pre.std[0]);
    assert_eq!(pre.assess(&k, &corr)[0], Assessment::Suspect);
    assert!((preflight_systematic(&k, &day)[0] - nuisance).abs() < 1e-6);
    // Without a declared spread the day adds nothing.
    assert_eq!(record.on_day(0.34 / 12.0).friction_for(&k), 0.0);
    // The other components keep their bits.
    for i in 1..FAULT_COUNT {
        assert_eq!(pre.std[i].to_bits(), own.std[i].to_bits(), "{i}");
    }
}

#[test]
fn a_preflight_takes_the_systematic_error_its_actuator_record_carries() {
    let c = Curvature {
        gradient: [0.0; FAULT_COUNT],
        normal: diagonal([4.0; FAULT_COUNT]),
        rss: 1.0,
        fitted: 1000,
    };
    // The light actuator's survey: 0.009 over all runs, 0.018 over those with a play.
    let light = SystematicError {
        gain_drift: 0.009,
        play_gain_drift: 0.018,
        gear_temperature_spread: 0.0,
        healthy_friction: 0.0,
    };
    let play = FaultVector::new([0.0, 0.4, 0.0, 0.0, 0.0, 0.0, 0.5, 0.625, 0.0]).unwrap();
    let mut none = *play.as_array();
    none[1] = 0.0;
    let none = FaultVector::new(none).unwrap();
    for (k, e) in [(play, 0.018f32), (none, 0.009)] {
        let (own, _) = c.uncertainty(&k).unwrap();
        let (pre, _) = c.preflight_uncertainty(&k, &light).unwrap();
        let (reference, _) = c
            .preflight_uncertainty(&k, &SystematicError::REFERENCE_ACTUATOR)
            .unwrap();
        let want = (own.std[7] * own.std[7] + e * e).sqrt();
        assert!((pre.std[7] - want).abs() < 1e-7, "{} {want}", pre.std[7]);
        assert!(pre.std[7] > reference.std[7]);
        // Only the gain drift moves.
        for i in (0..FAULT_COUNT).filter(|&i| i != 7) {
            assert_eq!(pre.std[i].to_bits(), reference.std[i].to_bits(), "{i}");
        }
        assert_eq!(preflight_systematic(&k, &light)[7], e);
    }
    // A flight's windows read that mix's gain drift 0.600; the light preflight read it
    // 0.625 (docs/in-flight.md): outside the interval a play takes on the reference
    // actuator, inside the light actuator's own.
    let (read, own) = (0.625f32, 0.005f32);
    let lower = |e: f32| read - Z90 * (own * own + e * e).sqrt();
    assert!(lower(PLAY_GAIN_DRIFT_SYSTEMATIC) > 0.6);
    assert!(lower(light.play_gain_drift) <= 0.6);
}

#[test]
fn faulty_needs_the_interval_beyond_the_threshold() {
    let c = Curvature {
        gradient: [0.0; FAULT_COUNT],
        normal: diagonal([1.0e4; FAULT_COUNT]),
        rss: 1.0,
        fitted: 10_009,
    };
    // std = √(1e-4 / 1e4)·c = 1e-4·c: tiny.
    let k = FaultVector::new([0.3, 0.052, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0]).unwrap();
    let (u, corr) = c.uncertainty(&k).unwrap();
    let v = u.assess(&k, &corr);
    assert_eq!(v[0], Assessment::Faulty);
    // Just beyond the threshold, but its interval is not when the std is larger.
    let wide = Curvature { rss: 1.0e6, ..c };
    let (u, corr) = wide.uncertainty(&k).unwrap();
    assert_eq!(u.assess(&k, &corr)[1], Assessment::Suspect);
    assert!(Curvature {
        gradient: [0.0; FAULT_COUNT],
        normal: [[0.0; FAULT_COUNT]; FAULT_COUNT],
        rss: 1.0,
        fitted: 10
    }
    .uncertainty(&k)
    .is_err());
}

/// Amplitudes `√((ν + σ·g₁)² + (σ·g₂)²)` of a true amplitude `ν` in Gaussian noise of
/// `sigma` per quadrature (Box–Muller from a seeded stream), `n` of them.
fn noisy_amplitudes(nu: f32, sigma: f32, n: usize, seed: u64) -> std::vec::Vec<f32> {
    let mut rng = crate::base::random::Xoshiro128PlusPlus::seed_from_u64(seed);
    let mut uniform = || (f64::from(rng.next_u32()) + 0.5) / 4_294_967_296.0;
    (0..n)
        .map(|_| {
            let (u, v) = (uniform(), uniform());
            let r = (-2.0 * u.ln()).sqrt();
            let angle = 2.0 * core::f64::consts::PI * v;
            let (x, y) = (r * angle.cos(), r * angle.sin());
            let i = f64::from(nu) + f64::from(sigma) * x;
            let q = f64::from(sigma) * y;
            (i * i + q * q).sqrt() as f32
        })
        .collect()
}

/// The correction takes noise's bias off the square: over 20 000 draws the corrected
/// amplitude's mean square is the truth's, the raw one's `2σ²` above it (within four
/// standard errors, each well below `2σ²`) where the truth stands clear of the noise,
/// and a round rotor reads beyond `ROUND_ROTOR_99 · σ` in 1 % of draws (0.8–1.2 %), at
/// 0 in `1 − e⁻¹` of them.
#[test]
fn the_free_phase_correction_takes_noises_bias_off() {
    let sigma = 0.03;
    let n = 20_000;
    for nu in [0.1f32, 0.2] {
        let z = noisy_amplitudes(nu, sigma, n, 7);
        // The mean square and four of its standard errors.
        let mean_square = |f: &dyn Fn(f32) -> f32| {
            let sq: std::vec::Vec<f64> = z.iter().map(|&x| f64::from(f(x)).powi(2)).collect();
            let mean = sq.iter().sum::<f64>() / n as f64;
            let var = sq.iter().map(|q| (q - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
            (mean - f64::from(nu * nu), 4.0 * (var / n as f64).sqrt())
        };
        let (raw, raw_tolerance) = mean_square(&|x| x);
        let (corrected, tolerance) = mean_square(&|x| free_phase_corrected(x, sigma));
        let bias = 2.0 * f64::from(sigma * sigma);
        assert!((raw - bias).abs() < raw_tolerance, "ν {nu}: raw bias {raw}");
        assert!(tolerance < 0.3 * bias, "ν {nu}: too few draws to tell");
        assert!(
            corrected.abs() < tolerance,
            "ν {nu}: corrected bias {corrected}"
        );
    }
    let round = noisy_amplitudes(0.0, sigma, n, 8);
    let corrected: std::vec::Vec<f32> = round
        .iter()
        .map(|&x| free_phase_corrected(x, sigma))
        .collect();
    let beyond = corrected
        .iter()
        .filter(|&&x| x > ROUND_ROTOR_99 * sigma)
        .count() as f64
        / n as f64;
    assert!(
        (0.008..=0.012).contains(&beyond),
        "beyond the floor: {beyond}"
    );
    let zero = corrected.iter().filter(|&&x| x == 0.0).count() as f64 / n as f64;
    assert!(
        (zero - (1.0 - (-1.0f64).exp())).abs() < 0.02,
        "at zero: {zero}"
    );
    // No deviation: the reading as it is.
    assert_eq!(free_phase_corrected(0.04, f32::NAN), 0.04);
    assert_eq!(free_phase_corrected(0.04, 0.0), 0.04);
}

/// A preflight's reading: only the eccentricity moves, by its own white-noise
/// deviation (its std over the inflation) scaled to the residual's noise share, and its
/// interval is redrawn around it.
#[test]
fn a_reading_is_corrected_by_its_own_deviation() {
    let k = FaultVector::new([0.2, 0.1, 0.0, 0.0, 0.0, 0.05, 0.5, 0.5, 0.0]).unwrap();
    let mut std = [0.01; FAULT_COUNT];
    std[ECCENTRICITY] = 0.02 * INFLATION;
    let u = stated(std);
    let (read, v) = u.with_free_phase_corrected(&k, 1.0);
    let z = (0.05f32 * 0.05 - 2.0 * 0.02 * 0.02).sqrt();
    for i in 0..FAULT_COUNT {
        let expected = if i == ECCENTRICITY {
            z
        } else {
            k.as_array()[i]
        };
        assert!(
            (read.as_array()[i] - expected).abs() < 1e-6,
            "component {i}"
        );
    }
    let lo = (z - Z90 * 0.02 * INFLATION).max(0.0);
    assert!((v.lower[ECCENTRICITY] - lo).abs() < 1e-6);
    assert!((v.upper[ECCENTRICITY] - (z + Z90 * 0.02 * INFLATION)).abs() < 1e-6);
    assert_eq!(v.std, u.std);
    // A quarter of the residual noise: σ halved.
    let (quarter, _) = u.with_free_phase_corrected(&k, 0.25);
    let z = (0.05f32 * 0.05 - 2.0 * 0.01 * 0.01).sqrt();
    assert!((quarter.as_array()[ECCENTRICITY] - z).abs() < 1e-6);
    // No noise: a mismatch's residual takes nothing off.
    assert_eq!(u.with_free_phase_corrected(&k, 0.0).0, k);
    // Undetermined: left as read.
    let unknown = Uncertainty {
        std: [f32::NAN; FAULT_COUNT],
        ..u
    };
    assert_eq!(unknown.with_free_phase_corrected(&k, 1.0).0, k);
}

#[test]
fn an_eccentricity_within_what_noise_makes_of_a_round_rotor_reads_healthy() {
    let k = FaultVector::new([0.07, 0.0, 0.0, 0.0, 0.0, 0.07, 0.5, 0.5, 0.0]).unwrap();
    let corr = [[0.0; FAULT_COUNT]; FAULT_COUNT];
    // White-noise std 0.03 (0.24 inflated): a 0.07 amplitude is below the Rayleigh
    // floor 3.03 × 0.03 = 0.091, a 0.07 friction is not an amplitude.
    let noisy = stated([0.03 * INFLATION; FAULT_COUNT]);
    let v = noisy.assess(&k, &corr);
    assert_eq!(v[5], Assessment::Healthy);
    assert_eq!(v[0], Assessment::Suspect);
    // A quiet test (std 0.01): the same amplitude is beyond the floor.
    let quiet = Uncertainty {
        std: [0.01 * INFLATION; FAULT_COUNT],
        ..noisy
    };
    assert_eq!(quiet.assess(&k, &corr)[5], Assessment::Suspect);
    // Undetermined (NaN std): the threshold alone.
    let unknown = Uncertainty {
        std: [f32::NAN; FAULT_COUNT],
        ..noisy
    };
    assert_eq!(unknown.assess(&k, &corr)[5], Assessment::Suspect);
}

/// Deviations `std` with intervals spanning [0, 1] and nothing else stated.
fn stated(std: [f32; FAULT_COUNT]) -> Uncertainty {
    Uncertainty {
        std,
        lower: [0.0; FAULT_COUNT],
        upper: [1.0; FAULT_COUNT],
        worst_correlation: 0.0,
        worst_pair: (0, 1),
        residual_std: 0.0,
        magnet_std: f32::NAN,
    }
}

#[test]
fn a_magnets_depth_deviation_is_its_curvatures_inflated_with_the_grids_beside_it() {
    // s² = 100 A² over 10 011 − 11 samples = 0.01; a curvature of 0.04 A²·s per unit² at
    // a 100 µs step is J_dᵀWJ_d = 200: Gauss–Newton std √(0.01/200) ≈ 0.00707.
    let c = Curvature {
        rss: 100.0,
        fitted: 10_011,
        ..Curvature::EMPTY
    };
    let s = depth_deviation(&c, 0.04, 1.0e-4);
    let gauss_newton = DEPTH_INFLATION * (0.01f32 / 200.0).sqrt();
    let expected = (gauss_newton * gauss_newton + DEPTH_QUANTIZATION * DEPTH_QUANTIZATION).sqrt();
    assert!((s - expected).abs() < 1e-6, "{s} against {expected}");
    // A flatter profile states a wider depth; the grid's deviation is the floor.
    assert!(depth_deviation(&c, 0.01, 1.0e-4) > s);
    assert!(depth_deviation(&c, 1.0e6, 1.0e-4) >= DEPTH_QUANTIZATION);
    // No curvature (none read, a profile bent the wrong way), or no samples: unknown.
    for bad in [f32::NAN, 0.0, -0.04] {
        assert!(depth_deviation(&c, bad, 1.0e-4).is_nan(), "{bad}");
    }
    let empty = Curvature { fitted: 11, ..c };
    assert!(depth_deviation(&empty, 0.04, 1.0e-4).is_nan());
}

#[test]
fn a_magnets_verdict_follows_the_components_rule() {
    let t = DETECTION_THRESHOLD;
    // None read, or within the threshold: healthy, whatever its deviation.
    assert_eq!(assess_magnet(0.0, f32::NAN, t), Assessment::Healthy);
    assert_eq!(assess_magnet(t, 0.5, t), Assessment::Healthy);
    // Its 90 % interval clear of the threshold: FAULT; not clear, or unknown: suspect.
    assert_eq!(assess_magnet(0.5, 0.03, t), Assessment::Faulty);
    assert_eq!(assess_magnet(0.1, 0.035, t), Assessment::Suspect);
    assert_eq!(assess_magnet(0.5, f32::NAN, t), Assessment::Suspect);
    // The same rule as a component's.
    let k = FaultVector::new([0.1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.5]).unwrap();
    let u = stated([0.035; FAULT_COUNT]);
    let corr = [[0.0; FAULT_COUNT]; FAULT_COUNT];
    let v = u.assess(&k, &corr);
    assert_eq!(v[0], assess_magnet(0.1, 0.035, t));
    assert_eq!(v[8], assess_magnet(0.5, 0.035, t));
}
