//! The pinned window's error landscape (issue 36; docs/in-flight.md): why its
//! search scans the gain drift finely first and the play on a grid of 0.05. A cruise window
//! of the built-in actuator simulated by the reference model, every component but the
//! backlash, the gain drift and the start's moment at the truth (as a flight holds them at
//! its preflight's), the surface pinned to its sensor; the share of the current's energy
//! left unexplained [‰, capped at 999] along the gain drift at the true play, and along the
//! play at the true gain drift, at starts about the load model's moment
//! (`cargo run --release -p host-sim --example window_pinned_landscape [low|medium [SEED
//! [light|moderate]]]`; low, 0, moderate by default; ≈ 2 s).

#[allow(dead_code)] // each study reads a part of what the module sets up
mod cruise_window;

use cruise_window::CruiseWindow;
use host_sim::plant::aero::Turbulence;
use shared::window::{HeldComponents, SurfaceSamples, WindowLoad};
use shared::FaultVector;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let faults = match args.get(1).map(String::as_str) {
        Some("medium") => [0.4, 0.4, 0.2, 0.1, 0.05, 0.2, 0.75, 0.6, 0.0],
        _ => [0.1, 0.1, 0.1, 0.05, 0.0, 0.1, 0.25, 0.4, 0.0],
    };
    let seed: u64 = args
        .get(2)
        .map(|a| a.parse().expect("SEED: a number"))
        .unwrap_or(0);
    let turbulence = match args.get(3).map(String::as_str) {
        Some("light") => Turbulence::Light,
        _ => Turbulence::Moderate,
    };
    let truth = FaultVector::new(faults).expect("a valid vector");
    let cruise = CruiseWindow::simulate(&truth, turbulence, seed);
    let record = cruise_window::record();
    let stiffness = record.params.aero_stiffness;
    let problem = cruise.problem();
    let (load, _) = problem.fit_load(&truth, stiffness);
    let problem = problem.with_held(HeldComponents::of_preflight(&truth).also_holding(0));
    let (angles, speeds) = cruise.sensed_surface();
    let surface = SurfaceSamples {
        angles: &angles,
        speeds: &speeds,
        motor: &[],
    };
    let misfit = |play: f32, gain: f32, moment: f32| -> u32 {
        let mut k = *truth.as_array();
        k[1] = play;
        k[7] = gain;
        let (fit, _, _) = problem.evaluate_with_surface_samples(
            &FaultVector::saturating(k),
            WindowLoad::spring(stiffness, moment),
            &surface,
            &mut [],
        );
        (problem.misfit(fit.error) * 1000.0).round().min(999.0) as u32
    };
    let (play, gain) = (faults[1], faults[7]);
    println!(
        "{turbulence:?} cruise, seed {seed}: backlash {play}, gain drift {gain}; the load model's start {:.0} N·m",
        load.moment
    );
    let starts = [-120.0f32, -60.0, 0.0, 60.0, 120.0];
    let table = |title: &str, along: &[f32], at: &dyn Fn(f32, f32) -> u32| {
        println!("\nunexplained [‰] {title}:\n");
        print!("| start − guess [N·m] |");
        for x in along {
            print!(" {x:.2} |");
        }
        println!("\n| ---: |{}", " ---: |".repeat(along.len()));
        for d in starts {
            print!("| {d:+.0} |");
            for &x in along {
                print!(" {} |", at(x, load.moment + d));
            }
            println!();
        }
    };
    let gains: Vec<f32> = (0..=10).map(|i| gain - 0.05 + 0.01 * i as f32).collect();
    table(
        &format!("along the gain drift at backlash {play}"),
        &gains,
        &|g, m| misfit(play, g, m),
    );
    let plays: Vec<f32> = (0..=20).map(|i| 0.05 * i as f32).collect();
    table(
        &format!("along the backlash at gain drift {gain}"),
        &plays,
        &|p, m| misfit(p, gain, m),
    );
}
