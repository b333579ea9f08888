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
use host_sim::files::trace::TraceFormat;
use host_sim::plant::pair_motor::PairMotor;
use host_sim::plant::reference::{ReferenceModel, Scenario};

#[derive(Parser)]
#[command(
    about = "Runs the board image (cargo board-build) on an emulated STM32F405: its clocks, \
flash, bridge timer, converters and encoder modelled at register level, with the motor's leads \
open, a plain motor or the reference model on its pins, and prints its RTT log, clocks and \
frame timing (--table: known faults read through the board)"
)]
struct Args {
    /// The board image's ELF.
    #[arg(long, default_value = "target/thumbv7em-none-eabihf/board/firmware")]
    elf: PathBuf,
    /// A flash pair image to program before the run, as ADDRESS=FILE (from `host-sim
    /// flash-pair --store record --write R.rec --out pair.bin`: 0x08020000=pair.bin).
    /// Without any, the `--actuator`'s record is flashed in its pair.
    #[arg(long = "flash", value_name = "ADDRESS=FILE")]
    flash: Vec<String>,
    /// Instructions to run at most.
    #[arg(long, default_value_t = 50_000_000)]
    instructions: u64,
    /// The bus voltage [V] (default: the actuator's) and the winding's temperature [°C] the
    /// converters read.
    #[arg(long)]
    bus_volts: Option<f32>,
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
    /// `cargo fw` (the reference actuator's test); CSV where the name ends in `.csv`.
    #[arg(long, value_name = "FILE")]
    trace_out: Option<PathBuf>,
    /// The reference model's fault vector (nine comma-separated values, the trace's order).
    #[arg(long, default_value = "0,0,0,0,0,0,0.5,0.5,0", value_delimiter = ',')]
    faults: Vec<f32>,
    /// The reference model's seed (its sensors' noise; its wind's).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// A wind on the parked surface for `--plant reference`, MEAN,GUST [kt] (e.g. 20,35):
    /// it may spoil a test, which the board then runs again.
    #[arg(long, value_name = "MEAN,GUST", value_delimiter = ',')]
    wind: Vec<f64>,
    /// How many of the board's tests meet the wind (the next seed each); the tests after
    /// them are in still air (at most three tests in all: the first and two re-runs).
    #[arg(long, default_value_t = 3)]
    windy_tests: u32,
    /// Known faults through the board instead of one run: Table I's single faults (`1`,
    /// without its gain-drift cases: on the board's pins the board's own gain drives) or
    /// Table II's multiple faults (`2`, without I_ref noise, which acts in the actuator's
    /// own controller), each run read from the trace the board measured and, beside it,
    /// under the actuator's own controller. Run r: reference-model seed r, GA seed 1 + r.
    #[arg(long, value_name = "1|2")]
    table: Option<u8>,
    /// Runs per case of `--table`, and seeds of `--window-sensors`.
    #[arg(long, default_value_t = 3)]
    runs: u64,
    /// The actuator (a description, TOML): its record is flashed (unless `--flash`), the
    /// motor has its constants, the reference model plays it, the trace is its test's.
    /// Default: the built-in reference actuator.
    #[arg(long, value_name = "FILE")]
    actuator: Option<PathBuf>,
    /// Where `--table` writes its Markdown table (default: standard output only).
    #[arg(long, value_name = "FILE")]
    out: Option<PathBuf>,
    /// With `--plant reference`: after the preflight, a flight in this phase follows at
    /// once — the flight control computer's demand on the board's demand input, the hinge
    /// moment and gusts on the surface — which the board flies, playing and reading its
    /// windows in the control loop's idle time. No re-run day is queued (a spoiled preflight
    /// would meet the flight).
    #[arg(long, value_enum)]
    flight: Option<host_sim::plant::aero::FlightPhase>,
    /// The flight's turbulence.
    #[arg(long, value_enum, default_value_t = host_sim::plant::aero::Turbulence::Light)]
    turbulence: host_sim::plant::aero::Turbulence,
    /// The flight's length [s] (a window's reading takes ≈ 50 s of flight at one slice per
    /// control period; what is left when the flight ends is read on the ground).
    #[arg(long, default_value_t = 60.0)]
    flight_seconds: f64,
    /// Write each window of flight the image read as a binary trace, PREFIX-N.bin (N from
    /// 1), with the command its flight followed, for `host-sim identify`.
    #[arg(long, value_name = "PREFIX")]
    window_out: Option<PathBuf>,
    /// Instead of running the image: what the board's drive and sensors cost a window of
    /// flight, on the host (no emulation, ≈ 1 s per row). The board's flight drive flies the
    /// reference model with `--faults` and `--seed` through climb, cruise and approach (or
    /// `--flight`), reading its encoder and transducer at the board's resolution and at the
    /// actuator's own, and each window is read with the same seed's preflight held: a
    /// Markdown table (`--out`), over `--runs` seeds from `--seed`.
    #[arg(long)]
    window_sensors: bool,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum PlantKind {
    Open,
    Motor,
    Reference,
}

fn main() -> Result<()> {
    let args = Args::parse();
    if args.window_sensors {
        return window_sensors(&args);
    }
    let elf = std::fs::read(&args.elf).with_context(|| {
        format!(
            "reading {} (build it with `cargo board-build`)",
            args.elf.display()
        )
    })?;
    if let Some(table) = args.table {
        return campaign(&args, &elf, table);
    }
    let actuator = host_sim::files::actuator::Actuator::from_option(args.actuator.as_deref())?;
    let record = actuator.record_for(&actuator.record.test)?;
    let bus_volts = args.bus_volts.unwrap_or(record.params.dc_bus_voltage);
    let mut flash = FlashInterface::new();
    if args.flash.is_empty() {
        let pair = host_sim::files::flash_pair::pair_image(&actuator.record_bytes())?;
        let address = host_sim::files::flash_pair::Store::Record.address();
        flash.load(address, &pair)?;
        println!("flashed {}'s record at {address:#010x}", actuator.name);
    }
    for item in &args.flash {
        let (address, file) = item.split_once('=').context("--flash takes ADDRESS=FILE")?;
        let address = u32::from_str_radix(address.trim_start_matches("0x"), 16)
            .with_context(|| format!("{address}: a hexadecimal address"))?;
        let bytes = std::fs::read(file).with_context(|| format!("reading {file}"))?;
        flash.load(address, &bytes)?;
    }
    let plant: Box<dyn Plant> = match args.plant {
        PlantKind::Open => Box::new(OpenBridge::new(bus_volts, args.celsius)),
        PlantKind::Motor => Box::new(MotorOnPins::new(
            PairMotor::new(record.params, bus_volts),
            args.celsius,
        )),
        PlantKind::Reference => {
            let faults = parse_faults(&args.faults)?;
            let still = ReferenceModel::new(actuator.reference_settings()?).with_test(record.test);
            let wind = match args.wind.as_slice() {
                [] => None,
                &[mean, gust] => Some(
                    host_sim::plant::aero::GroundWind::new(mean, gust)
                        .map_err(|e| anyhow::anyhow!("--wind: {e}"))?,
                ),
                _ => anyhow::bail!("--wind takes MEAN,GUST"),
            };
            // The first test and its two re-runs, each on a day of its own.
            let day = |test: u32| {
                let windy = wind.is_some() && test < args.windy_tests;
                let model = still.with_wind(if windy { wind } else { None });
                let scenario = Scenario {
                    seed: args.seed + u64::from(test),
                    ..Scenario::new(faults)
                };
                (model, scenario)
            };
            let (model, scenario) = day(0);
            let mut pins = ReferenceOnPins::new(model, scenario);
            if let Some(phase) = args.flight {
                anyhow::ensure!(
                    args.flight_seconds > 0.0 && args.flight_seconds <= 600.0,
                    "--flight-seconds: 0 … 600"
                );
                let periods = (args.flight_seconds / f64::from(record.params.control_period))
                    .round() as usize;
                let flight = still
                    .with_test(record.test.chirp_only())
                    .with_flight(Some(host_sim::plant::aero::FlightWindow {
                        phase,
                        turbulence: args.turbulence,
                    }))
                    .with_flight_periods(Some(periods));
                let scenario = Scenario {
                    seed: args.seed + 100,
                    ..Scenario::new(faults)
                };
                pins = pins.then(flight, scenario);
            } else {
                for test in 1..u32::from(firmware::Reruns::MAX_TESTS) {
                    let (model, scenario) = day(test);
                    pins = pins.then(model, scenario);
                }
            }
            Box::new(pins)
        }
    };
    anyhow::ensure!(
        args.flight.is_none() || matches!(args.plant, PlantKind::Reference),
        "--flight takes --plant reference"
    );
    let mut board = Board::new(&elf, flash, plant)?;
    let end = run_with_progress(&mut board, args.instructions)?;
    let log = decode(&args.elf, &board.log)?;
    println!("end {end:?} after {} instructions", board.instructions);
    if let Some(c) = board.clocks {
        println!("clocks {c:?} flash_wait_states={}", board.latency_at_start);
    }
    let f = &board.frames;
    println!("frames triggers={} read={}", f.triggers, f.latencies.len());
    for (what, latencies) in [
        ("trigger_to_read", &f.latencies),
        ("trigger_to_duties", &f.to_duties),
    ] {
        println!("{what}_instructions {}", distribution(latencies));
    }
    if let Some(path) = &args.trace_out {
        let frames =
            firmware::sequencer::TestSequencer::new(record.test, record.params.control_period)
                .samples();
        let trace = board_emu::feed::fed_trace(&board.frames.fed, &record, frames)
            .context("the test did not run to its end")?;
        let format = match path.extension().and_then(|e| e.to_str()) {
            Some("csv") => TraceFormat::Csv,
            _ => TraceFormat::Bin,
        };
        trace.write(path, format)?;
        println!(
            "wrote {} ({frames} frames the image measured)",
            path.display()
        );
    }
    if let Some(prefix) = &args.window_out {
        let windows = board_emu::feed::windows_in_log(&log);
        anyhow::ensure!(!windows.is_empty(), "the image read no window");
        for (n, first, frames) in windows {
            let trace = board_emu::feed::window_trace(&board.frames.fed, &record, first, frames)?;
            let path = PathBuf::from(format!("{}-{n}.bin", prefix.display()));
            trace.write(&path, TraceFormat::Bin)?;
            println!(
                "wrote {} (window {n}: {frames} frames from frame {first})",
                path.display()
            );
        }
    }
    std::process::exit(match end {
        RunEnd::Asleep { .. } | RunEnd::InstructionLimit => 0,
        _ => 1,
    })
}

/// Percentiles and a histogram of `instructions` (resolution: the emulator's chunk), against
/// the 100 µs control period at 168 MHz (16 800 instructions).
fn distribution(instructions: &[u64]) -> String {
    let mut l = instructions.to_vec();
    l.sort_unstable();
    let Some(&worst) = l.last() else {
        return "none".into();
    };
    let at = |q: f64| l[((l.len() - 1) as f64 * q).round() as usize];
    let bins = [2_000u64, 4_000, 8_000, 12_000, 16_800, u64::MAX];
    let mut from = 0;
    let histogram: Vec<String> = bins
        .iter()
        .map(|&to| {
            let n = l.iter().filter(|&&x| x >= from && x < to).count();
            let label = if to == u64::MAX {
                format!("≥{from}")
            } else {
                format!("{from}–{to}")
            };
            from = to;
            format!("{label}:{n}")
        })
        .collect();
    format!(
        "n={} p50={} p90={} p99={} worst={worst} ({:.0} % of the period) histogram [{}]",
        l.len(),
        at(0.5),
        at(0.9),
        at(0.99),
        100.0 * worst as f64 / 16_800.0,
        histogram.join(" ")
    )
}

/// `--faults` as a fault vector.
fn parse_faults(values: &[f32]) -> Result<shared::FaultVector> {
    let faults: [f32; shared::FAULT_COUNT] = values
        .try_into()
        .with_context(|| format!("--faults takes {} values", shared::FAULT_COUNT))?;
    shared::FaultVector::new(faults).map_err(|e| anyhow::anyhow!("--faults: {e:?}"))
}

/// `--window-sensors`: the study's table, printed and written to `--out`.
fn window_sensors(args: &Args) -> Result<()> {
    use host_sim::plant::aero::FlightPhase;
    let actuator = host_sim::files::actuator::Actuator::from_option(args.actuator.as_deref())?;
    let faults = parse_faults(&args.faults)?;
    let phases = match args.flight {
        Some(phase) => vec![phase],
        None => vec![
            FlightPhase::Climb,
            FlightPhase::Cruise,
            FlightPhase::Approach,
        ],
    };
    let seeds = args.seed..args.seed + args.runs.max(1);
    let table = board_emu::sensing::table(&actuator, &phases, faults, seeds, |row| {
        eprintln!("flying: {row}");
    })?;
    print!("{table}");
    if let Some(out) = &args.out {
        std::fs::write(out, &table).with_context(|| format!("writing {}", out.display()))?;
        eprintln!("wrote {}", out.display());
    }
    Ok(())
}

/// `--table`: every case's runs through the board and under the actuator's own controller,
/// two runs at a time, as a Markdown table.
fn campaign(args: &Args, elf: &[u8], table: u8) -> Result<()> {
    use host_sim::studies::campaign::{TABLE_1, TABLE_2};
    use shared::fault::GAIN_DRIFT_INDEX;
    let cases: Vec<_> = match table {
        1 => TABLE_1
            .iter()
            .filter(|c| c.faults[GAIN_DRIFT_INDEX] == 0.5)
            .collect(),
        2 => TABLE_2.iter().filter(|c| c.noise == 0.0).collect(),
        other => anyhow::bail!("--table {other}: 1 (single faults) or 2 (multiple faults)"),
    };
    anyhow::ensure!(args.runs > 0, "--runs must be at least 1");
    let actuator = host_sim::files::actuator::Actuator::from_option(args.actuator.as_deref())?;
    let jobs: Vec<(usize, u64)> = (0..cases.len())
        .flat_map(|c| (0..args.runs).map(move |r| (c, r)))
        .collect();
    let next = std::sync::atomic::AtomicUsize::new(0);
    let results = std::sync::Mutex::new(vec![None; jobs.len()]);
    let started = std::time::Instant::now();
    std::thread::scope(|scope| -> Result<()> {
        let workers: Vec<_> = (0..2)
            .map(|_| {
                scope.spawn(|| -> Result<()> {
                    loop {
                        let j = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                        let Some(&(c, r)) = jobs.get(j) else {
                            return Ok(());
                        };
                        let case = cases[c];
                        let faults = shared::FaultVector::new(case.faults)
                            .map_err(|e| anyhow::anyhow!("{e:?}"))?;
                        let run = board_emu::campaign::run_case(elf, &actuator, faults, r, 1 + r)
                            .with_context(|| format!("{}, run {r}", case.name))?;
                        eprintln!(
                            "[{:>4.0} s] {} run {r}: board e_tot {:.2} % ({:?}), own {:.2} %",
                            started.elapsed().as_secs_f64(),
                            case.name,
                            run.board.e_tot,
                            run.board.domain,
                            run.own.e_tot
                        );
                        if let Some(slot) = results.lock().expect("no worker panics").get_mut(j) {
                            *slot = Some(run);
                        }
                    }
                })
            })
            .collect();
        for w in workers {
            w.join()
                .map_err(|_| anyhow::anyhow!("a worker panicked"))??;
        }
        Ok(())
    })?;
    let results = results.into_inner().expect("no worker panics");
    let mut md = format!(
        "### Through the board: Table {table} ({}, {} runs per case)\n\n\
         The board image on the emulated STM32F405 plays the test on the reference model; the \
         trace it measured is read by the onboard FDI's code (the board's own bits). \
         \"Own controller\": the same actuator, faults and seeds under the actuator's own \
         controller. e_tot in % (eq. 4); the board's truth has the nominal gain drift 0.5.\n\n\
         | case | board: mean e_tot | worst | within | own controller: mean e_tot | worst | \
         board's mean reading (k1 … k9) |\n| --- | --- | --- | --- | --- | --- | --- |\n",
        actuator.name, args.runs
    );
    for (c, case) in cases.iter().enumerate() {
        let runs: Vec<board_emu::campaign::CaseRun> = jobs
            .iter()
            .zip(&results)
            .filter(|((jc, _), _)| *jc == c)
            .filter_map(|(_, r)| *r)
            .collect();
        let n = runs.len().max(1) as f32;
        let mean =
            |f: &dyn Fn(&board_emu::campaign::CaseRun) -> f32| runs.iter().map(f).sum::<f32>() / n;
        let worst = |f: &dyn Fn(&board_emu::campaign::CaseRun) -> f32| {
            runs.iter().map(f).fold(0.0, f32::max)
        };
        let within = runs
            .iter()
            .filter(|r| r.board.domain == shared::domain::Domain::Within)
            .count();
        let reading: Vec<String> = (0..shared::FAULT_COUNT)
            .map(|i| format!("{:.3}", mean(&|r| r.board.faults.as_array()[i])))
            .collect();
        md.push_str(&format!(
            "| {} | {:.2} | {:.2} | {within}/{} | {:.2} | {:.2} | {} |\n",
            case.name,
            mean(&|r| r.board.e_tot),
            worst(&|r| r.board.e_tot),
            runs.len(),
            mean(&|r| r.own.e_tot),
            worst(&|r| r.own.e_tot),
            reading.join(" ")
        ));
    }
    print!("{md}");
    if let Some(path) = &args.out {
        std::fs::write(path, &md).with_context(|| format!("writing {}", path.display()))?;
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}

/// The RTT bytes through `defmt-print -e ELF`, printed and returned, or their count if it
/// is not installed (then nothing is returned).
fn decode(elf: &PathBuf, log: &[u8]) -> Result<String> {
    let child = Command::new("defmt-print")
        .arg("-e")
        .arg(elf)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn();
    match child {
        Ok(mut child) => {
            if let Some(mut stdin) = child.stdin.take() {
                stdin.write_all(log)?;
            }
            let out = child.wait_with_output()?;
            let text = String::from_utf8_lossy(&out.stdout).into_owned();
            print!("{text}");
            Ok(text)
        }
        Err(_) => {
            println!(
                "rtt {} bytes (install defmt-print to decode them)",
                log.len()
            );
            Ok(String::new())
        }
    }
}

/// Runs the board for `instructions` at most, saying on standard error every 10⁹ how far it
/// is (a flight takes minutes).
fn run_with_progress(board: &mut Board, instructions: u64) -> Result<RunEnd> {
    const STEP: u64 = 1_000_000_000;
    let started = std::time::Instant::now();
    loop {
        let left = instructions.saturating_sub(board.instructions);
        let end = board.run(left.min(STEP))?;
        match end {
            RunEnd::InstructionLimit if board.instructions < instructions => eprintln!(
                "[{:>4.0} s] {:.1} × 10⁹ instructions, {} frames read",
                started.elapsed().as_secs_f64(),
                board.instructions as f64 / 1e9,
                board.frames.fed.len()
            ),
            end => return Ok(end),
        }
    }
}
