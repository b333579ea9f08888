//! The fitness of a candidate fault vector, paper eq. (3) (the calibration it subtracts lives
//! in [`crate::model::calibration`]).
//!
//! `err(k) = dt · Σ_i (I_r,i − I_m,i(k))² / ((ΔI_r,i)²/κ + 1) − residual`, with `I_r` the
//! filtered measured equivalent current, `I_m` the monitor model's current through the same
//! filter, `ΔI_r,i` the sample-to-sample change of `I_r` and κ its mean square (the
//! derivative normalisation; using differences instead of derivatives is the same ratio).
//!
//! A test with a standstill segment adds, for its fitted samples (they come first, after the
//! unfitted settle), `dt · w · Σ (I_r,i − I_m,i)²` with `w` = [`STANDSTILL_WEIGHT`]; κ and
//! the eq. (3) sum run over the chirp only, so the paper's test keeps its bits.
//! Units: A²·s. One evaluation = one monitor-model run over the measured samples: O(N), no
//! allocation, never panics; a non-finite result cannot occur for finite inputs and is
//! reported as `+∞` by [`FitnessProblem::error`] if it ever did. A bounded evaluation
//! ([`FitnessProblem::error_below`]) stops as soon as the candidate provably cannot beat the
//! bound, with the same result below it.

use core::ops::ControlFlow;

use crate::model::calibration::Calibration;
use crate::model::conditions::TestConditions;
use crate::model::monitor::{MonitorModel, MonitorRun, MonitorSample, SampleSink};
use crate::physics::fault::{FaultVector, FAULT_COUNT};
use crate::physics::magnets::WeakMagnet;
use crate::physics::params::ActuatorParams;
use crate::solver::ga::Problem;
use crate::solver::uncertainty::{Curvature, SystematicError, Uncertainty, UncertaintyError, STEP};
#[cfg(feature = "command-table")]
use crate::test::command::CommandTable;
use crate::test::command::{ChirpSampler, CommandSource};
use crate::test::conditioning::{ConditioningError, LowPassState, MeasuredCurrent};

/// Why a fitness problem could not be set up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FitnessError {
    /// The measured current is not usable (not finished, too short, …).
    Measured(ConditioningError),
    /// A command table that does not sample the model's command at its control period.
    CommandTableMismatch,
}

impl From<ConditioningError> for FitnessError {
    fn from(e: ConditioningError) -> Self {
        Self::Measured(e)
    }
}

/// Eq. (3) over one measured test: the problem the GA minimises.
#[derive(Clone, Debug)]
pub struct FitnessProblem<'a, const N: usize> {
    measured: &'a MeasuredCurrent<N>,
    model: MonitorModel,
    inv_kappa: f32,
    standstill_weight: f32,
    nominal_residual: f32,
    conditions: TestConditions,
    #[cfg(feature = "command-table")]
    command_table: Option<&'a CommandTable<N>>,
}

/// Weight of the standstill segment's squared residual against the chirp's eq. (3) terms.
/// The segment's currents are ~0.2 A against the chirp's amperes and its model (an R–L
/// circuit) is nearly exact, so its residual must weigh far more per sample than the
/// chirp's, whose floor is the monitor model's ~3 % structural mismatch. Chosen by the
/// predicted mismatch error over the paper's Table I and II (`host-sim identifiability
/// --bias --weights …`, docs/identifiability.md): 100 and 300 tie (sums 13.8 and 13.9 % over
/// the 19 cases, 8 seeds), 10 and 1 000 are clearly worse (18.3, 15.5 %); 300 won a 4-seed
/// run. No random vector was used to choose it.
pub const STANDSTILL_WEIGHT: f32 = 300.0;

/// Samples between two checks of the partial error against the bound in
/// [`FitnessProblem::error_below`] (10 ms of the test).
pub const BOUND_CHECK_INTERVAL: u32 = 100;

impl<'a, const N: usize> FitnessProblem<'a, N> {
    /// The fitness of the monitor model of `params`, calibrated by `calibration`, against a
    /// finished measured current, on the test's day as [`TestConditions::estimate`] finds
    /// it (winding temperature from the injection, friction from the measured temperature).
    pub fn new(
        measured: &'a MeasuredCurrent<N>,
        params: ActuatorParams,
        calibration: &Calibration,
    ) -> Result<Self, FitnessError> {
        let conditions = TestConditions::estimate(measured, &params, calibration);
        Self::on_day(measured, params, calibration, conditions)
    }

    /// The same problem on a day the caller gives (the calibration's own, for the fit that
    /// makes the calibration).
    pub fn on_day(
        measured: &'a MeasuredCurrent<N>,
        params: ActuatorParams,
        calibration: &Calibration,
        conditions: TestConditions,
    ) -> Result<Self, FitnessError> {
        Ok(Self {
            measured,
            model: MonitorModel::new(params, calibration)
                .with_test(measured.test())
                .with_conditions(&conditions),
            inv_kappa: measured.inv_kappa()?,
            standstill_weight: STANDSTILL_WEIGHT,
            nominal_residual: calibration.nominal_residual,
            conditions,
            #[cfg(feature = "command-table")]
            command_table: None,
        })
    }

    /// The calibration's healthy mismatch this fitness subtracts [A²·s].
    pub fn nominal_residual(&self) -> f32 {
        self.nominal_residual
    }

    pub fn model(&self) -> &MonitorModel {
        &self.model
    }

    /// The day the problem's model plays.
    pub fn conditions(&self) -> &TestConditions {
        &self.conditions
    }

    /// What the test shows of a moment on the surface beyond its spring, with `offset` the
    /// [`CurvatureRun::load_offset`] at the identified vector (NaN without them;
    /// [`crate::model::domain::Domain::with_load`]). O(1).
    pub fn load_signs(&self, offset: f32) -> crate::model::domain::LoadSigns {
        let p = self.model.params();
        let chirp = self.model.command().amplitude;
        crate::model::domain::LoadSigns {
            offset,
            standstill: self.measured.standstill_travel() / (p.gear_ratio * chirp),
        }
    }

    /// The same problem with the day's healthy friction a nuisance down to `floor` times its
    /// estimate ([`MonitorModel::with_friction_floor`]).
    pub fn with_friction_floor(mut self, floor: f32) -> Self {
        self.model = self.model.with_friction_floor(floor);
        self
    }

    /// Sets the weak magnet the problem's model plays ([`MonitorModel::with_magnets`]): the
    /// weak-magnet search evaluates its candidates so. O(1).
    pub fn set_magnets(&mut self, magnets: WeakMagnet) {
        self.model = self.model.with_magnets(magnets);
    }

    /// The problem's model on a drive that slews to its current reference's steps of mean
    /// square `power` \[A²\] ([`MonitorModel::with_reference_steps`]; for studies of the
    /// noise's lean). O(1).
    pub fn set_reference_steps(&mut self, power: f32) {
        self.model = self.model.with_reference_steps(power);
    }

    /// The same problem with another standstill weight (for studies of the weight).
    pub fn with_standstill_weight(mut self, weight: f32) -> Self {
        self.standstill_weight = weight;
        self
    }

    /// Drives the monitor model with the precomputed `table` instead of evaluating the chirp
    /// at each step: the same bits, less work per step. Refused unless the table samples this
    /// model's command at its control period.
    #[cfg(feature = "command-table")]
    pub fn with_command_table(mut self, table: &'a CommandTable<N>) -> Result<Self, FitnessError> {
        let period = self.model.params().control_period;
        if table.command() != self.model.command() || table.period().to_bits() != period.to_bits() {
            return Err(FitnessError::CommandTableMismatch);
        }
        self.command_table = Some(table);
        Ok(self)
    }

    /// Eq. (3) without the residual subtracted [A²·s]. `+∞` if the sum is not finite.
    pub fn raw_error(&self, k: &FaultVector) -> f32 {
        self.raw_error_until(k, f32::INFINITY)
    }

    /// Eq. (3) with the calibrated nominal residual subtracted [A²·s].
    pub fn error(&self, k: &FaultVector) -> f32 {
        self.raw_error(k) - self.nominal_residual
    }

    /// [`error`](Self::error) if it is below `bound`; otherwise a value `≥ bound`, returned
    /// as soon as the partial sum proves it (checked every [`BOUND_CHECK_INTERVAL`]
    /// samples). Every term of the sum is non-negative and rounding is monotone, so the
    /// partial error never exceeds the full one: below `bound` the result is bit for bit
    /// [`error`](Self::error).
    pub fn error_below(&self, k: &FaultVector, bound: f32) -> f32 {
        self.raw_error_until(k, bound) - self.nominal_residual
    }

    /// The raw error, stopping once `partial·dt − residual ≥ bound`.
    fn raw_error_until(&self, k: &FaultVector, bound: f32) -> f32 {
        #[cfg(feature = "command-table")]
        if let Some(table) = self.command_table {
            return self.raw_error_with(k, bound, table);
        }
        self.raw_error_with(k, bound, &self.model.sampler())
    }

    /// The commanded user angle of chirp sample `index` at `time` [rad], from the table if
    /// there is one, else from `sampler`. O(1).
    fn command_at(&self, sampler: &ChirpSampler, index: usize) -> f32 {
        #[cfg(feature = "command-table")]
        if let Some(table) = self.command_table {
            return table.position_at(index);
        }
        sampler.at(index)
    }

    /// [`raw_error_until`](Self::raw_error_until) reading the command from `command`. One
    /// instance per command source, each with its own sink closure called from one place, so
    /// that the compiler inlines the sink into the model's loop even when optimising for size.
    #[inline(always)]
    fn raw_error_with(&self, k: &FaultVector, bound: f32, command: &impl CommandSource) -> f32 {
        let reference = self.measured.samples();
        let dt = self.model.params().control_period;
        let mut sum = EquationThreeSum {
            filter: self.measured.filter(),
            filter_state: LowPassState::default(),
            reference: reference.iter(),
            previous: 0.0,
            sum: 0.0,
            until_check: BOUND_CHECK_INTERVAL,
            fitted: self
                .measured
                .test()
                .standstill
                .map_or((0, 0), |s| (s.settle_samples as usize, s.samples())),
            lead: self.measured.lead_samples(),
            index: 0,
            standstill_weight: self.standstill_weight,
            inv_kappa: self.inv_kappa,
            // `sum·dt − residual ≥ bound`, as the sum is checked.
            dt,
            nominal_residual: self.nominal_residual,
            bound,
        };
        let start = self.measured.initial_angles();
        self.model
            .run_with(k, start, reference.len(), command, &mut sum);
        let err = sum.sum * dt;
        if err.is_finite() {
            err
        } else {
            f32::INFINITY
        }
    }
}

/// The running sum of eq. (3) over a run, fed sample by sample: the standstill segment's
/// weighted squares, then the chirp's normalised ones; every [`BOUND_CHECK_INTERVAL`] samples
/// it breaks the run once `sum·dt − residual ≥ bound`. A struct rather than a closure so that
/// its `take` is inlined into both of the run's loops and its state kept in registers.
struct EquationThreeSum<'r> {
    filter: &'r crate::test::conditioning::LowPass,
    filter_state: LowPassState,
    reference: core::slice::Iter<'r, f32>,
    previous: f32,
    sum: f32,
    until_check: u32,
    /// The standstill segment's fitted samples, `fitted.0 ≤ index < fitted.1` (empty
    /// without a segment): its `fitted` as two compares.
    fitted: (usize, usize),
    lead: usize,
    index: usize,
    standstill_weight: f32,
    inv_kappa: f32,
    dt: f32,
    nominal_residual: f32,
    bound: f32,
}

impl SampleSink for &mut EquationThreeSum<'_> {
    #[inline(always)]
    fn take(&mut self, s: &MonitorSample) -> ControlFlow<()> {
        let modelled = self.filter.apply(&mut self.filter_state, s.current);
        if let Some(&r) = self.reference.next() {
            let e = r - modelled;
            if self.index < self.lead {
                if self.index >= self.fitted.0 && self.index < self.fitted.1 {
                    self.sum += self.standstill_weight * e * e;
                }
                self.index += 1;
            } else {
                let d = r - self.previous;
                self.previous = r;
                self.sum += e * e / (d * d * self.inv_kappa + 1.0);
            }
        }
        self.until_check -= 1;
        if self.until_check == 0 {
            self.until_check = BOUND_CHECK_INTERVAL;
            if self.sum * self.dt - self.nominal_residual >= self.bound {
                return ControlFlow::Break(());
            }
        }
        ControlFlow::Continue(())
    }
}

impl<const N: usize> FitnessProblem<'_, N> {
    /// Starts the Gauss–Newton sums at `k` ([`crate::solver::uncertainty`]): the base run and one run
    /// per component shifted by [`crate::solver::uncertainty::STEP`] (down where up would leave
    /// [0, 1]), to be stepped in lockstep through the same filter and weights as the fitness
    /// by [`continue_curvature`](Self::continue_curvature). O(1).
    pub fn start_curvature(&self, k: &FaultVector) -> CurvatureRun {
        let mut run = CurvatureRun::IDLE;
        self.restart_curvature(&mut run, k);
        run
    }

    /// [`start_curvature`](Self::start_curvature) into an existing run, in place (no
    /// kilobyte temporaries on a small stack). O(1).
    #[inline(never)]
    pub fn restart_curvature(&self, run: &mut CurvatureRun, k: &FaultVector) {
        let base = *k.as_array();
        let start = self.measured.initial_angles();
        for (a, (slot, inv)) in run.shifts.iter_mut().zip(&mut run.inv_shifts).enumerate() {
            let x = base.get(a).copied().unwrap_or(0.0);
            *slot = if x + STEP <= 1.0 { STEP } else { -STEP };
            *inv = 1.0 / *slot;
        }
        for (j, slot) in run.runs.iter_mut().enumerate() {
            let mut g = base;
            if let (Some(x), Some(&h)) = (
                j.checked_sub(1).and_then(|a| g.get_mut(a)),
                j.checked_sub(1).and_then(|a| run.shifts.get(a)),
            ) {
                *x += h;
            }
            self.model
                .restart_run(slot, &FaultVector::saturating(g), start);
        }
        run.filters = [LowPassState::default(); FAULT_COUNT + 1];
        run.index = 0;
        run.previous = 0.0;
        run.sums = Curvature::EMPTY;
        run.block = BlockSums::ZERO;
        run.in_block = 0;
        run.chirp_residual = 0.0;
        run.chirp_power = 0.0;
        run.chirp_residual_sign = 0.0;
        run.chirp_sign = 0;
        run.chirp_moving = 0;
        run.chirp_samples = 0;
        run.previous_command = 0.0;
    }

    /// Advances `run` by at most `samples` samples (10 monitor-model steps and 45 f64
    /// multiply-adds each); the finished sums once every measured sample is done.
    #[allow(clippy::indexing_slicing, clippy::needless_range_loop)] // a, b < FAULT_COUNT, j ≤ FAULT_COUNT on fixed arrays
    #[inline(never)]
    pub fn continue_curvature(&self, run: &mut CurvatureRun, samples: usize) -> Option<Curvature> {
        let reference = self.measured.samples();
        let filter = self.measured.filter();
        let standstill = self.measured.test().standstill;
        let lead = self.measured.lead_samples();
        let end = run.index.saturating_add(samples).min(reference.len());
        let sampler = self.model.sampler();
        while run.index < end {
            let i = run.index;
            run.index += 1;
            let r = reference[i];
            // One command for all nine runs: they are at the same sample.
            let command = match run.runs[0].next_command_index(&self.model) {
                Some(c) => self.command_at(&sampler, c),
                None => 0.0,
            };
            let mut m = [0.0f32; FAULT_COUNT + 1];
            for (j, model) in run.runs.iter_mut().enumerate() {
                let sample = model.next_sample(&self.model, command);
                m[j] = filter.apply(&mut run.filters[j], sample.current);
            }
            let w = if i < lead {
                if standstill.is_some_and(|s| s.fitted(i)) {
                    self.standstill_weight
                } else {
                    0.0
                }
            } else {
                let d = r - run.previous;
                run.previous = r;
                1.0 / (d * d * self.inv_kappa + 1.0)
            };
            if w <= 0.0 {
                continue;
            }
            // f32 products summed in blocks of BLOCK samples, each block added to the f64
            // totals: the FPU's single precision per sample (no soft f64 on the Cortex-M4F),
            // the block sums' rounding bounded by BLOCK terms.
            let e = r - m[0];
            let d: [f32; FAULT_COUNT] =
                core::array::from_fn(|a| (m[a + 1] - m[0]) * run.inv_shifts[a]);
            let block = &mut run.block;
            if i >= lead {
                // The commanded direction: friction's sign, which the offset is told from.
                let s = i32::from(command > run.previous_command)
                    - i32::from(command < run.previous_command);
                run.previous_command = command;
                run.chirp_sign += s;
                run.chirp_moving += s.unsigned_abs();
                // In f32 (≤ 5 000 terms): a ratio for the domain check, not the fit.
                run.chirp_residual += e;
                run.chirp_power += r * r;
                run.chirp_residual_sign += e * s as f32;
                run.chirp_samples = run.chirp_samples.saturating_add(1);
            }
            block.rss += w * e * e;
            for a in 0..FAULT_COUNT {
                let wa = w * d[a];
                block.gradient[a] += wa * e;
                for b in a..FAULT_COUNT {
                    block.normal[a][b] += wa * d[b];
                }
            }
            run.sums.fitted = run.sums.fitted.saturating_add(1);
            run.in_block += 1;
            if run.in_block == CURVATURE_BLOCK {
                run.flush_block();
            }
        }
        if run.index < reference.len() {
            return None;
        }
        run.flush_block();
        let mut out = run.sums;
        for a in 0..FAULT_COUNT {
            for b in 0..a {
                out.normal[a][b] = out.normal[b][a];
            }
        }
        Some(out)
    }

    /// The Gauss–Newton sums at `k` in one go: 10 monitor-model runs, O(N · 9²).
    pub fn curvature(&self, k: &FaultVector) -> Curvature {
        let mut run = CurvatureRun::IDLE;
        self.curvature_in(&mut run, k)
    }

    /// [`curvature`](Self::curvature) in the caller's `run` (no 3.8 kB temporary).
    pub fn curvature_in(&self, run: &mut CurvatureRun, k: &FaultVector) -> Curvature {
        self.restart_curvature(run, k);
        loop {
            if let Some(c) = self.continue_curvature(run, usize::MAX) {
                return c;
            }
        }
    }

    /// A standard deviation, a 90 % interval and the correlations of each component of the
    /// identified `k` ([`crate::solver::uncertainty`], with the preflight's systematic error that
    /// the actuator's record carries). 10 monitor-model runs.
    pub fn uncertainty(
        &self,
        k: &FaultVector,
        systematic: &SystematicError,
    ) -> Result<(Uncertainty, [[f32; FAULT_COUNT]; FAULT_COUNT]), UncertaintyError> {
        self.curvature(k).preflight_uncertainty(k, systematic)
    }
}

/// The Gauss–Newton sums of one identified vector in progress ([`FitnessProblem::
/// start_curvature`]): 10 monitor-model runs and their filters, ≈ 4.5 kB.
#[derive(Clone, Debug)]
pub struct CurvatureRun {
    runs: [MonitorRun; FAULT_COUNT + 1],
    filters: [LowPassState; FAULT_COUNT + 1],
    shifts: [f32; FAULT_COUNT],
    inv_shifts: [f32; FAULT_COUNT],
    index: usize,
    previous: f32,
    sums: Curvature,
    /// The current block's sums in f32 ([`CURVATURE_BLOCK`] fitted samples at most).
    block: BlockSums,
    in_block: u32,
    /// Over the chirp: Σ r (measured − modelled at the identified vector) [A], Σ of the
    /// measured current squared [A²], Σ r·s, Σ s and Σ s² with s the commanded direction
    /// (±1, 0), the samples ([`CurvatureRun::load_offset`]).
    chirp_residual: f32,
    chirp_power: f32,
    chirp_residual_sign: f32,
    chirp_sign: i32,
    chirp_moving: u32,
    chirp_samples: u32,
    /// The previous chirp sample's command [rad].
    previous_command: f32,
}

/// Fitted samples summed in f32 before they join the f64 totals.
const CURVATURE_BLOCK: u32 = 64;

/// One block of the curvature's sums, in f32.
#[derive(Clone, Copy, Debug, PartialEq)]
struct BlockSums {
    normal: [[f32; FAULT_COUNT]; FAULT_COUNT],
    gradient: [f32; FAULT_COUNT],
    rss: f32,
}

impl BlockSums {
    const ZERO: Self = Self {
        normal: [[0.0; FAULT_COUNT]; FAULT_COUNT],
        gradient: [0.0; FAULT_COUNT],
        rss: 0.0,
    };
}

impl CurvatureRun {
    /// Every field zero, to be restarted ([`FitnessProblem::restart_curvature`]) before use:
    /// a `static` holding it lives in `.bss` and is never built on the stack (3.5 kB).
    pub const IDLE: Self = Self {
        runs: [MonitorRun::IDLE; FAULT_COUNT + 1],
        filters: [LowPassState::ZERO; FAULT_COUNT + 1],
        shifts: [0.0; FAULT_COUNT],
        inv_shifts: [0.0; FAULT_COUNT],
        index: 0,
        previous: 0.0,
        sums: Curvature::EMPTY,
        block: BlockSums::ZERO,
        in_block: 0,
        chirp_residual: 0.0,
        chirp_power: 0.0,
        chirp_residual_sign: 0.0,
        chirp_sign: 0,
        chirp_moving: 0,
        chirp_samples: 0,
        previous_command: 0.0,
    };

    /// The current the monitor model left unexplained over the chirp at the identified
    /// vector, its constant part as a share of the measured RMS, once the sums are finished
    /// (NaN without a chirp sample). The residual is fitted as `c + d·s` by least squares,
    /// `s` the commanded direction (±1, 0): a friction the model mis-sizes (a cold grease)
    /// leaves a residual that turns with the motion (`d`), a steady moment on the surface
    /// (wind on the parked aircraft) one that does not (`c`), which the position loop holds
    /// ([`crate::model::domain::Domain::with_load`]). O(1).
    #[inline(never)]
    pub fn load_offset(&self) -> f32 {
        // n·Σs² − (Σs)² keeps its digits in f32: the chirp moves both ways.
        let n = self.chirp_samples as f32;
        let s = self.chirp_sign as f32;
        let ss = self.chirp_moving as f32;
        let (r, rs) = (self.chirp_residual, self.chirp_residual_sign);
        let c = (r * ss - s * rs) / (n * ss - s * s);
        c / crate::base::math::sqrt(self.chirp_power / n)
    }

    /// Adds the block's f32 sums to the f64 totals and starts a new block (upper triangle
    /// of the normal matrix only). O(8²).
    #[allow(clippy::indexing_slicing, clippy::needless_range_loop)] // a, b < FAULT_COUNT
    fn flush_block(&mut self) {
        let (sums, block) = (&mut self.sums, &self.block);
        sums.rss += f64::from(block.rss);
        for a in 0..FAULT_COUNT {
            sums.gradient[a] += f64::from(block.gradient[a]);
            for b in a..FAULT_COUNT {
                sums.normal[a][b] += f64::from(block.normal[a][b]);
            }
        }
        self.block = BlockSums::ZERO;
        self.in_block = 0;
    }
}

impl<const N: usize> Problem for FitnessProblem<'_, N> {
    fn fitness(&mut self, genes: &[f32; FAULT_COUNT]) -> f32 {
        self.error(&FaultVector::saturating(*genes))
    }

    fn fitness_below(&mut self, genes: &[f32; FAULT_COUNT], bound: f32) -> f32 {
        self.error_below(&FaultVector::saturating(*genes), bound)
    }
}
