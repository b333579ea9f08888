//! What no preflight can read on a one-factor grease whose gearbox runs apart from the
//! winding's thermistor: the test's currents see the gear's friction, `r·F·(1 + 2·k1)`, with
//! `r` the grease's friction at the gearbox's temperature over its friction at the
//! winding's, and the friction law gives `F` at the winding's. A friction fault `k1` and a
//! gearbox `r` away give the same currents as the fault `k1' = (r·(1 + 2·k1) − 1) / 2` at
//! `r = 1`, so any reading errs by at least `|k1 − k1'| / 2` on one of the two; a reader
//! that takes the law's healthy friction (the FDI where the fault exceeds it) errs by
//! `|k1 − k1'|`. Printed per held-out draw of the physics family
//! (`host_sim::studies::physics`) and day, for no friction fault (every other Table I case)
//! and Table I's friction 0.4 and 1.0, as e_tot of
//! the paper's eight components (a single fault's error over √8), with `k1'` clipped to
//! [0, 1]. Two-part greases are listed without a bound: their drag is a thermometer of the
//! gearbox the test can read.
//!
//! `cargo run --release -p host-sim --example gear_temperature_bound -- [FIRST] [DRAWS]`
//! (instant).

use host_sim::files::actuator::Actuator;
use host_sim::studies::physics::{Grease, PhysicsDraw, DAYS};

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1).map(|a| a.parse::<u64>());
    let first = args.next().transpose()?.unwrap_or(20);
    let draws = args.next().transpose()?.unwrap_or(10);
    let base = Actuator::reference().reference_settings()?;
    println!(
        "| draw | gear − winding [K] | day | r | no friction fault: reads, e_tot floor / law's [%] | friction 0.4: the same | friction 1.0: the same |"
    );
    println!("| --- | ---: | --- | ---: | --- | --- | --- |");
    for seed in first..first + draws {
        let draw = PhysicsDraw::draw(seed);
        if matches!(draw.grease, Grease::TwoPart { .. }) {
            println!(
                "| {seed} | {:+.1} | – | – | two-part grease: its drag is a thermometer | | |",
                draw.gear_offset
            );
            continue;
        }
        for (day, delta) in DAYS {
            let s = draw.settings(&base, delta, false);
            let winding = s.conditions.winding_temperature;
            let gear = s.conditions.gear_temperature;
            let r = s.thermal.friction_scale(gear) / s.thermal.friction_scale(winding);
            let cell = |k1: f64| {
                let read = ((r * (1.0 + 2.0 * k1) - 1.0) / 2.0).clamp(0.0, 1.0);
                let e = 100.0 * (read - k1).abs() / 8f64.sqrt();
                format!("{read:.2}, {:.1} / {e:.1}", e / 2.0)
            };
            println!(
                "| {seed} | {:+.1} | {day} | {r:.3} | {} | {} | {} |",
                gear - winding,
                cell(0.0),
                cell(0.4),
                cell(1.0)
            );
        }
    }
    Ok(())
}
