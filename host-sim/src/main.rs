//! `host-sim`: the ground tools of ema-fdi.
//!
//! For now: the inverse-identification demo (a trace made by the monitor model itself at a
//! known fault vector, identified by the onboard FDI), the memory footprint of the onboard
//! FDI state, and a benchmark of one monitor-model evaluation. The reference model, trace
//! files and calibration come next.

use std::process::ExitCode;
use std::time::Instant;

use anyhow::Result;
use clap::{Parser, Subcommand};
use shared::fault::FAULT_NAMES;
use shared::fdi::{
    record_monitor_trace, Identification, OnboardGa, OnboardMeasured, POPULATION, TEST_SAMPLES,
};
use shared::metrics::{component_errors, total_error};
use shared::monitor::MonitorState;
use shared::{
    ActuatorParams, Calibration, FaultVector, FitnessProblem, GaSettings, LowPass, MonitorModel,
};

mod faults;

#[derive(Parser)]
#[command(
    name = "host-sim",
    version,
    about = "Ground tools for the ema-fdi onboard actuator prognostics"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Inverse check: simulate the monitor model at known faults, then identify them with the
    /// onboard FDI (same code, settings and sizes as the firmware).
    Inverse {
        /// True fault vector: eight comma-separated values in [0, 1]
        /// (friction, backlash, short A, short B, short C, eccentricity, ecc. phase, gain drift).
        #[arg(long, value_parser = faults::parse_fault_vector, allow_hyphen_values = true)]
        faults: FaultVector,
        /// GA seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Print one JSON object instead of the table.
        #[arg(long)]
        json: bool,
    },
    /// Bytes of the onboard FDI state (GA, measured-current buffer, monitor model).
    Footprint,
    /// Time one monitor-model evaluation and one fitness evaluation (0.5 s test) on one core.
    Bench {
        /// Evaluations to time.
        #[arg(long, default_value_t = 2000, value_parser = clap::value_parser!(u32).range(1..))]
        evaluations: u32,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let outcome = match cli.command {
        Command::Inverse { faults, seed, json } => inverse(faults, seed, json),
        Command::Footprint => {
            footprint();
            Ok(())
        }
        Command::Bench { evaluations } => bench(evaluations),
    };
    match outcome {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn measured_from_monitor(
    model: &MonitorModel,
    truth: &FaultVector,
) -> Result<Box<OnboardMeasured>> {
    let filter = LowPass::for_control_period(model.params().control_period)
        .map_err(|e| anyhow::anyhow!("conditioning filter: {e:?}"))?;
    let mut measured = Box::new(OnboardMeasured::new(filter));
    record_monitor_trace(model, truth, &mut measured)
        .map_err(|e| anyhow::anyhow!("recording the trace: {e:?}"))?;
    Ok(measured)
}

fn inverse(truth: FaultVector, seed: u64, json: bool) -> Result<()> {
    let params = ActuatorParams::REFERENCE;
    let calibration = Calibration::IDENTITY;
    let model = MonitorModel::new(params, &calibration);
    let measured = measured_from_monitor(&model, &truth)?;
    let mut id = Identification::<TEST_SAMPLES, POPULATION>::new(
        &measured,
        params,
        &calibration,
        GaSettings::FDI,
        seed,
    )
    .map_err(|e| anyhow::anyhow!("setting up the identification: {e:?}"))?;
    let start = Instant::now();
    let result = id.run();
    let seconds = start.elapsed().as_secs_f64();
    let errors = component_errors(&result.faults, &truth);
    let e_tot = total_error(&result.faults, &truth);
    if json {
        let list = |v: &[f32]| {
            v.iter()
                .map(|x| format!("{x}"))
                .collect::<Vec<_>>()
                .join(",")
        };
        println!(
            "{{\"faults\":[{}],\"truth\":[{}],\"fitness\":{},\"evaluations\":{},\"seconds\":{seconds:.4},\"e_tot\":{e_tot},\"stop_reason\":\"{:?}\"}}",
            list(result.faults.as_array()),
            list(truth.as_array()),
            result.fitness,
            result.evaluations,
            result.stop_reason
        );
        return Ok(());
    }
    println!(
        "{:<14} {:>8} {:>8} {:>8}",
        "fault", "true", "found", "e_i [%]"
    );
    for (i, name) in FAULT_NAMES.iter().enumerate() {
        println!(
            "{name:<14} {:>8.4} {:>8.4} {:>8.3}",
            truth.as_array()[i],
            result.faults.as_array()[i],
            errors[i]
        );
    }
    println!("e_tot        {e_tot:.4} %");
    println!("fitness      {:.4e} A²·s", result.fitness);
    println!(
        "evaluations  {} (stopped: {:?})",
        result.evaluations, result.stop_reason
    );
    println!("seconds      {seconds:.3}");
    Ok(())
}

fn footprint() {
    use core::mem::size_of;
    let ga = size_of::<OnboardGa>();
    let measured = size_of::<OnboardMeasured>();
    let model = size_of::<MonitorModel>();
    let state = size_of::<MonitorState>();
    println!("onboard GA (population {POPULATION})          {ga:>6} B");
    println!("measured current ({TEST_SAMPLES} samples)      {measured:>6} B");
    println!("monitor model settings                {model:>6} B");
    println!("monitor model running state           {state:>6} B");
    let total = ga + measured + model + state;
    println!(
        "total                                 {total:>6} B ({:.1} KiB; target 24 KiB)",
        total as f64 / 1024.0
    );
}

fn bench(evaluations: u32) -> Result<()> {
    let params = ActuatorParams::REFERENCE;
    let model = MonitorModel::new(params, &Calibration::IDENTITY);
    let truth = FaultVector::new([0.1, 0.1, 0.1, 0.05, 0.0, 0.1, 0.25, 0.4])
        .map_err(|e| anyhow::anyhow!("bench fault vector: {e:?}"))?;
    let measured = measured_from_monitor(&model, &truth)?;
    let problem = FitnessProblem::new(&measured, params, &Calibration::IDENTITY)
        .map_err(|e| anyhow::anyhow!("fitness: {e:?}"))?;
    // Candidates spread over the fault space, as the GA would ask (eccentricity on).
    let candidates: Vec<FaultVector> = (0..16)
        .map(|i| {
            let x = i as f32 / 16.0;
            FaultVector::saturating([
                x,
                1.0 - x,
                0.5 * x,
                0.3,
                0.1,
                0.2 + 0.5 * x,
                x,
                0.3 + 0.4 * x,
            ])
        })
        .collect();
    let steps = model.test_samples();
    let mut buffer = vec![0.0f32; steps];
    let start = Instant::now();
    for i in 0..evaluations {
        model.simulate(&candidates[i as usize % candidates.len()], &mut buffer);
        std::hint::black_box(&buffer);
    }
    let mm = start.elapsed().as_secs_f64() / f64::from(evaluations);
    let start = Instant::now();
    let mut sink = 0.0f32;
    for i in 0..evaluations {
        sink += problem.error(&candidates[i as usize % candidates.len()]);
    }
    std::hint::black_box(sink);
    let fit = start.elapsed().as_secs_f64() / f64::from(evaluations);
    println!(
        "monitor model, {steps} steps (0.5 s):  {:>8.1} µs/evaluation  {:>6.1} ns/step",
        mm * 1e6,
        mm * 1e9 / steps as f64
    );
    println!(
        "fitness eq. (3) incl. model + filter:  {:>8.1} µs/evaluation  {:>6.1} ns/step",
        fit * 1e6,
        fit * 1e9 / steps as f64
    );
    println!("({evaluations} evaluations, one core; target ≤ 100 µs/evaluation)");
    Ok(())
}
