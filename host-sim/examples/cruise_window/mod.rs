//! What the window studies share (`window_moment`, `window_pinned`; issue 36,
//! docs/in-flight.md): the built-in reference actuator, the two cases, a cruise window of
//! one simulated by the reference model, and the window model on it (the day estimated from
//! the window, the load at the actuator's spring). One reference-model run per window.

use host_sim::fdi::window::recorded_command;
use host_sim::plant::aero::{FlightPhase, FlightWindow, Turbulence};
use host_sim::plant::reference::{ReferenceModel, ReferenceSettings, Scenario, Simulation};
use shared::actuator::ActuatorRecord;
use shared::conditions::TestConditions;
use shared::fdi::{OnboardMeasured, TEST_SAMPLES};
use shared::window::{RecordedCommand, WindowLoad, WindowProblem, COMMAND_STRIDE};
use shared::{FaultVector, MonitorModel};

/// The healthy actuator and Table II medium.
pub const CASES: [(&str, [f32; 9]); 2] = [
    ("healthy", [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0]),
    (
        "Table II medium",
        [0.4, 0.4, 0.2, 0.1, 0.05, 0.2, 0.75, 0.6, 0.0],
    ),
];

pub const SETTINGS: ReferenceSettings = ReferenceSettings::REFERENCE;
/// The actuator as the flight's windows carry it: the built-in record with its chirp-only
/// test and the calibration on it (`host_sim::studies::flight::flight_record`, what the
/// flight campaign plays and identifies with), not the preflight's record, whose test is not
/// what a window carries.
pub fn record() -> ActuatorRecord {
    host_sim::studies::flight::flight_record(&ActuatorRecord::REFERENCE)
}

/// A cruise window of `faults` in `turbulence`, seed `seed`, as the controller recorded it.
pub struct CruiseWindow {
    pub window: FlightWindow,
    pub sim: Simulation,
    pub measured: Box<OnboardMeasured>,
    pub command: Vec<f32>,
    pub model: MonitorModel,
}

impl CruiseWindow {
    pub fn simulate(faults: &FaultVector, turbulence: Turbulence, seed: u64) -> Self {
        let window = FlightWindow {
            phase: FlightPhase::Cruise,
            turbulence,
        };
        let record = record();
        let rm = ReferenceModel::new(SETTINGS)
            .with_test(record.test)
            .with_flight(Some(window));
        let sim = rm.simulate(&Scenario {
            seed,
            ..Scenario::new(*faults)
        });
        let measured = sim.trace.measured(&record.params).expect("a sound trace");
        let command = recorded_command(&sim.trace);
        let conditions = TestConditions::estimate(&measured, &record.params, &record.calibration);
        let model = MonitorModel::new(record.params, &record.calibration)
            .with_test(measured.test())
            .with_conditions(&conditions);
        Self {
            window,
            sim,
            measured,
            command,
            model,
        }
    }

    /// The surface as its sensor read it: the angle [rad] and its central difference over
    /// four samples [rad/s] per sample (what the pinned model is pinned to).
    pub fn sensed_surface(&self) -> (Vec<f32>, Vec<f32>) {
        const HALF_SPAN: usize = 2;
        let period = f64::from(record().params.control_period);
        let angles: Vec<f64> = self
            .sim
            .trace
            .samples()
            .iter()
            .map(|s| s.user_angle)
            .collect();
        let n = angles.len();
        let speeds = (0..n)
            .map(|i| {
                let (a, b) = (i.saturating_sub(HALF_SPAN), (i + HALF_SPAN).min(n - 1));
                ((angles[b] - angles[a]) / ((b - a) as f64 * period)) as f32
            })
            .collect();
        (angles.iter().map(|&a| a as f32).collect(), speeds)
    }

    /// The window problem on it, the load at the actuator's spring.
    pub fn problem(&self) -> WindowProblem<'_, TEST_SAMPLES> {
        let record = record();
        WindowProblem::new(
            &self.measured,
            RecordedCommand::kept_every(COMMAND_STRIDE, &self.command),
            self.model,
            WindowLoad::spring(record.params.aero_stiffness, 0.0),
        )
        .expect("a window")
    }
}
