//! How the monitor model is fitted to one actuator: electrical and mechanical scale factors
//! and the nominal residual, found on a healthy trace (`host-sim calibrate`). Plain data, no
//! work: the firmware carries it in the actuator record ([`crate::preflight::actuator`]); the monitor
//! model applies it once at construction and the fitness subtracts its residual.

use crate::test::test_design::PreflightTest;

/// Temperatures besides the calibration's at which the friction law can be measured.
pub const FRICTION_POINTS: usize = 4;
// The field's type spells the 4 out (a named constant there trips rustc 1.9x's MIR check).
const _: () = assert!(FRICTION_POINTS == 4);

/// How the monitor model is fitted to one actuator: electrical scale factors found on a
/// healthy trace, and the nominal residual error subtracted so that a healthy actuator scores
/// 0 (paper §III.2). Plain data: the firmware carries it as a constant or a flash record.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Calibration {
    /// Multiplier of the monitor model's equivalent resistance.
    pub resistance_scale: f32,
    /// Multiplier of the monitor model's equivalent inductance.
    pub inductance_scale: f32,
    /// Multiplier of the monitor model's back-EMF / torque constant.
    pub back_emf_scale: f32,
    /// Multiplier of the monitor model's nominal dry-friction torques (what the lumped
    /// friction of the model needs to be to match the healthy actuator).
    pub friction_scale: f32,
    /// Viscous damping on the monitor model's user shaft [N·m·s/rad] (aerodynamic and
    /// bearing damping the parameters do not list).
    pub damping: f32,
    /// Fitness of the nominal fault vector against the healthy trace [A²·s].
    pub nominal_residual: f32,
    /// Multipliers of the data sheet's phase R and L in the standstill segment's pair
    /// circuits: the installed circuit (copper, harness, switches, what the bridge does to
    /// the commanded volts) at the calibration's temperature.
    pub pair_resistance_scale: f32,
    pub pair_inductance_scale: f32,
    /// Temperature the controller measured during the healthy trace [°C]
    /// ([`crate::physics::params::REFERENCE_TEMPERATURE`] when the trace carried none).
    pub temperature: f32,
    /// The healthy actuator's dry friction measured at other temperatures (`host-sim
    /// calibrate --at`): `[°C, factor against the calibration's]`; a factor of 0 marks an
    /// unused point. With the calibration's own `(temperature, 1)` they make the friction
    /// law (`shared::conditions::friction_factor`); none: friction does not move.
    pub friction_points: [[f32; 2]; 4],
    /// Magnet flux coefficient [1/K] (−0.0011 NdFeB, −0.00035 SmCo; 0: not known).
    pub magnet_coefficient: f32,
    /// The installed controller's timing \[s\]: how long after a sample the voltages computed
    /// from it take effect (0 … one control period; a controller that loads each duty at
    /// the next PWM update has one carrier period). `host-sim calibrate` measures it on the
    /// healthy trace's injection; the injection's fit and the monitor model's pair circuits
    /// apply each period's volts that much late.
    pub duty_delay: f32,
    /// The chirp's viscous drag on the healthy trace (`crate::physics::grease`, its own units), when
    /// the grease has a drag of its own (the friction points' drags span at least
    /// [`DRAG_LAW_SPAN`] and fall as the temperatures rise). 0: it has none, or it was not
    /// measured (records before version 7); friction then follows the measured temperature.
    pub viscous: f32,
    /// The chirp's viscous drag at each friction point against [`viscous`](Self::viscous)
    /// (0 where unused): with the friction points they make the friction law by drag
    /// (`shared::conditions::friction_factor_by_drag`), the grease's own thermometer.
    pub drag_points: [f32; 4],
}

/// Ratio of the friction points' largest to smallest drag (the calibration's own 1 among
/// them) from which `host-sim calibrate` takes the grease to have a drag of its own and
/// writes a friction law by drag: a one-factor grease moves the chirp's drag by under ±25 %
/// (faults and noise included), a real grease's base oil ×5 and more from −40 to +20 °C
/// (docs/identifiability.md §0c).
pub const DRAG_LAW_SPAN: f32 = 2.0;

impl Calibration {
    /// No correction: the monitor model as the parameters describe it.
    pub const IDENTITY: Self = Self {
        resistance_scale: 1.0,
        inductance_scale: 1.0,
        back_emf_scale: 1.0,
        friction_scale: 1.0,
        damping: 0.0,
        nominal_residual: 0.0,
        pair_resistance_scale: 1.0,
        pair_inductance_scale: 1.0,
        temperature: crate::physics::params::REFERENCE_TEMPERATURE,
        friction_points: [[0.0; 2]; 4],
        magnet_coefficient: 0.0,
        duty_delay: 0.0,
        viscous: 0.0,
        drag_points: [0.0; 4],
    };
}

impl Calibration {
    /// The monitor model calibrated against this project's reference model with the default
    /// test (injection at standstill + chirp) on its real bridge: what `host-sim calibrate`
    /// fits on the healthy, noise-free reference trace (seed 0, 20 °C), with the friction
    /// law from healthy traces at −45, −25, 0 and +75 °C (`calibrate --at`) and the NdFeB
    /// magnets' coefficient. The firmware carries it as data; `host-sim` checks it is still
    /// what the fit gives.
    pub const REFERENCE_ACTUATOR: Self = Self {
        resistance_scale: 0.6197983,
        inductance_scale: 0.79253405,
        back_emf_scale: 1.0001426,
        friction_scale: 0.98432016,
        damping: 8.496969,
        nominal_residual: 0.013886672,
        pair_resistance_scale: 1.1904732,
        pair_inductance_scale: 1.0562423,
        temperature: 21.998205,
        friction_points: [
            [-43.001793, 3.550076],
            [-23.001795, 2.0123153],
            [1.9982052, 1.2823199],
            [76.9982, 0.7399107],
        ],
        magnet_coefficient: -0.0011,
        duty_delay: 0.0,
        viscous: 0.0,
        drag_points: [0.0; 4],
    };

    /// The same for the earlier default test (voltage steps at standstill), fitted on an
    /// ideal drive (that test cannot run on a real bridge: docs/identifiability.md).
    pub const REFERENCE_ACTUATOR_STEPS: Self = Self {
        resistance_scale: 1.2684298,
        inductance_scale: 0.43415764,
        back_emf_scale: 1.0011888,
        friction_scale: 0.9988724,
        damping: 9.943476,
        nominal_residual: 0.0007755383,
        ..Self::IDENTITY
    };

    /// The same for the paper's test (the chirp alone), fitted on an ideal drive.
    pub const REFERENCE_ACTUATOR_PAPER: Self = Self {
        resistance_scale: 0.8208843,
        inductance_scale: 0.6972787,
        back_emf_scale: 0.9999265,
        friction_scale: 0.9713661,
        damping: 10.043313,
        nominal_residual: 0.0011582866,
        ..Self::IDENTITY
    };
}

impl Calibration {
    /// The duty delay as a share of the control period `dt`, within [0, 1]: the weight of
    /// the previous period's volts in each period's mean. O(1).
    pub fn delay_share(&self, dt: f32) -> f32 {
        let share = self.duty_delay / dt;
        if share > 0.0 {
            share.min(1.0)
        } else {
            0.0
        }
    }

    /// The reference actuator's calibration for `test`: the injection's, the steps', or the
    /// paper's (a test without a standstill segment).
    pub fn reference_actuator(test: &PreflightTest) -> Self {
        match test.standstill {
            Some(s) if s.is_injection() => Self::REFERENCE_ACTUATOR,
            Some(_) => Self::REFERENCE_ACTUATOR_STEPS,
            None => Self::REFERENCE_ACTUATOR_PAPER,
        }
    }
}

impl Default for Calibration {
    fn default() -> Self {
        Self::IDENTITY
    }
}
