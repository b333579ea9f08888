//! The monitor model (MM): the fast, single-phase-equivalent model the GA runs thousands of
//! times (paper Fig. 4, SPEC §4).
//!
//! Fixed step = the control period (100 µs, 10 kHz); f32; O(1) work and no allocation per
//! step; one [`MonitorModel::run`] of `n` samples is `n` steps. Time is the step index times
//! the period, never read from a clock.
//!
//! Structure, per step:
//! 1. **ACE controller** — PID position loop on the user-shaft angle (its proportional gain
//!    carries the gain-drift fault) → motor speed reference (saturated) → PI speed loop with
//!    conditional-integration anti-windup → current reference I_ref (saturated).
//! 2. **Single-phase equivalent drive** — no PWM and no phase switching: the drive applies the
//!    voltage that would bring the current to I_ref within one period, limited to ±V_dc
//!    (an ideal hysteresis controller seen at the control rate), on an R–L–back-EMF branch of
//!    two phases in series. Electrical faults enter through the paper's shape functions:
//!    short circuit, eq. (1), scales resistance and torque/back-EMF gain by the mean healthy
//!    fraction of the two phases conducting in the current 60° sector; eccentricity, eq. (2),
//!    modulates torque/back-EMF gain with rotor angle.
//! 3. **Mechanics** — motor inertia (with lumped stick-slip dry friction: a velocity-level
//!    friction impulse that can stop, but never reverse, the motor within one step) coupled to
//!    the user inertia by a compliant gear train whose play is a dead zone; the user shaft
//!    carries the aerodynamic spring load. Semi-implicit Euler.
//!
//! The recorded signal is the equivalent current at the start of each step, i.e. what the ADC
//! samples at `t = i·dt` before the control update.
//!
//! A run starts at rest from the shaft angles measured at the test's first sample, the gear
//! relaxed inside its play ([`MonitorModel::run_from`]); the model's own traces start at zero.

use core::ops::ControlFlow;

use crate::command::{ChirpCommand, CommandSource};
use crate::conditioning::commutation_sector;
use crate::conditioning::ShaftAngles;
use crate::fault::FaultVector;
use crate::fitness::Calibration;
use crate::math::{abs, clamp, cos, frac, sin, TAU};
use crate::params::ActuatorParams;

/// What the monitor model exposes at each sample: the state at `time`, before the step's
/// update, plus the controller's output for the coming period.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MonitorSample {
    /// Time of the sample [s].
    pub time: f32,
    /// Commanded user-shaft angle [rad].
    pub command: f32,
    /// Equivalent (two conducting phases) motor current [A].
    pub current: f32,
    /// Reference current from the controller for the coming period [A].
    pub current_ref: f32,
    /// Motor-shaft angle at the sample [rad].
    pub motor_angle: f32,
    /// User-shaft angle at the sample [rad].
    pub user_angle: f32,
}

/// Running state of one simulation. Plain data, a few dozen bytes.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MonitorState {
    pub motor_angle: f32,
    /// Motor angle one period earlier (what the shape functions see).
    pub previous_motor_angle: f32,
    pub motor_speed: f32,
    /// True user-shaft angle [rad] (the aerodynamic load's zero is 0).
    pub user_angle: f32,
    pub user_speed: f32,
    /// Position-transducer offset [rad], constant over a run: the controller and the
    /// recorded samples see `user_angle + user_offset`.
    pub user_offset: f32,
    pub current: f32,
    pub position_integral: f32,
    pub previous_error: f32,
    pub speed_integral: f32,
}

impl MonitorState {
    /// At rest, with the shafts where the measured test began. The gear starts relaxed: the
    /// surface as near its load's rest (0) as the play allows, which splits the measured
    /// user angle into a true angle and the transducer's offset. O(1).
    fn at_rest(start: ShaftAngles, f: &FaultedConstants, inv_gear_ratio: f32) -> Self {
        let motor_at_user = start.motor * inv_gear_ratio;
        let user_angle = clamp(
            0.0,
            motor_at_user - f.half_backlash,
            motor_at_user + f.half_backlash,
        );
        Self {
            motor_angle: start.motor,
            previous_motor_angle: start.motor,
            user_angle,
            user_offset: start.user - user_angle,
            // The command starts at 0: no derivative kick on the first step.
            previous_error: -start.user,
            ..Self::default()
        }
    }
}

/// Quantities that depend on the fault vector, computed once per run.
#[derive(Clone, Copy, Debug)]
struct FaultedConstants {
    kp: f32,
    static_friction_impulse: f32,
    dynamic_friction_impulse: f32,
    half_backlash: f32,
    /// Short-circuit shape function eq. (1) for sector index mod 3.
    sector_gain: [f32; 3],
    eccentricity_z: f32,
    eccentricity_phase: f32,
}

/// The monitor model's settings: parameters, calibration and test command, with the
/// per-step constants derived once.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MonitorModel {
    params: ActuatorParams,
    command: ChirpCommand,
    dt: f32,
    inv_dt: f32,
    resistance: f32,
    l_over_dt: f32,
    dt_over_l: f32,
    torque_constant: f32,
    inv_gear_ratio: f32,
    dt_over_motor_inertia: f32,
    dt_over_user_inertia: f32,
    friction_scale: f32,
    user_damping: f32,
}

impl MonitorModel {
    /// A monitor model of `params` corrected by `calibration` (electrical scales, friction
    /// scale, user-shaft damping), driven by the preflight chirp.
    pub fn new(params: ActuatorParams, calibration: &Calibration) -> Self {
        let dt = params.control_period;
        let inductance = 2.0 * params.phase_inductance * calibration.inductance_scale;
        Self {
            params,
            command: ChirpCommand::PREFLIGHT,
            dt,
            inv_dt: 1.0 / dt,
            resistance: 2.0 * params.phase_resistance * calibration.resistance_scale,
            l_over_dt: inductance / dt,
            dt_over_l: dt / inductance,
            torque_constant: params.torque_constant() * calibration.back_emf_scale,
            inv_gear_ratio: 1.0 / params.gear_ratio,
            dt_over_motor_inertia: dt / params.motor_inertia,
            dt_over_user_inertia: dt / params.user_inertia,
            friction_scale: calibration.friction_scale,
            user_damping: calibration.damping,
        }
    }

    /// The same model driven by another command.
    pub fn with_command(mut self, command: ChirpCommand) -> Self {
        self.command = command;
        self
    }

    pub fn params(&self) -> &ActuatorParams {
        &self.params
    }

    pub fn command(&self) -> &ChirpCommand {
        &self.command
    }

    /// Number of samples in the whole test command.
    pub fn test_samples(&self) -> usize {
        let n = self.command.duration * self.inv_dt + 0.5;
        if n.is_finite() && n > 0.0 {
            n as usize
        } else {
            0
        }
    }

    fn faulted(&self, k: &FaultVector) -> FaultedConstants {
        let fx = k.effects();
        let p = &self.params;
        let [na, nb, nc] = fx.healthy_turns;
        FaultedConstants {
            kp: p.position_kp * fx.kp_scale,
            static_friction_impulse: self.dt_over_motor_inertia
                * p.static_friction
                * self.friction_scale
                * fx.friction_scale,
            dynamic_friction_impulse: self.dt_over_motor_inertia
                * p.dynamic_friction
                * self.friction_scale
                * fx.friction_scale,
            half_backlash: 0.5 * p.nominal_backlash * fx.backlash_scale,
            // Sector j (mod 3) has phase j floating: the other two conduct.
            sector_gain: [0.5 * (nb + nc), 0.5 * (nc + na), 0.5 * (na + nb)],
            eccentricity_z: fx.eccentricity_z,
            eccentricity_phase: fx.eccentricity_phase,
        }
    }

    /// Simulates `samples` steps from rest for fault vector `k`, handing each sample to `sink`.
    /// O(`samples`) work, no allocation.
    pub fn run(&self, k: &FaultVector, samples: usize, sink: impl FnMut(&MonitorSample)) {
        self.run_from(k, ShaftAngles::ZERO, samples, sink);
    }

    /// As [`run`](Self::run), from rest with the shafts at `start` (the measured angles at
    /// the first sample): the controller's integrators empty, the drive unpowered.
    pub fn run_from(
        &self,
        k: &FaultVector,
        start: ShaftAngles,
        samples: usize,
        mut sink: impl FnMut(&MonitorSample),
    ) {
        self.run_with(k, start, samples, &self.command, |s| {
            sink(s);
            ControlFlow::Continue(())
        });
    }

    /// The general run: at most `samples` steps from rest at `start`, reading the command
    /// from `command` (the model's own chirp, or a [`CommandTable`](crate::command::CommandTable)
    /// of it for the same bits with less work), until `sink` breaks. Returns the number of
    /// steps simulated. O(`samples`) work, no allocation.
    pub fn run_with(
        &self,
        k: &FaultVector,
        start: ShaftAngles,
        samples: usize,
        command: &impl CommandSource,
        mut sink: impl FnMut(&MonitorSample) -> ControlFlow<()>,
    ) -> usize {
        let f = self.faulted(k);
        let mut state = MonitorState::at_rest(start, &f, self.inv_gear_ratio);
        for i in 0..samples {
            let time = i as f32 * self.dt;
            let sample = self.step(&f, &mut state, time, command.position_at(i, time));
            if sink(&sample).is_break() {
                return i + 1;
            }
        }
        samples
    }

    /// Simulates `out.len()` samples and writes the equivalent current [A] into `out`.
    pub fn simulate(&self, k: &FaultVector, out: &mut [f32]) {
        let mut slots = out.iter_mut();
        self.run(k, slots.len(), |s| {
            if let Some(slot) = slots.next() {
                *slot = s.current;
            }
        });
    }

    /// One control period. O(1).
    #[inline(always)]
    fn step(
        &self,
        f: &FaultedConstants,
        s: &mut MonitorState,
        time: f32,
        command: f32,
    ) -> MonitorSample {
        let p = &self.params;
        let dt = self.dt;

        // 1. ACE controller.
        let error = command - (s.user_angle + s.user_offset);
        s.position_integral += error * dt;
        let error_rate = (error - s.previous_error) * self.inv_dt;
        s.previous_error = error;
        let speed_ref =
            f.kp * error + p.position_ki * s.position_integral + p.position_kd * error_rate;
        let speed_ref = clamp(speed_ref, -p.max_speed, p.max_speed);
        let speed_error = speed_ref - s.motor_speed;
        let integral = s.speed_integral + speed_error * dt;
        let unsaturated = p.speed_kp * speed_error + p.speed_ki * integral;
        let current_ref = clamp(unsaturated, -p.max_current, p.max_current);
        // Conditional integration: hold the integrator while it would push further into
        // saturation.
        if unsaturated == current_ref || (unsaturated > current_ref) != (speed_error > 0.0) {
            s.speed_integral = integral;
        }

        // 2. Single-phase equivalent drive with the electrical shape functions, evaluated at
        //    the rotor angle of the previous sample: the drive commutates from the last
        //    position it sampled.
        let theta_e = p.pole_pairs * s.previous_motor_angle;
        let short_gain = match commutation_sector(theta_e) % 3 {
            0 => f.sector_gain[0],
            1 => f.sector_gain[1],
            _ => f.sector_gain[2],
        };
        let eccentricity_gain = if f.eccentricity_z > 0.0 {
            let a = theta_e + f.eccentricity_phase;
            let sawtooth = frac((6.0 * theta_e + f.eccentricity_phase) * (1.0 / TAU));
            1.0 - f.eccentricity_z * (cos(a) + sawtooth * sin(a))
        } else {
            1.0
        };
        let kt = self.torque_constant * short_gain * eccentricity_gain;
        let r = self.resistance * short_gain;
        let back_emf = kt * s.motor_speed;
        let sampled = (s.current, s.motor_angle, s.user_angle + s.user_offset);
        let voltage = r * s.current + back_emf + self.l_over_dt * (current_ref - s.current);
        let voltage = clamp(voltage, -p.dc_bus_voltage, p.dc_bus_voltage);
        s.current += self.dt_over_l * (voltage - r * s.current - back_emf);
        let motor_torque = kt * s.current;

        // 3. Mechanics: dead-zone compliant gear train, stick-slip friction, aero load.
        let deflection = s.motor_angle * self.inv_gear_ratio - s.user_angle;
        let engaged = deflection - clamp(deflection, -f.half_backlash, f.half_backlash);
        // A contact pushes, never pulls: damping cannot reverse the spring's torque.
        let contact = p.gear_stiffness * engaged
            + p.gear_damping * (s.motor_speed * self.inv_gear_ratio - s.user_speed);
        let gear_torque = if engaged > 0.0 && contact > 0.0 || engaged < 0.0 && contact < 0.0 {
            contact
        } else {
            0.0
        };
        let free_speed = s.motor_speed
            + self.dt_over_motor_inertia * (motor_torque - gear_torque * self.inv_gear_ratio);
        let friction_impulse = if abs(s.motor_speed) < p.stick_speed {
            f.static_friction_impulse
        } else {
            f.dynamic_friction_impulse
        };
        s.motor_speed = if abs(free_speed) <= friction_impulse {
            0.0
        } else if free_speed > 0.0 {
            free_speed - friction_impulse
        } else {
            free_speed + friction_impulse
        };
        s.previous_motor_angle = s.motor_angle;
        s.motor_angle += s.motor_speed * dt;
        s.user_speed += self.dt_over_user_inertia
            * (gear_torque - p.aero_stiffness * s.user_angle - self.user_damping * s.user_speed);
        s.user_angle += s.user_speed * dt;

        MonitorSample {
            time,
            command,
            current: sampled.0,
            current_ref,
            motor_angle: sampled.1,
            user_angle: sampled.2,
        }
    }
}
