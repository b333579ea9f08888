//! Prognostics on the ground: simulated degradations (`host-sim degrade`), the trend and RUL
//! report of a history (`host-sim prognose`), its picture, and the ProgPy-style evaluation
//! (`host-sim prognostics`: α-λ accuracy and prognostic horizon).
//!
//! One simulated flight = one reference-model test (≈ 0.05 s) + one onboard identification
//! (≈ 1 s), and with `--windows N` N windows of flight flown and identified in flight
//! (≈ 0.4 s each); flights run in parallel. The trend and RUL are `shared::prognosis`, the code the
//! controller runs.

use std::path::Path;

use anyhow::{anyhow, bail, Context, Result};
use plotters::prelude::*;
use rayon::prelude::*;
use shared::actuator::ActuatorRecord;
use shared::domain::DomainLimits;
use shared::fault::{FAULT_COUNT, FAULT_NAMES};
use shared::fusion::{WindowFusion, FLIGHT_MAX_FRICTION_STD};
use shared::health::HealthRecord;
use shared::prognosis::{
    trended_value, FaultTrend, Growth, HealthTrend, TrendEstimate, TrendSettings, TREND_COUNT,
    TREND_NAMES, WEAK_MAGNET_TREND,
};
use shared::{ActuatorParams, Calibration, FaultVector};

use crate::fdi::identify::identify;
use crate::fdi::window::{flight_entry, held_from, identify_window, WindowIdentified};
use crate::files::health::{HistoryRow, Intrusion};
use crate::plant::aero::FlightWindow;
use crate::plant::reference::{
    Anomaly, Demagnetization, ReferenceModel, ReferenceSettings, Scenario,
};
use crate::studies::flight::{flight_record, ALL_WINDOWS};

/// How the faults grow from the start vector to the end vector over the flights.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum PathShape {
    /// Uniform growth per flight.
    Linear,
    /// Exponential growth, `(e^{3s} − 1)/(e^3 − 1)` of the way at fraction `s` of the flights
    /// (a fifth of the change in the first half, as wear feeding on itself).
    #[value(alias = "accelerating")]
    Exponential,
    /// Power-law growth, `s^2.2` of the way (spalling, crack growth); an exponent the
    /// trend's power-law family does not hold.
    PowerLaw,
}

impl PathShape {
    pub const ALL: [Self; 3] = [Self::Linear, Self::Exponential, Self::PowerLaw];

    pub fn name(self) -> &'static str {
        match self {
            Self::Linear => "linear",
            Self::Exponential => "exponential",
            Self::PowerLaw => "power law",
        }
    }
}

/// Rate of [`PathShape::Exponential`] over the whole path.
const ACCELERATION: f64 = 3.0;

/// Exponent of [`PathShape::PowerLaw`].
const POWER: f64 = 2.2;

/// A degradation path: `flights` preflights from `start` (flight 0) to `end` (the last), and
/// optionally one magnet losing its flux along the same shape.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DegradationPath {
    pub start: FaultVector,
    pub end: FaultVector,
    pub flights: u32,
    pub shape: PathShape,
    /// One weak magnet: its pole, and the share of its flux lost by the last flight (none
    /// at flight 0).
    pub magnet: Option<MagnetLoss>,
}

/// One magnet's flux lost along a [`DegradationPath`]: pole `pole` (0 … 2P − 1, as
/// `preflight --demagnetization partial:LOSS@POLE` counts them), `end` of its flux lost by
/// the path's last flight.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MagnetLoss {
    pub pole: u32,
    pub end: f64,
}

impl MagnetLoss {
    /// `END@POLE` (END the share of the magnet's flux lost by the last flight, 0 … 1; POLE
    /// one of the reference actuator's), read as `partial:END@POLE` is
    /// ([`Demagnetization::parse`]).
    pub fn parse(text: &str) -> Result<Self, String> {
        if !text.contains('@') {
            return Err(format!("{text:?}: expected END@POLE, as 0.6@3"));
        }
        let Demagnetization::Partial { loss, pole } =
            Demagnetization::parse(&format!("partial:{text}"))?
        else {
            return Err(format!("{text:?}: expected END@POLE, as 0.6@3"));
        };
        let poles = shared::magnets::poles(&ActuatorParams::REFERENCE);
        if pole >= poles {
            return Err(format!(
                "pole {pole}: the actuator has poles 0 … {}",
                poles - 1
            ));
        }
        Ok(Self { pole, end: loss })
    }
}

impl DegradationPath {
    /// Fraction of the way at `flight` (fractional flights allowed).
    fn progress(&self, flight: f64) -> f64 {
        let s = flight / f64::from(self.flights.saturating_sub(1).max(1));
        match self.shape {
            PathShape::Linear => s,
            PathShape::Exponential => (ACCELERATION * s).exp_m1() / ACCELERATION.exp_m1(),
            PathShape::PowerLaw => s.max(0.0).powf(POWER),
        }
    }

    /// The actuator's true fault vector at `flight`.
    pub fn at(&self, flight: u32) -> FaultVector {
        let p = self.progress(f64::from(flight)) as f32;
        let mut k = [0f32; FAULT_COUNT];
        for ((o, a), b) in k
            .iter_mut()
            .zip(self.start.as_array())
            .zip(self.end.as_array())
        {
            *o = a + (b - a) * p;
        }
        FaultVector::saturating(k)
    }

    /// The weak magnet's true loss at `flight` (`None`: no magnet on this path).
    pub fn magnet_at(&self, flight: u32) -> Option<MagnetLoss> {
        self.magnet.map(|m| MagnetLoss {
            pole: m.pole,
            end: m.end * self.progress(f64::from(flight)),
        })
    }

    /// The (fractional) flight at which trended quantity `i` ([`TREND_NAMES`]: a
    /// component's deviation from nominal, or the weak magnet's depth) reaches `threshold`,
    /// if it does within the path: the true end of life.
    pub fn end_of_life(&self, i: usize, threshold: f32) -> Option<f64> {
        let (a, b) = if i == WEAK_MAGNET_TREND {
            (0.0, self.magnet?.end)
        } else {
            let dev = |v: &FaultVector| v.deviations().get(i).copied().flatten().map(f64::from);
            (dev(&self.start)?, dev(&self.end)?)
        };
        let t = f64::from(threshold);
        if a >= t || b < t || b <= a {
            return None;
        }
        let q = (t - a) / (b - a);
        let s = match self.shape {
            PathShape::Linear => q,
            PathShape::Exponential => (q * ACCELERATION.exp_m1()).ln_1p() / ACCELERATION,
            PathShape::PowerLaw => q.powf(1.0 / POWER),
        };
        Some(s * f64::from(self.flights.saturating_sub(1).max(1)))
    }
}

/// Seeds of flight `flight` of run `seed`: (reference model, GA).
fn flight_seeds(seed: u64, flight: u32) -> (u64, u64) {
    let rm = seed.wrapping_mul(100_003).wrapping_add(u64::from(flight));
    (rm, rm.wrapping_add(1))
}

/// The reference model that plays intrusion `intrusion`.
fn intrusion_model(intrusion: Intrusion, rm: ReferenceModel) -> ReferenceModel {
    match intrusion {
        Intrusion::Jammed => rm.with_anomaly(Anomaly::Jammed),
        Intrusion::OpenPhase => rm.with_anomaly(Anomaly::OpenPhase(1)),
        Intrusion::OtherCommand => {
            let mut chirp = rm.test().chirp;
            chirp.amplitude *= 2.0;
            rm.with_command(chirp)
        }
    }
}

/// SplitMix64's finaliser: a well-mixed 64-bit word from `z`.
fn splitmix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Which flights of run `seed` meet an intrusion: each with probability `share`
/// (deterministic in seed and flight), the kind in turn.
pub fn intrusion(seed: u64, flight: u32, share: f64) -> Option<Intrusion> {
    let z = splitmix(
        seed.wrapping_mul(0x9E37_79B9_7F4A_7C15)
            .wrapping_add(u64::from(flight).wrapping_mul(0xBF58_476D_1CE4_E5B9)),
    );
    let u = (z >> 11) as f64 / (1u64 << 53) as f64;
    (u < share).then(|| Intrusion::ALL[(z % 3) as usize])
}

/// The window of flight `n` (≥ 1) of flight `flight` of run `seed` flies: a phase and a
/// turbulence of [`ALL_WINDOWS`], drawn deterministically (SplitMix64).
pub fn flown_window(seed: u64, flight: u32, n: u8) -> FlightWindow {
    let z = splitmix(
        seed.wrapping_mul(0xD1B5_4A32_D192_ED03)
            .wrapping_add(u64::from(flight).wrapping_mul(0x9E37_79B9_7F4A_7C15))
            .wrapping_add(u64::from(n).wrapping_mul(0xBF58_476D_1CE4_E5B9)),
    );
    ALL_WINDOWS[(z % ALL_WINDOWS.len() as u64) as usize]
}

/// A standard normal number drawn deterministically from `key` (SplitMix64, Box–Muller).
fn normal_of(key: u64) -> f64 {
    let a = splitmix(key);
    let b = splitmix(a ^ 0x6A09_E667_F3BC_C909);
    let u1 = ((a >> 11) as f64 + 0.5) / (1u64 << 53) as f64;
    let u2 = (b >> 11) as f64 / (1u64 << 53) as f64;
    (-2.0 * u1.ln()).sqrt() * (core::f64::consts::TAU * u2).cos()
}

/// The history of run `seed` as an ideal identification of standard deviation `sigma` would
/// have logged it, in place of the onboard FDI: each preflight without an intrusion reads its
/// true fault vector plus Gaussian noise of `sigma` on every component but the eccentricity
/// phase (drawn from the run, the flight and the component; clamped to each range), states
/// `sigma` as every component's deviation and is `within` the domain. A flight with an
/// intrusion keeps the FDI's record (its domain verdict); in-flight entries are left out, and
/// so is a row without a truth. What the trend would predict from readings of that precision
/// (docs/prognostics.md, "What the readings cost").
pub fn ideal_readings(rows: &[HistoryRow], sigma: f32, seed: u64) -> Vec<HistoryRow> {
    rows.iter()
        .filter(|r| r.record.window == 0)
        .filter_map(|r| {
            let truth = r.truth?;
            if r.intrusion.is_some() {
                return Some(*r);
            }
            let mut k = *truth.as_array();
            for (i, x) in k.iter_mut().enumerate() {
                if shared::prognosis::is_trended(i) {
                    let key = seed
                        .wrapping_mul(0x9E37_79B9_7F4A_7C15)
                        .wrapping_add(
                            u64::from(r.record.flight).wrapping_mul(0xD1B5_4A32_D192_ED03),
                        )
                        .wrapping_add(i as u64);
                    *x += sigma * normal_of(key) as f32;
                }
            }
            let mut record = HealthRecord::new(
                r.record.flight,
                FaultVector::saturating(k),
                r.record.fitness,
                shared::domain::Domain::Within,
            );
            record.std = shared::health::ComponentStd::new([sigma; FAULT_COUNT]);
            record.day = r.record.day;
            Some(HistoryRow { record, ..*r })
        })
        .collect()
}

/// The preflights of a history with their lean taken off, an oracle that knows the truth:
/// each component's mean error (reading − truth, in the fault vector's units) over the run's
/// trusted preflights whose true deviation is at least [`shared::fault::DETECTION_THRESHOLD`]
/// (nearer nominal a deviation folds at zero) is subtracted from every preflight's reading of
/// it. In-flight entries and rows without a truth are left out. What the trend would predict
/// if the identification's error were its scatter alone (docs/prognostics.md, "What the
/// readings cost").
pub fn lean_removed(rows: &[HistoryRow]) -> Vec<HistoryRow> {
    let preflights = || {
        rows.iter()
            .filter(|r| r.record.window == 0 && r.truth.is_some())
    };
    let mut sum = [0.0f64; FAULT_COUNT];
    let mut count = [0u32; FAULT_COUNT];
    for r in preflights().filter(|r| r.record.is_trusted()) {
        let Some(truth) = r.truth else { continue };
        let deviations = truth.deviations();
        let pairs = truth.as_array().iter().zip(r.record.faults.as_array());
        for (i, (t, y)) in pairs.enumerate() {
            if deviations[i].is_some_and(|d| d >= shared::fault::DETECTION_THRESHOLD) {
                sum[i] += f64::from(y - t);
                count[i] += 1;
            }
        }
    }
    preflights()
        .map(|r| {
            let mut k = *r.record.faults.as_array();
            for (i, x) in k.iter_mut().enumerate() {
                if count[i] > 0 {
                    *x -= (sum[i] / f64::from(count[i])) as f32;
                }
            }
            let mut row = *r;
            row.record.faults = FaultVector::saturating(k);
            row
        })
        .collect()
}

/// The seed step between a flight's repeated tests (`degrade`'s `repeat`).
const REPEAT_STREAM: u64 = 0x9e37_79b9_7f4a_7c15;

/// One record of a preflight whose test was played `readings.len()` times
/// (`shared::repeat::RepeatedTests`, the controller's).
pub fn repeated_reading(readings: &[HealthRecord]) -> HealthRecord {
    let Some(first) = readings.first() else {
        return HealthRecord::new(0, FaultVector::NOMINAL, 0.0, shared::domain::Domain::Within);
    };
    let mut tests = shared::repeat::RepeatedTests::EMPTY;
    tests.add(first);
    for r in readings.iter().skip(1) {
        tests.add(r);
    }
    tests.reading()
}

/// Simulates the preflight of every flight of `path` (RM trace with I_ref noise `noise`,
/// onboard identification with its uncertainty, domain verdict), in parallel; a share
/// `intrusions` of the flights meets an [`Intrusion`]. With `windows` > 0, each flight then
/// flies that many windows ([`flown_window`]: the reference model flying the surface with
/// the chirp superimposed, the same actuator and I_ref noise), each identified in flight
/// ([`identify_window`]) and kept as an in-flight entry ([`HealthRecord::window`] 1, 2, …;
/// `Outside` windows with their reason); from two windows on, the flight's reading from
/// those that enter (`shared::fusion`) follows them ([`flight_entry`], window
/// `FLIGHT_READING`; none when no window entered). With `repeat` > 1 a preflight whose
/// first test is trusted plays as many tests as its noise calls for, at most `repeat`
/// (`ActuatorRecord::tests_called_for`; the I_ref noise drawn anew each time, an intrusion
/// spoiling the first only), its record is their readings' mean ([`repeated_reading`]), and
/// its windows hold the last test's reading. Rows in
/// (flight, window) order. `tick` is called after each flight.
pub fn degrade(
    path: &DegradationPath,
    noise: f64,
    seed: u64,
    intrusions: f64,
    windows: u8,
    repeat: u8,
    tick: &(dyn Fn() + Sync),
) -> Result<Vec<HistoryRow>> {
    let rm = ReferenceModel::new(ReferenceSettings::REFERENCE);
    let params = ActuatorParams::REFERENCE;
    let window_record = flight_record(&ActuatorRecord::REFERENCE);
    let flights: Vec<Vec<HistoryRow>> = (0..path.flights)
        .into_par_iter()
        .map(|flight| -> Result<Vec<HistoryRow>> {
            let truth = path.at(flight);
            let (rm_seed, ga_seed) = flight_seeds(seed, flight);
            let intruded = intrusion(seed, flight, intrusions);
            let rm = match path.magnet_at(flight) {
                Some(m) if m.end > 0.0 => rm.with_demagnetization(Demagnetization::Partial {
                    loss: m.end,
                    pole: m.pole,
                }),
                _ => rm,
            };
            let flying = rm.with_test(window_record.test);
            let model = intruded.map_or(rm, |i| intrusion_model(i, rm));
            // One test of the preflight, played by `model` with the I_ref noise of `rm_seed`,
            // identified and judged, and its record.
            let test = |model: &ReferenceModel, rm_seed: u64| -> Result<_> {
                let trace = model
                    .simulate(&Scenario {
                        faults: truth,
                        current_ref_noise: noise,
                        seed: rm_seed,
                    })
                    .trace
                    .with_test(*rm.test());
                let measured = trace.measured(&params)?;
                let id = identify(&measured, &Calibration::REFERENCE_ACTUATOR, ga_seed, false)?;
                let domain = id.domain(
                    &trace.domain_monitor(&params),
                    &DomainLimits::REFERENCE_ACTUATOR,
                );
                let record = id.health_record(flight, domain);
                Ok((id, domain, record))
            };
            let (mut id, mut domain, mut record) = test(&model, rm_seed)?;
            // As the controller: the tests the first one's noise calls for, at most `repeat`.
            let mut first = shared::repeat::RepeatedTests::EMPTY;
            first.add(&record);
            let tests = first.called_for(&ActuatorRecord {
                max_tests: u32::from(repeat),
                ..ActuatorRecord::REFERENCE
            });
            if tests > 1 {
                let mut readings = vec![record];
                for j in 1..u64::from(tests) {
                    let again = rm_seed.wrapping_add(REPEAT_STREAM.wrapping_mul(j));
                    let (last, last_domain, reading) = test(&rm, again)?;
                    readings.push(reading);
                    // The windows hold the last test's reading, as the controller's do.
                    (id, domain) = (last, last_domain);
                }
                record = repeated_reading(&readings);
            }
            let mut rows = vec![HistoryRow {
                record,
                truth: Some(truth),
                intrusion: intruded,
            }];
            // The windows hold the shorts at this flight's preflight reading, with its
            // uncertainty, when it is `within` (a window cannot tell them from an
            // eccentricity).
            let held = held_from(&id, domain == shared::domain::Domain::Within);
            let mut fusion = WindowFusion::EMPTY;
            let mut entered = Vec::new();
            for n in 1..=windows {
                let w_seed = rm_seed.wrapping_add(7_919 * u64::from(n));
                let sim = flying
                    .with_flight(Some(flown_window(seed, flight, n)))
                    .simulate(&Scenario {
                        faults: truth,
                        current_ref_noise: noise,
                        seed: w_seed,
                    });
                let measured = sim.trace.measured(&window_record.params)?;
                let w = identify_window(&sim.trace, &measured, &window_record, held, w_seed + 1)?;
                rows.push(HistoryRow {
                    record: w.record(flight, n),
                    truth: Some(truth),
                    intrusion: None,
                });
                if w.enter(&mut fusion) {
                    entered.push(w);
                }
            }
            if windows >= 2 {
                if let Ok(reading) = fusion.final_reading(FLIGHT_MAX_FRICTION_STD) {
                    let entered: Vec<&WindowIdentified> = entered.iter().collect();
                    rows.push(HistoryRow {
                        record: flight_entry(flight, &reading, &entered),
                        truth: Some(truth),
                        intrusion: None,
                    });
                }
            }
            tick();
            Ok(rows)
        })
        .collect::<Result<_>>()?;
    Ok(flights.into_iter().flatten().collect())
}

/// Parses `--threshold`: one number for every fault, or `name=value` pairs (names as in the
/// CSV header) over [`TrendSettings::DEFAULT`]'s.
pub fn parse_thresholds(text: &str) -> Result<[f32; TREND_COUNT], String> {
    let mut t = TrendSettings::DEFAULT.thresholds;
    let value = |s: &str| -> Result<f32, String> {
        let v: f32 = s
            .trim()
            .parse()
            .map_err(|_| format!("\"{s}\" is not a number"))?;
        if v.is_finite() && v > 0.0 && v <= 1.0 {
            Ok(v)
        } else {
            Err(format!("threshold {v} is outside (0, 1]"))
        }
    };
    if !text.contains('=') {
        let v = value(text)?;
        for (i, o) in t.iter_mut().enumerate() {
            if shared::prognosis::is_trended(i) {
                *o = v;
            }
        }
        return Ok(t);
    }
    for pair in text.split(',') {
        let (name, v) = pair
            .split_once('=')
            .ok_or_else(|| format!("\"{pair}\" is not name=value"))?;
        let i = TREND_NAMES
            .iter()
            .position(|n| *n == name.trim())
            .filter(|&i| shared::prognosis::is_trended(i))
            .ok_or_else(|| {
                let names: Vec<&str> = TREND_NAMES
                    .iter()
                    .enumerate()
                    .filter(|&(i, _)| shared::prognosis::is_trended(i))
                    .map(|(_, n)| *n)
                    .collect();
                format!(
                    "unknown fault \"{}\" (one of {})",
                    name.trim(),
                    names.join(", ")
                )
            })?;
        t[i] = value(v)?;
    }
    Ok(t)
}

/// The trend of a history, up to and including flight `until` (all of it when `None`).
pub fn trend_of(rows: &[HistoryRow], until: Option<u32>, settings: &TrendSettings) -> HealthTrend {
    HealthTrend::from_records(
        rows.iter()
            .map(|r| &r.record)
            .filter(|r| until.is_none_or(|u| r.flight <= u)),
        settings,
    )
}

/// A growth shape as reports print it: `linear`, `exp 0.088` (rate per flight), `power 2`.
pub fn growth_name(g: Growth) -> String {
    match g {
        Growth::Linear => "linear".into(),
        Growth::Exponential(r) => format!("exp {r:.3}"),
        Growth::PowerLaw(p) => format!("power {p}"),
    }
}

fn fmt_flights(v: Option<f32>) -> String {
    match v {
        None => "beyond".into(),
        Some(x) => format!("{x:.1}"),
    }
}

/// The per-fault table `prognose` prints.
pub fn report_text(
    estimates: &[Option<TrendEstimate>; TREND_COUNT],
    settings: &TrendSettings,
) -> String {
    let mut out = format!(
        "{:<15} {:>4} {:>4} {:>7} {:>9} {:>16} {:>7} {:>9} {:>9} {:>19}\n",
        "fault",
        "n",
        "out",
        "level",
        "slope/fl",
        "growth (weight)",
        "thresh",
        "scatter",
        "RUL [fl]",
        "90 % interval"
    );
    for (i, e) in estimates.iter().enumerate() {
        let Some(e) = e else { continue };
        let shape = format!("{} {:.0}%", growth_name(e.growth), 100.0 * e.weight);
        let (thr, rul, interval) = match (settings.threshold(i), e.rul) {
            (Some(t), Some(r)) => (
                format!("{t:.3}"),
                fmt_flights(r.rul),
                format!("[{}, {}]", fmt_flights(r.lower), fmt_flights(r.upper)),
            ),
            _ => ("-".into(), "-".into(), "-".into()),
        };
        out += &format!(
            "{:<15} {:>4} {:>4} {:>7.4} {:>9.5} {:>16} {:>7} {:>9.4} {:>9} {:>19}\n",
            TREND_NAMES[i],
            e.observations,
            e.outliers,
            e.level,
            e.slope,
            shape,
            thr,
            e.scatter,
            rul,
            interval
        );
    }
    out
}

/// The JSON object `prognose --json` prints: per fault its trend and a `rul` entry
/// (`{"flights", "lower", "upper"}`, `null` = beyond the horizon; `rul` itself `null` when the
/// fault has no threshold).
/// The weak magnet over a history's trusted preflights: how many read one, the first flight
/// that did, and the newest preflight's reading (none: it read even magnets).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WeakMagnetSeen {
    pub read: usize,
    pub of: usize,
    pub first_flight: u32,
    pub newest_flight: u32,
    pub newest: shared::magnets::WeakMagnet,
    /// The newest's depth's standard deviation as its record keeps it (`None`: not kept).
    pub newest_std: Option<f32>,
}

/// A stored weak magnet's verdict against the detection threshold: its depth's 90 %
/// interval from the record's deviation and `shared::uncertainty::assess_magnet`'s rule —
/// `FAULT`, `suspect` or `healthy`; `None` without a magnet or a deviation (a record before
/// version 6). The record's deviation is rounded up: its verdict is never bolder than the
/// test's own. O(1).
pub fn stored_magnet_verdict(
    magnets: &shared::magnets::WeakMagnet,
    std: Option<f32>,
) -> Option<((f32, f32), &'static str)> {
    use shared::fault::DETECTION_THRESHOLD;
    use shared::uncertainty::{assess_magnet, magnet_interval, Assessment};
    let std = std.filter(|_| !magnets.is_none())?;
    let verdict = match assess_magnet(magnets.depth, std, DETECTION_THRESHOLD) {
        Assessment::Faulty => "FAULT",
        Assessment::Healthy => "healthy",
        _ => "suspect",
    };
    Some((magnet_interval(magnets.depth, std), verdict))
}

/// [`WeakMagnetSeen`] of `rows` (`None`: no trusted preflight read a weak magnet). O(rows).
pub fn weak_magnet_seen(rows: &[HistoryRow]) -> Option<WeakMagnetSeen> {
    let preflights = rows
        .iter()
        .filter(|r| r.record.window == 0 && r.record.is_trusted());
    let read = || {
        preflights
            .clone()
            .filter(|r| !r.record.magnet.magnets().is_none())
    };
    let first = read().next()?;
    let newest = preflights.clone().next_back()?;
    Some(WeakMagnetSeen {
        read: read().count(),
        of: preflights.clone().count(),
        first_flight: first.record.flight,
        newest_flight: newest.record.flight,
        newest: newest.record.magnet.magnets(),
        newest_std: newest.record.magnet.std(),
    })
}

/// One line of [`WeakMagnetSeen`] for a report.
pub fn weak_magnet_text(seen: &WeakMagnetSeen) -> String {
    let newest = if seen.newest.is_none() {
        "none read".to_string()
    } else {
        let verdict = match (
            seen.newest_std,
            stored_magnet_verdict(&seen.newest, seen.newest_std),
        ) {
            (Some(sd), Some(((lo, hi), v))) => {
                format!(", ± {sd:.3} (1 σ, as stored), 90 % [{lo:.3}, {hi:.3}], {v}")
            }
            _ => ", its deviation not kept".to_string(),
        };
        format!(
            "{:.2} of its flux lost, centred {:.1}° from the encoder's zero{verdict}",
            seen.newest.depth,
            seen.newest.centre.to_degrees()
        )
    };
    format!(
        "weak magnet: read by {} of {} trusted preflights, first at flight {}; flight {} (the \
         newest): {newest}; its depth's trend and RUL are the `weak_magnet` row\n",
        seen.read, seen.of, seen.first_flight, seen.newest_flight
    )
}

pub fn report_json(
    rows: &[HistoryRow],
    trend: &HealthTrend,
    estimates: &[Option<TrendEstimate>; TREND_COUNT],
    settings: &TrendSettings,
) -> serde_json::Value {
    let mut faults = serde_json::Map::new();
    for (i, e) in estimates.iter().enumerate() {
        let Some(e) = e else { continue };
        let rul = e
            .rul
            .map(|r| serde_json::json!({"flights": r.rul, "lower": r.lower, "upper": r.upper}));
        faults.insert(
            TREND_NAMES[i].to_string(),
            serde_json::json!({
                "observations": e.observations,
                "outliers": e.outliers,
                "level": e.level,
                "slope": e.slope,
                "growth": growth_name(e.growth),
                "growth_weight": e.weight,
                "scatter": e.scatter,
                "threshold": settings.threshold(i),
                "rul": rul,
            }),
        );
    }
    serde_json::json!({
        "records": rows.len(),
        "skipped": trend.skipped(),
        "newest_flight": rows.last().map(|r| r.record.flight),
        "horizon": settings.horizon,
        "faults": faults,
        "weak_magnet": weak_magnet_seen(rows).map(|w| serde_json::json!({
            "preflights_read": w.read,
            "preflights": w.of,
            "first_flight": w.first_flight,
            "newest_flight": w.newest_flight,
            "newest_depth": (!w.newest.is_none()).then_some(w.newest.depth),
            "newest_centre_deg": (!w.newest.is_none()).then_some(w.newest.centre.to_degrees()),
            "newest_std": w.newest_std,
            "newest_interval90": stored_magnet_verdict(&w.newest, w.newest_std).map(|(i, _)| [i.0, i.1]),
            "newest_verdict": stored_magnet_verdict(&w.newest, w.newest_std).map(|(_, v)| v),
        })),
    })
}

/// The picture: per fault with a threshold, the identified levels (dots; crosses outside the
/// domain), the truth when known, the fit, the 90 % cone of every plausible growth rate and
/// the threshold with the RUL interval marked on it.
pub fn history_svg(
    out: &Path,
    rows: &[HistoryRow],
    trend: &HealthTrend,
    settings: &TrendSettings,
    title: &str,
) -> Result<()> {
    let estimates = trend.estimates(settings);
    // Faults with a threshold and an estimate; of those, the ones detected or heading for
    // their threshold within the horizon (all of them when none is).
    let candidates: Vec<usize> = (0..TREND_COUNT)
        .filter(|&i| settings.threshold(i).is_some() && estimates[i].is_some())
        .collect();
    let active: Vec<usize> = candidates
        .iter()
        .copied()
        .filter(|&i| {
            estimates[i].is_some_and(|e| {
                e.level > shared::fault::DETECTION_THRESHOLD
                    || e.rul.is_some_and(|r| r.rul.is_some())
            })
        })
        .collect();
    let shown = if active.is_empty() {
        candidates
    } else {
        active
    };
    if shown.is_empty() {
        bail!("nothing to plot: fewer than 3 trusted records");
    }
    let newest = f64::from(rows.last().map_or(0, |r| r.record.flight));
    let first = f64::from(rows.first().map_or(0, |r| r.record.flight));
    let span = (newest - first).max(1.0);
    let rows_n = shown.len().div_ceil(2);
    let root = SVGBackend::new(out, (1200, 40 + 330 * rows_n as u32)).into_drawing_area();
    let e = |e: DrawingAreaErrorKind<_>| anyhow!("drawing {}: {e:?}", out.display());
    root.fill(&WHITE).map_err(e)?;
    let root = root.titled(title, ("sans-serif", 20)).map_err(e)?;
    let panels = root.split_evenly((rows_n, 2));
    for (panel, &i) in panels.iter().zip(&shown) {
        let threshold = f64::from(settings.threshold(i).unwrap_or(1.0));
        let estimate = estimates[i].ok_or_else(|| anyhow!("no estimate"))?;
        let fault: &FaultTrend = trend.fault(i).ok_or_else(|| anyhow!("no trend"))?;
        // Show the future up to the interval's far end (or half the history again).
        let far = estimate
            .rul
            .and_then(|r| r.upper.or(r.rul))
            .map_or(0.5 * span, f64::from)
            .clamp(0.25 * span, 1.5 * span);
        let x_end = newest + 1.15 * far;
        // (flight, level, trusted, in flight)
        let obs: Vec<(f64, f64, bool, bool)> = rows
            .iter()
            .filter(|r| !r.record.is_window())
            .filter_map(|r| {
                let d = trended_value(&r.record, i)?;
                Some((
                    f64::from(r.record.flight),
                    f64::from(d),
                    r.record.is_trusted(),
                    r.record.window != 0,
                ))
            })
            .collect();
        let steps = 200;
        let grid: Vec<f64> = (0..=steps)
            .map(|s| first + (x_end - first) * f64::from(s) / f64::from(steps))
            .collect();
        let fit: Vec<(f64, f64)> = grid
            .iter()
            .map(|&x| (x, fault.band(x, settings).0))
            .collect();
        let cone: Vec<(f64, (f64, f64))> = grid
            .iter()
            .filter(|&&x| x >= newest)
            .map(|&x| (x, fault.envelope(x, settings)))
            .collect();
        let y_hi = obs
            .iter()
            .map(|o| o.1)
            .fold(threshold * 1.15, f64::max)
            .min(1.0);
        let mut chart = ChartBuilder::on(panel)
            .caption(TREND_NAMES[i], ("sans-serif", 16))
            .margin(8)
            .x_label_area_size(32)
            .y_label_area_size(50)
            .build_cartesian_2d(first..x_end, 0.0..y_hi)
            .map_err(e)?;
        chart
            .configure_mesh()
            .x_desc("flight")
            .y_desc("deviation from nominal")
            .draw()
            .map_err(e)?;
        let mut upper: Vec<(f64, f64)> = cone.iter().map(|&(x, (_, h))| (x, h.min(y_hi))).collect();
        let lower: Vec<(f64, f64)> = cone.iter().map(|&(x, (l, _))| (x, l.max(0.0))).collect();
        upper.extend(lower.into_iter().rev());
        chart
            .draw_series(std::iter::once(Polygon::new(upper, RED.mix(0.15))))
            .map_err(e)?
            .label("90 % cone (plausible growth rates)")
            .legend(|(x, y)| Rectangle::new([(x, y - 4), (x + 20, y + 4)], RED.mix(0.15).filled()));
        chart
            .draw_series(LineSeries::new(fit, RED.stroke_width(2)))
            .map_err(e)?
            .label("fit")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED));
        if rows.iter().all(|r| r.truth.is_some()) {
            let truth: Vec<(f64, f64)> = rows
                .iter()
                .filter_map(|r| {
                    Some((
                        f64::from(r.record.flight),
                        // The history keeps no weak magnet's truth.
                        f64::from(r.truth?.deviations().get(i).copied().flatten()?),
                    ))
                })
                .collect();
            chart
                .draw_series(LineSeries::new(truth, BLACK.mix(0.6)))
                .map_err(e)?
                .label("truth")
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.mix(0.6)));
        }
        chart
            .draw_series(
                obs.iter()
                    .filter(|o| o.2 && !o.3)
                    .map(|&(x, y, ..)| Circle::new((x, y), 3, BLUE.filled())),
            )
            .map_err(e)?
            .label("identified (preflight)")
            .legend(|(x, y)| Circle::new((x + 10, y), 3, BLUE.filled()));
        if obs.iter().any(|o| o.2 && o.3) {
            chart
                .draw_series(
                    obs.iter()
                        .filter(|o| o.2 && o.3)
                        .map(|&(x, y, ..)| Circle::new((x, y), 3, MAGENTA.stroke_width(1))),
                )
                .map_err(e)?
                .label("flight's reading (its windows fused)")
                .legend(|(x, y)| Circle::new((x + 10, y), 3, MAGENTA.stroke_width(1)));
        }
        chart
            .draw_series(
                obs.iter()
                    .filter(|o| !o.2)
                    .map(|&(x, y, ..)| Cross::new((x, y), 4, BLACK)),
            )
            .map_err(e)?;
        chart
            .draw_series(LineSeries::new(
                vec![(first, threshold), (x_end, threshold)],
                GREEN.stroke_width(2),
            ))
            .map_err(e)?
            .label(format!("threshold {threshold:.3}"))
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], GREEN));
        if let Some(r) = estimate.rul {
            let lo = r.lower.map_or(x_end, |v| newest + f64::from(v)).min(x_end);
            let hi = r.upper.map_or(x_end, |v| newest + f64::from(v)).min(x_end);
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [(lo, threshold - 0.01 * y_hi), (hi, threshold + 0.01 * y_hi)],
                    GREEN.mix(0.6).filled(),
                )))
                .map_err(e)?;
            if let Some(m) = r.rul {
                let x = newest + f64::from(m);
                if x <= x_end {
                    chart
                        .draw_series(std::iter::once(TriangleMarker::new(
                            (x, threshold),
                            6,
                            GREEN,
                        )))
                        .map_err(e)?
                        .label(format!("RUL {m:.1} flights"))
                        .legend(|(x, y)| TriangleMarker::new((x + 10, y), 5, GREEN));
                }
            }
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK.mix(0.3))
            .label_font(("sans-serif", 11))
            .draw()
            .map_err(e)?;
    }
    root.present().context("writing the plot")?;
    Ok(())
}

/// One evaluation scenario: the start and end vectors of a degradation, its shape and the
/// I_ref noise of its tests.
#[derive(Clone, Debug)]
pub struct EvalScenario {
    /// The fault family (`friction`, `friction + short B`, …).
    pub family: &'static str,
    pub start: [f32; FAULT_COUNT],
    pub end: [f32; FAULT_COUNT],
    /// One magnet's flux lost by the last flight (its pole drawn from the run's seed,
    /// [`magnet_pole`]); `None`: no weak magnet.
    pub magnet: Option<f64>,
    pub shape: PathShape,
    pub noise: f64,
}

impl EvalScenario {
    /// `family, shape, noise N %`.
    pub fn name(&self) -> String {
        format!(
            "{}, {}, noise {:.0} %",
            self.family,
            self.shape.name(),
            100.0 * self.noise
        )
    }

    /// File name of its run `seed`'s history in a cache folder.
    fn file_name(
        &self,
        seed: u64,
        flights: u32,
        intrusions: f64,
        windows: u8,
        repeat: u8,
    ) -> String {
        let slug: String = self
            .name()
            .chars()
            .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
            .collect();
        let windows = match windows {
            0 => String::new(),
            // Flights' readings from their windows (none before them: another name).
            w => format!("-{w}win-fused"),
        };
        let repeat = match repeat {
            0 | 1 => String::new(),
            r => format!("-x{r}"),
        };
        format!("{slug}-{flights}fl{windows}{repeat}-ood{intrusions}-seed{seed}.csv")
    }
}

const H: [f32; FAULT_COUNT] = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0];

const fn with(mut k: [f32; FAULT_COUNT], i: usize, v: f32) -> [f32; FAULT_COUNT] {
    k[i] = v;
    k
}

/// The fault families evaluated: every fault alone, and two pairs growing together; each
/// crosses its default threshold at 80–93 % of the path.
pub const EVAL_FAMILIES: [(&str, [f32; FAULT_COUNT]); 7] = [
    ("friction", with(H, 0, 0.6)),
    ("backlash", with(H, 1, 0.6)),
    ("short A", with(H, 2, 0.36)),
    ("eccentricity", with(H, 5, 0.6)),
    ("gain drift up", with(H, 7, 0.8)),
    ("friction + short B", with(with(H, 0, 0.6), 3, 0.36)),
    ("backlash + gain drift down", with(with(H, 1, 0.6), 7, 0.2)),
];

/// Every family × every path shape × each noise level.
pub fn eval_scenarios(noises: &[f64]) -> Vec<EvalScenario> {
    let mut out = Vec::new();
    for &noise in noises {
        for (family, end) in EVAL_FAMILIES {
            for shape in PathShape::ALL {
                out.push(EvalScenario {
                    family,
                    start: H,
                    end,
                    magnet: None,
                    shape,
                    noise,
                });
            }
        }
    }
    out
}

/// The weak magnet's flux lost by the last flight of its evaluation's paths: it crosses
/// [`TrendSettings::DEFAULT`]'s 0.5 at 80–93 % of the path, as the other families cross
/// theirs.
pub const WEAK_MAGNET_END: f64 = 0.6;

/// The weak magnet's scenarios: one magnet losing its flux to [`WEAK_MAGNET_END`], every path
/// shape, each noise level; the other components nominal.
pub fn weak_magnet_scenarios(noises: &[f64]) -> Vec<EvalScenario> {
    let mut out = Vec::new();
    for &noise in noises {
        for shape in PathShape::ALL {
            out.push(EvalScenario {
                family: "weak magnet",
                start: H,
                end: H,
                magnet: Some(WEAK_MAGNET_END),
                shape,
                noise,
            });
        }
    }
    out
}

/// The pole of run `seed`'s weak magnet: the reference actuator's poles in turn.
pub fn magnet_pole(seed: u64) -> u32 {
    let poles = u64::from(shared::magnets::poles(&ActuatorParams::REFERENCE));
    (seed % poles) as u32
}

/// One fault's prognosis along one simulated run.
#[derive(Clone, Debug)]
pub struct Track {
    pub scenario: String,
    pub family: &'static str,
    pub shape: PathShape,
    pub noise: f64,
    pub seed: u64,
    pub fault: usize,
    /// True end of life (fractional flight).
    pub eol: f64,
    /// Flight at which the true deviation reaches the detection threshold (0 when it starts
    /// beyond it).
    pub detected: f64,
    /// After each flight: the RUL estimate (`None` before three observations).
    pub predictions: Vec<(u32, Option<shared::prognosis::RulEstimate>)>,
}

/// What one run's out-of-domain flights became.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct IntrusionCount {
    /// Flights that met an intrusion.
    pub injected: u32,
    /// Of those, judged outside the domain (left out of the trend).
    pub flagged: u32,
    /// Flights without an intrusion judged outside the domain (lost to the trend).
    pub false_alarms: u32,
}

impl IntrusionCount {
    fn of(rows: &[HistoryRow]) -> Self {
        let mut c = Self::default();
        for r in rows {
            match (r.intrusion.is_some(), r.record.is_trusted()) {
                (true, trusted) => {
                    c.injected += 1;
                    c.flagged += u32::from(!trusted);
                }
                (false, false) => c.false_alarms += 1,
                (false, true) => {}
            }
        }
        c
    }

    fn add(&mut self, o: Self) {
        self.injected += o.injected;
        self.flagged += o.flagged;
        self.false_alarms += o.false_alarms;
    }
}

/// How far a kind of entry's readings of one component are from the truth against the
/// deviations they state: sums over every trusted reading with a stated deviation.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Scatter {
    pub readings: u32,
    /// Σ (reading − truth)², in deviations from nominal.
    pub squared_error: f64,
    /// Σ stated σ² (not below the trend's noise floor).
    pub squared_std: f64,
}

impl Scatter {
    fn add(&mut self, row: &HistoryRow, i: usize, noise_floor: f64) {
        let Some(truth) = row.truth.filter(|_| row.record.is_trusted()) else {
            return;
        };
        let (found, truth) = (row.record.faults.deviations(), truth.deviations());
        if let (Some(Some(f)), Some(Some(t)), Some(sd)) =
            (found.get(i), truth.get(i), row.record.std.get(i))
        {
            let sd = f64::from(sd).max(noise_floor);
            self.readings += 1;
            self.squared_error += f64::from(f - t).powi(2);
            self.squared_std += sd * sd;
        }
    }

    /// RMS error and RMS stated deviation.
    pub fn rms(&self) -> (f64, f64) {
        let n = f64::from(self.readings.max(1));
        (
            (self.squared_error / n).sqrt(),
            (self.squared_std / n).sqrt(),
        )
    }

    /// RMS error over RMS stated deviation.
    pub fn ratio(&self) -> f64 {
        let (e, s) = self.rms();
        e / s
    }
}

/// In-flight readings a component needs for its factor to count in the largest.
const FACTOR_READINGS: u32 = 20;

/// Per component, how optimistic an in-flight entry's stated deviation is against a
/// preflight's: (in-flight RMS error / RMS stated σ) over (the same for preflights); with
/// the largest over the components with at least [`FACTOR_READINGS`] in-flight readings (the
/// scale at which no component's in-flight entries weigh more than their errors support).
pub fn scatter_factors(scatter: &[[Scatter; FAULT_COUNT]; 2]) -> ([Option<f64>; FAULT_COUNT], f64) {
    let mut factors = [None; FAULT_COUNT];
    let mut largest = 0.0f64;
    for (i, f) in factors.iter_mut().enumerate() {
        let (p, w) = (scatter[0][i], scatter[1][i]);
        if p.readings == 0 || w.readings == 0 || p.ratio() <= 0.0 {
            continue;
        }
        let factor = w.ratio() / p.ratio();
        *f = Some(factor);
        if w.readings >= FACTOR_READINGS {
            largest = largest.max(factor);
        }
    }
    (factors, largest)
}

fn scatter_markdown(scatter: &[[Scatter; FAULT_COUNT]; 2]) -> String {
    let (factors, largest) = scatter_factors(scatter);
    let mut out = String::from(
        "\nErrors against stated deviations, every trusted reading with one (deviations \
         from nominal; σ not below the noise floor):\n\n\
         | component | preflights | RMS error | RMS stated σ | flights' readings | RMS error | RMS stated σ | a flight's σ this many times as optimistic |\n\
         | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n",
    );
    for (i, f) in factors.iter().enumerate() {
        let (p, w) = (scatter[0][i], scatter[1][i]);
        if p.readings == 0 {
            continue;
        }
        let ((pe, ps), (we, ws)) = (p.rms(), w.rms());
        out += &format!(
            "| {} | {} | {pe:.4} | {ps:.4} | {} | {we:.4} | {ws:.4} | {} |\n",
            FAULT_NAMES[i],
            p.readings,
            w.readings,
            f.map_or("–".into(), |f| format!("{f:.2}"))
        );
    }
    out += &format!(
        "\nLargest factor over the components with ≥ {FACTOR_READINGS} in-flight readings: \
         **{largest:.2}** (the in-flight scale at which no component's in-flight entries \
         weigh more than their errors support).\n"
    );
    out
}

/// One component's reading errors (reading − truth, deviations from nominal) over trusted
/// preflights at least [`shared::fault::DETECTION_THRESHOLD`] from nominal: their mean (the
/// lean) and their scatter about each run's own mean (what a trend sees about its fit).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ReadingErrors {
    pub readings: u32,
    sum: f64,
    /// Σ (error − its run's mean error)².
    within_run: f64,
}

impl ReadingErrors {
    /// Adds one run's errors.
    pub fn add_run(&mut self, errors: &[f64]) {
        if errors.is_empty() {
            return;
        }
        let mean = errors.iter().sum::<f64>() / errors.len() as f64;
        self.readings += errors.len() as u32;
        self.sum += mean * errors.len() as f64;
        self.within_run += errors.iter().map(|e| (e - mean).powi(2)).sum::<f64>();
    }

    /// Mean error (the lean).
    pub fn mean(&self) -> f64 {
        self.sum / f64::from(self.readings.max(1))
    }

    /// Standard deviation about each run's mean.
    pub fn scatter(&self) -> f64 {
        (self.within_run / f64::from(self.readings.max(1))).sqrt()
    }

    /// Each trended component's errors in the trusted entries of one run of one kind: the
    /// preflights (`in_flight` false) or the flights' readings (true: the components read in
    /// flight, those with a stated deviation; a held one is its preflight's).
    pub fn of_run(rows: &[HistoryRow], in_flight: bool) -> [Vec<f64>; FAULT_COUNT] {
        let mut out: [Vec<f64>; FAULT_COUNT] = Default::default();
        let kind = if in_flight {
            shared::health::FLIGHT_READING
        } else {
            0
        };
        let entries = rows
            .iter()
            .filter(|r| r.record.window == kind && r.record.is_trusted());
        for r in entries {
            let Some(truth) = r.truth else { continue };
            let (found, truth) = (r.record.faults.deviations(), truth.deviations());
            for (i, errors) in out.iter_mut().enumerate() {
                let read = !in_flight || r.record.std.get(i).is_some();
                if let (Some(Some(f)), Some(Some(t)), true) = (found.get(i), truth.get(i), read) {
                    if *t >= shared::fault::DETECTION_THRESHOLD {
                        errors.push(f64::from(f - t));
                    }
                }
            }
        }
        out
    }
}

/// Each I_ref noise level's reading errors, each component's.
pub type ErrorsByNoise = Vec<(f64, [ReadingErrors; FAULT_COUNT])>;

fn reading_errors_markdown(errors: &ErrorsByNoise, entries: &str) -> String {
    if errors
        .iter()
        .all(|(_, e)| e.iter().all(|c| c.readings == 0))
    {
        return String::new();
    }
    let mut out = format!(
        "\nThe {entries}' reading errors (reading − truth in deviations from nominal, trusted \
         {entries} at least 0.05 from nominal): mean (the lean) / standard deviation about each \
         run's own mean (the scatter a trend sees), by I_ref noise:\n\n| component |",
    );
    for (noise, _) in errors {
        out += &format!(" {:.0} % |", 100.0 * noise);
    }
    out += "\n| --- |";
    out += &" ---: |".repeat(errors.len());
    out += "\n";
    for (i, name) in FAULT_NAMES.iter().enumerate() {
        if errors.iter().all(|(_, e)| e[i].readings == 0) {
            continue;
        }
        out += &format!("| {name} |");
        for (_, e) in errors {
            let e = e[i];
            out += &if e.readings == 0 {
                " – |".to_string()
            } else {
                format!(" {:+.4} / {:.4} ({}) |", e.mean(), e.scatter(), e.readings)
            };
        }
        out += "\n";
    }
    out
}

/// The evaluation's tracks and intrusion counts.
#[derive(Clone, Debug, Default)]
pub struct Evaluation {
    /// The reading errors per I_ref noise level, each component's: the preflights' `[0]`,
    /// the flights' readings' `[1]`.
    pub errors: [ErrorsByNoise; 2],
    pub tracks: Vec<Track>,
    /// With in-flight windows: the same runs' tracks from their preflights alone.
    pub preflight_only: Vec<Track>,
    /// Windows of flight: identified (within) and all.
    pub windows: (u32, u32),
    /// Flights' readings from their windows: within (the trend's in-flight entries) and all
    /// (the others `unconfirmed` or `turbulence_too_high`).
    pub flights_read: (u32, u32),
    /// Errors against stated deviations per component: preflights `[0]`, flights'
    /// readings `[1]`.
    pub scatter: [[Scatter; FAULT_COUNT]; 2],
    pub intrusions: IntrusionCount,
    /// Runs simulated now, and runs read from the cache folder.
    pub simulated: u32,
    pub cached: u32,
    /// The weak magnet's readings per I_ref noise level, on paths that grow one.
    pub magnets: Vec<(f64, MagnetReadings)>,
}

/// A weak magnet's readings along its paths, over trusted preflights: the depth's error
/// (reading − truth, 0 where none was read) where the truth is at least
/// [`shared::fault::DETECTION_THRESHOLD`], and its pole where the truth is at least 0.2.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MagnetReadings {
    pub depth: ReadingErrors,
    /// Preflights whose magnet was read at its true pole...
    pub pole_right: u32,
    /// ...of those whose truth is at least 0.2.
    pub pole_of: u32,
}

impl MagnetReadings {
    /// Adds one run of `path` (`rows` its history).
    pub fn add_run(&mut self, path: &DegradationPath, rows: &[HistoryRow]) {
        let params = ActuatorParams::REFERENCE;
        let mut errors = Vec::new();
        for r in rows
            .iter()
            .filter(|r| r.record.window == 0 && r.record.is_trusted())
        {
            let Some(truth) = path.magnet_at(r.record.flight) else {
                continue;
            };
            let read = r.record.magnet.magnets();
            if truth.end >= f64::from(shared::fault::DETECTION_THRESHOLD) {
                errors.push(f64::from(read.depth) - truth.end);
            }
            if truth.end >= 0.2 {
                self.pole_of += 1;
                if !read.is_none() && read.pole(&params) == truth.pole {
                    self.pole_right += 1;
                }
            }
        }
        self.depth.add_run(&errors);
    }
}

/// The tracks of one simulated run: each fault with a threshold crossed within the path,
/// the onboard prognosis replayed flight by flight.
pub fn tracks_of(
    sc: &EvalScenario,
    path: &DegradationPath,
    seed: u64,
    rows: &[HistoryRow],
    settings: &TrendSettings,
) -> Vec<Track> {
    let mut out = Vec::new();
    for i in 0..TREND_COUNT {
        let Some(threshold) = settings.threshold(i) else {
            continue;
        };
        let Some(eol) = path.end_of_life(i, threshold) else {
            continue;
        };
        // One prediction per flight, after its preflight (its in-flight entries feed the
        // next flight's).
        let mut trend = FaultTrend::new();
        let predictions = rows
            .iter()
            .filter_map(|r| {
                if r.record.is_trusted() {
                    trend.add(&r.record, i, settings);
                }
                (r.record.window == 0).then(|| {
                    let e = trend.estimate(Some(threshold), settings);
                    (r.record.flight, e.and_then(|e| e.rul))
                })
            })
            .collect();
        let detected = path
            .end_of_life(i, shared::fault::DETECTION_THRESHOLD)
            .unwrap_or(0.0);
        out.push(Track {
            scenario: sc.name(),
            family: sc.family,
            shape: sc.shape,
            noise: sc.noise,
            seed,
            fault: i,
            eol,
            detected,
            predictions,
        });
    }
    out
}

/// The runs of an evaluation: seeds, flights per run, the share of flights out of the
/// domain and the windows of flight identified per flight.
#[derive(Clone, Debug)]
pub struct EvalRuns {
    pub seeds: std::ops::Range<u64>,
    pub flights: u32,
    pub intrusions: f64,
    pub windows: u8,
    /// The most tests per preflight, as many as the noise calls for (`degrade`'s `repeat`).
    pub repeat: u8,
    /// Whose readings the trend takes.
    pub readings: Readings,
}

/// Whose readings the trend takes: the FDI's, or a study of what they cost (preflights only).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Readings {
    /// The onboard FDI's, as identified.
    Fdi,
    /// An ideal identification of this standard deviation ([`ideal_readings`]).
    Ideal(f32),
    /// The FDI's with each run's mean error per component taken off ([`lean_removed`]).
    LeanRemoved,
}

/// Runs every scenario for the `seeds` over `flights` flights, a share `intrusions` of
/// them out of the domain, `windows` windows of flight identified in each flight, and
/// replays the onboard prognosis flight by flight (with windows, also from the preflights
/// alone: [`Evaluation::preflight_only`]). With `cache`,
/// each run's history is read from that folder when there and written to it when simulated
/// (the trend can then be re-evaluated without simulating again).
pub fn evaluate(
    scenarios: &[EvalScenario],
    runs: &EvalRuns,
    settings: &TrendSettings,
    cache: Option<&Path>,
    tick: &(dyn Fn(u64) + Sync),
) -> Result<Evaluation> {
    let EvalRuns {
        seeds,
        flights,
        intrusions,
        windows,
        repeat,
        readings,
    } = runs.clone();
    let mut eval = Evaluation::default();
    for sc in scenarios {
        let base = DegradationPath {
            start: FaultVector::new(sc.start).map_err(|e| anyhow!("{}: {e:?}", sc.name()))?,
            end: FaultVector::new(sc.end).map_err(|e| anyhow!("{}: {e:?}", sc.name()))?,
            flights,
            shape: sc.shape,
            magnet: None,
        };
        for seed in seeds.clone() {
            let path = DegradationPath {
                magnet: sc.magnet.map(|end| MagnetLoss {
                    pole: magnet_pole(seed),
                    end,
                }),
                ..base
            };
            let file =
                cache.map(|c| c.join(sc.file_name(seed, flights, intrusions, windows, repeat)));
            let rows = match &file {
                Some(f) if f.exists() => {
                    eval.cached += 1;
                    tick(u64::from(flights));
                    crate::files::health::read_history(f)?
                }
                _ => {
                    eval.simulated += 1;
                    let rows =
                        degrade(&path, sc.noise, seed, intrusions, windows, repeat, &|| {
                            tick(1)
                        })?;
                    if let Some(f) = &file {
                        std::fs::write(f, crate::files::health::history_csv(&rows))
                            .with_context(|| format!("writing {}", f.display()))?;
                    }
                    rows
                }
            };
            let rows = match readings {
                Readings::Fdi => rows,
                Readings::Ideal(sigma) => ideal_readings(&rows, sigma, seed),
                Readings::LeanRemoved => lean_removed(&rows),
            };
            for (in_flight, errors) in [false, true].into_iter().zip(eval.errors.iter_mut()) {
                for (e, run) in at_noise(errors, sc.noise)
                    .iter_mut()
                    .zip(ReadingErrors::of_run(&rows, in_flight))
                {
                    e.add_run(&run);
                }
            }
            // Preflights `[0]` and flights' readings `[1]`: the entries the trend takes.
            for r in rows.iter().filter(|r| !r.record.is_window()) {
                for (i, s) in eval.scatter[usize::from(r.record.window != 0)]
                    .iter_mut()
                    .enumerate()
                {
                    s.add(r, i, settings.noise_floor);
                }
            }
            let preflights: Vec<HistoryRow> = rows
                .iter()
                .filter(|r| r.record.window == 0)
                .copied()
                .collect();
            eval.intrusions.add(IntrusionCount::of(&preflights));
            if path.magnet.is_some() {
                at_noise(&mut eval.magnets, sc.noise).add_run(&path, &rows);
            }
            eval.tracks
                .extend(tracks_of(sc, &path, seed, &rows, settings));
            if preflights.len() < rows.len() {
                let count = |kind: fn(&HealthRecord) -> bool| {
                    let entries = rows.iter().filter(|r| kind(&r.record));
                    (
                        entries.clone().filter(|r| r.record.is_trusted()).count() as u32,
                        entries.count() as u32,
                    )
                };
                let (windows, flights) = (
                    count(HealthRecord::is_window),
                    count(|r| r.window == shared::health::FLIGHT_READING),
                );
                eval.windows.0 += windows.0;
                eval.windows.1 += windows.1;
                eval.flights_read.0 += flights.0;
                eval.flights_read.1 += flights.1;
                eval.preflight_only
                    .extend(tracks_of(sc, &path, seed, &preflights, settings));
            }
        }
    }
    Ok(eval)
}

/// The entry of I_ref noise level `noise` in `by_noise`, added empty when missing. O(levels).
fn at_noise<T: Default>(by_noise: &mut Vec<(f64, T)>, noise: f64) -> &mut T {
    let at = match by_noise.iter().position(|(n, _)| *n == noise) {
        Some(at) => at,
        None => {
            by_noise.push((noise, T::default()));
            by_noise.len() - 1
        }
    };
    &mut by_noise[at].1
}

/// Where a track's prediction window starts (`t_P` of Saxena et al.'s metrics: the time
/// `λ` is counted from, `t_λ = t_P + λ·(EOL − t_P)`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PredictionStart {
    /// When the fault reaches the detection threshold (0.05): prognosis starts at detection.
    Detection,
    /// At the first flight (the evaluation before issue 20).
    FirstFlight,
}

/// ProgPy-style metrics of one track with accuracy bound `alpha` (relative).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrackMetrics {
    /// α-λ at λ = 0.5 and λ = 0.75 (RUL within ±α of the truth at that flight).
    pub alpha_lambda: [bool; 2],
    /// Relative RUL error at λ = 0.5 (`None`: no crossing predicted).
    pub error_half: Option<f64>,
    /// Predictions from half of the life to the end of life: how many, how many within ±α,
    /// how many whose 90 % interval holds the truth.
    pub late: usize,
    pub late_within: usize,
    pub late_covered: usize,
    /// Every prediction from the first (three trusted flights) to the end of life, and how
    /// many of their intervals hold the truth.
    pub all: usize,
    pub all_covered: usize,
    /// Of the intervals that miss: how many lie wholly after the truth (optimistic).
    pub all_late_misses: usize,
    /// Prognostic horizon [flights]: end of life minus the first flight from which every
    /// prediction stays within ±α·EOL of the truth (0 when none does).
    pub horizon: f64,
}

fn within(pred: Option<f32>, truth: f64, bound: f64) -> bool {
    pred.is_some_and(|p| (f64::from(p) - truth).abs() <= bound)
}

fn covers(r: &shared::prognosis::RulEstimate, truth: f64) -> bool {
    r.lower.is_some_and(|l| f64::from(l) <= truth) && r.upper.is_none_or(|u| f64::from(u) >= truth)
}

impl Track {
    fn at(&self, flight: u32) -> Option<shared::prognosis::RulEstimate> {
        self.predictions
            .iter()
            .find(|p| p.0 == flight)
            .and_then(|p| p.1)
    }

    /// The metrics over the predictions from `start` to the end of life.
    pub fn metrics(&self, alpha: f64, start: PredictionStart) -> TrackMetrics {
        let t_p = match start {
            PredictionStart::Detection => self.detected,
            PredictionStart::FirstFlight => 0.0,
        };
        let t_lambda = |l: f64| (t_p + l * (self.eol - t_p)).floor() as u32;
        let lambda = |l: f64| {
            let t = t_lambda(l);
            let truth = self.eol - f64::from(t);
            within(self.at(t).and_then(|r| r.rul), truth, alpha * truth)
        };
        let t_half = t_lambda(0.5);
        let error_half = self.at(t_half).and_then(|r| r.rul).map(|p| {
            (f64::from(p) - (self.eol - f64::from(t_half))) / (self.eol - f64::from(t_half))
        });
        let before_eol: Vec<(u32, Option<shared::prognosis::RulEstimate>)> = self
            .predictions
            .iter()
            .copied()
            .filter(|p| f64::from(p.0) < self.eol && f64::from(p.0) >= t_p.floor())
            .collect();
        let truth = |f: u32| self.eol - f64::from(f);
        let late: Vec<_> = before_eol.iter().filter(|p| p.0 >= t_half).collect();
        let made: Vec<(u32, shared::prognosis::RulEstimate)> = before_eol
            .iter()
            .filter_map(|p| Some((p.0, p.1?)))
            .collect();
        let missed_late = made
            .iter()
            .filter(|(f, r)| {
                !covers(r, truth(*f)) && r.lower.is_none_or(|l| f64::from(l) > truth(*f))
            })
            .count();
        // First flight from which every later prediction stays within ±α·EOL.
        let mut first_good = None;
        for p in before_eol.iter().rev() {
            if within(p.1.and_then(|r| r.rul), truth(p.0), alpha * self.eol) {
                first_good = Some(p.0);
            } else {
                break;
            }
        }
        TrackMetrics {
            alpha_lambda: [lambda(0.5), lambda(0.75)],
            error_half,
            late: late.len(),
            late_within: late
                .iter()
                .filter(|p| within(p.1.and_then(|r| r.rul), truth(p.0), alpha * truth(p.0)))
                .count(),
            late_covered: late
                .iter()
                .filter(|p| p.1.is_some_and(|r| covers(&r, truth(p.0))))
                .count(),
            all: made.len(),
            all_covered: made.iter().filter(|(f, r)| covers(r, truth(*f))).count(),
            all_late_misses: missed_late,
            horizon: first_good.map_or(0.0, |t| self.eol - f64::from(t)),
        }
    }
}

/// Totals of a group of tracks.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Totals {
    pub tracks: usize,
    pub alpha_lambda_half: usize,
    pub alpha_lambda_three_quarters: usize,
    pub late: usize,
    pub late_within: usize,
    pub late_covered: usize,
    pub all: usize,
    pub all_covered: usize,
    pub all_late_misses: usize,
}

impl Totals {
    pub fn of<'t>(
        tracks: impl IntoIterator<Item = &'t Track>,
        alpha: f64,
        start: PredictionStart,
    ) -> Self {
        let mut t = Self::default();
        for m in tracks.into_iter().map(|x| x.metrics(alpha, start)) {
            t.tracks += 1;
            t.alpha_lambda_half += usize::from(m.alpha_lambda[0]);
            t.alpha_lambda_three_quarters += usize::from(m.alpha_lambda[1]);
            t.late += m.late;
            t.late_within += m.late_within;
            t.late_covered += m.late_covered;
            t.all += m.all;
            t.all_covered += m.all_covered;
            t.all_late_misses += m.all_late_misses;
        }
        t
    }

    fn share(a: usize, b: usize) -> f64 {
        a as f64 / b.max(1) as f64
    }

    /// α-λ at λ = 0.5: share of tracks.
    pub fn alpha_lambda(&self) -> f64 {
        Self::share(self.alpha_lambda_half, self.tracks)
    }

    /// Predictions after half of the life within ±α.
    pub fn within_after_half(&self) -> f64 {
        Self::share(self.late_within, self.late)
    }

    /// 90 % intervals that hold the truth, over every prediction.
    pub fn coverage(&self) -> f64 {
        Self::share(self.all_covered, self.all)
    }

    /// ...and over the predictions after half of the life.
    pub fn coverage_after_half(&self) -> f64 {
        Self::share(self.late_covered, self.late)
    }

    fn row(&self, name: &str) -> String {
        let pct = |x: f64| format!("{:.0} %", 100.0 * x);
        format!(
            "| {name} | {} | {}/{} ({}) | {}/{} | {} | {} | {} | {} |\n",
            self.tracks,
            self.alpha_lambda_half,
            self.tracks,
            pct(self.alpha_lambda()),
            self.alpha_lambda_three_quarters,
            self.tracks,
            pct(self.within_after_half()),
            pct(self.coverage()),
            pct(self.coverage_after_half()),
            pct(Self::share(
                self.all_late_misses,
                self.all - self.all_covered
            )),
        )
    }

    const HEADER: &'static str = "| tracks | α-λ λ=0.5 | α-λ λ=0.75 | within ±α after half life | 90 % interval holds truth (every prediction) | (after half life) | misses that are optimistic |\n";
}

/// `tracks` grouped by `key`, groups in the order their first track comes, each named by
/// `name`.
fn grouped<'t, K: PartialEq + Copy>(
    tracks: &'t [Track],
    key: impl Fn(&'t Track) -> K,
    name: impl Fn(K) -> String,
) -> Vec<(String, Vec<&'t Track>)> {
    let mut groups: Vec<(K, Vec<&Track>)> = Vec::new();
    for t in tracks {
        let k = key(t);
        match groups.iter_mut().find(|g| g.0 == k) {
            Some(g) => g.1.push(t),
            None => groups.push((k, vec![t])),
        }
    }
    groups.into_iter().map(|(k, ts)| (name(k), ts)).collect()
}

fn magnet_readings_markdown(magnets: &[(f64, MagnetReadings)]) -> String {
    if magnets.is_empty() {
        return String::new();
    }
    let mut out = "\nThe weak magnet's readings, trusted preflights: the depth's error (reading − \
                   truth, 0 where none was read; truth at least 0.05) as mean (the lean) / \
                   standard deviation about each run's own mean, and the pole read right where \
                   the truth is at least 0.2:\n\n| I_ref noise | depth: lean / scatter (readings) \
                   | pole right |\n| --- | ---: | ---: |\n"
        .to_string();
    for (noise, m) in magnets {
        out += &format!(
            "| {:.0} % | {:+.4} / {:.4} ({}) | {} of {} |\n",
            100.0 * noise,
            m.depth.mean(),
            m.depth.scatter(),
            m.depth.readings,
            m.pole_right,
            m.pole_of
        );
    }
    out
}

/// The evaluation report (Markdown): the totals, by family, by path shape and by noise, then
/// one row per scenario and fault.
pub fn eval_markdown(eval: &Evaluation, alpha: f64) -> String {
    let tracks = &eval.tracks;
    let mut out = String::new();
    let summary = |title: &str, groups: Vec<(String, Vec<&Track>)>| -> String {
        let mut s = format!(
            "| {title} {}| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n",
            Totals::HEADER
        );
        for (name, ts) in groups {
            s += &Totals::of(ts, alpha, PredictionStart::Detection).row(&name);
        }
        s
    };
    out += &summary("", vec![("**all**".into(), tracks.iter().collect())]);
    out += &Totals::of(tracks, alpha, PredictionStart::FirstFlight)
        .row("all, counted from the first flight");
    out += "\n";
    out += &summary(
        "fault family",
        grouped(tracks, |t| t.family, |f| f.to_string()),
    );
    out += "\n";
    out += &summary(
        "growth",
        grouped(tracks, |t| t.shape, |s| s.name().to_string()),
    );
    out += "\n";
    out += &summary(
        "I_ref noise",
        grouped(tracks, |t| t.noise, |n| format!("{:.0} %", 100.0 * n)),
    );
    out += &reading_errors_markdown(&eval.errors[0], "preflights");
    out += &magnet_readings_markdown(&eval.magnets);
    out += &reading_errors_markdown(&eval.errors[1], "flights' readings");
    if !eval.preflight_only.is_empty() {
        let (within, flown) = eval.windows;
        let (read, flights) = eval.flights_read;
        out += &scatter_markdown(&eval.scatter);
        out += &format!(
            "\nThe same runs from their preflights alone (the {read} flights' readings left \
             out: of {flights} flights with a window that entered, the others `unconfirmed` or \
             `turbulence_too_high`; of the {flown} windows {within} identified, the others \
             `Outside`):\n\n"
        );
        out += &summary(
            "",
            vec![(
                "**preflights only**".into(),
                eval.preflight_only.iter().collect(),
            )],
        );
        out += &summary(
            "growth, preflights only",
            grouped(&eval.preflight_only, |t| t.shape, |s| s.name().to_string()),
        );
    }
    let c = eval.intrusions;
    out += &format!(
        "\nOut-of-domain flights mixed in: {} (jammed, phase B open, test run at twice the \
         chirp amplitude, in turn); judged outside the domain and left out of the trend: {}; \
         flights without one judged outside: {}.\n",
        c.injected, c.flagged, c.false_alarms
    );
    // Per scenario and fault.
    let groups = grouped(
        tracks,
        |t| (t.scenario.as_str(), t.fault),
        |(name, fault)| format!("{name} | {}", TREND_NAMES[fault]),
    );
    let pct = |x: f64| format!("{:.0} %", 100.0 * x);
    out += &format!(
        "\n| scenario | fault | runs | true EOL [flight] | α-λ λ=0.5 | RUL error at λ=0.5 (each run) | within ±{a} after half life | 90 % interval holds truth | prognostic horizon [flights] (PH/EOL) |\n\
         | --- | --- | ---: | ---: | ---: | --- | ---: | ---: | --- |\n",
        a = pct(alpha)
    );
    for (name, ts) in &groups {
        let m: Vec<TrackMetrics> = ts
            .iter()
            .map(|t| t.metrics(alpha, PredictionStart::Detection))
            .collect();
        let tot = Totals::of(ts.iter().copied(), alpha, PredictionStart::Detection);
        let n = m.len() as f64;
        let errors: Vec<String> = m
            .iter()
            .map(|x| {
                x.error_half
                    .map_or("none".into(), |e| format!("{:+.0} %", 100.0 * e))
            })
            .collect();
        let eol = ts.iter().map(|t| t.eol).sum::<f64>() / n;
        let ph: Vec<String> = m.iter().map(|x| format!("{:.0}", x.horizon)).collect();
        out += &format!(
            "| {name} | {} | {eol:.1} | {}/{} | {} | {} | {} | {} ({}) |\n",
            m.len(),
            tot.alpha_lambda_half,
            m.len(),
            errors.join(", "),
            pct(tot.within_after_half()),
            pct(tot.coverage()),
            ph.join(", "),
            pct(m.iter().map(|x| x.horizon).sum::<f64>() / n / eol),
        );
    }
    out
}

/// The α-λ picture: predicted RUL against flight, both over the true EOL, for every track,
/// with the truth and the ±α cone; one panel per path shape.
/// One row of a readings sweep: whose readings the trend took, and how it did from them
/// (every prediction from detection).
#[derive(Clone, Copy, Debug)]
pub struct SweepRow {
    pub readings: Readings,
    pub totals: Totals,
}

impl Readings {
    fn name(self) -> String {
        match self {
            Self::Fdi => "the FDI's readings".into(),
            Self::LeanRemoved => "the FDI's, lean taken off (oracle)".into(),
            Self::Ideal(sigma) => format!("ideal, σ {sigma}"),
        }
    }
}

/// The sweep as a Markdown table.
pub fn sweep_markdown(rows: &[SweepRow], alpha: f64) -> String {
    let mut out = format!(
        "| readings | tracks | α-λ (α = {:.0} %) at λ = 0.5 | within ±{:.0} % after half life | 90 % interval holds the truth |\n\
         | --- | ---: | ---: | ---: | ---: |\n",
        100.0 * alpha,
        100.0 * alpha
    );
    for r in rows {
        let t = &r.totals;
        out += &format!(
            "| {} | {} | {}/{} ({:.0} %) | {:.0} % | {:.0} % |\n",
            r.readings.name(),
            t.tracks,
            t.alpha_lambda_half,
            t.tracks,
            100.0 * t.alpha_lambda(),
            100.0 * t.within_after_half(),
            100.0 * t.coverage()
        );
    }
    out
}

/// A panel of the sweep's picture: its title, the metric, and the target band (if
/// any).
type SweepMetric = (&'static str, fn(&Totals) -> f64, Option<(f64, f64)>);

/// The sweep as a picture: each metric against the ideal readings' σ, the FDI's (and its
/// lean-removed oracle's) as horizontal lines, the targets shaded.
pub fn sweep_svg(out: &Path, rows: &[SweepRow]) -> Result<()> {
    let root = SVGBackend::new(out, (1200, 460)).into_drawing_area();
    let e = |e: DrawingAreaErrorKind<_>| anyhow!("drawing {}: {e:?}", out.display());
    root.fill(&WHITE).map_err(e)?;
    let ideal: Vec<(f64, Totals)> = rows
        .iter()
        .filter_map(|r| match r.readings {
            Readings::Ideal(sigma) => Some((f64::from(sigma), r.totals)),
            _ => None,
        })
        .collect();
    let top = ideal.iter().map(|p| p.0).fold(0.01, f64::max) * 1.05;
    let metrics: [SweepMetric; 3] = [
        ("α-λ at λ = 0.5", Totals::alpha_lambda, Some((0.85, 1.0))),
        (
            "within ±α after half life",
            Totals::within_after_half,
            Some((0.80, 1.0)),
        ),
        (
            "90 % interval holds the truth",
            Totals::coverage,
            Some((0.85, 0.95)),
        ),
    ];
    for (panel, (name, metric, target)) in root.split_evenly((1, 3)).iter().zip(metrics) {
        let mut chart = ChartBuilder::on(panel)
            .caption(name, ("sans-serif", 15))
            .margin(10)
            .x_label_area_size(36)
            .y_label_area_size(50)
            .build_cartesian_2d(0.0..top, 0.0..1.0)
            .map_err(e)?;
        chart
            .configure_mesh()
            .x_desc("ideal readings' σ (fault-vector units)")
            .y_desc("share")
            .draw()
            .map_err(e)?;
        if let Some((lo, hi)) = target {
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [(0.0, lo), (top, hi)],
                    GREEN.mix(0.15).filled(),
                )))
                .map_err(e)?
                .label("target")
                .legend(|(x, y)| {
                    Rectangle::new([(x, y - 4), (x + 20, y + 4)], GREEN.mix(0.15).filled())
                });
        }
        chart
            .draw_series(LineSeries::new(
                ideal.iter().map(|(s, t)| (*s, metric(t))),
                BLUE.stroke_width(2),
            ))
            .map_err(e)?
            .label("ideal readings")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLUE));
        chart
            .draw_series(
                ideal
                    .iter()
                    .map(|(s, t)| Circle::new((*s, metric(t)), 3, BLUE.filled())),
            )
            .map_err(e)?;
        for (readings, colour) in [(Readings::Fdi, RED), (Readings::LeanRemoved, MAGENTA)] {
            if let Some(r) = rows.iter().find(|r| r.readings == readings) {
                let y = metric(&r.totals);
                chart
                    .draw_series(LineSeries::new(
                        vec![(0.0, y), (top, y)],
                        colour.stroke_width(2),
                    ))
                    .map_err(e)?
                    .label(readings.name())
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour));
            }
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerLeft)
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK.mix(0.3))
            .draw()
            .map_err(e)?;
    }
    root.present().context("writing the plot")?;
    Ok(())
}

pub fn eval_svg(out: &Path, tracks: &[Track], alpha: f64) -> Result<()> {
    let root = SVGBackend::new(out, (1500, 520)).into_drawing_area();
    let e = |e: DrawingAreaErrorKind<_>| anyhow!("drawing {}: {e:?}", out.display());
    root.fill(&WHITE).map_err(e)?;
    let panels = root.split_evenly((1, 3));
    for (panel, shape) in panels.iter().zip(PathShape::ALL) {
        let mut chart = ChartBuilder::on(panel)
            .caption(
                format!("{} growth: RUL / EOL against flight / EOL", shape.name()),
                ("sans-serif", 15),
            )
            .margin(10)
            .x_label_area_size(36)
            .y_label_area_size(50)
            .build_cartesian_2d(0.0..1.0, 0.0..1.2)
            .map_err(e)?;
        chart
            .configure_mesh()
            .x_desc("λ = flight / true EOL")
            .y_desc("RUL / true EOL")
            .draw()
            .map_err(e)?;
        let cone: Vec<(f64, f64)> = [
            (0.0, 1.0 + alpha),
            (1.0, 0.0),
            (1.0, 0.0),
            (0.0, 1.0 - alpha),
        ]
        .into_iter()
        .collect();
        chart
            .draw_series(std::iter::once(Polygon::new(cone, GREEN.mix(0.15))))
            .map_err(e)?
            .label(format!("truth ±{:.0} %", 100.0 * alpha))
            .legend(|(x, y)| {
                Rectangle::new([(x, y - 4), (x + 20, y + 4)], GREEN.mix(0.15).filled())
            });
        chart
            .draw_series(LineSeries::new(
                vec![(0.0, 1.0), (1.0, 0.0)],
                BLACK.stroke_width(2),
            ))
            .map_err(e)?
            .label("true RUL")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK));
        for (n, t) in tracks.iter().filter(|t| t.shape == shape).enumerate() {
            let colour = Palette99::pick(n).mix(0.8);
            let pts: Vec<(f64, f64)> = t
                .predictions
                .iter()
                .filter(|p| f64::from(p.0) < t.eol)
                .filter_map(|p| {
                    let r = p.1?.rul?;
                    Some((f64::from(p.0) / t.eol, (f64::from(r) / t.eol).min(1.2)))
                })
                .collect();
            chart.draw_series(LineSeries::new(pts, colour)).map_err(e)?;
        }
        chart
            .draw_series(LineSeries::new(
                vec![(0.5, 0.0), (0.5, 1.2)],
                BLACK.mix(0.3),
            ))
            .map_err(e)?;
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK.mix(0.3))
            .draw()
            .map_err(e)?;
    }
    root.present().context("writing the plot")?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A repeated test's record: the mean of the `within` readings, their deviations' RMS
    /// over √N, the first's phase and day; an outside reading left out, all outside the
    /// first as it was.
    #[test]
    fn a_repeated_test_reads_its_readings_mean() {
        use shared::domain::{Domain, OutsideReason};
        let reading = |friction: f32, phase: f32, sd: f32, domain: Domain| {
            let mut k = *FaultVector::NOMINAL.as_array();
            (k[0], k[6]) = (friction, phase);
            HealthRecord::new(7, FaultVector::new(k).unwrap(), 0.01, domain)
                .with_std([sd; FAULT_COUNT])
        };
        let day = shared::health::RecordedDay::new(Some(270.0), Some(20.0), None);
        let first = reading(0.20, 0.3, 0.02, Domain::Within).with_day(day);
        let outside = reading(
            0.90,
            0.9,
            0.02,
            Domain::Outside(OutsideReason::FitnessFloor { fitness: 0.5 }),
        );
        let r = repeated_reading(&[first, reading(0.24, 0.7, 0.02, Domain::Within), outside]);
        assert!((r.faults.friction() - 0.22).abs() < 1e-6, "{r:?}");
        assert_eq!(r.faults.as_array()[6], 0.3);
        let sd = r.std.get(0).unwrap();
        assert!((sd - 0.02 / 2f32.sqrt()).abs() < 1e-4, "{sd}");
        assert_eq!((r.flight, r.day), (7, day));
        assert!(r.is_trusted());
        assert_eq!(repeated_reading(&[outside, outside]), outside);
    }
    #[test]
    fn the_weak_magnet_is_summed_over_the_trusted_preflights_alone() {
        use shared::domain::{Domain, OutsideReason};
        use shared::magnets::WeakMagnet;
        let row = |flight: u32, depth: f32, domain: Domain| {
            let m = if depth > 0.0 {
                WeakMagnet::new(depth, 1.0)
            } else {
                WeakMagnet::NONE
            };
            HistoryRow {
                record: HealthRecord::new(flight, FaultVector::NOMINAL, 0.01, domain)
                    .with_magnet(&m)
                    .with_magnet_std(0.03),
                truth: None,
                intrusion: None,
            }
        };
        let outside = Domain::Outside(OutsideReason::FitnessFloor { fitness: 0.5 });
        let mut window = row(4, 0.9, Domain::Within);
        window.record = window.record.in_flight(1);
        let rows = [
            row(1, 0.0, Domain::Within),
            row(2, 0.8, outside),
            row(3, 0.3, Domain::Within),
            window,
            row(5, 0.4, Domain::Within),
        ];
        let seen = weak_magnet_seen(&rows).unwrap();
        assert_eq!((seen.read, seen.of), (2, 3));
        assert_eq!((seen.first_flight, seen.newest_flight), (3, 5));
        assert!((seen.newest.depth - 0.4).abs() < 0.003, "{seen:?}");
        let text = weak_magnet_text(&seen);
        assert!(
            text.contains("2 of 3 trusted preflights, first at flight 3"),
            "{text}"
        );
        // 0.03 kept as 16/512: the interval 0.4 ± 1.645·0.03125 clears 0.05.
        assert_eq!(seen.newest_std, Some(16.0 / 512.0));
        assert!(
            text.contains("± 0.031 (1 σ, as stored), 90 % [0.34"),
            "{text}"
        );
        assert!(text.contains("0.451], FAULT; its depth's trend"), "{text}");
        // A shallow magnet whose interval reaches below the threshold is `suspect`; one
        // without a kept deviation has no verdict.
        let shallow = WeakMagnet::new(0.06, 1.0);
        assert_eq!(
            stored_magnet_verdict(&shallow, Some(0.03)).unwrap().1,
            "suspect"
        );
        assert_eq!(stored_magnet_verdict(&shallow, None), None);
        assert_eq!(weak_magnet_seen(&rows[..2]), None);
        // A repeated test keeps its first trusted reading's magnet.
        let r = repeated_reading(&[rows[1].record, rows[2].record, rows[4].record]);
        assert_eq!(r.magnet, rows[2].record.magnet);
    }

    use shared::prognosis::RulEstimate;

    fn path(shape: PathShape) -> DegradationPath {
        DegradationPath {
            start: FaultVector::new(H).unwrap(),
            end: FaultVector::new(with(H, 0, 0.6)).unwrap(),
            flights: 40,
            shape,
            magnet: None,
        }
    }

    #[test]
    fn each_path_reaches_the_threshold_at_its_end_of_life() {
        for shape in PathShape::ALL {
            let p = path(shape);
            let eol = p.end_of_life(0, 0.5).unwrap();
            let level = |f: f64| 0.6 * p.progress(f);
            assert!(
                (level(eol) - 0.5).abs() < 1e-6,
                "{shape:?} {eol} {}",
                level(eol)
            );
            assert!(
                level(eol - 0.5) < 0.5 && level(eol + 0.5) > 0.5,
                "{shape:?}"
            );
        }
        // The accelerating paths show little in their first half.
        assert!(path(PathShape::Exponential).progress(19.5) < 0.2);
        assert!(path(PathShape::PowerLaw).progress(19.5) < 0.25);
    }

    #[test]
    fn a_weak_magnets_path_reaches_its_threshold_at_its_end_of_life() {
        for shape in PathShape::ALL {
            let p = DegradationPath {
                magnet: Some(MagnetLoss::parse("0.6@3").unwrap()),
                ..path(shape)
            };
            let eol = p.end_of_life(WEAK_MAGNET_TREND, 0.5).unwrap();
            // The same flight as friction's on the same shape, 0 → 0.6 crossing 0.5.
            assert!(
                (eol - p.end_of_life(0, 0.5).unwrap()).abs() < 1e-4,
                "{shape:?}"
            );
            let at = |f: u32| p.magnet_at(f).unwrap();
            assert_eq!((at(0).end, at(0).pole), (0.0, 3));
            assert!((at(39).end - 0.6).abs() < 1e-9);
            assert!(at(eol.floor() as u32).end < 0.5 && at(eol.ceil() as u32).end > 0.5);
            // No magnet on the path: no end of life for it.
            assert_eq!(path(shape).end_of_life(WEAK_MAGNET_TREND, 0.5), None);
        }
        for bad in ["0.6", "1.2@3", "0.6@8", "x@1", "0.6@-1"] {
            assert!(MagnetLoss::parse(bad).is_err(), "{bad}");
        }
        // The evaluation's poles: the reference actuator's eight in turn.
        assert_eq!((magnet_pole(3), magnet_pole(11)), (3, 3));
    }

    #[test]
    fn intrusions_are_deterministic_and_about_their_share() {
        let hits: Vec<bool> = (0..2000).map(|f| intrusion(7, f, 0.1).is_some()).collect();
        let again: Vec<bool> = (0..2000).map(|f| intrusion(7, f, 0.1).is_some()).collect();
        assert_eq!(hits, again);
        let n = hits.iter().filter(|&&h| h).count();
        assert!((150..250).contains(&n), "{n} of 2000");
        assert!((0..2000).all(|f| intrusion(7, f, 0.0).is_none()));
        let kinds: Vec<Intrusion> = (0..2000).filter_map(|f| intrusion(3, f, 1.0)).collect();
        for k in Intrusion::ALL {
            assert!(kinds.iter().filter(|&&x| x == k).count() > 500, "{k:?}");
        }
    }

    /// A linear friction path's preflights as the FDI might log them: each reading `lean`
    /// above the truth, flight 3 with an intrusion (its record outside), and one in-flight
    /// entry after flight 5.
    fn logged(lean: f32) -> Vec<HistoryRow> {
        let p = path(PathShape::Linear);
        let mut rows = Vec::new();
        for flight in 0..40 {
            let truth = p.at(flight);
            let mut k = *truth.as_array();
            k[0] += lean;
            let intrusion = (flight == 3).then_some(Intrusion::Jammed);
            let domain = match intrusion {
                Some(_) => {
                    shared::domain::Domain::Outside(shared::domain::OutsideReason::NoMotion {
                        travel: 0.0,
                    })
                }
                None => shared::domain::Domain::Within,
            };
            let record = HealthRecord::new(flight, FaultVector::saturating(k), 1e-4, domain);
            rows.push(HistoryRow {
                record,
                truth: Some(truth),
                intrusion,
            });
            if flight == 5 {
                let mut window = record;
                window.window = shared::health::FLIGHT_READING;
                rows.push(HistoryRow {
                    record: window,
                    truth: Some(truth),
                    intrusion: None,
                });
            }
        }
        rows
    }

    #[test]
    fn ideal_readings_are_the_truth_with_the_stated_scatter_and_keep_the_fdis_intrusions() {
        let rows = logged(0.03);
        let exact = ideal_readings(&rows, 0.0, 4);
        assert_eq!(exact.len(), 40, "the in-flight entry is left out");
        for r in &exact {
            if r.record.flight == 3 {
                assert!(
                    !r.record.is_trusted(),
                    "the intrusion keeps the FDI's verdict"
                );
                continue;
            }
            assert!(r.record.is_trusted());
            assert_eq!(
                r.record.faults,
                r.truth.unwrap(),
                "flight {}",
                r.record.flight
            );
            assert_eq!(r.record.std.get(0), Some(0.0));
        }
        let sigma = 0.01;
        let noisy = ideal_readings(&rows, sigma, 4);
        assert_eq!(noisy, ideal_readings(&rows, sigma, 4), "seeded");
        assert_ne!(
            noisy,
            ideal_readings(&rows, sigma, 5),
            "another run, other noise"
        );
        // The friction readings' errors: about zero mean, about `sigma` (39 readings).
        let errors: Vec<f64> = noisy
            .iter()
            .filter(|r| r.record.is_trusted())
            .map(|r| f64::from(r.record.faults.friction() - r.truth.unwrap().friction()))
            .collect();
        let n = errors.len() as f64;
        let mean = errors.iter().sum::<f64>() / n;
        let sd = (errors.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / n).sqrt();
        assert!(mean.abs() < 0.005, "mean {mean}");
        assert!((0.007..0.013).contains(&sd), "sd {sd}");
        assert_eq!(
            noisy[10]
                .record
                .std
                .get(7)
                .map(|s| (s - sigma).abs() < 1e-4),
            Some(true)
        );
    }

    #[test]
    fn the_lean_is_taken_off_and_the_reading_errors_say_it() {
        let rows = logged(0.03);
        let errors = ReadingErrors::of_run(&rows, false);
        // Friction is at least 0.05 from flight 4 on; flight 3 is outside.
        let mut friction = ReadingErrors::default();
        friction.add_run(&errors[0]);
        assert!((friction.mean() - 0.03).abs() < 1e-6, "{}", friction.mean());
        assert!(friction.scatter() < 1e-6);
        assert!(errors[1].is_empty(), "the backlash never leaves nominal");
        // The flight's reading after flight 5: its friction counts only when read in flight.
        assert!(ReadingErrors::of_run(&rows, true)[0].is_empty(), "held");
        let mut read = rows.clone();
        for r in read.iter_mut().filter(|r| r.record.window != 0) {
            r.record.std = shared::health::ComponentStd::new([0.01; FAULT_COUNT]);
        }
        let flights = ReadingErrors::of_run(&read, true);
        assert_eq!(flights[0].len(), 1);
        assert!((flights[0][0] - 0.03).abs() < 1e-6);
        let taken = lean_removed(&rows);
        assert_eq!(taken.len(), 40);
        for r in taken.iter().filter(|r| r.record.is_trusted()) {
            let e = r.record.faults.friction() - r.truth.unwrap().friction();
            assert!(e.abs() < 1e-5, "flight {}: {e}", r.record.flight);
        }
        // Two runs: their means make the lean, each run's own spread the scatter.
        let mut two = ReadingErrors::default();
        two.add_run(&[0.01, 0.03]);
        two.add_run(&[0.05, 0.07]);
        assert!((two.mean() - 0.04).abs() < 1e-12);
        assert!((two.scatter() - 0.01).abs() < 1e-12);
    }

    #[test]
    fn a_sweep_names_each_kind_of_readings_and_draws_them() {
        let t = |a| Totals {
            tracks: 10,
            alpha_lambda_half: a,
            late: 4,
            late_within: 3,
            all: 8,
            all_covered: 7,
            ..Totals::default()
        };
        let rows = [
            SweepRow {
                readings: Readings::Fdi,
                totals: t(6),
            },
            SweepRow {
                readings: Readings::LeanRemoved,
                totals: t(7),
            },
            SweepRow {
                readings: Readings::Ideal(0.0),
                totals: t(9),
            },
            SweepRow {
                readings: Readings::Ideal(0.01),
                totals: t(5),
            },
        ];
        let text = sweep_markdown(&rows, 0.2);
        for line in [
            "| the FDI's readings | 10 | 6/10 (60 %) | 75 % | 88 % |",
            "| the FDI's, lean taken off (oracle) | 10 | 7/10 (70 %) |",
            "| ideal, σ 0 | 10 | 9/10 (90 %) |",
            "| ideal, σ 0.01 | 10 | 5/10 (50 %) |",
        ] {
            assert!(text.contains(line), "{line}\n{text}");
        }
        let dir = tempfile::tempdir().unwrap();
        let svg = dir.path().join("sweep.svg");
        sweep_svg(&svg, &rows).unwrap();
        let drawn = std::fs::read_to_string(&svg).unwrap();
        assert!(drawn.contains("ideal readings") && drawn.contains("lean taken off"));
    }

    fn track(predict: impl Fn(f64) -> RulEstimate) -> Track {
        let eol = 30.0;
        Track {
            scenario: "test".into(),
            family: "friction",
            shape: PathShape::Linear,
            noise: 0.0,
            seed: 0,
            fault: 0,
            eol,
            detected: 10.0,
            predictions: (0..40)
                .map(|f| (f, (f >= 3).then(|| predict(eol - f64::from(f)))))
                .collect(),
        }
    }

    #[test]
    fn the_in_flight_factor_compares_each_kinds_errors_with_its_stated_deviations() {
        let kind = |readings: u32, error: f64, std: f64| Scatter {
            readings,
            squared_error: f64::from(readings) * error * error,
            squared_std: f64::from(readings) * std * std,
        };
        let mut scatter = [[Scatter::default(); FAULT_COUNT]; 2];
        // Friction: preflights state 4× their error, windows half theirs: 8× as optimistic.
        scatter[0][0] = kind(100, 0.01, 0.04);
        scatter[1][0] = kind(30, 0.02, 0.01);
        // Short A: windows state 10× their error (2.5× as cautious as preflights).
        scatter[0][2] = kind(100, 0.01, 0.04);
        scatter[1][2] = kind(30, 0.01, 0.1);
        // Backlash: windows 16× as optimistic, but too few readings to set the largest.
        scatter[0][1] = kind(100, 0.01, 0.04);
        scatter[1][1] = kind(FACTOR_READINGS - 1, 0.04, 0.01);
        let (factors, largest) = scatter_factors(&scatter);
        let close = |a: Option<f64>, b: f64| a.is_some_and(|a| (a - b).abs() < 1e-9);
        assert!(close(factors[0], 8.0), "{factors:?}");
        assert!(close(factors[2], 0.4), "{factors:?}");
        assert!(close(factors[1], 16.0), "{factors:?}");
        assert_eq!(factors[3], None);
        assert!((largest - 8.0).abs() < 1e-9, "{largest}");
    }

    #[test]
    fn metrics_count_what_the_predictions_say() {
        let exact = track(|t| RulEstimate {
            rul: Some(t as f32),
            lower: Some(t as f32 - 1.0),
            upper: Some(t as f32 + 1.0),
        });
        let m = exact.metrics(0.2, PredictionStart::Detection);
        assert_eq!(m.alpha_lambda, [true, true]);
        assert_eq!((m.all, m.all_covered), (20, 20)); // flights 10..29
        assert_eq!((m.late, m.late_within, m.late_covered), (10, 10, 10)); // 20..29
        assert_eq!(m.error_half, Some(0.0));
        let m = exact.metrics(0.2, PredictionStart::FirstFlight);
        assert_eq!((m.all, m.late), (27, 15)); // 3..29 made; 15..29
                                               // 30 % late with an interval that misses on the late side.
        let late = track(|t| RulEstimate {
            rul: Some(1.3 * t as f32),
            lower: Some(1.2 * t as f32),
            upper: Some(1.4 * t as f32),
        });
        let m = late.metrics(0.2, PredictionStart::Detection);
        assert_eq!(m.alpha_lambda, [false, false]);
        assert_eq!((m.all_covered, m.all_late_misses), (0, 20));
        assert!((m.error_half.unwrap() - 0.3).abs() < 1e-6);
        let totals = Totals::of([&exact, &late], 0.2, PredictionStart::Detection);
        assert_eq!((totals.tracks, totals.alpha_lambda_half), (2, 1));
        assert!((totals.coverage() - 0.5).abs() < 1e-12);
    }
}
