//! A plain brushless motor on a rigid gear, driven through the bridge's two conducting legs,
//! written from the physics — not the monitor model, not the reference model: the pair
//! circuit `V = 2R·i + 2L·di/dt + k_t·ω` fed by the legs' duties on the bus, torque `k_t·i`
//! along the pair the rotor's sector makes of it, the motor's and the surface's inertias
//! through the gear, no friction, no load. What a drive's wiring is checked against (the
//! duty's sign and scale, the conducting legs and their signs per sector, the floating leg
//! off): a sign error makes the loop run away or a pair's current flow backwards
//! (`tests/board_drive.rs`, `board-emu`). Step: 50 Euler steps per control period.

use firmware::position_loop::Feedback;
use shared::params::ActuatorParams;

/// Euler steps per control period.
const STEPS: usize = 50;

#[derive(Clone, Copy, Debug)]
pub struct PairMotor {
    pub p: ActuatorParams,
    /// The bus [V].
    pub bus: f32,
    /// The pair current along the conducting legs' signs [A], and those signs.
    pub current: f32,
    pub signs: [i8; 3],
    /// Motor shaft angle [rad] and speed [rad/s].
    pub motor_angle: f32,
    pub motor_speed: f32,
}

impl PairMotor {
    /// At rest, no current, on a bus of `bus` volts.
    pub fn new(p: ActuatorParams, bus: f32) -> Self {
        Self {
            p,
            bus,
            current: 0.0,
            signs: [0; 3],
            motor_angle: 0.0,
            motor_speed: 0.0,
        }
    }

    /// What the controller's sensors read now (exactly: no noise, no quantisation).
    pub fn feedback(&self) -> Feedback {
        Feedback {
            phase_currents: self.signs.map(|s| f32::from(s) * self.current),
            motor_angle: self.motor_angle,
            user_angle: self.motor_angle / self.p.gear_ratio,
            bus_voltage: self.bus,
        }
    }

    /// One control period with the legs at `duties` (each leg's high side, 0 … 1 of the
    /// carrier; `None`: both switches off). Two driven legs form the pair; any other number
    /// carries no current.
    pub fn period(&mut self, duties: [Option<f32>; 3]) {
        // The driven legs' voltages from the bus midpoint; a floating leg carries nothing.
        let volts = duties.map(|d| d.map(|d| (d - 0.5) * self.bus));
        let driven: Vec<usize> = (0..3).filter(|&x| volts[x].is_some()).collect();
        let (a, b) = match driven.as_slice() {
            &[a, b] => (a, b),
            _ => {
                self.current = 0.0;
                self.signs = [0; 3];
                return self.coast();
            }
        };
        let mut signs = [0i8; 3];
        signs[a] = 1;
        signs[b] = -1;
        if signs != self.signs {
            // The current keeps its phase a's direction where the new pair shares it.
            let carried: f32 = (0..3)
                .map(|x| f32::from(self.signs[x]) * f32::from(signs[x]))
                .sum::<f32>()
                * 0.5;
            self.current *= carried;
            self.signs = signs;
        }
        let pair_volts = volts[a].unwrap_or(0.0) - volts[b].unwrap_or(0.0);
        let p = &self.p;
        let kt = p.torque_constant();
        let j = self.inertia();
        let h = p.control_period / STEPS as f32;
        for _ in 0..STEPS {
            // The EMF and torque along this pair: the sector's signs decide their sign
            // through the drive's choice, so the pair current is the equivalent current
            // when the drive commutates as the rotor does.
            let along = equivalent_sign(signs, p.pole_pairs * self.motor_angle);
            let emf = along * kt * self.motor_speed;
            let di = (pair_volts - 2.0 * p.phase_resistance * self.current - emf)
                / (2.0 * p.phase_inductance);
            self.current += h * di;
            let torque = along * kt * self.current;
            self.motor_speed += h * torque / j;
            self.motor_angle += h * self.motor_speed;
        }
    }

    /// The motor's and the surface's inertias seen at the motor [kg·m²].
    fn inertia(&self) -> f32 {
        let p = &self.p;
        p.motor_inertia + p.user_inertia / (p.gear_ratio * p.gear_ratio)
    }

    /// No torque: the shafts turn on at their speed over the period.
    fn coast(&mut self) {
        self.motor_angle += self.p.control_period * self.motor_speed;
    }
}

/// +1 when the pair `signs` is the sector's pair for `theta_e` with its signs, −1 reversed,
/// 0 for another pair (a mis-commutated drive gets no torque from it).
fn equivalent_sign(signs: [i8; 3], theta_e: f32) -> f32 {
    let sector = shared::conditioning::commutation_signs(theta_e);
    let dot: i32 = (0..3)
        .map(|x| i32::from(signs[x]) * i32::from(sector[x]))
        .sum();
    match dot {
        2 => 1.0,
        -2 => -1.0,
        _ => 0.0,
    }
}
