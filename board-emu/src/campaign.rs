//! Known faults read through the board: the board image plays the actuator's preflight test
//! on the reference model (the actuator's physics on TIM1's legs, its sensors through the
//! board's converters and encoder), and the trace it measured is identified by the onboard
//! FDI's code on the host — the same bits as the board's own identification
//! (`tests/board_image.rs`), without its 2.2 × 10⁹ emulated instructions. Beside it, the same
//! actuator, faults and seed under the actuator's own controller (the accuracy campaigns'
//! setting), identified the same way.
//!
//! Per run: the test's frames on the emulator (≈ 10⁸ instructions, a few seconds), two
//! reference-model runs and two identifications. The controller's gain drift (k8) is the
//! actuator's own controller's fault: on the board's pins the board's position gain drives,
//! so the board's truth for k8 is the nominal 0.5 and Table I's gain-drift cases are left out.

use anyhow::{Context, Result};
use host_sim::files::actuator::Actuator;
use host_sim::files::flash_pair::{pair_image, Store};
use host_sim::plant::reference::{ReferenceModel, Scenario};
use shared::domain::Domain;
use shared::fault::GAIN_DRIFT_INDEX;
use shared::metrics::total_error;
use shared::FaultVector;

use crate::flash::FlashInterface;
use crate::plant::ReferenceOnPins;
use crate::{Board, RunEnd};

/// Instructions the board may take to its test's last frame (boot, configuration, the
/// reference model's pre-roll and the test; ≈ 1.2 × 10⁸ for a 0.55 s test).
const TEST_INSTRUCTIONS: u64 = 400_000_000;

/// One reading of one run.
#[derive(Clone, Copy, Debug)]
pub struct Reading {
    pub faults: FaultVector,
    pub domain: Domain,
    /// Eq. (4) against the truth [%].
    pub e_tot: f32,
}

/// One run: the board's reading and the actuator's own controller's.
#[derive(Clone, Copy, Debug)]
pub struct CaseRun {
    pub board: Reading,
    pub own: Reading,
}

/// The board image `elf` on `actuator` (a description: the reference model plays it) with
/// `faults`, reference-model seed `seed` and GA seed `ga_seed`.
pub fn run_case(
    elf: &[u8],
    actuator: &Actuator,
    faults: FaultVector,
    seed: u64,
    ga_seed: u64,
) -> Result<CaseRun> {
    let record = actuator.record_for(&actuator.record.test)?;
    let model = ReferenceModel::new(actuator.reference_settings()?).with_test(record.test);
    let scenario = Scenario {
        seed,
        ..Scenario::new(faults)
    };
    // The board: the record in its sectors, the reference model on its pins.
    let mut flash = FlashInterface::new();
    flash.load(
        Store::Record.address(),
        &pair_image(&actuator.record_bytes())?,
    )?;
    let plant = ReferenceOnPins::new(model, scenario);
    let mut board = Board::new(elf, flash, Box::new(plant))?;
    let frames = firmware::sequencer::TestSequencer::new(record.test, record.params.control_period)
        .samples();
    while board.frames.fed.len() < frames {
        match board.run(10_000_000)? {
            RunEnd::InstructionLimit if board.instructions < TEST_INSTRUCTIONS => {}
            end => anyhow::bail!(
                "the board stopped before its test's last frame ({} of {frames} after {} \
                 instructions): {end:?}",
                board.frames.fed.len(),
                board.instructions
            ),
        }
    }
    let fed = crate::feed::fed_trace(&board.frames.fed, &record, frames)?;
    // The board drives with its own gain: the reference model's gain drift acts on nothing.
    let mut board_truth = *faults.as_array();
    if let Some(k8) = board_truth.get_mut(GAIN_DRIFT_INDEX) {
        *k8 = FaultVector::NOMINAL.as_array()[GAIN_DRIFT_INDEX];
    }
    let board_truth = FaultVector::new(board_truth).map_err(|e| anyhow::anyhow!("{e:?}"))?;
    let own = model.simulate(&scenario).trace;
    Ok(CaseRun {
        board: read(&fed, &record, &board_truth, ga_seed).context("the board's trace")?,
        own: read(&own, &record, &faults, ga_seed).context("the actuator's own trace")?,
    })
}

/// The onboard FDI's reading of `trace` against `truth`.
fn read(
    trace: &host_sim::files::trace::Trace,
    record: &shared::actuator::ActuatorRecord,
    truth: &FaultVector,
    ga_seed: u64,
) -> Result<Reading> {
    let measured = trace.measured(&record.params)?;
    let id = host_sim::fdi::identify::identify_for(&measured, record, ga_seed, false)?;
    let domain = id.domain(&trace.domain_monitor(&record.params), &record.domain);
    Ok(Reading {
        faults: id.result.faults,
        domain,
        e_tot: total_error(&id.result.faults, truth),
    })
}
