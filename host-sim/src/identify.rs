//! Running the onboard FDI on the host: the very `shared` code, sizes, GA settings and seed
//! the firmware uses, driven in slices of [`SLICE`] evaluations so that the host can show
//! progress and record the fitness history.

use std::time::Instant;

use anyhow::Result;
use shared::command::CommandTable;
use shared::fdi::{
    Identification, IdentificationResult, OnboardMeasured, POPULATION, TEST_SAMPLES,
};
use shared::{ActuatorParams, Calibration, ChirpCommand, GaSettings, Status};

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
}

/// Identifies the faults behind `measured`. `progress` shows a bar on stderr.
pub fn identify(
    measured: &OnboardMeasured,
    calibration: &Calibration,
    seed: u64,
    progress: bool,
) -> Result<Identified> {
    let settings = GaSettings::FDI;
    let params = ActuatorParams::REFERENCE;
    let start = Instant::now();
    // The firmware evaluates the chirp at every step; the host reads the same bits from a
    // table (20 kB), built inside the timed span.
    let table = Box::new(CommandTable::<TEST_SAMPLES>::new(
        ChirpCommand::PREFLIGHT,
        params.control_period,
    ));
    let mut id = Identification::<TEST_SAMPLES, POPULATION>::new(
        measured,
        params,
        calibration,
        settings,
        seed,
    )
    .and_then(|id| id.with_command_table(&table))
    .map_err(|e| anyhow::anyhow!("setting up the identification: {e:?}"))?;
    let bar = crate::progress_bar(
        u64::from(settings.max_evaluations),
        "identifying {bar:40} {pos}/{len} evaluations {msg}",
        progress,
    );
    let mut history = Vec::new();
    loop {
        let status = id.step(SLICE);
        let best = id.ga().best();
        history.push((id.ga().evaluations(), best.fitness));
        bar.set_position(u64::from(id.ga().evaluations()));
        bar.set_message(format!("best {:.3e} A²·s", best.fitness));
        if let Status::Done(_) = status {
            break;
        }
    }
    let seconds = start.elapsed().as_secs_f64();
    bar.finish_and_clear();
    Ok(Identified {
        result: id.result_so_far(),
        seconds,
        history,
    })
}
