//! Calibrating the monitor model against a healthy trace (paper §III.2).
//!
//! The MM's electrical scale factors (R, L, k_e), its nominal friction level and a viscous
//! user-shaft damping are fitted so that, at the nominal fault vector, its filtered
//! equivalent current matches the measured one in the eq. (3) sense; the error left is the
//! nominal residual the fitness subtracts. Optimiser: Nelder–Mead on the logarithms of the
//! four scales, each bounded to [1/4, 4], and on damping / 10 N·m·s/rad in [0, 10]; at most
//! [`MAX_EVALUATIONS`] monitor-model runs (≈ 0.2 s).

use std::path::Path;

use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};
use shared::conditioning::LowPassState;
use shared::conditions::{pair_impedances, TestConditions, WindingEstimate};
use shared::fdi::OnboardMeasured;
use shared::{ActuatorParams, Calibration, FaultVector, FitnessProblem, MonitorModel};

use crate::files::trace::Trace;

/// Budget of the calibration fit [monitor-model evaluations].
pub const MAX_EVALUATIONS: u32 = 1500;
/// Bound on each scale: [1/4, 4].
const LOG_BOUND: f64 = 1.386_294_361_119_890_6; // ln 4

/// What `host-sim calibrate` writes: the calibration plus how well it fits.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CalibrationFile {
    /// Always `"ema-fdi calibration"`.
    pub format: String,
    /// File format version (1).
    pub version: u32,
    pub resistance_scale: f32,
    pub inductance_scale: f32,
    pub back_emf_scale: f32,
    pub friction_scale: f32,
    /// User-shaft viscous damping [N·m·s/rad].
    pub damping: f32,
    /// Eq. (3) error of the nominal vector after calibration [A²·s].
    pub nominal_residual: f32,
    /// The injection's pair circuits (1 without an injection segment).
    #[serde(default = "one")]
    pub pair_resistance_scale: f32,
    #[serde(default = "one")]
    pub pair_inductance_scale: f32,
    /// Temperature measured during the healthy trace [°C].
    #[serde(default = "reference_temperature")]
    pub temperature: f32,
    /// The healthy friction at other temperatures, `[°C, factor]` (factor 0: unused), and
    /// the magnet coefficient [1/K] (see `shared::Calibration`).
    #[serde(default)]
    pub friction_points: [[f32; 2]; 4],
    #[serde(default)]
    pub magnet_coefficient: f32,
    /// The controller's duty delay the injection showed [s] (`shared::Calibration`).
    #[serde(default)]
    pub duty_delay: f32,
    /// The grease's friction law by drag (`shared::Calibration`): the chirp's viscous drag on
    /// the healthy trace (0: the grease has no drag of its own) and each friction point's
    /// drag against it.
    #[serde(default)]
    pub viscous: f32,
    #[serde(default)]
    pub drag_points: [f32; 4],
    /// The installation's encoder offset, when `calibrate` estimated it (not with `--keep-offset`)
    /// [rad, motor side]: `identify --calibration` uses it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub encoder_offset: Option<f32>,
    /// When the chirp did not determine the resistance and inductance scales: the free fit's
    /// values at their bound, held at the data sheet's instead ([`HeldScales`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub held_at_data_sheet: Option<HeldScales>,
    /// Relative RMS mismatch of the filtered equivalent current, nominal vector, before and
    /// after calibration [-].
    pub mismatch_before: f64,
    pub mismatch_after: f64,
    /// Monitor-model runs the fit took.
    pub evaluations: u32,
}

/// A fit whose resistance or inductance scale ran into its bound, held at the data sheet's
/// (×1) because that explains the trace as well: the chirp's current loop hides R and L, so
/// its valley is flat along them, and a bound reached there says nothing of the actuator.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct HeldScales {
    /// The free fit's resistance and inductance scales.
    pub free_resistance: f32,
    pub free_inductance: f32,
    /// The free fit's relative mismatch, and the held one's [-].
    pub free_mismatch: f64,
    pub held_mismatch: f64,
}

/// How much more mismatch, relative, a fit with the resistance and inductance scales held
/// at the data sheet's may leave than the free fit that ran into a bound and still be taken
/// (5 %: the healthy reference actuator's mismatch is 3.0 %, so 0.15 points).
pub const HELD_TOLERANCE: f64 = 0.05;

fn one() -> f32 {
    1.0
}

fn reference_temperature() -> f32 {
    shared::params::REFERENCE_TEMPERATURE
}

pub const FORMAT: &str = "ema-fdi calibration";
pub const VERSION: u32 = 1;

impl CalibrationFile {
    pub fn calibration(&self) -> Calibration {
        Calibration {
            resistance_scale: self.resistance_scale,
            inductance_scale: self.inductance_scale,
            back_emf_scale: self.back_emf_scale,
            friction_scale: self.friction_scale,
            damping: self.damping,
            nominal_residual: self.nominal_residual,
            pair_resistance_scale: self.pair_resistance_scale,
            pair_inductance_scale: self.pair_inductance_scale,
            temperature: self.temperature,
            friction_points: self.friction_points,
            magnet_coefficient: self.magnet_coefficient,
            duty_delay: self.duty_delay,
            viscous: self.viscous,
            drag_points: self.drag_points,
        }
    }

    pub fn read(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read calibration {}", path.display()))?;
        let file: Self = serde_json::from_str(&text).with_context(|| {
            format!(
                "calibration {} is not valid JSON of the expected form",
                path.display()
            )
        })?;
        if file.format != FORMAT {
            bail!(
                "calibration {}: format is {:?}, expected {FORMAT:?}",
                path.display(),
                file.format
            );
        }
        if file.version != VERSION {
            bail!(
                "calibration {}: version {} is not supported (expected {VERSION})",
                path.display(),
                file.version
            );
        }
        for (name, value) in [
            ("resistance_scale", file.resistance_scale),
            ("inductance_scale", file.inductance_scale),
            ("back_emf_scale", file.back_emf_scale),
            ("friction_scale", file.friction_scale),
        ] {
            if !(value.is_finite() && value > 0.0) {
                bail!(
                    "calibration {}: {name} = {value} must be finite and positive",
                    path.display()
                );
            }
        }
        if !(file.damping.is_finite() && file.damping >= 0.0) {
            bail!(
                "calibration {}: damping = {} must be finite and ≥ 0",
                path.display(),
                file.damping
            );
        }
        if !(file.nominal_residual.is_finite() && file.nominal_residual >= 0.0) {
            bail!(
                "calibration {}: nominal_residual = {} must be finite and ≥ 0",
                path.display(),
                file.nominal_residual
            );
        }
        Ok(file)
    }

    pub fn write(&self, path: &Path) -> Result<()> {
        let text = serde_json::to_string_pretty(self)?;
        std::fs::write(path, text + "\n").with_context(|| format!("writing {}", path.display()))
    }
}

/// The monitor model's equivalent current at fault vector `k`, through the same low-pass as
/// `measured`, one value per measured sample [A].
pub fn filtered_model_current(
    measured: &OnboardMeasured,
    params: ActuatorParams,
    calibration: &Calibration,
    k: &FaultVector,
) -> Vec<f32> {
    let model = MonitorModel::new(params, calibration).with_test(measured.test());
    let filter = measured.filter();
    let mut state = LowPassState::default();
    let mut out = Vec::with_capacity(measured.samples().len());
    model.run_from(
        k,
        measured.initial_angles(),
        measured.samples().len(),
        |s| {
            out.push(filter.apply(&mut state, s.current));
        },
    );
    out
}

/// Where the current the monitor model does not explain lies, at fault vector `k` on the day
/// `day`: per part of the test — each injection pair's window (weighted as the fitness weighs
/// the standstill segment) and the chirp — its share of the unexplained energy and its RMS
/// misfit against the measured RMS there (both %). The settle, which the fitness does not
/// fit, is left out. For messages (`identify` when a test is outside the domain).
pub fn residual_by_part(
    measured: &OnboardMeasured,
    params: ActuatorParams,
    calibration: &Calibration,
    day: &shared::conditions::TestConditions,
    k: &FaultVector,
) -> Vec<(String, f64, f64)> {
    let model = MonitorModel::new(params, calibration)
        .with_test(measured.test())
        .with_conditions(day);
    let filter = measured.filter();
    let mut state = LowPassState::default();
    let mut modelled = Vec::with_capacity(measured.samples().len());
    model.run_from(
        k,
        measured.initial_angles(),
        measured.samples().len(),
        |s| {
            modelled.push(filter.apply(&mut state, s.current));
        },
    );
    let segment = measured.test().standstill;
    let lead = segment.map_or(0, |s| s.samples());
    let weight = f64::from(shared::fitness::STANDSTILL_WEIGHT);
    // Per part: Σ (weighted) squared misfit, Σ squared misfit, Σ squared measurement.
    let mut parts = [[0.0f64; 3]; 4];
    for (i, (&r, &m)) in measured.samples().iter().zip(&modelled).enumerate() {
        let (part, w) = match segment {
            Some(s) if i < lead => match s.at(i) {
                Some(_) if !s.fitted(i) => continue,
                Some(drive) => (drive.pair.min(2), weight),
                None => continue,
            },
            _ => (3, 1.0),
        };
        let e = f64::from(r - m);
        parts[part][0] += w * e * e;
        parts[part][1] += e * e;
        parts[part][2] += f64::from(r) * f64::from(r);
    }
    let total: f64 = parts.iter().map(|p| p[0]).sum();
    let names = PAIR_NAMES.map(|p| format!("injection {p}"));
    names
        .into_iter()
        .chain([String::from("chirp")])
        .zip(parts)
        .filter(|(_, p)| p[2] > 0.0)
        .map(|(name, p)| {
            (
                name,
                100.0 * p[0] / total.max(f64::MIN_POSITIVE),
                100.0 * (p[1] / p[2]).sqrt(),
            )
        })
        .collect()
}

/// Relative RMS difference between the measured filtered equivalent current and the monitor
/// model's (same filter) at fault vector `k`: `√(Σ(I_r − I_m)² / Σ I_r²)`.
pub fn relative_mismatch(
    measured: &OnboardMeasured,
    params: ActuatorParams,
    calibration: &Calibration,
    k: &FaultVector,
) -> f64 {
    let modelled = filtered_model_current(measured, params, calibration, k);
    let (num, den) = measured
        .samples()
        .iter()
        .zip(&modelled)
        .fold((0.0f64, 0.0f64), |(num, den), (&r, &m)| {
            (num + f64::from(r - m).powi(2), den + f64::from(r).powi(2))
        });
    if den > 0.0 {
        (num / den).sqrt()
    } else {
        f64::INFINITY
    }
}

/// Fits the calibration to a healthy measured trace. The injection's pair circuits come from
/// its own regression (`shared::conditions::pair_impedances`: the installed R and L, bridge
/// included, at this trace's temperature); the temperature is what the trace measured; the
/// friction law and magnet coefficient are `prior`'s (the actuator's), as they are not seen
/// at one temperature.
pub fn calibrate(
    measured: &OnboardMeasured,
    params: ActuatorParams,
    prior: &Calibration,
) -> Result<CalibrationFile> {
    let nominal = FaultVector::NOMINAL;
    let dt = params.control_period;
    let (pairs, winding) = pair_impedances(measured, dt, prior.delay_share(dt));
    // The copper alone at the trace's temperature: an installed pair circuit (copper,
    // harness, switches) is never below it by more than a data sheet's tolerance.
    let celsius = measured
        .conditions()
        .temperature()
        .unwrap_or(shared::params::REFERENCE_TEMPERATURE);
    let copper = 2.0
        * f64::from(params.phase_resistance)
        * (1.0
            + f64::from(shared::conditions::COPPER_COEFFICIENT)
                * f64::from(celsius - shared::params::REFERENCE_TEMPERATURE));
    let timing_hint = || match least_duty_delay(measured, dt, copper) {
        Some(d) if d > f64::from(prior.duty_delay) => format!(
            ": the pair answers the tone as if the controller applied its volts at least \
             {:.1} µs after their sample, and the record says {:.1} µs. Declare the \
             controller's timing (`[drive] duty_delay` in the actuator description, e.g. \
             5e-5 for a duty loaded at the next 20 kHz PWM update) and calibrate again",
            d * 1e6,
            f64::from(prior.duty_delay) * 1e6
        ),
        _ => String::from(": the trace cannot calibrate the pair circuits"),
    };
    let (pair_resistance_scale, pair_inductance_scale) = match winding {
        WindingEstimate::Injection => {
            let r: f32 = pairs.iter().map(|p| p.resistance).sum::<f32>() / 3.0;
            let l: f32 = pairs.iter().map(|p| p.inductance).sum::<f32>() / 3.0;
            if f64::from(r) < MIN_COPPER_SHARE * copper {
                bail!(
                    "the injection's pair resistance is {:.3} Ω, {:.0} % of the data sheet's \
                     copper at the measured {celsius:.1} °C ({copper:.3} Ω){}",
                    r,
                    100.0 * f64::from(r) / copper,
                    timing_hint()
                );
            }
            (
                r / (2.0 * params.phase_resistance),
                l / (2.0 * params.phase_inductance),
            )
        }
        WindingEstimate::NoInjection => (1.0, 1.0),
        WindingEstimate::PairCarriedNothing { pair } => bail!(
            "the injection segment's pair {} carried {:.3} A RMS, less than {} A: the trace \
             cannot calibrate the pair circuits (is the bridge driving the test's pair \
             voltages?)",
            PAIR_NAMES[usize::from(pair).min(2)],
            injection_rms(measured, dt)[usize::from(pair).min(2)],
            shared::conditions::MIN_PAIR_CURRENT
        ),
        WindingEstimate::PairNotPhysical { pair } => bail!(
            "the injection segment's pair {} carried {:.2} A RMS but its answer to the tone \
             is not a physical R–L circuit{}",
            PAIR_NAMES[usize::from(pair).min(2)],
            injection_rms(measured, dt)[usize::from(pair).min(2)],
            timing_hint()
        ),
    };
    let base = Calibration {
        pair_resistance_scale,
        pair_inductance_scale,
        temperature: measured
            .conditions()
            .temperature()
            .unwrap_or(shared::params::REFERENCE_TEMPERATURE),
        friction_points: prior.friction_points,
        magnet_coefficient: prior.magnet_coefficient,
        duty_delay: prior.duty_delay,
        viscous: prior.viscous,
        drag_points: prior.drag_points,
        ..Calibration::IDENTITY
    };
    const DAMPING_UNIT: f64 = 10.0;
    let in_bounds =
        |x: &[f64; 5]| x[..4].iter().all(|v| v.abs() <= LOG_BOUND) && (0.0..=10.0).contains(&x[4]);
    let calibration_at = |x: &[f64; 5]| Calibration {
        resistance_scale: x[0].clamp(-LOG_BOUND, LOG_BOUND).exp() as f32,
        inductance_scale: x[1].clamp(-LOG_BOUND, LOG_BOUND).exp() as f32,
        back_emf_scale: x[2].clamp(-LOG_BOUND, LOG_BOUND).exp() as f32,
        friction_scale: x[3].clamp(-LOG_BOUND, LOG_BOUND).exp() as f32,
        damping: (DAMPING_UNIT * x[4].clamp(0.0, 10.0)) as f32,
        nominal_residual: 0.0,
        ..base
    };
    let day = TestConditions::CALIBRATION;
    let mut evaluations = 0u32;
    let mut cost = |x: &[f64; 5]| -> f64 {
        evaluations += 1;
        if !in_bounds(x) {
            return f64::INFINITY;
        }
        match FitnessProblem::on_day(measured, params, &calibration_at(x), day) {
            Ok(problem) => f64::from(problem.raw_error(&nominal)),
            Err(_) => f64::INFINITY,
        }
    };
    let mut best = nelder_mead(&mut cost, [0.0, 0.0, 0.0, 0.0, 0.1], 0.1, MAX_EVALUATIONS);
    let at_bound = |x: &[f64; 5]| x[..4].iter().any(|v| v.abs() >= 0.99 * LOG_BOUND);
    // The chirp's current loop hides R and L: a fit that ran into their bound may sit on a
    // flat valley. Held at the data sheet's, with the other three free, it is taken when it
    // explains the trace as well (`HELD_TOLERANCE`).
    let mut held_at_data_sheet = None;
    let mut held_text = String::new();
    if at_bound(&best) && best[2..4].iter().all(|v| v.abs() < 0.99 * LOG_BOUND) {
        let free_mismatch = relative_mismatch(measured, params, &calibration_at(&best), &nominal);
        let mut held_cost = |y: &[f64; 3]| cost(&[0.0, 0.0, y[0], y[1], y[2]]);
        let y = nelder_mead(&mut held_cost, [0.0, 0.0, 0.1], 0.1, MAX_EVALUATIONS);
        let held = [0.0, 0.0, y[0], y[1], y[2]];
        let held_mismatch = relative_mismatch(measured, params, &calibration_at(&held), &nominal);
        if !at_bound(&held) && held_mismatch <= free_mismatch * (1.0 + HELD_TOLERANCE) {
            held_at_data_sheet = Some(HeldScales {
                free_resistance: best[0].exp() as f32,
                free_inductance: best[1].exp() as f32,
                free_mismatch,
                held_mismatch,
            });
            best = held;
        } else {
            held_text = format!(
                "; held at the data sheet's the fit leaves a mismatch of {:.2} % against \
                 {:.2} % free",
                100.0 * held_mismatch,
                100.0 * free_mismatch
            );
        }
    }
    // A scale at its search bound explains nothing: the monitor model could not match the
    // trace's chirp within a factor 4 of the data sheet.
    for (name, x) in ["resistance", "inductance", "back-EMF", "friction"]
        .iter()
        .zip(&best)
    {
        if x.abs() >= 0.99 * LOG_BOUND {
            let start = measured.initial_angles();
            bail!(
                "the fit of the {name} scale ran into its bound (×{:.3}; the search spans \
                 ×0.25 … ×4 of the data sheet){held_text}: the monitor model cannot explain \
                 this trace with the description's parameters. The trace starts with the \
                 motor {:+.4} rad from where the record's rigging offset and the surface \
                 sensor put it (a few hundredths: `calibrate` without `--keep-offset` estimates it). Check the trace's \
                 current scale and sign (`import --scales`), the description's motor and \
                 controller against the actuator, and the controller's timing (`[drive] \
                 duty_delay`)",
                x.exp(),
                f64::from(start.motor - params.encoder_offset)
                    - f64::from(params.gear_ratio) * f64::from(start.user)
            );
        }
    }
    let mut calibration = calibration_at(&best);
    let problem = FitnessProblem::on_day(measured, params, &calibration, day)
        .map_err(|e| anyhow::anyhow!("the trace cannot be used for calibration: {e:?}"))?;
    calibration.nominal_residual = problem.raw_error(&nominal);
    if !calibration.nominal_residual.is_finite() {
        bail!("calibration failed: the nominal error is not finite");
    }
    Ok(CalibrationFile {
        format: FORMAT.into(),
        version: VERSION,
        resistance_scale: calibration.resistance_scale,
        inductance_scale: calibration.inductance_scale,
        back_emf_scale: calibration.back_emf_scale,
        friction_scale: calibration.friction_scale,
        damping: calibration.damping,
        nominal_residual: calibration.nominal_residual,
        pair_resistance_scale: calibration.pair_resistance_scale,
        pair_inductance_scale: calibration.pair_inductance_scale,
        temperature: calibration.temperature,
        friction_points: calibration.friction_points,
        magnet_coefficient: calibration.magnet_coefficient,
        duty_delay: calibration.duty_delay,
        viscous: calibration.viscous,
        drag_points: calibration.drag_points,
        encoder_offset: None,
        held_at_data_sheet,
        mismatch_before: relative_mismatch(measured, params, &Calibration::IDENTITY, &nominal),
        mismatch_after: relative_mismatch(measured, params, &calibration, &nominal),
        evaluations,
    })
}

/// Each pair's resistance [Ω] as the injection of `measured` shows it if the controller's
/// volts took effect `share` of a control period `dt` after their sample: the regression of
/// `shared::conditions::pair_impedances` in f64, without its physical checks (a negative R
/// is returned as it is). For messages: a controller whose timing the record does not
/// carry shows an R that moves by ≈ 5.6 Ω per period of delay on the reference actuator.
pub fn pair_resistances_at(measured: &OnboardMeasured, dt: f32, share: f64) -> [f64; 3] {
    let mut sums = [[0.0f64; 5]; 3];
    shared::conditions::injection_rows(measured, dt, share as f32, |pair, [y0, u, y]| {
        let (y0, u, y) = (f64::from(y0), f64::from(u), f64::from(y));
        if let Some(s) = sums.get_mut(pair) {
            for (slot, v) in s.iter_mut().zip([y0 * y0, y0 * u, u * u, y * y0, y * u]) {
                *slot += v;
            }
        }
    });
    sums.map(|s| {
        let det = s[0] * s[2] - s[1] * s[1];
        let a = (s[3] * s[2] - s[4] * s[1]) / det;
        let b = (s[0] * s[4] - s[1] * s[3]) / det;
        (1.0 - a) / b
    })
}

/// The least duty delay [s] that makes the injection's mean pair resistance at least
/// `floor` [Ω] (the pair's copper alone: the harness and switches only add), within one
/// control period `dt`; `None` if even one period does not. Bisection, 30 fits.
pub fn least_duty_delay(measured: &OnboardMeasured, dt: f32, floor: f64) -> Option<f64> {
    let mean = |share: f64| pair_resistances_at(measured, dt, share).iter().sum::<f64>() / 3.0;
    if mean(1.0) < floor {
        return None;
    }
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    for _ in 0..30 {
        let mid = 0.5 * (lo + hi);
        if mean(mid) < floor {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some(hi * f64::from(dt))
}

/// The least share of the data sheet's copper an installed pair circuit may show [-].
const MIN_COPPER_SHARE: f64 = 0.8;

/// The RMS of each pair's measured current over its fitted rows [A].
fn injection_rms(measured: &OnboardMeasured, dt: f32) -> [f64; 3] {
    let mut sums = [[0.0f64; 2]; 3];
    shared::conditions::injection_rows(measured, dt, 0.0, |pair, [_, _, y]| {
        if let Some(s) = sums.get_mut(pair) {
            s[0] += f64::from(y) * f64::from(y);
            s[1] += 1.0;
        }
    });
    sums.map(|[sq, n]| if n > 0.0 { (sq / n).sqrt() } else { 0.0 })
}

/// The injection's pairs as the messages name them.
const PAIR_NAMES: [&str; 3] = ["A→B", "B→C", "C→A"];

/// The healthy actuator's friction at the temperature of another healthy trace, against the
/// calibration's: the friction factor that best explains `measured` at the nominal vector,
/// everything else from `calibration` and the day the trace shows (winding temperature from
/// its injection). Returns `[measured °C, factor]`. At most 60 monitor-model runs.
pub fn friction_point(
    measured: &OnboardMeasured,
    params: ActuatorParams,
    calibration: &Calibration,
) -> Result<[f32; 2]> {
    let Some(celsius) = measured.conditions().temperature() else {
        bail!("the trace carries no measured temperature (a version 3 trace has `temp`)");
    };
    let day = TestConditions::estimate(measured, &params, calibration);
    // With a friction law by drag the point is measured at its own drag, as identification
    // will apply it (`grease_law`).
    let drag_rise = match measured.grease() {
        Ok(g) if calibration.viscous > 0.0 => g.viscous - calibration.viscous,
        _ => 0.0,
    };
    let nominal = FaultVector::NOMINAL;
    let cost = |log: f64| -> f64 {
        let at = TestConditions {
            friction_scale: log.exp() as f32,
            drag_rise,
            ..day
        };
        FitnessProblem::on_day(measured, params, calibration, at)
            .map_or(f64::INFINITY, |p| f64::from(p.raw_error(&nominal)))
    };
    // Golden-section search of ln(factor) over [ln ¼, ln 8].
    let (mut lo, mut hi) = ((0.25f64).ln(), (8.0f64).ln());
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut a, mut b) = (hi - g * (hi - lo), lo + g * (hi - lo));
    let (mut fa, mut fb) = (cost(a), cost(b));
    for _ in 0..60 {
        if fa < fb {
            hi = b;
            b = a;
            fb = fa;
            a = hi - g * (hi - lo);
            fa = cost(a);
        } else {
            lo = a;
            a = b;
            fa = fb;
            b = lo + g * (hi - lo);
            fb = cost(b);
        }
    }
    let factor = (0.5 * (lo + hi)).exp() as f32;
    Ok([celsius, factor])
}

/// Whether the grease has a drag of its own, from the chirp's drag on the calibration's
/// healthy trace `day` and on the `--at` traces `points`: their drags against the day's,
/// when they span at least `shared::calibration::DRAG_LAW_SPAN` (the day's 1 among them) and
/// fall as the measured temperatures rise. `Some((the day's viscous drag, each point's
/// ratio))` then; `None` for a grease whose drag does not move with temperature (friction
/// then follows the thermistor), a drag that does not fall with temperature, or a chirp
/// that gave no reading.
pub fn grease_law(day: &OnboardMeasured, points: &[&OnboardMeasured]) -> Option<(f32, Vec<f32>)> {
    let viscous = day.grease().ok()?.viscous;
    if viscous <= 0.0 {
        return None;
    }
    let ratios: Vec<f32> = points
        .iter()
        .map(|m| m.grease().map_or(f32::NAN, |g| g.viscous / viscous))
        .collect();
    if ratios.iter().any(|r| !(r.is_finite() && *r > 0.0)) {
        return None;
    }
    let (lo, hi) = ratios
        .iter()
        .fold((1.0f32, 1.0f32), |(lo, hi), &r| (lo.min(r), hi.max(r)));
    // The day's own point among the others, by temperature: the drag must fall.
    let mut by_temperature: Vec<(f32, f32)> = points
        .iter()
        .zip(&ratios)
        .map(|(m, &r)| (m.conditions().temperature().unwrap_or(f32::NAN), r))
        .collect();
    by_temperature.push((day.conditions().temperature().unwrap_or(f32::NAN), 1.0));
    by_temperature.sort_by(|a, b| a.0.total_cmp(&b.0));
    let falling = by_temperature.windows(2).all(|w| w[1].1 < w[0].1);
    (hi / lo >= shared::calibration::DRAG_LAW_SPAN && falling).then_some((viscous, ratios))
}

/// The record's friction law from measured points `([°C, factor], drag)`: rising in
/// temperature (`shared::conditions::friction_factor` reads them so), unused slots zero; at
/// most the record's four (more are dropped).
pub fn friction_law(mut points: Vec<([f32; 2], f32)>) -> ([[f32; 2]; 4], [f32; 4]) {
    points.sort_by(|a, b| a.0[0].total_cmp(&b.0[0]));
    let (mut friction, mut drag) = ([[0.0f32; 2]; 4], [0.0f32; 4]);
    for ((f, d), (point, ratio)) in friction.iter_mut().zip(&mut drag).zip(points) {
        *f = point;
        *d = ratio;
    }
    (friction, drag)
}

/// Half-width of the scan of the installation's start offset around the first frame's
/// reading [rad, motor side], and its step: the first frame reads the motor against the
/// surface through the gear's play and compliance and the transducer's own offset
/// (−0.0085 rad on the reference actuator), a few hundredths at most.
pub const OFFSET_SCAN_HALF_WIDTH: f32 = 0.03;
pub const OFFSET_SCAN_STEP: f32 = 0.0025;

/// The installation's start offset as the healthy trace's first frame reads it [rad, motor
/// side]: `θ_m − N·θ_u` (through the gear's play and compliance and the transducer's offset).
pub fn first_frame_offset(trace: &Trace, params: &ActuatorParams) -> Option<f32> {
    let first = trace.samples().first()?;
    Some((first.motor_angle - f64::from(params.gear_ratio) * first.user_angle) as f32)
}

/// The installation's start offset estimated from the healthy `trace` itself: the offset
/// [rad] within ± [`OFFSET_SCAN_HALF_WIDTH`] of the first frame's reading (every
/// [`OFFSET_SCAN_STEP`]) whose calibration (`params` with that offset, `prior`) leaves the
/// least mismatch; a refused fit counts as none. 25 calibrations. Returns the offset and its
/// mismatch, or `None` when the trace is empty or no offset calibrates.
pub fn estimate_offset(
    trace: &Trace,
    params: ActuatorParams,
    prior: &Calibration,
) -> Option<(f32, f64)> {
    let frame = first_frame_offset(trace, &params)?;
    let steps = (OFFSET_SCAN_HALF_WIDTH / OFFSET_SCAN_STEP).round() as i32;
    (-steps..=steps)
        .filter_map(|k| {
            let p = ActuatorParams {
                encoder_offset: frame + k as f32 * OFFSET_SCAN_STEP,
                ..params
            };
            let measured = trace.measured(&p).ok()?;
            let fit = calibrate(&measured, p, prior).ok()?;
            Some((p.encoder_offset, fit.mismatch_after))
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))
}

/// Temperatures of the reference actuator's climatic calibration [°C]: the healthy traces
/// whose friction makes the built-in friction law (`calibrate --at`).
pub const CLIMATIC_TEMPERATURES: [f64; 4] = [-45.0, -25.0, 0.0, 75.0];

/// How a built-in calibration of the reference model `model` is made, for its test: the
/// healthy trace (seed 0) at the model's day, calibrated with `prior`'s magnet coefficient;
/// for an injection test also the friction law from healthy traces (seed 0) at
/// [`CLIMATIC_TEMPERATURES`]. `host-sim calibrate … --at …` does the same from files.
pub fn reference_calibration(
    model: &crate::plant::reference::ReferenceModel,
    prior: &Calibration,
) -> Result<Calibration> {
    use crate::plant::reference::{ReferenceModel, Scenario};
    let params = model.settings().params;
    let healthy = |m: &ReferenceModel| {
        m.simulate(&Scenario::new(FaultVector::NOMINAL))
            .trace
            .measured(&params)
    };
    let day = healthy(model)?;
    let mut calibration = calibrate(&day, params, prior)?.calibration();
    if model.test().standstill.is_some_and(|s| s.is_injection()) {
        let traces = CLIMATIC_TEMPERATURES
            .iter()
            .map(|&celsius| {
                let mut settings = *model.settings();
                settings.conditions = settings.conditions.at_temperature(celsius);
                healthy(&ReferenceModel::new(settings).with_test(*model.test()))
            })
            .collect::<Result<Vec<_>>>()?;
        let refs: Vec<&OnboardMeasured> = traces.iter().map(|b| &**b).collect();
        let law = grease_law(&day, &refs);
        calibration.viscous = law.as_ref().map_or(0.0, |l| l.0);
        let mut points = Vec::new();
        for (j, measured) in refs.iter().enumerate() {
            let drag = law.as_ref().map_or(0.0, |l| l.1[j]);
            points.push((friction_point(measured, params, &calibration)?, drag));
        }
        (calibration.friction_points, calibration.drag_points) = friction_law(points);
    }
    Ok(calibration)
}

/// Nelder–Mead simplex minimisation in `D` dimensions from `start` with initial step
/// `step`, at most `budget` cost evaluations. Returns the best point seen.
fn nelder_mead<const D: usize>(
    cost: &mut impl FnMut(&[f64; D]) -> f64,
    start: [f64; D],
    step: f64,
    budget: u32,
) -> [f64; D] {
    let mut used = 0u32;
    let mut eval = |x: [f64; D], used: &mut u32| {
        *used += 1;
        (x, cost(&x))
    };
    let mut simplex: Vec<([f64; D], f64)> = (0..=D)
        .map(|j| {
            let mut x = start;
            if j > 0 {
                x[j - 1] += step;
            }
            eval(x, &mut used)
        })
        .collect();
    let lerp = |a: &[f64; D], b: &[f64; D], t: f64| -> [f64; D] {
        core::array::from_fn(|i| a[i] + t * (b[i] - a[i]))
    };
    while used as usize + D <= budget as usize {
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        let spread = simplex[D].1 - simplex[0].1;
        if spread.abs() <= 1e-12 * simplex[0].1.abs().max(1e-30) {
            break;
        }
        let centroid: [f64; D] =
            core::array::from_fn(|i| simplex[..D].iter().map(|s| s.0[i]).sum::<f64>() / D as f64);
        let worst = simplex[D];
        let reflected = eval(lerp(&centroid, &worst.0, -1.0), &mut used);
        if reflected.1 < simplex[0].1 {
            let expanded = eval(lerp(&centroid, &worst.0, -2.0), &mut used);
            simplex[D] = if expanded.1 < reflected.1 {
                expanded
            } else {
                reflected
            };
        } else if reflected.1 < simplex[D - 1].1 {
            simplex[D] = reflected;
        } else {
            let contracted = if reflected.1 < worst.1 {
                eval(lerp(&centroid, &reflected.0, 0.5), &mut used)
            } else {
                eval(lerp(&centroid, &worst.0, 0.5), &mut used)
            };
            if contracted.1 < worst.1.min(reflected.1) {
                simplex[D] = contracted;
            } else {
                let best = simplex[0].0;
                for s in simplex.iter_mut().skip(1) {
                    let x = lerp(&best, &s.0, 0.5);
                    *s = eval(x, &mut used);
                }
            }
        }
    }
    simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
    simplex[0].0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nelder_mead_finds_a_quadratic_minimum() {
        let mut f = |x: &[f64; 3]| {
            (x[0] - 0.3).powi(2) + 2.0 * (x[1] + 0.2).powi(2) + 0.5 * (x[2] - 0.1).powi(2)
        };
        let x = nelder_mead(&mut f, [0.0; 3], 0.1, 400);
        assert!(
            (x[0] - 0.3).abs() < 1e-3 && (x[1] + 0.2).abs() < 1e-3 && (x[2] - 0.1).abs() < 1e-3,
            "{x:?}"
        );
    }
}

#[cfg(test)]
mod reference_tests {
    use super::*;
    use crate::plant::reference::{ReferenceModel, ReferenceSettings, Scenario};
    use shared::test_design::PreflightTest;

    /// The calibrations the firmware and `identify` use by default are exactly what the fit
    /// gives on the healthy reference traces (seed 0) of each test: stored tables, checked.
    /// The default (injection) test on the real bridge with its climatic friction law; the
    /// earlier designs on the ideal drive they were calibrated on.
    #[test]
    fn built_in_calibration_is_what_the_fit_gives() {
        // The reference actuator's NdFeB magnets (actuators/reference.toml [motor]).
        let magnets = Calibration {
            magnet_coefficient: -0.0011,
            ..Calibration::IDENTITY
        };
        for (settings, test, prior) in [
            (
                ReferenceSettings::REFERENCE,
                PreflightTest::INJECTION,
                magnets,
            ),
            (
                ReferenceSettings::IDEAL_DRIVE,
                PreflightTest::STANDSTILL,
                Calibration::IDENTITY,
            ),
            (
                ReferenceSettings::IDEAL_DRIVE,
                PreflightTest::PAPER,
                Calibration::IDENTITY,
            ),
        ] {
            let model = ReferenceModel::new(settings).with_test(test);
            let fit = reference_calibration(&model, &prior).unwrap();
            assert_eq!(
                fit,
                Calibration::reference_actuator(&test),
                "{test:?}: {fit:?}"
            );
            // Calibration never makes the nominal fit worse.
            let measured = model
                .simulate(&Scenario::new(FaultVector::NOMINAL))
                .trace
                .measured(&ActuatorParams::REFERENCE)
                .unwrap();
            let file = calibrate(&measured, ActuatorParams::REFERENCE, &prior).unwrap();
            assert!(file.mismatch_after <= file.mismatch_before);
        }
    }
}
