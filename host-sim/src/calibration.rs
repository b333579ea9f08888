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
use shared::fdi::OnboardMeasured;
use shared::{ActuatorParams, Calibration, FaultVector, FitnessProblem, MonitorModel};

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
    /// Relative RMS mismatch of the filtered equivalent current, nominal vector, before and
    /// after calibration [-].
    pub mismatch_before: f64,
    pub mismatch_after: f64,
    /// Monitor-model runs the fit took.
    pub evaluations: u32,
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

/// Fits the calibration to a healthy measured trace.
pub fn calibrate(measured: &OnboardMeasured, params: ActuatorParams) -> Result<CalibrationFile> {
    let nominal = FaultVector::NOMINAL;
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
    };
    let mut evaluations = 0u32;
    let mut cost = |x: &[f64; 5]| -> f64 {
        evaluations += 1;
        if !in_bounds(x) {
            return f64::INFINITY;
        }
        match FitnessProblem::new(measured, params, &calibration_at(x)) {
            Ok(problem) => f64::from(problem.raw_error(&nominal)),
            Err(_) => f64::INFINITY,
        }
    };
    let best = nelder_mead(&mut cost, [0.0, 0.0, 0.0, 0.0, 0.1], 0.1, MAX_EVALUATIONS);
    let mut calibration = calibration_at(&best);
    let problem = FitnessProblem::new(measured, params, &calibration)
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
        mismatch_before: relative_mismatch(measured, params, &Calibration::IDENTITY, &nominal),
        mismatch_after: relative_mismatch(measured, params, &calibration, &nominal),
        evaluations,
    })
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
    use crate::reference::{ReferenceModel, ReferenceSettings, Scenario};
    use shared::test_design::PreflightTest;

    /// The calibrations the firmware and `identify` use by default are exactly what the fit
    /// gives on the healthy reference trace (seed 0) of each test: stored tables, checked.
    #[test]
    fn built_in_calibration_is_what_the_fit_gives() {
        for test in [PreflightTest::STANDSTILL, PreflightTest::PAPER] {
            let sim = ReferenceModel::new(ReferenceSettings::REFERENCE)
                .with_test(test)
                .simulate(&Scenario::new(FaultVector::NOMINAL));
            let params = ActuatorParams::REFERENCE;
            let measured = sim.trace.measured(&params).unwrap();
            let fit = calibrate(&measured, params).unwrap();
            assert_eq!(
                fit.calibration(),
                Calibration::reference_actuator(&test),
                "{test:?}: {fit:?}"
            );
            // Calibration never makes the nominal fit worse.
            assert!(fit.mismatch_after <= fit.mismatch_before);
        }
    }
}
