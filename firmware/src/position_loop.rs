//! The actuator's position loop on the board: the ACE controller the monitor model describes
//! (SPEC §3) — position PID → speed PI with conditional integration → current — driving the
//! brushless motor by six-step commutation: the sector of the electrical angle picks the two
//! conducting phases and their signs (`shared::conditioning::COMMUTATION_SIGNS`, the third
//! floats), and their pair voltage takes the equivalent current to the speed loop's demand in
//! one control period, with the monitor model's current law
//! `V = 2R·i + k_t·ω + (2L/dt)·(i_ref − i)`.
//!
//! A board is not the monitor model's ideal controller, and [`Sensing`] says how it differs:
//! its timer loads the voltage at the next update (the loop then steps from the current,
//! speed and angles it predicts for that update, on the next period's command), and its
//! sensors are coarse (an α-β observer carries the encoder's angle between counts with the
//! measured current's torque; the surface transducer is low-passed against the motor angle
//! through the gear). Without these the board's current swings at a sixth of the control rate
//! and its count steps become amperes (`tests/board_drive.rs`, `board-emu`).
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
    /// The pair current along `signs` the loop expects when the voltage takes effect [A].
    pub current: f32,
}

/// How the loop reads its sensors and when its voltage acts: settings, fixed for a board.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sensing {
    /// The voltage computed from a frame acts from the next control period on (a timer's
    /// preloaded compare registers): the current law aims at the current predicted for that
    /// update, from the voltage acting now.
    pub late_voltage: bool,
    /// The motor angle's tracking observer: the double pole of its error per control period
    /// (0 … 1; 0 takes the encoder as it comes, as the actuator's controller with a fine
    /// encoder does). Between counts it carries the angle on the speed and the torque the
    /// measured current makes.
    pub observer_pole: f32,
    /// Cutoff [rad/s] of the low-pass on the surface transducer's difference from the motor
    /// angle through the gear (0: the transducer as it comes). Above it the loop sees the
    /// motor's angle through the gear, below it the transducer.
    pub transducer_cutoff: f32,
}

impl Sensing {
    /// Fine sensors, a voltage that acts at once: the monitor model's controller as it is.
    pub const DIRECT: Self = Self {
        late_voltage: false,
        observer_pole: 0.0,
        transducer_cutoff: 0.0,
    };
    /// The board (`board.rs`): TIM1's preloaded duties, a 2 048-line encoder and a 12-bit
    /// transducer ADC, whose count steps (7.7 rad/s of speed across one period, 24 rad/s of
    /// speed demand per transducer count) the cascade's gains would otherwise turn into amperes.
    pub const BOARD: Self = Self {
        late_voltage: true,
        observer_pole: 0.74,
        transducer_cutoff: 50.0,
    };
}

/// What the loop knows of the shafts between frames.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Motion {
    /// Motor angle [rad] and speed [rad/s] as the observer holds them.
    motor_angle: f32,
    motor_speed: f32,
    /// The transducer's low-passed difference from the motor angle through the gear [rad].
    user_offset: f32,
    /// The pair current measured at the last frame [A].
    current: f32,
}

/// The cascade's state and gains.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PositionLoop {
    params: ActuatorParams,
    sensing: Sensing,
    position_integral: f32,
    previous_error: f32,
    speed_integral: f32,
    /// `None` after a suspension (no speed yet).
    motion: Option<Motion>,
    /// The pair voltage commanded last period: with late voltages, what acts now [V].
    acting_volts: f32,
}

impl PositionLoop {
    pub fn new(params: &ActuatorParams, sensing: Sensing) -> Self {
        Self {
            params: *params,
            sensing,
            position_integral: 0.0,
            previous_error: 0.0,
            speed_integral: 0.0,
            motion: None,
            acting_volts: 0.0,
        }
    }

    /// How the loop reads its sensors.
    pub fn sensing(&self) -> Sensing {
        self.sensing
    }

    /// The loop is not driving (pair voltages, pauses): its integrators restart from 0 and
    /// its speed estimate from the next angle, as the actuator's controller does when the
    /// position loop closes again.
    pub fn suspend(&mut self) {
        *self = Self::new(&self.params, self.sensing);
    }

    /// The shafts at this frame as the loop reads them.
    fn observe(&mut self, f: &Feedback, current: f32) -> Observed {
        let p = &self.params;
        let s = &self.sensing;
        let dt = p.control_period;
        let through_gear = |motor: f32| motor / p.gear_ratio;
        let Some(m) = self.motion else {
            self.motion = Some(Motion {
                motor_angle: f.motor_angle,
                motor_speed: 0.0,
                user_offset: f.user_angle - through_gear(f.motor_angle),
                current,
            });
            return Observed {
                motor_angle: f.motor_angle,
                speed: 0.0,
                user_angle: f.user_angle,
            };
        };
        let (motor_angle, speed) = if s.observer_pole > 0.0 {
            // An α-β observer with the torque of the period's mean current as its input.
            let acceleration = self.acceleration(0.5 * (m.current + current));
            let predicted = m.motor_angle + dt * m.motor_speed + 0.5 * dt * dt * acceleration;
            let error = f.motor_angle - predicted;
            let r = s.observer_pole;
            let (alpha, beta) = (1.0 - r * r, (1.0 - r) * (1.0 - r));
            (
                predicted + alpha * error,
                m.motor_speed + dt * acceleration + beta / dt * error,
            )
        } else {
            // The encoder's difference over the period.
            (f.motor_angle, (f.motor_angle - m.motor_angle) / dt)
        };
        let (user_offset, user_angle) = if s.transducer_cutoff > 0.0 {
            let share = clamp(s.transducer_cutoff * dt, 0.0, 1.0);
            let offset =
                m.user_offset + share * (f.user_angle - through_gear(motor_angle) - m.user_offset);
            (offset, through_gear(motor_angle) + offset)
        } else {
            (0.0, f.user_angle)
        };
        self.motion = Some(Motion {
            motor_angle,
            motor_speed: speed,
            user_offset,
            current,
        });
        Observed {
            motor_angle,
            speed,
            user_angle,
        }
    }

    /// The motor's acceleration [rad/s²] under the pair current `current` [A], the gear
    /// rigid and the load's inertia through it.
    fn acceleration(&self, current: f32) -> f32 {
        let p = &self.params;
        let inertia = p.motor_inertia + p.user_inertia / (p.gear_ratio * p.gear_ratio);
        p.torque_constant() * current / inertia
    }

    /// The pair voltage that takes the user shaft to `command` [rad]. With late voltages,
    /// `command` is the next period's: the loop steps from the state it predicts for the
    /// update at which its voltage takes effect.
    pub fn step(&mut self, command: f32, f: &Feedback) -> PairVoltage {
        let p = self.params;
        let dt = p.control_period;
        let two_r = 2.0 * p.phase_resistance;
        let two_l_per_dt = 2.0 * p.phase_inductance / dt;
        let kt = p.torque_constant();
        let measured_current = equivalent_current(f.phase_currents, p.pole_pairs * f.motor_angle);
        let now = self.observe(f, measured_current);
        let (current, speed, user_angle, motor_angle) = if self.sensing.late_voltage {
            // Over the period to the update the voltage commanded last period acts.
            let next_current = measured_current
                + (self.acting_volts - two_r * measured_current - kt * now.speed) / two_l_per_dt;
            let acceleration = self.acceleration(0.5 * (measured_current + next_current));
            let travel = dt * (now.speed + 0.5 * dt * acceleration);
            (
                next_current,
                now.speed + dt * acceleration,
                now.user_angle + travel / p.gear_ratio,
                now.motor_angle + travel,
            )
        } else {
            (measured_current, now.speed, now.user_angle, now.motor_angle)
        };
        // Position PID.
        let error = command - user_angle;
        self.position_integral += error * dt;
        let rate = (error - self.previous_error) / dt;
        self.previous_error = error;
        let speed_ref = clamp(
            p.position_kp * error + p.position_ki * self.position_integral + p.position_kd * rate,
            -p.max_speed,
            p.max_speed,
        );
        // Speed PI, integrating only out of saturation.
        let speed_error = speed_ref - speed;
        let integral = self.speed_integral + speed_error * dt;
        let unsaturated = p.speed_kp * speed_error + p.speed_ki * integral;
        let current_ref = clamp(unsaturated, -p.max_current, p.max_current);
        if unsaturated == current_ref || (unsaturated > current_ref) != (speed_error > 0.0) {
            self.speed_integral = integral;
        }
        // Six-step commutation and the pair's current law.
        let volts = two_r * current + kt * speed + two_l_per_dt * (current_ref - current);
        let bus = f.bus_voltage.max(0.0);
        let volts = clamp(volts, -bus, bus);
        self.acting_volts = volts;
        PairVoltage {
            signs: commutation_signs(p.pole_pairs * motor_angle),
            volts,
            current,
        }
    }
}

/// The shafts at a frame as the loop reads them.
#[derive(Clone, Copy, Debug)]
struct Observed {
    /// Motor angle [rad] and speed [rad/s].
    motor_angle: f32,
    speed: f32,
    /// User angle [rad].
    user_angle: f32,
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
        let mut l = PositionLoop::new(&p, Sensing::DIRECT);
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
        let up = PositionLoop::new(&p, Sensing::DIRECT)
            .step(1.0e-6, &feedback(0.0))
            .volts;
        let down = PositionLoop::new(&p, Sensing::DIRECT)
            .step(-1.0e-6, &feedback(0.0))
            .volts;
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
        let mut l = PositionLoop::new(&ActuatorParams::REFERENCE, Sensing::DIRECT);
        let fresh = l;
        l.step(0.01, &feedback(0.0));
        l.step(0.01, &feedback(0.3));
        assert_ne!(l, fresh);
        l.suspend();
        assert_eq!(l, fresh);
    }
}
