//! The board's drive in closed loop: the test sequencer plays the actuator's preflight test
//! through `BridgeDrive` (position loop, six-step commutation, pair voltages, duties) into a
//! plain brushless motor on a rigid gear, written here from the physics (not the monitor
//! model, not the reference model): the pair circuit `V = 2R·i + 2L·di/dt + k_t·ω` fed by the
//! legs' duties on the measured bus, torque `k_t·i`, the inertias through the gear.
//!
//! What it checks is the wiring a board would get wrong: the duty's sign and scale, the
//! conducting legs and their signs per sector, the floating leg off, the pair segment's legs.
//! A sign error anywhere makes the loop run away or the pair's current flow backwards.

use firmware::bridge::{BridgeDrive, BridgeTiming, Leg, Legs};
use firmware::position_loop::Feedback;
use firmware::sequencer::{Sequenced, TestSequencer};
use host_sim::plant::reference::{ReferenceModel, ReferenceSettings, Scenario};
use shared::drive::DriveSettings;
use shared::params::ActuatorParams;
use shared::test_design::{Drive as Command, PreflightTest, PAIR_SIGNS};
use shared::FaultVector;

#[derive(Default)]
struct Latched([Option<u16>; 3]);

impl Legs for &mut Latched {
    fn set(&mut self, legs: [Leg; 3]) {
        self.0 = legs.map(|l| match l {
            Leg::Off => None,
            Leg::Duty(d) => Some(d),
        });
    }
}

/// The motor and load, integrated in fine steps over one control period.
struct Plant {
    p: ActuatorParams,
    counts: f32,
    bus: f32,
    /// The pair current along the conducting legs' signs [A], and those signs.
    current: f32,
    signs: [i8; 3],
    motor_angle: f32,
    motor_speed: f32,
}

impl Plant {
    fn feedback(&self) -> Feedback {
        Feedback {
            phase_currents: self.signs.map(|s| f32::from(s) * self.current),
            motor_angle: self.motor_angle,
            user_angle: self.motor_angle / self.p.gear_ratio,
            bus_voltage: self.bus,
        }
    }

    fn period(&mut self, legs: [Option<u16>; 3]) {
        // The driven legs' voltages from the bus midpoint; a floating leg carries nothing.
        let volts = legs.map(|l| l.map(|d| (f32::from(d) / self.counts - 0.5) * self.bus));
        let driven: Vec<usize> = (0..3).filter(|&x| volts[x].is_some()).collect();
        if driven.len() != 2 {
            self.current = 0.0;
            self.signs = [0; 3];
        } else {
            // The pair: the higher-index-independent orientation is (first, second).
            let (a, b) = (driven[0], driven[1]);
            let mut signs = [0i8; 3];
            signs[a] = 1;
            signs[b] = -1;
            if signs != self.signs {
                // The current keeps its phase a's direction where the new pair shares it.
                let carried: f32 = (0..3)
                    .map(|x| f32::from(self.signs[x]) * f32::from(signs[x]))
                    .sum::<f32>()
                    * 0.5;
                self.current *= carried;
                self.signs = signs;
            }
            let pair_volts = volts[a].unwrap() - volts[b].unwrap();
            let p = &self.p;
            let kt = p.torque_constant();
            let j = p.motor_inertia + p.user_inertia / (p.gear_ratio * p.gear_ratio);
            let steps = 50;
            let h = p.control_period / steps as f32;
            for _ in 0..steps {
                // The EMF and torque along this pair: the sector's signs decide their sign
                // through the drive's choice, so the pair current is the equivalent current
                // when the drive commutates as the rotor does.
                let theta_e = p.pole_pairs * self.motor_angle;
                let along = equivalent_sign(signs, theta_e);
                let emf = along * kt * self.motor_speed;
                let di = (pair_volts - 2.0 * p.phase_resistance * self.current - emf)
                    / (2.0 * p.phase_inductance);
                self.current += h * di;
                let torque = along * kt * self.current;
                self.motor_speed += h * torque / j;
                self.motor_angle += h * self.motor_speed;
            }
        }
    }
}

/// +1 when the pair `signs` is the sector's pair for `theta_e` with its signs, −1 reversed,
/// 0 for another pair (a mis-commutated drive gets no torque from it).
fn equivalent_sign(signs: [i8; 3], theta_e: f32) -> f32 {
    let sector = shared::conditioning::commutation_signs(theta_e);
    let dot: i32 = (0..3)
        .map(|x| i32::from(signs[x]) * i32::from(sector[x]))
        .sum();
    match dot {
        2 => 1.0,
        -2 => -1.0,
        _ => 0.0,
    }
}

#[test]
fn the_board_drive_plays_the_test_in_closed_loop() {
    let p = ActuatorParams::REFERENCE;
    let drive = DriveSettings {
        compensation: false, // the plant here has no dead time
        ..DriveSettings::TYPICAL
    };
    let timing = BridgeTiming::new(&drive, 168_000_000, p.control_period).unwrap();
    let test = PreflightTest::INJECTION;
    let mut latched = Latched::default();
    let mut board = BridgeDrive::new(&mut latched, timing, drive, &p);
    let mut plant = Plant {
        p,
        counts: f32::from(timing.counts),
        bus: p.dc_bus_voltage,
        current: 0.0,
        signs: [0; 3],
        motor_angle: 0.0,
        motor_speed: 0.0,
    };
    let mut sequencer = TestSequencer::new(test, p.control_period);
    let mut tracking = Vec::new();
    let mut pair_currents = Vec::new();
    let mut index = 0;
    loop {
        board.measured(plant.feedback());
        if sequencer.tick(&mut board) == Sequenced::Done {
            break;
        }
        let legs = board.legs_mut().0;
        plant.period(legs);
        match test.drive(index, p.control_period) {
            Command::Position(command) => {
                tracking.push((command, plant.motor_angle / p.gear_ratio));
            }
            Command::Pair(d) if d.volts != 0.0 => {
                // The pair commanded drives its legs with its signs, the third floats.
                let signs = PAIR_SIGNS[usize::from(d.pair as u8)];
                for x in 0..3 {
                    assert_eq!(legs[x].is_some(), signs[x] != 0, "period {index}: {legs:?}");
                }
                // Its current, along the pair's own signs.
                let i = plant.feedback().phase_currents;
                let along: f32 = (0..3).map(|x| f32::from(signs[x]) * i[x]).sum::<f32>() * 0.5;
                pair_currents.push((d.voltage(p.control_period), along));
            }
            Command::Pair(_) => assert_eq!(legs, [None; 3], "period {index}"),
        }
        index += 1;
    }
    assert_eq!(index, sequencer.samples());
    // The pair segment: the tone's current flows the way its voltage pushes (the pair takes
    // power), at the amplitude the pair's impedance gives it, V / |2R + j·ω·2L|.
    assert!(!pair_currents.is_empty());
    let power: f32 = pair_currents.iter().map(|(v, i)| v * i).sum();
    let tone = test.standstill.unwrap();
    let omega = 2.0 * std::f32::consts::PI * tone.frequency;
    let impedance = (2.0 * p.phase_resistance).hypot(omega * 2.0 * p.phase_inductance);
    let peak = pair_currents
        .iter()
        .map(|(_, i)| i.abs())
        .fold(0.0, f32::max);
    println!(
        "pair segment: {} periods, power sum {power:.3}, peak {peak:.3} A against {:.3} A",
        pair_currents.len(),
        tone.volts / impedance
    );
    assert!(power > 0.0, "{power}");
    let ratio = peak / (tone.volts / impedance);
    assert!((0.8..1.25).contains(&ratio), "{ratio}");
    // The chirp: the user shaft follows the command (rigid gear, no friction here).
    let amplitude = test.chirp.amplitude;
    let rms =
        (tracking.iter().map(|(c, y)| (c - y).powi(2)).sum::<f32>() / tracking.len() as f32).sqrt();
    let largest = tracking.iter().map(|(_, y)| y.abs()).fold(0.0, f32::max);
    println!(
        "{} position periods: tracking error RMS {:.3e} rad of a {amplitude} rad chirp, largest angle {largest:.3e} rad",
        tracking.len(),
        rms
    );
    // The actuator's own controller on the reference model (the nominal actuator, the
    // same test): its user shaft's tracking of the same commands.
    let rm = ReferenceModel::new(ReferenceSettings::REFERENCE)
        .with_test(test)
        .simulate(&Scenario::new(FaultVector::NOMINAL));
    let rm_tracking: Vec<(f32, f32)> = rm
        .trace
        .samples()
        .iter()
        .zip(&rm.truth)
        .enumerate()
        .filter(|(k, _)| matches!(test.drive(*k, p.control_period), Command::Position(_)))
        .map(|(_, (s, t))| (s.command as f32, t.user_angle as f32))
        .collect();
    assert_eq!(rm_tracking.len(), tracking.len());
    let rm_rms = (rm_tracking
        .iter()
        .map(|(c, y)| (c - y).powi(2))
        .sum::<f32>()
        / rm_tracking.len() as f32)
        .sqrt();
    println!("reference model's controller: tracking error RMS {rm_rms:.3e} rad");
    assert!(
        rms < 2.0 * rm_rms,
        "board {rms} against the reference model's {rm_rms}"
    );
    assert!(largest < 2.0 * amplitude, "{largest}");
}
