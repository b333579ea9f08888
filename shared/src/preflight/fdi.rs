//! The onboard FDI wired together: sizes, settings and the executor-free identification loop.
//!
//! Memory (checked by `host-sim footprint`): [`OnboardMeasured`] `4·TEST_SAMPLES` bytes +
//! [`OnboardGa`] `≈ 36·POPULATION` bytes + one [`MonitorModel`]; no heap. The firmware drives
//! [`Identification`] a bounded number of evaluations at a time; the host calls
//! [`Identification::run`].

use crate::model::calibration::Calibration;
use crate::model::monitor::MonitorModel;
use crate::physics::fault::FaultVector;
use crate::physics::magnets::WeakMagnet;
use crate::physics::params::ActuatorParams;
use crate::solver::fitness::{CurvatureRun, FitnessError, FitnessProblem};
use crate::solver::ga::{GaError, GaSettings, RecordError, Status, SteadyStateGa, StopReason};
use crate::solver::polish::{Polish, PolishAsk, PolishSettings};
use crate::solver::uncertainty::{Curvature, SystematicError, Uncertainty, UncertaintyError};
use crate::solver::weak_magnet::{MagnetAsk, MagnetReading, WeakMagnetSearch};
#[cfg(feature = "command-table")]
use crate::test::command::CommandTable;
use crate::test::conditioning::{commutation_signs, AdcFrame, MeasuredCurrent};
use crate::test::trace::Crc32;

pub use crate::base::capacity::{POPULATION, TEST_SAMPLES};

/// The measured-current buffer the controller fills during the test.
pub type OnboardMeasured = MeasuredCurrent<TEST_SAMPLES>;

/// The onboard GA.
pub type OnboardGa = SteadyStateGa<POPULATION>;

/// The onboard GA's checkpoint record (1 412 bytes; version 2, nine genes): a flash page on the controller, a file
/// under emulation and on the host.
pub type OnboardRecord = [u8; crate::solver::ga::record_bytes(POPULATION)];

/// Result of an identification.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct IdentificationResult {
    pub faults: FaultVector,
    /// Eq. (3) of the best vector, residual subtracted [A²·s].
    pub fitness: f32,
    pub evaluations: u32,
    pub stop_reason: StopReason,
    /// Gauss–Newton sums the polish computed (ten monitor-model runs each: the point and one per component; 0 before it).
    pub curvatures: u32,
    /// One weak magnet read by the search after the polish ([`WeakMagnetSearch`];
    /// [`WeakMagnet::NONE`] before it, or when an eccentricity explains the current better).
    pub magnets: WeakMagnet,
    /// The fitness's curvature along that magnet's depth
    /// ([`WeakMagnetSearch::depth_curvature`]; 0 without one) [A²·s per unit²]: its
    /// deviation in the uncertainty ([`Uncertainty::with_magnet`]).
    pub depth_curvature: f32,
}

/// A reading's uncertainty and the correlations between its components
/// ([`Identification::read`]).
pub type ReadingUncertainty = (
    Uncertainty,
    [[f32; crate::physics::fault::FAULT_COUNT]; crate::physics::fault::FAULT_COUNT],
);

/// Why an identification could not start.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FdiError {
    Fitness(FitnessError),
    Ga(GaError),
}

impl From<FitnessError> for FdiError {
    fn from(e: FitnessError) -> Self {
        Self::Fitness(e)
    }
}
impl From<GaError> for FdiError {
    fn from(e: GaError) -> Self {
        Self::Ga(e)
    }
}

/// One identification in progress: the problem (fitness against one measured test) and the
/// solver state. Both the firmware task and the host loop drive this same value.
#[derive(Clone, Debug)]
pub struct Identification<'a, const N: usize, const P: usize> {
    problem: FitnessProblem<'a, N>,
    ga: SteadyStateGa<P>,
    fingerprint: u32,
}

impl<'a, const N: usize, const P: usize> Identification<'a, N, P> {
    pub fn new(
        measured: &'a MeasuredCurrent<N>,
        params: ActuatorParams,
        calibration: &Calibration,
        settings: GaSettings,
        seed: u64,
    ) -> Result<Self, FdiError> {
        Ok(Self {
            problem: FitnessProblem::new(measured, params, calibration)?,
            ga: SteadyStateGa::new(settings, seed)?,
            fingerprint: fingerprint(measured, &params, calibration, &settings, seed),
        })
    }

    /// [`Self::new`] for an actuator whose record carries `systematic`: where it declares
    /// how far the gearbox may run from the thermistor, the day's healthy friction is a
    /// nuisance estimated with the faults — the solver may read it down to `exp(−2σ)` of the
    /// law's estimate, σ the day's deviation ([`SystematicError::on_day`]: the law's slope ×
    /// the spread), a box prior; above the estimate the friction fault takes the excess —,
    /// the GA starting from the healthy friction at the estimate. Without a spread, exactly
    /// [`Self::new`]. Results are in the solver's coordinates until [`Self::reading`].
    pub fn with_nuisances(
        measured: &'a MeasuredCurrent<N>,
        params: ActuatorParams,
        calibration: &Calibration,
        systematic: &SystematicError,
        mut settings: GaSettings,
        seed: u64,
    ) -> Result<Self, FdiError> {
        let mut problem = FitnessProblem::new(measured, params, calibration)?;
        let sigma = systematic
            .on_day(problem.conditions().friction_slope)
            .healthy_friction;
        let mut fingerprint = fingerprint(measured, &params, calibration, &settings, seed);
        if sigma > 0.0 {
            problem = problem.with_friction_floor(crate::base::math::exp(-2.0 * sigma));
            let model = problem.model();
            if let Some(guess) = settings.initial_guess.as_mut() {
                *guess = *model
                    .solver_vector(&FaultVector::saturating(*guess))
                    .as_array();
            }
            let mut crc = Crc32::new();
            crc.update(&fingerprint.to_le_bytes());
            crc.update(&model.friction_floor().to_bits().to_le_bytes());
            fingerprint = crc.finish();
        }
        Ok(Self {
            problem,
            ga: SteadyStateGa::new(settings, seed)?,
            fingerprint,
        })
    }

    /// What the solver's `result` reads as: its friction's excess over the day's healthy
    /// friction as the fault ([`MonitorModel::reading`]); itself without a floor. O(1).
    pub fn reading(&self, result: IdentificationResult) -> IdentificationResult {
        IdentificationResult {
            faults: self.problem.model().reading(&result.faults),
            ..result
        }
    }

    /// The preflight's uncertainty of the reading of the solver's vector `k` from its
    /// `curvature`, on an actuator whose record carries `systematic`: the curvature's
    /// deviations with the record's systematic error, the friction's moved to the reading's
    /// scale, then the day's healthy friction's deviation added to it in quadrature
    /// ([`SystematicError::friction_for`]). Without a floor, exactly
    /// [`Curvature::preflight_uncertainty`] with the day's systematic error. O(9³).
    pub fn reading_uncertainty(
        &self,
        k: &FaultVector,
        curvature: &Curvature,
        systematic: &SystematicError,
    ) -> Result<ReadingUncertainty, UncertaintyError> {
        let model = self.problem.model();
        let day = systematic.on_day(self.problem.conditions().friction_slope);
        if model.friction_floor() == 1.0 {
            return curvature.preflight_uncertainty(k, &day);
        }
        let (u, correlation) = curvature.preflight_uncertainty(
            k,
            &SystematicError {
                healthy_friction: 0.0,
                ..day
            },
        )?;
        let read = model.reading(k);
        let mut factors = [1.0; crate::physics::fault::FAULT_COUNT];
        factors[0] = model.reading_scale();
        let mut shared = [0.0; crate::physics::fault::FAULT_COUNT];
        shared[0] = day.friction_for(&read);
        Ok((
            u.widened(&read, &factors).with_shared(&read, &shared),
            correlation,
        ))
    }

    /// What a finished identification reports: the solver's `result` as read
    /// ([`Self::reading`]) and its uncertainty from `curvature` at `result`
    /// ([`Self::reading_uncertainty`]), the eccentricity's free-phase bias taken off the
    /// reading ([`Uncertainty::with_free_phase_corrected`]: a round rotor reads noise's
    /// amplitude otherwise). The residual's noise share is what the calibration's healthy
    /// mismatch does not explain: the fitness over the fitness plus the nominal residual it
    /// subtracts (≈ 0.8 for a healthy reference actuator under 50 % I_ref noise, ≈ 0.07 for
    /// a noise-free play of 0.2). Without an uncertainty, the reading as the solver found
    /// it. `result.fitness` stays the solver's. O(9³).
    pub fn read(
        &self,
        result: IdentificationResult,
        curvature: &Curvature,
        systematic: &SystematicError,
    ) -> (IdentificationResult, Option<ReadingUncertainty>) {
        let read = self.reading(result);
        match self.reading_uncertainty(&result.faults, curvature, systematic) {
            Ok((u, correlation)) => {
                let excess = result.fitness.max(0.0);
                let share = excess / (excess + self.problem.nominal_residual().max(0.0));
                let (faults, u) = u.with_free_phase_corrected(&read.faults, share);
                let dt = self.problem.model().params().control_period;
                (
                    IdentificationResult { faults, ..read },
                    Some((
                        u.with_magnet(curvature, result.depth_curvature, dt),
                        correlation,
                    )),
                )
            }
            Err(_) => (read, None),
        }
    }

    /// What ties a checkpoint to this run: a CRC-32 over the measured samples and initial
    /// angles, the actuator (parameters, test, calibration, GA settings: what an actuator
    /// record holds) and the seed. O(N), computed once.
    pub fn fingerprint(&self) -> u32 {
        self.fingerprint
    }

    /// Writes the GA's state into `record` (see [`crate::solver::ga::checkpoint`]). O(P).
    pub fn save(&self, record: &mut [u8]) -> Result<(), RecordError> {
        self.ga.save(self.fingerprint, record)
    }

    /// Continues from `record` if it is a sound checkpoint of this very run; returns the
    /// evaluations it had done. On `Err` this identification is left exactly as it was
    /// (a fresh one restarts cleanly). O(P).
    pub fn resume(&mut self, record: &[u8]) -> Result<u32, RecordError> {
        self.ga.resume_from(self.fingerprint, record)?;
        Ok(self.ga.evaluations())
    }

    /// The same identification with the command read from `table` (see
    /// [`FitnessProblem::with_command_table`]): the same bits, faster where RAM allows.
    #[cfg(feature = "command-table")]
    pub fn with_command_table(mut self, table: &'a CommandTable<N>) -> Result<Self, FdiError> {
        self.problem = self.problem.with_command_table(table)?;
        Ok(self)
    }

    /// The same identification with its model on a drive that slews to its current
    /// reference's steps of mean square `power` \[A²\] ([`FitnessProblem::set_reference_steps`];
    /// for studies of the noise's lean: the flown identification does not set it). Before
    /// the first step. O(1).
    #[must_use]
    pub fn with_reference_steps(mut self, power: f32) -> Self {
        self.problem.set_reference_steps(power);
        self
    }

    /// At most `budget` monitor-model evaluations, then returns.
    pub fn step(&mut self, budget: u32) -> Status {
        self.ga.step(&mut self.problem, budget)
    }

    /// Runs to the end: the GA (bounded by its settings), then the flown polish
    /// ([`PolishSettings::FDI`]) with its curvature runs on the stack (≈ 3.8 kB; the host's
    /// executor — the firmware lends a static buffer and polls the polish in chunks).
    pub fn run(&mut self) -> IdentificationResult {
        self.ga.run(&mut self.problem);
        let mut curvature = CurvatureRun::IDLE;
        let polished = self.polished(PolishSettings::FDI, &mut curvature);
        self.with_weak_magnet(polished, PolishSettings::FDI, &mut curvature)
    }

    /// The weak-magnet search from the polished `result` with whole model runs and polishes
    /// (`settings`, curvatures in `run`): the host's executor (the firmware polls the same
    /// [`WeakMagnetSearch`] in slices). Leaves the problem's model playing the magnets read,
    /// so that the curvature and the uncertainty after it are the reading's. Work: at most
    /// [`WeakMagnetSearch::max_evaluations`] model runs and
    /// [`MAX_POLISHES`](crate::solver::weak_magnet::MAX_POLISHES) polishes.
    pub fn with_weak_magnet(
        &mut self,
        result: IdentificationResult,
        settings: PolishSettings,
        run: &mut CurvatureRun,
    ) -> IdentificationResult {
        let params = *self.problem.model().params();
        let mut search = WeakMagnetSearch::new(&params, result.faults, result.fitness);
        let mut out = result;
        loop {
            match search.ask() {
                MagnetAsk::Fitness { k, magnets, bound } => {
                    self.set_magnets(magnets);
                    out.evaluations = out.evaluations.saturating_add(1);
                    search.tell(self.problem.error_below(&k, bound));
                }
                MagnetAsk::Polish(start) => {
                    self.problem.set_magnets(start.magnets);
                    let from = IdentificationResult {
                        faults: start.faults,
                        fitness: start.fitness,
                        magnets: start.magnets,
                        ..out
                    };
                    let polished = self.polished_from(from, settings, run);
                    (out.evaluations, out.curvatures) = (polished.evaluations, polished.curvatures);
                    search.tell_polished(MagnetReading {
                        faults: polished.faults,
                        magnets: start.magnets,
                        fitness: polished.fitness,
                    });
                }
                MagnetAsk::Done(reading) => {
                    self.problem.set_magnets(reading.magnets);
                    return IdentificationResult {
                        faults: reading.faults,
                        fitness: reading.fitness,
                        magnets: reading.magnets,
                        depth_curvature: search.depth_curvature(),
                        ..out
                    };
                }
            }
        }
    }

    pub fn ga(&self) -> &SteadyStateGa<P> {
        &self.ga
    }

    /// Sets the weak magnet the problem's model plays (the weak-magnet search's executor,
    /// [`FitnessProblem::set_magnets`]). O(1).
    pub fn set_magnets(&mut self, magnets: WeakMagnet) {
        self.problem.set_magnets(magnets);
    }

    pub fn problem(&self) -> &FitnessProblem<'a, N> {
        &self.problem
    }

    /// The best vector found so far (the stop reason says `EvaluationBudget` while running).
    pub fn result_so_far(&self) -> IdentificationResult {
        let best = self.ga.best();
        IdentificationResult {
            faults: FaultVector::saturating(best.genes),
            fitness: best.fitness,
            evaluations: self.ga.evaluations(),
            stop_reason: match self.ga.status() {
                Status::Done(reason) => reason,
                Status::Running => StopReason::EvaluationBudget,
            },
            curvatures: 0,
            magnets: WeakMagnet::NONE,
            depth_curvature: 0.0,
        }
    }

    /// The GA's result so far, polished to the end ([`crate::solver::polish`]) with whole curvature
    /// runs in `run`: the host's executor (the firmware polls the same [`Polish`] in chunks).
    /// Work: bounded by [`PolishSettings::max_curvatures`] and
    /// [`PolishSettings::max_evaluations`].
    pub fn polished(
        &self,
        settings: PolishSettings,
        run: &mut CurvatureRun,
    ) -> IdentificationResult {
        self.polished_from(self.result_so_far(), settings, run)
    }

    /// [`polished`](Self::polished) from `start` instead of the GA's best (a weak magnet's
    /// reading, polished with its magnet held). The same work bound.
    pub fn polished_from(
        &self,
        start: IdentificationResult,
        settings: PolishSettings,
        run: &mut CurvatureRun,
    ) -> IdentificationResult {
        let mut polish = Polish::new(settings, start.faults, start.fitness);
        let mut out = start;
        loop {
            match polish.ask() {
                PolishAsk::Curvature(k) => {
                    out.curvatures = out.curvatures.saturating_add(1);
                    polish.tell_curvature(&self.problem.curvature_in(run, &k));
                }
                PolishAsk::Fitness { k, bound } => {
                    out.evaluations = out.evaluations.saturating_add(1);
                    polish.tell_fitness(self.problem.error_below(&k, bound));
                }
                PolishAsk::Done { k, fitness } => {
                    out.faults = k;
                    out.fitness = fitness;
                    return out;
                }
            }
        }
    }
}

fn fingerprint<const N: usize>(
    measured: &MeasuredCurrent<N>,
    params: &ActuatorParams,
    calibration: &Calibration,
    settings: &GaSettings,
    seed: u64,
) -> u32 {
    let mut crc = Crc32::new();
    for v in measured.samples() {
        crc.update(&v.to_bits().to_le_bytes());
    }
    let angles = measured.initial_angles();
    for v in [angles.motor, angles.user] {
        crc.update(&v.to_bits().to_le_bytes());
    }
    // What an actuator record holds of this run, word for word as the record stores it.
    crate::preflight::actuator::run_words(params, measured.test(), calibration, settings, |word| {
        crc.update(&word.to_le_bytes())
    });
    crc.update(&calibration.duty_delay.to_bits().to_le_bytes());
    // A friction law by drag (nothing added without one, so that earlier checkpoints still
    // resume; the chirp's drag reading comes from the same frames as the samples).
    if calibration.viscous > 0.0 {
        for v in [calibration.viscous].iter().chain(&calibration.drag_points) {
            crc.update(&v.to_bits().to_le_bytes());
        }
    }
    crc.update(&seed.to_le_bytes());
    crc.finish()
}

/// Records what the controller would measure if the actuator behaved exactly like the monitor
/// model with faults `k`: three phase currents from the equivalent current and the commutation
/// table (the driven pair during a standstill segment of `measured`'s test, which the model
/// plays), quantised into [`AdcFrame`]s and conditioned into `measured` (cleared first). Used
/// by the inverse check, which proves fitness and optimiser before any reference model.
pub fn record_monitor_trace<const N: usize>(
    model: &MonitorModel,
    k: &FaultVector,
    measured: &mut MeasuredCurrent<N>,
) -> Result<(), FitnessError> {
    measured.clear();
    let pole_pairs = model.params().pole_pairs;
    let model = model.with_test(measured.test());
    let samples = model.test_samples().min(N);
    let standstill = measured.test().standstill;
    let mut index = 0usize;
    model.run(k, samples, |s| {
        // The driven pair's signs during a standstill segment, the commutated pair's after.
        let signs = match standstill.and_then(|segment| segment.at(index)) {
            Some(drive) => drive.signs(),
            None => commutation_signs(pole_pairs * s.motor_angle),
        };
        index += 1;
        let phases = signs.map(|x| f32::from(x) * s.current);
        // Cannot be full: at most N samples are produced.
        let _ = measured.push_frame(
            AdcFrame::from_f32(phases, s.motor_angle, s.user_angle),
            pole_pairs,
        );
    });
    measured.finish()?;
    Ok(())
}
