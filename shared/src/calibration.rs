//! How the monitor model is fitted to one actuator: electrical and mechanical scale factors
//! and the nominal residual, found on a healthy trace (`host-sim calibrate`). Plain data, no
//! work: the firmware carries it in the actuator record ([`crate::actuator`]); the monitor
//! model applies it once at construction and the fitness subtracts its residual.

use crate::test_design::PreflightTest;

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
}

impl Calibration {
    /// No correction: the monitor model as the parameters describe it.
    pub const IDENTITY: Self = Self {
        resistance_scale: 1.0,
        inductance_scale: 1.0,
        back_emf_scale: 1.0,
        friction_scale: 1.0,
        damping: 0.0,
        nominal_residual: 0.0,
    };
}

impl Calibration {
    /// The monitor model calibrated against this project's reference model with the default
    /// test (standstill segment + chirp): what `host-sim calibrate` fits on the healthy,
    /// noise-free reference trace (seed 0). The firmware carries it as data; `host-sim`
    /// checks it is still what the fit gives.
    pub const REFERENCE_ACTUATOR: Self = Self {
        resistance_scale: 0.47267297,
        inductance_scale: 0.860487,
        back_emf_scale: 1.001137,
        friction_scale: 0.99771225,
        damping: 9.88454,
        nominal_residual: 0.0007770943,
    };

    /// The same for the paper's test (the chirp alone).
    pub const REFERENCE_ACTUATOR_PAPER: Self = Self {
        resistance_scale: 0.75073683,
        inductance_scale: 0.8183919,
        back_emf_scale: 0.99955827,
        friction_scale: 0.9820077,
        damping: 8.570111,
        nominal_residual: 0.0011607918,
    };
}

impl Calibration {
    /// The reference actuator's calibration for `test`: the paper's for a test without a
    /// standstill segment, the default test's otherwise.
    pub fn reference_actuator(test: &PreflightTest) -> Self {
        if test.standstill.is_some() {
            Self::REFERENCE_ACTUATOR
        } else {
            Self::REFERENCE_ACTUATOR_PAPER
        }
    }
}

impl Default for Calibration {
    fn default() -> Self {
        Self::IDENTITY
    }
}
