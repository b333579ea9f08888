//! Running the onboard FDI on the host: the very `shared` code, sizes, GA settings and seed
//! the firmware uses, driven in slices of [`SLICE`] evaluations so that the host can show
//! progress and record the fitness history. With [`Checkpointing`] the GA record is written
//! to a file as the firmware writes its flash page, and a run resumes from it.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};
use shared::actuator::ActuatorRecord;
use shared::command::CommandTable;
use shared::fault::FAULT_COUNT;
use shared::fdi::{
    Identification, IdentificationResult, OnboardMeasured, OnboardRecord, POPULATION, TEST_SAMPLES,
};
use shared::ga::RecordError;
use shared::uncertainty::{Assessment, Uncertainty};
use shared::{Calibration, GaSettings, Status};

/// Evaluations per slice (the firmware's bounded tick does the same kind of slicing).
pub const SLICE: u32 = 32;

/// One identification as the host saw it.
#[derive(Clone, Debug)]
pub struct Identified {
    pub result: IdentificationResult,
    /// Wall time of the identification (command table and GA) [s].
    pub seconds: f64,
    /// (evaluations, best fitness) after each slice.
    pub history: Vec<(u32, f32)>,
    /// Standard deviation and 90 % interval per component, with the correlations
    /// (`shared::uncertainty`; `None` when the test determines no component).
    pub uncertainty: Option<(Uncertainty, [[f32; FAULT_COUNT]; FAULT_COUNT])>,
    /// The day the FDI estimated for the test (`shared::conditions`).
    pub conditions: shared::conditions::TestConditions,
    /// The share of the friction's deviation that is the day's healthy friction's
    /// (`shared::uncertainty::SystematicError::friction_for`, in quadrature; 0 without a
    /// declared gearbox spread).
    pub friction_nuisance: f32,
    /// The healthy friction the identification read against the day's estimate: below 1
    /// where it estimated the day's healthy friction lower (`Identification::with_nuisances`;
    /// 1 without a declared gearbox spread or where it read a friction fault).
    pub healthy_friction: f32,
    /// What the test showed of a moment on the surface beyond its spring
    /// (`shared::domain::Domain::with_load`).
    pub load: shared::domain::LoadSigns,
}

impl Identified {
    /// The flown domain verdict on this identification: `monitor`'s statistics of the test
    /// against `limits` with the best fitness and the day, then the moved-load check — the
    /// firmware's report, in one place for every ground tool.
    pub fn domain(
        &self,
        monitor: &shared::domain::DomainMonitor,
        limits: &shared::domain::DomainLimits,
    ) -> shared::domain::Domain {
        monitor
            .assess(limits, self.result.fitness, &self.conditions)
            .with_load(self.load)
    }

    /// Verdicts that use the uncertainty (the plain threshold verdicts without one).
    pub fn assessments(&self) -> [Assessment; FAULT_COUNT] {
        self.assessments_at(shared::fault::DETECTION_THRESHOLD)
    }

    /// [`Self::assessments`] against `threshold` (an actuator record's).
    pub fn assessments_at(&self, threshold: f32) -> [Assessment; FAULT_COUNT] {
        let k = &self.result.faults;
        match &self.uncertainty {
            Some((u, correlation)) => u.assess_at(k, correlation, threshold),
            None => plain_assessments(k, threshold),
        }
    }
}

impl Identified {
    /// The health record the controller logs of this reading as flight `flight`, judged
    /// `domain` (`firmware::health::test_record`'s fields: the vector, fitness, deviations,
    /// the day, the weak magnet and its deviation).
    pub fn health_record(
        &self,
        flight: u32,
        domain: shared::domain::Domain,
    ) -> shared::health::HealthRecord {
        shared::health::HealthRecord::new(flight, self.result.faults, self.result.fitness, domain)
            .with_std(
                self.uncertainty
                    .as_ref()
                    .map_or([f32::NAN; FAULT_COUNT], |(u, _)| u.std),
            )
            .with_day(shared::health::RecordedDay::of(&self.conditions))
            .with_magnet(&self.result.magnets)
            .with_magnet_std(self.magnet_std())
    }

    /// The weak magnet's standard deviation (`shared::uncertainty::depth_deviation`; NaN
    /// without a magnet or an uncertainty).
    pub fn magnet_std(&self) -> f32 {
        self.uncertainty
            .as_ref()
            .map_or(f32::NAN, |(u, _)| u.magnet_std)
    }

    /// The weak magnet's verdict against `threshold`, by the firmware's rule
    /// (`shared::uncertainty::assess_magnet`).
    pub fn magnet_assessment_at(&self, threshold: f32) -> Assessment {
        shared::uncertainty::assess_magnet(self.result.magnets.depth, self.magnet_std(), threshold)
    }
}

/// Verdicts without an uncertainty: the plain threshold, a value beyond it only `Suspect`.
pub fn plain_assessments(k: &shared::FaultVector, threshold: f32) -> [Assessment; FAULT_COUNT] {
    k.verdicts_at(threshold).map(|v| match v {
        shared::Verdict::Healthy => Assessment::Healthy,
        shared::Verdict::Faulty => Assessment::Suspect,
        shared::Verdict::NotApplicable => Assessment::NotApplicable,
    })
}

/// Where the GA record goes and when (`identify --checkpoint`).
#[derive(Clone, Debug, PartialEq)]
pub struct Checkpointing {
    pub path: PathBuf,
    /// Evaluations between two writes (rounded up to whole slices).
    pub every: u32,
    /// Simulated power loss: stop once this many evaluations are done, record written.
    pub stop_after: Option<u32>,
}

/// What became of an existing checkpoint file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Resumption {
    /// No file: a fresh run.
    Fresh,
    /// Resumed at this many evaluations.
    Resumed(u32),
    /// The file was refused; the run restarted from scratch.
    Refused(RecordError),
}

/// How a checkpointed identification ended.
#[derive(Clone, Debug)]
pub enum Outcome {
    Finished(Box<Identified>),
    /// `stop_after` reached; the record holds this many evaluations.
    Interrupted {
        evaluations: u32,
    },
}

/// The command table of `measured`'s chirp at `record`'s control period (20 kB): the firmware
/// plays the chirp at every step, the host reads the same bits from this table.
pub fn command_table(
    measured: &OnboardMeasured,
    record: &ActuatorRecord,
) -> Box<CommandTable<TEST_SAMPLES>> {
    Box::new(CommandTable::new(
        measured.test().chirp,
        record.params.control_period,
    ))
}

/// The onboard identification of `measured` for `record`'s actuator (its parameters and
/// calibration) with GA `settings` and `seed`, reading the command from `table`: the
/// firmware's code, sizes and bits.
pub fn onboard_identification<'a>(
    measured: &'a OnboardMeasured,
    record: &ActuatorRecord,
    settings: GaSettings,
    seed: u64,
    table: &'a CommandTable<TEST_SAMPLES>,
) -> Result<Identification<'a, TEST_SAMPLES, POPULATION>> {
    Identification::with_nuisances(
        measured,
        record.params,
        &record.calibration,
        &record.systematic,
        settings,
        seed,
    )
    .and_then(|id| id.with_command_table(table))
    .map_err(|e| anyhow::anyhow!("setting up the identification: {e:?}"))
}

/// Identifies the faults behind `measured` of the reference actuator with `calibration`.
/// `progress` shows a bar on stderr.
pub fn identify(
    measured: &OnboardMeasured,
    calibration: &Calibration,
    seed: u64,
    progress: bool,
) -> Result<Identified> {
    let record = ActuatorRecord {
        calibration: *calibration,
        ..ActuatorRecord::REFERENCE
    };
    identify_for(measured, &record, seed, progress)
}

/// Identifies the faults behind `measured` of the actuator `record` describes (its
/// parameters, calibration and GA settings; the test is `measured`'s).
pub fn identify_for(
    measured: &OnboardMeasured,
    record: &ActuatorRecord,
    seed: u64,
    progress: bool,
) -> Result<Identified> {
    match identify_checkpointed(measured, record, seed, progress, None)?.0 {
        Outcome::Finished(id) => Ok(*id),
        // Only a checkpointed run can be cut short.
        Outcome::Interrupted { evaluations } => {
            anyhow::bail!("identification stopped after {evaluations} evaluations")
        }
    }
}

fn read_record(path: &Path) -> Result<Option<Vec<u8>>> {
    match std::fs::read(path) {
        Ok(bytes) => Ok(Some(bytes)),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(e).with_context(|| format!("reading checkpoint {}", path.display())),
    }
}

/// Writes the record beside `path` and renames it over: a crash mid-write leaves the old one.
fn write_record(path: &Path, record: &OnboardRecord) -> Result<()> {
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".tmp");
    std::fs::write(&tmp, record).with_context(|| format!("writing {}", path.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("replacing {}", path.display()))
}

/// [`identify`] with an optional checkpoint file: resumes from it if it is a sound record of
/// this run, writes it every `every` evaluations and at the end, and stops early on
/// `stop_after`.
pub fn identify_checkpointed(
    measured: &OnboardMeasured,
    record: &ActuatorRecord,
    seed: u64,
    progress: bool,
    checkpointing: Option<&Checkpointing>,
) -> Result<(Outcome, Resumption)> {
    if measured.conditions().temperature().is_none()
        && record
            .calibration
            .friction_points
            .iter()
            .any(|p| p[1] > 0.0)
    {
        anyhow::bail!(
            "the trace carries no measured temperature (a version 3 trace has `temp`), and \
             the calibration has a friction law: the healthy friction cannot be set for the \
             day (a cold actuator's friction would read as a fault, or hide one). Record the \
             controller's temperature with the test"
        );
    }
    let settings = record.ga;
    let polish = record.polish;
    let systematic = record.systematic;
    let start = Instant::now();
    // The table is built inside the timed span.
    let table = command_table(measured, record);
    let mut id = onboard_identification(measured, record, settings, seed, &table)?;
    let mut resumption = Resumption::Fresh;
    let mut record: OnboardRecord = [0; std::mem::size_of::<OnboardRecord>()];
    if let Some(c) = checkpointing {
        if let Some(bytes) = read_record(&c.path)? {
            resumption = match id.resume(&bytes) {
                Ok(n) => Resumption::Resumed(n),
                Err(e) => Resumption::Refused(e),
            };
        }
    }
    let mut next_write = checkpointing.map_or(u32::MAX, |c| id.ga().evaluations() + c.every);
    let bar = crate::progress_bar(
        u64::from(settings.max_evaluations),
        "identifying {bar:40} {pos}/{len} evaluations {msg}",
        progress,
    );
    let mut history = Vec::new();
    loop {
        let done = id.ga().evaluations();
        // Never step past the simulated power loss.
        let slice = checkpointing
            .and_then(|c| c.stop_after)
            .map_or(SLICE, |stop| stop.saturating_sub(done).min(SLICE));
        let status = id.step(slice);
        let evaluations = id.ga().evaluations();
        let best = id.ga().best();
        history.push((evaluations, best.fitness));
        bar.set_position(u64::from(evaluations));
        bar.set_message(format!("best {:.3e} A²·s", best.fitness));
        if let Some(c) = checkpointing {
            let cut = c.stop_after.is_some_and(|n| evaluations >= n);
            let finished = matches!(status, Status::Done(_));
            if evaluations >= next_write || cut || finished {
                next_write = evaluations.saturating_add(c.every);
                id.save(&mut record)
                    .map_err(|e| anyhow::anyhow!("checkpoint: {e:?}"))?;
                write_record(&c.path, &record)?;
            }
            if cut && !finished {
                bar.finish_and_clear();
                return Ok((Outcome::Interrupted { evaluations }, resumption));
            }
        }
        if let Status::Done(_) = status {
            break;
        }
    }
    let mut run = Box::new(shared::fitness::CurvatureRun::IDLE);
    let polished = id.polished(polish, &mut run);
    let result = id.with_weak_magnet(polished, polish, &mut run);
    let seconds = start.elapsed().as_secs_f64();
    bar.finish_and_clear();
    let curvature = id.problem().curvature_in(&mut run, &result.faults);
    let healthy_friction = id.problem().model().healthy_friction_read(&result.faults);
    let (result, uncertainty) = id.read(result, &curvature, &systematic);
    let day = systematic.on_day(id.problem().conditions().friction_slope);
    Ok((
        Outcome::Finished(Box::new(Identified {
            result,
            seconds,
            history,
            uncertainty,
            conditions: *id.problem().conditions(),
            friction_nuisance: day.friction_for(&result.faults),
            healthy_friction,
            load: id.problem().load_signs(run.load_offset()),
        })),
        resumption,
    ))
}
