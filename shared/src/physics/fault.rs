//! The fault vector `k` (SPEC §3) and its mapping to physical quantities, in one place.
//!
//! Nine components, each in `[0, 1]`: the paper's eight and the magnets' flux loss (the
//! paper's named next fault). The paper's error `e_tot` (eq. 4) stays over the first
//! [`PAPER_FAULT_COUNT`].
//!
//! | index | accessor | fault | mapping |
//! | --- | --- | --- | --- |
//! | 0 | [`FaultVector::friction`] | dry friction | torques × (1 + 2·k1) |
//! | 1 | [`FaultVector::backlash`] | backlash | play × (1 + 99·k2) |
//! | 2, 3, 4 | [`FaultVector::short_circuit`] | partial short of phase A, B, C | healthy turns N = 1 − k, floored at [`MIN_HEALTHY_TURNS`] |
//! | 5 | [`FaultVector::eccentricity`] | static eccentricity amplitude | Z = [`ECCENTRICITY_Z_MAX`] · k6 |
//! | 6 | [`FaultVector::eccentricity_phase`] | eccentricity phase | φ = −π + 2π·k7 (circular) |
//! | 7 | [`FaultVector::gain_drift`] | proportional-gain drift | K_p × (0.5 + k8) |
//! | 8 | [`FaultVector::demagnetization`] | irreversible loss of the magnets' flux | flux × (1 − [`DEMAGNETIZATION_LOSS_MAX`]·k9) |

use crate::base::math::{abs, TAU};

/// The gear's play at full backlash fault (k2 = 1), in multiples of the nominal play.
pub const BACKLASH_SCALE_MAX: f32 = 100.0;

/// Number of components of the fault vector.
pub const FAULT_COUNT: usize = 9;

/// The paper's components (k1 … k8): its tables and its `e_tot` (eq. 4) are over these.
pub const PAPER_FAULT_COUNT: usize = 8;

/// Index of k9, demagnetization, in the vector (after the paper's eight).
pub const DEMAGNETIZATION_INDEX: usize = PAPER_FAULT_COUNT;

/// Index of k6, the static eccentricity's amplitude, in the vector.
pub const ECCENTRICITY_INDEX: usize = 5;

/// Index of k7, the eccentricity's phase (the one circular component), in the vector.
pub const ECCENTRICITY_PHASE_INDEX: usize = 6;

/// Index of k8, the controller's gain drift (its position gain's), in the vector.
pub const GAIN_DRIFT_INDEX: usize = 7;

/// Share of the magnets' flux lost at full demagnetization (k9 = 1): half the flux, past
/// which the actuator has lost its torque margin long before.
pub const DEMAGNETIZATION_LOSS_MAX: f32 = 0.5;

/// A complete short circuit (N = 0) has no torque at all in its sectors; the models floor the
/// healthy fraction of turns here so that every `k` simulates without blow-up.
pub const MIN_HEALTHY_TURNS: f32 = 0.02;

/// Normalised eccentricity amplitude at k6 = 1. Eq. (2) of the paper reaches
/// `1 − Z·√2` at worst; with `Z ≤ 0.5` the back-EMF constant stays above 29 % of nominal and
/// never changes sign, which a real air gap cannot make it do.
pub const ECCENTRICITY_Z_MAX: f32 = 0.5;

/// Short names of the components, in order (for reports and CSV headers).
pub const FAULT_NAMES: [&str; FAULT_COUNT] = [
    "friction",
    "backlash",
    "short_a",
    "short_b",
    "short_c",
    "eccentricity",
    "ecc_phase",
    "gain_drift",
    "demagnetization",
];

/// Which component of the vector is circular (the eccentricity phase wraps at 0 ≡ 1).
pub const CIRCULAR: [bool; FAULT_COUNT] =
    [false, false, false, false, false, false, true, false, false];
const _: () = assert!(CIRCULAR[ECCENTRICITY_PHASE_INDEX]);

/// Why a fault vector was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FaultVectorError {
    /// Component `index` is NaN or infinite.
    NotFinite { index: u8 },
    /// Component `index` lies outside `[0, 1]`.
    OutOfRange { index: u8 },
}

/// The actuator health: nine normalised fault magnitudes, each in `[0, 1]`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FaultVector([f32; FAULT_COUNT]);

impl FaultVector {
    /// The healthy actuator (eccentricity phase 0.5 by convention, gain drift 0.5 = no drift).
    pub const NOMINAL: Self = Self([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0]);

    /// Every component 0, every byte zero: a buffer's idle state (a gain drift of 0 is not
    /// the healthy actuator's, see [`Self::NOMINAL`]).
    pub(crate) const ZEROED: Self = Self([0.0; FAULT_COUNT]);

    /// The paper's eight components with no demagnetization (a record of the
    /// eight-component versions). Checked as [`new`](Self::new).
    pub fn from_paper(k: [f32; PAPER_FAULT_COUNT]) -> Result<Self, FaultVectorError> {
        let mut all = Self::NOMINAL.0;
        for (a, v) in all.iter_mut().zip(k) {
            *a = v;
        }
        Self::new(all)
    }

    /// Checks every component is finite and in `[0, 1]`.
    pub fn new(k: [f32; FAULT_COUNT]) -> Result<Self, FaultVectorError> {
        for (index, &v) in k.iter().enumerate() {
            let index = index as u8;
            if !v.is_finite() {
                return Err(FaultVectorError::NotFinite { index });
            }
            if !(0.0..=1.0).contains(&v) {
                return Err(FaultVectorError::OutOfRange { index });
            }
        }
        Ok(Self(k))
    }

    /// Forces any input into the domain: NaN becomes the nominal value of that component,
    /// everything else is clamped to `[0, 1]`. Never fails; used on the optimiser's path.
    pub fn saturating(k: [f32; FAULT_COUNT]) -> Self {
        let mut out = Self::NOMINAL.0;
        for (o, v) in out.iter_mut().zip(k) {
            if !v.is_nan() {
                *o = v.clamp(0.0, 1.0);
            }
        }
        Self(out)
    }

    /// The raw components, in the order of [`FAULT_NAMES`].
    pub const fn as_array(&self) -> &[f32; FAULT_COUNT] {
        &self.0
    }

    /// k1: normalised dry friction.
    pub fn friction(&self) -> f32 {
        self.0[0]
    }
    /// k2: normalised backlash.
    pub fn backlash(&self) -> f32 {
        self.0[1]
    }
    /// k3, k4, k5: normalised partial short circuit of phases A, B, C.
    pub fn short_circuit(&self) -> [f32; 3] {
        [self.0[2], self.0[3], self.0[4]]
    }
    /// k6: normalised eccentricity amplitude.
    pub fn eccentricity(&self) -> f32 {
        self.0[ECCENTRICITY_INDEX]
    }
    /// k7: normalised eccentricity phase (circular).
    pub fn eccentricity_phase(&self) -> f32 {
        self.0[ECCENTRICITY_PHASE_INDEX]
    }
    /// k8: normalised proportional-gain drift (0.5 = none).
    pub fn gain_drift(&self) -> f32 {
        self.0[7]
    }
    /// k9: normalised demagnetization (share of the magnets' flux lost irreversibly).
    pub fn demagnetization(&self) -> f32 {
        self.0[DEMAGNETIZATION_INDEX]
    }

    /// The physical effect of each fault: the single mapping used by every model.
    pub fn effects(&self) -> FaultEffects {
        let [sa, sb, sc] = self.short_circuit();
        let turns = |k: f32| (1.0 - k).max(MIN_HEALTHY_TURNS);
        FaultEffects {
            friction_scale: 1.0 + 2.0 * self.friction(),
            backlash_scale: 1.0 + (BACKLASH_SCALE_MAX - 1.0) * self.backlash(),
            healthy_turns: [turns(sa), turns(sb), turns(sc)],
            eccentricity_z: ECCENTRICITY_Z_MAX * self.eccentricity(),
            eccentricity_phase: -core::f32::consts::PI + TAU * self.eccentricity_phase(),
            kp_scale: 0.5 + self.gain_drift(),
            flux_scale: 1.0 - DEMAGNETIZATION_LOSS_MAX * self.demagnetization(),
        }
    }
}

/// Deviation from the nominal value above which a component is read as a fault (5 % of the
/// normalised range). The eccentricity phase k7 is a location, not a fault: it has no verdict.
pub const DETECTION_THRESHOLD: f32 = 0.05;

/// The reading of one component of an identified fault vector.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Verdict {
    /// Within [`DETECTION_THRESHOLD`] of nominal.
    Healthy,
    /// Beyond [`DETECTION_THRESHOLD`] from nominal.
    Faulty,
    /// Not a fault on its own (the eccentricity phase).
    NotApplicable,
}

impl FaultVector {
    /// |k_i − nominal_i| of each fault component; `None` for the eccentricity phase, which
    /// is a location, not a fault.
    pub fn deviations(&self) -> [Option<f32>; FAULT_COUNT] {
        let mut out = [None; FAULT_COUNT];
        for ((d, &k), (&nominal, &circular)) in out
            .iter_mut()
            .zip(self.0.iter())
            .zip(Self::NOMINAL.0.iter().zip(CIRCULAR.iter()))
        {
            *d = (!circular).then(|| abs(k - nominal));
        }
        out
    }

    /// The largest deviation from nominal over the fault components.
    pub fn largest_deviation(&self) -> f32 {
        self.deviations()
            .iter()
            .flatten()
            .fold(0.0, |m, &d| m.max(d))
    }

    /// Per-component verdicts against [`DETECTION_THRESHOLD`].
    pub fn verdicts(&self) -> [Verdict; FAULT_COUNT] {
        self.verdicts_at(DETECTION_THRESHOLD)
    }

    /// Per-component verdicts against `threshold` (an actuator record's).
    pub fn verdicts_at(&self, threshold: f32) -> [Verdict; FAULT_COUNT] {
        self.deviations().map(|d| match d {
            None => Verdict::NotApplicable,
            Some(d) if d > threshold => Verdict::Faulty,
            Some(_) => Verdict::Healthy,
        })
    }
}

impl Default for FaultVector {
    fn default() -> Self {
        Self::NOMINAL
    }
}

/// Physical meaning of a fault vector (dimensionless multipliers unless stated).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FaultEffects {
    /// Multiplier of the static and dynamic friction torques (1 … 3).
    pub friction_scale: f32,
    /// Multiplier of the nominal backlash (1 … 100).
    pub backlash_scale: f32,
    /// Healthy fraction of turns N_a, N_b, N_c ([`MIN_HEALTHY_TURNS`] … 1).
    pub healthy_turns: [f32; 3],
    /// Normalised eccentricity amplitude Z (0 … [`ECCENTRICITY_Z_MAX`]).
    pub eccentricity_z: f32,
    /// Eccentricity phase φ \[rad\] (−π … π): angle from phase A to the minimum air gap.
    pub eccentricity_phase: f32,
    /// Multiplier of the position-loop proportional gain (0.5 … 1.5).
    pub kp_scale: f32,
    /// Multiplier of the magnets' flux left after irreversible loss (0.5 … 1); the day's
    /// reversible change with temperature is apart from it.
    pub flux_scale: f32,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn new_rejects_out_of_range_and_non_finite() {
        let mut k = FaultVector::NOMINAL.0;
        assert!(FaultVector::new(k).is_ok());
        k[3] = 1.01;
        assert_eq!(
            FaultVector::new(k),
            Err(FaultVectorError::OutOfRange { index: 3 })
        );
        k[3] = f32::NAN;
        assert_eq!(
            FaultVector::new(k),
            Err(FaultVectorError::NotFinite { index: 3 })
        );
        k[3] = -0.0;
        assert!(FaultVector::new(k).is_ok());
    }

    #[test]
    fn saturating_clamps_and_replaces_nan() {
        let k =
            FaultVector::saturating([2.0, -1.0, f32::NAN, 0.3, 0.0, 0.0, f32::NAN, 7.0, f32::NAN]);
        assert_eq!(k.as_array(), &[1.0, 0.0, 0.0, 0.3, 0.0, 0.0, 0.5, 1.0, 0.0]);
    }

    #[test]
    fn mapping_endpoints_match_spec() {
        let healthy = FaultVector::NOMINAL.effects();
        assert_eq!(healthy.friction_scale, 1.0);
        assert_eq!(healthy.backlash_scale, 1.0);
        assert_eq!(healthy.healthy_turns, [1.0; 3]);
        assert_eq!(healthy.eccentricity_z, 0.0);
        assert_eq!(healthy.eccentricity_phase, 0.0);
        assert_eq!(healthy.kp_scale, 1.0);
        assert_eq!(healthy.flux_scale, 1.0);

        let worst = FaultVector::new([1.0; FAULT_COUNT]).unwrap().effects();
        assert_eq!(worst.friction_scale, 3.0);
        assert_eq!(worst.backlash_scale, 100.0);
        assert_eq!(worst.healthy_turns, [MIN_HEALTHY_TURNS; 3]);
        assert_eq!(worst.eccentricity_z, ECCENTRICITY_Z_MAX);
        assert!((worst.eccentricity_phase - core::f32::consts::PI).abs() < 1e-6);
        assert_eq!(worst.kp_scale, 1.5);
        assert_eq!(worst.flux_scale, 0.5);

        let zero = FaultVector::new([0.0; FAULT_COUNT]).unwrap().effects();
        assert!((zero.eccentricity_phase + core::f32::consts::PI).abs() < 1e-6);
        assert_eq!(zero.kp_scale, 0.5);
    }

    #[test]
    fn accessors_follow_names() {
        let k = FaultVector::new([0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9]).unwrap();
        assert_eq!(k.friction(), 0.1);
        assert_eq!(k.backlash(), 0.2);
        assert_eq!(k.short_circuit(), [0.3, 0.4, 0.5]);
        assert_eq!(k.eccentricity(), 0.6);
        assert_eq!(k.eccentricity_phase(), 0.7);
        assert_eq!(k.gain_drift(), 0.8);
        assert_eq!(k.demagnetization(), 0.9);
        assert_eq!(FAULT_NAMES.len(), FAULT_COUNT);
    }

    #[test]
    fn verdicts_flag_components_beyond_the_threshold() {
        use Verdict::*;
        assert_eq!(
            FaultVector::NOMINAL.verdicts(),
            [
                Healthy,
                Healthy,
                Healthy,
                Healthy,
                Healthy,
                Healthy,
                NotApplicable,
                Healthy,
                Healthy
            ]
        );
        let k = FaultVector::new([0.06, 0.04, 0.0, 0.3, 0.0, 0.2, 0.0, 0.44, 0.06]).unwrap();
        assert_eq!(
            k.verdicts(),
            [
                Faulty,
                Healthy,
                Healthy,
                Faulty,
                Healthy,
                Faulty,
                NotApplicable,
                Faulty,
                Faulty
            ]
        );
    }

    #[test]
    fn an_eight_component_vector_reads_with_no_demagnetization() {
        let k = FaultVector::from_paper([0.1, 0.2, 0.0, 0.0, 0.3, 0.4, 0.7, 0.5]).unwrap();
        assert_eq!(k.as_array(), &[0.1, 0.2, 0.0, 0.0, 0.3, 0.4, 0.7, 0.5, 0.0]);
        assert_eq!(
            FaultVector::from_paper([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 1.5]),
            Err(FaultVectorError::OutOfRange { index: 7 })
        );
    }
}
