//! The preflight self-test: Acquire → Condition → Identify → Polish → Magnets → Uncertainty
//! → Report, one bounded slice of work per [`Preflight::poll`] so that the executor can run
//! other tasks in between.
//!
//! Work bounds per poll: Acquire ≤ [`PreflightSettings::frames_per_poll`] frames (O(1) each);
//! Condition one O(`TEST_SAMPLES`) pass; Identify ≤
//! [`PreflightSettings::evaluations_per_poll`] monitor-model evaluations (each one whole test,
//! ≤ 0.552 s of model time at the control period); Polish one fitness evaluation or one
//! slice of its sums; Magnets one fitness evaluation (the weak-magnet search,
//! [`shared::weak_magnet`]; a polish it asks for runs in Polish); Uncertainty ≤
//! [`PreflightSettings::uncertainty_samples_per_poll`] samples of 10 lockstep runs, the last
//! poll also the 9 × 9 inversion and the verdicts (O(9³)); Report O(1), including the domain verdict
//! ([`shared::domain`], its statistics gathered frame by frame during Acquire). Time is
//! never read here; the caller measures it.
//!
//! Memory: the measured-current buffer is lent in (`&mut OnboardMeasured`, 22 kB), the GA
//! and the monitor model live in the state (≈ 1.5 kB). Same settings, seed and frames give the
//! same bits as `host-sim identify`.

use shared::actuator::ActuatorRecord;
use shared::conditioning::ConditioningError;
use shared::conditions::TestConditions;
use shared::domain::{Domain, DomainMonitor};
use shared::fdi::TEST_SAMPLES;
use shared::fdi::{FdiError, Identification, IdentificationResult, OnboardMeasured, POPULATION};
use shared::fitness::CurvatureRun;
use shared::ga::RecordError;
use shared::polish::{Polish, PolishAsk, PolishSettings};
use shared::test_design::PreflightTest;
use shared::uncertainty::{Assessment, Uncertainty};
use shared::weak_magnet::{MagnetAsk, MagnetReading, WeakMagnetSearch};
use shared::window::HeldComponents;
use shared::{Calibration, FaultVector, Status, Verdict, FAULT_COUNT};

use crate::source::{Acquired, CurrentSource};

/// How the preflight runs: plain data, split from the running state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PreflightSettings {
    /// The actuator: its parameters, the test its controller commands (under emulation of
    /// the trace header's kind), the monitor model's calibration, GA settings, domain limits
    /// and detection threshold (a flash record on a fleet, [`ActuatorRecord`]).
    pub actuator: ActuatorRecord,
    /// GA seed (`host-sim identify --seed`).
    pub seed: u64,
    /// Frames taken from the source per poll.
    pub frames_per_poll: u32,
    /// Monitor-model evaluations per poll during Identify.
    pub evaluations_per_poll: u32,
    /// Samples per poll of the Gauss–Newton sums' 9 lockstep runs, in the polish and the
    /// uncertainty (200 ≈ a third of one evaluation's work: 9 model steps and 45 f32
    /// multiply-adds per sample).
    pub uncertainty_samples_per_poll: u32,
}

impl PreflightSettings {
    /// The same settings for another test design, with the reference actuator's calibration
    /// for it.
    pub fn for_test(mut self, test: PreflightTest) -> Self {
        self.actuator.test = test;
        self.actuator.calibration = Calibration::reference_actuator(&test);
        self
    }

    /// The same settings for the actuator `record` describes (its parameters, test,
    /// calibration, GA settings, domain limits and threshold).
    pub fn for_actuator(mut self, record: &ActuatorRecord) -> Self {
        self.actuator = *record;
        self
    }

    /// The onboard FDI against this project's reference actuator: the same parameters,
    /// calibration, GA settings and default seed as `host-sim identify`.
    pub const ONBOARD: Self = Self {
        actuator: ActuatorRecord::REFERENCE,
        seed: 1,
        frames_per_poll: 500,
        evaluations_per_poll: 1,
        uncertainty_samples_per_poll: 200,
    };
}

/// Where the self-test stands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(any(feature = "defmt", target_os = "none"), derive(defmt::Format))]
pub enum Stage {
    Acquire,
    Condition,
    Identify,
    /// Gauss–Newton steps from the GA's best and from the probes ([`shared::polish`]).
    Polish,
    /// One weak magnet against the eccentricity read ([`shared::weak_magnet`]).
    Magnets,
    /// A standard deviation and a 90 % interval per component ([`shared::uncertainty`]).
    Uncertainty,
    Report,
    Done,
}

/// Why a self-test gave no result.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(any(feature = "defmt", target_os = "none"), derive(defmt::Format))]
pub enum PreflightError<E> {
    /// The current source failed.
    Source(E),
    /// The test produced more frames than the buffer holds (refused, never truncated).
    TooManyFrames { capacity: u32 },
    /// The measured current cannot be used (too short, not finite).
    Conditioning(ConditioningError),
    /// The identification could not start.
    Fdi(FdiError),
    /// Polled again after a failure.
    AlreadyFailed,
}

/// What the self-test found.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(any(feature = "defmt", target_os = "none"), derive(defmt::Format))]
pub struct Report {
    pub result: IdentificationResult,
    /// Standard deviation and 90 % interval per component (`None`: not determined).
    pub uncertainty: Option<Uncertainty>,
    /// Verdicts that use the uncertainty: `Faulty` only when the interval clears the
    /// detection threshold.
    pub assessments: [Assessment; FAULT_COUNT],
    /// The weak magnet's verdict by the same rule (`shared::uncertainty::assess_magnet`).
    pub magnet: Assessment,
    /// Whether the monitor model explains this actuator at all; when `Outside`, the fault
    /// vector and the verdicts must not be acted on.
    pub domain: Domain,
    pub verdicts: [Verdict; FAULT_COUNT],
    /// Frames acquired.
    pub frames: u32,
    /// Polls spent in Identify.
    pub identify_polls: u32,
    /// Largest number of evaluations one poll did (≤ `evaluations_per_poll`).
    pub max_evaluations_per_poll: u32,
    /// What a window of the same flight holds of this reading, were it trusted
    /// (`HeldComponents::from_preflight_reading`: the shorts, the eccentricity and the
    /// demagnetization with their covariance); a flight's windows take it when `domain` is
    /// `Within`, and hold nothing otherwise.
    pub held: HeldComponents,
}

/// How many times a preflight spoiled by its load is run (issue 36): a gust or a hand on the
/// parked surface (`OutsideReason::LoadMoved`, `LoadMovedAtRest`) spoils one test, not the
/// actuator; the test is run again, at most [`Reruns::MAX_TESTS`] times in all, and the last
/// report is the one logged, whatever its verdict.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Reruns {
    tests: u8,
}

impl Reruns {
    /// Tests per preflight at most (the first and two re-runs): each is ≈ 0.8 s of drive time
    /// and ≈ 13 s of identification at 168 MHz.
    pub const MAX_TESTS: u8 = 3;

    pub const fn new() -> Self {
        Self { tests: 0 }
    }

    /// Called with each test's report: whether to run the test again. O(1).
    pub fn again(&mut self, report: &Report) -> bool {
        self.tests = self.tests.saturating_add(1);
        let moved = matches!(
            report.domain,
            Domain::Outside(
                shared::domain::OutsideReason::LoadMoved { .. }
                    | shared::domain::OutsideReason::LoadMovedAtRest { .. }
            )
        );
        moved && self.tests < Self::MAX_TESTS
    }

    /// Tests run so far.
    pub fn tests(&self) -> u8 {
        self.tests
    }
}

impl Default for Reruns {
    fn default() -> Self {
        Self::new()
    }
}

/// Why a checkpoint was not taken or not resumed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(any(feature = "defmt", target_os = "none"), derive(defmt::Format))]
pub enum CheckpointError {
    /// Checkpoints exist only during Identify (resume: before its first evaluation).
    NotIdentifying,
    /// The record was refused (the identification goes on from where it was).
    Record(RecordError),
}

/// The outcome of one poll.
#[derive(Clone, Copy, Debug, PartialEq)]
// The report (≈ 204 bytes) by value, once, when the self-test ends: no heap to box it in.
#[allow(clippy::large_enum_variant)]
pub enum Progress {
    /// Work remains; `stage` is where the next poll continues.
    Working { stage: Stage },
    /// The self-test is over (every further poll returns the same report).
    Finished(Report),
}

// One value lives for the whole test in the task's static storage; without a heap there is
// nothing to box the large variant into.
#[allow(clippy::large_enum_variant)]
enum State<'m> {
    Acquire {
        measured: &'m mut OnboardMeasured,
    },
    Condition {
        measured: &'m mut OnboardMeasured,
    },
    /// The identification itself stays in place in [`Preflight::id`] from here on.
    Identify,
    /// The polish itself stays in place in [`Preflight::polish`] and its sums run in
    /// [`Preflight::curvature`] like the uncertainty's. The same fields as `Uncertainty`:
    /// moving the identification between the two costs no copy code.
    Polish {
        result: IdentificationResult,
        /// The weak-magnet search this polish was asked by (`None`: the polish after the
        /// GA).
        search: Option<WeakMagnetSearch>,
    },
    /// The weak-magnet search after the polish: one fitness evaluation (a model run) per
    /// poll; a polish it asks for runs in `Polish` and comes back here.
    Magnets {
        result: IdentificationResult,
        search: WeakMagnetSearch,
    },
    /// The runs themselves stay in place in [`Preflight::curvature`] (≈ 3 kB, not moved
    /// from poll to poll).
    Uncertainty {
        result: IdentificationResult,
    },
    /// The assessments are taken when the uncertainty is: the correlations (a 9 × 9 matrix)
    /// are not carried from state to state.
    Report {
        result: IdentificationResult,
        uncertainty: Option<Uncertainty>,
        assessments: [Assessment; FAULT_COUNT],
        /// The unexplained current's mean over the chirp against its RMS
        /// (`CurvatureRun::load_offset`; NaN without the curvature's runs).
        load_offset: f32,
        held: HeldComponents,
    },
    Done(Report),
    Failed,
}

/// One preflight self-test in progress.
pub struct Preflight<'m, S> {
    /// Lent, as the buffers are: the caller keeps the one copy of the actuator's record
    /// (≈ 0.5 kB of the task's RAM that a second copy here would take).
    settings: &'m PreflightSettings,
    source: S,
    state: State<'m>,
    /// The uncertainty's lockstep runs (≈ 3 kB), lent in like the measured buffer; without
    /// one the Uncertainty stage is skipped and the report has no uncertainty.
    curvature: Option<&'m mut CurvatureRun>,
    /// The identification, from Condition on (kept in place: never moved from poll to poll).
    id: Option<Identification<'m, TEST_SAMPLES, POPULATION>>,
    /// The polish after the GA (≈ 0.7 kB, kept in place from poll to poll).
    polish: Polish,
    /// Whether the polish's current Gauss–Newton sums are under way in `curvature`.
    summing: bool,
    domain: DomainMonitor,
    /// The day the identification estimated (winding temperature, friction, bus).
    day: TestConditions,
    frames: u32,
    identify_polls: u32,
    max_evaluations_per_poll: u32,
}

impl<'m, S: CurrentSource> Preflight<'m, S> {
    /// The day the identification estimated (the calibration's until Identify starts).
    pub fn day(&self) -> &TestConditions {
        &self.day
    }

    /// The most work the settings allow the identification: fitness evaluations (the GA's
    /// budget, the polish's, the weak-magnet search's and its polishes') and Gauss–Newton
    /// sums (nine monitor-model runs each). With the measured cost of each, the preflight's
    /// worst case (BENCHMARKS.md §1).
    pub fn work_bound(&self) -> (u32, u32) {
        let a = &self.settings.actuator;
        let (evaluations, curvatures) = WeakMagnetSearch::work_after_ga(&a.params, &a.polish);
        (a.ga.max_evaluations.saturating_add(evaluations), curvatures)
    }

    /// A self-test that fills `measured` (cleared first) from `source`.
    pub fn new(
        settings: &'m PreflightSettings,
        source: S,
        measured: &'m mut OnboardMeasured,
    ) -> Self {
        measured.clear_for(settings.actuator.test);
        Self {
            settings,
            source,
            state: State::Acquire { measured },
            curvature: None,
            id: None,
            polish: Polish::new(PolishSettings::NONE, FaultVector::NOMINAL, f32::INFINITY),
            summing: false,
            day: TestConditions::CALIBRATION,
            domain: DomainMonitor::new(settings.actuator.test.chirp, &settings.actuator.params),
            frames: 0,
            identify_polls: 0,
            max_evaluations_per_poll: 0,
        }
    }

    /// The same self-test computing the uncertainty of its result in `buffer`.
    pub fn with_curvature_buffer(mut self, buffer: &'m mut CurvatureRun) -> Self {
        self.curvature = Some(buffer);
        self
    }

    pub fn stage(&self) -> Stage {
        match self.state {
            State::Acquire { .. } => Stage::Acquire,
            State::Condition { .. } => Stage::Condition,
            State::Identify { .. } => Stage::Identify,
            State::Polish { .. } => Stage::Polish,
            State::Magnets { .. } => Stage::Magnets,
            State::Uncertainty { .. } => Stage::Uncertainty,
            State::Report { .. } => Stage::Report,
            State::Done(_) | State::Failed => Stage::Done,
        }
    }

    /// Evaluations done so far (0 before Identify).
    pub fn evaluations(&self) -> u32 {
        match &self.state {
            State::Identify | State::Uncertainty { .. } => {
                self.id.as_ref().map_or(0, |id| id.ga().evaluations())
            }
            State::Polish { result, .. } | State::Magnets { result, .. } => result.evaluations,
            State::Report { result, .. } => result.evaluations,
            State::Done(report) => report.result.evaluations,
            _ => 0,
        }
    }

    /// Writes the identification's state into `record` (an `OnboardRecord`, 1 412 B) for a
    /// resume after a power loss; returns the evaluations it holds. O(`POPULATION`).
    pub fn checkpoint(&self, record: &mut [u8]) -> Result<u32, CheckpointError> {
        match &self.state {
            State::Identify => {
                let id = self.id.as_ref().ok_or(CheckpointError::NotIdentifying)?;
                id.save(record).map_err(CheckpointError::Record)?;
                Ok(id.ga().evaluations())
            }
            _ => Err(CheckpointError::NotIdentifying),
        }
    }

    /// Continues the identification from a checkpoint of this same test, settings and seed,
    /// right after Identify began; returns the evaluations it resumed at. A refused record
    /// (damaged, torn, erased, another run) leaves the fresh identification untouched: the
    /// preflight restarts cleanly. O(`POPULATION`).
    pub fn resume(&mut self, record: &[u8]) -> Result<u32, CheckpointError> {
        match &mut self.state {
            State::Identify => match self.id.as_mut() {
                Some(id) if id.ga().evaluations() == 0 => {
                    id.resume(record).map_err(CheckpointError::Record)
                }
                _ => Err(CheckpointError::NotIdentifying),
            },
            _ => Err(CheckpointError::NotIdentifying),
        }
    }

    /// Does one bounded slice of work (see the module docs).
    pub fn poll(&mut self) -> Result<Progress, PreflightError<S::Error>> {
        let state = core::mem::replace(&mut self.state, State::Failed);
        match self.advance(state) {
            Ok(next) => {
                self.state = next;
                Ok(match &self.state {
                    State::Done(report) => Progress::Finished(*report),
                    _ => Progress::Working {
                        stage: self.stage(),
                    },
                })
            }
            Err(e) => Err(e),
        }
    }

    /// The verdicts that use the uncertainty (`Faulty` only when the interval clears the
    /// threshold); without one, a component beyond the threshold is only `Suspect`. O(9²).
    fn assess(
        &self,
        result: &IdentificationResult,
        uncertainty: Option<&(Uncertainty, [[f32; FAULT_COUNT]; FAULT_COUNT])>,
    ) -> [Assessment; FAULT_COUNT] {
        let threshold = self.settings.actuator.detection_threshold;
        match uncertainty {
            Some((u, correlation)) => u.assess_at(&result.faults, correlation, threshold),
            None => result.faults.verdicts_at(threshold).map(|v| match v {
                Verdict::Healthy => Assessment::Healthy,
                Verdict::Faulty => Assessment::Suspect,
                Verdict::NotApplicable => Assessment::NotApplicable,
            }),
        }
    }

    /// One step of the weak-magnet search: a fitness evaluation, or the start of a polish it
    /// asks for, or its reading (then the uncertainty's runs start). Out of line: the
    /// search's code once in the image.
    #[inline(never)]
    fn search_magnets(
        &mut self,
        mut result: IdentificationResult,
        mut search: WeakMagnetSearch,
    ) -> Result<State<'m>, PreflightError<S::Error>> {
        let Some(id) = self.id.as_mut() else {
            return Err(PreflightError::AlreadyFailed);
        };
        match search.ask() {
            MagnetAsk::Fitness { k, magnets, bound } => {
                id.set_magnets(magnets);
                result.evaluations = result.evaluations.saturating_add(1);
                search.tell(id.problem().error_below(&k, bound));
                Ok(State::Magnets { result, search })
            }
            MagnetAsk::Polish(start) => {
                id.set_magnets(start.magnets);
                result.faults = start.faults;
                result.fitness = start.fitness;
                result.magnets = start.magnets;
                self.polish =
                    Polish::new(self.settings.actuator.polish, start.faults, start.fitness);
                self.summing = false;
                Ok(State::Polish {
                    result,
                    search: Some(search),
                })
            }
            MagnetAsk::Done(reading) => {
                id.set_magnets(reading.magnets);
                result.faults = reading.faults;
                result.fitness = reading.fitness;
                result.magnets = reading.magnets;
                result.depth_curvature = search.depth_curvature();
                if let Some(run) = self.curvature.as_deref_mut() {
                    id.problem().restart_curvature(run, &result.faults);
                }
                Ok(State::Uncertainty { result })
            }
        }
    }

    fn advance(&mut self, state: State<'m>) -> Result<State<'m>, PreflightError<S::Error>> {
        match state {
            State::Acquire { measured } => {
                let pole_pairs = self.settings.actuator.params.pole_pairs;
                for _ in 0..self.settings.frames_per_poll {
                    match self.source.next_frame().map_err(PreflightError::Source)? {
                        Acquired::Frame(frame) => {
                            if measured.push_frame(frame, pole_pairs).is_err() {
                                return Err(PreflightError::TooManyFrames {
                                    capacity: TEST_SAMPLES as u32,
                                });
                            }
                            // The domain statistics are the chirp's.
                            if self.frames as usize >= self.settings.actuator.test.lead_samples() {
                                self.domain.push(&frame);
                            }
                            self.frames = self.frames.saturating_add(1);
                        }
                        Acquired::NotYet => break,
                        Acquired::EndOfTest => return Ok(State::Condition { measured }),
                    }
                }
                Ok(State::Acquire { measured })
            }
            State::Condition { measured } => {
                measured.finish().map_err(PreflightError::Conditioning)?;
                let measured: &'m OnboardMeasured = measured;
                let s = &self.settings;
                let id = Identification::with_nuisances(
                    measured,
                    s.actuator.params,
                    &s.actuator.calibration,
                    &s.actuator.systematic,
                    s.actuator.ga,
                    s.seed,
                )
                .map_err(PreflightError::Fdi)?;
                self.day = *id.problem().conditions();
                self.id = Some(id);
                Ok(State::Identify)
            }
            State::Identify => {
                let Some(id) = self.id.as_mut() else {
                    return Err(PreflightError::AlreadyFailed);
                };
                let before = id.ga().evaluations();
                let status = id.step(self.settings.evaluations_per_poll);
                let done = id.ga().evaluations().saturating_sub(before);
                self.identify_polls = self.identify_polls.saturating_add(1);
                self.max_evaluations_per_poll = self.max_evaluations_per_poll.max(done);
                Ok(match status {
                    Status::Running => State::Identify,
                    Status::Done(_) => {
                        let result = id.result_so_far();
                        match self.curvature {
                            Some(_) => {
                                // The actuator's polish (its record); it needs the curvature
                                // runs, like the uncertainty.
                                self.polish = Polish::new(
                                    self.settings.actuator.polish,
                                    result.faults,
                                    result.fitness,
                                );
                                self.summing = false;
                                State::Polish {
                                    result,
                                    search: None,
                                }
                            }
                            None => State::Report {
                                result,
                                uncertainty: None,
                                assessments: self.assess(&result, None),
                                load_offset: f32::NAN,
                                held: HeldComponents::of_preflight(&result.faults)
                                    .with_magnets(result.magnets),
                            },
                        }
                    }
                })
            }
            State::Polish { mut result, search } => {
                let Some(id) = self.id.as_ref() else {
                    return Err(PreflightError::AlreadyFailed);
                };
                let Some(run) = self.curvature.as_deref_mut() else {
                    return Ok(State::Report {
                        result,
                        uncertainty: None,
                        assessments: self.assess(&result, None),
                        load_offset: f32::NAN,
                        held: HeldComponents::of_preflight(&result.faults)
                            .with_magnets(result.magnets),
                    });
                };
                let polish = &mut self.polish;
                match polish.ask() {
                    PolishAsk::Curvature(k) => {
                        if !self.summing {
                            id.problem().restart_curvature(run, &k);
                            result.curvatures = result.curvatures.saturating_add(1);
                            self.summing = true;
                        }
                        let samples = self.settings.uncertainty_samples_per_poll as usize;
                        if let Some(c) = id.problem().continue_curvature(run, samples) {
                            polish.tell_curvature(&c);
                            self.summing = false;
                        }
                    }
                    PolishAsk::Fitness { k, bound } => {
                        result.evaluations = result.evaluations.saturating_add(1);
                        polish.tell_fitness(id.problem().error_below(&k, bound));
                    }
                    PolishAsk::Done { k, fitness } => {
                        result.faults = k;
                        result.fitness = fitness;
                        let search = match search {
                            // Back to the search that asked for this polish.
                            Some(mut search) => {
                                search.tell_polished(MagnetReading {
                                    faults: k,
                                    magnets: result.magnets,
                                    fitness,
                                });
                                search
                            }
                            None => {
                                WeakMagnetSearch::new(&self.settings.actuator.params, k, fitness)
                            }
                        };
                        return Ok(State::Magnets { result, search });
                    }
                }
                Ok(State::Polish { result, search })
            }
            State::Magnets { result, search } => self.search_magnets(result, search),
            State::Uncertainty { result } => {
                let Some(id) = self.id.as_ref() else {
                    return Err(PreflightError::AlreadyFailed);
                };
                let samples = self.settings.uncertainty_samples_per_poll as usize;
                let done = match self.curvature.as_deref_mut() {
                    Some(run) => id.problem().continue_curvature(run, samples),
                    None => Some(shared::uncertainty::Curvature::EMPTY),
                };
                Ok(match done {
                    None => State::Uncertainty { result },
                    Some(curvature) => {
                        let systematic = &self.settings.actuator.systematic;
                        let (result, uncertainty) = id.read(result, &curvature, systematic);
                        let nuisance = systematic
                            .on_day(self.day.friction_slope)
                            .friction_for(&result.faults);
                        State::Report {
                            result,
                            held: HeldComponents::from_preflight_reading(
                                &result.faults,
                                true,
                                uncertainty.as_ref().map(|(u, c)| (&u.std, c)),
                                nuisance,
                            )
                            .with_magnets(result.magnets),
                            assessments: self.assess(&result, uncertainty.as_ref()),
                            uncertainty: uncertainty.map(|(u, _)| u),
                            load_offset: self
                                .curvature
                                .as_deref()
                                .map_or(f32::NAN, CurvatureRun::load_offset),
                        }
                    }
                })
            }
            State::Report {
                result,
                uncertainty,
                assessments,
                load_offset,
                held,
            } => Ok(State::Done(Report {
                held,
                result,
                magnet: shared::uncertainty::assess_magnet(
                    result.magnets.depth,
                    uncertainty.map_or(f32::NAN, |u| u.magnet_std),
                    self.settings.actuator.detection_threshold,
                ),
                uncertainty,
                assessments,
                domain: {
                    let load = match self.id.as_ref() {
                        Some(id) => id.problem().load_signs(load_offset),
                        None => return Err(PreflightError::AlreadyFailed),
                    };
                    self.domain
                        .assess(&self.settings.actuator.domain, result.fitness, &self.day)
                        .with_load(load)
                },
                verdicts: result
                    .faults
                    .verdicts_at(self.settings.actuator.detection_threshold),
                frames: self.frames,
                identify_polls: self.identify_polls,
                max_evaluations_per_poll: self.max_evaluations_per_poll,
            })),
            State::Done(report) => Ok(State::Done(report)),
            State::Failed => Err(PreflightError::AlreadyFailed),
        }
    }
}
