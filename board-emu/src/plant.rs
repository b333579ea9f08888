//! What the board's pins are connected to: the bridge's legs in, the converters' voltages
//! and the encoder's edges out, through the reference board's front end (`SensorScaling`).
//! [`OpenBridge`] is an actuator whose motor leads are open (no current flows, the shafts
//! stay still); [`MotorOnPins`] a plain brushless motor on a rigid gear
//! (`host_sim::plant::pair_motor`: no friction, no load, no dead time), on a bus of known
//! voltage at a known temperature; [`ReferenceOnPins`] the reference model, its own bridge
//! driven by TIM1's legs. O(1) per call but a period's physics (50 Euler steps for the
//! motor, the reference model's fine steps).

use std::collections::VecDeque;
use std::sync::mpsc::{sync_channel, Receiver, SyncSender};
use std::thread::JoinHandle;

use firmware::acquisition::SensorScaling;
use host_sim::plant::pair_motor::PairMotor;
use host_sim::plant::reference::{
    AnalogSensors, ExternalDrive, ReferenceModel, Scenario, Simulation,
};

/// The bridge as TIM1 drives it over the next control period.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BridgeState {
    /// Per leg: its high side's duty (0 … 1, the compare over the auto-reload), or `None`
    /// with both outputs off.
    pub legs: [Option<f32>; 3],
    /// Dead time [s].
    pub dead_time: f32,
    /// Whether the main output is enabled (MOE).
    pub main_output: bool,
}

pub trait Plant {
    /// An update of TIM1: the instant the converters sample (before [`drive`](Self::drive)).
    fn sample(&mut self) {}
    /// One control period begins with the bridge driven as `bridge`.
    fn drive(&mut self, bridge: &BridgeState);
    /// The voltage on ADC channel `channel` now [V] (0 … 3.3).
    fn volts(&self, channel: u8) -> f32;
    /// The encoder's quadrature edges counted since power-up.
    fn encoder_edges(&self) -> i64;
    /// For reading a plant back after a run ([`crate::Board::plant`]).
    fn as_any(&self) -> &dyn std::any::Any;
}

/// The motor's leads open: no current, no motion.
#[derive(Clone, Copy, Debug)]
pub struct OpenBridge {
    pub bus_volts: f32,
    pub celsius: f32,
    pub scaling: SensorScaling,
    /// Control periods driven.
    pub periods: u64,
}

impl OpenBridge {
    pub fn new(bus_volts: f32, celsius: f32) -> Self {
        Self {
            bus_volts,
            celsius,
            scaling: SensorScaling::REFERENCE_BOARD,
            periods: 0,
        }
    }
}

/// The voltage that converts to `count` on a 12-bit, 3.3 V converter (mid-step).
pub fn volts_of_count(count: f32) -> f32 {
    (count + 0.5) / 4096.0 * 3.3
}

impl Plant for OpenBridge {
    fn drive(&mut self, _bridge: &BridgeState) {
        self.periods += 1;
    }

    fn volts(&self, channel: u8) -> f32 {
        let s = &self.scaling;
        let count = match channel {
            0..=2 => s.current_zero,
            3 => s.transducer_zero,
            10 => self.bus_volts / s.bus_volts_per_count,
            11 => self.celsius / s.celsius_per_count + s.temperature_zero,
            // On the ground: no demand (the flight control computer's output off).
            _ => 0.0,
        };
        volts_of_count(count)
    }

    fn encoder_edges(&self) -> i64 {
        0
    }

    fn as_any(&self) -> &dyn std::any::Any {
        self
    }
}

/// A brushless motor on a rigid gear driven by TIM1's legs (both outputs of a leg on, with
/// the main output enabled: its duty; otherwise the leg floats).
#[derive(Clone, Debug)]
pub struct MotorOnPins {
    pub motor: PairMotor,
    pub celsius: f32,
    pub scaling: SensorScaling,
    /// The user shaft's angle at the end of each period driven [rad].
    pub user_angles: Vec<f32>,
}

impl MotorOnPins {
    pub fn new(motor: PairMotor, celsius: f32) -> Self {
        Self {
            motor,
            celsius,
            scaling: SensorScaling::REFERENCE_BOARD,
            user_angles: Vec::new(),
        }
    }
}

impl Plant for MotorOnPins {
    fn drive(&mut self, bridge: &BridgeState) {
        let duties = if bridge.main_output {
            bridge.legs
        } else {
            [None; 3]
        };
        self.motor.period(duties);
        self.user_angles.push(self.motor.feedback().user_angle);
    }

    fn volts(&self, channel: u8) -> f32 {
        let s = &self.scaling;
        let f = self.motor.feedback();
        let count = match channel {
            0..=2 => f.phase_currents[usize::from(channel)] / s.amps_per_count + s.current_zero,
            3 => f.user_angle / s.transducer_rad_per_count + s.transducer_zero,
            10 => f.bus_voltage / s.bus_volts_per_count,
            11 => self.celsius / s.celsius_per_count + s.temperature_zero,
            _ => 0.0,
        };
        volts_of_count(count)
    }

    fn encoder_edges(&self) -> i64 {
        (self.motor.motor_angle / self.scaling.motor_rad_per_count).round() as i64
    }

    fn as_any(&self) -> &dyn std::any::Any {
        self
    }
}

/// The reference model on the pins: its actuator, bridge and sensors in a thread of their
/// own (`ReferenceModel::simulate_driven`), one control period per update of TIM1 — at each
/// update the converters sample what its sensors see, then its bridge runs the period on
/// the legs TIM1 drives (the duties the image preloaded, the reference model's own dead time
/// and diodes). After the reference model's run ends (its pre-roll and test), its last
/// readings hold; with a next run queued ([`ReferenceOnPins::then`]: the board's re-run of
/// a spoiled test) the actuator is at rest again where that run starts, and waits there
/// until the board enables the bridge's outputs for its next test.
pub struct ReferenceOnPins {
    legs: Option<SyncSender<[Option<f64>; 3]>>,
    sensors: Receiver<AnalogSensors>,
    latest: AnalogSensors,
    awaiting_legs: bool,
    pub scaling: SensorScaling,
    /// Control periods the reference model ran.
    pub periods: u64,
    run: Option<JoinHandle<Simulation>>,
    /// The runs for the board's next tests (a re-run after a spoiled one): each begins when
    /// the last ends, its actuator at rest where its run starts, and waits there (`parked`)
    /// until the board enables the bridge's outputs again.
    next: VecDeque<(ReferenceModel, Scenario)>,
    parked: bool,
    main_output: bool,
    /// Runs begun so far, and those the board drove (the tests it played on them).
    runs: u32,
    pub driven: u32,
}

/// The thread's side: the sensors out, the legs in.
struct Channels {
    sensors: SyncSender<AnalogSensors>,
    legs: Receiver<[Option<f64>; 3]>,
}

impl ExternalDrive for Channels {
    fn period(&mut self, sensed: &AnalogSensors) -> Option<[Option<f64>; 3]> {
        self.sensors.send(*sensed).ok()?;
        self.legs.recv().ok()
    }
}

impl ReferenceOnPins {
    /// `model` playing `scenario` on the pins.
    pub fn new(model: ReferenceModel, scenario: Scenario) -> Self {
        let (_, sensors) = sync_channel(1);
        let mut pins = Self {
            legs: None,
            sensors,
            latest: AnalogSensors::default(),
            awaiting_legs: false,
            scaling: SensorScaling::REFERENCE_BOARD,
            periods: 0,
            run: None,
            next: VecDeque::new(),
            parked: false,
            main_output: false,
            runs: 0,
            driven: 0,
        };
        pins.begin(model, scenario);
        pins
    }

    /// Then, for the board's next test, `model` playing `scenario` (the same actuator on
    /// another day: a gust gone, a wind risen).
    pub fn then(mut self, model: ReferenceModel, scenario: Scenario) -> Self {
        self.next.push_back((model, scenario));
        self
    }

    fn begin(&mut self, model: ReferenceModel, scenario: Scenario) {
        if let Some(run) = self.run.take() {
            let _ = run.join();
        }
        let (sensors_out, sensors) = sync_channel(1);
        let (legs, legs_in) = sync_channel(1);
        self.run = Some(std::thread::spawn(move || {
            let mut channels = Channels {
                sensors: sensors_out,
                legs: legs_in,
            };
            model.simulate_driven(&scenario, &mut channels)
        }));
        self.legs = Some(legs);
        self.sensors = sensors;
        self.awaiting_legs = false;
        self.parked = self.runs > 0;
        self.runs += 1;
        self.driven += u32::from(!self.parked);
    }
}

impl Drop for ReferenceOnPins {
    fn drop(&mut self) {
        // Closing the legs' channel ends the reference model's run.
        self.legs = None;
        if let Some(run) = self.run.take() {
            let _ = run.join();
        }
    }
}

impl Plant for ReferenceOnPins {
    fn sample(&mut self) {
        if self.awaiting_legs || self.legs.is_none() {
            return;
        }
        match self.sensors.recv() {
            Ok(s) => {
                self.latest = s;
                self.awaiting_legs = true;
            }
            // The run is over: the last readings hold (the flight control computer's demand
            // gone with its flight), or the next run's first.
            Err(_) => {
                self.legs = None;
                self.latest.demand = None;
                if let Some((model, scenario)) = self.next.pop_front() {
                    self.begin(model, scenario);
                    self.sample();
                }
            }
        }
    }

    fn drive(&mut self, bridge: &BridgeState) {
        if bridge.main_output && !self.main_output && self.parked {
            self.parked = false;
            self.driven += 1;
        }
        self.main_output = bridge.main_output;
        if !self.awaiting_legs || self.parked {
            return;
        }
        let legs = if bridge.main_output {
            bridge.legs.map(|l| l.map(f64::from))
        } else {
            [None; 3]
        };
        if let Some(tx) = &self.legs {
            if tx.send(legs).is_err() {
                self.legs = None;
            }
        }
        self.awaiting_legs = false;
        self.periods += 1;
    }

    fn volts(&self, channel: u8) -> f32 {
        let s = &self.scaling;
        let r = &self.latest;
        let count = match channel {
            0..=2 => {
                r.phase_currents[usize::from(channel)] as f32 / s.amps_per_count + s.current_zero
            }
            3 => r.user_angle as f32 / s.transducer_rad_per_count + s.transducer_zero,
            10 => r.bus_voltage as f32 / s.bus_volts_per_count,
            11 => r.temperature as f32 / s.celsius_per_count + s.temperature_zero,
            // The flight control computer's demand; on the ground (or after the flight) its
            // output is off: the rail.
            12 => r
                .demand
                .map_or(0.0, |d| d as f32 / s.demand_rad_per_count + s.demand_zero),
            _ => 0.0,
        };
        volts_of_count(count)
    }

    fn encoder_edges(&self) -> i64 {
        (self.latest.motor_angle / f64::from(self.scaling.motor_rad_per_count)).round() as i64
    }

    fn as_any(&self) -> &dyn std::any::Any {
        self
    }
}
