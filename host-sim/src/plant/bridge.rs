//! The reference model's power bridge and operating day: what a real inverter and the weather
//! do to the voltages the controller commands and to the motor it drives (SPEC §9).
//!
//! Units: V, A, Ω, s, °C (K for differences). Everything here is O(1) per call and pure: the
//! reference model (`reference.rs`) calls it once per control period (duties) and once per
//! 1 µs fine step (leg voltages); nothing reads a clock.
//!
//! * **Bridge** ([`BridgeSettings`]): centre-aligned PWM at `carrier_hz` from a timer at
//!   `timer_hz` (duties in whole counts: at 168 MHz and 20 kHz one count is 1/4 200 of the
//!   bus); every edge has `dead_time` with both switches off, during which the diodes set the
//!   leg by the current's sign; the controller adds the dead time back by the sign of the
//!   *measured* current, only where that current is beyond `compensation_threshold` (near
//!   zero the sign is unknown); switches drop `switch_resistance · i`, diodes `diode_drop`;
//!   the harness adds `harness_resistance` to each phase; the bus carries `ripple` at
//!   `ripple_hz`.
//! * **Day** ([`OperatingConditions`], [`ThermalLaws`]): winding temperature (copper
//!   resistance, magnet flux by the magnet's coefficient), gear temperature (dry friction by
//!   the grease's law, a table of factors), bus voltage.
//! * **What the controller measures of them** ([`ConditionSensors`]): the bus voltage through
//!   a divider with a gain error, a temperature with a bias (a winding thermistor, or the
//!   board), both with noise and quantisation.

/// A three-phase PWM bridge as the controller drives it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BridgeSettings {
    /// PWM carrier frequency [Hz] (centre-aligned: the counter runs up and down once).
    pub carrier_hz: f64,
    /// Timer clock [Hz]: one count of duty is `carrier_hz / (timer_hz / 2)` of the period.
    pub timer_hz: f64,
    /// Time with both switches of a leg off at every edge [s].
    pub dead_time: f64,
    /// Whether the controller adds the dead time back by the measured current's sign.
    pub compensation: bool,
    /// Measured current below which the controller does not know the sign and does not
    /// compensate [A].
    pub compensation_threshold: f64,
    /// On-resistance of a conducting switch [Ω].
    pub switch_resistance: f64,
    /// Forward drop of a conducting freewheeling diode [V].
    pub diode_drop: f64,
    /// Harness resistance from the bridge to each phase [Ω].
    pub harness_resistance: f64,
    /// Peak bus ripple as a fraction of the bus voltage, and its frequency [Hz].
    pub ripple: f64,
    pub ripple_hz: f64,
    /// The controller's timing: how long after the sample it was computed from a control
    /// period's output (the duties, the current reference) takes effect [s], from 0 (at the
    /// sample, this project's controller) to one control period. A controller that computes
    /// each duty from the sample it just took and loads it at the next PWM update has one
    /// carrier period (50 µs at 20 kHz).
    pub duty_delay: f64,
}

impl BridgeSettings {
    /// What the actuator record carries of this bridge for the controller's board: the
    /// carrier, the dead time and its compensation.
    pub fn drive(&self) -> shared::drive::DriveSettings {
        shared::drive::DriveSettings {
            carrier_hz: self.carrier_hz as f32,
            dead_time: self.dead_time as f32,
            compensation: self.compensation,
            compensation_threshold: self.compensation_threshold as f32,
        }
    }

    /// A bridge that applies exactly what it is told: no counts, no dead time, no drops.
    /// For studies of what the bridge does; never the plant a result is claimed on.
    pub const IDEAL: Self = Self {
        carrier_hz: 10_000.0,
        timer_hz: 0.0,
        dead_time: 0.0,
        compensation: false,
        compensation_threshold: 0.0,
        switch_resistance: 0.0,
        diode_drop: 0.0,
        harness_resistance: 0.0,
        ripple: 0.0,
        ripple_hz: 0.0,
        duty_delay: 0.0,
    };

    /// A 270 V MOSFET/IGBT bridge as the issue describes it: 20 kHz centre-aligned carrier
    /// from a 168 MHz timer, 0.5 µs dead time compensated by the measured current's sign
    /// beyond 50 mA, 30 mΩ switches, 0.8 V diodes, 50 mΩ of harness per phase, 1 % ripple
    /// at 2.4 kHz (a 400 Hz six-pulse rectifier).
    pub const TYPICAL: Self = Self {
        carrier_hz: 20_000.0,
        timer_hz: 168.0e6,
        dead_time: 0.5e-6,
        compensation: true,
        compensation_threshold: 0.05,
        switch_resistance: 0.03,
        diode_drop: 0.8,
        harness_resistance: 0.05,
        ripple: 0.01,
        ripple_hz: 2400.0,
        duty_delay: 0.0,
    };

    /// Timer counts from the bottom to the top of the carrier (the duty's resolution);
    /// `None` for an ideal, continuous duty.
    pub fn counts(&self) -> Option<f64> {
        (self.timer_hz > 0.0 && self.carrier_hz > 0.0)
            .then(|| (self.timer_hz / (2.0 * self.carrier_hz)).round().max(1.0))
    }

    /// The duty (share of the carrier period with the high switch commanded on) the
    /// controller writes for a leg voltage `volts` from the bus midpoint, with the bus it
    /// measured, and its dead-time compensation by the measured leg current's sign. In whole
    /// counts, within [0, 1].
    pub fn duty(&self, volts: f64, measured_bus: f64, measured_current: f64) -> f64 {
        // (2·v)/(2·bus): the same bits as the pair form ½ ± V/(2·bus) the ideal drive had.
        let mut duty = 0.5 + (2.0 * volts) / (2.0 * measured_bus.max(1e-3));
        if self.compensation && measured_current.abs() > self.compensation_threshold {
            duty += measured_current.signum() * self.dead_time * self.carrier_hz;
        }
        let duty = match self.counts() {
            Some(n) => (duty * n).round() / n,
            None => duty,
        };
        duty.clamp(0.0, 1.0)
    }

    /// The carrier period within a control period of `control_period` [s]: a whole number
    /// of carriers per control period, so that the controller's instants fall on the
    /// counter's bottom (the ADC samples at the carrier's centre, with every leg low).
    pub fn period(&self, control_period: f64) -> f64 {
        let n = (self.carrier_hz * control_period).round().max(1.0);
        control_period / n
    }

    /// The mean voltage of one leg from the bus midpoint over the fine step `[t0, t0 + dt]`
    /// of a carrier of `period` [s] that starts at the counter's bottom at time 0:
    /// the high switch is commanded on for the middle `duty` of the period and turns on
    /// `dead_time` after its command; until then (and after the low switch's turn-off) the
    /// diodes decide by the leg current `current` (positive into the motor). O(1).
    pub fn leg_voltage(
        &self,
        duty: f64,
        period: f64,
        t0: f64,
        dt: f64,
        bus: f64,
        current: f64,
    ) -> f64 {
        let t0 = t0.rem_euclid(period);
        let rise = 0.5 * period * (1.0 - duty);
        let fall = 0.5 * period * (1.0 + duty);
        let overlap = |a: f64, b: f64| ((t0 + dt).min(b) - t0.max(a)).max(0.0);
        if self.dead_time == 0.0 && self.switch_resistance == 0.0 {
            // A lossless leg: the share of the step it spends high.
            let high = overlap(rise, fall) / dt;
            return (2.0 * high - 1.0) * 0.5 * bus;
        }
        // Windows of the period, in order: low on, dead, high on, dead, low on.
        let dead = self.dead_time.min(fall - rise);
        let high = overlap(rise + dead, fall);
        let dead_share = overlap(rise, rise + dead) + overlap(fall, (fall + dead).min(period));
        let low = dt - high - dead_share;
        let half = 0.5 * bus;
        let switch_drop = self.switch_resistance * current;
        let diode = if current > 0.0 {
            -half - self.diode_drop
        } else {
            half + self.diode_drop
        };
        ((half - switch_drop) * high + (-half - switch_drop) * low + diode * dead_share) / dt
    }

    /// The voltage of a switched leg (hysteresis control: `leg` = +1 high, −1 low) with its
    /// switch's drop. O(1).
    pub fn switched_leg(&self, leg: i8, bus: f64, current: f64) -> f64 {
        f64::from(leg) * 0.5 * bus - self.switch_resistance * current
    }

    /// The voltage of a leg with both switches off and current flowing through a diode.
    pub fn diode_leg(&self, bus: f64, current: f64) -> f64 {
        if current > 0.0 {
            -0.5 * bus - self.diode_drop
        } else if current < 0.0 {
            0.5 * bus + self.diode_drop
        } else {
            0.0
        }
    }

    /// The bus voltage at time `t` [s] around its mean `mean` [V].
    pub fn bus(&self, mean: f64, t: f64) -> f64 {
        mean * (1.0 + self.ripple * (std::f64::consts::TAU * self.ripple_hz * t).sin())
    }
}

/// The day a test runs on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OperatingConditions {
    /// Winding (and magnet) temperature [°C].
    pub winding_temperature: f64,
    /// Gear and bearing (grease) temperature [°C].
    pub gear_temperature: f64,
    /// Mean DC bus voltage [V]; `None`: the actuator's nominal bus.
    pub bus_voltage: Option<f64>,
}

impl OperatingConditions {
    /// The data sheet's day: everything at the reference temperature, the nominal bus.
    pub const REFERENCE: Self = Self {
        winding_temperature: ThermalLaws::REFERENCE_TEMPERATURE,
        gear_temperature: ThermalLaws::REFERENCE_TEMPERATURE,
        bus_voltage: None,
    };

    /// The same day with the whole actuator at `celsius` (a morning on the ramp).
    pub fn at_temperature(mut self, celsius: f64) -> Self {
        self.winding_temperature = celsius;
        self.gear_temperature = celsius;
        self
    }
}

/// How the actuator's physics moves with temperature.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThermalLaws {
    /// Temperature the data sheet's R, k_e and friction are given at [°C].
    pub reference_temperature: f64,
    /// Copper resistance coefficient [1/K] (0.00393 for copper).
    pub copper: f64,
    /// Magnet flux coefficient [1/K] (−0.0011 NdFeB, −0.00035 SmCo).
    pub magnet: f64,
    /// Dry friction against gear temperature, when the grease has no drag of its own
    /// (`grease_drag` = 0): a Coulomb part that does not move and a grease-drag part,
    /// `viscous_share` of it at the reference temperature, that follows the grease's
    /// viscosity ratio `ν_r = exp(activation · (1/T − 1/T_ref))` (Arrhenius, T in kelvin):
    /// one factor on the whole dry friction.
    pub friction_viscous_share: f64,
    /// The grease's base-oil activation temperature [K] (its viscosity law, both forms).
    pub friction_activation: f64,
    /// The grease as two things (SPEC §9): a viscous drag on the motor shaft
    /// `grease_drag · ν_r · ω_m` [N·m·s/rad at the reference temperature], and the dry
    /// (break-away and sliding) friction scaled by `ν_r^coulomb_exponent`, a much weaker law.
    /// 0: the one-factor law above.
    pub grease_drag: f64,
    /// Power of the viscosity ratio the dry friction follows in the two-part form [-].
    pub coulomb_exponent: f64,
    /// The form of the base oil's viscosity against temperature (both grease forms).
    pub viscosity_law: ViscosityLaw,
}

/// How a grease's base oil thickens in the cold. Both forms reach the same ratio at
/// [`ViscosityLaw::MATCHED_AT`] (−40 °C) for one `friction_activation`; they differ in shape
/// between.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum ViscosityLaw {
    /// `ν_r = exp(activation · (1/T − 1/T_ref))`, T in kelvin.
    #[default]
    Arrhenius,
    /// Walther's (ASTM D341) `log log(ν + 0.7) = A − B·log T` [cSt, K], the oil at
    /// [`ViscosityLaw::WALTHER_REFERENCE_CST`] at the reference temperature and `B` set so
    /// that the ratio at −40 °C is Arrhenius's: steeper than Arrhenius in the deep cold,
    /// flatter near the reference.
    Walther,
    /// Vogel–Fulcher–Tammann's `ν_r = exp(B · (1/(T − T₀) − 1/(T_ref − T₀)))`, T₀ =
    /// [`ViscosityLaw::VOGEL_FULCHER_T0`], `B` set so that the ratio at −40 °C is
    /// Arrhenius's: a glass-forming oil, steeper still in the deep cold.
    VogelFulcher,
}

impl ViscosityLaw {
    /// The temperature both forms agree at [°C].
    pub const MATCHED_AT: f64 = -40.0;
    /// The base oil's viscosity at the reference temperature under Walther's law [cSt] (a
    /// typical grease base oil).
    pub const WALTHER_REFERENCE_CST: f64 = 100.0;
    /// Vogel–Fulcher's divergence temperature [K] (−123 °C, a mineral base oil's).
    pub const VOGEL_FULCHER_T0: f64 = 150.0;
}

impl ThermalLaws {
    pub const REFERENCE_TEMPERATURE: f64 = 20.0;
    /// Copper's 0.393 %/K, NdFeB magnets, and a greased gear train with 40 % grease drag at
    /// 20 °C whose friction is 3.0× at −40 °C, 1.8× at −20 °C, 1.27× at 0 °C, 0.81× at
    /// 50 °C and 0.72× at 80 °C (activation 2 040 K).
    pub const NDFEB_GREASED: Self = Self {
        reference_temperature: Self::REFERENCE_TEMPERATURE,
        copper: 0.00393,
        magnet: -0.0011,
        friction_viscous_share: 0.4,
        friction_activation: 2040.0,
        grease_drag: 0.0,
        coulomb_exponent: 0.0,
        viscosity_law: ViscosityLaw::Arrhenius,
    };

    /// The same actuator with a two-part grease: the base oil ×10 viscosity at −40 °C
    /// against 20 °C (activation 2 623 K), dry friction following ν_r^0.47 (×2.95 at −40 °C,
    /// ×0.49 at +80 °C), and a drag at 20 °C of a fifth of `params`' sliding friction at the
    /// chirp's typical motor speed (0.08 rad/s at the surface times the gear ratio: 40 rad/s
    /// and 2·10⁻⁴ N·m·s/rad on the reference actuator's 500:1 gear).
    pub fn with_two_part_grease(self, params: &shared::ActuatorParams) -> Self {
        let typical_speed = 0.08 * f64::from(params.gear_ratio);
        Self {
            friction_activation: 2623.0,
            grease_drag: 0.2 * f64::from(params.dynamic_friction) / typical_speed.max(1e-3),
            coulomb_exponent: 0.47,
            ..self
        }
    }

    /// Copper resistance at `celsius` relative to the data sheet's.
    pub fn copper_scale(&self, celsius: f64) -> f64 {
        1.0 + self.copper * (celsius - self.reference_temperature)
    }

    /// Magnet flux at `celsius` relative to the data sheet's.
    pub fn flux_scale(&self, celsius: f64) -> f64 {
        1.0 + self.magnet * (celsius - self.reference_temperature)
    }

    /// The grease's viscosity at gear temperature `celsius` relative to the reference
    /// temperature's.
    pub fn viscosity_ratio(&self, celsius: f64) -> f64 {
        const KELVIN: f64 = 273.15;
        let arrhenius = |celsius: f64| {
            let inverse = 1.0 / (celsius + KELVIN) - 1.0 / (self.reference_temperature + KELVIN);
            (self.friction_activation * inverse).exp()
        };
        match self.viscosity_law {
            ViscosityLaw::Arrhenius => arrhenius(celsius),
            ViscosityLaw::Walther => {
                let nu_ref = ViscosityLaw::WALTHER_REFERENCE_CST;
                let loglog = |nu: f64| (nu + 0.7).log10().log10();
                let log_t = |c: f64| (c + KELVIN).log10();
                let matched = nu_ref * arrhenius(ViscosityLaw::MATCHED_AT);
                let b = (loglog(matched) - loglog(nu_ref))
                    / (log_t(self.reference_temperature) - log_t(ViscosityLaw::MATCHED_AT));
                let at = loglog(nu_ref) - b * (log_t(celsius) - log_t(self.reference_temperature));
                (10f64.powf(10f64.powf(at)) - 0.7) / nu_ref
            }
            ViscosityLaw::VogelFulcher => {
                let t0 = ViscosityLaw::VOGEL_FULCHER_T0;
                let inverse = |c: f64| 1.0 / (c + KELVIN - t0);
                let reference = inverse(self.reference_temperature);
                let b = arrhenius(ViscosityLaw::MATCHED_AT).ln()
                    / (inverse(ViscosityLaw::MATCHED_AT) - reference);
                (b * (inverse(celsius) - reference)).exp()
            }
        }
    }

    /// Dry friction at gear temperature `celsius` relative to the data sheet's.
    pub fn friction_scale(&self, celsius: f64) -> f64 {
        let ratio = self.viscosity_ratio(celsius);
        if self.grease_drag > 0.0 {
            return ratio.powf(self.coulomb_exponent);
        }
        let s = self.friction_viscous_share;
        (1.0 - s) + s * ratio
    }

    /// The grease's viscous drag on the motor shaft at gear temperature `celsius`
    /// [N·m·s/rad] (0 for the one-factor law).
    pub fn drag(&self, celsius: f64) -> f64 {
        if self.grease_drag > 0.0 {
            self.grease_drag * self.viscosity_ratio(celsius)
        } else {
            0.0
        }
    }
}

/// What the controller measures of its bus and its temperature, with the sensors' errors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConditionSensors {
    /// Relative gain error of the bus-voltage divider.
    pub bus_gain_error: f64,
    /// RMS noise and quantum of the bus measurement [V].
    pub bus_noise: f64,
    pub bus_lsb: f64,
    /// Bias of the temperature reading against the winding [K] (a thermistor's tolerance,
    /// or how far the board sits from the winding).
    pub temperature_bias: f64,
    /// RMS noise and quantum of the temperature reading [K].
    pub temperature_noise: f64,
    pub temperature_lsb: f64,
}

impl ConditionSensors {
    /// A 0.5 % divider read at 0.1 V, a winding thermistor within 2 K read at 0.1 K.
    pub const TYPICAL: Self = Self {
        bus_gain_error: 0.005,
        bus_noise: 0.2,
        bus_lsb: 0.1,
        temperature_bias: 2.0,
        temperature_noise: 0.2,
        temperature_lsb: 0.1,
    };
    /// Exact readings (for studies of the sensors' share).
    pub const EXACT: Self = Self {
        bus_gain_error: 0.0,
        bus_noise: 0.0,
        bus_lsb: 0.0,
        temperature_bias: 0.0,
        temperature_noise: 0.0,
        temperature_lsb: 0.0,
    };
}

/// `x` to the nearest multiple of `lsb` (`lsb` = 0: unchanged).
pub fn to_lsb(x: f64, lsb: f64) -> f64 {
    if lsb > 0.0 {
        (x / lsb).round() * lsb
    } else {
        x
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const STEP: f64 = 1.0e-6;

    /// The mean leg voltage over one carrier period, fine step by fine step.
    fn period_mean(b: &BridgeSettings, duty: f64, current: f64) -> f64 {
        let period = b.period(1.0e-4);
        let n = (period / STEP).round() as usize;
        (0..n)
            .map(|k| b.leg_voltage(duty, period, k as f64 * STEP, STEP, 270.0, current))
            .sum::<f64>()
            / n as f64
    }

    #[test]
    fn an_ideal_leg_applies_its_duty_exactly() {
        let b = BridgeSettings {
            carrier_hz: 20_000.0,
            ..BridgeSettings::IDEAL
        };
        for volts in [-20.0, -0.12, 0.0, 0.12, 20.0] {
            let d = b.duty(volts, 270.0, 0.0);
            assert!((period_mean(&b, d, 0.0) - volts).abs() < 1e-9, "{volts}");
        }
    }

    #[test]
    fn dead_time_costs_its_share_of_the_bus_against_the_current_and_compensation_returns_it() {
        let raw = BridgeSettings {
            compensation: false,
            switch_resistance: 0.0,
            diode_drop: 0.0,
            timer_hz: 0.0,
            ..BridgeSettings::TYPICAL
        };
        // 0.5 µs of 50 µs at 270 V: 2.7 V against the current's direction.
        let d = raw.duty(0.0, 270.0, 1.0);
        assert!((period_mean(&raw, d, 1.0) + 2.7).abs() < 1e-6);
        assert!((period_mean(&raw, d, -1.0) - 2.7).abs() < 1e-6);
        let compensated = BridgeSettings {
            compensation: true,
            ..raw
        };
        for i in [1.0, -1.0] {
            let d = compensated.duty(0.0, 270.0, i);
            assert!(period_mean(&compensated, d, i).abs() < 1e-6, "{i}");
        }
        // Below the threshold the sign is unknown: nothing is compensated.
        let d = compensated.duty(0.0, 270.0, 0.01);
        assert!((period_mean(&compensated, d, 0.01) + 2.7).abs() < 1e-6);
    }

    #[test]
    fn duties_come_in_whole_timer_counts() {
        let b = BridgeSettings::TYPICAL;
        assert_eq!(b.counts(), Some(4200.0));
        let d = b.duty(0.12, 270.0, 0.0);
        assert_eq!((d * 4200.0).fract(), 0.0);
        // One count is 270/4200 = 64 mV of leg voltage: 0.12 V is 1.87 counts, applied as 2.
        assert_eq!(d * 4200.0, 2102.0);
    }

    #[test]
    fn grease_friction_is_threefold_at_minus_40_and_falls_towards_coulomb_when_hot() {
        let t = ThermalLaws::NDFEB_GREASED;
        assert_eq!(t.friction_scale(20.0), 1.0);
        assert!((t.friction_scale(-40.0) - 3.0).abs() < 0.01);
        assert!((t.friction_scale(-20.0) - 1.8).abs() < 0.01);
        assert!((t.friction_scale(80.0) - 0.72).abs() < 0.01);
        assert!(t.friction_scale(200.0) > 0.6);
        assert!((t.copper_scale(-40.0) - (1.0 - 0.2358)).abs() < 1e-12);
        assert!((t.flux_scale(80.0) - 0.934).abs() < 1e-12);
        assert_eq!(t.drag(-40.0), 0.0);
    }

    #[test]
    fn the_viscosity_laws_agree_at_the_reference_and_at_minus_40_and_differ_between() {
        let arrhenius =
            ThermalLaws::NDFEB_GREASED.with_two_part_grease(&shared::ActuatorParams::REFERENCE);
        let ratio = |law: ViscosityLaw, c: f64| {
            ThermalLaws {
                viscosity_law: law,
                ..arrhenius
            }
            .viscosity_ratio(c)
        };
        for law in [ViscosityLaw::Walther, ViscosityLaw::VogelFulcher] {
            assert!((ratio(law, 20.0) - 1.0).abs() < 1e-9, "{law:?}");
            let cold = ratio(ViscosityLaw::Arrhenius, -40.0);
            assert!((ratio(law, -40.0) / cold - 1.0).abs() < 1e-9, "{law:?}");
            // Between, the forms part: each falls with temperature, none is Arrhenius.
            let mid = ratio(law, -10.0) / ratio(ViscosityLaw::Arrhenius, -10.0);
            assert!((mid - 1.0).abs() > 0.02, "{law:?}: {mid}");
            let mut last = f64::INFINITY;
            for c in [-60.0, -40.0, -20.0, 0.0, 20.0, 50.0, 80.0] {
                let r = ratio(law, c);
                assert!(r < last && r > 0.0, "{law:?} at {c}: {r}");
                last = r;
            }
        }
    }

    #[test]
    fn a_two_part_grease_drags_tenfold_at_minus_40_while_its_dry_friction_triples() {
        let t = ThermalLaws::NDFEB_GREASED.with_two_part_grease(&shared::ActuatorParams::REFERENCE);
        assert!((t.drag(20.0) - 2.0e-4).abs() < 1e-11, "{}", t.drag(20.0));
        let drag = t.drag(-40.0) / t.drag(20.0);
        assert!((drag - 10.0).abs() < 0.1, "{drag}");
        let dry = t.friction_scale(-40.0);
        assert!((dry - 2.95).abs() < 0.05, "{dry}");
        assert!((t.friction_scale(80.0) - 0.49).abs() < 0.01);
        assert_eq!(t.friction_scale(20.0), 1.0);
    }
}
