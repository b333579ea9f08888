//! Actuator parameters: the one place where the physical numbers of the reference actuator live.
//!
//! SI units throughout: volts, amperes, ohms, henries, seconds, radians, N·m, kg·m².
//! "Motor side" quantities refer to the fast (motor) shaft, "user side" to the slow (surface)
//! shaft; the gear ratio relates them (`θ_motor = gear_ratio · θ_user` when there is no play).
//!
//! The set describes a ~1 kW flight-control EMA: 270 V DC bus, 4 pole pairs, R ≈ 0.6 Ω and
//! L ≈ 2.5 mH per phase, k_e ≈ 0.13 V·s/rad, gear ratio 500, 10 kHz control and ADC. The
//! mechanical and controller numbers are chosen so that the 0.5 s test chirp (5 mrad at the
//! user shaft, 0 → 15 Hz) is tracked closely while drawing currents well above ripple and noise:
//! a spring-like aerodynamic load dominates at low frequency, motor inertia at high frequency.

/// Temperature the data sheet gives R, k_e and friction at [°C].
pub const REFERENCE_TEMPERATURE: f32 = 20.0;

/// Number of `f32` words in [`ActuatorParams::to_words`].
pub const PARAM_WORDS: usize = 27;

/// Physical parameters and nominal controller settings of the actuator.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ActuatorParams {
    // ---- power drive and motor ----
    /// DC bus voltage available to the inverter \[V\].
    pub dc_bus_voltage: f32,
    /// Number of rotor pole pairs P (electrical angle θ_e = P · θ_motor).
    pub pole_pairs: f32,
    /// Resistance of one stator phase \[Ω\].
    pub phase_resistance: f32,
    /// Self inductance of one stator phase (minus mutual) \[H\].
    pub phase_inductance: f32,
    /// Back-EMF constant of one phase, flat top of the trapezoid [V·s/rad, motor side].
    /// Two phases conduct in series, so the equivalent torque constant is `2 · k_e` [N·m/A].
    pub back_emf_constant: f32,
    /// Saturation of the reference current I_ref \[A\].
    pub max_current: f32,
    /// Winding layout: mechanical angle of the centre of each phase's coil group (A, B, C)
    /// \[rad\]. Each phase's coils sit side by side in its own third of the stator (a modular,
    /// fault-tolerant winding); what an eccentric air gap does to a phase depends on where
    /// its coils are.
    pub winding_group_angle: [f32; 3],

    // ---- mechanics ----
    /// Rotor (and motor-side gear) inertia [kg·m²].
    pub motor_inertia: f32,
    /// Surface (user-side) inertia [kg·m²].
    pub user_inertia: f32,
    /// Gear ratio motor : user [-].
    pub gear_ratio: f32,
    /// Torsional stiffness of the gear train, user side [N·m/rad].
    pub gear_stiffness: f32,
    /// Viscous damping of the gear train in contact, user side [N·m·s/rad].
    pub gear_damping: f32,
    /// Nominal total backlash (free play) of the gear train, user side \[rad\].
    pub nominal_backlash: f32,
    /// Nominal static (break-away) dry-friction torque, lumped at the motor [N·m].
    pub static_friction: f32,
    /// Nominal dynamic (sliding) dry-friction torque, lumped at the motor [N·m].
    pub dynamic_friction: f32,
    /// Speed below which the motor is considered stuck (stick-slip threshold) [rad/s].
    pub stick_speed: f32,
    /// Aerodynamic hinge-moment stiffness on the user shaft: T_R = −k · θ_user [N·m/rad].
    pub aero_stiffness: f32,
    /// What the motor encoder reads when the surface is at its zero with the gear relaxed
    /// [rad, motor side]: the rigging of one installation (the encoder is aligned to the
    /// rotor's magnets, not to the surface). The gear sees `θ_motor − encoder_offset`; the
    /// commutation sees `θ_motor`.
    pub encoder_offset: f32,

    // ---- ACE controller ----
    /// Position-loop proportional gain: motor speed reference per user-side position error
    /// [(rad/s) / rad]. The gain-drift fault scales it.
    pub position_kp: f32,
    /// Position-loop integral gain [(rad/s) / (rad·s)].
    pub position_ki: f32,
    /// Position-loop derivative gain on the user-side position error [(rad/s) / (rad/s)].
    pub position_kd: f32,
    /// Saturation of the motor speed reference [rad/s].
    pub max_speed: f32,
    /// Speed-loop proportional gain [A / (rad/s)].
    pub speed_kp: f32,
    /// Speed-loop integral gain [A / rad].
    pub speed_ki: f32,
    /// Control (and ADC) period \[s\].
    pub control_period: f32,
}

impl ActuatorParams {
    /// The reference actuator of this project.
    pub const REFERENCE: Self = Self {
        dc_bus_voltage: 270.0,
        pole_pairs: 4.0,
        phase_resistance: 0.6,
        phase_inductance: 2.5e-3,
        back_emf_constant: 0.13,
        max_current: 15.0,
        // A, B, C at 67.5°, 307.5°, 187.5°: 120° apart in the order A, C, B, which with 4
        // pole pairs puts B 120° electrical behind A.
        winding_group_angle: [
            67.5 * core::f32::consts::PI / 180.0,
            307.5 * core::f32::consts::PI / 180.0,
            187.5 * core::f32::consts::PI / 180.0,
        ],

        motor_inertia: 1.0e-4,
        user_inertia: 2.0,
        gear_ratio: 500.0,
        gear_stiffness: 1.0e7,
        gear_damping: 5000.0,
        // k2 = 1 (×100) gives 1e-3 rad of play: 20 % of the 5e-3 rad chirp amplitude.
        nominal_backlash: 1.0e-5,
        static_friction: 0.06,
        dynamic_friction: 0.04,
        stick_speed: 0.5,
        aero_stiffness: 5.0e4,
        encoder_offset: 0.0,

        // Position bandwidth ≈ kp / gear_ratio ≈ 200 rad/s (≈ 32 Hz): the chirp is tracked
        // with a growing lag, and the loop stays free of backlash limit cycles over the whole
        // fault range (at 3e5 it tracks better but chatters once k2 > 0.1, which makes the
        // fitness landscape chaotic).
        position_kp: 1.0e5,
        position_ki: 0.0,
        position_kd: 0.0,
        max_speed: 600.0,
        // Speed bandwidth ≈ kp · 2k_e / J ≈ 1800 rad/s.
        speed_kp: 0.7,
        speed_ki: 70.0,
        control_period: 1.0e-4,
    };

    /// Every field as one array, in declaration order (the winding angles in place): what the
    /// actuator record stores and the checkpoint fingerprint hashes. O(1).
    pub const fn to_words(&self) -> [f32; PARAM_WORDS] {
        let [a, b, c] = self.winding_group_angle;
        [
            self.dc_bus_voltage,
            self.pole_pairs,
            self.phase_resistance,
            self.phase_inductance,
            self.back_emf_constant,
            self.max_current,
            a,
            b,
            c,
            self.motor_inertia,
            self.user_inertia,
            self.gear_ratio,
            self.gear_stiffness,
            self.gear_damping,
            self.nominal_backlash,
            self.static_friction,
            self.dynamic_friction,
            self.stick_speed,
            self.aero_stiffness,
            self.encoder_offset,
            self.position_kp,
            self.position_ki,
            self.position_kd,
            self.max_speed,
            self.speed_kp,
            self.speed_ki,
            self.control_period,
        ]
    }

    /// The parameters from [`Self::to_words`]'s array.
    pub const fn from_words(w: [f32; PARAM_WORDS]) -> Self {
        let [dc_bus_voltage, pole_pairs, phase_resistance, phase_inductance, back_emf_constant, max_current, a, b, c, motor_inertia, user_inertia, gear_ratio, gear_stiffness, gear_damping, nominal_backlash, static_friction, dynamic_friction, stick_speed, aero_stiffness, encoder_offset, position_kp, position_ki, position_kd, max_speed, speed_kp, speed_ki, control_period] =
            w;
        Self {
            dc_bus_voltage,
            pole_pairs,
            phase_resistance,
            phase_inductance,
            back_emf_constant,
            max_current,
            winding_group_angle: [a, b, c],
            motor_inertia,
            user_inertia,
            gear_ratio,
            gear_stiffness,
            gear_damping,
            nominal_backlash,
            static_friction,
            dynamic_friction,
            stick_speed,
            aero_stiffness,
            encoder_offset,
            position_kp,
            position_ki,
            position_kd,
            max_speed,
            speed_kp,
            speed_ki,
            control_period,
        }
    }

    /// Equivalent torque (and line back-EMF) constant of two phases in series [N·m/A].
    pub fn torque_constant(&self) -> f32 {
        2.0 * self.back_emf_constant
    }
}

impl Default for ActuatorParams {
    fn default() -> Self {
        Self::REFERENCE
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn words_round_trip() {
        let p = ActuatorParams::REFERENCE;
        assert_eq!(ActuatorParams::from_words(p.to_words()), p);
        let w = p.to_words();
        assert_eq!(w[19], p.encoder_offset);
        assert_eq!(w[26], p.control_period);
    }
}
