//! The actuator's position loop on the board: the ACE controller the monitor model describes
//! (SPEC §3) — position PID → speed PI with conditional integration → current — driving the
//! brushless motor by six-step commutation: the sector of the electrical angle picks the two
//! conducting phases and their signs (`shared::conditioning::COMMUTATION_SIGNS`, the third
//! floats), and their pair voltage takes the equivalent current to the speed loop's demand in
//! one control period, with the monitor model's current law
//! `V = 2R·i + k_t·ω + (2L/dt)·(i_ref − i)`.
//!
//! Units: rad (user shaft for the command and the transducer, motor shaft for the encoder),
//! rad/s, A, V; one call per control period `params.control_period`; O(1), no allocation.
//! The encoder is taken as zeroed where the electrical angle is 0 (the board's alignment at
//! assembly).

use shared::conditioning::{commutation_signs, equivalent_current};
use shared::math::clamp;
use shared::params::ActuatorParams;

/// What the loop reads each control period.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Feedback {
    /// Phase currents a, b, c [A].
    pub phase_currents: [f32; 3],
    /// Motor shaft angle from the encoder [rad].
    pub motor_angle: f32,
    /// User shaft angle from the surface transducer [rad].
    pub user_angle: f32,
    /// DC bus voltage [V].
    pub bus_voltage: f32,
}

/// A voltage across the two conducting phases: `signs[x]` +1 for the leg driven high, −1 for
/// the one driven low, 0 for the floating one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairVoltage {
    pub signs: [i8; 3],
    /// [V], within ± the measured bus.
    pub volts: f32,
}

/// The cascade's state and gains.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PositionLoop {
    params: ActuatorParams,
    position_integral: f32,
    previous_error: f32,
    speed_integral: f32,
    /// The previous period's motor angle; `None` after a suspension (no speed yet).
    previous_motor_angle: Option<f32>,
}

impl PositionLoop {
    pub fn new(params: &ActuatorParams) -> Self {
        Self {
            params: *params,
            position_integral: 0.0,
            previous_error: 0.0,
            speed_integral: 0.0,
            previous_motor_angle: None,
        }
    }

    /// The loop is not driving (pair voltages, pauses): its integrators restart from 0 and
    /// its speed estimate from the next angle, as the actuator's controller does when the
    /// position loop closes again.
    pub fn suspend(&mut self) {
        *self = Self::new(&self.params);
    }

    /// The pair voltage that takes the user shaft to `command` [rad].
    pub fn step(&mut self, command: f32, f: &Feedback) -> PairVoltage {
        let p = &self.params;
        let dt = p.control_period;
        // Position PID.
        let error = command - f.user_angle;
        self.position_integral += error * dt;
        let rate = (error - self.previous_error) / dt;
        self.previous_error = error;
        let speed_ref = clamp(
            p.position_kp * error + p.position_ki * self.position_integral + p.position_kd * rate,
            -p.max_speed,
            p.max_speed,
        );
        // Speed PI on the encoder's difference, integrating only out of saturation.
        let speed = self
            .previous_motor_angle
            .map_or(0.0, |previous| (f.motor_angle - previous) / dt);
        self.previous_motor_angle = Some(f.motor_angle);
        let speed_error = speed_ref - speed;
        let integral = self.speed_integral + speed_error * dt;
        let unsaturated = p.speed_kp * speed_error + p.speed_ki * integral;
        let current_ref = clamp(unsaturated, -p.max_current, p.max_current);
        if unsaturated == current_ref || (unsaturated > current_ref) != (speed_error > 0.0) {
            self.speed_integral = integral;
        }
        // Six-step commutation and the pair's current law.
        let theta_e = p.pole_pairs * f.motor_angle;
        let current = equivalent_current(f.phase_currents, theta_e);
        let volts = 2.0 * p.phase_resistance * current
            + p.torque_constant() * speed
            + (2.0 * p.phase_inductance / dt) * (current_ref - current);
        let bus = f.bus_voltage.max(0.0);
        PairVoltage {
            signs: commutation_signs(theta_e),
            volts: clamp(volts, -bus, bus),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn feedback(angle: f32) -> Feedback {
        Feedback {
            bus_voltage: 270.0,
            motor_angle: angle,
            ..Feedback::default()
        }
    }

    #[test]
    fn the_conducting_pair_follows_the_rotor_and_the_voltage_stays_within_the_bus() {
        let p = ActuatorParams::REFERENCE;
        let mut l = PositionLoop::new(&p);
        let mut saturated = 0;
        for k in 0..200 {
            let angle = 0.01 * k as f32;
            let v = l.step(0.01, &feedback(angle));
            // One phase floats, the other two carry opposite signs: the rotor's sector's.
            assert_eq!(v.signs, commutation_signs(p.pole_pairs * angle));
            assert_eq!(v.signs.iter().map(|&s| i32::from(s)).sum::<i32>(), 0);
            assert!(v.volts.abs() <= 270.0, "{v:?}");
            if v.volts.abs() == 270.0 {
                saturated += 1;
            }
        }
        // A 10 mrad step asks for far more than the bus: the limit was exercised.
        assert!(saturated > 0);
    }

    #[test]
    fn the_voltage_pushes_towards_the_command() {
        // At rest, no current: a positive error asks for a positive pair voltage (motoring
        // torque in the positive direction), a negative one for a negative voltage.
        let p = ActuatorParams::REFERENCE;
        let up = PositionLoop::new(&p).step(1.0e-6, &feedback(0.0)).volts;
        let down = PositionLoop::new(&p).step(-1.0e-6, &feedback(0.0)).volts;
        assert!(up > 0.0 && down < 0.0, "{up} {down}");
        assert!((up + down).abs() < 1.0e-3 * up);
        // The cascade by hand: speed demand kp·e, current demand from the speed PI's first
        // step, and at rest (no current, no speed) only the inductive term of the law.
        let dt = p.control_period;
        let speed_ref = p.position_kp * 1.0e-6;
        let current_ref = p.speed_kp * speed_ref + p.speed_ki * speed_ref * dt;
        let expected = 2.0 * p.phase_inductance / dt * current_ref;
        assert!(
            (up - expected).abs() < 1.0e-4 * expected,
            "{up} against {expected}"
        );
    }

    #[test]
    fn suspension_restarts_the_integrators() {
        let mut l = PositionLoop::new(&ActuatorParams::REFERENCE);
        let fresh = l;
        l.step(0.01, &feedback(0.0));
        l.step(0.01, &feedback(0.3));
        assert_ne!(l, fresh);
        l.suspend();
        assert_eq!(l, fresh);
    }
}
