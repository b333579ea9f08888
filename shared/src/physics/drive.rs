//! The power bridge the controller drives, as the actuator record carries it: the PWM
//! carrier \[Hz\] (centre-aligned), the dead time \[s\] at every switching edge, and whether
//! the controller adds the dead time back by the measured current's sign, beyond a current
//! threshold \[A\]. Plain data; the checks are O(1) (the threshold's, finite and at least 0,
//! is the record's non-negative check).
//!
//! The board (firmware feature `hardware`) sets its bridge timer from these values; the
//! host's reference model plays the same bridge from the description file's `[drive]`
//! section, where these keys have the same names.

/// The bridge settings of one actuator's controller.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DriveSettings {
    /// PWM carrier \[Hz\], centre-aligned (the counter runs up and down once per period).
    pub carrier_hz: f32,
    /// Both switches of a leg off at every edge \[s\].
    pub dead_time: f32,
    /// Whether the controller adds the dead time back by the measured current's sign.
    pub compensation: bool,
    /// Measured current below which the sign is unknown and nothing is added \[A\].
    pub compensation_threshold: f32,
}

impl DriveSettings {
    /// The reference actuator's 270 V bridge: 20 kHz, 0.5 µs, compensated beyond 50 mA.
    /// Records written before version 5 (which had no drive) read as this.
    pub const TYPICAL: Self = Self {
        carrier_hz: 20_000.0,
        dead_time: 0.5e-6,
        compensation: true,
        compensation_threshold: 0.05,
    };

    /// The carrier is within 1–200 kHz.
    pub fn carrier_valid(&self) -> bool {
        (1.0e3..=2.0e5).contains(&self.carrier_hz)
    }

    /// The dead time is at least 0 and below a tenth of the carrier period.
    pub fn dead_time_valid(&self) -> bool {
        self.dead_time >= 0.0 && self.dead_time < 0.1 / self.carrier_hz
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn typical_is_valid_and_limits_refuse() {
        let t = DriveSettings::TYPICAL;
        assert!(t.carrier_valid() && t.dead_time_valid());
        let slow = DriveSettings {
            carrier_hz: 500.0,
            ..t
        };
        assert!(!slow.carrier_valid());
        let nan = DriveSettings {
            carrier_hz: f32::NAN,
            ..t
        };
        assert!(!nan.carrier_valid());
        // 5 µs at 20 kHz is exactly a tenth of the 50 µs period: refused.
        let long = DriveSettings {
            dead_time: 5.0e-6,
            ..t
        };
        assert!(!long.dead_time_valid());
    }
}
