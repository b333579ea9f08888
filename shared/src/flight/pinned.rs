//! The second window model (issue 36): a window of flight the load model leaves at its
//! fitness floor — most often a gear play several times nominal, whose crossings the
//! window's spring and trend cannot follow — read with the model's surface pinned, each
//! sample, to where its sensor read it ([`WindowProblem::evaluate_with_surface_samples`]).
//! No hinge moment is modelled: the gear carries whatever moved the measured surface.
//!
//! It reads the backlash and the gain drift ([`FREE`]). The friction is held at the same
//! flight's preflight reading beside the shorts, the eccentricity and the demagnetization
//! (a window holds those already, [`HeldComponents`]): given the surface's path the
//! controller's current hardly depends on the friction — moving it by 0.3 changes the pinned
//! fit by at most 0.1–0.6 points of the current's energy and a search scatters it over
//! 0–0.43 for 0.4 (docs/in-flight.md) — so a pinned
//! window needs a trusted preflight and says nothing of the friction. The one nuisance is
//! where the run starts in the play: the moment at the window's start [N·m]
//! ([`MonitorModel::start_loaded_run`](crate::MonitorModel::start_loaded_run)), profiled out
//! of the curvature.
//!
//! The search: with the surface pinned the gain drift is a needle — 0.01 off it the fit
//! leaves 20–40 % of the current, 0.05 off the model's current is several times the
//! measured — and the play a notch a few hundredths wide at its value, flat above it where
//! the window never crosses it (docs/in-flight.md). So
//! first the gain drift over its whole range at the guessed start, at a middle play and at
//! none ([`SCAN_GAIN_STEPS`] evaluations each), then the start's moment at every play of a
//! grid at each gain found ([`SCAN_PLAYS`] × [`SCAN_MOMENTS`] each; one grid when both
//! found the same), then Nelder–Mead over (backlash, gain drift, moment) from each grid's
//! best two points, [`SEARCH_EVALUATIONS`] each, the best end kept; the
//! curvature by central differences at two step sizes ([`CURVATURE_EVALUATIONS`]), the
//! uncertainty there widened by
//! [`PINNED_INFLATION`] with the held values' error carried beside it (their coupling by
//! mixed central differences, [`COUPLING_EVALUATIONS`]: the preflight's friction, shorts,
//! eccentricity and demagnetization, each with its stated deviation), and the verdict
//! against [`PinnedLimits`] (the play's other end tried at [`SCAN_MOMENTS`] starts), the
//! misfit's limit raised by what the surface sensor's own error leaves (the found point run
//! once more on the surface with that error drawn again — by the caller, from the error the
//! angles themselves show —, one evaluation).
//! Units: fault-vector units, N·m, A²·s. Work: at most [`PINNED_EVALUATIONS`] evaluations,
//! each one monitor-model run over the window (O(N)); O(1) memory beyond the problem; no
//! allocation, no panic.
//!
//! Run by the host on every window the load model names `fitness_floor` when the flight's
//! preflight was trusted (`host-sim`'s window identification). Not on the controller: it
//! needs the surface's angle per sample (4 bytes × the window's samples), and the board
//! image has no flash for either window model (docs/in-flight.md).

use crate::flight::window::{
    HeldComponents, HeldCoupling, SurfaceSamples, WindowFit, WindowLoad, WindowProblem,
    WindowReason,
};
use crate::physics::fault::FAULT_COUNT;
use crate::solver::uncertainty::{Curvature, Uncertainty};
use crate::FaultVector;

/// The components a pinned window reads: the backlash (k2) and the gain drift (k8).
pub const FREE: [usize; 2] = [1, 7];

/// Whether a window read with its load fitted, of verdict `verdict` and holding `held`,
/// is read again with its surface pinned: the load model at its fitness floor, and the
/// flight's preflight trusted (its shorts held), since a pinned window holds its friction at
/// the preflight's. The host's and the controller's rule. O(1).
pub fn wants_pinned(verdict: &Result<(), WindowReason>, held: &HeldComponents) -> bool {
    matches!(verdict, Err(WindowReason::FitnessFloor { .. })) && held.holds(2)
}

/// The friction's index: held at the preflight's in a pinned window.
const FRICTION: usize = 0;

/// The start's moment in the search's units [N·m per unit] on the built-in actuator: a play
/// crossed in the window's settle moves it by a few hundred N·m. Another actuator's unit
/// and scan step are these times its spring's moment at the test's amplitude over the
/// built-in one's ([`moment_scale`]: a trim tab's 10 N·m against 250).
const MOMENT_UNIT: f32 = 100.0;

/// The built-in actuator's spring moment at the test's amplitude [N·m]: its hinge stiffness
/// times the chirp's amplitude, the scale [`MOMENT_UNIT`] and [`SCAN_STEP`] were set at.
const REFERENCE_MOMENT: f32 = crate::physics::params::ActuatorParams::REFERENCE.aero_stiffness
    * crate::ChirpCommand::PREFLIGHT.amplitude;

/// How much larger than the built-in actuator's an actuator's moments are: its spring's
/// moment at the test's amplitude (`stiffness` [N·m/rad] × `amplitude` [rad]) over
/// [`REFERENCE_MOMENT`]; exactly 1 on the built-in actuator, 1 where either is not positive.
fn moment_scale(stiffness: f32, amplitude: f32) -> f32 {
    let scale = stiffness * amplitude / REFERENCE_MOMENT;
    if scale.is_finite() && scale > 0.0 {
        scale
    } else {
        1.0
    }
}

/// The backlash values the start's scan tries, every 0.05 from 0 to 1 (the search starts
/// from the best two): finer than the play's notch is wide at a window's start scanned
/// (a grid of 0, 0.5 and 1 ended beside it on the low mix's play of 0.1).
pub const SCAN_PLAYS: usize = 21;

/// The gain drifts the first scan tries, every 0.01 from 0 to 1, at each of
/// `SCAN_GAIN_PLAYS` and the guessed start: the needle is ±0.01 wide and its place hardly
/// moves with the start (three gains, 0.1, 0.5 and 0.9, missed it on most low-mix windows).
pub const SCAN_GAIN_STEPS: usize = 101;

/// The plays the gain drift is scanned at: a middle one, and none. On a gear with no play
/// the needle scanned at 0.5 alone can land off it (two of the light actuator's healthy-gear
/// windows were left `fitness_floor` that way; docs/in-flight.md).
const SCAN_GAIN_PLAYS: [f32; 2] = [0.5, 0.0];

/// Moments per play in the start's scan: the guess ± 10 steps of `SCAN_STEP`.
pub const SCAN_MOMENTS: usize = 21;

/// The scan's step [N·m].
const SCAN_STEP: f32 = 60.0;

/// Evaluations each Nelder–Mead search spends at most.
pub const SEARCH_EVALUATIONS: u32 = 300;

/// Evaluations of the central-difference curvature: at two step sizes, the centre, two per
/// parameter and four per pair each.
pub const CURVATURE_EVALUATIONS: u32 = 2 * 19;

/// Evaluations of the coupling to the held values at most: four per pair of a search
/// parameter (backlash, gain drift, start) and a held component whose value carries an
/// error ([`HeldComponents::covariance`]).
pub const COUPLING_EVALUATIONS: u32 = 4 * 3 * (FAULT_COUNT - FREE.len()) as u32;

/// Evaluations of one pinned identification at most.
pub const PINNED_EVALUATIONS: u32 = (SCAN_GAIN_PLAYS.len() * SCAN_GAIN_STEPS) as u32
    + (SCAN_GAIN_PLAYS.len() * SCAN_PLAYS * SCAN_MOMENTS) as u32
    + 2 * SCAN_GAIN_PLAYS.len() as u32 * SEARCH_EVALUATIONS
    + CURVATURE_EVALUATIONS
    + COUPLING_EVALUATIONS
    + 2
    + SCAN_MOMENTS as u32;

/// The central differences' steps: backlash, gain drift [fault-vector units], the start's
/// moment [`MOMENT_UNIT`]s.
const STEPS: [f32; 3] = [0.02, 0.01, 0.1];

/// The held values' steps in the coupling's differences, per component [fault-vector
/// units] (0: a free component); taken at the kept curvature's scale.
const HELD_STEPS: [f32; FAULT_COUNT] = [0.02, 0.0, 0.01, 0.01, 0.01, 0.02, 0.02, 0.0, 0.01];

/// The Nelder–Mead simplex's first edges, as [`STEPS`].
const SIMPLEX: [f32; 3] = [0.2, 0.1, 1.0];

/// How many times a pinned window's standard deviation per component must be taken beyond
/// what its curvature states (after the preflight's
/// [`INFLATION`](crate::solver::uncertainty::INFLATION)) for its 90 % interval to hold the truth in
/// 90 % of identified windows. The window factors' rule — each component's 90th percentile
/// of |error| / σ over [`Z90`](crate::solver::uncertainty::Z90), rounded up to a tenth where above
/// one — on Table II in cruise, selection seeds 10–29, light and moderate turbulence, flights
/// of eight (`campaign --flight --table 2 --phase cruise --runs 20 --first-seed 10
/// --flight-windows 8`): 450 windows read pinned under [`PinnedLimits::REFERENCE`] — the
/// backlash ×1.11 → **1.2**, the gain drift ×0.53 (left). The others are held.
pub const PINNED_INFLATION: [f32; FAULT_COUNT] = [1.0, 1.2, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0];

/// What a pinned window must satisfy to be identified.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PinnedLimits {
    /// The largest [`WindowProblem::misfit`] of an identified pinned window beyond the
    /// share its surface sensor's own error leaves ([`PinnedReading::sensor_floor`]).
    pub max_misfit: f32,
    /// The smallest excess of the play's other end's error (the farther bound, its start
    /// scanned) over the found one's, over the found one's: below it the window cannot tell
    /// a wide play from none.
    pub min_play_contrast: f32,
    /// The largest backlash standard deviation (after [`PINNED_INFLATION`])
    /// [fault-vector units]: beyond it the window did not cross its play enough to read it.
    pub max_backlash_std: f32,
}

impl PinnedLimits {
    /// The limits of the built-in actuator's flight campaign. The misfit's on the selection
    /// of [`PINNED_INFLATION`] (788 windows at the load model's floor with a trusted
    /// preflight, tried at a limit of 3 %: 457 read): 446 of them fit within 0.3 % of the
    /// current's energy, 450 within **0.5 %**, one of those off by more than four
    /// deviations (backlash 0.42 for 1.0: a basin the search ended in); of the 7 between
    /// 0.5 and 3 %, 5 are off by 4–8 deviations (the fit biased) — one such window in a
    /// flight of eight makes the flight `unconfirmed`. The play's contrast is the load
    /// model's limit ([`WindowLimits::REFERENCE`](crate::flight::window::WindowLimits::REFERENCE)),
    /// not chosen anew: added after Table I's evaluation seeds 0–3 read windows of the
    /// halved and the doubled gain `within` with the play at 0.07–0.98 (e_tot 2.6–35 %),
    /// their fit as good at either end of the play (docs/in-flight.md's study: the
    /// halved gain's windows search to a play of 1.0 on every seed). The backlash
    /// deviation's limit is a guard, not a choice: a curvature that does not determine the
    /// play is NaN.
    pub const REFERENCE: Self = Self {
        max_misfit: 0.005,
        min_play_contrast: 1.0,
        max_backlash_std: 0.1,
    };
}

/// Why a window cannot be read pinned at all.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PinnedError {
    /// The window holds nothing from a preflight: the friction has no value to be held at.
    NoPreflight,
    /// The surface's samples do not cover the window.
    SurfaceTooShort,
}

/// What the pinned identification of one window found ([`identify_pinned`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PinnedReading {
    /// The vector: [`FREE`] read, every other component at the preflight's.
    pub faults: FaultVector,
    /// The fit at `faults` from `start_moment`: eq. (3) after the drift [A²·s].
    pub fit: WindowFit,
    /// The moment the run starts under [N·m] (where it starts in the play).
    pub start_moment: f32,
    /// [`WindowProblem::misfit`] of `fit`.
    pub misfit: f32,
    /// The share of the window's energy the surface sensor's own error leaves unexplained
    /// at `faults` (the misfit's excess on the surface with that error drawn again; 0
    /// without such a surface): added to [`PinnedLimits::max_misfit`] in the verdict.
    pub sensor_floor: f32,
    /// The Gauss–Newton sums of [`FREE`] at `faults` (the start's moment and the drift
    /// profiled out; every other row and column zero): what a flight's reading adds.
    pub curvature: Curvature,
    /// How the backlash and the gain drift lean on the held values (the friction among
    /// them) at `faults`, the start profiled out: with the held values' covariance, what a
    /// flight's reading takes of their error (zero columns where a held value has none).
    pub coupling: HeldCoupling,
    /// The standard deviation per component the held values' error adds
    /// ([`HeldComponents::shared_std`]), already in `uncertainty`.
    pub shared_std: [f32; FAULT_COUNT],
    /// Standard deviation and 90 % interval per component (NaN: held, not read here) with
    /// the correlations; `None` if the curvature is not positive.
    pub uncertainty: Option<(Uncertainty, [[f32; FAULT_COUNT]; FAULT_COUNT])>,
    /// The window's verdict under the limits it was judged with.
    pub verdict: Result<(), WindowReason>,
    /// Monitor-model runs spent.
    pub evaluations: u32,
}

/// A point of the search: backlash, gain drift, the start's moment in [`MOMENT_UNIT`]s.
type Point = [f32; 3];

/// The pinned window's objective: one evaluation per call, counted.
struct Objective<'p, 'a, const N: usize> {
    problem: &'p WindowProblem<'a, N>,
    surface: &'p SurfaceSamples<'p>,
    base: FaultVector,
    stiffness: f32,
    /// The start moment's unit on this actuator [N·m] ([`MOMENT_UNIT`] × [`moment_scale`]).
    unit: f32,
    evaluations: u32,
}

impl<const N: usize> Objective<'_, '_, N> {
    /// The vector of point `x` (its components clamped into the box).
    fn vector(&self, x: &Point) -> FaultVector {
        let mut genes = *self.base.as_array();
        for (&i, &v) in FREE.iter().zip(x) {
            if let Some(g) = genes.get_mut(i) {
                *g = v;
            }
        }
        FaultVector::saturating(genes)
    }

    fn fit(&mut self, x: &Point) -> WindowFit {
        self.fit_on(self.problem, x)
    }

    /// [`Self::fit`] on `problem` (this window with other held values).
    fn fit_on(&mut self, problem: &WindowProblem<'_, N>, x: &Point) -> WindowFit {
        self.fit_pinned_to(problem, x, self.surface)
    }

    /// [`Self::fit_on`] with the surface pinned to `surface` (another draw of its sensor).
    fn fit_pinned_to(
        &mut self,
        problem: &WindowProblem<'_, N>,
        x: &Point,
        surface: &SurfaceSamples<'_>,
    ) -> WindowFit {
        self.evaluations = self.evaluations.saturating_add(1);
        let load = WindowLoad::spring(self.stiffness, x[2] * self.unit);
        problem
            .evaluate_with_surface_samples(&self.vector(x), load, surface, &mut [])
            .0
    }

    /// The error at `x`, with a point outside the box paid for by its squared distance
    /// from it in units of the window's energy (so the search comes back).
    fn error(&mut self, x: &Point) -> f32 {
        let outside: f32 = x[..2]
            .iter()
            .map(|&v| {
                let d = v - v.clamp(0.0, 1.0);
                d * d
            })
            .sum();
        let e = self.fit(x).error;
        let energy = self.problem.energy();
        if e.is_finite() {
            e + outside * energy
        } else {
            f32::INFINITY
        }
    }
}

/// Reads the backlash and the gain drift of the window of `problem` with its surface pinned
/// to `surface` (the sensor's angle and speed per sample; the motor's angle unused), every
/// other component at `held`'s values and the friction at the preflight's beside them (the
/// preflight whose reading `held` holds), the run's spring at `stiffness` [N·m/rad] and its
/// start scanned around `start_guess` [N·m]; judged under `limits`, the misfit's limit
/// raised by the sensor's floor measured on `redrawn` — the same surface with the sensor's
/// error drawn again on its angles, its speeds from them as `surface`'s (`None`: no
/// floor). At most
/// [`PINNED_EVALUATIONS`] model runs; `Err` when `held` holds nothing (no preflight) or the
/// surface's samples (or `redrawn`'s) end before the window.
pub fn identify_pinned<const N: usize>(
    problem: &WindowProblem<'_, N>,
    surface: &SurfaceSamples<'_>,
    redrawn: Option<&SurfaceSamples<'_>>,
    held: &HeldComponents,
    stiffness: f32,
    start_guess: f32,
    limits: &PinnedLimits,
) -> Result<PinnedReading, PinnedError> {
    if !held.holds(2) {
        return Err(PinnedError::NoPreflight);
    }
    let samples = problem.samples();
    let covers = |s: &SurfaceSamples<'_>| s.angles.len() >= samples && s.speeds.len() >= samples;
    if !covers(surface) || !redrawn.is_none_or(covers) {
        return Err(PinnedError::SurfaceTooShort);
    }
    let held = held.also_holding(FRICTION);
    let problem = problem.clone().with_held(held);
    let mut f = Objective {
        problem: &problem,
        surface,
        base: held.apply(&FaultVector::NOMINAL),
        stiffness,
        unit: MOMENT_UNIT * moment_scale(stiffness, problem.model().command().amplitude),
        evaluations: 0,
    };
    // The gain drift's needle: its whole range at the guessed start, at a middle play and
    // at none (a needle found at one play can lie off it at the other).
    let centre = start_guess / f.unit;
    let [at_middle, at_none] = SCAN_GAIN_PLAYS.map(|play| {
        let mut gain = (0.5, f32::INFINITY);
        for n in 0..SCAN_GAIN_STEPS {
            let g = n as f32 / (SCAN_GAIN_STEPS - 1) as f32;
            let e = f.error(&[play, g, centre]);
            if e < gain.1 {
                gain = (g, e);
            }
        }
        gain.0
    });
    // The start's scan at each gain found (once when both plays found the same): the best
    // moment at each play; Nelder–Mead from each grid's two best points, the best end kept
    // (the middle play's grid first: with one gain, the search as it was).
    let gains = [Some(at_middle), (at_none != at_middle).then_some(at_none)];
    let mut found: (Point, f32) = ([0.0; 3], f32::INFINITY);
    for gain in gains.into_iter().flatten() {
        let mut best: [(Point, f32); SCAN_PLAYS] = [([0.0; 3], f32::INFINITY); SCAN_PLAYS];
        for (n, slot) in best.iter_mut().enumerate() {
            let play = n as f32 / (SCAN_PLAYS - 1) as f32;
            for j in 0..SCAN_MOMENTS {
                let step = j as f32 - (SCAN_MOMENTS / 2) as f32;
                let x = [play, gain, centre + step * SCAN_STEP / MOMENT_UNIT];
                let e = f.error(&x);
                if e < slot.1 {
                    *slot = (x, e);
                }
            }
        }
        best.sort_unstable_by(|a, b| a.1.total_cmp(&b.1));
        if found.1 == f32::INFINITY {
            found.0 = best[0].0;
        }
        for (start, _) in best.iter().take(2) {
            let x = nelder_mead(&mut f, *start, SEARCH_EVALUATIONS);
            if x.1 < found.1 {
                found = x;
            }
        }
    }
    let mut x = found.0;
    x[0] = x[0].clamp(0.0, 1.0);
    x[1] = x[1].clamp(0.0, 1.0);
    let fit = f.fit(&x);
    let faults = f.vector(&x);
    let fine = curvature(&mut f, &x, fit.error, 1.0);
    let coarse = curvature(&mut f, &x, fit.error, 2.0);
    let (curvature, raw, scale) = wider(fine, coarse);
    // The held values' error (the preflight's friction among them) moves the backlash and
    // the gain drift found beside them alike in every window of the flight: carried into
    // the deviations, not widened.
    let coupling = held_coupling(&mut f, &x, &raw, scale);
    let shared_std = HeldComponents::sensitivity(&curvature, &coupling)
        .map_or([0.0; FAULT_COUNT], |a| held.shared_std(&a));
    let uncertainty = curvature.uncertainty(&faults).ok().map(|(u, c)| {
        (
            u.widened(&faults, &PINNED_INFLATION)
                .with_shared(&faults, &shared_std),
            c,
        )
    });
    let misfit = problem.misfit(fit.error);
    // What the sensor's own error leaves: the found point's misfit grows by as much again
    // when that error is drawn a second time (the two draws independent, their effects on
    // the current add in energy).
    let sensor_floor = redrawn.map_or(0.0, |r| {
        let again = f.fit_pinned_to(&problem, &x, r);
        let excess = problem.misfit(again.error) - misfit;
        if excess.is_finite() && excess > 0.0 {
            excess
        } else {
            0.0
        }
    });
    // The play's other end: the farther bound at the same gain drift, the start scanned.
    let other = if x[0] > 0.5 { 0.0 } else { 1.0 };
    let mut other_error = f32::INFINITY;
    for j in 0..SCAN_MOMENTS {
        let step = j as f32 - (SCAN_MOMENTS / 2) as f32;
        let e = f.error(&[other, x[1], x[2] + step * SCAN_STEP / MOMENT_UNIT]);
        other_error = other_error.min(e);
    }
    let contrast = (other_error - fit.error) / fit.error.max(f32::MIN_POSITIVE);
    let verdict = judge(
        limits,
        misfit,
        sensor_floor,
        contrast,
        uncertainty.as_ref().map(|(u, _)| u),
    );
    Ok(PinnedReading {
        faults,
        fit,
        start_moment: x[2] * f.unit,
        misfit,
        sensor_floor,
        curvature,
        coupling,
        shared_std,
        uncertainty,
        verdict,
        evaluations: f.evaluations,
    })
}

/// The verdict of a pinned window: its misfit beyond its sensor's floor under the limit
/// (the whole misfit reported when it is not), the play's other end
/// fitting worse by `contrast` (its error's excess over the found one's, over the found
/// one's), its backlash read.
fn judge(
    limits: &PinnedLimits,
    misfit: f32,
    sensor_floor: f32,
    contrast: f32,
    uncertainty: Option<&Uncertainty>,
) -> Result<(), WindowReason> {
    if misfit.is_nan() || misfit - sensor_floor > limits.max_misfit {
        return Err(WindowReason::FitnessFloor { misfit });
    }
    if contrast.is_nan() || contrast < limits.min_play_contrast {
        return Err(WindowReason::PlayUnseen { contrast });
    }
    let backlash_std = uncertainty
        .and_then(|u| u.std.get(FREE[0]).copied())
        .unwrap_or(f32::NAN);
    if backlash_std.is_nan() || backlash_std > limits.max_backlash_std {
        return Err(WindowReason::PlayUnseen { contrast: f32::NAN });
    }
    Ok(())
}

/// Of two curvatures of the same point ([`curvature`]'s), the one that states the larger
/// variance: `b` when its profiled 2 × 2 block of [`FREE`] has the smaller determinant or
/// `a`'s is not positive definite (a Hessian the play's crossings make rough at one step
/// size reads as information it does not carry); empty when neither is positive definite.
#[allow(clippy::indexing_slicing)] // FREE's indices < FAULT_COUNT
fn wider(a: Sums, b: Sums) -> Sums {
    let det = |c: &Curvature| {
        let (p, q, r) = (
            c.normal[FREE[0]][FREE[0]],
            c.normal[FREE[0]][FREE[1]],
            c.normal[FREE[1]][FREE[1]],
        );
        if p > 0.0 && r > 0.0 && p * r - q * q > 0.0 {
            p * r - q * q
        } else {
            f64::NAN
        }
    };
    match (det(&a.0), det(&b.0)) {
        (x, y) if x.is_nan() && y.is_nan() => (Curvature::EMPTY, [[0.0; 3]; 3], b.2),
        (x, _) if x.is_nan() => b,
        (_, y) if y.is_nan() => a,
        (x, y) if y < x => b,
        _ => a,
    }
}

/// A curvature of [`FREE`], the unprofiled 3 × 3 sums it came from (backlash, gain drift,
/// start) and the scale of [`STEPS`] it was taken at.
type Sums = (Curvature, [[f64; 3]; 3], f32);

/// Where a point's differences at `steps` are centred: `x` moved into the box where a step
/// would leave it.
fn centred(x: &Point, steps: &[f32; 3]) -> Point {
    let mut c = *x;
    for (v, s) in c.iter_mut().zip(steps).take(2) {
        *v = v.clamp(*s, 1.0 - *s);
    }
    c
}

/// The Gauss–Newton sums of [`FREE`] at `x` (error `error`) from the error's central
/// differences at `scale` times [`STEPS`], `JᵀWJ = H / (2·dt)`, the start's moment profiled
/// out (Schur complement); the differences' centre moved into the box where a step would
/// leave it; `JᵀW r` left at zero (below).
/// [`CURVATURE_EVALUATIONS`]` / 2` evaluations.
#[allow(clippy::indexing_slicing)] // indices < 3 on fixed 3-arrays, < FAULT_COUNT on 9-arrays
fn curvature<const N: usize>(
    f: &mut Objective<'_, '_, N>,
    x: &Point,
    error: f32,
    scale: f32,
) -> Sums {
    let steps = STEPS.map(|s| s * scale);
    let c = centred(x, &steps);
    let at = |f: &mut Objective<'_, '_, N>, d: [f32; 3]| -> f64 {
        let p = [c[0] + d[0], c[1] + d[1], c[2] + d[2]];
        f64::from(f.fit(&p).error)
    };
    let step = |i: usize, s: f32| -> [f32; 3] {
        let mut d = [0.0; 3];
        d[i] = s * steps[i];
        d
    };
    let e0 = at(f, [0.0; 3]);
    let mut hessian = [[0.0f64; 3]; 3];
    for i in 0..3 {
        let h = f64::from(steps[i]);
        let up = at(f, step(i, 1.0));
        let down = at(f, step(i, -1.0));
        hessian[i][i] = (up - 2.0 * e0 + down) / (h * h);
    }
    for i in 0..3 {
        for j in i + 1..3 {
            let pair = |si: f32, sj: f32| {
                let mut d = step(i, si);
                d[j] = sj * steps[j];
                d
            };
            let pp = at(f, pair(1.0, 1.0));
            let pm = at(f, pair(1.0, -1.0));
            let mp = at(f, pair(-1.0, 1.0));
            let mm = at(f, pair(-1.0, -1.0));
            let h = (pp - pm - mp + mm) / (4.0 * f64::from(steps[i]) * f64::from(steps[j]));
            hessian[i][j] = h;
            hessian[j][i] = h;
        }
    }
    let dt = f64::from(f.problem.model().params().control_period);
    let normal = hessian.map(|row| row.map(|h| h / (2.0 * dt)));
    // The start's moment profiled out.
    let mut out = Curvature::EMPTY;
    let m = normal[2][2];
    for (a, &i) in FREE.iter().enumerate() {
        let lean = if m > 0.0 { normal[a][2] / m } else { 0.0 };
        // No gradient (`JᵀW r` = 0): the search's end is taken as the minimum. Inside the
        // box the central differences' gradient is their noise (the play's crossings make
        // the error rough at these steps): as a step for the flight's reading
        // (`crate::flight::fusion`) it moved a window's point by up to 18 deviations on the
        // selection seeds; carried to a bound along the Hessian it is that noise
        // extrapolated (the healthy actuator's and Table II high's flights with a pinned
        // window were `unconfirmed` on seeds 0–9 with it). A component read at its bound
        // stays there.
        out.gradient[i] = 0.0;
        for (b, &j) in FREE.iter().enumerate() {
            out.normal[i][j] = normal[a][b] - lean * normal[2][b];
        }
    }
    out.rss = f64::from(error) / dt;
    out.fitted = f.problem.fitted_samples() as u32;
    (out, normal, scale)
}

/// How the search's parameters at `x` lean on each held value that carries an error: the
/// error's mixed central differences between a parameter (at `scale` times [`STEPS`]) and
/// the held value (at `scale` times [`HELD_STEPS`], centred into the box), over `2·dt`, the
/// start profiled out with `raw`'s (the kept curvature's) sums: rows [`FREE`], columns the
/// held components, as the load model's [`HeldCoupling`]. At most [`COUPLING_EVALUATIONS`]
/// evaluations.
#[allow(clippy::indexing_slicing)] // indices < 3 on fixed 3-arrays, < FAULT_COUNT on 9-arrays
fn held_coupling<const N: usize>(
    f: &mut Objective<'_, '_, N>,
    x: &Point,
    raw: &[[f64; 3]; 3],
    scale: f32,
) -> HeldCoupling {
    let steps = STEPS.map(|s| s * scale);
    let c = centred(x, &steps);
    let held = *f.problem.held();
    let dt = f64::from(f.problem.model().params().control_period);
    let mut out = HeldCoupling::NONE;
    for (h, &step) in HELD_STEPS.iter().enumerate() {
        let s = step * scale;
        if !held.holds(h) || s <= 0.0 || held.covariance()[h][h] <= 0.0 {
            continue;
        }
        let value = held.value(h);
        let centre = value.clamp(s, 1.0 - s) - value;
        let up = f.problem.clone().with_held(held.shifted(h, centre + s));
        let down = f.problem.clone().with_held(held.shifted(h, centre - s));
        let mut cross = [0.0f64; 3];
        for (a, cross) in cross.iter_mut().enumerate() {
            let mut at = |p: &WindowProblem<'_, N>, sign: f32| {
                let mut q = c;
                q[a] += sign * steps[a];
                f64::from(f.fit_on(p, &q).error)
            };
            let e = at(&up, 1.0) - at(&up, -1.0) - at(&down, 1.0) + at(&down, -1.0);
            *cross = e / (4.0 * f64::from(steps[a]) * f64::from(s)) / (2.0 * dt);
        }
        let m = raw[2][2];
        let lean = if m > 0.0 { cross[2] / m } else { 0.0 };
        for (a, &i) in FREE.iter().enumerate() {
            out.normal[i][h] = cross[a] - raw[a][2] * lean;
        }
    }
    out
}

/// Nelder–Mead from `start` (edges [`SIMPLEX`]) over `f`, at most `budget` evaluations: the
/// best point and its error.
#[allow(clippy::indexing_slicing)] // indices < 4 on the fixed simplex
fn nelder_mead<const N: usize>(
    f: &mut Objective<'_, '_, N>,
    start: Point,
    budget: u32,
) -> (Point, f32) {
    let mut simplex = [(start, 0.0f32); 4];
    for (j, vertex) in simplex.iter_mut().enumerate() {
        if j > 0 {
            vertex.0[j - 1] += SIMPLEX[j - 1];
        }
        vertex.1 = f.error(&vertex.0);
    }
    let mut used = 4u32;
    while used + 5 <= budget {
        simplex.sort_unstable_by(|a, b| a.1.total_cmp(&b.1));
        let mut centre = [0.0f32; 3];
        for (x, _) in &simplex[..3] {
            for d in 0..3 {
                centre[d] += x[d] / 3.0;
            }
        }
        let worst = simplex[3];
        let along = |t: f32| -> Point {
            core::array::from_fn(|d| centre[d] + t * (worst.0[d] - centre[d]))
        };
        let r = along(-1.0);
        let fr = f.error(&r);
        used += 1;
        if fr < simplex[0].1 {
            let e = along(-2.0);
            let fe = f.error(&e);
            used += 1;
            simplex[3] = if fe < fr { (e, fe) } else { (r, fr) };
        } else if fr < simplex[2].1 {
            simplex[3] = (r, fr);
        } else {
            let c = along(0.5);
            let fc = f.error(&c);
            used += 1;
            if fc < worst.1 {
                simplex[3] = (c, fc);
            } else {
                let best = simplex[0].0;
                for vertex in simplex.iter_mut().skip(1) {
                    for (v, b) in vertex.0.iter_mut().zip(best) {
                        *v = b + 0.5 * (*v - b);
                    }
                    vertex.1 = f.error(&vertex.0);
                }
                used += 3;
            }
        }
    }
    simplex.sort_unstable_by(|a, b| a.1.total_cmp(&b.1));
    simplex[0]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_start_moments_scale_follows_the_actuators_spring() {
        // The built-in actuator: exactly the unit the search was set at (its bits kept).
        let built_in = crate::physics::params::ActuatorParams::REFERENCE.aero_stiffness;
        let amplitude = crate::ChirpCommand::PREFLIGHT.amplitude;
        assert_eq!(moment_scale(built_in, amplitude), 1.0);
        // A trim tab's spring (10 N·m at the chirp's 5 mrad against 250): 1/25 of it.
        assert!((moment_scale(2.0e3, amplitude) - 0.04).abs() < 1e-6);
        // Twice the amplitude, twice the moments; no spring: the built-in unit.
        assert!((moment_scale(built_in, 2.0 * amplitude) - 2.0).abs() < 1e-6);
        assert_eq!(moment_scale(0.0, amplitude), 1.0);
        assert_eq!(moment_scale(f32::NAN, amplitude), 1.0);
    }
}
