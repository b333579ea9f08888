//! Identification from a window of flight (issue 36): the monitor model driven by the
//! command the controller followed (the flight control computer's corrections with the test
//! superimposed, [`RecordedCommand`]), started in equilibrium under the hinge moment it
//! measured ([`MonitorModel::start_loaded_run`]), with the surface's load a spring of the
//! window's own stiffness ([`WindowLoad`]).
//!
//! The fitness is eq. (3)'s weighted sum over the window after [`SETTLE_SAMPLES`], with a slow
//! drift of the current profiled out: per candidate, the Legendre polynomial of degree
//! `DRIFT_TERMS − 1` over the window that best fits the residual (weighted least squares,
//! the weighted Gram matrix inverted once per window) is subtracted. The drift stands for
//! what the window's load does slowly that the model does not play — turbulence on the
//! incidence, a trim change — which the loop answers with current. Units: A²·s, rad, N·m.
//!
//! The load's stiffness, moment and trend are nuisances fitted per window
//! ([`WindowProblem::fit_load`]); the uncertainty's curvature profiles them out beside the
//! drift ([`WindowProblem::curvature`]); [`WindowProblem::judge`] gives the window's own
//! `Outside` reasons ([`WindowReason`]). The stator shorts, the eccentricity and the
//! demagnetization are held at the same flight's preflight reading when there is one
//! ([`HeldComponents`]): without a standstill segment a window cannot tell a short from an
//! eccentricity, and under its fitted load a demagnetization reads as friction. The held
//! values' error enters the window's deviations through the curvature's cross terms with
//! them ([`HeldCoupling`], the preflight's deviations taken [`HELD_ERROR_SCALE`] times).
//!
//! Work: one evaluation = one monitor-model run over the window (O(N), a few multiply-adds
//! more per sample: the drift's polynomials are expanded per block of [`DRIFT_BLOCK`]
//! samples) and O(`DRIFT_TERMS²`); [`WindowProblem::fit_load`] is at most
//! [`LOAD_SEARCH_EVALUATIONS`] evaluations; a curvature twelve lockstep runs and
//! O(N·(9 + 12)²) f32 multiply-adds summed in f64 per block; the whole identification
//! ([`identify`]: two load searches, two GA runs of at most [`WINDOW_GA_EVALUATIONS`], the
//! polish — Gauss–Newton steps that move the load's stiffness and moment with the faults —,
//! the uncertainty widened by [`WINDOW_INFLATION`], the verdict) at most
//! 2 × [`LOAD_SEARCH_EVALUATIONS`] + 2 × [`WINDOW_GA_EVALUATIONS`] + 7 curvatures + 10
//! evaluations, and [`identify_stepwise`] does it in polls of at most one evaluation or
//! [`CURVATURE_CHUNK`] curvature samples. No allocation, no panic. Run by the host on every
//! window; the controller's images have no flash left for it; on the Cortex-M4F one
//! identification is 2.9 × 10⁹ instructions in ≈ 1 500 polls (`cargo window-bench`,
//! docs/in-flight.md §6).

use crate::command::CommandSource;
use crate::conditioning::{LowPass, LowPassState, MeasuredCurrent};
use crate::fault::{FaultVector, DEMAGNETIZATION_INDEX, FAULT_COUNT};
use crate::ga::Problem;
use crate::math::{abs, invert};
use crate::monitor::{MonitorModel, MonitorRun, RunRigging};
use crate::steps::{pause, run_to_end};
use crate::uncertainty::{Curvature, STEP};

/// Samples at the window's start left out of the sum (20 ms): the model starts still, the
/// surface was moving with the flight's commands.
pub const SETTLE_SAMPLES: usize = 200;

/// Terms of the profiled drift (Legendre polynomials of degree 0 … 9).
pub const DRIFT_TERMS: usize = 10;

/// Fitness evaluations one [`WindowProblem::fit_load`] spends at most.
pub const LOAD_SEARCH_EVALUATIONS: usize = 3 * GOLDEN_STEPS + MOMENT_SCAN + 4 * TREND_ROUNDS + 1;

/// Rounds of the trend's fixed-point update in each pass of [`WindowProblem::fit_load`].
const TREND_ROUNDS: usize = 3;

const GOLDEN_STEPS: usize = 14;

/// The curvature's nuisances: the drift's terms and the load's stiffness and moment.
const NUISANCES: usize = DRIFT_TERMS + 2;

/// The curvature's runs: the base, one per fault component, one per load parameter.
const RUNS: usize = FAULT_COUNT + 3;

/// The load parameters' relative step in the curvature.
const LOAD_STEP: f32 = 0.01;

/// Moments tried by the load fit's scan before its golden-section search.
const MOMENT_SCAN: usize = 81;

/// How many times a window's standard deviation per component must be taken beyond what
/// its curvature states (after the preflight's [`crate::uncertainty::INFLATION`]), so that
/// its 90 % interval holds the truth in 90 % of identified windows: the turbulence the
/// drift does not absorb leaves a coloured residual that the curvature reads as
/// information. Chosen on the flight campaign's seeds 10–29 (every phase and turbulence,
/// the healthy actuator and friction 0.2, 162 identified windows), each component's 90th
/// percentile of |error| / σ over [`crate::uncertainty::Z90`], rounded up to a tenth:
/// friction 1.52 → 1.6, gain drift 1.40 → 1.4; the others' intervals already hold the
/// truth in 98–100 % of windows and are left as they are (docs/in-flight.md §4). Checked
/// again with the shorts held at the preflight's ([`HeldComponents`]; same seeds, eight
/// windows per flight, the 116 `within` first windows): friction ×0.97, gain drift ×1.08
/// (its interval held the truth in 100 of 116: holding the shorts took their share of its
/// deviation) → 1.4 × 1.08 = 1.51 → **1.6**. With the demagnetization held too (same seeds,
/// the 143 `within` first windows): friction ×1.09 (119 of 143: the torque constant no
/// longer shares its deviation) → 1.6 × 1.09 = 1.74 → **1.8**, gain drift ×0.90. With the
/// polish stepping the load with the faults (same seeds, the 121 `within` first windows):
/// friction ×0.96, gain drift ×0.86, the backlash ×0.72, the eccentricity ×0.71 — left as
/// they are. With the eccentricity held too (same seeds, the 124 `within` first windows):
/// friction ×0.96, gain drift ×0.97, the backlash ×0.62 — left. With Table I in cruise
/// added to the selection (seeds 10–29, eight windows per flight: 255 `within` first
/// windows; with the 124 above, 379): gain drift ×1.34 on Table I alone (its interval held
/// the truth in 200 of 255: with a short, a wide eccentricity or a halved gain the window
/// reads the gain 0.01–0.02 off, an error the curvature does not see), ×1.24 on the union →
/// 1.6 × 1.24 = 1.98 → **2.0**; friction ×0.97 on the union — left. Reported on seeds 0–9.
pub const WINDOW_INFLATION: [f32; FAULT_COUNT] = [1.8, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 2.0, 1.0];

/// How much of the preflight's stated standard deviation a held value's error is taken to
/// be, per component ([`HeldComponents::with_preflight_uncertainty`]): the preflight's
/// intervals are calibrated in bulk ([`crate::uncertainty::INFLATION`]) and are wide on the
/// components a window holds (its Table I intervals hold the truth in 98.7 % of
/// component-runs). Chosen on the preflight's own campaigns, Table I and II, 10 seeds each
/// (`host-sim campaign --table 1 --runs 10 --runs-csv F`, `--table 2`; 210 `within` runs):
/// per held component the 90th percentile of |error| / σ over
/// [`crate::uncertainty::Z90`], rounded up to a tenth — short A 0.37 → 0.4 (0.16 on Table
/// I alone, 1.24 on Table II), short B 0.59 → 0.6, short C 0.49 → 0.5, the eccentricity
/// 0.19 → 0.2, its phase 0.29 → 0.3 (the 70 runs with an eccentricity), the
/// demagnetization 0.09 → 0.1; the friction, held by a window read with its surface pinned
/// (`crate::pinned`, stop 57, the same rule on the same campaigns): 0.22 → 0.3. Components
/// a window never holds: 1 (unused). docs/in-flight.md §4.
pub const HELD_ERROR_SCALE: [f32; FAULT_COUNT] = [0.3, 1.0, 0.4, 0.6, 0.5, 0.2, 0.3, 1.0, 0.1];

/// How often the controller keeps the command it followed over a window: every
/// `COMMAND_STRIDE`-th sample (2.5 kHz at the reference's 10 kHz loop), linear in between
/// ([`RecordedCommand::kept_every`]): 5.5 kB for a window instead of 22 kB. The chirp's
/// 15 Hz at 5 mrad departs from its chords by at most `A·(2π·f·h)²/8` ≈ 0.9 µrad (0.02 % of
/// its amplitude); the flight control computer's corrections (≤ 2 Hz) by ≈ 10⁻⁸ rad.
pub const COMMAND_STRIDE: usize = 4;

/// The commanded user-shaft angle [rad] of each sample of a window, as the controller
/// followed it (a trace's `theta_cmd`), kept every `stride` samples and linear in between
/// (every sample when `stride` is 1). Past the last kept sample the last value holds. O(1).
#[derive(Clone, Copy, Debug)]
pub struct RecordedCommand<'a> {
    kept: &'a [f32],
    stride: usize,
    inv_stride: f32,
}

impl<'a> RecordedCommand<'a> {
    /// Every sample's command.
    pub fn new(samples: &'a [f32]) -> Self {
        Self::kept_every(1, samples)
    }

    /// The command kept every `stride` samples: `kept[j]` is sample `j·stride`'s (`stride`
    /// 0 is taken as 1).
    pub fn kept_every(stride: usize, kept: &'a [f32]) -> Self {
        let stride = stride.max(1);
        Self {
            kept,
            stride,
            inv_stride: 1.0 / stride as f32,
        }
    }

    /// The kept samples.
    pub fn kept(&self) -> &'a [f32] {
        self.kept
    }

    /// The samples the command spans: up to its last kept one.
    pub fn len(&self) -> usize {
        self.kept.len().saturating_sub(1) * self.stride + usize::from(!self.kept.is_empty())
    }

    pub fn is_empty(&self) -> bool {
        self.kept.is_empty()
    }
}

impl CommandSource for RecordedCommand<'_> {
    #[inline(always)]
    fn position_at(&self, index: usize) -> f32 {
        let j = index / self.stride;
        let within = index - j * self.stride;
        match (self.kept.get(j), self.kept.get(j + 1)) {
            (Some(&a), Some(&b)) if within > 0 => a + (b - a) * (within as f32 * self.inv_stride),
            (Some(&a), _) => a,
            _ => self.kept.last().copied().unwrap_or(0.0),
        }
    }
}

/// The surface's load over a window: a spring of `stiffness` [N·m/rad] around the window's
/// start, which carries `moment` [N·m] there, and a slow change of the hinge moment the
/// motor must hold beyond the spring's, `trend` [N·m] as Legendre coefficients over the
/// window (zero at its start).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct WindowLoad {
    pub stiffness: f32,
    pub moment: f32,
    pub trend: [f32; DRIFT_TERMS],
}

impl WindowLoad {
    /// A spring of `stiffness` carrying `moment`, no trend.
    pub fn spring(stiffness: f32, moment: f32) -> Self {
        Self {
            stiffness,
            moment,
            trend: [0.0; DRIFT_TERMS],
        }
    }

    /// The trend's moment [N·m] where the drift's polynomials are `now` (`legendre(x)` at a
    /// point `x` of the window's axis).
    #[inline(always)]
    fn trend_at(&self, now: &[f32; DRIFT_TERMS]) -> f32 {
        let start = legendre(-1.0);
        self.trend
            .iter()
            .zip(now.iter().zip(&start))
            .map(|(c, (a, b))| c * (a - b))
            .sum()
    }
}

/// Why a window is not identified: the window's own `Outside` reasons.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum WindowReason {
    /// The measured current reached the drive's limit [A]: the model's loop and the
    /// controller's part.
    CurrentSaturated { peak: f32 },
    /// The command moved over more than the limits' range [rad]: a manoeuvre, not a
    /// correction.
    ManoeuvreTooLarge { range: f32 },
    /// The fit left this share of the measured current unexplained (0 … 1).
    FitnessFloor { misfit: f32 },
    /// A wide play changes the fit by only this share of the fit's error: the load never
    /// reversed, the gear's play was never crossed, the backlash cannot be read.
    PlayUnseen { contrast: f32 },
    /// The window reads friction only to this standard deviation (calibrated, with the
    /// load and the drift profiled out; NaN: not at all): the load's moment the turbulence
    /// moves stands in for friction, and what it does to the other components with it.
    TurbulenceTooHigh { friction_std: f32 },
    /// A flight's reading from its windows (`crate::fusion`) that no second window
    /// confirms: fewer than two windows fused (`disagreement` NaN), or their readings farther
    /// apart than their deviations allow — `disagreement` is their χ² over its 99 % quantile,
    /// or the friction of the window that reads it closest against the others' over χ²₁'s
    /// (the larger; above 1: one of them is wrong).
    Unconfirmed { windows: u32, disagreement: f32 },
}

/// What a window must satisfy to be identified.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct WindowLimits {
    /// Share of the drive's current limit the measured current may reach.
    pub saturation_share: f32,
    /// The command's largest range over a window [rad].
    pub max_command_range: f32,
    /// The largest [`WindowProblem::misfit`] of an identified window.
    pub max_misfit: f32,
    /// The smallest change of the fit, over its error, between no backlash and a wide one
    /// ([`PLAY_PROBE`]) at the found vector.
    pub min_play_contrast: f32,
    /// The largest friction standard deviation of an identified window (after
    /// [`WINDOW_INFLATION`]) [fault-vector units].
    pub max_friction_std: f32,
}

/// The backlash component of the wide play [`WindowProblem::judge`] tries.
pub const PLAY_PROBE: f32 = 0.5;

impl WindowLimits {
    /// The limits of the built-in actuator's study (docs/in-flight.md §5).
    pub const REFERENCE: Self = Self {
        saturation_share: 0.95,
        max_command_range: 0.05,
        max_misfit: 0.01,
        min_play_contrast: 1.0,
        max_friction_std: 0.08,
    };
}

/// Why a window problem could not be set up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum WindowError {
    /// Fewer samples (measured or commanded) than the settle and the drift's terms need.
    TooShort,
    /// The measured current is flat: no weight can be formed.
    Flat,
    /// The drift's normal equations are singular (cannot happen for a window longer than
    /// the settle by `DRIFT_TERMS` samples).
    Singular,
}

/// Components a window does not identify but holds at values from outside it: the stator
/// shorts, the eccentricity (amplitude and phase) and the demagnetization at the same
/// flight's preflight reading ([`HeldComponents::of_preflight`]). A window has no standstill
/// segment, and without it a short's phase asymmetry and the rotor's eccentricity trade
/// against each other (a short A of 0.2 read as an eccentricity of 0.4 in cruise). Holding
/// the shorts alone left the eccentricity free to take what the monitor model's short does
/// not play of a real half-shorted phase: beside a held short A of 0.5 one window read an
/// eccentricity of 0.29 `within` at 10.6 % e_tot, and flights of eight read 0.06–0.10
/// (one false `FAULT`) — so the eccentricity is held with them. Its hinge load is unknown
/// (fitted), and a weaker torque constant then reads as friction (a demagnetization of 0.2
/// read 0.05 beside a friction of 0.17 in approach, docs/in-flight.md §4). The preflight,
/// on its known spring, with its pair circuits, tells them apart, and none of them changes
/// within a flight. The GA's genes for held components are ignored and the polish does not
/// move them (their deviations read "not determined"). A held value is the preflight's
/// reading, not the truth: its error, the same in every window of the flight, moves the
/// free components the window fits beside it (a short A of 0.5 whose preflight read the
/// eccentricity 0.09 high read a healthy friction 0.12 in moderate cruise). With the
/// preflight's covariance ([`HeldComponents::with_preflight_uncertainty`]) the window's
/// intervals carry that error ([`HeldComponents::shared_std`]).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HeldComponents {
    held: [bool; FAULT_COUNT],
    values: [f32; FAULT_COUNT],
    /// The held values' covariance (the preflight's, between held components; zero when
    /// not given) [fault-vector units²].
    covariance: [[f32; FAULT_COUNT]; FAULT_COUNT],
}

/// How a window's free components lean on its held ones: the window curvature's normal
/// matrix (nuisances profiled out) between a free component's row and a held component's
/// column, zero elsewhere [A² per unit²] ([`WindowProblem::curvature_with_coupling`],
/// [`WindowReading::coupling`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeldCoupling {
    pub normal: [[f64; FAULT_COUNT]; FAULT_COUNT],
}

impl HeldCoupling {
    /// No held component.
    pub const NONE: Self = Self {
        normal: [[0.0; FAULT_COUNT]; FAULT_COUNT],
    };
}

impl HeldComponents {
    /// Nothing held: every component identified from the window.
    pub const NONE: Self = Self {
        held: [false; FAULT_COUNT],
        values: [0.0; FAULT_COUNT],
        covariance: [[0.0; FAULT_COUNT]; FAULT_COUNT],
    };

    /// The three stator shorts (k3, k4, k5), the eccentricity and its phase (k6, k7) and the
    /// demagnetization (k9) held at `preflight`'s.
    pub fn of_preflight(preflight: &FaultVector) -> Self {
        let held: [bool; FAULT_COUNT] = core::array::from_fn(|i| {
            SHORTS.contains(&i) || ECCENTRICITY.contains(&i) || i == DEMAGNETIZATION_INDEX
        });
        Self {
            held,
            values: *preflight.as_array(),
            covariance: [[0.0; FAULT_COUNT]; FAULT_COUNT],
        }
    }

    /// These held values with the preflight's standard deviations `std` and correlations
    /// `correlation` (its calibrated uncertainty): its covariance, each deviation taken
    /// [`HELD_ERROR_SCALE`] times; a deviation the preflight did not determine (NaN) counts
    /// as none. Kept for every component, held or not: a window reads only the held ones'
    /// part (its coupling has no other column), and a component held later
    /// ([`HeldComponents::also_holding`]: the friction of a pinned window) brings its
    /// error with it. O(9²).
    #[must_use]
    pub fn with_preflight_uncertainty(
        mut self,
        std: &[f32; FAULT_COUNT],
        correlation: &[[f32; FAULT_COUNT]; FAULT_COUNT],
    ) -> Self {
        let s = |i: usize| match std.get(i) {
            Some(&x) if x.is_finite() => x * HELD_ERROR_SCALE.get(i).copied().unwrap_or(1.0),
            _ => 0.0,
        };
        for (i, row) in self.covariance.iter_mut().enumerate() {
            for (j, c) in row.iter_mut().enumerate() {
                let r = if i == j {
                    1.0
                } else {
                    correlation
                        .get(i)
                        .and_then(|r| r.get(j))
                        .copied()
                        .filter(|r| r.is_finite())
                        .unwrap_or(0.0)
                };
                *c = s(i) * s(j) * r;
            }
        }
        self
    }

    /// The held values' covariance [fault-vector units²] (zero where not given).
    pub fn covariance(&self) -> &[[f32; FAULT_COUNT]; FAULT_COUNT] {
        &self.covariance
    }

    /// How far each free component's reading moves per unit of each held component's
    /// error, `A = N_ff⁻¹ · N_fh` from a window's `curvature` (held rows and columns zero)
    /// and its `coupling`: row a free component, column a held one. `None` when the
    /// curvature determines no component. O(9³).
    #[allow(clippy::indexing_slicing, clippy::needless_range_loop)] // i, j < FAULT_COUNT on fixed 9×9 arrays
    pub fn sensitivity(
        curvature: &Curvature,
        coupling: &HeldCoupling,
    ) -> Option<[[f64; FAULT_COUNT]; FAULT_COUNT]> {
        let (inverse, determined) = curvature.inverse(0.0)?;
        let mut a = [[0.0f64; FAULT_COUNT]; FAULT_COUNT];
        for i in (0..FAULT_COUNT).filter(|&i| determined[i]) {
            for h in 0..FAULT_COUNT {
                a[i][h] = (0..FAULT_COUNT)
                    .filter(|&j| determined[j])
                    .map(|j| inverse[i][j] * coupling.normal[j][h])
                    .sum();
            }
        }
        Some(a)
    }

    /// The standard deviation each free component takes from the held values' error
    /// through `sensitivity` ([`HeldComponents::sensitivity`]): `√diag(A·Σ·Aᵀ)`, Σ the held
    /// covariance [fault-vector units]. Shared by every window of a flight (the same held
    /// values), so a flight's windows do not average it away. O(9³).
    pub fn shared_std(
        &self,
        sensitivity: &[[f64; FAULT_COUNT]; FAULT_COUNT],
    ) -> [f32; FAULT_COUNT] {
        propagated_std(sensitivity, &self.covariance)
    }

    /// What a window holds given its flight's preflight reading `preflight`: the shorts and
    /// the demagnetization when that preflight was `within` (`trusted`), else nothing.
    pub fn from_preflight(preflight: &FaultVector, trusted: bool) -> Self {
        if trusted {
            Self::of_preflight(preflight)
        } else {
            Self::NONE
        }
    }

    /// These held components with component `i` held too, at the preflight's value these
    /// hold (`crate::pinned`: the friction of a window read with its surface pinned).
    #[must_use]
    pub fn also_holding(mut self, i: usize) -> Self {
        if let Some(h) = self.held.get_mut(i) {
            *h = true;
        }
        self
    }

    /// These held values with component `i`'s moved by `by` (the pinned window's
    /// differences in a held value, `crate::pinned`); the box is the vector's
    /// ([`HeldComponents::apply`] saturates).
    #[must_use]
    pub fn shifted(mut self, i: usize, by: f32) -> Self {
        if let Some(v) = self.values.get_mut(i) {
            *v += by;
        }
        self
    }

    /// Component `i`'s held value (NaN beyond the vector).
    pub fn value(&self, i: usize) -> f32 {
        self.values.get(i).copied().unwrap_or(f32::NAN)
    }

    /// Whether component `i` is held.
    pub fn holds(&self, i: usize) -> bool {
        self.held.get(i).copied().unwrap_or(false)
    }

    /// `k` with the held components at their values. O(`FAULT_COUNT`).
    pub fn apply(&self, k: &FaultVector) -> FaultVector {
        let mut genes = *k.as_array();
        for ((g, &h), &v) in genes.iter_mut().zip(&self.held).zip(&self.values) {
            if h {
                *g = v;
            }
        }
        FaultVector::saturating(genes)
    }
}

/// `√diag(A·Σ·Aᵀ)`: the standard deviation per component that an error of covariance
/// `covariance` in the held components moves through `sensitivity` (`A`, row a free
/// component, column a held one) [fault-vector units]. O(9³).
#[allow(clippy::indexing_slicing)] // i, h, g < FAULT_COUNT on fixed 9×9 arrays
pub fn propagated_std(
    sensitivity: &[[f64; FAULT_COUNT]; FAULT_COUNT],
    covariance: &[[f32; FAULT_COUNT]; FAULT_COUNT],
) -> [f32; FAULT_COUNT] {
    core::array::from_fn(|i| {
        let mut v = 0.0f64;
        for h in 0..FAULT_COUNT {
            for g in 0..FAULT_COUNT {
                v += sensitivity[i][h] * f64::from(covariance[h][g]) * sensitivity[i][g];
            }
        }
        crate::math::sqrt64(v.max(0.0)) as f32
    })
}

/// Indices of the stator shorts A, B, C in a fault vector.
const SHORTS: [usize; 3] = [2, 3, 4];

/// Indices of the eccentricity's amplitude and phase in a fault vector.
const ECCENTRICITY: [usize; 2] = [
    crate::fault::ECCENTRICITY_INDEX,
    crate::fault::ECCENTRICITY_PHASE_INDEX,
];

/// Eq. (3) over one window with the drift profiled out: what the GA minimises in flight.
#[derive(Clone, Debug)]
pub struct WindowProblem<'a, const N: usize> {
    measured: &'a MeasuredCurrent<N>,
    command: RecordedCommand<'a>,
    /// The monitor model on the window's day, without the window's load stiffness.
    model: MonitorModel,
    load: WindowLoad,
    inv_kappa: f32,
    /// Inverse of the weighted Gram matrix of the drift's polynomials.
    drift_inverse: [[f32; DRIFT_TERMS]; DRIFT_TERMS],
    /// The weighted Gram matrix itself (the curvature's nuisance block).
    gram: [[f64; DRIFT_TERMS]; DRIFT_TERMS],
    samples: usize,
    /// The error of a model that gives no current [A²·s]: the scale of [`Self::misfit`].
    energy: f32,
    /// Largest filtered measured current's size [A].
    peak_current: f32,
    /// The command's range over the window [rad].
    command_range: f32,
    /// Components held at values from outside the window.
    held: HeldComponents,
}

/// Bonnet's recurrence `(n + 1)·P(n+1) = (2n + 1)·x·P(n) − n·P(n−1)` as the two factors of
/// each step from `P(n−1)`, `P(n)` to `P(n+1)`, n = 1 … `DRIFT_TERMS − 2`: `(2n + 1)/(n + 1)`
/// and `n/(n + 1)`, rounded once here rather than divided at every sample.
#[allow(clippy::indexing_slicing)] // n − 1 < DRIFT_TERMS − 2, evaluated at compile time
const BONNET: [(f32, f32); DRIFT_TERMS - 2] = {
    let mut t = [(0.0f32, 0.0f32); DRIFT_TERMS - 2];
    let mut n = 1;
    while n <= DRIFT_TERMS - 2 {
        let (a, b) = (
            (2 * n + 1) as f64 / (n + 1) as f64,
            n as f64 / (n + 1) as f64,
        );
        t[n - 1] = (a as f32, b as f32);
        n += 1;
    }
    t
};

/// The first [`DRIFT_TERMS`] Legendre polynomials at `x` ∈ [−1, 1] (Bonnet's recurrence,
/// [`BONNET`]): three multiplies per term, no division; indexed, so that the size-optimised
/// build keeps it a plain loop. Per window, per block of samples and per curvature sample.
#[inline(always)]
#[allow(clippy::indexing_slicing)] // n < DRIFT_TERMS on fixed arrays
fn legendre(x: f32) -> [f32; DRIFT_TERMS] {
    let mut p = [0.0f32; DRIFT_TERMS];
    p[0] = 1.0;
    p[1] = x;
    let mut n = 2;
    while n < DRIFT_TERMS {
        let (a, b) = BONNET[n - 2];
        p[n] = a * x * p[n - 1] - b * p[n - 2];
        n += 1;
    }
    p
}

/// Where sample `i` of a window of `n` sits on the drift's axis [−1, 1].
#[inline(always)]
fn axis(i: usize, n: usize) -> f32 {
    let span = n.saturating_sub(SETTLE_SAMPLES + 1).max(1) as f32;
    2.0 * (i.saturating_sub(SETTLE_SAMPLES)) as f32 / span - 1.0
}

/// The distance between two samples on the drift's axis (see [`axis`]).
#[inline(always)]
fn axis_step(n: usize) -> f32 {
    2.0 / n.saturating_sub(SETTLE_SAMPLES + 1).max(1) as f32
}

/// Fitted samples per block of the drift's expansion ([`TaylorBlock`]).
pub const DRIFT_BLOCK: usize = 16;

/// `Σ a·b` over the drift's terms.
#[inline(always)]
fn dot(a: &[f32; DRIFT_TERMS], b: &[f32; DRIFT_TERMS]) -> f32 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// The drift's polynomials, their first and second derivatives at a block's centre: over
/// the block, `P(x_c + u) ≈ P + u·P′ + ½u²·P″`. O(`DRIFT_TERMS`).
#[derive(Clone, Copy, Debug, PartialEq)]
struct TaylorBlock {
    value: [f32; DRIFT_TERMS],
    slope: [f32; DRIFT_TERMS],
    bend: [f32; DRIFT_TERMS],
}

impl TaylorBlock {
    const ZERO: Self = Self {
        value: [0.0; DRIFT_TERMS],
        slope: [0.0; DRIFT_TERMS],
        bend: [0.0; DRIFT_TERMS],
    };

    /// At `x`: Bonnet's recurrence for the values, `P′(n+1) = P′(n−1) + (2n+1)·P(n)` and
    /// the same for `P″` from `P′`.
    #[allow(clippy::indexing_slicing)] // n < DRIFT_TERMS on fixed arrays
    fn at(x: f32) -> Self {
        let mut b = Self::ZERO;
        b.value = legendre(x);
        b.slope[1] = 1.0;
        let mut n = 1;
        while n + 1 < DRIFT_TERMS {
            let f = (2 * n + 1) as f32;
            b.slope[n + 1] = b.slope[n - 1] + f * b.value[n];
            b.bend[n + 1] = b.bend[n - 1] + f * b.slope[n];
            n += 1;
        }
        b
    }

    /// Adds a block's sums `(Σ w·e, Σ w·e·u, Σ w·e·u²)` to the projections `Σ w·e·P`.
    fn add_to(&self, projections: &mut [f32; DRIFT_TERMS], sums: (f32, f32, f32)) {
        for (((p, v), s), c) in projections
            .iter_mut()
            .zip(&self.value)
            .zip(&self.slope)
            .zip(&self.bend)
        {
            *p += v * sums.0 + s * sums.1 + 0.5 * c * sums.2;
        }
    }
}

/// The modelled current of a window's samples, in order: `next(i, h)` steps the model to
/// sample `i` with `h` [N·m] pushed on the surface and gives its filtered current [A]. O(1),
/// inlined into [`WindowProblem::residual_fit`]'s loops.
trait SampleCurrent {
    fn next(&mut self, i: usize, h: f32) -> f32;
}

/// No model: the measured current's own energy.
struct NoCurrent;

impl SampleCurrent for NoCurrent {
    #[inline(always)]
    fn next(&mut self, _: usize, _: f32) -> f32 {
        0.0
    }
}

/// A monitor-model run under a window's load, driven by the recorded command and seen
/// through the measurement's filter.
struct LoadedRunCurrent<'a, 'c> {
    model: &'a MonitorModel,
    run: &'a mut MonitorRun,
    command: &'a RecordedCommand<'c>,
    filter: &'a LowPass,
    state: LowPassState,
    /// The load's trend is not zero: its moment is pushed on the surface each step.
    trending: bool,
    /// No standstill segment: the model steps inline.
    motion_only: bool,
}

impl SampleCurrent for LoadedRunCurrent<'_, '_> {
    #[inline(always)]
    fn next(&mut self, i: usize, h: f32) -> f32 {
        if self.trending {
            self.run.push_surface(self.model, -h);
        }
        let command = self.command.position_at(i);
        let sample = if self.motion_only {
            self.run.next_motion_sample(self.model, command)
        } else {
            self.run.next_sample(self.model, command)
        };
        self.filter.apply(&mut self.state, sample.current)
    }
}

/// A run's current pushed by a moment per sample from outside the problem
/// ([`WindowProblem::evaluate_with_moment_samples`]) instead of the load's trend.
struct MomentSamples<'m, C: SampleCurrent> {
    current: C,
    moments: &'m [f32],
}

impl<C: SampleCurrent> SampleCurrent for MomentSamples<'_, C> {
    #[inline(always)]
    fn next(&mut self, i: usize, _trend: f32) -> f32 {
        let h = self.moments.get(i).copied().unwrap_or(0.0);
        self.current.next(i, h)
    }
}

/// A run whose surface follows its sensor ([`WindowProblem::evaluate_with_surface_samples`]),
/// summing the squared difference of its motor angle from the measured.
struct PinnedSurface<'m, 'a, 'c> {
    current: LoadedRunCurrent<'a, 'c>,
    surface: &'m SurfaceSamples<'m>,
    motor_error: f64,
    motor_sum: f64,
    counted: u32,
    trajectory: &'m mut [f32],
}

/// What the sensors read of a window's shafts, per sample: the surface's angle [rad] and
/// speed [rad/s], the motor's unwrapped angle [rad].
#[derive(Clone, Copy, Debug)]
pub struct SurfaceSamples<'m> {
    pub angles: &'m [f32],
    pub speeds: &'m [f32],
    pub motor: &'m [f32],
}

impl SampleCurrent for PinnedSurface<'_, '_, '_> {
    #[inline(always)]
    fn next(&mut self, i: usize, _trend: f32) -> f32 {
        let c = &mut self.current;
        if let (Some(&angle), Some(&speed)) =
            (self.surface.angles.get(i), self.surface.speeds.get(i))
        {
            c.run.pin_surface(angle, speed);
        }
        let command = c.command.position_at(i);
        let sample = if c.motion_only {
            c.run.next_motion_sample(c.model, command)
        } else {
            c.run.next_sample(c.model, command)
        };
        let moving = i >= c.model.lead_samples();
        if let (Some(&motor), true) = (self.surface.motor.get(i), moving) {
            let e = f64::from(sample.motor_angle - motor);
            self.motor_error += e * e;
            self.motor_sum += e;
            self.counted += 1;
        }
        if let Some(t) = self.trajectory.get_mut(i) {
            *t = sample.motor_angle;
        }
        c.filter.apply(&mut c.state, sample.current)
    }
}

/// The eq. (3) weight of each fitted sample: `1 / ((ΔI_r)²/κ + 1)`.
#[inline(always)]
fn weight(delta: f32, inv_kappa: f32) -> f32 {
    1.0 / (delta * delta * inv_kappa + 1.0)
}

/// What one evaluation found: the error and the profiled drift's coefficients [A].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WindowFit {
    /// Eq. (3) after the drift [A²·s].
    pub error: f32,
    /// The drift's Legendre coefficients [A].
    pub drift: [f32; DRIFT_TERMS],
}

impl<'a, const N: usize> WindowProblem<'a, N> {
    /// The window problem of `measured` (a finished buffer of the window's frames) driven by
    /// `command` (one commanded angle per frame), with `model` on the window's day (the
    /// chirp-only test's) and the load at `load`.
    pub fn new(
        measured: &'a MeasuredCurrent<N>,
        command: RecordedCommand<'a>,
        model: MonitorModel,
        load: WindowLoad,
    ) -> Result<Self, WindowError> {
        let reference = measured.samples();
        let samples = reference.len().min(command.len());
        if samples < SETTLE_SAMPLES + 10 * DRIFT_TERMS {
            return Err(WindowError::TooShort);
        }
        let inv_kappa = measured.inv_kappa().map_err(|_| WindowError::Flat)?;
        let mut gram = [[0.0f64; DRIFT_TERMS]; DRIFT_TERMS];
        let mut previous = 0.0f32;
        for (i, &r) in reference.iter().take(samples).enumerate() {
            let d = r - previous;
            previous = r;
            if i < SETTLE_SAMPLES {
                continue;
            }
            let w = f64::from(weight(d, inv_kappa));
            let phi = legendre(axis(i, samples));
            for (row, &a) in gram.iter_mut().zip(&phi) {
                for (x, &b) in row.iter_mut().zip(&phi) {
                    *x += w * f64::from(a) * f64::from(b);
                }
            }
        }
        let drift_inverse = invert(&gram)
            .ok_or(WindowError::Singular)?
            .map(|row| row.map(|x| x as f32));
        // The kept samples within the window (the line between two never leaves them).
        let (lo, hi) = command
            .kept()
            .iter()
            .take((samples - 1) / command.stride + 1)
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &x| {
                (lo.min(x), hi.max(x))
            });
        let mut problem = Self {
            measured,
            command,
            model,
            load,
            inv_kappa,
            drift_inverse,
            gram,
            samples,
            energy: 0.0,
            peak_current: reference
                .iter()
                .take(samples)
                .fold(0.0f32, |m, &x| m.max(abs(x))),
            command_range: hi - lo,
            held: HeldComponents::NONE,
        };
        problem.energy = problem
            .residual_fit(&[0.0; DRIFT_TERMS], &mut NoCurrent)
            .error;
        Ok(problem)
    }

    pub fn load(&self) -> WindowLoad {
        self.load
    }

    /// The window's samples (the measured and the commanded, the shorter).
    pub fn samples(&self) -> usize {
        self.samples
    }

    /// The samples eq. (3) sums over (the window's after [`SETTLE_SAMPLES`]).
    pub fn fitted_samples(&self) -> usize {
        self.samples.saturating_sub(SETTLE_SAMPLES)
    }

    /// The error of a model that gives no current [A²·s]: what
    /// [`misfit`](Self::misfit) divides by.
    pub fn energy(&self) -> f32 {
        self.energy
    }

    pub fn model(&self) -> &MonitorModel {
        &self.model
    }

    /// The same problem with `held` components held ([`HeldComponents`]).
    pub fn with_held(mut self, held: HeldComponents) -> Self {
        self.held = held;
        self
    }

    /// The components held at values from outside the window.
    pub fn held(&self) -> &HeldComponents {
        &self.held
    }

    /// The same problem under another load.
    pub fn with_load(mut self, load: WindowLoad) -> Self {
        self.load = load;
        self
    }

    /// Puts the problem under another load, in place.
    pub fn set_load(&mut self, load: WindowLoad) {
        self.load = load;
    }

    /// The moment [N·m] the measured current holds at the window's start, at the model's
    /// torque constant: the mean over the 10 ms after the settle, times the gear ratio. The
    /// load search's start.
    pub fn held_moment(&self) -> f32 {
        let span = self
            .measured
            .samples()
            .iter()
            .skip(SETTLE_SAMPLES / 2)
            .take(SETTLE_SAMPLES / 2);
        let (sum, n) = span.fold((0.0f32, 0u32), |(s, n), &x| (s + x, n + 1));
        let mean = if n > 0 { sum / n as f32 } else { 0.0 };
        mean * self.model.torque_constant() * self.model.params().gear_ratio
    }

    /// The error and drift of fault vector `k` under the problem's load. One model run.
    pub fn evaluate(&self, k: &FaultVector) -> WindowFit {
        self.evaluate_under(k, self.load)
    }

    /// As [`evaluate`](Self::evaluate) under `load`.
    pub fn evaluate_under(&self, k: &FaultVector, load: WindowLoad) -> WindowFit {
        let (model, mut run) = self.loaded_start(k, load);
        let trending = load.trend != [0.0; DRIFT_TERMS];
        let mut current = self.loaded_current(&model, &mut run, trending);
        self.residual_fit(&load.trend, &mut current)
    }

    /// As [`evaluate_under`](Self::evaluate_under) with the load's trend replaced by a
    /// moment per sample from outside the problem, `moments[i]` [N·m] the hinge moment the
    /// motor must hold at sample `i` beyond the spring's, relative to the window's start
    /// (0 past the slice's end). For studies of what the window's load must follow
    /// (host-sim's example `window_moment`, docs/in-flight.md §6); not flown. O(samples).
    pub fn evaluate_with_moment_samples(
        &self,
        k: &FaultVector,
        load: WindowLoad,
        moments: &[f32],
    ) -> WindowFit {
        let (model, mut run) = self.loaded_start(k, load);
        let current = self.loaded_current(&model, &mut run, true);
        self.residual_fit(&[0.0; DRIFT_TERMS], &mut MomentSamples { current, moments })
    }

    /// As [`evaluate_with_moment_samples`](Self::evaluate_with_moment_samples) with no
    /// moment at all: the surface is put, each sample, where its sensor read it, so the gear
    /// carries whatever moved it; `load` sets where the run starts in the play. Also returns
    /// the mean and the mean square of the run's motor angle against the measured [rad,
    /// rad²] over the samples stepped past the test's lead; the run's motor angle [rad]
    /// goes to `trajectory`, as far as it reaches. For studies (host-sim's example
    /// `window_pinned`, docs/in-flight.md §6); not flown. O(samples).
    pub fn evaluate_with_surface_samples(
        &self,
        k: &FaultVector,
        load: WindowLoad,
        surface: &SurfaceSamples<'_>,
        trajectory: &mut [f32],
    ) -> (WindowFit, f64, f64) {
        let (model, mut run) = self.loaded_start(k, load);
        let current = self.loaded_current(&model, &mut run, false);
        let mut pinned = PinnedSurface {
            current,
            surface,
            motor_error: 0.0,
            motor_sum: 0.0,
            counted: 0,
            trajectory,
        };
        let fit = self.residual_fit(&[0.0; DRIFT_TERMS], &mut pinned);
        let n = f64::from(pinned.counted.max(1));
        (fit, pinned.motor_sum / n, pinned.motor_error / n)
    }

    /// The model under `load`'s stiffness and its run started in equilibrium under its
    /// moment, at the held components' values of `k`.
    #[inline(always)]
    fn loaded_start(&self, k: &FaultVector, load: WindowLoad) -> (MonitorModel, MonitorRun) {
        let k = &self.held.apply(k);
        let model = self.model.with_load_stiffness(load.stiffness);
        let start = self.measured.initial_angles();
        let first = self.command.position_at(0);
        model.start_loaded_run(k, start, load.moment, first)
    }

    /// The run's current through the measurement's filter, pushing a moment each step
    /// when `trending`.
    #[inline(always)]
    fn loaded_current<'s>(
        &'s self,
        model: &'s MonitorModel,
        run: &'s mut MonitorRun,
        trending: bool,
    ) -> LoadedRunCurrent<'s, 'a> {
        LoadedRunCurrent {
            model,
            run,
            command: &self.command,
            filter: self.measured.filter(),
            state: LowPassState::default(),
            trending,
            // A window's test has no standstill segment: its model steps inline.
            motion_only: model.lead_samples() == 0,
        }
    }

    /// Eq. (3) of the modelled current `modelled.next(i, h)` (filtered; called once per
    /// sample, in order, with `h` the moment [N·m] of `trend` there, relative to the window's
    /// start) against the measured, after the settle, with the drift profiled out. The
    /// settle and the fitted samples are two loops, each with the model stepped inline
    /// ([`SampleCurrent`]).
    ///
    /// The drift's polynomials are not evaluated per sample: over each block of
    /// [`DRIFT_BLOCK`] fitted samples they are expanded to second order about the block's
    /// centre ([`TaylorBlock`]), so a sample adds three weighted powers of its distance from
    /// the centre and the trend's moment is three multiply-adds. The expansion's error is
    /// the third derivative's term: below 10⁻⁴ of the polynomials' range for degree 9.
    #[inline(always)]
    fn residual_fit(
        &self,
        trend: &[f32; DRIFT_TERMS],
        modelled: &mut impl SampleCurrent,
    ) -> WindowFit {
        let step = axis_step(self.samples);
        let at_start: f32 = dot(trend, &legendre(-1.0));
        let mut block = TaylorBlock::ZERO;
        // The trend's expansion over the block: value, slope, half the bend.
        let mut moment = (0.0f32, 0.0f32, 0.0f32);
        // Σ w·e, Σ w·e·u, Σ w·e·u² over the block, u the distance from its centre.
        let mut sums = (0.0f32, 0.0f32, 0.0f32);
        let mut projections = [0.0f32; DRIFT_TERMS];
        let mut previous = 0.0f32;
        let mut squares = 0.0f32;
        let mut in_block = 0usize;
        let half = 0.5 * (DRIFT_BLOCK - 1) as f32;
        let reference = self.measured.samples();
        let reference = reference.get(..self.samples).unwrap_or(reference);
        let (settle, fitted) = reference
            .split_at_checked(SETTLE_SAMPLES)
            .unwrap_or((reference, &[]));
        for (i, &r) in settle.iter().enumerate() {
            modelled.next(i, 0.0);
            previous = r;
        }
        for (j, &r) in fitted.iter().enumerate() {
            let i = SETTLE_SAMPLES + j;
            if in_block == 0 {
                block.add_to(&mut projections, sums);
                sums = (0.0, 0.0, 0.0);
                block = TaylorBlock::at(axis(i, self.samples) + half * step);
                moment = (
                    dot(trend, &block.value) - at_start,
                    dot(trend, &block.slope),
                    0.5 * dot(trend, &block.bend),
                );
            }
            let u = (in_block as f32 - half) * step;
            in_block = if in_block + 1 == DRIFT_BLOCK {
                0
            } else {
                in_block + 1
            };
            let h = moment.0 + u * (moment.1 + u * moment.2);
            let m = modelled.next(i, h);
            let d = r - previous;
            previous = r;
            let w = weight(d, self.inv_kappa);
            let e = r - m;
            let we = w * e;
            squares += we * e;
            let weu = we * u;
            sums.0 += we;
            sums.1 += weu;
            sums.2 += weu * u;
        }
        block.add_to(&mut projections, sums);
        let mut drift = [0.0f32; DRIFT_TERMS];
        for (c, row) in drift.iter_mut().zip(&self.drift_inverse) {
            *c = row.iter().zip(&projections).map(|(a, b)| a * b).sum();
        }
        let explained: f32 = drift.iter().zip(&projections).map(|(c, b)| c * b).sum();
        let dt = self.model.params().control_period;
        let error = (squares - explained).max(0.0) * dt;
        WindowFit {
            error: if error.is_finite() {
                error
            } else {
                f32::INFINITY
            },
            drift,
        }
    }

    /// The Gauss–Newton sums at `k` under the problem's load ([`Curvature`]): one base run,
    /// one run per component shifted by [`STEP`] (down where up would leave [0, 1]) and one
    /// per fitted load parameter (the stiffness by 1 %, the moment by 1 % of the spring's
    /// moment at the test's amplitude), stepped in lockstep. The nuisances — the drift's
    /// polynomials and the two load parameters — are profiled out of the residual and of
    /// every fault column (the Schur complement `JᵀWJ − CᵀQ⁻¹C`, `Q` the nuisances' normal
    /// matrix, `C` their cross terms with the faults): an interval then includes what the
    /// window cannot tell from its load (a moment against friction). Twelve model runs, no
    /// storage of residuals; f32 products summed in blocks joined in f64. For the window's
    /// uncertainty and its polish. A held component ([`HeldComponents`]) is varied, but its
    /// row and column leave the sums (its deviation not determined; the polish does not
    /// move it); its cross terms with the free components are the [`HeldCoupling`].
    pub fn curvature(&self, k: &FaultVector) -> Curvature {
        run_to_end(self.curvature_stepwise(k))
    }

    /// [`curvature`](Self::curvature) with how the free components lean on the held ones
    /// there ([`HeldCoupling`]; what [`identify`] hands a flight's reading).
    pub fn curvature_with_coupling(&self, k: &FaultVector) -> (Curvature, HeldCoupling) {
        let (c, _, coupling) = run_to_end(self.curvature_and_load_stepwise(k, self.load));
        (c, coupling)
    }

    /// [`curvature`](Self::curvature) in steps: the future pauses after every
    /// [`CURVATURE_CHUNK`] samples of the twelve lockstep runs.
    pub async fn curvature_stepwise(&self, k: &FaultVector) -> Curvature {
        self.curvature_and_load_stepwise(k, self.load).await.0
    }

    /// [`curvature_stepwise`](Self::curvature_stepwise) under `load`, with how the load's
    /// best stiffness and moment move with the faults ([`LoadResponse`]): the polish steps
    /// the load with the faults, as the profiled curvature assumes.
    #[allow(clippy::indexing_slicing, clippy::needless_range_loop)] // indices < FAULT_COUNT, NUISANCES on fixed arrays
    async fn curvature_and_load_stepwise(
        &self,
        k: &FaultVector,
        load: WindowLoad,
    ) -> (Curvature, LoadResponse, HeldCoupling) {
        let k = &self.held.apply(k);
        let start = self.measured.initial_angles();
        let first = self.command.position_at(0);
        let moment_step = LOAD_STEP * load.stiffness * self.model.command().amplitude;
        let moment_step = if moment_step > 0.0 { moment_step } else { 1.0 };
        let mut steps = [0.0f32; FAULT_COUNT];
        // One model for the twelve runs, each run's rigging set before its step.
        let mut model = self.model;
        let mut runs: [(RunRigging, crate::monitor::MonitorRun, LowPassState); RUNS] =
            core::array::from_fn(|j| {
                let mut genes = *k.as_array();
                let (mut stiffness, mut moment) = (load.stiffness, load.moment);
                // Held components are varied too: their columns give how the free
                // components lean on them ([`HeldCoupling`]), then leave the sums.
                if (1..=FAULT_COUNT).contains(&j) {
                    let c = j - 1;
                    let x = genes[c];
                    let shifted = if x + STEP <= 1.0 { x + STEP } else { x - STEP };
                    steps[c] = shifted - x;
                    genes[c] = shifted;
                } else if j == FAULT_COUNT + 1 {
                    stiffness *= 1.0 + LOAD_STEP;
                } else if j == FAULT_COUNT + 2 {
                    moment += moment_step;
                }
                let (m, r) = self.model.with_load_stiffness(stiffness).start_loaded_run(
                    &FaultVector::saturating(genes),
                    start,
                    moment,
                    first,
                );
                (m.rigging(), r, LowPassState::default())
            });
        let filter = self.measured.filter();
        let mut totals = WindowTotals::ZERO;
        let mut fitted = 0u32;
        let mut previous = 0.0f32;
        let mut block = WindowBlockSums::ZERO;
        let mut in_block = 0u32;
        for (i, &r) in self
            .measured
            .samples()
            .iter()
            .take(self.samples)
            .enumerate()
        {
            let x = axis(i, self.samples);
            let phi = legendre(x);
            let push = -load.trend_at(&phi);
            let command = self.command.position_at(i);
            let mut current = [0.0f32; RUNS];
            for ((rigging, run, state), out) in runs.iter_mut().zip(current.iter_mut()) {
                model.rig(*rigging);
                if push != 0.0 {
                    run.push_surface(&model, push);
                }
                *out = filter.apply(state, run.next_sample(&model, command).current);
            }
            let d = r - previous;
            previous = r;
            if (i + 1) % CURVATURE_CHUNK == 0 {
                pause().await;
            }
            if i < SETTLE_SAMPLES {
                continue;
            }
            // f32 products summed in blocks of CURVATURE_BLOCK samples, each block added to
            // the f64 totals (as the preflight's curvature): single precision per sample,
            // the Cortex-M4F's FPU, no soft f64 in the loop.
            let w = weight(d, self.inv_kappa);
            let base = current[0];
            let e = r - base;
            let jac: [f32; FAULT_COUNT] = core::array::from_fn(|c| {
                if steps[c] != 0.0 {
                    (current[c + 1] - base) / steps[c]
                } else {
                    0.0
                }
            });
            // The nuisance columns: the drift's polynomials, then d/d ln K and d/dM.
            let nuisance: [f32; NUISANCES] = core::array::from_fn(|t| {
                if t < DRIFT_TERMS {
                    phi[t]
                } else if t == DRIFT_TERMS {
                    (current[FAULT_COUNT + 1] - base) / LOAD_STEP
                } else {
                    (current[FAULT_COUNT + 2] - base) / moment_step
                }
            });
            let b = &mut block;
            for a in 0..FAULT_COUNT {
                let wa = w * jac[a];
                b.gradient[a] += wa * e;
                for c in a..FAULT_COUNT {
                    b.normal[a][c] += wa * jac[c];
                }
            }
            b.rss += w * e * e;
            for t in 0..NUISANCES {
                let wn = w * nuisance[t];
                b.q_residual[t] += wn * e;
                for c in 0..FAULT_COUNT {
                    b.cross[t][c] += wn * jac[c];
                }
            }
            for (row, &n) in b.q_load.iter_mut().zip(&nuisance[DRIFT_TERMS..]) {
                let wn = w * n;
                for (x, &m) in row.iter_mut().zip(&nuisance) {
                    *x += wn * m;
                }
            }
            fitted += 1;
            in_block += 1;
            if in_block == CURVATURE_BLOCK {
                block.flush(&mut totals);
                in_block = 0;
            }
        }
        block.flush(&mut totals);
        let WindowTotals {
            mut normal,
            mut gradient,
            mut rss,
            q_load,
            cross,
            q_residual,
        } = totals;
        for a in 0..FAULT_COUNT {
            for c in 0..a {
                normal[a][c] = normal[c][a];
            }
        }
        let mut q = [[0.0f64; NUISANCES]; NUISANCES];
        for (row, g) in q.iter_mut().zip(&self.gram) {
            row[..DRIFT_TERMS].copy_from_slice(g);
        }
        for (t, row) in q_load.iter().enumerate() {
            let t = DRIFT_TERMS + t;
            q[t] = *row;
            for u in 0..DRIFT_TERMS {
                q[u][t] = row[u];
            }
        }
        // Profile the nuisances out (a regular Q; a singular one leaves the sums as they are,
        // and the load where it is).
        let mut response = LoadResponse::NONE;
        if let Some(qi) = invert(&q) {
            let solve = |v: &dyn Fn(usize) -> f64| -> [f64; NUISANCES] {
                core::array::from_fn(|t| (0..NUISANCES).map(|u| qi[t][u] * v(u)).sum())
            };
            let qr = solve(&|u| q_residual[u]);
            rss -= (0..NUISANCES).map(|t| qr[t] * q_residual[t]).sum::<f64>();
            response.at_zero = [qr[DRIFT_TERMS], qr[DRIFT_TERMS + 1]];
            for a in 0..FAULT_COUNT {
                let qa = solve(&|u| cross[u][a]);
                response.per_fault[0][a] = -qa[DRIFT_TERMS];
                response.per_fault[1][a] = -qa[DRIFT_TERMS + 1];
                gradient[a] -= (0..NUISANCES).map(|t| qa[t] * q_residual[t]).sum::<f64>();
                for c in 0..FAULT_COUNT {
                    normal[a][c] -= (0..NUISANCES).map(|t| qa[t] * cross[t][c]).sum::<f64>();
                }
            }
        }
        // The held components' entries leave the sums (the polish does not move them, the
        // uncertainty does not read them); what the free ones share with them is kept.
        let mut coupling = HeldCoupling::NONE;
        for h in (0..FAULT_COUNT).filter(|&h| self.held.holds(h)) {
            for a in (0..FAULT_COUNT).filter(|&a| !self.held.holds(a)) {
                coupling.normal[a][h] = normal[a][h];
            }
            for a in 0..FAULT_COUNT {
                normal[a][h] = 0.0;
                normal[h][a] = 0.0;
            }
            gradient[h] = 0.0;
            response.per_fault[0][h] = 0.0;
            response.per_fault[1][h] = 0.0;
        }
        let curvature = Curvature {
            normal,
            rss: rss.max(0.0),
            gradient,
            fitted,
        };
        (curvature, response, coupling)
    }

    /// How much the window's load moved beyond its spring: the RMS over the window of the
    /// load's trend and of the drift `fit` profiled out (as a moment: amperes times the
    /// torque constant and the gear ratio), without their constant parts, over the spring's
    /// moment at the test's amplitude. The turbulence the window carried (0 in still air).
    pub fn unmodelled_moment(&self, fit: &WindowFit) -> f32 {
        let per_ampere = self.model.torque_constant() * self.model.params().gear_ratio;
        let square: f32 = self
            .load
            .trend
            .iter()
            .zip(&fit.drift)
            .enumerate()
            .skip(1)
            .map(|(j, (t, d))| {
                let m = t + per_ampere * d;
                m * m / (2 * j + 1) as f32
            })
            .sum();
        let spring = self.load.stiffness * self.model.command().amplitude;
        if spring > 0.0 {
            crate::math::sqrt(square) / spring
        } else {
            f32::INFINITY
        }
    }

    /// The error `error` [A²·s] over the error of a model that gives no current: how much of
    /// the window's measured current the fit leaves unexplained (0 … 1).
    pub fn misfit(&self, error: f32) -> f32 {
        if self.energy > 0.0 {
            error / self.energy
        } else {
            f32::INFINITY
        }
    }

    /// Whether the window can be trusted at all, and at the vector `k` found with the fit
    /// `error` and the friction's standard deviation `friction_std` there (the window's
    /// calibrated uncertainty; NaN if it has none): a saturated current, a manoeuvre beyond
    /// the limits' command range, a fit that leaves more than the limits' share of the
    /// current unexplained (a load the model does not play: turbulence beyond the trend, a
    /// play crossed where the model cannot follow), a window that cannot tell a wide play
    /// from none, or a friction the window cannot read (the turbulence's moment stands in
    /// for it) make it `Outside`, judged in this order. Two model runs (the play's
    /// contrast).
    pub fn judge(
        &self,
        limits: &WindowLimits,
        k: &FaultVector,
        error: f32,
        friction_std: f32,
    ) -> Result<(), WindowReason> {
        run_to_end(self.judge_stepwise(limits, k, error, friction_std))
    }

    /// [`judge`](Self::judge) in steps: the future pauses after each of its two runs.
    pub async fn judge_stepwise(
        &self,
        limits: &WindowLimits,
        k: &FaultVector,
        error: f32,
        friction_std: f32,
    ) -> Result<(), WindowReason> {
        let p = self.model.params();
        if self.peak_current >= limits.saturation_share * p.max_current {
            return Err(WindowReason::CurrentSaturated {
                peak: self.peak_current,
            });
        }
        if self.command_range > limits.max_command_range {
            return Err(WindowReason::ManoeuvreTooLarge {
                range: self.command_range,
            });
        }
        let misfit = self.misfit(error);
        if misfit.is_nan() || misfit > limits.max_misfit {
            return Err(WindowReason::FitnessFloor { misfit });
        }
        // The play: the fit with no backlash against the fit with a wide one, at `k`. If
        // the two hardly differ the gear never crossed its play (the load did not reverse):
        // the window shows nothing of the backlash and the GA's value is noise. Judged
        // before the turbulence, so that a window named only for its turbulence has seen
        // the play (its evidence is sound: a flight's reading adds it, `crate::fusion`).
        let with_play = |level: f32| {
            let mut genes = *k.as_array();
            if let Some(b) = genes.get_mut(1) {
                *b = level;
            }
            self.evaluate(&FaultVector::saturating(genes)).error
        };
        let wide = with_play(PLAY_PROBE);
        pause().await;
        let none = with_play(0.0);
        pause().await;
        let contrast = abs(wide - none) / error.max(f32::MIN_POSITIVE);
        if contrast.is_nan() || contrast < limits.min_play_contrast {
            return Err(WindowReason::PlayUnseen { contrast });
        }
        if friction_std.is_nan() || friction_std > limits.max_friction_std {
            return Err(WindowReason::TurbulenceTooHigh { friction_std });
        }
        Ok(())
    }

    /// The window as fitted at `k` under the problem's load: for every sample, the time
    /// [s], the measured current, the model's and the model's with the profiled drift [A]
    /// (all filtered alike), handed to `sink`. Two model runs (the drift, then the trace).
    pub fn fitted(&self, k: &FaultVector, mut sink: impl FnMut(f32, f32, f32, f32)) {
        let k = &self.held.apply(k);
        let load = self.load;
        let drift = self.evaluate_under(k, load).drift;
        let model = self.model.with_load_stiffness(load.stiffness);
        let start = self.measured.initial_angles();
        let first = self.command.position_at(0);
        let (model, mut run) = model.start_loaded_run(k, start, load.moment, first);
        let filter = self.measured.filter();
        let mut state = LowPassState::default();
        let dt = self.model.params().control_period;
        for (i, &r) in self
            .measured
            .samples()
            .iter()
            .take(self.samples)
            .enumerate()
        {
            let phi = legendre(axis(i, self.samples));
            run.push_surface(&model, -load.trend_at(&phi));
            let sample = run.next_sample(&model, self.command.position_at(i));
            let modelled = filter.apply(&mut state, sample.current);
            let d: f32 = drift.iter().zip(&phi).map(|(c, p)| c * p).sum();
            sink(i as f32 * dt, r, modelled, modelled + d);
        }
    }

    /// Fits the load at fault vector `k`: a golden-section search of the stiffness (from a
    /// third to three times `stiffness_guess`) and of the moment (±50 % of the held moment),
    /// [`TREND_ROUNDS`] fixed-point rounds that move the drift the fit profiled out into the
    /// load (its value at the start into the moment, its change into the trend: the model
    /// then plays the slow hinge moment, backlash crossings where they happen), the stiffness
    /// again near the first, and the trend's rounds again. [`LOAD_SEARCH_EVALUATIONS`]
    /// evaluations. Returns the load found and its error.
    pub fn fit_load(&self, k: &FaultVector, stiffness_guess: f32) -> (WindowLoad, f32) {
        let (load, error, _) = run_to_end(self.fit_load_stepwise(k, stiffness_guess));
        (load, error)
    }

    /// [`fit_load`](Self::fit_load) in steps: the future pauses after every evaluation.
    /// Also returns the evaluations it spent (≤ [`LOAD_SEARCH_EVALUATIONS`]: the trend's
    /// rounds stop when one does not lower the error).
    pub async fn fit_load_stepwise(
        &self,
        k: &FaultVector,
        stiffness_guess: f32,
    ) -> (WindowLoad, f32, u32) {
        let held = self.held_moment();
        let mut load = WindowLoad::spring(stiffness_guess, held);
        let stiffness_at = |load: WindowLoad, log_k: f32| WindowLoad {
            stiffness: crate::math::exp64(f64::from(log_k)) as f32,
            moment: load.moment,
            trend: load.trend,
        };
        let at_moment = |load: WindowLoad, m: f32| WindowLoad {
            moment: m,
            stiffness: load.stiffness,
            trend: load.trend,
        };
        // The moment sets where the load reverses, so where the gear crosses its play, and
        // with a wide play the fitness is sharp in it (a basin a few N·m wide per crossing
        // pattern): a fine scan first, at the guessed stiffness.
        // The current holds the moment less what dry friction carries: the span is the
        // friction a fault could reach (three times the healthy breakaway, at the user
        // shaft) and a fifth of the held moment for the estimate's own error.
        let p = self.model.params();
        let span = 3.0 * p.static_friction * p.gear_ratio + 0.2 * abs(held);
        let cell = 2.0 * span / (MOMENT_SCAN - 1) as f32;
        let mut best = (held, f32::INFINITY);
        for j in 0..MOMENT_SCAN {
            let m = held - span + cell * j as f32;
            let e = self.evaluate_under(k, at_moment(load, m)).error;
            pause().await;
            if e < best.1 {
                best = (m, e);
            }
        }
        load.moment = best.0;
        let ln = crate::math::ln;
        let range_k = (ln(stiffness_guess / 3.0), ln(stiffness_guess * 3.0));
        let mut search = GoldenSearch::new(range_k);
        while let Some(x) = search.ask() {
            search.tell(self.evaluate_under(k, stiffness_at(load, x)).error);
            pause().await;
        }
        let (log_k, _) = search.best();
        load = stiffness_at(load, log_k);
        let mut search = GoldenSearch::new((best.0 - cell, best.0 + cell));
        while let Some(m) = search.ask() {
            search.tell(self.evaluate_under(k, at_moment(load, m)).error);
            pause().await;
        }
        let (moment, _) = search.best();
        load.moment = moment;
        let (trended, first_rounds) = self.follow_trend(k, load).await;
        load = trended;
        let mut search = GoldenSearch::new((log_k - 0.3, log_k + 0.3));
        while let Some(x) = search.ask() {
            search.tell(self.evaluate_under(k, stiffness_at(load, x)).error);
            pause().await;
        }
        let (log_k, _) = search.best();
        let (load, second_rounds) = self.follow_trend(k, stiffness_at(load, log_k)).await;
        let error = self.evaluate_under(k, load).error;
        pause().await;
        let runs = MOMENT_SCAN + 3 * GOLDEN_STEPS + 1 + first_rounds + second_rounds;
        (load, error, runs as u32)
    }

    /// [`TREND_ROUNDS`] rounds: the drift the fit profiles out, as a moment (amperes times
    /// the torque constant and the gear ratio), added to the load. O(rounds) evaluations.
    /// Also returns the evaluations spent (two per round).
    async fn follow_trend(&self, k: &FaultVector, mut load: WindowLoad) -> (WindowLoad, usize) {
        let mut runs = 0;
        let per_ampere = self.model.torque_constant() * self.model.params().gear_ratio;
        for _ in 0..TREND_ROUNDS {
            let fit = self.evaluate_under(k, load);
            pause().await;
            let start: f32 = fit
                .drift
                .iter()
                .zip(&legendre(-1.0))
                .map(|(c, p)| c * p)
                .sum();
            let next = WindowLoad {
                moment: load.moment + per_ampere * start,
                trend: core::array::from_fn(|j| {
                    load.trend.get(j).copied().unwrap_or(0.0)
                        + per_ampere * fit.drift.get(j).copied().unwrap_or(0.0)
                }),
                stiffness: load.stiffness,
            };
            let error = self.evaluate_under(k, next).error;
            pause().await;
            runs += 2;
            if error <= fit.error {
                load = next;
            } else {
                break;
            }
        }
        (load, runs)
    }
}

/// How the load's best stiffness and moment move with a step of the faults, from a
/// window's curvature: the nuisances' least-squares step given the faults' step `δ` is
/// `Q⁻¹(NᵀWr − C·δ)` (`N` the nuisances' columns, `Q = NᵀWN`, `C = NᵀWJ` their cross terms
/// with the faults; linearised at the curvature's vector); its two load rows are kept.
#[derive(Clone, Copy, Debug)]
struct LoadResponse {
    /// The load's step for no fault step: [ln stiffness, moment in N·m] (the curvature's
    /// columns are the current's change per relative stiffness and per N·m).
    at_zero: [f64; 2],
    /// Its change per unit of each fault component.
    per_fault: [[f64; FAULT_COUNT]; 2],
}

impl LoadResponse {
    const NONE: Self = Self {
        at_zero: [0.0; 2],
        per_fault: [[0.0; FAULT_COUNT]; 2],
    };

    /// `load` moved with the faults' step from `from` to `to` (the phase's step taken the
    /// short way round). O(9).
    fn step(&self, load: WindowLoad, from: &FaultVector, to: &FaultVector) -> WindowLoad {
        let [mut ln_k, mut moment] = self.at_zero;
        for (i, (a, b)) in from.as_array().iter().zip(to.as_array()).enumerate() {
            let mut d = b - a;
            if crate::fault::CIRCULAR.get(i).copied().unwrap_or(false) {
                d -= crate::math::floor(d + 0.5);
            }
            let d = f64::from(d);
            ln_k += self.per_fault[0].get(i).copied().unwrap_or(0.0) * d;
            moment += self.per_fault[1].get(i).copied().unwrap_or(0.0) * d;
        }
        WindowLoad {
            stiffness: load.stiffness * crate::math::exp64(ln_k) as f32,
            moment: load.moment + moment as f32,
            trend: load.trend,
        }
    }
}

/// Samples of a window curvature's twelve lockstep runs between two pauses of
/// [`WindowProblem::curvature_stepwise`] (about one window evaluation's work).
pub const CURVATURE_CHUNK: usize = 400;

/// Fitted samples a window curvature sums in f32 before they join its f64 totals.
const CURVATURE_BLOCK: u32 = 64;

/// One block of a window curvature's sums in f32 ([`WindowProblem::curvature`]): the
/// faults' normal matrix (upper triangle) and gradient, the residual's squares, the
/// nuisances' products with the residual and the fault columns, and the load columns'
/// products with every nuisance.
struct WindowBlockSums {
    normal: [[f32; FAULT_COUNT]; FAULT_COUNT],
    gradient: [f32; FAULT_COUNT],
    rss: f32,
    q_residual: [f32; NUISANCES],
    cross: [[f32; FAULT_COUNT]; NUISANCES],
    q_load: [[f32; NUISANCES]; NUISANCES - DRIFT_TERMS],
}

impl WindowBlockSums {
    const ZERO: Self = Self {
        normal: [[0.0; FAULT_COUNT]; FAULT_COUNT],
        gradient: [0.0; FAULT_COUNT],
        rss: 0.0,
        q_residual: [0.0; NUISANCES],
        cross: [[0.0; FAULT_COUNT]; NUISANCES],
        q_load: [[0.0; NUISANCES]; NUISANCES - DRIFT_TERMS],
    };

    /// Adds the block to `totals` and empties it.
    fn flush(&mut self, totals: &mut WindowTotals) {
        for (total, block) in totals.normal.iter_mut().zip(&self.normal) {
            add(total, block);
        }
        add(&mut totals.gradient, &self.gradient);
        totals.rss += f64::from(self.rss);
        add(&mut totals.q_residual, &self.q_residual);
        for (total, block) in totals.cross.iter_mut().zip(&self.cross) {
            add(total, block);
        }
        for (total, block) in totals.q_load.iter_mut().zip(&self.q_load) {
            add(total, block);
        }
        *self = Self::ZERO;
    }
}

/// A window curvature's sums in f64, the blocks' totals: the faults' normal matrix (upper
/// triangle) and gradient, the residual's squares, the nuisances' normal matrix's load rows
/// (its drift block is the Gram matrix), their cross terms with the faults and their
/// products with the residual.
struct WindowTotals {
    normal: [[f64; FAULT_COUNT]; FAULT_COUNT],
    gradient: [f64; FAULT_COUNT],
    rss: f64,
    q_load: [[f64; NUISANCES]; NUISANCES - DRIFT_TERMS],
    cross: [[f64; FAULT_COUNT]; NUISANCES],
    q_residual: [f64; NUISANCES],
}

impl WindowTotals {
    const ZERO: Self = Self {
        normal: [[0.0; FAULT_COUNT]; FAULT_COUNT],
        gradient: [0.0; FAULT_COUNT],
        rss: 0.0,
        q_load: [[0.0; NUISANCES]; NUISANCES - DRIFT_TERMS],
        cross: [[0.0; FAULT_COUNT]; NUISANCES],
        q_residual: [0.0; NUISANCES],
    };
}

/// `total += block`, element by element.
fn add<const M: usize>(total: &mut [f64; M], block: &[f32; M]) {
    for (t, &b) in total.iter_mut().zip(block) {
        *t += f64::from(b);
    }
}

/// The evaluations each of a window's two GA runs may spend (the actuator's settings
/// otherwise, [`window_ga`]): the identification's cost on the controller is set by it
/// (≈ 2 M instructions per evaluation on the Cortex-M4F). Chosen on the flight campaign's
/// selection seeds 10–29 among 1 400 (the preflight's), 800, 600, 400 and 250: 400 kept the
/// reference actuator's counts (identified 111–115, one window above 6 % e_tot, no false
/// `FAULT`) and the light actuator's (55 identified, none above 6 %), but on the light
/// actuator's seeds 0–9 it read a Table II medium window in climb `within` at 14.3 % e_tot
/// (the gear's play read closed: both GAs settled in the closed-play basin; from 600 on
/// the same window is `play_unseen`), so **600** — those seeds were looked at for this
/// choice (docs/in-flight.md §6).
pub const WINDOW_GA_EVALUATIONS: u32 = 600;

/// The GA settings of a window's identification: the actuator's, with at most
/// [`WINDOW_GA_EVALUATIONS`] evaluations per run.
pub fn window_ga(actuator: &crate::ga::GaSettings) -> crate::ga::GaSettings {
    crate::ga::GaSettings {
        max_evaluations: actuator.max_evaluations.min(WINDOW_GA_EVALUATIONS),
        ..*actuator
    }
}

/// Gauss–Newton steps of the polish at most, and their first damping.
const POLISH_STEPS: usize = 6;
const POLISH_DAMPING: f64 = 0.1;

/// Model runs of one window curvature ([`WindowProblem::curvature`]).
pub const CURVATURE_RUNS: u32 = RUNS as u32;

/// What the identification of one window found ([`identify`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WindowReading {
    pub faults: FaultVector,
    /// The fit at `faults` under `load`: eq. (3) after the drift [A²·s] and the drift.
    pub fit: WindowFit,
    /// The load fitted at the first GA's best, as the polish moved it with the faults (the
    /// one `fit` is under).
    pub load: WindowLoad,
    /// Standard deviation and 90 % interval per component (the preflight's inflation, then
    /// [`WINDOW_INFLATION`]) with the correlations; `None` if the curvature is singular.
    pub uncertainty: Option<(
        crate::uncertainty::Uncertainty,
        [[f32; FAULT_COUNT]; FAULT_COUNT],
    )>,
    /// The window's own verdict under the limits it was judged with.
    pub verdict: Result<(), WindowReason>,
    /// The Gauss–Newton sums at `faults` (the load and the drift profiled out): what a
    /// flight's reading adds of this window ([`crate::fusion::WindowFusion`]).
    pub curvature: Curvature,
    /// How the free components lean on the held ones at `faults` (zero when nothing is
    /// held): with the held values' covariance, what a flight's reading takes of their
    /// error.
    pub coupling: HeldCoupling,
    /// The standard deviation per component the held values' error adds to the window's
    /// own ([`HeldComponents::shared_std`]; zero when nothing is held or the held values
    /// came without their covariance), already in `uncertainty`.
    pub shared_std: [f32; FAULT_COUNT],
    /// Monitor-model runs spent (a curvature counts [`CURVATURE_RUNS`], the verdict's two
    /// runs not counted).
    pub evaluations: u32,
}

/// Identifies the faults behind the window of `problem` (its load is the starting guess:
/// a spring of the actuator's stiffness): the load fitted at the nominal vector, a GA of
/// `settings` under it, the load fitted again at the GA's best and a second GA (seed
/// `seed + 0x5eed`) under that, the better of the two polished by at most
/// [`POLISH_STEPS`] damped Gauss–Newton steps on the window's curvature (the load's
/// stiffness and moment stepped with the faults by their profiled response), the uncertainty
/// there and the verdict under `limits`. Bounded: 2 × [`LOAD_SEARCH_EVALUATIONS`], two GA
/// runs of `settings`, ≤ 2 + 7 × [`CURVATURE_RUNS`] + [`POLISH_STEPS`] model runs and the
/// verdict's two; no allocation (one [`SteadyStateGa`](crate::SteadyStateGa) of `P` on the
/// stack at a time). [`identify_stepwise`] run to its end: the same bits.
pub fn identify<const N: usize, const P: usize>(
    problem: &WindowProblem<'_, N>,
    settings: crate::ga::GaSettings,
    seed: u64,
    limits: &WindowLimits,
) -> Result<WindowReading, crate::ga::GaError> {
    let mut problem = problem.clone();
    run_to_end(identify_stepwise::<N, P>(
        &mut problem,
        settings,
        seed,
        limits,
    ))
}

/// [`identify`] as a future that does bounded work per poll, for a controller's idle time
/// (an executor's task polls it; the control loop runs in between): each poll does at most
/// one window evaluation (one model run over the window, with the GA's O(`P`) bookkeeping),
/// or [`CURVATURE_CHUNK`] samples of a curvature's twelve lockstep runs, or the polish's
/// and the uncertainty's O(12³) algebra. The future holds the GA, the curvature's runs and
/// the load search between polls (no allocation); `problem`'s load is its starting guess
/// and is left at the load found.
pub async fn identify_stepwise<const N: usize, const P: usize>(
    problem: &mut WindowProblem<'_, N>,
    settings: crate::ga::GaSettings,
    seed: u64,
    limits: &WindowLimits,
) -> Result<WindowReading, crate::ga::GaError> {
    let guess = problem.load().stiffness;
    let mut evaluations = 0u32;
    let (load, _, runs) = problem
        .fit_load_stepwise(&FaultVector::NOMINAL, guess)
        .await;
    evaluations += runs;
    problem.set_load(load);
    let (first, runs) = search_stepwise::<N, P>(problem, settings, seed).await?;
    evaluations += runs;
    let (mut load, _, runs) = problem.fit_load_stepwise(&first, load.stiffness).await;
    evaluations += runs;
    problem.set_load(load);
    let (second, runs) =
        search_stepwise::<N, P>(problem, settings, seed.wrapping_add(0x5eed)).await?;
    evaluations += runs;
    let first_fit = problem.evaluate(&first);
    pause().await;
    let second_fit = problem.evaluate(&second);
    pause().await;
    let (mut faults, mut fit) = if second_fit.error.total_cmp(&first_fit.error).is_lt() {
        (second, second_fit)
    } else {
        (first, first_fit)
    };
    // The polish: damped Gauss–Newton steps on the window's curvature, the load stepped with
    // the faults (the curvature profiles it out, so its step assumes the load's best
    // response: a fault the load was fitted against can still move), each kept only if it
    // lowers the error; then the uncertainty at the result.
    let mut damping = POLISH_DAMPING;
    let (mut curvature, mut response, mut coupling) =
        problem.curvature_and_load_stepwise(&faults, load).await;
    pause().await;
    evaluations += CURVATURE_RUNS;
    for _ in 0..POLISH_STEPS {
        let Some(next) = curvature.gauss_newton_step(&faults, damping) else {
            break;
        };
        let next_load = response.step(load, &faults, &next);
        let next_fit = problem.evaluate_under(&next, next_load);
        pause().await;
        evaluations += 1;
        if next_fit.error < fit.error {
            faults = next;
            fit = next_fit;
            load = next_load;
            damping = (damping * 0.3).max(1e-3);
            let sums = problem.curvature_and_load_stepwise(&faults, load).await;
            curvature = sums.0;
            response = sums.1;
            coupling = sums.2;
            pause().await;
            evaluations += CURVATURE_RUNS;
        } else {
            damping *= 10.0;
        }
    }
    // The verdict's runs under the load the fit is under (field by field: a whole-struct
    // copy out of this future's state links a 1.5 kB `memmove` on the Cortex-M4F).
    problem.load.stiffness = load.stiffness;
    problem.load.moment = load.moment;
    for (to, from) in problem.load.trend.iter_mut().zip(load.trend) {
        *to = from;
    }
    // The window's own deviations widened by its factors, then what the held values' error
    // moves beside them (the same in every window of the flight: not widened).
    let shared_std = HeldComponents::sensitivity(&curvature, &coupling)
        .map_or([0.0; FAULT_COUNT], |a| problem.held.shared_std(&a));
    let uncertainty = curvature.uncertainty(&faults).ok().map(|(u, c)| {
        (
            u.widened(&faults, &WINDOW_INFLATION)
                .with_shared(&faults, &shared_std),
            c,
        )
    });
    let friction_std = uncertainty
        .as_ref()
        .and_then(|(u, _)| u.std.first().copied())
        .unwrap_or(f32::NAN);
    Ok(WindowReading {
        faults,
        fit,
        load,
        uncertainty,
        verdict: problem
            .judge_stepwise(limits, &faults, fit.error, friction_std)
            .await,
        curvature,
        coupling,
        shared_std,
        evaluations,
    })
}

/// One GA run of `settings` (seed `seed`) over `problem` under its load, one evaluation per
/// poll: its best vector and the evaluations spent. The population lives in this future
/// only while it runs (one at a time in [`identify_stepwise`]'s state).
async fn search_stepwise<const N: usize, const P: usize>(
    problem: &mut WindowProblem<'_, N>,
    settings: crate::ga::GaSettings,
    seed: u64,
) -> Result<(FaultVector, u32), crate::ga::GaError> {
    let mut ga = crate::SteadyStateGa::<P>::new(settings, seed)?;
    loop {
        let status = ga.step(&mut *problem, 1);
        pause().await;
        if status != crate::ga::Status::Running {
            break;
        }
    }
    Ok((
        problem
            .held
            .apply(&FaultVector::saturating(ga.best().genes)),
        ga.evaluations(),
    ))
}

/// Records what the controller would measure over a window of flight if the actuator
/// behaved exactly like the monitor model `model` (its day and test) with faults `k` under a
/// spring of `load.stiffness` carrying `load.moment` at the start (no trend, no turbulence),
/// following `command` over `samples` samples from the motor angle `start_motor` [rad]: three phase currents from
/// the equivalent current and the commutation table, quantised into frames and conditioned
/// into `measured` (cleared first, its test kept). The window identification's inverse
/// check and its instruction-count bench (`firmware/window-bench`). O(N), one model run.
pub fn record_monitor_window<const N: usize>(
    model: &MonitorModel,
    k: &FaultVector,
    load: &WindowLoad,
    command: &impl CommandSource,
    samples: usize,
    start_motor: f32,
    measured: &mut MeasuredCurrent<N>,
) -> Result<(), crate::conditioning::ConditioningError> {
    use crate::conditioning::{commutation_signs, AdcFrame, ShaftAngles};
    measured.clear();
    let pole_pairs = model.params().pole_pairs;
    let first = command.position_at(0);
    let start = ShaftAngles {
        motor: start_motor,
        user: first,
        currents: [0.0; 3],
    };
    let (m, mut run) =
        model
            .with_load_stiffness(load.stiffness)
            .start_loaded_run(k, start, load.moment, first);
    for i in 0..samples.min(N) {
        let s = run.next_sample(&m, command.position_at(i));
        let phases =
            commutation_signs(pole_pairs * s.motor_angle).map(|x| f32::from(x) * s.current);
        // Cannot be full: at most N frames are pushed.
        let _ = measured.push_frame(
            AdcFrame::from_f32(phases, s.motor_angle, s.user_angle),
            pole_pairs,
        );
    }
    measured.finish()
}

/// A window's command [rad] at sample `index` of period `period` [s]: the flight control
/// computer's corrections as three tones (0.3, 0.9 and 1.7 Hz, `correction` [rad] RMS
/// together) with `chirp` superimposed. For [`record_monitor_window`]'s checks and bench;
/// a real window's command is what the controller followed (a trace's `theta_cmd`). O(1).
pub fn synthetic_command(
    chirp: &crate::command::ChirpSampler,
    correction: f32,
    period: f32,
    index: usize,
) -> f32 {
    const TONES: [(f32, f32); 3] = [(0.3, 0.0), (0.9, 1.1), (1.7, 2.3)];
    let t = index as f32 * period;
    // Three unit tones have an RMS of √1.5.
    let scale = correction / crate::math::sqrt(1.5);
    let corrections: f32 = TONES
        .iter()
        .map(|&(f, phase)| scale * crate::math::sin(2.0 * core::f32::consts::PI * f * t + phase))
        .sum();
    corrections + chirp.at(index)
}

/// A golden-section search over a range, asked point by point (ask / tell, as the GA):
/// [`GOLDEN_STEPS`] points, then the best point seen and its value. O(1) per point.
#[derive(Clone, Copy, Debug)]
struct GoldenSearch {
    a: f32,
    b: f32,
    c: f32,
    d: f32,
    fc: f32,
    fd: f32,
    /// Points told so far.
    told: usize,
    /// Whether the point asked next is `d` (else `c`).
    at_d: bool,
}

impl GoldenSearch {
    const R: f32 = 0.618_034;

    fn new((a, b): (f32, f32)) -> Self {
        Self {
            a,
            b,
            c: b - Self::R * (b - a),
            d: a + Self::R * (b - a),
            fc: f32::NAN,
            fd: f32::NAN,
            told: 0,
            at_d: false,
        }
    }

    /// The next point to evaluate; `None` once [`GOLDEN_STEPS`] were told.
    fn ask(&self) -> Option<f32> {
        (self.told < GOLDEN_STEPS).then_some(if self.at_d { self.d } else { self.c })
    }

    /// The value at the point last asked.
    fn tell(&mut self, value: f32) {
        if self.at_d {
            self.fd = value;
        } else {
            self.fc = value;
        }
        self.told += 1;
        if self.told == 1 {
            self.at_d = true;
        } else if self.told < GOLDEN_STEPS {
            if self.fc <= self.fd {
                self.b = self.d;
                self.d = self.c;
                self.fd = self.fc;
                self.c = self.b - Self::R * (self.b - self.a);
                self.at_d = false;
            } else {
                self.a = self.c;
                self.c = self.d;
                self.fc = self.fd;
                self.d = self.a + Self::R * (self.b - self.a);
                self.at_d = true;
            }
        }
    }

    /// The better of the two inner points and its value.
    fn best(&self) -> (f32, f32) {
        if self.fc <= self.fd {
            (self.c, self.fc)
        } else {
            (self.d, self.fd)
        }
    }
}

impl<const N: usize> Problem for WindowProblem<'_, N> {
    fn fitness(&mut self, genes: &[f32; FAULT_COUNT]) -> f32 {
        self.evaluate(&FaultVector::saturating(*genes)).error
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The load's response read from a window's curvature moves a load whose moment is off
    /// most of the way back, and lowers the fit: a window recorded from the monitor model
    /// (the controller's gain halved, friction 0.1) under a spring carrying 120 N·m, the
    /// problem under the same spring carrying 124 N·m, the faults not moved; then a step of
    /// the gain alone, the load moved with it, fits better than the load left where it is.
    #[test]
    fn the_polish_moves_the_load_with_the_faults() {
        use crate::actuator::ActuatorRecord;
        use crate::fdi::{OnboardMeasured, TEST_SAMPLES};
        let record = ActuatorRecord::REFERENCE;
        let test = record.test.chirp_only();
        let model = MonitorModel::new(
            record.params,
            &crate::Calibration::reference_actuator(&test),
        )
        .with_test(&test);
        let period = record.params.control_period;
        let sampler = model.sampler();
        let command: std::vec::Vec<f32> = (0..TEST_SAMPLES)
            .map(|i| synthetic_command(&sampler, 1.0e-3, period, i))
            .collect();
        let mut genes = *FaultVector::NOMINAL.as_array();
        (genes[0], genes[7]) = (0.1, 0.0);
        let truth = FaultVector::new(genes).unwrap();
        let stiffness = 1.4 * record.params.aero_stiffness;
        let load = WindowLoad::spring(stiffness, 120.0);
        let mut measured = std::boxed::Box::new(OnboardMeasured::ZEROED);
        measured.set_filter(LowPass::for_control_period(period).unwrap());
        measured.clear_for(test);
        let full = RecordedCommand::new(&command);
        record_monitor_window(
            &model,
            &truth,
            &load,
            &full,
            TEST_SAMPLES,
            0.3,
            &mut measured,
        )
        .unwrap();
        let kept: std::vec::Vec<f32> = command.iter().step_by(COMMAND_STRIDE).copied().collect();
        // The fit is sharp in the moment (where the gear reverses): a few N·m off.
        let off = WindowLoad::spring(stiffness, 124.0);
        let problem = WindowProblem::new(
            &measured,
            RecordedCommand::kept_every(COMMAND_STRIDE, &kept),
            model,
            off,
        )
        .unwrap();

        let (_, response, _) = run_to_end(problem.curvature_and_load_stepwise(&truth, off));
        let moved = response.step(off, &truth, &truth);
        assert!(
            (moved.moment - 120.0).abs() < 0.6 * 4.0,
            "moment moved to {}",
            moved.moment
        );
        assert!(
            (moved.stiffness / stiffness - 1.0).abs() < 0.01,
            "{moved:?}"
        );
        assert!(
            problem.evaluate_under(&truth, moved).error
                < 0.5 * problem.evaluate_under(&truth, off).error
        );

        // From the gain read 0.06 under the load best for it, the step to the true gain
        // with the load moved fits better than the step alone.
        let mut high = genes;
        high[7] = 0.06;
        let high = FaultVector::new(high).unwrap();
        let (fitted, _) = problem.fit_load(&high, stiffness);
        let mut at_high = problem.clone();
        at_high.set_load(fitted);
        let (_, response, _) = run_to_end(at_high.curvature_and_load_stepwise(&high, fitted));
        let stepped = response.step(fitted, &high, &truth);
        let with_load = at_high.evaluate_under(&truth, stepped).error;
        let without = at_high.evaluate_under(&truth, fitted).error;
        assert!(with_load < without, "{with_load} against {without}");
    }

    #[test]
    fn recorded_command_holds_its_last_sample() {
        let samples = [1.0f32, 2.0, 3.0];
        let c = RecordedCommand::new(&samples);
        assert_eq!(c.position_at(1), 2.0);
        assert_eq!(c.position_at(7), 3.0);
        assert_eq!(RecordedCommand::new(&[]).position_at(0), 0.0);
        assert_eq!((c.len(), RecordedCommand::new(&[]).len()), (3, 0));
    }

    /// A command kept every fourth sample is exact at the kept samples, on the line between
    /// them, holds its last value past them, spans up to its last kept sample; keeping a
    /// chirp-like command every fourth sample departs from it by less than its bound.
    #[test]
    fn a_command_kept_every_fourth_sample() {
        let kept = [0.0f32, 4.0, 2.0];
        let c = RecordedCommand::kept_every(4, &kept);
        let at: [f32; 11] = core::array::from_fn(|i| c.position_at(i));
        assert_eq!(at, [0.0, 1.0, 2.0, 3.0, 4.0, 3.5, 3.0, 2.5, 2.0, 2.0, 2.0]);
        assert_eq!(c.len(), 9);
        // 15 Hz at 5 mrad sampled at 10 kHz: within 1 µrad of the full command.
        let full: [f32; 2000] = core::array::from_fn(|i| {
            5e-3 * crate::math::sin(2.0 * core::f32::consts::PI * 15.0 * i as f32 * 1e-4)
        });
        let mut store = [0.0f32; 500];
        for (slot, &x) in store.iter_mut().zip(full.iter().step_by(COMMAND_STRIDE)) {
            *slot = x;
        }
        let c = RecordedCommand::kept_every(COMMAND_STRIDE, &store);
        assert_eq!(c.len(), 1997);
        let worst = (0..c.len()).fold(0.0f32, |m, i| m.max((c.position_at(i) - full[i]).abs()));
        assert!(worst < 1.0e-6, "{worst}");
    }

    /// A loaded start is an equilibrium: under a steady command the model holds the moment
    /// with a steady current and the shafts do not move; the same start without the moment
    /// gives no current. Fails if the start's gear flank, surface angle, current or
    /// integrators disagree with each other.
    #[test]
    fn a_loaded_start_holds_still() {
        use crate::params::ActuatorParams;
        use crate::{Calibration, ShaftAngles};
        let params = ActuatorParams::REFERENCE;
        let model =
            MonitorModel::new(params, &Calibration::REFERENCE_ACTUATOR).with_load_stiffness(6.5e4);
        let start = ShaftAngles {
            motor: 1.3,
            user: 2.0e-3,
            currents: [0.0; 3],
        };
        for (moment, backlash) in [(150.0f32, 0.0f32), (-80.0, 0.4), (0.0, 0.0)] {
            let mut genes = *FaultVector::NOMINAL.as_array();
            genes[1] = backlash;
            let k = FaultVector::saturating(genes);
            let (m, mut run) = model.start_loaded_run(&k, start, moment, start.user);
            let first = run.next_sample(&m, start.user);
            let held = moment / (params.gear_ratio * model.torque_constant());
            assert!(
                (first.current - held).abs() < 0.02 * held.abs() + 1e-6,
                "{moment}: {first:?}"
            );
            let mut last = first;
            for _ in 0..2000 {
                last = run.next_sample(&m, start.user);
            }
            assert!(
                (last.current - first.current).abs() < 0.01 * held.abs() + 1e-3,
                "{moment}: {last:?}"
            );
            assert!(
                (last.user_angle - start.user).abs() < 1e-6,
                "{moment}: {last:?}"
            );
            assert!(
                (last.motor_angle - start.motor).abs() < 1e-4,
                "{moment}: {last:?}"
            );
        }
    }

    /// The recurrence gives Legendre's closed forms (P2 … P5 at a few points).
    #[test]
    fn legendre_polynomials() {
        for x in [-1.0f32, -0.3, 0.0, 0.55, 1.0] {
            let p = legendre(x);
            let x2 = x * x;
            let closed = [
                1.0,
                x,
                1.5 * x2 - 0.5,
                x * (2.5 * x2 - 1.5),
                (35.0 * x2 * x2 - 30.0 * x2 + 3.0) / 8.0,
                x * (63.0 * x2 * x2 - 70.0 * x2 + 15.0) / 8.0,
            ];
            for (a, b) in p.iter().zip(&closed) {
                assert!((a - b).abs() < 1e-5, "x {x}: {a} vs {b}");
            }
        }
    }

    /// The second-order expansion about a block's centre gives every polynomial within
    /// 10⁻⁴ across the block, anywhere on the axis (the trend's moment and the projections
    /// rest on it); fails if a derivative's recurrence is off.
    #[test]
    #[allow(clippy::needless_range_loop)] // three arrays read at one index
    fn a_blocks_expansion_gives_the_polynomials() {
        let step = axis_step(5520);
        let half = 0.5 * (DRIFT_BLOCK - 1) as f32 * step;
        for centre in [-1.0 + half, -0.62, 0.0, 0.37, 1.0 - half] {
            let b = TaylorBlock::at(centre);
            for u in [-half, -0.3 * half, 0.0, 0.8 * half, half] {
                let exact = legendre(centre + u);
                for j in 0..DRIFT_TERMS {
                    let t = b.value[j] + u * b.slope[j] + 0.5 * u * u * b.bend[j];
                    assert!(
                        (t - exact[j]).abs() < 1e-4,
                        "x {centre}+{u}, P{j}: {t} vs {}",
                        exact[j]
                    );
                }
            }
        }
        // The derivatives' closed forms at one point: P2′ = 3x, P3″ = 15x.
        let b = TaylorBlock::at(0.4);
        assert!(
            (b.slope[2] - 1.2).abs() < 1e-5 && (b.bend[3] - 6.0).abs() < 1e-5,
            "{b:?}"
        );
    }

    #[test]
    fn golden_finds_a_parabolas_minimum() {
        let mut search = GoldenSearch::new((-3.0, 5.0));
        let mut asked = 0;
        while let Some(x) = search.ask() {
            search.tell((x - 1.25) * (x - 1.25) + 2.0);
            asked += 1;
        }
        assert_eq!(asked, GOLDEN_STEPS);
        let (x, fx) = search.best();
        assert!((x - 1.25).abs() < 0.03, "{x}");
        assert!((fx - 2.0).abs() < 1e-3);
    }

    #[test]
    #[allow(clippy::needless_range_loop)] // a matrix product written as one
    fn inverse_of_a_gram_matrix() {
        // A symmetric, diagonally dominant matrix: the Gram matrix's kind.
        let m: [[f64; DRIFT_TERMS]; DRIFT_TERMS] = core::array::from_fn(|i| {
            core::array::from_fn(|j| {
                if i == j {
                    4.0 + i as f64
                } else {
                    0.3 / (1.0 + (i + j) as f64)
                }
            })
        });
        let inv = invert(&m).expect("regular");
        for i in 0..DRIFT_TERMS {
            for j in 0..DRIFT_TERMS {
                let x: f64 = (0..DRIFT_TERMS).map(|k| m[i][k] * inv[k][j]).sum();
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((x - want).abs() < 1e-5, "{i},{j}: {x}");
            }
        }
        assert!(invert(&[[0.0; DRIFT_TERMS]; DRIFT_TERMS]).is_none());
    }
}
