//! What the board's pins are connected to: the bridge's legs in, the converters' voltages
//! and the encoder's edges out, through the reference board's front end (`SensorScaling`).
//! [`OpenBridge`] is an actuator whose motor leads are open (no current flows, the shafts
//! stay still); [`MotorOnPins`] a plain brushless motor on a rigid gear
//! (`host_sim::plant::pair_motor`: no friction, no load, no dead time), on a bus of known
//! voltage at a known temperature. O(1) per call; a motor's period is 50 Euler steps.

use firmware::acquisition::SensorScaling;
use host_sim::plant::pair_motor::PairMotor;

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
