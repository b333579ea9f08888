//! What a window's load must follow for a wide play to be read in flight (issue 36,
//! docs/in-flight.md "Backlash in flight"): the window model at the true vector, cruise,
//! the healthy actuator and Table II medium, light and moderate turbulence, seeds 0…N−1
//! (`cargo run --release -p host-sim --example window_moment [N]`, N = 4 by default,
//! ≈ 1 min). Per window, the share of the measured current's energy the fit leaves (the
//! window's `fitness_floor` is 1 %) under:
//!
//! - `fitted`: the window's own load (`WindowProblem::fit_load`: a spring, its moment at the
//!   start and a trend of ten Legendre terms);
//! - `true`: the reference model's turbulence moment sample by sample (its incidence's hinge
//!   moment, `q·S·c·C_hα·Δα`), the spring's stiffness (0.8–1.2 × the fitted) and the
//!   moment at the start (±200 N·m about the fitted) scanned;
//! - `L10`, `L40`: the same moment's least-squares fit by 10 and 40 Legendre terms;
//! - `angles`: the moment estimated from what the controller measures — the gear's
//!   deflection (the motor encoder over the ratio minus the surface sensor, the play's
//!   centre scanned) through its stiffness, the surface's inertia times the motor encoder's
//!   acceleration over the ratio, the spring's moment on the surface sensor; each smoothed
//!   over 21 samples — and its RMS error against the true moment [N·m].
//!
//! A study, not the product: the window identification does not use a moment per sample.

#[allow(dead_code)] // each study reads a part of what the module sets up
mod cruise_window;

use cruise_window::{CruiseWindow, CASES, SETTINGS};
use host_sim::plant::aero::Turbulence;
use host_sim::plant::reference::WIND_SETTLE;
use shared::actuator::ActuatorRecord;
use shared::window::{WindowLoad, WindowProblem};
use shared::FaultVector;

/// Half the width of the moving averages [samples].
const HALF_WIDTH: usize = 10;

fn main() {
    let seeds: u64 = std::env::args()
        .nth(1)
        .map(|a| a.parse().expect("N: a count of seeds"))
        .unwrap_or(4);
    let (settings, record) = (SETTINGS, cruise_window::record());
    println!(
        "| turbulence | case | seed | moment RMS [N·m] | fitted | true | L10 | L40 | angles | angles' error RMS [N·m] |"
    );
    println!("| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |");
    for turbulence in [Turbulence::Light, Turbulence::Moderate] {
        for (name, faults) in CASES {
            for seed in 0..seeds {
                let truth = FaultVector::new(faults).expect("a valid vector");
                let cruise = CruiseWindow::simulate(&truth, turbulence, seed);
                let (window, sim) = (cruise.window, &cruise.sim);
                let problem = cruise.problem();
                let (load, fitted) = problem.fit_load(&truth, record.params.aero_stiffness);

                // The true turbulence moment on the surface, relative to the window's start:
                // the reference model's incidence sequence for this seed, after its hold.
                let period = f64::from(record.params.control_period);
                let hold = (settings.pre_roll.max(WIND_SETTLE) / period).round() as usize;
                let n = sim.trace.samples().len();
                let scale = window.phase.dynamic_pressure()
                    * settings.surface.area
                    * settings.surface.chord;
                let incidence = window.samples(hold + n, period, seed);
                let at_start = incidence[hold].incidence;
                let moment: Vec<f64> = (0..n)
                    .map(|i| {
                        scale
                            * settings.surface.ch_alpha
                            * (incidence[hold + i].incidence - at_start)
                    })
                    .collect();
                let rms =
                    |x: &[f64]| (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt();

                // The window model pushes −h: h is what the motor holds against the moment.
                let best = |pushed: &[f64]| -> f32 {
                    let h: Vec<f32> = pushed.iter().map(|v| -(*v as f32)).collect();
                    let mut least = f32::INFINITY;
                    for s in 0..=8 {
                        let stiffness = load.stiffness * (0.8 + 0.05 * s as f32);
                        for m in -25..=25 {
                            let l = WindowLoad::spring(stiffness, load.moment + 8.0 * m as f32);
                            least = least
                                .min(problem.evaluate_with_moment_samples(&truth, l, &h).error);
                        }
                    }
                    problem.misfit(least)
                };
                let (estimate, error) =
                    from_angles(&sim.trace, &record, &truth, load, &moment, &problem);
                println!(
                    "| {turbulence:?} | {name} | {seed} | {:.1} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.1} |",
                    rms(&moment),
                    problem.misfit(fitted),
                    best(&moment),
                    best(&legendre_fit(&moment, 10)),
                    best(&legendre_fit(&moment, 40)),
                    estimate,
                    error,
                );
            }
        }
    }
}

/// The least-squares fit of `x` (samples over the window) by `terms` Legendre polynomials of
/// the window's axis, shifted to start at 0.
fn legendre_fit(x: &[f64], terms: usize) -> Vec<f64> {
    let n = x.len();
    let axis: Vec<f64> = (0..n)
        .map(|i| -1.0 + 2.0 * i as f64 / (n - 1) as f64)
        .collect();
    let mut fit = vec![0.0f64; n];
    let (mut older, mut old) = (vec![1.0f64; n], axis.clone());
    for j in 0..terms {
        let p: Vec<f64> = match j {
            0 => vec![1.0; n],
            1 => axis.clone(),
            _ => {
                let next: Vec<f64> = (0..n)
                    .map(|i| {
                        ((2 * j - 1) as f64 * axis[i] * old[i] - (j - 1) as f64 * older[i])
                            / j as f64
                    })
                    .collect();
                older = std::mem::replace(&mut old, next.clone());
                next
            }
        };
        let along: f64 = p.iter().zip(x).map(|(a, b)| a * b).sum();
        let norm: f64 = p.iter().map(|a| a * a).sum();
        for (f, a) in fit.iter_mut().zip(&p) {
            *f += along / norm * a;
        }
    }
    let start = fit[0];
    fit.iter().map(|v| v - start).collect()
}

/// The centred moving average of `x` over `2·half + 1` samples (fewer at the ends).
fn smooth(x: &[f64], half: usize) -> Vec<f64> {
    (0..x.len())
        .map(|i| {
            let (a, b) = (i.saturating_sub(half), (i + half + 1).min(x.len()));
            x[a..b].iter().sum::<f64>() / (b - a) as f64
        })
        .collect()
}

/// The turbulence moment estimated from the trace's two angles (the play's centre and the
/// moment at the start scanned about the fitted `load`'s, each candidate's fit at the
/// truth): the best candidate's misfit and its RMS error against `truth_moment` [N·m].
fn from_angles(
    trace: &host_sim::files::trace::Trace,
    record: &ActuatorRecord,
    truth: &FaultVector,
    load: WindowLoad,
    truth_moment: &[f64],
    problem: &WindowProblem<'_, { shared::fdi::TEST_SAMPLES }>,
) -> (f32, f64) {
    let p = record.params;
    let samples = trace.samples();
    let n = samples.len();
    let period = f64::from(p.control_period);
    let gear = f64::from(p.gear_ratio);
    // The motor encoder unwrapped, over the ratio: the surface's angle as the motor sees it.
    let mut motor = Vec::with_capacity(n);
    let (mut turned, mut last) = (0.0f64, samples[0].motor_angle);
    for s in samples {
        let step = (s.motor_angle - last + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
            - std::f64::consts::PI;
        turned += step;
        last = s.motor_angle;
        motor.push(turned / gear);
    }
    let surface: Vec<f64> = samples.iter().map(|s| s.user_angle).collect();
    let motor_smooth = smooth(&motor, HALF_WIDTH);
    let acceleration: Vec<f64> = (0..n)
        .map(|i| {
            if i == 0 || i + 1 == n {
                0.0
            } else {
                (motor_smooth[i + 1] - 2.0 * motor_smooth[i] + motor_smooth[i - 1])
                    / (period * period)
            }
        })
        .collect();
    let acceleration = smooth(&acceleration, HALF_WIDTH);
    let deflection = smooth(
        &motor
            .iter()
            .zip(&surface)
            .map(|(m, u)| m - u)
            .collect::<Vec<_>>(),
        HALF_WIDTH,
    );
    let surface = smooth(&surface, HALF_WIDTH);
    let half_play = 0.5 * f64::from(p.nominal_backlash) * f64::from(truth.effects().backlash_scale);
    let (gear_stiffness, inertia) = (f64::from(p.gear_stiffness), f64::from(p.user_inertia));
    let mut best = (f32::INFINITY, f64::NAN);
    for c in -30..=30 {
        let centre = deflection[0] + c as f64 * (half_play + 2.0e-5) / 15.0;
        let moment: Vec<f64> = (0..n)
            .map(|i| {
                let e = deflection[i] - centre;
                let engaged = e - e.clamp(-half_play, half_play);
                inertia * acceleration[i] - gear_stiffness * engaged
                    + f64::from(load.stiffness) * surface[i]
            })
            .collect();
        let relative: Vec<f64> = moment.iter().map(|m| m - moment[0]).collect();
        let h: Vec<f32> = relative.iter().map(|v| -(*v as f32)).collect();
        for m in -25..=25 {
            let l = WindowLoad::spring(load.stiffness, load.moment + 8.0 * m as f32);
            let e = problem.evaluate_with_moment_samples(truth, l, &h).error;
            if e < best.0 {
                let error = (relative
                    .iter()
                    .zip(truth_moment)
                    .map(|(a, b)| (a - b) * (a - b))
                    .sum::<f64>()
                    / n as f64)
                    .sqrt();
                best = (e, error);
            }
        }
    }
    (problem.misfit(best.0), best.1)
}
