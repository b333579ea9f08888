//! The three-phase bridge as the board's timer drives it, without the timer: the timer's
//! settings from the actuator record's drive ([`BridgeTiming`]), and a [`Drive`] for the test
//! sequencer ([`BridgeDrive`]) that turns its commands into leg states ([`Leg`]) through
//! the position loop (six-step: a pair voltage on the rotor's conducting phases), the bus the
//! board measured and the record's dead-time compensation.
//!
//! Units: volts, amperes, radians, seconds; duties in timer counts of a centre-aligned
//! carrier (0 = the high switch never on, `counts` = always on). O(1) per call, no
//! allocation. The board (`board.rs`, feature `hardware`) writes the legs into TIM1; the host
//! tests them with a recording [`Legs`].

use shared::drive::DriveSettings;
use shared::math::{abs, clamp, floor};
use shared::params::ActuatorParams;
use shared::test_design::PAIR_SIGNS;

use crate::position_loop::{Feedback, PositionLoop, Sensing};
use crate::sequencer::Drive;

/// Why the record's drive cannot run on this timer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(any(feature = "defmt", target_os = "none"), derive(defmt::Format))]
pub enum BridgeError {
    /// The carrier needs more than 16 bits of counts, or fewer than 100 (duty resolution).
    CarrierCounts { counts: u32 },
    /// The control period is not a whole number (1 to 128) of carrier periods within 0.1 %:
    /// the ADC trigger would not keep the record's sample time.
    ControlPeriod { carriers_per_period_milli: u32 },
    /// The dead time needs more than the timer's dead-time generator holds (1 008 ticks).
    DeadTime { ticks: u32 },
}

/// What the bridge timer is set to: an advanced timer counting up and down (centre-aligned)
/// from its clock `timer_hz`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(any(feature = "defmt", target_os = "none"), derive(defmt::Format))]
pub struct BridgeTiming {
    /// Auto-reload: counts from the carrier's bottom to its top (the duty's full scale).
    pub counts: u16,
    /// Repetition counter: the update event (the ADC trigger) every `repetition + 1` counter
    /// turns, two per carrier, so once per control period at the carrier's top.
    pub repetition: u8,
    /// Dead time in timer clock ticks, rounded up (never shorter than the record's).
    pub dead_time_ticks: u16,
    /// Carrier periods per control period.
    pub carriers_per_period: u8,
}

/// The dead-time generator's longest setting [ticks of an undivided clock]: DTG = 0xFF,
/// (32 + 31) × 16.
const MAX_DEAD_TIME_TICKS: u32 = 1_008;

impl BridgeTiming {
    /// The timer's settings for `drive` at `control_period` [s] on a timer clocked at
    /// `timer_hz`. Refuses a drive the timer cannot play exactly.
    pub fn new(
        drive: &DriveSettings,
        timer_hz: u32,
        control_period: f32,
    ) -> Result<Self, BridgeError> {
        let counts = floor(timer_hz as f32 / (2.0 * drive.carrier_hz) + 0.5);
        // Float to int saturates (NaN → 0), so the range check sees every case.
        let whole = counts as u32;
        let Ok(counts) = u16::try_from(whole) else {
            return Err(BridgeError::CarrierCounts { counts: whole });
        };
        if counts < 100 {
            return Err(BridgeError::CarrierCounts { counts: whole });
        }
        // The carrier the timer really plays, and how many fit one control period.
        let carrier = timer_hz as f32 / (2.0 * f32::from(counts));
        let per_period = carrier * control_period;
        let carriers = floor(per_period + 0.5);
        let milli = (per_period * 1000.0) as u32;
        if !(1.0..=128.0).contains(&carriers) || abs(per_period - carriers) > 1.0e-3 * carriers {
            return Err(BridgeError::ControlPeriod {
                carriers_per_period_milli: milli,
            });
        }
        // 1 to 128 carriers: the repetition, 2·n − 1, fits the timer's 8-bit counter.
        let carriers = carriers as u8;
        let repetition = u8::try_from(2 * u16::from(carriers) - 1).unwrap_or(u8::MAX);
        let exact = drive.dead_time * timer_hz as f32;
        let ticks = -floor(-exact) as u32;
        let Ok(dead_time_ticks) = u16::try_from(ticks) else {
            return Err(BridgeError::DeadTime { ticks });
        };
        if ticks > MAX_DEAD_TIME_TICKS {
            return Err(BridgeError::DeadTime { ticks });
        }
        Ok(Self {
            counts,
            // Two counter turns (overflow, underflow) per carrier; an odd value written
            // before the counter starts puts the update on the overflow (RM0090 §17.3.3).
            repetition,
            dead_time_ticks,
            carriers_per_period: carriers,
        })
    }
}

impl BridgeTiming {
    /// The dead-time generator's DTG byte for [`Self::dead_time_ticks`] at an undivided
    /// clock (CKD = 1), rounded up to the generator's next step (RM0090 §17.4.18): 0–127
    /// ticks in steps of 1, then to 254 in steps of 2, to 504 in steps of 8, to 1 008 in
    /// steps of 16.
    pub fn dead_time_register(&self) -> u8 {
        let t = u32::from(self.dead_time_ticks);
        let code = if t <= 127 {
            t
        } else if t <= 254 {
            0x80 | (t.div_ceil(2) - 64)
        } else if t <= 504 {
            0xC0 | (t.div_ceil(8) - 32)
        } else {
            0xE0 | (t.div_ceil(16).min(63) - 32)
        };
        code as u8
    }

    /// The dead time a DTG byte `dtg` makes [ticks of an undivided clock].
    pub fn dead_time_of(dtg: u8) -> u32 {
        let d = u32::from(dtg);
        match dtg >> 5 {
            0..=3 => d,
            4 | 5 => (64 + (d & 0x3F)) * 2,
            6 => (32 + (d & 0x1F)) * 8,
            _ => (32 + (d & 0x1F)) * 16,
        }
    }
}

/// One leg of the bridge for the next control period.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(any(feature = "defmt", target_os = "none"), derive(defmt::Format))]
pub enum Leg {
    /// Both switches off: the leg floats (its current freewheels through the diodes).
    Off,
    /// Complementary switching, the high switch on for `counts` of [`BridgeTiming::counts`]
    /// around the carrier's bottom (every leg low at its top, where the ADC samples).
    Duty(u16),
}

/// The bridge's three legs, as the board's timer takes them.
pub trait Legs {
    /// Applies `legs` (phases a, b, c) from the next update on.
    fn set(&mut self, legs: [Leg; 3]);
}

/// Legs that keep what they were last set to, for a plant on the host that reads them each
/// control period: each leg's duty in timer counts, `None` for a leg off. O(1).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LatchedLegs(pub [Option<u16>; 3]);

impl Legs for &mut LatchedLegs {
    fn set(&mut self, legs: [Leg; 3]) {
        self.0 = legs.map(|l| match l {
            Leg::Off => None,
            Leg::Duty(d) => Some(d),
        });
    }
}

/// The sequencer's [`Drive`] on a real bridge: position commands through the position loop,
/// pair voltages and pauses as leg states. Feed it each frame's measurements
/// ([`BridgeDrive::measured`]) before the sequencer ticks it.
pub struct BridgeDrive<L> {
    legs: L,
    timing: BridgeTiming,
    drive: DriveSettings,
    position_loop: PositionLoop,
    feedback: Feedback,
    /// The pair signs and volts acting until the next update (what was set last period).
    acting: ([i8; 3], f32),
    /// The pair circuit: 2R [Ω] and dt/2L [A/V] over one control period.
    two_r: f32,
    dt_over_two_l: f32,
}

impl<L: Legs> BridgeDrive<L> {
    pub fn new(
        legs: L,
        timing: BridgeTiming,
        drive: DriveSettings,
        params: &ActuatorParams,
        sensing: Sensing,
    ) -> Self {
        Self {
            legs,
            timing,
            drive,
            position_loop: PositionLoop::new(params, sensing),
            feedback: Feedback::default(),
            acting: ([0; 3], 0.0),
            two_r: 2.0 * params.phase_resistance,
            dt_over_two_l: params.control_period / (2.0 * params.phase_inductance),
        }
    }

    /// This period's measurements (the frame the ADC and the encoder latched at the trigger).
    pub fn measured(&mut self, feedback: Feedback) {
        self.feedback = feedback;
    }

    /// The legs (what was last set on them).
    pub fn legs_mut(&mut self) -> &mut L {
        &mut self.legs
    }

    /// The duty for a leg voltage `volts` from the bus midpoint, with the measured bus and
    /// the leg's measured current (dead-time compensation by its sign beyond the threshold);
    /// the same law as the reference model's controller (`host-sim` `plant::bridge`).
    pub fn duty(&self, volts: f32, current: f32) -> u16 {
        let bus = self.feedback.bus_voltage.max(1.0e-3);
        let mut duty = 0.5 + volts / bus;
        let d = &self.drive;
        if d.compensation && abs(current) > d.compensation_threshold {
            duty += if current > 0.0 { 1.0 } else { -1.0 } * d.dead_time * d.carrier_hz;
        }
        let n = f32::from(self.timing.counts);
        // Saturating float-to-int: NaN → 0 (leg low), beyond the top → the top.
        clamp(floor(duty * n + 0.5), 0.0, n) as u16
    }

    /// Whether what is set now acts from the next update on (the position loop's sensing).
    fn late(&self) -> bool {
        self.position_loop.sensing().late_voltage
    }

    /// The phase currents when legs set now take effect, at standstill: measured, or with
    /// late voltages the acting pair's current carried one period on by its R–L circuit
    /// (no back-EMF) from the volts acting until then.
    fn currents_at_update(&self) -> [f32; 3] {
        let measured = self.feedback.phase_currents;
        if !self.late() {
            return measured;
        }
        let (signs, volts) = self.acting;
        let along: f32 = signs
            .iter()
            .zip(&measured)
            .map(|(&s, &i)| f32::from(s) * i)
            .sum::<f32>()
            * 0.5;
        let next = along + (volts - self.two_r * along) * self.dt_over_two_l;
        signs.map(|s| f32::from(s) * next)
    }

    /// `volts` across the legs `signs` marks (+1 high, −1 low), ±½ of it each from the bus
    /// midpoint with the compensation for its own leg's `currents`; the leg marked 0 off.
    fn drive_pair(&mut self, signs: [i8; 3], volts: f32, currents: [f32; 3]) {
        self.acting = (signs, volts);
        let mut legs = [Leg::Off; 3];
        for ((leg, &sign), &current) in legs.iter_mut().zip(&signs).zip(&currents) {
            if sign != 0 {
                *leg = Leg::Duty(self.duty(f32::from(sign) * 0.5 * volts, current));
            }
        }
        self.legs.set(legs);
    }
}

impl<L: Legs> Drive for BridgeDrive<L> {
    fn position(&mut self, rad: f32) {
        let pair = self.position_loop.step(rad, &self.feedback);
        let currents = if self.late() {
            pair.signs.map(|s| f32::from(s) * pair.current)
        } else {
            self.feedback.phase_currents
        };
        self.drive_pair(pair.signs, pair.volts, currents);
    }

    fn pair_voltage(&mut self, pair: u8, volts: f32) {
        self.position_loop.suspend();
        let currents = self.currents_at_update();
        match PAIR_SIGNS.get(usize::from(pair)) {
            Some(&signs) => self.drive_pair(signs, volts, currents),
            None => self.off(pair),
        }
    }

    fn off(&mut self, _pair: u8) {
        self.position_loop.suspend();
        self.acting = ([0; 3], 0.0);
        self.legs.set([Leg::Off; 3]);
    }

    fn lead(&self) -> usize {
        usize::from(self.position_loop.sensing().late_voltage)
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::vec;
    use std::vec::Vec;

    #[test]
    fn the_reference_drive_on_a_168_mhz_timer() {
        let t = BridgeTiming::new(&DriveSettings::TYPICAL, 168_000_000, 1.0e-4).unwrap();
        // 168 MHz / (2 · 20 kHz) = 4 200 counts; two carriers per 100 µs; 0.5 µs = 84 ticks.
        assert_eq!(t.counts, 4_200);
        assert_eq!(t.carriers_per_period, 2);
        assert_eq!(t.repetition, 3);
        assert_eq!(t.dead_time_ticks, 84);
        // The most carriers a control period takes: 128, the repetition counter's top.
        let slow = DriveSettings {
            carrier_hz: 12_800.0,
            ..DriveSettings::TYPICAL
        };
        let t = BridgeTiming::new(&slow, 168_000_000, 1.0e-2).unwrap();
        assert_eq!((t.carriers_per_period, t.repetition), (128, 255));
    }

    #[test]
    fn the_dead_time_register_never_shortens_the_dead_time() {
        let mut previous = 0;
        for ticks in 0..=1_008u16 {
            let t = BridgeTiming {
                dead_time_ticks: ticks,
                ..BridgeTiming::new(&DriveSettings::TYPICAL, 168_000_000, 1.0e-4).unwrap()
            };
            let dtg = t.dead_time_register();
            let made = BridgeTiming::dead_time_of(dtg);
            assert!(
                made >= u32::from(ticks),
                "{ticks} ticks: DTG {dtg:#04x} makes {made}"
            );
            // Within one step of the generator, and never going back.
            let step = match ticks {
                0..=127 => 0,
                128..=254 => 1,
                255..=504 => 7,
                _ => 15,
            };
            assert!(made <= u32::from(ticks) + step, "{ticks}: {made}");
            assert!(made >= previous);
            previous = made;
        }
        // The reference drive's 84 ticks (0.5 µs) are exact.
        let t = BridgeTiming::new(&DriveSettings::TYPICAL, 168_000_000, 1.0e-4).unwrap();
        assert_eq!(t.dead_time_register(), 84);
    }

    #[test]
    fn a_drive_the_timer_cannot_play_is_refused() {
        let t = DriveSettings::TYPICAL;
        let odd = DriveSettings {
            carrier_hz: 15_000.0,
            ..t
        };
        // 1.5 carriers per control period.
        assert!(matches!(
            BridgeTiming::new(&odd, 168_000_000, 1.0e-4),
            Err(BridgeError::ControlPeriod {
                carriers_per_period_milli: 1_500
            })
        ));
        assert!(matches!(
            BridgeTiming::new(&t, 1_000_000, 1.0e-4),
            Err(BridgeError::CarrierCounts { counts: 25 })
        ));
        let long = DriveSettings {
            dead_time: 7.0e-6,
            ..t
        };
        assert_eq!(
            BridgeTiming::new(&long, 168_000_000, 1.0e-4),
            Err(BridgeError::DeadTime { ticks: 1_176 })
        );
        let nan = DriveSettings {
            carrier_hz: f32::NAN,
            ..t
        };
        assert!(BridgeTiming::new(&nan, 168_000_000, 1.0e-4).is_err());
    }

    #[derive(Default)]
    struct Recorder(Vec<[Leg; 3]>);
    impl Legs for Recorder {
        fn set(&mut self, legs: [Leg; 3]) {
            self.0.push(legs);
        }
    }

    fn drive(compensation: bool) -> BridgeDrive<Recorder> {
        let d = DriveSettings {
            compensation,
            ..DriveSettings::TYPICAL
        };
        let timing = BridgeTiming::new(&d, 168_000_000, 1.0e-4).unwrap();
        let mut b = BridgeDrive::new(
            Recorder::default(),
            timing,
            d,
            &ActuatorParams::REFERENCE,
            Sensing::DIRECT,
        );
        b.measured(Feedback {
            bus_voltage: 270.0,
            ..Feedback::default()
        });
        b
    }

    #[test]
    fn a_pair_voltage_splits_across_its_legs_and_leaves_the_third_open() {
        let mut b = drive(false);
        // 27 V across pair 1 (b+, c−): ±13.5 V from the midpoint, 0.5 ± 0.05 of 4 200.
        b.pair_voltage(1, 27.0);
        b.off(1);
        b.pair_voltage(7, 27.0);
        assert_eq!(
            b.legs.0,
            vec![
                [Leg::Off, Leg::Duty(2_310), Leg::Duty(1_890)],
                [Leg::Off; 3],
                [Leg::Off; 3],
            ]
        );
    }

    #[test]
    fn dead_time_compensation_follows_the_measured_current_beyond_its_threshold() {
        let mut b = drive(true);
        // 0.5 µs · 20 kHz = 1 % of the period = 42 counts, by the current's sign.
        b.measured(Feedback {
            bus_voltage: 270.0,
            phase_currents: [2.0, -2.0, 0.01],
            ..Feedback::default()
        });
        assert_eq!(b.duty(0.0, 2.0), 2_142);
        assert_eq!(b.duty(0.0, -2.0), 2_058);
        assert_eq!(b.duty(0.0, 0.01), 2_100);
        assert_eq!(drive(false).duty(0.0, 2.0), 2_100);
        // Beyond the bus: the top, never a wrapped count; NaN: leg low.
        assert_eq!(b.duty(1.0e6, 0.0), 4_200);
        assert_eq!(b.duty(-1.0e6, 0.0), 0);
        assert_eq!(b.duty(f32::NAN, 0.0), 0);
    }
}
