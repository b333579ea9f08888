//! The board's drive in closed loop: the test sequencer plays the actuator's preflight test
//! through `BridgeDrive` (position loop, six-step commutation, pair voltages, duties) into a
//! plain brushless motor on a rigid gear written from the physics
//! (`host_sim::plant::pair_motor`, not the monitor model, not the reference model).
//!
//! What it checks is the wiring a board would get wrong: the duty's sign and scale, the
//! conducting legs and their signs per sector, the floating leg off, the pair segment's legs.
//! A sign error anywhere makes the loop run away or the pair's current flow backwards.

use firmware::bridge::{BridgeDrive, BridgeTiming, LatchedLegs};
use firmware::position_loop::Sensing;
use firmware::sequencer::{Sequenced, TestSequencer};
use host_sim::plant::pair_motor::PairMotor;
use host_sim::plant::reference::{ReferenceModel, ReferenceSettings, Scenario};
use shared::drive::DriveSettings;
use shared::params::ActuatorParams;
use shared::test_design::{Drive as Command, PreflightTest, PAIR_SIGNS};
use shared::FaultVector;

/// The reference actuator's drive on a 168 MHz timer, without dead-time compensation (the
/// motor here has no dead time).
fn reference_drive() -> (ActuatorParams, DriveSettings, BridgeTiming) {
    let p = ActuatorParams::REFERENCE;
    let drive = DriveSettings {
        compensation: false,
        ..DriveSettings::TYPICAL
    };
    let timing = BridgeTiming::new(&drive, 168_000_000, p.control_period).unwrap();
    (p, drive, timing)
}

#[test]
fn the_board_drive_plays_the_test_in_closed_loop() {
    let (p, drive, timing) = reference_drive();
    let test = PreflightTest::INJECTION;
    let mut latched = LatchedLegs::default();
    let mut board = BridgeDrive::new(&mut latched, timing, drive, &p, Sensing::DIRECT);
    let mut plant = PairMotor::new(p, p.dc_bus_voltage);
    let counts = f32::from(timing.counts);
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
        plant.period(legs.map(|l| l.map(|d| f32::from(d) / counts)));
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

/// What the board's drive did over the chirp on a motor: the user shaft's tracking RMS [rad]
/// and the pair current's RMS [A].
#[derive(Debug)]
struct Chirp {
    tracking: f32,
    current: f32,
}

/// The test's chirp through `BridgeDrive` with `sensing` on the motor. `board_like`: the
/// board's timer and sensors — each period's legs act from the next update on (TIM1's
/// preload), the encoder counts 8 192 per revolution and the surface transducer reads through
/// a 12-bit converter over ±0.5 rad (`SensorScaling::REFERENCE_BOARD`); otherwise the legs act
/// at once and the sensors are exact.
fn chirp_on_motor(sensing: Sensing, board_like: bool) -> Chirp {
    let (p, drive, timing) = reference_drive();
    let test = PreflightTest::INJECTION;
    let mut latched = LatchedLegs::default();
    let mut board = BridgeDrive::new(&mut latched, timing, drive, &p, sensing);
    let mut plant = PairMotor::new(p, p.dc_bus_voltage);
    let counts = f32::from(timing.counts);
    let scaling = firmware::acquisition::SensorScaling::REFERENCE_BOARD;
    let quantise = |x: f32, lsb: f32| (x / lsb).round() * lsb;
    let mut sequencer = TestSequencer::new(test, p.control_period);
    let mut acting = [None; 3];
    let (mut errors, mut currents) = (Vec::new(), Vec::new());
    for index in 0.. {
        let mut f = plant.feedback();
        if board_like {
            f.motor_angle = quantise(f.motor_angle, scaling.motor_rad_per_count);
            f.user_angle = quantise(f.user_angle, scaling.transducer_rad_per_count);
        }
        board.measured(f);
        if sequencer.tick(&mut board) == Sequenced::Done {
            break;
        }
        let set = board.legs_mut().0.map(|l| l.map(|d| f32::from(d) / counts));
        let legs = if board_like { acting } else { set };
        acting = set;
        plant.period(legs);
        if let Command::Position(command) = test.drive(index, p.control_period) {
            errors.push(command - plant.motor_angle / p.gear_ratio);
            currents.push(plant.current);
        }
    }
    let rms = |v: &[f32]| (v.iter().map(|x| x * x).sum::<f32>() / v.len() as f32).sqrt();
    Chirp {
        tracking: rms(&errors),
        current: rms(&currents),
    }
}

#[test]
fn the_board_drive_allows_for_its_late_duties_and_coarse_sensors() {
    // The loop as the monitor model describes it, on a drive that acts at once with exact
    // sensors: what the board's drive must reproduce.
    let ideal = chirp_on_motor(Sensing::DIRECT, false);
    // The board's drive on the board's timing and sensors.
    let board = chirp_on_motor(Sensing::BOARD, true);
    // The same loop without allowing for them.
    let naive = chirp_on_motor(Sensing::DIRECT, true);
    println!("ideal {ideal:?}\nboard {board:?}\nnaive {naive:?}");
    assert!(
        board.current < 1.1 * ideal.current,
        "{board:?} against {ideal:?}"
    );
    assert!(
        board.tracking < 1.25 * ideal.tracking,
        "{board:?} against {ideal:?}"
    );
    // What the allowance is for: without it the current is far from the ideal's.
    assert!(naive.current > 1.5 * ideal.current, "{naive:?}");
}

/// The board's flight on the reference model in cruise: `FlightCommand` follows the flight
/// control computer's demand (as the board's converter reads it) through `BridgeDrive` on
/// the reference model's own bridge, legs acting from the next update, sensors through the
/// board's converters; after half a second a window's chirp is superimposed. The surface
/// must follow the command the window records as the actuator's own controller follows its
/// own.
#[test]
fn the_board_flies_the_demand_with_a_windows_chirp_superimposed() {
    use firmware::acquisition::SensorScaling;
    use firmware::flight::FlightCommand;
    use host_sim::plant::aero::{FlightPhase, FlightWindow, Turbulence};
    use host_sim::plant::reference::{AnalogSensors, ExternalDrive};

    struct Flight {
        board: BridgeDrive<&'static mut LatchedLegs>,
        command: FlightCommand,
        counts: f32,
        scaling: SensorScaling,
        motor_zero: Option<f64>,
        frames: usize,
        window_from: usize,
        window: Vec<(f32, f32)>,
    }
    impl ExternalDrive for Flight {
        fn period(&mut self, s: &AnalogSensors) -> Option<[Option<f64>; 3]> {
            let q = |x: f64, lsb: f32| ((x as f32) / lsb).round() * lsb;
            let zero = *self.motor_zero.get_or_insert(s.motor_angle);
            let sc = &self.scaling;
            let user = q(s.user_angle, sc.transducer_rad_per_count);
            self.board.measured(firmware::position_loop::Feedback {
                phase_currents: s.phase_currents.map(|i| q(i, sc.amps_per_count)),
                motor_angle: q(s.motor_angle - zero, sc.motor_rad_per_count),
                user_angle: user,
                bus_voltage: s.bus_voltage as f32,
            });
            let demand = q(s.demand?, sc.demand_rad_per_count);
            if self.frames == self.window_from {
                let p = ActuatorParams::REFERENCE;
                self.command
                    .begin_window(PreflightTest::INJECTION, p.control_period);
            }
            let acting = self.command.tick(demand, &mut self.board);
            if self.frames > self.window_from && self.command.in_window() {
                self.window.push((acting, user));
            }
            self.frames += 1;
            let legs = self.board.legs_mut().0;
            Some(legs.map(|l| l.map(|d| f64::from(d) / f64::from(self.counts))))
        }
    }

    let p = ActuatorParams::REFERENCE;
    let drive = shared::drive::DriveSettings::TYPICAL;
    let timing = BridgeTiming::new(&drive, 168_000_000, p.control_period).unwrap();
    let cruise = FlightWindow {
        phase: FlightPhase::Cruise,
        turbulence: Turbulence::Light,
    };
    let model = ReferenceModel::new(ReferenceSettings::REFERENCE)
        .with_test(PreflightTest::INJECTION.chirp_only())
        .with_flight(Some(cruise))
        .with_flight_periods(Some(12_000));
    let mut flight = Flight {
        board: BridgeDrive::new(Box::leak(Box::default()), timing, drive, &p, Sensing::BOARD),
        command: FlightCommand::follow(ActuatorParams::REFERENCE.control_period),
        counts: f32::from(timing.counts),
        scaling: SensorScaling::REFERENCE_BOARD,
        motor_zero: None,
        frames: 0,
        window_from: 6_000,
        window: Vec::new(),
    };
    model.simulate_driven(&Scenario::new(FaultVector::NOMINAL), &mut flight);
    let n = flight.window.len();
    assert!(n > 4_000, "{n} window frames");
    let rms = (flight
        .window
        .iter()
        .map(|(c, y)| (c - y).powi(2))
        .sum::<f32>()
        / n as f32)
        .sqrt();
    let swing = flight
        .window
        .iter()
        .map(|(c, _)| c.abs())
        .fold(0.0, f32::max);
    println!("window: {n} frames, tracking RMS {rms:.3e} rad, command up to {swing:.3e} rad");
    assert!(rms < 1.0e-3, "{rms}");
}
