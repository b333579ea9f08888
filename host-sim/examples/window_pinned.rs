//! Whether a window of flight fits when the model's surface follows its sensor (issue 36,
//! docs/in-flight.md): the window model at the true vector, cruise, the healthy actuator
//! and Table II medium, light and moderate turbulence, seeds FIRST … FIRST + N − 1
//! (`cargo run --release -p host-sim --example window_pinned [N [W [FIRST [more]]]]`: N = 4,
//! W = 0, FIRST = 0 by default, ≈ 10 s; `more` adds six of Table I's cases, ≈ 1 min for ten
//! seeds). Per window, the share of the measured current's energy the fit leaves (the
//! window's `fitness_floor` is 1 %) under:
//!
//! - `fitted`: the window's own load (`WindowProblem::fit_load`: a spring, its moment at the
//!   start and a trend of ten Legendre terms);
//! - `pinned`: no load at all — each sample the model's surface is put where the surface
//!   sensor read it, moving at the sensor's central difference over four samples
//!   (`WindowProblem::evaluate_with_surface_samples`): the gear carries what the motor's
//!   side and the measured surface make of it. Where the run starts in the play (the moment
//!   at the start) is scanned;
//! - `pinned, friction ±0.3`: the same start with the friction moved by 0.3;
//! - `identified`: friction, backlash and gain drift searched from nominal with the pinned
//!   surface (Nelder–Mead over them and the start, three starts of the backlash; the other
//!   components at the truth, as a flight holds them at its preflight's reading), its
//!   misfit and e_tot [%] against the truth.
//!
//! W weighs the motor angle's variance about its mean against the measured motor encoder
//! (in units of 1 mrad², against the current's misfit; 0: the current alone).
//!
//! A study, not the product: the window identification does not pin the surface.

#[allow(dead_code)] // each study reads a part of what the module sets up
mod cruise_window;

use cruise_window::{CruiseWindow, CASES};
use host_sim::plant::aero::Turbulence;
use shared::window::{SurfaceSamples, WindowLoad};
use shared::FaultVector;

/// Table I's cases beside them (the fourth argument `more`).
const MORE_CASES: [(&str, [f32; 9]); 6] = [
    (
        "friction 0.2",
        [0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0],
    ),
    (
        "backlash 0.1",
        [0.0, 0.1, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0],
    ),
    (
        "backlash 1.0",
        [0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0],
    ),
    ("short A 0.2", [0.0, 0.0, 0.2, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0]),
    (
        "gain drift 0.0",
        [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.0, 0.0],
    ),
    (
        "gain drift 1.0",
        [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 1.0, 0.0],
    ),
];

/// The motor angle's error that weighs as much as the whole current [rad, motor side].
const MOTOR_SCALE: f64 = 1.0e-3;

fn main() {
    let seeds: u64 = std::env::args()
        .nth(1)
        .map(|a| a.parse().expect("N: a count of seeds"))
        .unwrap_or(4);
    let motor_weight: f64 = std::env::args()
        .nth(2)
        .map(|a| a.parse().expect("W: the motor angle's weight"))
        .unwrap_or(0.0);
    let first: u64 = std::env::args()
        .nth(3)
        .map(|a| a.parse().expect("FIRST: the first seed"))
        .unwrap_or(0);
    let more = std::env::args().nth(4).is_some_and(|a| a == "more");
    let cases: Vec<(&str, [f32; 9])> = CASES
        .into_iter()
        .chain(more.then_some(MORE_CASES).into_iter().flatten())
        .collect();
    let record = cruise_window::record();
    println!(
        "| turbulence | case | seed | fitted | pinned | pinned, friction ±0.3 | start moment [N·m] | identified: misfit | e_tot [%] | friction, backlash, gain drift |"
    );
    println!("| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- |");
    for turbulence in [Turbulence::Light, Turbulence::Moderate] {
        for &(name, faults) in &cases {
            for seed in first..first + seeds {
                let truth = FaultVector::new(faults).expect("a valid vector");
                let cruise = CruiseWindow::simulate(&truth, turbulence, seed);
                let sim = &cruise.sim;
                let problem = cruise.problem();
                let (load, fitted) = problem.fit_load(&truth, record.params.aero_stiffness);

                let (angles, speeds) = cruise.sensed_surface();
                let n = angles.len();
                let mut motor = Vec::with_capacity(n);
                let (mut turned, mut last) = (0.0f64, sim.trace.samples()[0].motor_angle);
                for s in sim.trace.samples() {
                    let step = (s.motor_angle - last + std::f64::consts::PI)
                        .rem_euclid(std::f64::consts::TAU)
                        - std::f64::consts::PI;
                    turned += step;
                    last = s.motor_angle;
                    motor.push((sim.trace.samples()[0].motor_angle + turned) as f32);
                }
                let surface = SurfaceSamples {
                    angles: &angles,
                    speeds: &speeds,
                    motor: &motor,
                };
                // The objective: the current's misfit plus the motor angle's variance about
                // its mean (the surface sensor's offset from the motor's rigging is not known)
                // in units of MOTOR_SCALE².
                let objective = |fit: shared::window::WindowFit, motor: f64| -> f64 {
                    f64::from(problem.misfit(fit.error))
                        + motor_weight * motor / (MOTOR_SCALE * MOTOR_SCALE)
                };
                let mut best = (f32::INFINITY, 0.0f32);
                for m in -60..=60 {
                    let moment = load.moment + 10.0 * m as f32;
                    let l = WindowLoad::spring(load.stiffness, moment);
                    let (fit, mean, ms) =
                        problem.evaluate_with_surface_samples(&truth, l, &surface, &mut []);
                    let m = ms - mean * mean;
                    let e = objective(fit, m) as f32;
                    if e < best.0 {
                        best = (e, moment);
                    }
                }
                let evaluate = |x: &[f64; 4]| -> f64 {
                    let mut k = *truth.as_array();
                    k[0] = x[0].clamp(0.0, 1.0) as f32;
                    k[1] = x[1].clamp(0.0, 1.0) as f32;
                    k[7] = x[2].clamp(0.0, 1.0) as f32;
                    let Ok(k) = FaultVector::new(k) else {
                        return f64::INFINITY;
                    };
                    let l = WindowLoad::spring(load.stiffness, x[3] as f32);
                    let (fit, mean, ms) =
                        problem.evaluate_with_surface_samples(&k, l, &surface, &mut []);
                    let m = ms - mean * mean;
                    objective(fit, m)
                };
                let mut found = ([0.0f64; 4], f64::INFINITY);
                for backlash in [0.1, 0.5, 0.9] {
                    let x = nelder_mead(&evaluate, [0.0, backlash, 0.5, f64::from(best.1)], 400);
                    if x.1 < found.1 {
                        found = x;
                    }
                }
                let mut k = *truth.as_array();
                k[0] = found.0[0].clamp(0.0, 1.0) as f32;
                k[1] = found.0[1].clamp(0.0, 1.0) as f32;
                k[7] = found.0[2].clamp(0.0, 1.0) as f32;
                let k = FaultVector::new(k).expect("clamped");
                // The same start with the friction moved by 0.3 (down from 0.4, up from 0).
                let moved = {
                    let mut k = *truth.as_array();
                    k[0] = if k[0] > 0.2 { k[0] - 0.3 } else { k[0] + 0.3 };
                    FaultVector::new(k).expect("a valid vector")
                };
                let l = WindowLoad::spring(load.stiffness, best.1);
                let (fit, mean, ms) =
                    problem.evaluate_with_surface_samples(&moved, l, &surface, &mut []);
                let friction_moved = objective(fit, ms - mean * mean);
                println!(
                    "| {turbulence:?} | {name} | {seed} | {:.3} | {:.3} | {friction_moved:.3} | {:.0} | {:.3} | {:.2} | {:.3}, {:.3}, {:.3} |",
                    problem.misfit(fitted),
                    best.0,
                    best.1,
                    found.1,
                    shared::metrics::total_error(&k, &truth),
                    k.as_array()[0],
                    k.as_array()[1],
                    k.as_array()[7],
                );
            }
        }
    }
}

/// Nelder–Mead from `start` (steps 0.2 on the components, 20 N·m on the start's moment),
/// at most `budget` evaluations: the best point and its value.
fn nelder_mead(f: &impl Fn(&[f64; 4]) -> f64, start: [f64; 4], budget: usize) -> ([f64; 4], f64) {
    let steps = [0.2, 0.2, 0.2, 20.0];
    let mut simplex: Vec<([f64; 4], f64)> = (0..5)
        .map(|j| {
            let mut x = start;
            if j > 0 {
                x[j - 1] += steps[j - 1];
            }
            (x, f(&x))
        })
        .collect();
    let mut used = 5;
    while used < budget {
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        let mut centre = [0.0; 4];
        for (x, _) in &simplex[..4] {
            for d in 0..4 {
                centre[d] += x[d] / 4.0;
            }
        }
        let worst = simplex[4];
        let along = |t: f64| -> [f64; 4] {
            let mut x = [0.0; 4];
            for d in 0..4 {
                x[d] = centre[d] + t * (worst.0[d] - centre[d]);
            }
            x
        };
        let r = along(-1.0);
        let fr = f(&r);
        used += 1;
        if fr < simplex[0].1 {
            let e = along(-2.0);
            let fe = f(&e);
            used += 1;
            simplex[4] = if fe < fr { (e, fe) } else { (r, fr) };
        } else if fr < simplex[3].1 {
            simplex[4] = (r, fr);
        } else {
            let c = along(0.5);
            let fc = f(&c);
            used += 1;
            if fc < worst.1 {
                simplex[4] = (c, fc);
            } else {
                let best = simplex[0].0;
                for s in simplex.iter_mut().skip(1) {
                    for (v, b) in s.0.iter_mut().zip(best) {
                        *v = b + 0.5 * (*v - b);
                    }
                    s.1 = f(&s.0);
                    used += 1;
                }
            }
        }
    }
    simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
    simplex[0]
}
