//! The test schedule (`host-sim test-schedule`): what the controller commands during the
//! actuator's preflight test, control period by control period, as a CSV a rig engineer can
//! play on a bench drive. The firmware's `TestSequencer` plays the same rows.

use std::path::Path;

use anyhow::{Context, Result};
use shared::test_design::{Drive, PreflightTest, PAIR_SIGNS};

use crate::files::actuator::Actuator;

/// The schedule's CSV header.
pub const SCHEDULE_HEADER: &str = "sample,t,mode,pair,value";

/// The schedule of `test` at control period `dt` [s]: one row per control period.
pub fn schedule_csv(test: &PreflightTest, dt: f32) -> String {
    let mut out = String::new();
    out += "# ema-fdi preflight test schedule: what the controller commands over each control period\n";
    out += &format!(
        "# test: {}; control period {} s; {} samples\n",
        test.kind_name(),
        dt,
        test.samples(dt)
    );
    out += "# mode position: value = user-shaft angle command [rad] (position loop closed)\n";
    out += "# mode voltage: value = line voltage across pair (+ phase minus − phase) [V], position loop suspended\n";
    out += "# mode off: the pair freewheels at 0 V (or the settle before the first pair)\n";
    out += SCHEDULE_HEADER;
    out.push('\n');
    let name = |pair: usize| {
        let signs = PAIR_SIGNS.get(pair).copied().unwrap_or([0; 3]);
        let phase = |s: i8| {
            signs
                .iter()
                .position(|&x| x == s)
                .map_or('-', |x| ['A', 'B', 'C'][x])
        };
        format!("{}{}", phase(1), phase(-1))
    };
    // Time from the rate, so that 10 kHz prints 0.0001, 0.0002, …
    let rate = (1.0 / f64::from(dt)).round();
    for k in 0..test.samples(dt) {
        let t = k as f64 / rate;
        match test.drive(k, dt) {
            Drive::Position(x) => out += &format!("{k},{t},position,-,{x:?}\n"),
            Drive::Pair(d) => {
                let v = d.voltage(dt);
                let mode = if d.volts == 0.0 { "off" } else { "voltage" };
                out += &format!("{k},{t},{mode},{},{v:?}\n", name(d.pair));
            }
        }
    }
    out
}

pub fn write_schedule(actuator: &Actuator, out: &Path) -> Result<()> {
    let test = actuator.record.test;
    let dt = actuator.params().control_period;
    let text = schedule_csv(&test, dt);
    std::fs::write(out, &text).with_context(|| format!("writing {}", out.display()))?;
    println!(
        "wrote {} ({} control periods of {} s, the {} test of {})",
        out.display(),
        test.samples(dt),
        dt,
        test.kind_name(),
        actuator.name
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_schedule_is_the_tests_drive_row_for_row() {
        let test = PreflightTest::INJECTION;
        let text = schedule_csv(&test, 1.0e-4);
        let rows: Vec<&str> = text.lines().filter(|l| !l.starts_with('#')).collect();
        assert_eq!(rows[0], SCHEDULE_HEADER);
        assert_eq!(rows.len(), 1 + 5460);
        // Settle, the first tone's first period, its off, the chirp.
        assert!(rows[1].starts_with("0,0,off,AB,"), "{}", rows[1]);
        let first = rows[101].split(',').collect::<Vec<_>>();
        assert_eq!(&first[..4], &["100", "0.01", "voltage", "AB"]);
        let v: f32 = first[4].parse().unwrap();
        assert_eq!(
            v.to_bits(),
            test.standstill
                .unwrap()
                .at(100)
                .unwrap()
                .voltage(1e-4)
                .to_bits()
        );
        assert!(rows[1 + 100 + 120].contains(",voltage,BC,"));
        assert!(rows[1 + 100 + 240].contains(",voltage,CA,"));
        assert!(rows[1 + 100 + 100].contains(",off,AB,"));
        let chirp = rows[1 + 460 + 1000].split(',').collect::<Vec<_>>();
        assert_eq!(chirp[2], "position");
        let x: f32 = chirp[4].parse().unwrap();
        assert_eq!(x.to_bits(), test.chirp.position(1000.0 * 1e-4).to_bits());
    }
}
