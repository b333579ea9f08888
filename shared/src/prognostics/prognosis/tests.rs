//! Unit tests of [`super`] (`prognosis`).

use super::*;
use crate::physics::fault::FaultVector;

/// A deterministic scatter in ±`amp` (no RNG needed).
fn wiggle(i: u32, amp: f32) -> f32 {
    amp * (((i * 7919 + 13) % 101) as f32 / 50.0 - 1.0)
}

fn feed(levels: impl Fn(u32) -> f32, flights: u32) -> FaultTrend {
    feed_with(levels, |_| None, flights, &TrendSettings::DEFAULT)
}

/// Flights 100.. with levels `levels(f)` and standard deviations `std(f)`.
fn feed_with(
    levels: impl Fn(u32) -> f32,
    std: impl Fn(u32) -> Option<f32>,
    flights: u32,
    s: &TrendSettings,
) -> FaultTrend {
    let mut t = FaultTrend::new();
    for f in 0..flights {
        assert!(t.update(100 + f, false, levels(f), std(f), s));
    }
    t
}

fn interval(t: &FaultTrend, s: &TrendSettings) -> (f32, f32, f32) {
    let r = t.estimate(Some(0.5), s).unwrap().rul.unwrap();
    (r.lower.unwrap(), r.rul.unwrap(), r.upper.unwrap())
}

#[test]
fn a_line_gives_its_rul_and_a_precise_line_is_read_as_linear() {
    // 0.01 per flight from 0.05: reaches 0.5 at flight 45; 20 flights seen (0..19).
    let line = |f: u32| 0.05 + 0.01 * f as f32;
    let s = TrendSettings::DEFAULT;
    let e = feed(line, 20).estimate(Some(0.5), &s).unwrap();
    assert_eq!(e.growth, Growth::Linear, "{e:?}");
    assert!((e.slope - 0.01).abs() < 1e-4 && (e.level - 0.24).abs() < 1e-3);
    // At the noise floor slow accelerations explain 20 flights as well: they pull
    // the median a little early, and the interval holds the truth.
    let (lo, rul, hi) = interval(&feed(line, 20), &s);
    assert!(
        (rul - 26.0).abs() < 1.3 && lo <= 26.0 && hi >= 26.0,
        "{lo} {rul} {hi}"
    );
    // Precise observations leave the line alone.
    let precise = TrendSettings {
        noise_floor: 1e-4,
        systematic: 1e-3,
        ..s
    };
    let t = feed_with(line, |_| Some(1e-4), 20, &precise);
    let e = t.estimate(Some(0.5), &precise).unwrap();
    assert!(e.weight > 0.9, "{e:?}");
    let (lo, rul, hi) = interval(&t, &precise);
    assert!(
        (rul - 26.0).abs() < 0.05 && lo <= 26.0 && hi >= 26.0,
        "{lo} {rul} {hi}"
    );
}

#[test]
fn precise_exponential_and_power_law_growth_are_recognised() {
    let s = TrendSettings {
        noise_floor: 1e-4,
        ..TrendSettings::DEFAULT
    };
    // y = 0.02·e^{0.0879 f}: reaches 0.5 at f = ln(25)/0.0879 = 36.6; 25 flights seen.
    let y = |f: u32| 0.02 * (0.0879 * f as f64).exp() as f32;
    let t = feed_with(y, |_| Some(0.002), 25, &s);
    let e = t.estimate(Some(0.5), &s).unwrap();
    assert!(
        matches!(e.growth, Growth::Exponential(r) if r > 0.05),
        "{e:?}"
    );
    let truth = (25.0f32).ln() / 0.0879 - 24.0;
    let (lo, rul, hi) = interval(&t, &s);
    assert!(
        (rul - truth).abs() < 0.1 * truth && lo <= truth && hi >= truth,
        "{lo} {rul} {hi} truth {truth}"
    );
    // At the default noise floor the same history leaves the shape open: the truth stays
    // inside.
    let (lo, _, hi) = interval(&feed(y, 25), &TrendSettings::DEFAULT);
    assert!(lo <= truth && hi >= truth, "{lo}..{hi} truth {truth}");
    // y = 0.05 + 0.25·(f/20)²: reaches 0.5 at f = 20·√1.8 = 26.8; 20 flights seen.
    let q = |f: u32| 0.05 + 0.25 * (f as f32 / 20.0).powi(2);
    let t = feed_with(q, |_| Some(0.002), 20, &s);
    let e = t.estimate(Some(0.5), &s).unwrap();
    assert_eq!(e.growth, Growth::PowerLaw(2.0), "{e:?}");
    let truth = 20.0 * 1.8f32.sqrt() - 19.0;
    let (lo, rul, hi) = interval(&t, &s);
    assert!(
        (rul - truth).abs() < 0.1 * truth && lo <= truth && hi >= truth,
        "{lo} {rul} {hi} truth {truth}"
    );
}

#[test]
fn scatter_and_the_systematic_error_widen_the_interval() {
    let no_bias = TrendSettings {
        systematic: 0.0,
        noise_floor: 0.002,
        ..TrendSettings::DEFAULT
    };
    let line = |f: u32| 0.1 + 0.01 * f as f32;
    let clean = feed_with(line, |_| None, 20, &no_bias);
    let noisy = feed_with(|f| line(f) + wiggle(f, 0.02), |_| None, 20, &no_bias);
    let (cl, _, cu) = interval(&clean, &no_bias);
    let (nl, _, nu) = interval(&noisy, &no_bias);
    assert!(
        nu - nl > 2.0 * (cu - cl),
        "clean {cl}..{cu}, noisy {nl}..{nu}"
    );
    // Truth: reaches 0.5 at flight 40, i.e. 21 flights after the newest (19).
    assert!(nl <= 21.0 && nu >= 21.0, "noisy {nl}..{nu}");
    let biased = TrendSettings {
        systematic: 0.015,
        ..no_bias
    };
    let (bl, _, bu) = interval(&feed_with(line, |_| None, 20, &biased), &biased);
    assert!(
        bu - bl > 1.5 * (cu - cl),
        "without {cl}..{cu}, with {bl}..{bu}"
    );
}

#[test]
fn flights_are_weighted_by_their_stated_standard_deviation() {
    // Every other test scatters ±0.04 (and says so), the others ±0.002: weighted by what
    // they state, the RUL stays near the truth; taken as equals, it wanders.
    let s = TrendSettings::DEFAULT;
    let level = |f: u32| {
        let amp = if f % 2 == 1 { 0.04 } else { 0.002 };
        0.1 + 0.01 * f as f32 + wiggle(f, amp)
    };
    let stated = |f: u32| Some(if f % 2 == 1 { 0.04 } else { 0.002 });
    // Truth: 0.5 at flight 40, 21 flights after the newest (19).
    let (wl, weighted, wu) = interval(&feed_with(level, stated, 20, &s), &s);
    let (el, equal, eu) = interval(&feed(level, 20), &s);
    assert!(
        (weighted - 21.0).abs() < 0.5 * (equal - 21.0).abs(),
        "weighted {weighted}, as equals {equal}"
    );
    assert!(
        wu - wl < eu - el,
        "weighted {wl}..{wu}, as equals {el}..{eu}"
    );
}

#[test]
fn one_outlier_barely_moves_the_rul() {
    let base = |f: u32| 0.1 + 0.01 * f as f32 + wiggle(f, 0.004);
    let s = TrendSettings::DEFAULT;
    let clean = feed(base, 20).estimate(Some(0.5), &s).unwrap();
    let hit = feed(|f| if f == 12 { base(f) + 0.4 } else { base(f) }, 20)
        .estimate(Some(0.5), &s)
        .unwrap();
    assert_eq!(hit.outliers, 1);
    let a = clean.rul.unwrap().rul.unwrap();
    let b = hit.rul.unwrap().rul.unwrap();
    assert!((a - b).abs() < 0.1 * a, "clean {a}, with outlier {b}");
    // Without the down-weighting the same outlier moves it far more.
    let mut no_guard = s;
    no_guard.outlier_z = f64::INFINITY;
    let mut t = FaultTrend::new();
    for f in 0..20 {
        t.update(
            100 + f,
            false,
            if f == 12 { base(f) + 0.4 } else { base(f) },
            None,
            &no_guard,
        );
    }
    let c = t
        .estimate(Some(0.5), &no_guard)
        .unwrap()
        .rul
        .unwrap()
        .rul
        .unwrap();
    assert!((a - c).abs() > 3.0 * (a - b).abs(), "unguarded {c}");
}

#[test]
fn flat_levels_have_no_rul_and_reached_levels_have_zero() {
    let s = TrendSettings::DEFAULT;
    let flat = feed(|f| 0.02 + wiggle(f, 0.003), 15)
        .estimate(Some(0.5), &s)
        .unwrap();
    assert_eq!(flat.rul.unwrap().rul, None);
    let over = feed(|f| 0.6 + 0.001 * f as f32, 5)
        .estimate(Some(0.5), &s)
        .unwrap();
    assert_eq!(over.rul.unwrap().rul, Some(0.0));
    assert!(FaultTrend::new().estimate(Some(0.5), &s).is_none());
}

#[test]
fn the_past_and_non_finite_values_are_ignored() {
    let s = TrendSettings::DEFAULT;
    let mut t = FaultTrend::new();
    assert!(t.update(5, false, 0.1, None, &s));
    assert!(!t.update(5, false, 0.2, None, &s));
    assert!(!t.update(4, false, 0.2, None, &s));
    assert!(!t.update(6, false, f32::NAN, None, &s));
    assert_eq!(t.observations(), 1);
    // In-flight entries count at their flight, after its preflight, as many as flown; a
    // later preflight must still be newer, and nothing goes back.
    assert!(t.update(5, true, 0.11, Some(0.02), &s));
    assert!(t.update(5, true, 0.12, Some(0.02), &s));
    // Without a deviation an in-flight value was not read in flight.
    assert!(!t.update(5, true, 0.12, None, &s));
    assert!(!t.update(5, false, 0.1, None, &s));
    assert!(!t.update(4, true, 0.1, Some(0.02), &s));
    assert!(t.update(6, false, 0.1, None, &s));
    assert_eq!(t.observations(), 4);
}

#[test]
fn an_in_flight_entry_counts_its_own_noise() {
    // Preflights on a line, and one in-flight entry 0.1 above it at flight 110.
    let with = |std: f32, flight_scale: f64| {
        let s = TrendSettings {
            flight_scale,
            ..TrendSettings::DEFAULT
        };
        let mut t = FaultTrend::new();
        for f in 0..20u32 {
            let level = 0.01 * f as f32;
            assert!(t.update(100 + f, false, level, Some(0.0625), &s));
            if f == 10 {
                assert!(t.update(100 + f, true, level + 0.1, Some(std), &s));
            }
        }
        t.estimate(Some(0.5), &s).unwrap()
    };
    // Its stated deviation counts `flight_scale` times.
    assert_eq!(with(0.03125, 4.0), with(0.125, 1.0));
    // The larger its own noise, the less it pulls the trend.
    let (a, b) = (with(0.0625, 1.0).level, with(0.0625, 8.0).level);
    assert!(a > b && b > 0.19, "level {a} at scale 1, {b} at scale 8");
}

#[test]
fn a_flights_reading_is_trended_and_its_windows_own_entries_are_not() {
    let s = TrendSettings::DEFAULT;
    let at = |f: u32, friction: f32| {
        let mut k = *FaultVector::NOMINAL.as_array();
        k[0] = friction;
        HealthRecord::new(
            f,
            FaultVector::new(k).unwrap(),
            0.01,
            crate::model::domain::Domain::Within,
        )
        .with_std([0.02; FAULT_COUNT])
    };
    let mut with_windows = HealthTrend::new();
    let mut preflights = HealthTrend::new();
    for f in 0..8u32 {
        let level = 0.1 + 0.01 * f as f32;
        with_windows.update(&at(f, level), &s);
        preflights.update(&at(f, level), &s);
        // Two windows far off the line, then their flight's reading on it.
        with_windows.update(&at(f, 0.9).in_flight(1), &s);
        with_windows.update(&at(f, 0.8).in_flight(2), &s);
        with_windows.update(&at(f, level).flight_reading(2), &s);
    }
    let friction = |t: &HealthTrend| t.fault(0).unwrap().observations();
    assert_eq!((friction(&with_windows), friction(&preflights)), (16, 8));
    // A flight's component it states no deviation for (held at its preflight's, or
    // not determined) is not trended; its other components are.
    let mut held = at(8, 0.18).flight_reading(2);
    held.std = crate::prognostics::health::ComponentStd::new({
        let mut sd = [0.02; FAULT_COUNT];
        sd[0] = f32::NAN;
        sd
    });
    with_windows.update(&at(8, 0.18), &s);
    with_windows.update(&held, &s);
    assert_eq!(friction(&with_windows), 17);
    assert_eq!(with_windows.fault(7).unwrap().observations(), 18);
    let level = |t: &HealthTrend| t.estimates(&s)[0].unwrap().level;
    assert_eq!(with_windows.skipped(), 0);
    preflights.update(&at(8, 0.18), &s);
    let (a, b) = (level(&with_windows), level(&preflights));
    assert!((a - b).abs() < 0.005 && (a - 0.18).abs() < 0.005, "{a} {b}");
}

#[test]
fn records_outside_the_domain_do_not_feed_the_trend() {
    use crate::model::domain::{Domain, OutsideReason};
    let s = TrendSettings::DEFAULT;
    let mut k = *FaultVector::NOMINAL.as_array();
    let mut trend = HealthTrend::new();
    for f in 0..6u32 {
        k[0] = 0.1 + 0.02 * f as f32;
        let domain = if f == 3 {
            Domain::Outside(OutsideReason::NoMotion { travel: 0.0 })
        } else {
            Domain::Within
        };
        let r = HealthRecord::new(f, FaultVector::new(k).unwrap(), 0.01, domain);
        trend.update(&r, &s);
    }
    assert_eq!(trend.skipped(), 1);
    assert_eq!(trend.fault(0).unwrap().observations(), 5);
    let e = trend.estimates(&s);
    assert!(e[6].is_none(), "the eccentricity phase has no trend");
    assert!(e[0].unwrap().rul.unwrap().rul.is_some());
    assert!(e[1].unwrap().rul.unwrap().rul.is_none());
}

#[test]
fn a_weak_magnets_depth_is_trended_from_its_first_reading() {
    use crate::model::domain::Domain;
    use crate::physics::magnets::WeakMagnet;
    let s = TrendSettings::DEFAULT;
    let preflight = |f: u32, depth: f32| {
        HealthRecord::new(f, FaultVector::NOMINAL, 0.01, Domain::Within)
            .with_magnet(&WeakMagnet::new(depth, 1.2))
            .with_magnet_std(0.03)
    };
    let mut trend = HealthTrend::new();
    let depths = |t: &HealthTrend| t.fault(WEAK_MAGNET_TREND).unwrap().observations();
    // Healthy: nothing read, no trend, no RUL.
    for f in 0..5 {
        trend.update(&preflight(f, 0.0), &s);
    }
    assert_eq!(depths(&trend), 0);
    assert!(trend.estimates(&s)[WEAK_MAGNET_TREND].is_none());
    // The magnet read from flight 5, 0.02 more each flight (0.1 … 0.36 by flight 18); one
    // preflight in between reads none and counts as 0 ± NO_MAGNET_STD; a flight's reading
    // holds its preflight's magnet and adds nothing.
    for f in 5..19 {
        let depth = if f == 9 {
            0.0
        } else {
            0.1 + 0.02 * (f - 5) as f32
        };
        trend.update(&preflight(f, depth), &s);
        trend.update(&preflight(f, depth).flight_reading(3), &s);
    }
    assert_eq!(depths(&trend), 14);
    let e = trend.estimates(&s)[WEAK_MAGNET_TREND].unwrap();
    assert!((e.level - 0.36).abs() < 0.02, "{e:?}");
    // 0.5 is reached at flight 25: 7 flights after the newest.
    let r = e.rul.unwrap();
    let (lo, rul, hi) = (r.lower.unwrap(), r.rul.unwrap(), r.upper.unwrap());
    assert!(
        (rul - 7.0).abs() < 1.5 && lo <= 7.0 && hi >= 7.0,
        "{lo} {rul} {hi}"
    );
    // The trend's names and thresholds follow the fault vector's, then the magnet's.
    assert_eq!(TREND_NAMES[WEAK_MAGNET_TREND], "weak_magnet");
    assert_eq!(
        TREND_NAMES[..FAULT_COUNT],
        crate::physics::fault::FAULT_NAMES
    );
    assert_eq!(s.threshold(WEAK_MAGNET_TREND), Some(0.5));
    assert!(is_trended(WEAK_MAGNET_TREND) && !is_trended(TREND_COUNT));
}
