//! What the board's pins are connected to: the bridge's legs in, the converters' voltages
//! and the encoder's edges out. [`OpenBridge`] is an actuator whose motor leads are open
//! (no current flows, the shafts stay still) on a bus of known voltage at a known
//! temperature, seen through the reference board's front end (`SensorScaling`).

use firmware::acquisition::SensorScaling;

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
}
