//! `board-emu`: runs the board image on the emulated STM32F405 and prints its RTT log
//! (decoded by `defmt-print`), the clocks it configured and its frames' timing.

use std::io::Write;
use std::path::PathBuf;
use std::process::{Command, Stdio};

use anyhow::{Context, Result};
use board_emu::flash::FlashInterface;
use board_emu::plant::{MotorOnPins, OpenBridge, Plant, ReferenceOnPins};
use board_emu::{Board, RunEnd};
use clap::Parser;
use host_sim::plant::pair_motor::PairMotor;
use host_sim::plant::reference::{ReferenceModel, ReferenceSettings, Scenario};

#[derive(Parser)]
#[command(
    about = "Runs the board image (cargo board-build) on an emulated STM32F405: its clocks, \
flash, bridge timer, converters and encoder modelled at register level, the motor's leads open \
(no current, no motion), and prints its RTT log"
)]
struct Args {
    /// The board image's ELF.
    #[arg(long, default_value = "target/thumbv7em-none-eabihf/board/firmware")]
    elf: PathBuf,
    /// A flash pair image to program before the run, as ADDRESS=FILE (from `host-sim
    /// flash-pair --store record --write R.rec --out pair.bin`: 0x08020000=pair.bin).
    #[arg(long = "flash", value_name = "ADDRESS=FILE")]
    flash: Vec<String>,
    /// Instructions to run at most.
    #[arg(long, default_value_t = 50_000_000)]
    instructions: u64,
    /// The bus voltage [V] and the winding's temperature [°C] the converters read.
    #[arg(long, default_value_t = 270.0)]
    bus_volts: f32,
    #[arg(long, default_value_t = 20.0)]
    celsius: f32,
    /// What the pins drive: `open` (the motor's leads open: no current, no motion), `motor`
    /// (a plain brushless motor on a rigid gear, the reference actuator's constants: no
    /// friction, no load, no dead time) or `reference` (the reference model with `--faults`,
    /// its own bridge on TIM1's legs; `--bus-volts` and `--celsius` are then its own).
    #[arg(long, value_enum, default_value_t = PlantKind::Open)]
    plant: PlantKind,
    /// Write what the image measured over its test (each frame's conversions and encoder
    /// capture, converted as the board does) as a binary trace, for `host-sim identify` and
    /// `cargo fw` (the reference actuator's test).
    #[arg(long, value_name = "FILE")]
    trace_out: Option<PathBuf>,
    /// The reference model's fault vector (nine comma-separated values, the trace's order).
    #[arg(long, default_value = "0,0,0,0,0,0,0.5,0.5,0", value_delimiter = ',')]
    faults: Vec<f32>,
    /// The reference model's seed (its sensors' noise).
    #[arg(long, default_value_t = 1)]
    seed: u64,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum PlantKind {
    Open,
    Motor,
    Reference,
}

fn main() -> Result<()> {
    let args = Args::parse();
    let elf = std::fs::read(&args.elf).with_context(|| {
        format!(
            "reading {} (build it with `cargo board-build`)",
            args.elf.display()
        )
    })?;
    let mut flash = FlashInterface::new();
    for item in &args.flash {
        let (address, file) = item.split_once('=').context("--flash takes ADDRESS=FILE")?;
        let address = u32::from_str_radix(address.trim_start_matches("0x"), 16)
            .with_context(|| format!("{address}: a hexadecimal address"))?;
        let bytes = std::fs::read(file).with_context(|| format!("reading {file}"))?;
        flash.load(address, &bytes)?;
    }
    let plant: Box<dyn Plant> = match args.plant {
        PlantKind::Open => Box::new(OpenBridge::new(args.bus_volts, args.celsius)),
        PlantKind::Motor => Box::new(MotorOnPins::new(
            PairMotor::new(shared::params::ActuatorParams::REFERENCE, args.bus_volts),
            args.celsius,
        )),
        PlantKind::Reference => {
            let faults: [f32; shared::FAULT_COUNT] = args
                .faults
                .as_slice()
                .try_into()
                .with_context(|| format!("--faults takes {} values", shared::FAULT_COUNT))?;
            let faults =
                shared::FaultVector::new(faults).map_err(|e| anyhow::anyhow!("--faults: {e:?}"))?;
            let record = shared::actuator::ActuatorRecord::REFERENCE;
            let model = ReferenceModel::new(ReferenceSettings::REFERENCE).with_test(record.test);
            let scenario = Scenario {
                seed: args.seed,
                ..Scenario::new(faults)
            };
            Box::new(ReferenceOnPins::new(model, scenario))
        }
    };
    let mut board = Board::new(&elf, flash, plant)?;
    let end = board.run(args.instructions)?;
    decode(&args.elf, &board.log)?;
    println!("end {end:?} after {} instructions", board.instructions);
    if let Some(c) = board.clocks {
        println!("clocks {c:?} flash_wait_states={}", board.latency_at_start);
    }
    let f = &board.frames;
    let mut l = f.latencies.clone();
    l.sort_unstable();
    if let (Some(median), Some(worst)) = (l.get(l.len() / 2), l.last()) {
        println!(
            "frames triggers={} read={} trigger_to_read_instructions median={median} worst={worst}",
            f.triggers,
            l.len()
        );
    }
    if let Some(path) = &args.trace_out {
        let record = shared::actuator::ActuatorRecord::REFERENCE;
        let frames =
            firmware::sequencer::TestSequencer::new(record.test, record.params.control_period)
                .samples();
        let trace = board_emu::feed::fed_trace(&board.frames.fed, &record, frames)
            .context("the test did not run to its end")?;
        std::fs::write(path, trace.to_bin()?)
            .with_context(|| format!("writing {}", path.display()))?;
        println!(
            "wrote {} ({frames} frames the image measured)",
            path.display()
        );
    }
    std::process::exit(match end {
        RunEnd::Asleep { .. } | RunEnd::InstructionLimit => 0,
        _ => 1,
    })
}

/// The RTT bytes through `defmt-print -e ELF`, or their count if it is not installed.
fn decode(elf: &PathBuf, log: &[u8]) -> Result<()> {
    let child = Command::new("defmt-print")
        .arg("-e")
        .arg(elf)
        .stdin(Stdio::piped())
        .spawn();
    match child {
        Ok(mut child) => {
            if let Some(mut stdin) = child.stdin.take() {
                stdin.write_all(log)?;
            }
            child.wait()?;
        }
        Err(_) => println!(
            "rtt {} bytes (install defmt-print to decode them)",
            log.len()
        ),
    }
    Ok(())
}
