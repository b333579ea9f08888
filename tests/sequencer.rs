//! The firmware's test sequencer against the ground's schedule and the emulation's trace: a
//! recording `Drive` receives, period by period, exactly the rows `host-sim test-schedule`
//! writes (the same f32 bits), for both actuators' tests, and its position commands are the
//! command column of a reference-model trace of the same test.

use firmware::sequencer::{Drive, Sequenced, TestSequencer};
use host_sim::files::schedule::{schedule_csv, SCHEDULE_HEADER};
use host_sim::plant::reference::{ReferenceModel, ReferenceSettings, Scenario};
use shared::test_design::{PreflightTest, PAIR_SIGNS};
use shared::{ActuatorParams, FaultVector};

/// What the drive was told, one entry per control period.
#[derive(Debug, PartialEq)]
enum Told {
    Position(f32),
    Voltage(u8, f32),
    Off(u8),
}

#[derive(Default)]
struct Recorder(Vec<Told>, usize);

impl Drive for Recorder {
    fn lead(&self) -> usize {
        self.1
    }
    fn position(&mut self, rad: f32) {
        self.0.push(Told::Position(rad));
    }
    fn pair_voltage(&mut self, pair: u8, volts: f32) {
        self.0.push(Told::Voltage(pair, volts));
    }
    fn off(&mut self, pair: u8) {
        self.0.push(Told::Off(pair));
    }
}

fn play(test: PreflightTest, dt: f32) -> Vec<Told> {
    let mut sequencer = TestSequencer::new(test, dt);
    let mut drive = Recorder::default();
    let mut expected = 0;
    while let Sequenced::Commanded { index } = sequencer.tick(&mut drive) {
        assert_eq!(index, expected);
        expected += 1;
    }
    // Done stays done, and commands nothing.
    assert_eq!(sequencer.tick(&mut drive), Sequenced::Done);
    assert_eq!(drive.0.len(), sequencer.samples());
    drive.0
}

fn pair_name(pair: u8) -> String {
    let signs = PAIR_SIGNS[usize::from(pair)];
    let phase = |s: i8| ['A', 'B', 'C'][signs.iter().position(|&x| x == s).unwrap()];
    format!("{}{}", phase(1), phase(-1))
}

#[test]
fn the_sequencer_plays_the_schedule_bit_for_bit() {
    for (test, dt) in [
        (PreflightTest::INJECTION, 1.0e-4),
        (PreflightTest::STANDSTILL, 1.0e-4),
        (PreflightTest::PAPER, 1.0e-4),
        (PreflightTest::INJECTION, 2.0e-4),
    ] {
        let told = play(test, dt);
        let text = schedule_csv(&test, dt);
        let rows: Vec<&str> = text.lines().filter(|l| !l.starts_with('#')).collect();
        assert_eq!(rows[0], SCHEDULE_HEADER);
        assert_eq!(rows.len() - 1, told.len(), "{test:?}");
        let (mut positions, mut volts, mut offs) = (0, 0, 0);
        for (k, (row, t)) in rows[1..].iter().zip(&told).enumerate() {
            let f: Vec<&str> = row.split(',').collect();
            assert_eq!(f[0], k.to_string());
            let value: f32 = f[4].parse().unwrap();
            match t {
                Told::Position(x) => {
                    assert_eq!((f[2], f[3]), ("position", "-"), "row {k}");
                    assert_eq!(value.to_bits(), x.to_bits(), "row {k}");
                    positions += 1;
                }
                Told::Voltage(p, v) => {
                    assert_eq!((f[2], f[3]), ("voltage", pair_name(*p).as_str()), "row {k}");
                    assert_eq!(value.to_bits(), v.to_bits(), "row {k}");
                    volts += 1;
                }
                Told::Off(p) => {
                    assert_eq!((f[2], f[3]), ("off", pair_name(*p).as_str()), "row {k}");
                    offs += 1;
                }
            }
        }
        assert_eq!(positions, test.chirp_samples(dt), "{test:?}");
        if test.standstill.is_some() {
            assert!(volts >= 200 && offs >= 100, "{test:?}: {volts} {offs}");
        }
    }
}

#[test]
fn the_sequencers_positions_are_the_traces_commands() {
    let test = PreflightTest::INJECTION;
    let p = ActuatorParams::REFERENCE;
    let told = play(test, p.control_period);
    let trace = ReferenceModel::new(ReferenceSettings::REFERENCE)
        .with_test(test)
        .simulate(&Scenario::new(FaultVector::NOMINAL))
        .trace;
    assert_eq!(trace.samples().len(), told.len());
    for (k, (s, t)) in trace.samples().iter().zip(&told).enumerate() {
        let commanded = match t {
            Told::Position(x) => f64::from(*x),
            Told::Voltage(..) | Told::Off(_) => 0.0,
        };
        assert_eq!(s.command.to_bits(), commanded.to_bits(), "row {k}");
    }
}

#[test]
fn a_drive_whose_commands_act_a_period_late_is_told_each_a_period_early() {
    let (test, dt) = (PreflightTest::INJECTION, 1.0e-4);
    let on_time = play(test, dt);
    let mut sequencer = TestSequencer::new(test, dt);
    let mut late = Recorder(Vec::new(), 1);
    while let Sequenced::Commanded { .. } = sequencer.tick(&mut late) {}
    // Frame k is told period k + 1's command; the last frame holds the last command.
    assert_eq!(late.0.len(), on_time.len());
    assert_eq!(late.0[..on_time.len() - 1], on_time[1..]);
    assert_eq!(late.0.last(), on_time.last());
}
