//! Unit tests of [`super`] (`fusion`).

use super::*;
use crate::flight::window::WINDOW_INFLATION;

/// A window's curvature with `normal` on the diagonal (the others coupled by `coupling`
/// between friction and gain drift), gradient `gradient`, and a noise scale (c·s)² of 1.
fn curvature(normal: [f64; FAULT_COUNT], gradient: [f64; FAULT_COUNT], coupling: f64) -> Curvature {
    let mut n = [[0.0; FAULT_COUNT]; FAULT_COUNT];
    for i in 0..FAULT_COUNT {
        n[i][i] = normal[i];
    }
    (n[0][7], n[7][0]) = (coupling, coupling);
    let p = normal.iter().filter(|&&x| x > 0.0).count();
    Curvature {
        normal: n,
        rss: 1.0 / f64::from(INFLATION * INFLATION),
        gradient,
        fitted: p as u32 + 1,
    }
}

const ONES: [f32; FAULT_COUNT] = [1.0; FAULT_COUNT];

#[test]
#[allow(clippy::needless_range_loop)] // i indexes four arrays of FAULT_COUNT
fn one_window_states_the_deviations_its_own_uncertainty_states_widened_for_a_flight() {
    let c = curvature(
        [400.0, 900.0, 4.0, 1.0, 0.5, 2.0, 3.0, 2500.0, 0.2],
        [0.0; FAULT_COUNT],
        600.0,
    );
    let k = FaultVector::new([0.2, 0.1, 0.3, 0.4, 0.2, 0.3, 0.5, 0.6, 0.4]).unwrap();
    let mut fusion = WindowFusion::EMPTY;
    fusion.add(&k, &c, &WINDOW_INFLATION).unwrap();
    let flight = fusion.reading(FLIGHT_MAX_FRICTION_STD).unwrap();
    let (own, _) = c.uncertainty(&k).unwrap();
    let own = own.widened(&k, &WINDOW_INFLATION);
    for i in 0..FAULT_COUNT {
        // The flight's own widening on top (the gain drift's).
        let (a, b) = (
            flight.uncertainty.0.std[i],
            own.std[i] * FLIGHT_INFLATION[i],
        );
        assert!((a - b).abs() <= 1e-5 * b, "component {i}: {a} against {b}");
        // At a gradient of zero the window's point is its vector.
        let (x, y) = (flight.faults.as_array()[i], k.as_array()[i]);
        assert!((x - y).abs() < 1e-5, "component {i}: {x} against {y}");
    }
    assert_eq!(flight.windows, 1);
}

#[test]
fn windows_add_their_evidence() {
    // Four windows reading friction 0.16, 0.24, 0.20, 0.20 at σ 0.1 each: 0.2 at σ 0.05
    // (times the flight's friction factor).
    let mut fusion = WindowFusion::EMPTY;
    for friction in [0.16, 0.24, 0.20, 0.20] {
        let mut genes = *FaultVector::NOMINAL.as_array();
        genes[0] = friction;
        let k = FaultVector::new(genes).unwrap();
        let c = curvature(
            [100.0, 100.0, 100.0, 100.0, 100.0, 100.0, 0.0, 100.0, 100.0],
            [0.0; FAULT_COUNT],
            0.0,
        );
        fusion.add(&k, &c, &ONES).unwrap();
        let one = fusion.windows() == 1;
        let flight = fusion.reading(0.08).unwrap();
        // One window at σ 0.1 is above a friction limit of 0.08; two are not.
        assert_eq!(flight.verdict.is_err(), one, "{:?}", flight.verdict);
    }
    let flight = fusion.reading(FLIGHT_MAX_FRICTION_STD).unwrap();
    assert!((flight.faults.friction() - 0.2).abs() < 1e-5);
    assert!((flight.uncertainty.0.std[0] - 0.05 * FLIGHT_INFLATION[0]).abs() < 1e-6);
    // The phase: no window determines it.
    assert!(flight.uncertainty.0.std[PHASE].is_nan());
}

#[test]
fn beyond_the_calibrated_windows_a_shared_error_no_longer_shrinks() {
    // Identical windows: friction's deviation shrinks as 1/√n all the way, the
    // eccentricity's only up to eight windows and stays there.
    let k = FaultVector::new([0.2, 0.0, 0.0, 0.0, 0.0, 0.2, 0.5, 0.5, 0.0]).unwrap();
    let c = curvature([100.0; FAULT_COUNT], [0.0; FAULT_COUNT], 0.0);
    let mut fusion = WindowFusion::EMPTY;
    let mut std = [(0.0f32, 0.0f32); 17];
    for slot in std.iter_mut().skip(1) {
        fusion.add(&k, &c, &ONES).unwrap();
        let s = fusion.reading(1.0).unwrap().uncertainty.0.std;
        *slot = (s[0], s[5]);
    }
    let shrink = |n: usize| 1.0 / (n as f32).sqrt();
    for n in [2, 8, 12, 16] {
        let (friction, eccentricity) = std[n];
        assert!(
            (friction / std[1].0 - shrink(n)).abs() < 1e-4,
            "friction at {n}"
        );
        let expected = shrink(n.min(CALIBRATED_WINDOWS as usize));
        assert!(
            (eccentricity / std[1].1 - expected).abs() < 1e-4,
            "eccentricity at {n}: {} against {expected}",
            eccentricity / std[1].1
        );
    }
    assert_eq!(flight_inflation(8), FLIGHT_INFLATION);
    assert!(flight_inflation(16)[5] > FLIGHT_INFLATION[5] * 1.41);
}

#[test]
fn a_component_read_at_its_bound_keeps_the_push_beyond_it() {
    // A healthy friction read at 0 by two windows whose gradients push it below 0
    // (points −0.06), and at 0.06 and 0.05 by two others: the fused reading stays near 0
    // (the points' mean −0.0025, clamped), where the clamped values' mean is 0.0275.
    let mut fusion = WindowFusion::EMPTY;
    for (friction, push) in [(0.0, -0.06), (0.06, 0.0), (0.0, -0.06), (0.05, 0.0)] {
        let mut genes = *FaultVector::NOMINAL.as_array();
        genes[0] = friction;
        let normal = [400.0, 100.0, 100.0, 100.0, 100.0, 100.0, 0.0, 100.0, 100.0];
        let mut gradient = [0.0; FAULT_COUNT];
        gradient[0] = push * normal[0];
        let c = curvature(normal, gradient, 0.0);
        fusion
            .add(&FaultVector::new(genes).unwrap(), &c, &ONES)
            .unwrap();
    }
    let flight = fusion.reading(FLIGHT_MAX_FRICTION_STD).unwrap();
    assert_eq!(flight.faults.friction(), 0.0);
    assert_eq!(flight.verdict, Ok(()));
}

#[test]
fn coupled_components_are_minimised_together_in_the_box() {
    // Friction and gain drift coupled: the box-constrained minimum of the quadratic,
    // checked against a fine grid over the two.
    let c = curvature(
        [400.0, 100.0, 100.0, 100.0, 100.0, 100.0, 0.0, 900.0, 100.0],
        [-30.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 50.0, 0.0],
        500.0,
    );
    let mut genes = *FaultVector::NOMINAL.as_array();
    genes[0] = 0.02;
    let k = FaultVector::new(genes).unwrap();
    let mut fusion = WindowFusion::EMPTY;
    fusion.add(&k, &c, &ONES).unwrap();
    let flight = fusion.reading(FLIGHT_MAX_FRICTION_STD).unwrap();
    // q(δ) = ½ δᵀNδ − gᵀδ over (friction, gain drift), δ from k.
    let q = |a: f64, b: f64| {
        let (da, db) = (a - 0.02, b - 0.5);
        0.5 * (400.0 * da * da + 2.0 * 500.0 * da * db + 900.0 * db * db) - (-30.0 * da + 50.0 * db)
    };
    let found = q(
        f64::from(flight.faults.friction()),
        f64::from(flight.faults.as_array()[7]),
    );
    let mut best = f64::INFINITY;
    for i in 0..=1000 {
        for j in 0..=1000 {
            best = best.min(q(f64::from(i) * 1e-3, f64::from(j) * 1e-3));
        }
    }
    assert!(found <= best + 1e-6, "{found} against the grid's {best}");
    assert_eq!(
        flight.faults.friction(),
        0.0,
        "the unbounded minimum has friction < 0"
    );
}

#[test]
fn a_reading_needs_a_second_window_that_agrees() {
    // Friction read at σ 0.05 by each window (the others well determined at 0).
    let window = |friction: f32| {
        let mut genes = *FaultVector::NOMINAL.as_array();
        genes[0] = friction;
        let normal = [400.0, 1e4, 1e4, 1e4, 1e4, 1e4, 0.0, 1e4, 1e4];
        (
            FaultVector::new(genes).unwrap(),
            curvature(normal, [0.0; FAULT_COUNT], 0.0),
        )
    };
    let fused = |frictions: &[f32]| {
        let mut fusion = WindowFusion::EMPTY;
        for &f in frictions {
            let (k, c) = window(f);
            fusion.add(&k, &c, &ONES).unwrap();
        }
        // A friction limit above two windows' 0.035: the verdict is the agreement's.
        fusion.reading(0.04).unwrap().verdict
    };
    // One window alone is not confirmed.
    assert!(matches!(
        fused(&[0.2]),
        Err(WindowReason::Unconfirmed { windows: 1, disagreement }) if disagreement.is_nan()
    ));
    // Two within a deviation of each other: confirmed.
    assert_eq!(fused(&[0.17, 0.23]), Ok(()));
    // Eight deviations apart (χ² 32 on 8 degrees of freedom, its 99 % quantile 20.1:
    // 1.6; the friction alone 32 against χ²₁'s 6.63: 4.8, the larger): one of them is
    // wrong.
    match fused(&[0.0, 0.4]) {
        Err(WindowReason::Unconfirmed {
            windows: 2,
            disagreement,
        }) => assert!((4.6..5.0).contains(&disagreement), "{disagreement}"),
        other => panic!("{other:?}"),
    }
}

#[test]
fn one_close_window_does_not_outweigh_the_others_it_disagrees_with() {
    // Friction read at σ 0.1 by eight windows around 0.1 and at σ 0.035 by a ninth
    // (its information that of eight: half the flight's), the others well determined.
    let window = |friction: f32, std: f64| {
        let mut genes = *FaultVector::NOMINAL.as_array();
        genes[0] = friction;
        let normal = [1.0 / (std * std), 1e4, 1e4, 1e4, 1e4, 1e4, 0.0, 1e4, 1e4];
        (
            FaultVector::new(genes).unwrap(),
            curvature(normal, [0.0; FAULT_COUNT], 0.0),
        )
    };
    let flight = |closest: f32| {
        let mut fusion = WindowFusion::EMPTY;
        for f in [0.0, 0.15, 0.05, 0.2, 0.1, 0.18, 0.02, 0.1] {
            let (k, c) = window(f, 0.1);
            fusion.add(&k, &c, &ONES).unwrap();
        }
        let (k, c) = window(closest, 0.035);
        fusion.add(&k, &c, &ONES).unwrap();
        fusion
    };
    // Reading 0.30: four of the pair's deviations from the others' 0.10 (χ² 16 against
    // χ²₁'s 6.63: 2.5), while the χ² over all nine windows and components stays far
    // below its quantile (the one window diluted among 64 degrees of freedom).
    let apart = flight(0.30);
    let reading = apart.reading(0.04).unwrap();
    let k = reading.faults.as_array().map(f64::from);
    let free: [bool; FAULT_COUNT] = core::array::from_fn(|i| i != PHASE);
    assert!(run_to_end(apart.disagreement(&k, &free, &free)) < 0.5);
    match reading.verdict {
        Err(WindowReason::Unconfirmed {
            windows: 9,
            disagreement,
        }) => assert!((2.2..2.8).contains(&disagreement), "{disagreement}"),
        other => panic!("{other:?}"),
    }
    // Reading 0.12, within its and the others' deviations: the flight is read.
    assert_eq!(flight(0.12).reading(0.04).unwrap().verdict, Ok(()));
    // The closest window is chosen by its deviation, not its reading: the same nine
    // readings with the ninth as loose as the others are confirmed.
    let mut even = WindowFusion::EMPTY;
    for f in [0.0, 0.15, 0.05, 0.2, 0.1, 0.18, 0.02, 0.1, 0.30] {
        let (k, c) = window(f, 0.1);
        even.add(&k, &c, &ONES).unwrap();
    }
    assert_eq!(even.reading(0.04).unwrap().verdict, Ok(()));
}

#[test]
fn nothing_is_read_from_no_window_or_an_undetermined_one() {
    let mut fusion = WindowFusion::EMPTY;
    assert!(fusion.reading(FLIGHT_MAX_FRICTION_STD).is_err());
    let flat = curvature([0.0; FAULT_COUNT], [0.0; FAULT_COUNT], 0.0);
    assert!(fusion.add(&FaultVector::NOMINAL, &flat, &ONES).is_err());
    assert_eq!(fusion, WindowFusion::EMPTY);
}

/// Flies identical windows (friction 0.2 at information `normal` each) under `length`
/// until it says done: the windows flown, why it stopped and the last reading's verdict.
fn fly(length: FlightLength, normal: f64) -> (u32, FlightEnd, Result<(), WindowReason>) {
    let mut genes = *FaultVector::NOMINAL.as_array();
    genes[0] = 0.2;
    let k = FaultVector::new(genes).unwrap();
    let c = curvature([normal; FAULT_COUNT], [0.0; FAULT_COUNT], 0.0);
    let mut fusion = WindowFusion::EMPTY;
    for flown in 1..=64 {
        fusion.add(&k, &c, &ONES).unwrap();
        let reading = fusion.reading(FLIGHT_MAX_FRICTION_STD).ok();
        match length.after(flown, reading.as_ref(), FLIGHT_MAX_FRICTION_STD) {
            FlightProgress::MoreWindows => {}
            FlightProgress::Done(end) => return (flown, end, reading.unwrap().verdict),
        }
    }
    panic!("no end in 64 windows");
}

/// The windows a reading needs (`FlightReading::windows_to_reach`): eight identical
/// windows at information 100 read friction to σ 1.1 / √800 = 0.0389; at the limit 0.03
/// they need 14, the count a flight under `FlightLength` is read at (below); with a held
/// part of 0.02 that does not shrink, more; with one of 0.03 or more, never.
#[test]
fn the_windows_a_reading_needs_count_its_held_part_as_staying() {
    let mut genes = *FaultVector::NOMINAL.as_array();
    genes[0] = 0.2;
    let k = FaultVector::new(genes).unwrap();
    let c = curvature([100.0; FAULT_COUNT], [0.0; FAULT_COUNT], 0.0);
    let mut fusion = WindowFusion::EMPTY;
    for _ in 0..8 {
        fusion.add(&k, &c, &ONES).unwrap();
    }
    let reading = fusion.reading(FLIGHT_MAX_FRICTION_STD).unwrap();
    let std = reading.uncertainty.0.std[0];
    assert!((std - 1.1 / 800f32.sqrt()).abs() < 1e-4, "{std}");
    assert_eq!(reading.windows_to_reach(FLIGHT_MAX_FRICTION_STD), Some(14));
    assert_eq!(reading.windows_to_reach(0.05), Some(8));
    let (n, _, _) = fly(CRUISE_LENGTH, 100.0);
    assert_eq!(n, 14);

    let mut held = reading;
    held.shared_std[0] = 0.02;
    // 8 · (σ² − 0.02²) / (0.03² − 0.02²) = 17.8.
    let own = std * std - 0.0004;
    let expected = (8.0 * own / 0.0005).ceil() as u32;
    assert_eq!(
        held.windows_to_reach(FLIGHT_MAX_FRICTION_STD),
        Some(expected)
    );
    assert!(expected > 14);
    held.shared_std[0] = 0.03;
    assert_eq!(held.windows_to_reach(FLIGHT_MAX_FRICTION_STD), None);
    held.shared_std[0] = 0.0;
    held.uncertainty.0.std[0] = f32::NAN;
    assert_eq!(held.windows_to_reach(FLIGHT_MAX_FRICTION_STD), None);
}

#[test]
fn a_long_phase_flies_windows_until_the_friction_deviation_reaches_the_limit() {
    // Information 100 per window: σ = 1.1 / √(100 n), above 0.03 up to 13 windows.
    let sigma = |n: f32| FLIGHT_INFLATION[0] / (100.0 * n).sqrt();
    assert!(sigma(13.0) > FLIGHT_MAX_FRICTION_STD && sigma(14.0) <= FLIGHT_MAX_FRICTION_STD);
    // Eight fixed: named for turbulence after eight.
    let (n, end, verdict) = fly(FlightLength::fixed(8), 100.0);
    assert_eq!((n, end), (8, FlightEnd::WindowCap));
    assert!(matches!(
        verdict,
        Err(WindowReason::TurbulenceTooHigh { .. })
    ));
    // Up to 24: read at the fourteenth.
    let (n, end, verdict) = fly(CRUISE_LENGTH, 100.0);
    assert_eq!((n, end, verdict), (14, FlightEnd::Settled, Ok(())));
    // Up to 12: fourteen are out of reach, known after eight.
    let (n, end, _) = fly(FlightLength { least: 8, most: 12 }, 100.0);
    assert_eq!((n, end), (8, FlightEnd::OutOfReach));
    // Windows rich enough to read at eight stop there.
    let (n, end, verdict) = fly(CRUISE_LENGTH, 400.0);
    assert_eq!((n, end, verdict), (8, FlightEnd::Settled, Ok(())));
}

/// A flight's windows that held the same preflight values share their error: each
/// window's friction leans on the held eccentricity by `A = 50 / 100 = 0.5`, the
/// eccentricity's error is σ 0.04, so every window's friction carries 0.02
/// of it — in a flight of one window or of sixteen, while the windows' own 0.1 shrinks
/// as 1/√n. A flight whose shared part alone is above the limit is out of reach at
/// once. Fails if the fusion averages the held error away or drops it.
#[test]
fn the_held_values_error_is_shared_by_a_flights_windows() {
    use crate::flight::window::{HeldComponents, HeldCoupling};
    let mut genes = *FaultVector::NOMINAL.as_array();
    genes[0] = 0.2;
    let k = FaultVector::new(genes).unwrap();
    // The held components' rows and columns are zero, as a window's curvature has them.
    let mut normal = [0.0; FAULT_COUNT];
    (normal[0], normal[1], normal[7]) = (100.0, 100.0, 100.0);
    let c = curvature(normal, [0.0; FAULT_COUNT], 0.0);
    let mut coupling = HeldCoupling::NONE;
    coupling.normal[0][5] = 50.0;
    // The preflight stated σ 0.2: taken `HELD_ERROR_SCALE` times, 0.04.
    let mut std = [f32::NAN; FAULT_COUNT];
    std[5] = 0.04 / crate::flight::window::HELD_ERROR_SCALE[5];
    let mut correlation = [[0.0f32; FAULT_COUNT]; FAULT_COUNT];
    for (i, row) in correlation.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    let held = HeldComponents::of_preflight(&FaultVector::NOMINAL)
        .with_preflight_uncertainty(&std, &correlation);
    let mut fusion = WindowFusion::EMPTY;
    let mut unheld = WindowFusion::EMPTY;
    for n in 1..=16u32 {
        fusion.add_holding(&k, &c, &ONES, &held, &coupling).unwrap();
        unheld.add(&k, &c, &ONES).unwrap();
        let r = fusion.reading(1.0).unwrap();
        let plain = unheld.reading(1.0).unwrap();
        assert!(
            (r.shared_std[0] - 0.02).abs() < 1e-6,
            "{n}: {:?}",
            r.shared_std
        );
        assert_eq!(r.shared_std[1], 0.0);
        let own = FLIGHT_INFLATION[0] * 0.1 / (n as f32).sqrt();
        let expect = (own * own + 0.02 * 0.02).sqrt();
        assert!((r.uncertainty.0.std[0] - expect).abs() < 1e-6, "{n}: {r:?}");
        assert!(
            (plain.uncertainty.0.std[0] - own).abs() < 1e-6,
            "{n}: {plain:?}"
        );
        assert_eq!(plain.shared_std, [0.0; FAULT_COUNT]);
        // The same reading: the held error widens it, does not move it.
        assert_eq!(r.faults, plain.faults);
    }
    // The windows' own deviation could reach 0.015 by 64 windows (0.11 / 8 = 0.014),
    // the shared 0.02 never: out of reach after eight.
    let length = FlightLength { least: 8, most: 64 };
    let mut fusion = WindowFusion::EMPTY;
    for _ in 0..8 {
        fusion.add_holding(&k, &c, &ONES, &held, &coupling).unwrap();
    }
    let r = fusion.reading(0.015).unwrap();
    assert_eq!(
        length.after(8, Some(&r), 0.015),
        FlightProgress::Done(FlightEnd::OutOfReach)
    );
    let r = unheld.reading(0.015).unwrap();
    assert_eq!(
        length.after(16, Some(&r), 0.015),
        FlightProgress::MoreWindows
    );
}

#[test]
fn windows_that_disagree_or_never_enter_end_the_flight() {
    let length = FlightLength { least: 2, most: 24 };
    assert_eq!(
        length.after(1, None, FLIGHT_MAX_FRICTION_STD),
        FlightProgress::MoreWindows
    );
    assert_eq!(
        length.after(2, None, FLIGHT_MAX_FRICTION_STD),
        FlightProgress::Done(FlightEnd::Settled)
    );
    let mut fusion = WindowFusion::EMPTY;
    for friction in [0.0, 0.4] {
        let mut genes = *FaultVector::NOMINAL.as_array();
        genes[0] = friction;
        // σ 0.05 each: eight deviations apart, χ² 32 on 8 degrees of freedom.
        let c = curvature([400.0; FAULT_COUNT], [0.0; FAULT_COUNT], 0.0);
        fusion
            .add(&FaultVector::new(genes).unwrap(), &c, &ONES)
            .unwrap();
    }
    let reading = fusion.reading(FLIGHT_MAX_FRICTION_STD).unwrap();
    assert!(matches!(
        reading.verdict,
        Err(WindowReason::Unconfirmed { .. })
    ));
    assert_eq!(
        length.after(2, Some(&reading), FLIGHT_MAX_FRICTION_STD),
        FlightProgress::Done(FlightEnd::Settled)
    );
}

#[test]
fn windows_that_hold_the_friction_give_the_flight_the_preflights() {
    // Two windows that read the backlash and the gain drift alone (σ 0.05 each), the
    // friction not determined: held at the preflight's 0.4, or not held at all.
    let preflight = FaultVector::new([0.4, 0.4, 0.2, 0.1, 0.05, 0.2, 0.75, 0.6, 0.0]).unwrap();
    let mut normal = [0.0; FAULT_COUNT];
    (normal[1], normal[7]) = (400.0, 400.0);
    let c = curvature(normal, [0.0; FAULT_COUNT], 0.0);
    let held = HeldComponents::of_preflight(&preflight).also_holding(0);
    let mut holding = WindowFusion::EMPTY;
    let mut free = WindowFusion::EMPTY;
    for _ in 0..2 {
        holding
            .add_holding(&preflight, &c, &ONES, &held, &HeldCoupling::NONE)
            .unwrap();
        free.add(&preflight, &c, &ONES).unwrap();
    }
    let reading = holding.reading(FLIGHT_MAX_FRICTION_STD).unwrap();
    assert_eq!(reading.verdict, Ok(()));
    assert!(reading.friction_held);
    assert_eq!(reading.faults.as_array()[0], 0.4);
    assert!(reading.uncertainty.0.std[0].is_nan());
    // Its windows were pinned ones: the play's deviation is taken
    // `PINNED_FLIGHT_INFLATION` times the same windows' unpinned, the gain drift's not.
    let unpinned = free.reading(FLIGHT_MAX_FRICTION_STD).unwrap().uncertainty.0;
    let pinned = &reading.uncertainty.0;
    for i in [1, 7] {
        let ratio = pinned.std[i] / unpinned.std[i];
        assert!(
            (ratio - PINNED_FLIGHT_INFLATION[i]).abs() < 1e-4,
            "component {i}: {ratio}"
        );
    }
    assert!(pinned.std[1] > 1.5 * unpinned.std[1]);
    // Not held: the friction is read by no window, the flight cannot be judged on it.
    let reading = free.reading(FLIGHT_MAX_FRICTION_STD).unwrap();
    assert!(!reading.friction_held);
    assert!(matches!(
        reading.verdict,
        Err(WindowReason::TurbulenceTooHigh { friction_std }) if friction_std.is_nan()
    ));
    // A window that reads the friction beside them: the flight's friction is read.
    let mut read = holding;
    let mut normal = [0.0; FAULT_COUNT];
    (normal[0], normal[1], normal[7]) = (2500.0, 400.0, 400.0);
    read.add(
        &preflight,
        &curvature(normal, [0.0; FAULT_COUNT], 0.0),
        &ONES,
    )
    .unwrap();
    let reading = read.reading(FLIGHT_MAX_FRICTION_STD).unwrap();
    assert!(!reading.friction_held);
    assert!(reading.uncertainty.0.std[0] > 0.0);
}

#[test]
#[allow(clippy::needless_range_loop)] // i indexes FAULT_COUNT arrays
fn a_flight_the_friction_limit_keeps_out_ends_on_its_pinned_windows_friction() {
    use crate::flight::window::HeldComponents;
    // Two pinned windows read the play and the gain drift (σ 0.05 each), the friction
    // held at the preflight's 0.3 (σ 0.1, taken `HELD_ERROR_SCALE` times); two windows
    // of the load model read the friction 0.1 loose (σ 0.1) and the gain drift coupled
    // to it.
    let preflight = FaultVector::new([0.3, 0.1, 0.0, 0.0, 0.0, 0.0, 0.5, 0.45, 0.0]).unwrap();
    let mut std = [f32::NAN; FAULT_COUNT];
    std[0] = 0.1;
    let mut correlation = [[0.0f32; FAULT_COUNT]; FAULT_COUNT];
    for (i, row) in correlation.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    // A flight's windows hold the preflight's shorts with its covariance; a pinned one
    // its friction too.
    let shorts =
        HeldComponents::of_preflight(&preflight).with_preflight_uncertainty(&std, &correlation);
    let held = shorts.also_holding(0);
    let mut normal = [0.0; FAULT_COUNT];
    (normal[1], normal[7]) = (400.0, 400.0);
    let pinned = curvature(normal, [0.0; FAULT_COUNT], 0.0);
    let mut normal = [0.0; FAULT_COUNT];
    (normal[0], normal[7]) = (100.0, 400.0);
    // The load model's windows read friction 0.35 and gain drift 0.45 (at their own
    // point), coupled: a friction 0.05 lower moves their gain drift up.
    let loose = curvature(normal, [0.0; FAULT_COUNT], 100.0);
    // Two pinned windows and two of the load model reading `loose_at`.
    let flight = |loose_at: [f32; FAULT_COUNT]| {
        let read = FaultVector::new(loose_at).unwrap();
        let mut fusion = WindowFusion::EMPTY;
        for _ in 0..2 {
            fusion
                .add_holding(&preflight, &pinned, &ONES, &held, &HeldCoupling::NONE)
                .unwrap();
            fusion
                .add_holding(&read, &loose, &ONES, &shorts, &HeldCoupling::NONE)
                .unwrap();
        }
        fusion
    };
    let fusion = flight([0.35, 0.1, 0.0, 0.0, 0.0, 0.0, 0.5, 0.45, 0.0]);
    // Read as it goes: the friction limit keeps it out (its windows' friction σ 0.07).
    let going = fusion.reading(FLIGHT_MAX_FRICTION_STD).unwrap();
    assert!(matches!(
        going.verdict,
        Err(WindowReason::TurbulenceTooHigh { friction_std }) if friction_std > 0.03
    ));
    assert!(!going.friction_held);
    // At its end: the pinned windows' friction, the others conditional on it.
    let end = fusion.final_reading(FLIGHT_MAX_FRICTION_STD).unwrap();
    assert_eq!(end.verdict, Ok(()));
    assert!(end.friction_held);
    assert_eq!(end.faults.as_array()[0], 0.3);
    assert!(end.uncertainty.0.std[0].is_nan());
    // The gain drift at friction 0.3: the loose windows' quadratic, (0.45 − k8) and
    // (0.35 − 0.3) coupled by 100 against 400 on k8, pulls it to 0.45 + 0.05·100/400 /
    // 2 against the pinned windows' 0.45 (equal information): 0.45625.
    let k8 = end.faults.as_array()[7];
    assert!((k8 - 0.45625).abs() < 1e-5, "{k8}");
    assert!((end.faults.as_array()[1] - 0.1).abs() < 1e-6);
    // The held friction's error (σ 0.1 × 0.3 = 0.03) moves the gain drift by
    // 200 / 1600 per unit: 0.00375 shared, more windows do not shrink it.
    let shared = 0.1 * crate::flight::window::HELD_ERROR_SCALE[0] * 200.0 / 1600.0;
    assert!(
        (end.shared_std[7] - shared).abs() < 1e-6,
        "{:?}",
        end.shared_std
    );
    // Windows that disagree with the held friction (read 0.9 at σ 0.1, twice) are not
    // read at their end either.
    let apart = flight([0.9, 0.1, 0.0, 0.0, 0.0, 0.0, 0.5, 0.45, 0.0]);
    assert!(matches!(
        apart
            .final_reading(FLIGHT_MAX_FRICTION_STD)
            .unwrap()
            .verdict,
        Err(WindowReason::Unconfirmed { .. })
    ));
    // Without a pinned window the end is the reading as it goes.
    let read = FaultVector::new([0.35, 0.1, 0.0, 0.0, 0.0, 0.0, 0.5, 0.45, 0.0]).unwrap();
    let mut plain = WindowFusion::EMPTY;
    for _ in 0..4 {
        plain.add(&read, &loose, &ONES).unwrap();
    }
    let (end, going) = (
        plain.final_reading(FLIGHT_MAX_FRICTION_STD).unwrap(),
        plain.reading(FLIGHT_MAX_FRICTION_STD).unwrap(),
    );
    assert!(matches!(
        end.verdict,
        Err(WindowReason::TurbulenceTooHigh { .. })
    ));
    assert_eq!((end.faults, end.verdict), (going.faults, going.verdict));
    assert!(!end.friction_held);
}
