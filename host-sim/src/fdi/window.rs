//! The identification of a window of flight on the host (issue 36; `shared::window`): the
//! window's load fitted at the nominal vector, the GA over the faults under it, the load
//! fitted again at the GA's best and the GA run again from that load, the better of the two
//! polished by damped Gauss–Newton steps on the window's curvature (the load's stiffness
//! and moment moved with the faults), and the uncertainty
//! there — `shared::window::identify`, the code a controller would run — and the window's
//! report around it. Two GA runs of at most `shared::window::WINDOW_GA_EVALUATIONS` each
//! of `shared::window::WINDOW_POPULATION` (`window_ga`), 2 ×
//! `shared::window::LOAD_SEARCH_EVALUATIONS` and at most 90 more monitor-model runs (≈ 900
//! in all).
//!
//! A window the load model leaves at its fitness floor is read again with the model's surface
//! pinned to its sensor (`shared::pinned`: the backlash and the gain drift, the friction held
//! at the same flight's preflight reading with the shorts, the eccentricity and the
//! demagnetization, their error carried into its deviations), when that preflight was
//! trusted: at most `shared::pinned::PINNED_EVALUATIONS` more runs (≤ 2 429).

use anyhow::Result;
use shared::actuator::ActuatorRecord;
use shared::conditions::TestConditions;
use shared::domain::Domain;
use shared::fdi::{OnboardMeasured, POPULATION};
use shared::fusion::{FlightReading, WindowFusion};
use shared::health::{HealthRecord, RecordedDay};
use shared::magnets::WeakMagnet;
use shared::pinned::{identify_pinned, PinnedLimits, PINNED_INFLATION};
use shared::uncertainty::{Assessment, Uncertainty};
use shared::window::{
    fusable, HeldComponents, HeldCoupling, SurfaceSamples, WindowLimits, WindowLoad, WindowProblem,
    WindowReason, COMMAND_STRIDE, WINDOW_INFLATION,
};
use shared::{FaultVector, FAULT_COUNT};

use crate::files::trace::Trace;

/// What the identification of one window found.
#[derive(Clone, Debug)]
pub struct WindowIdentified {
    pub faults: FaultVector,
    /// Eq. (3) after the drift at `faults` [A²·s].
    pub fitness: f32,
    /// The load fitted at `faults`.
    pub load: WindowLoad,
    /// The profiled drift's Legendre coefficients at `faults` [A].
    pub drift: [f32; shared::window::DRIFT_TERMS],
    /// The window's day as the FDI estimated it.
    pub conditions: TestConditions,
    /// Monitor-model runs spent.
    pub evaluations: u32,
    /// Of them, the window identification's with its load fitted: what the controller
    /// spends on the window (a window read pinned on the host adds the rest).
    pub load_model_runs: u32,
    /// The share of the measured current the fit leaves unexplained.
    pub misfit: f32,
    /// The load's movement beyond its spring over the spring's moment at the test's
    /// amplitude (`WindowProblem::unmodelled_moment`).
    pub turbulence: f32,
    /// The window's own verdict (`Err`: `Outside`, never identified).
    pub verdict: Result<(), WindowReason>,
    /// Standard deviation and 90 % interval per component, with the correlations, from the
    /// window's curvature (`shared::uncertainty`, its inflation calibrated on preflights,
    /// then `shared::window::WINDOW_INFLATION`, calibrated on flight windows).
    pub uncertainty: Option<(Uncertainty, [[f32; FAULT_COUNT]; FAULT_COUNT])>,
    /// The Gauss–Newton sums at `faults`: what the flight's reading adds of this window
    /// (`shared::fusion`).
    pub curvature: shared::uncertainty::Curvature,
    /// What the window held (the preflight's values and covariance) and how its free
    /// components lean on them: the flight's reading states the held values' error.
    pub held: HeldComponents,
    pub coupling: HeldCoupling,
    /// The deviation per component the held values' error adds (in `uncertainty`).
    pub shared_std: [f32; FAULT_COUNT],
    /// Which model read the window: its load fitted, or its surface pinned to its sensor.
    pub model: WindowModel,
    /// The misfit of the pinned reading when one was tried (the load model at its fitness
    /// floor, a trusted preflight), whatever its verdict, and why it was not read (`None`:
    /// read, or not tried).
    pub pinned_misfit: Option<f32>,
    /// The share of the current the surface sensor's own error leaves unexplained in that
    /// reading (`shared::pinned::PinnedReading::sensor_floor`): the pinned misfit's limit
    /// is `PinnedLimits::max_misfit` beyond it.
    pub pinned_sensor_floor: Option<f32>,
    pub pinned_reason: Option<WindowReason>,
}

/// The model a window was read with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WindowModel {
    /// The hinge load a spring with its moment and trend, fitted (`shared::window`).
    Load,
    /// The surface pinned to its sensor, no load (`shared::pinned`).
    Pinned,
}

impl WindowModel {
    /// The word reports and CSV files use.
    pub fn name(self) -> &'static str {
        match self {
            Self::Load => "load",
            Self::Pinned => "pinned",
        }
    }
}

impl WindowIdentified {
    /// The health log's in-flight entry of this window: the `window`-th (≥ 1) of `flight`,
    /// with its verdict, standard deviations and day.
    pub fn record(&self, flight: u32, window: u8) -> HealthRecord {
        let mut record = HealthRecord::new(flight, self.faults, self.fitness, Domain::Within)
            .with_std(
                self.uncertainty
                    .as_ref()
                    .map_or([f32::NAN; FAULT_COUNT], |(u, _)| u.std),
            )
            .with_day(RecordedDay::of(&self.conditions))
            .with_magnet(&self.held.magnets())
            .in_flight(window.max(1));
        record.domain = self.verdict.into();
        record
    }

    /// Adds this window to its flight's `fusion` when its verdict lets it enter
    /// (`shared::window::fusable`) and its curvature determines a component; whether it
    /// entered.
    pub fn enter(&self, fusion: &mut WindowFusion) -> bool {
        let factors = match self.model {
            WindowModel::Load => &WINDOW_INFLATION,
            WindowModel::Pinned => &PINNED_INFLATION,
        };
        fusable(&self.verdict)
            && fusion
                .add_holding(
                    &self.faults,
                    &self.curvature,
                    factors,
                    &self.held,
                    &self.coupling,
                )
                .is_ok()
    }

    /// Verdicts per component with the uncertainty (the plain threshold without one).
    pub fn assessments(&self) -> [Assessment; FAULT_COUNT] {
        let threshold = shared::fault::DETECTION_THRESHOLD;
        match &self.uncertainty {
            Some((u, c)) => u.assess_at(&self.faults, c, threshold),
            None => crate::fdi::identify::plain_assessments(&self.faults, threshold),
        }
    }
}

/// The health record of flight `flight`'s reading from its windows (an in-flight entry,
/// `shared::health::FLIGHT_READING`, with the windows fused): its vector, deviations and
/// verdict; its fitness the mean of the `entered` windows' and its day the first's.
pub fn flight_entry(
    flight: u32,
    reading: &FlightReading,
    entered: &[&WindowIdentified],
) -> HealthRecord {
    let fitness_sum = entered.iter().fold(0.0f32, |s, w| s + w.fitness);
    let day = entered
        .first()
        .map_or(RecordedDay::UNKNOWN, |w| RecordedDay::of(&w.conditions));
    let held = entered
        .first()
        .map_or(WeakMagnet::NONE, |w| w.held.magnets());
    HealthRecord::of_flight_reading(
        flight,
        reading,
        fitness_sum,
        entered.len() as u32,
        day,
        &held,
    )
}

/// The commanded angle of `trace` [rad] as the controller keeps it over a window: every
/// `shared::window::COMMAND_STRIDE`-th frame's (the window problem draws the line between).
pub fn recorded_command(trace: &Trace) -> Vec<f32> {
    trace
        .samples()
        .iter()
        .step_by(COMMAND_STRIDE)
        .map(|s| s.command as f32)
        .collect()
}

/// The window problem of `measured` driven by `command` (kept every `COMMAND_STRIDE`
/// frames, `recorded_command`) under `load`, on the day the FDI
/// estimates from the window, and that day.
fn window_problem<'a>(
    command: &'a [f32],
    measured: &'a OnboardMeasured,
    record: &ActuatorRecord,
    load: WindowLoad,
) -> Result<(
    WindowProblem<'a, { shared::fdi::TEST_SAMPLES }>,
    TestConditions,
)> {
    WindowProblem::of_record(measured, command, record, load)
        .map_err(|e| anyhow::anyhow!("the window: {e:?}"))
}

/// One sample of a window as identified: time [s], command and surface angle [rad], the
/// filtered measured current, the model's and the model's with the profiled drift [A].
pub type WindowPoint = (f32, f32, f32, f32, f32, f32);

/// The window as `id` fitted it, sample by sample (for the window's plot).
pub fn window_series(
    trace: &Trace,
    measured: &OnboardMeasured,
    record: &ActuatorRecord,
    id: &WindowIdentified,
) -> Result<Vec<WindowPoint>> {
    let command = recorded_command(trace);
    let (problem, _) = window_problem(&command, measured, record, id.load)?;
    let samples = trace.samples();
    let mut out = Vec::with_capacity(samples.len());
    problem.fitted(&id.faults, |t, r, m, md| {
        let i = out.len();
        let s = samples.get(i);
        out.push((
            t,
            s.map_or(0.0, |s| s.command as f32),
            s.map_or(0.0, |s| s.user_angle as f32),
            r,
            m,
            md,
        ));
    });
    Ok(out)
}

/// What a flight's windows hold of its preflight `pre` (its reading and calibrated
/// uncertainty): the shorts, the eccentricity and the demagnetization with their
/// covariance, and its weak magnet, when the preflight was `within`, else nothing. The friction's deviation
/// without the day's healthy friction's share: a window of the same day plays the same
/// healthy friction, so what it holds is the product the preflight measured.
pub fn held_from(pre: &crate::fdi::identify::Identified, within: bool) -> HeldComponents {
    HeldComponents::from_preflight_reading(
        &pre.result.faults,
        within,
        pre.uncertainty.as_ref().map(|(u, c)| (&u.std, c)),
        pre.friction_nuisance,
    )
    .with_magnets(pre.result.magnets)
}

/// The GA a window's identification runs twice: its evaluations at most and its
/// population. The controller's is [`WindowSearch::ONBOARD`]; others are for studies of
/// what a cheaper search costs (`campaign --flight --window-search`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WindowSearch {
    pub evaluations: u32,
    pub population: usize,
}

impl WindowSearch {
    /// The controller's: `shared::window::WINDOW_GA_EVALUATIONS` evaluations of a
    /// `shared::window::WINDOW_POPULATION`.
    pub const ONBOARD: Self = Self {
        evaluations: shared::window::WINDOW_GA_EVALUATIONS,
        population: shared::window::WINDOW_POPULATION,
    };

    /// The populations a study may ask for: 2 up to the GA's capacity (the preflight's
    /// population, which the controller's window GA is compiled with).
    pub const POPULATIONS: core::ops::RangeInclusive<usize> = 2..=POPULATION;
}

/// Identifies the faults behind a window of flight recorded in `trace`, conditioned into
/// `measured`, with the actuator `record` (its chirp-only test), the `held` components at
/// values from outside the window (`held_from` the same flight's preflight reading, when
/// it was `within`; `HeldComponents::NONE` without one).
pub fn identify_window(
    trace: &Trace,
    measured: &OnboardMeasured,
    record: &ActuatorRecord,
    held: HeldComponents,
    seed: u64,
) -> Result<WindowIdentified> {
    identify_window_with(trace, measured, record, held, seed, WindowSearch::ONBOARD)
}

/// [`identify_window`] with the GA of `search` (the controller's is
/// [`WindowSearch::ONBOARD`]).
pub fn identify_window_with(
    trace: &Trace,
    measured: &OnboardMeasured,
    record: &ActuatorRecord,
    held: HeldComponents,
    seed: u64,
    search: WindowSearch,
) -> Result<WindowIdentified> {
    let command = recorded_command(trace);
    let guess = record.params.aero_stiffness;
    let (problem, conditions) =
        window_problem(&command, measured, record, WindowLoad::spring(guess, 0.0))?;
    let problem = problem.with_held(held);
    let search = shared::window::WindowGa {
        settings: shared::ga::GaSettings {
            max_evaluations: record.ga.max_evaluations.min(search.evaluations),
            ..record.ga
        },
        population: search.population,
    };
    let limits = &WindowLimits::REFERENCE;
    let reading = shared::window::identify::<_, POPULATION>(&problem, search, seed, limits)
        .map_err(|e| {
            anyhow::anyhow!("the window's GA (population {}): {e:?}", search.population)
        })?;
    let problem = problem.with_load(reading.load);
    let loaded = WindowIdentified {
        faults: reading.faults,
        fitness: reading.fit.error,
        misfit: problem.misfit(reading.fit.error),
        turbulence: problem.unmodelled_moment(&reading.fit),
        verdict: reading.verdict,
        uncertainty: reading.uncertainty,
        curvature: reading.curvature,
        held,
        coupling: reading.coupling,
        shared_std: reading.shared_std,
        load: reading.load,
        drift: reading.fit.drift,
        conditions,
        evaluations: reading.evaluations,
        load_model_runs: reading.evaluations,
        model: WindowModel::Load,
        pinned_misfit: None,
        pinned_sensor_floor: None,
        pinned_reason: None,
    };
    if !shared::pinned::wants_pinned(&reading.verdict, &held) {
        return Ok(loaded);
    }
    // The load model cannot follow the window: read it again with the surface pinned.
    let period = f64::from(record.params.control_period);
    let measured_angles = surface_angles(trace);
    let (angles, speeds) = surface_of(&measured_angles, period);
    let surface = SurfaceSamples {
        angles: &angles,
        speeds: &speeds,
        motor: &[],
    };
    let (again, again_speeds) = surface_of(&redrawn(&measured_angles, seed), period);
    let redrawn = SurfaceSamples {
        angles: &again,
        speeds: &again_speeds,
        motor: &[],
    };
    let Ok(pinned) = identify_pinned(
        &problem,
        &surface,
        Some(&redrawn),
        &held,
        guess,
        reading.load.moment,
        &PinnedLimits::REFERENCE,
    ) else {
        return Ok(loaded);
    };
    let evaluations = loaded.evaluations + pinned.evaluations;
    if let Err(reason) = pinned.verdict {
        return Ok(WindowIdentified {
            pinned_misfit: Some(pinned.misfit),
            pinned_sensor_floor: Some(pinned.sensor_floor),
            pinned_reason: Some(reason),
            evaluations,
            ..loaded
        });
    }
    let load = WindowLoad::spring(guess, pinned.start_moment);
    Ok(WindowIdentified {
        faults: pinned.faults,
        fitness: pinned.fit.error,
        misfit: pinned.misfit,
        turbulence: problem.with_load(load).unmodelled_moment(&pinned.fit),
        verdict: pinned.verdict,
        uncertainty: pinned.uncertainty,
        curvature: pinned.curvature,
        held: held.also_holding(0),
        coupling: pinned.coupling,
        shared_std: pinned.shared_std,
        load,
        drift: pinned.fit.drift,
        conditions,
        evaluations,
        load_model_runs: loaded.load_model_runs,
        model: WindowModel::Pinned,
        pinned_misfit: Some(pinned.misfit),
        pinned_sensor_floor: Some(pinned.sensor_floor),
        pinned_reason: None,
    })
}

/// Half the span of the surface speed's central difference [samples].
const SPEED_HALF_SPAN: usize = 2;

/// The surface sensor's angle (`theta_u`) [rad] per sample of `trace`.
fn surface_angles(trace: &Trace) -> Vec<f64> {
    trace.samples().iter().map(|s| s.user_angle).collect()
}

/// `angles` [rad] as the pinned model reads them, with their speeds [rad/s]: a central
/// difference over `2 · SPEED_HALF_SPAN` samples of `period` [s] (shorter at the ends).
fn surface_of(angles: &[f64], period: f64) -> (Vec<f32>, Vec<f32>) {
    let n = angles.len();
    let speeds = (0..n)
        .map(|i| {
            let (a, b) = (
                i.saturating_sub(SPEED_HALF_SPAN),
                (i + SPEED_HALF_SPAN).min(n - 1),
            );
            if b > a {
                ((angles[b] - angles[a]) / ((b - a) as f64 * period)) as f32
            } else {
                0.0
            }
        })
        .collect();
    (angles.iter().map(|&a| a as f32).collect(), speeds)
}

/// The surface sensor's error per sample [rad] as its angles show it: the RMS of their
/// third differences over √20 (a white error's, or a quantizer's step over √12), the largest
/// [`SENSOR_TRIM`] of them left out and the rest taken back to a normal error's whole
/// variance — a slip or a glitch of the sensor, or a jerk where a play is crossed, moves a
/// few samples' differences by orders of magnitude and must not widen the pinned model's
/// limit. The surface's own motion is left in (the chirp's third difference, ≈ 4 nrad at its
/// 15 Hz end at 10 kHz): the estimate errs high, by little.
pub fn sensor_error(angles: &[f64]) -> f64 {
    let mut d: Vec<f64> = angles
        .windows(4)
        .map(|w| {
            let x = w[3] - 3.0 * w[2] + 3.0 * w[1] - w[0];
            x * x
        })
        .collect();
    let kept = d.len() - (d.len() as f64 * SENSOR_TRIM).ceil() as usize;
    if kept == 0 {
        return 0.0;
    }
    d.select_nth_unstable_by(kept - 1, f64::total_cmp);
    let mean = d[..kept].iter().sum::<f64>() / kept as f64;
    (mean / (20.0 * TRIMMED_VARIANCE)).sqrt()
}

/// The share of the largest squared third differences [`sensor_error`] leaves out.
const SENSOR_TRIM: f64 = 0.01;

/// A normal variable's variance within its central 99 % (|z| < 2.5758), over its whole
/// variance: `1 − 2·z·φ(z)/0.99`.
const TRIMMED_VARIANCE: f64 = 0.924_76;

/// `angles` [rad] with their error ([`sensor_error`]) drawn once more (a seeded normal draw
/// of that deviation added to each): the surface the pinned model's misfit is measured on
/// with the sensor's error counted twice.
fn redrawn(angles: &[f64], seed: u64) -> Vec<f64> {
    let sigma = sensor_error(angles);
    let mut draw = crate::plant::noise::Gaussian::new(seed ^ REDRAW_STREAM);
    angles.iter().map(|a| a + sigma * draw.next()).collect()
}

/// The redrawn sensor error's stream, apart from the GA's seed of the same window.
const REDRAW_STREAM: u64 = 0x5e45_0f10_0a15_e000;

#[cfg(test)]
mod tests {
    use super::*;

    /// A chirp-like surface path at 10 kHz: 5 mrad at 15 Hz, the window's fastest.
    fn path(n: usize) -> Vec<f64> {
        (0..n)
            .map(|i| 5.0e-3 * (std::f64::consts::TAU * 15.0 * i as f64 * 1.0e-4).sin())
            .collect()
    }

    #[test]
    fn the_surface_sensors_error_is_read_from_its_angles() {
        let clean = path(5_000);
        // A white error: its deviation, within 10 % (the path's own curvature adds little).
        let mut draw = crate::plant::noise::Gaussian::new(3);
        for sigma in [5.0e-7, 2.0e-6] {
            let noisy: Vec<f64> = clean.iter().map(|a| a + sigma * draw.next()).collect();
            let read = sensor_error(&noisy);
            assert!((read / sigma - 1.0).abs() < 0.1, "{read} for {sigma}");
        }
        // A quantized sensor: about its step over √12 (1 µrad steps).
        let lsb = 1.0e-6;
        let quantized: Vec<f64> = clean.iter().map(|a| (a / lsb).round() * lsb).collect();
        let read = sensor_error(&quantized);
        let expected = lsb / 12f64.sqrt();
        assert!((read / expected - 1.0).abs() < 0.1, "{read} for {expected}");
        // A slip of the sensor (5 mrad, one sample on) and a glitch (one sample 1 mrad off)
        // do not move it by more than 10 %.
        let mut faulty: Vec<f64> = clean.iter().map(|a| a + 5.0e-7 * draw.next()).collect();
        let sound = sensor_error(&faulty);
        for a in faulty.iter_mut().skip(2_500) {
            *a += 5.0e-3;
        }
        faulty[1_000] += 1.0e-3;
        let read = sensor_error(&faulty);
        assert!((read / sound - 1.0).abs() < 0.1, "{read} for {sound}");
        // A clean path: its own motion reads a hundredth of either, and too few samples
        // nothing.
        assert!(sensor_error(&clean) < 5.0e-9, "{}", sensor_error(&clean));
        assert_eq!(sensor_error(&clean[..3]), 0.0);
    }

    #[test]
    fn a_redrawn_surface_adds_the_sensors_error_once_more() {
        let mut draw = crate::plant::noise::Gaussian::new(4);
        let sigma = 1.0e-6;
        let noisy: Vec<f64> = path(5_000)
            .iter()
            .map(|a| a + sigma * draw.next())
            .collect();
        let (angles, speeds) = surface_of(&noisy, 1.0e-4);
        assert_eq!((angles.len(), speeds.len()), (5_000, 5_000));
        // The speed: a central difference over four samples.
        let expected = (noisy[12] - noisy[8]) / 4.0e-4;
        assert!((f64::from(speeds[10]) - expected).abs() < 1e-3 * expected.abs().max(1e-3));
        // What a redraw adds per sample: the error's deviation again (within 10 %); the same
        // seed the same draw, another seed another.
        let again = redrawn(&noisy, 9);
        assert_eq!(again, redrawn(&noisy, 9));
        assert_ne!(again, redrawn(&noisy, 10));
        let added = (noisy
            .iter()
            .zip(&again)
            .map(|(a, b)| (a - b) * (a - b))
            .sum::<f64>()
            / noisy.len() as f64)
            .sqrt();
        assert!((added / sigma - 1.0).abs() < 0.1, "{added}");
    }
}
