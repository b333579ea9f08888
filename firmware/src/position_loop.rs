//! The actuator's position loop on the board: the cascade the monitor model's controller
//! describes (SPEC §3: position PID → speed PI with conditional integration → current), with
//! the current loop in rotor coordinates (field-oriented: d-axis current held at 0, the
//! q-axis current driven to the speed loop's demand in one period, as the monitor model's
//! current law does) and the phase voltages it needs.
//!
//! Units: rad (user shaft for the command and the transducer, motor shaft for the encoder),
//! rad/s, A, V; one call per control period `params.control_period`; O(1), no allocation.
//! The encoder is taken as zeroed on the rotor's d-axis (the board's alignment at assembly).

use shared::math::{clamp, cos, sin};
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

/// √3 / 2.
const HALF_SQRT3: f32 = 0.866_025_4;
/// 1 / √3.
const INV_SQRT3: f32 = 0.577_350_3;

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
    /// its speed estimate from the next angle.
    pub fn suspend(&mut self) {
        *self = Self::new(&self.params);
    }

    /// The phase voltages from the bus midpoint [V] (a, b, c) that take the user shaft to
    /// `command` [rad], within what the bus can give (sine-triangle with min-max injection:
    /// a line voltage of at most the bus).
    pub fn step(&mut self, command: f32, f: &Feedback) -> [f32; 3] {
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
        // Clarke and Park at the electrical angle.
        let [ia, ib, _] = f.phase_currents;
        let alpha = ia;
        let beta = (ia + 2.0 * ib) * INV_SQRT3;
        let angle = p.pole_pairs * f.motor_angle;
        let (sin, cos) = (sin(angle), cos(angle));
        let id = alpha * cos + beta * sin;
        let iq = -alpha * sin + beta * cos;
        // The current law in one period (as the monitor model's), with the rotation's
        // cross terms and the back-EMF on q.
        let l = p.phase_inductance;
        let r = p.phase_resistance;
        let electrical_speed = p.pole_pairs * speed;
        let l_over_dt = l / dt;
        let vd = r * id + l_over_dt * (0.0 - id) - electrical_speed * l * iq;
        let vq = r * iq
            + l_over_dt * (current_ref - iq)
            + electrical_speed * l * id
            + p.back_emf_constant * speed;
        // Inverse Park and Clarke.
        let v_alpha = vd * cos - vq * sin;
        let v_beta = vd * sin + vq * cos;
        let v = [
            v_alpha,
            -0.5 * v_alpha + HALF_SQRT3 * v_beta,
            -0.5 * v_alpha - HALF_SQRT3 * v_beta,
        ];
        // Min-max injection centres the three on the midpoint; then scale into the bus.
        let high = v[0].max(v[1]).max(v[2]);
        let low = v[0].min(v[1]).min(v[2]);
        let centre = 0.5 * (high + low);
        let span = high - low;
        let bus = f.bus_voltage.max(0.0);
        let scale = if span > bus && span > 0.0 {
            bus / span
        } else {
            1.0
        };
        v.map(|x| (x - centre) * scale)
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
    fn voltages_are_centred_on_the_midpoint_and_stay_within_the_bus() {
        let mut l = PositionLoop::new(&ActuatorParams::REFERENCE);
        let mut saturated = 0;
        for k in 0..200 {
            let angle = 0.05 * k as f32;
            let v = l.step(0.01, &feedback(angle));
            let high = v.iter().copied().fold(f32::MIN, f32::max);
            let low = v.iter().copied().fold(f32::MAX, f32::min);
            assert!((high + low).abs() < 1.0e-3, "{v:?}");
            assert!(high - low <= 270.0 * (1.0 + 1.0e-5), "{v:?}");
            if high - low > 269.0 {
                saturated += 1;
            }
        }
        // A 10 mrad step asks for far more than the bus: the limit was exercised.
        assert!(saturated > 0);
    }

    #[test]
    fn a_positive_error_asks_for_torque_along_q() {
        // At rest, aligned (angle 0), a small positive error: the q-axis voltage is
        // positive and along β (phase b leads c), d stays near 0.
        let mut l = PositionLoop::new(&ActuatorParams::REFERENCE);
        let v = l.step(1.0e-4, &feedback(0.0));
        let v_alpha = v[0];
        let v_beta = (v[1] - v[2]) / (2.0 * HALF_SQRT3);
        assert!(v_beta > 1.0, "{v:?}");
        assert!(v_alpha.abs() < 1.0e-3 * v_beta, "{v:?}");
        // The opposite error, the opposite voltage.
        let mut l = PositionLoop::new(&ActuatorParams::REFERENCE);
        let w = l.step(-1.0e-4, &feedback(0.0));
        assert!(((w[1] - w[2]) + (v[1] - v[2])).abs() < 1.0e-3);
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
