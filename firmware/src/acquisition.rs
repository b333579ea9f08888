//! What the board's converters latched at one ADC trigger, in SI units: the counts of the
//! phase-current, transducer, bus and temperature channels and the encoder's 16-bit count,
//! converted by the board's analogue front end ([`SensorScaling`]) into the frame the FDI
//! takes and the feedback the position loop takes; and the pacing of the frames against the
//! hardware's trigger count ([`pace`]).
//!
//! Units: A, rad, V, °C. O(1) per frame, no allocation. The board (`board.rs`, feature
//! `hardware`) reads the registers; everything here is host-tested.

use shared::conditioning::ConditionReading;
use shared::AdcFrame;

use crate::position_loop::Feedback;

/// The counts latched at one trigger.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counts {
    /// ADC1 injected ranks: phase currents a, b, c, then the surface transducer.
    pub currents_and_transducer: [u16; 4],
    /// ADC2 injected ranks: the bus divider, then the winding thermistor's amplifier.
    pub bus_and_temperature: [u16; 2],
    /// ADC2's third injected rank: the flight control computer's analogue position demand.
    pub demand: u16,
    /// The encoder timer's count, captured by the same trigger.
    pub encoder: u16,
}

/// The board's analogue front end and encoder: a straight line per channel,
/// `value = (count − zero) · gain`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorScaling {
    /// [A per count] and the count at 0 A of each phase's current amplifier.
    pub amps_per_count: f32,
    pub current_zero: f32,
    /// [rad per count] of the surface transducer and its count at 0 rad.
    pub transducer_rad_per_count: f32,
    pub transducer_zero: f32,
    /// [V per count] of the bus divider.
    pub bus_volts_per_count: f32,
    /// [°C per count] and the count at 0 °C of the thermistor's linearised amplifier.
    pub celsius_per_count: f32,
    pub temperature_zero: f32,
    /// [rad per encoder count] of the motor shaft (2π over four times the lines).
    pub motor_rad_per_count: f32,
    /// [rad per count] of the flight control computer's position demand and its count at
    /// 0 rad; a count outside `demand_valid` (a rail: the computer's output off, on the
    /// ground) is no demand.
    pub demand_rad_per_count: f32,
    pub demand_zero: f32,
    pub demand_valid: (u16, u16),
}

impl SensorScaling {
    /// The reference board: 12-bit converters on 3.3 V; ±20 A full scale around mid-rail
    /// (9.8 mA per count); the transducer ±0.5 rad over the range; the bus through a
    /// 1:110 divider (0.0886 V per count, 363 V full scale); the thermistor amplifier
    /// −50…+200 °C over the range; a 2 048-line encoder (8 192 counts per turn).
    pub const REFERENCE_BOARD: Self = Self {
        amps_per_count: 40.0 / 4096.0,
        current_zero: 2048.0,
        transducer_rad_per_count: 1.0 / 4096.0,
        transducer_zero: 2048.0,
        bus_volts_per_count: 3.3 * 110.0 / 4096.0,
        celsius_per_count: 250.0 / 4096.0,
        temperature_zero: 819.2,
        motor_rad_per_count: core::f32::consts::TAU / 8192.0,
        // The demand as the transducer (±0.5 rad over the range), within 2 % of each rail.
        demand_rad_per_count: 1.0 / 4096.0,
        demand_zero: 2048.0,
        demand_valid: (82, 4013),
    };

    /// The position demand of `count` [rad], or `None` when the count sits on a rail (no
    /// demand: the flight control computer's output is off). O(1).
    pub fn demand(&self, count: u16) -> Option<f32> {
        let (low, high) = self.demand_valid;
        (low..=high)
            .contains(&count)
            .then(|| (f32::from(count) - self.demand_zero) * self.demand_rad_per_count)
    }
}

/// The encoder's 16-bit count continued across its wraps: the motor turns far less than
/// half the counter between two triggers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EncoderUnwrap {
    last: Option<u16>,
    total: i32,
}

impl EncoderUnwrap {
    /// The count since the first one, continued across wraps.
    pub fn update(&mut self, count: u16) -> i32 {
        let step = match self.last {
            Some(last) => count.wrapping_sub(last) as i16,
            None => 0,
        };
        self.last = Some(count);
        self.total = self.total.wrapping_add(i32::from(step));
        self.total
    }
}

/// The board's frames in SI units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Converter {
    scaling: SensorScaling,
    encoder: EncoderUnwrap,
}

impl Converter {
    pub fn new(scaling: SensorScaling) -> Self {
        Self {
            scaling,
            encoder: EncoderUnwrap::default(),
        }
    }

    /// The frame for the FDI and the feedback for the position loop. The motor angle starts
    /// at 0 with the first frame (the encoder has no absolute zero; the FDI starts its model
    /// from the first frame's angles).
    pub fn convert(&mut self, c: &Counts) -> (AdcFrame, Feedback) {
        let s = &self.scaling;
        let [ia, ib, ic, transducer] = c.currents_and_transducer;
        let amps = |count: u16| (f32::from(count) - s.current_zero) * s.amps_per_count;
        let phase_currents = [amps(ia), amps(ib), amps(ic)];
        let user_angle = (f32::from(transducer) - s.transducer_zero) * s.transducer_rad_per_count;
        let motor_angle = self.encoder.update(c.encoder) as f32 * s.motor_rad_per_count;
        let [bus, temperature] = c.bus_and_temperature;
        let bus_voltage = f32::from(bus) * s.bus_volts_per_count;
        let temperature = (f32::from(temperature) - s.temperature_zero) * s.celsius_per_count;
        let mut frame = AdcFrame::from_f32(phase_currents, motor_angle, user_angle);
        frame.conditions = Some(ConditionReading::from_f64(
            f64::from(bus_voltage),
            f64::from(temperature),
        ));
        let feedback = Feedback {
            phase_currents,
            motor_angle,
            user_angle,
            bus_voltage,
        };
        (frame, feedback)
    }
}

/// Where the frames stand against the triggers the hardware counted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(any(feature = "defmt", target_os = "none"), derive(defmt::Format))]
pub enum Pace {
    /// No trigger since the last frame was taken.
    Wait,
    /// The next frame's trigger came; its conversions may still be running.
    Due,
    /// Triggers came that no frame was taken for: the poll fell behind the control rate.
    Overrun { missed: u32 },
}

/// `triggers` counted by the hardware (since it started) against `frames` taken.
pub fn pace(triggers: u32, frames: u32) -> Pace {
    match triggers.wrapping_sub(frames) {
        0 => Pace::Wait,
        1 => Pace::Due,
        // Also a trigger count behind the frames (wrapped): the counter was disturbed.
        n => Pace::Overrun {
            missed: n.wrapping_sub(1),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_encoder_continues_across_its_wrap() {
        let mut e = EncoderUnwrap::default();
        assert_eq!(e.update(65_530), 0);
        assert_eq!(e.update(4), 10);
        assert_eq!(e.update(65_534), 4);
        assert_eq!(e.update(65_534), 4);
    }

    #[test]
    fn mid_rail_reads_zero_and_the_conditions_ride_with_the_frame() {
        let mut c = Converter::new(SensorScaling::REFERENCE_BOARD);
        let counts = Counts {
            currents_and_transducer: [2048, 2048 + 512, 2048 - 512, 2048],
            bus_and_temperature: [3_047, 819 + 410],
            demand: 0,
            encoder: 100,
        };
        let (frame, feedback) = c.convert(&counts);
        assert_eq!(feedback.phase_currents, [0.0, 5.0, -5.0]);
        assert_eq!(feedback.motor_angle, 0.0);
        assert!((feedback.bus_voltage - 270.0).abs() < 0.1, "{feedback:?}");
        let day = frame.conditions.expect("the board measures the day");
        assert!((day.temperature.to_num::<f32>() - 25.0).abs() < 0.1);
        // The next frame, two counts on: the angle moves by two counts.
        let (_, next) = c.convert(&Counts {
            encoder: 102,
            ..counts
        });
        assert!((next.motor_angle - 2.0 * core::f32::consts::TAU / 8192.0).abs() < 1.0e-7);
    }

    #[test]
    fn frames_are_paced_by_the_trigger_count() {
        assert_eq!(pace(0, 0), Pace::Wait);
        assert_eq!(pace(1, 0), Pace::Due);
        assert_eq!(pace(7, 4), Pace::Overrun { missed: 2 });
        assert_eq!(pace(0, u32::MAX), Pace::Due);
        assert_eq!(
            pace(3, 4),
            Pace::Overrun {
                missed: u32::MAX - 1
            }
        );
    }

    #[test]
    fn a_demand_on_a_rail_is_no_demand() {
        let s = SensorScaling::REFERENCE_BOARD;
        assert_eq!(s.demand(2048), Some(0.0));
        assert_eq!(s.demand(2048 + 41), Some(41.0 / 4096.0));
        assert_eq!(s.demand(0), None);
        assert_eq!(s.demand(4095), None);
        assert!(s.demand(81).is_none() && s.demand(82).is_some());
        assert!(s.demand(4013).is_some() && s.demand(4014).is_none());
    }
}
