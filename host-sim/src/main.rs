//! `host-sim`: the ground tools of ema-fdi.
//!
//! `preflight` simulates a (faulty) actuator with the reference model and identifies it with
//! the onboard FDI; `simulate`, `calibrate`, `identify` and `plot` do the same step by step
//! with trace files; `inverse`, `footprint` and `bench` check the FDI core on its own.

use std::io::IsTerminal;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use host_sim::calibration::{calibrate, CalibrationFile};
use host_sim::campaign::{run_once, TABLE_1};
use host_sim::faults;
use host_sim::health_file;
use host_sim::identify::{
    identify, identify_checkpointed, Checkpointing, Identified, Outcome, Resumption,
};
use host_sim::median;
use host_sim::optimisers::{self, TraceSource};
use host_sim::plot;
use host_sim::prognostics::{self, DegradationPath, PathShape};
use host_sim::reference::{ReferenceModel, ReferenceSettings, Scenario};
use host_sim::trace_file::{IngestError, Trace, TraceFormat};
use serde_json::json;
use shared::command::{CommandSource, CommandTable};
use shared::domain::{Domain, DomainLimits};
use shared::fault::{Verdict, FAULT_COUNT, FAULT_NAMES};
use shared::fdi::{
    record_monitor_trace, Identification, OnboardGa, OnboardMeasured, POPULATION, TEST_SAMPLES,
};
use shared::health::{HealthLog, ONBOARD_RECORDS};
use shared::metrics::{component_errors, total_error};
use shared::monitor::MonitorState;
use shared::prognosis::TrendSettings;
use shared::test_design::PreflightTest;
use shared::uncertainty::Assessment;
use shared::{
    ActuatorParams, Calibration, ChirpCommand, FaultVector, FitnessProblem, GaSettings, LowPass,
    MonitorModel, ShaftAngles, SteadyStateGa,
};

#[derive(Parser)]
#[command(
    name = "host-sim",
    version,
    about = "Ground tools for the ema-fdi onboard actuator prognostics",
    after_help = EXIT_HELP
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

const EXIT_HELP: &str = "Exit status: 0 done; 1 error; 2 usage; 3 trace refused (the message \
names the field and the line or row); 4 identify/preflight: the actuator is outside the monitor \
model's domain (jammed, open phase, another command, unexplained residual; the result is \
printed but must not be acted on); 5 identify stopped by --stop-after (checkpoint written).";

/// Exit status when a trace file is refused.
const EXIT_TRACE_REFUSED: u8 = 3;
/// Exit status of `identify --stop-after` (the simulated power loss).
const EXIT_INTERRUPTED: u8 = 5;

/// Exit status of `identify`/`preflight` when the actuator lies outside the monitor model's
/// domain (the result was printed, marked as not to be acted on).
const EXIT_OUTSIDE_DOMAIN: u8 = 4;

/// A command that said what it had to and ends with this exit status (no error message).
#[derive(Debug)]
struct ExitWith(u8);

impl std::fmt::Display for ExitWith {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "exit status {}", self.0)
    }
}

impl std::error::Error for ExitWith {}

/// The domain verdict as a heading line, and the exit status it calls for.
fn domain_heading(domain: Domain) -> ((String, String), Result<()>) {
    match domain {
        Domain::Within => (("domain".to_string(), "within".to_string()), Ok(())),
        Domain::Outside(reason) => {
            eprintln!(
                "warning: the actuator is outside the monitor model's domain ({reason:?}): \
                 do not act on the fault vector"
            );
            (
                ("domain".to_string(), format!("outside: {reason:?}")),
                Err(ExitWith(EXIT_OUTSIDE_DOMAIN).into()),
            )
        }
    }
}

const FAULTS_HELP: &str = "eight comma-separated values in [0, 1]: friction, backlash, \
short A, short B, short C, eccentricity, eccentricity phase, gain drift (nominal \
0,0,0,0,0,0,0.5,0.5)";

/// The simulated actuator: its faults, process noise and seed.
#[derive(clap::Args)]
struct ActuatorArgs {
    /// True fault vector of the simulated actuator.
    #[arg(long, value_parser = faults::parse_fault_vector, allow_hyphen_values = true, long_help = FAULTS_HELP)]
    faults: FaultVector,
    /// Band-limited white noise on I_ref, RMS as a fraction of the nominal I_ref RMS.
    #[arg(long, default_value_t = 0.0, value_parser = parse_noise)]
    noise: f64,
    /// Seed of every random draw of the reference model (sensor and process noise).
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Preflight test design: `standstill` (default: voltage steps on each phase pair at
    /// standstill, then the chirp) or `paper` (the paper's chirp alone, currents only).
    #[arg(long, value_enum, default_value_t = TestChoice::Standstill)]
    test: TestChoice,
}

/// The preflight test designs the FDI plays end to end.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum TestChoice {
    Standstill,
    Paper,
}

impl TestChoice {
    fn test(self) -> PreflightTest {
        match self {
            Self::Standstill => PreflightTest::STANDSTILL,
            Self::Paper => PreflightTest::PAPER,
        }
    }
}

#[derive(Subcommand)]
enum Command {
    /// Preflight self-test on the ground: the reference model plays an actuator with the given
    /// faults, the onboard FDI identifies them from its currents.
    Preflight {
        #[command(flatten)]
        actuator: ActuatorArgs,
        /// Seed of the GA.
        #[arg(long, default_value_t = 1)]
        ga_seed: u64,
        /// Also write the simulated trace (format from the extension: .bin or .csv).
        #[arg(long)]
        trace_out: Option<PathBuf>,
        /// Print one JSON object instead of the table.
        #[arg(long)]
        json: bool,
    },
    /// Simulate the 0.5 s preflight test with the reference model and write the trace.
    Simulate {
        #[command(flatten)]
        actuator: ActuatorArgs,
        /// Trace format.
        #[arg(long, value_enum, default_value_t = TraceFormat::Csv)]
        format: TraceFormat,
        /// Output file.
        #[arg(long)]
        out: PathBuf,
    },
    /// Fit the monitor model's electrical parameters and nominal residual to a healthy trace.
    Calibrate {
        /// Trace of the healthy actuator (CSV or binary).
        nominal_trace: PathBuf,
        /// Output calibration file (JSON).
        #[arg(long)]
        out: PathBuf,
    },
    /// Identify the faults behind a trace with the onboard FDI (firmware code and settings).
    Identify {
        /// Trace (CSV or binary).
        trace: PathBuf,
        /// Calibration file from `calibrate` (default: the built-in calibration against this
        /// project's reference model).
        #[arg(long)]
        calibration: Option<PathBuf>,
        /// GA seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// The true fault vector, if known: prints e_i and e_tot.
        #[arg(long, value_parser = faults::parse_fault_vector, allow_hyphen_values = true)]
        truth: Option<FaultVector>,
        /// Print one JSON object instead of the table.
        #[arg(long)]
        json: bool,
        /// GA checkpoint file (the firmware's 1 276-byte record): resumed from if it is a
        /// sound record of this trace, seed and settings (else refused and restarted), and
        /// rewritten as the run goes.
        #[arg(long, value_name = "FILE")]
        checkpoint: Option<PathBuf>,
        /// Evaluations between two checkpoint writes.
        #[arg(long, default_value_t = 500, requires = "checkpoint", value_parser = clap::value_parser!(u32).range(1..))]
        checkpoint_every: u32,
        /// Simulate a power loss: stop after N evaluations with the checkpoint written
        /// (exit status 5).
        #[arg(long, value_name = "N", requires = "checkpoint")]
        stop_after: Option<u32>,
    },
    /// Identify a trace and draw measured vs best-fit current and the fitness history (SVG).
    Plot {
        /// Trace (CSV or binary).
        trace: PathBuf,
        /// Calibration file (default: built-in).
        #[arg(long)]
        calibration: Option<PathBuf>,
        /// GA seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Output SVG file.
        #[arg(long)]
        out: PathBuf,
    },
    /// Accuracy campaign: the paper's fault cases simulated by the reference model and
    /// identified by the onboard FDI, several seeds per case, in parallel.
    Campaign {
        /// Which cases: 1 (paper Table I, single faults), 2 (Table II, multiple faults, plus
        /// the healthy actuator with noise), random (multi-fault vectors nobody tuned on).
        #[arg(long, value_enum)]
        table: CampaignTable,
        /// Runs (seeds) per case.
        #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u64).range(1..=1000))]
        runs: u64,
        /// Also write the table as Markdown to this file.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Also draw e_tot per case (ours vs paper) into this SVG.
        #[arg(long)]
        plot: Option<PathBuf>,
        /// Preflight test design the reference model plays and the FDI fits.
        #[arg(long, value_enum, default_value_t = TestChoice::Standstill)]
        test: TestChoice,
    },
    /// Inverse check: simulate the monitor model at known faults, then identify them with the
    /// onboard FDI (same code, settings and sizes as the firmware).
    Inverse {
        /// True fault vector.
        #[arg(long, value_parser = faults::parse_fault_vector, allow_hyphen_values = true, long_help = FAULTS_HELP)]
        faults: FaultVector,
        /// GA seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Print one JSON object instead of the table.
        #[arg(long)]
        json: bool,
    },
    /// Can one test tell two fault vectors apart? Compares their reference-model currents over
    /// many noise seeds: the deterministic signature between them against one test's scatter.
    Separability {
        /// Fault vector A.
        #[arg(long, value_parser = faults::parse_fault_vector, allow_hyphen_values = true, long_help = FAULTS_HELP)]
        faults: FaultVector,
        /// Fault vector B (same format).
        #[arg(long, value_parser = faults::parse_fault_vector, allow_hyphen_values = true)]
        versus: FaultVector,
        /// Noise seeds per vector (3 × this many reference-model runs).
        #[arg(long, default_value_t = 16, value_parser = clap::value_parser!(u64).range(2..=1000))]
        seeds: u64,
    },
    /// Identifiability study: for each test design, the sensitivity J of what the FDI fits to
    /// the 8 fault components (central differences on the reference model, averaged over
    /// noise seeds) at the healthy point and the Table II low and medium vectors; singular
    /// values, condition number and the predicted one-test standard deviation of each
    /// component. How the default test was chosen (docs/identifiability.md).
    Identifiability {
        /// Designs to study (default: all).
        #[arg(long, value_delimiter = ',')]
        designs: Vec<host_sim::identifiability::Design>,
        /// Noise seeds per point (each costs 1 + 2 × 8 reference-model runs).
        #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u64).range(3..=200))]
        seeds: u64,
        /// Difference step h in fault-vector units.
        #[arg(long, default_value_t = 0.02)]
        step: f32,
        /// Cutoff of the reference model's analogue current anti-alias filter [Hz] (0: none).
        #[arg(long, default_value_t = ReferenceSettings::ANTI_ALIAS_HZ)]
        anti_alias: f64,
        /// Band-limited noise on I_ref during the study, as a fraction of the nominal I_ref
        /// RMS (the process noise Σ then includes).
        #[arg(long, default_value_t = 0.0, value_parser = parse_noise)]
        noise: f64,
        /// Instead of the designs: the linearised identification error from the monitor
        /// model's structural mismatch, at the Table I, Table II and random vectors, for the
        /// designs the monitor model plays (paper, standstill; the reference actuator as
        /// calibrated).
        #[arg(long)]
        bias: bool,
        /// Weights of the standstill segment to compare with --bias (comma-separated).
        #[arg(long, value_delimiter = ',', default_value = "100")]
        weights: Vec<f64>,
        /// Also write the tables to this Markdown file.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Domain survey: the statistics behind the "outside the monitor model's domain" verdict
    /// on actuators the model explains (Table I/II, healthy, noise, seeds) and on ones it
    /// does not (jammed, an open phase, other commands). Prints a table and the limits.
    Domain {
        /// Reference-model seeds per case.
        #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u64).range(1..=100))]
        seeds: u64,
        /// Also write the table to this Markdown file.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Optimiser comparison on the same fitness and traces (paper Table I cases): our
    /// steady-state GA, a generational GA configured as the paper's MATLAB `ga`, and
    /// DE/rand/1/bin. Prints evaluations to reach the target e_tot and e_tot at fixed budgets.
    Optimisers {
        /// Seeds per case (reference-model seed r, solver seed 1 + r).
        #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u64).range(1..=100))]
        seeds: u64,
        /// Evaluations per run at most (the MATLAB-default GA stops by itself after at most
        /// 200 + 300 × 190 = 57 200).
        #[arg(long, default_value_t = 60_000, value_parser = clap::value_parser!(u64).range(100..=1_000_000))]
        cap: u64,
        /// Where the traces come from: the reference model (the real problem), or the
        /// calibrated monitor model (the truth is the optimum: the solvers alone).
        #[arg(long, value_enum, default_value = "reference")]
        source: SourceArg,
        /// e_tot target [%].
        #[arg(long, default_value_t = 1.0)]
        target: f32,
        /// Also write the tables as Markdown to this file.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Also draw the median e_tot against evaluations into this SVG.
        #[arg(long)]
        plot: Option<PathBuf>,
    },
    /// Simulate N preflights of an actuator whose faults grow from --faults-start to
    /// --faults-end: per flight a reference-model test and the onboard identification; writes
    /// the history CSV (identified and true vectors, fitness, domain verdict).
    Degrade {
        /// True fault vector at the first flight.
        #[arg(long, value_parser = faults::parse_fault_vector, allow_hyphen_values = true, long_help = FAULTS_HELP)]
        faults_start: FaultVector,
        /// True fault vector at the last flight.
        #[arg(long, value_parser = faults::parse_fault_vector, allow_hyphen_values = true, long_help = FAULTS_HELP)]
        faults_end: FaultVector,
        /// Number of flights (one preflight each).
        #[arg(long, value_parser = clap::value_parser!(u32).range(2..=10_000))]
        flights: u32,
        /// How the faults grow along the path.
        #[arg(long, value_enum, default_value = "linear")]
        shape: PathShape,
        /// Band-limited white noise on I_ref, RMS as a fraction of the nominal I_ref RMS.
        #[arg(long, default_value_t = 0.0, value_parser = parse_noise)]
        noise: f64,
        /// Seed of the run (each flight's reference-model and GA seeds derive from it).
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// History CSV to write.
        #[arg(long)]
        out: PathBuf,
        /// Also append every record to this health-log file (the controller's 52-byte
        /// records, 32 slots: the newest 32 flights), as the firmware's --health reads it.
        #[arg(long)]
        log: Option<PathBuf>,
    },
    /// Trend and remaining useful life (RUL, in flights) of each fault from a history CSV or
    /// a health-log file: the onboard prognosis (shared::prognosis) run on the ground.
    Prognose {
        /// History CSV (`degrade --out`) or health log (`degrade --log`, the firmware's).
        history: PathBuf,
        /// Maintenance threshold on the deviation from nominal: one value for every fault, or
        /// name=value pairs (friction, backlash, short_a, short_b, short_c, eccentricity,
        /// gain_drift) over the defaults 0.5, 0.5, 0.3, 0.3, 0.3, 0.5, 0.25.
        #[arg(long, value_parser = prognostics::parse_thresholds)]
        threshold: Option<[f32; FAULT_COUNT]>,
        /// Use only the flights up to and including this one.
        #[arg(long)]
        at: Option<u32>,
        /// Flights searched ahead for the threshold crossing.
        #[arg(long, default_value_t = 500, value_parser = clap::value_parser!(u32).range(1..=100_000))]
        horizon: u32,
        /// Draw the history, the fit and the RUL cone into this SVG.
        #[arg(long)]
        plot: Option<PathBuf>,
        /// Print one JSON object instead of the table.
        #[arg(long)]
        json: bool,
    },
    /// Evaluate the prognosis like ProgPy's metrics: simulated degradations (linear and
    /// accelerating, single faults and pairs), the onboard trend replayed flight by flight,
    /// α-λ accuracy, share within ±α after half of the life, interval coverage, prognostic
    /// horizon. 8 scenarios × seeds × flights identifications (≈ 9 min for 3 seeds × 40).
    Prognostics {
        /// Runs per scenario (seeds 0…N−1).
        #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u64).range(1..))]
        seeds: u64,
        /// Flights per run.
        #[arg(long, default_value_t = 40, value_parser = clap::value_parser!(u32).range(10..=1000))]
        flights: u32,
        /// Band-limited white noise on I_ref, RMS as a fraction of the nominal I_ref RMS.
        #[arg(long, default_value_t = 0.0, value_parser = parse_noise)]
        noise: f64,
        /// Accuracy bound α (relative).
        #[arg(long, default_value_t = 0.2)]
        alpha: f64,
        /// Also write the table as Markdown to this file.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Also draw the α-λ picture into this SVG.
        #[arg(long)]
        plot: Option<PathBuf>,
    },
    /// Bytes of the onboard FDI state (GA, measured-current buffer, monitor model).
    Footprint,
    /// Time one monitor-model evaluation, one fitness evaluation and one reference-model test
    /// on one core.
    Bench {
        /// Evaluations to time.
        #[arg(long, default_value_t = 2000, value_parser = clap::value_parser!(u32).range(1..))]
        evaluations: u32,
        /// Full identifications timed per paper Table I case, one after the other on one core
        /// (RM seeds 0…N−1); 0 skips them. The default, 10, takes about 4 minutes.
        #[arg(long, default_value_t = 10)]
        identifications: u64,
    },
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum SourceArg {
    Reference,
    Monitor,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum CampaignTable {
    #[value(name = "1")]
    One,
    #[value(name = "2")]
    Two,
    Random,
}

fn parse_noise(text: &str) -> Result<f64, String> {
    let x: f64 = text
        .trim()
        .parse()
        .map_err(|_| format!("{text:?} is not a number"))?;
    if x.is_finite() && (0.0..=10.0).contains(&x) {
        Ok(x)
    } else {
        Err(format!(
            "{text} is outside [0, 10] (a fraction of the nominal I_ref RMS)"
        ))
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let outcome = match cli.command {
        Command::Preflight {
            actuator:
                ActuatorArgs {
                    faults,
                    noise,
                    seed,
                    test,
                },
            ga_seed,
            trace_out,
            json,
        } => preflight(
            faults,
            noise,
            seed,
            test.test(),
            ga_seed,
            trace_out.as_deref(),
            json,
        ),
        Command::Simulate {
            actuator:
                ActuatorArgs {
                    faults,
                    noise,
                    seed,
                    test,
                },
            format,
            out,
        } => simulate(faults, noise, seed, test.test(), format, &out),
        Command::Calibrate { nominal_trace, out } => calibrate_command(&nominal_trace, &out),
        Command::Identify {
            trace,
            calibration,
            seed,
            truth,
            json,
            checkpoint,
            checkpoint_every,
            stop_after,
        } => {
            let checkpointing = checkpoint.map(|path| Checkpointing {
                path,
                every: checkpoint_every,
                stop_after,
            });
            identify_command(
                &trace,
                calibration.as_deref(),
                seed,
                truth,
                json,
                checkpointing.as_ref(),
            )
        }
        Command::Plot {
            trace,
            calibration,
            seed,
            out,
        } => plot_command(&trace, calibration.as_deref(), seed, &out),
        Command::Campaign {
            table,
            runs,
            out,
            plot,
            test,
        } => campaign_command(table, runs, test.test(), out.as_deref(), plot.as_deref()),
        Command::Inverse { faults, seed, json } => inverse(faults, seed, json),
        Command::Separability {
            faults,
            versus,
            seeds,
        } => separability_command(&faults, &versus, seeds),
        Command::Optimisers {
            seeds,
            cap,
            source,
            target,
            out,
            plot,
        } => optimisers_command(seeds, cap, source, target, out.as_deref(), plot.as_deref()),
        Command::Domain { seeds, out } => domain_command(seeds, out.as_deref()),
        Command::Identifiability {
            designs,
            seeds,
            step,
            anti_alias,
            noise,
            bias,
            weights,
            out,
        } => {
            if bias {
                mismatch_bias_command(&designs, &weights, seeds, step, out.as_deref())
            } else {
                identifiability_command(&designs, seeds, step, anti_alias, noise, out.as_deref())
            }
        }
        Command::Degrade {
            faults_start,
            faults_end,
            flights,
            shape,
            noise,
            seed,
            out,
            log,
        } => degrade_command(
            &DegradationPath {
                start: faults_start,
                end: faults_end,
                flights,
                shape,
            },
            noise,
            seed,
            &out,
            log.as_deref(),
        ),
        Command::Prognose {
            history,
            threshold,
            at,
            horizon,
            plot,
            json,
        } => {
            let mut settings = TrendSettings::DEFAULT;
            if let Some(t) = threshold {
                settings.thresholds = t;
            }
            settings.horizon = horizon;
            prognose_command(&history, &settings, at, plot.as_deref(), json)
        }
        Command::Prognostics {
            seeds,
            flights,
            noise,
            alpha,
            out,
            plot,
        } => prognostics_command(
            seeds,
            flights,
            noise,
            alpha,
            out.as_deref(),
            plot.as_deref(),
        ),
        Command::Footprint => {
            footprint();
            Ok(())
        }
        Command::Bench {
            evaluations,
            identifications,
        } => bench(evaluations, identifications),
    };
    match outcome {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if e.is::<ExitWith>() => match e.downcast_ref::<ExitWith>() {
            Some(ExitWith(code)) => ExitCode::from(*code),
            None => ExitCode::FAILURE,
        },
        Err(e) => {
            eprintln!("error: {e:#}");
            if e.chain().any(|c| c.is::<IngestError>()) {
                ExitCode::from(EXIT_TRACE_REFUSED)
            } else {
                ExitCode::FAILURE
            }
        }
    }
}

fn degrade_command(
    path: &DegradationPath,
    noise: f64,
    seed: u64,
    out: &Path,
    log: Option<&Path>,
) -> Result<()> {
    let start = Instant::now();
    let bar = host_sim::progress_bar(
        u64::from(path.flights),
        "{elapsed_precise} [{bar:40}] {pos}/{len} flights (ETA {eta})",
        std::io::stderr().is_terminal(),
    );
    let rows = prognostics::degrade(path, noise, seed, &|| bar.inc(1))?;
    bar.finish_and_clear();
    std::fs::write(out, health_file::history_csv(&rows))
        .with_context(|| format!("writing {}", out.display()))?;
    if let Some(log_path) = log {
        let mut store = health_file::FileStore::open(log_path, ONBOARD_RECORDS)?;
        let (mut log, _) = HealthLog::<ONBOARD_RECORDS>::load(&mut store)?;
        for r in &rows {
            log.append(&mut store, r.record)
                .map_err(|e| anyhow::anyhow!("appending flight {}: {e:?}", r.record.flight))?;
        }
    }
    let outside = rows.iter().filter(|r| !r.record.is_trusted()).count();
    println!(
        "wrote {} ({} flights, {outside} outside the monitor model's domain; {:.0} s)",
        out.display(),
        rows.len(),
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

fn prognose_command(
    history: &Path,
    settings: &TrendSettings,
    at: Option<u32>,
    plot_out: Option<&Path>,
    json: bool,
) -> Result<()> {
    let mut rows = health_file::read_history(history)?;
    if let Some(at) = at {
        rows.retain(|r| r.record.flight <= at);
        if rows.is_empty() {
            anyhow::bail!("no flight at or before {at} in {}", history.display());
        }
    }
    let trend = prognostics::trend_of(&rows, None, settings);
    let estimates = trend.estimates(settings);
    if json {
        println!(
            "{}",
            prognostics::report_json(&rows, &trend, &estimates, settings)
        );
    } else {
        println!(
            "{}: {} records, newest flight {}, {} outside the domain (not used)",
            history.display(),
            rows.len(),
            rows.last().map_or(0, |r| r.record.flight),
            trend.skipped()
        );
        print!("{}", prognostics::report_text(&estimates, settings));
        println!(
            "RUL in flights after the newest; \"beyond\" = no crossing within {} flights.",
            settings.horizon
        );
    }
    if let Some(out) = plot_out {
        let title = format!(
            "{} up to flight {}",
            history.display(),
            rows.last().map_or(0, |r| r.record.flight)
        );
        prognostics::history_svg(out, &rows, &trend, settings, &title)?;
        if !json {
            println!("wrote {}", out.display());
        }
    }
    Ok(())
}

fn prognostics_command(
    seeds: u64,
    flights: u32,
    noise: f64,
    alpha: f64,
    out: Option<&Path>,
    plot_out: Option<&Path>,
) -> Result<()> {
    let start = Instant::now();
    let scenarios = &prognostics::EVAL_SCENARIOS;
    let total = scenarios.len() as u64 * seeds * u64::from(flights);
    let bar = host_sim::progress_bar(
        total,
        "{elapsed_precise} [{bar:40}] {pos}/{len} flights (ETA {eta})",
        std::io::stderr().is_terminal(),
    );
    let settings = TrendSettings::DEFAULT;
    let tracks =
        prognostics::evaluate(scenarios, seeds, flights, noise, &settings, &|| bar.inc(1))?;
    bar.finish_and_clear();
    let mut text = prognostics::eval_markdown(&tracks, alpha);
    text += &format!(
        "\n{} runs × {flights} flights, noise {noise}, thresholds 0.5 friction and backlash, 0.3 \
         shorts, 0.25 gain drift; {:.0} s.\n",
        scenarios.len() as u64 * seeds,
        start.elapsed().as_secs_f64()
    );
    print!("{text}");
    if let Some(path) = out {
        std::fs::write(path, &text).with_context(|| format!("writing {}", path.display()))?;
    }
    if let Some(path) = plot_out {
        prognostics::eval_svg(path, &tracks, alpha)?;
    }
    Ok(())
}

fn domain_command(seeds: u64, out: Option<&Path>) -> Result<()> {
    let limits = shared::domain::DomainLimits::REFERENCE_ACTUATOR;
    let start = Instant::now();
    let rows = host_sim::domain::survey(seeds, &limits, std::io::stderr().is_terminal())?;
    let text = host_sim::domain::markdown(&rows, &limits);
    print!("{text}");
    println!(
        "\n{} tests in {:.0} s",
        rows.len(),
        start.elapsed().as_secs_f64()
    );
    if let Some(path) = out {
        std::fs::write(path, &text).with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(())
}

fn progress_wanted(json: bool) -> bool {
    !json && std::io::stderr().is_terminal()
}

/// The calibration file at `path`, or the built-in one of the trace's test.
fn load_calibration(path: Option<&Path>, test: &PreflightTest) -> Result<(Calibration, String)> {
    match path {
        Some(p) => Ok((
            CalibrationFile::read(p)?.calibration(),
            p.display().to_string(),
        )),
        None => Ok((
            Calibration::reference_actuator(test),
            format!("built-in ({} test)", test.name().unwrap_or("custom")),
        )),
    }
}

fn simulate_scenario(
    faults: FaultVector,
    noise: f64,
    seed: u64,
    test: PreflightTest,
) -> (Trace, f64) {
    let rm = ReferenceModel::new(ReferenceSettings::REFERENCE).with_test(test);
    let start = Instant::now();
    let sim = rm.simulate(&Scenario {
        faults,
        current_ref_noise: noise,
        seed,
    });
    (sim.trace, start.elapsed().as_secs_f64())
}

fn format_from_extension(path: &Path) -> TraceFormat {
    match path.extension().and_then(|e| e.to_str()) {
        Some(e) if e.eq_ignore_ascii_case("bin") => TraceFormat::Bin,
        _ => TraceFormat::Csv,
    }
}

fn simulate(
    faults: FaultVector,
    noise: f64,
    seed: u64,
    test: PreflightTest,
    format: TraceFormat,
    out: &Path,
) -> Result<()> {
    let (trace, seconds) = simulate_scenario(faults, noise, seed, test);
    trace.write(out, format)?;
    println!(
        "wrote {} ({format}, {} samples at 10 kHz; reference model {seconds:.3} s)",
        out.display(),
        trace.samples().len()
    );
    Ok(())
}

fn calibrate_command(trace_path: &Path, out: &Path) -> Result<()> {
    let trace = Trace::read(trace_path)?;
    let measured = trace.measured(&ActuatorParams::REFERENCE)?;
    let file = calibrate(&measured, ActuatorParams::REFERENCE)?;
    file.write(out)?;
    println!(
        "calibration of the monitor model against {}",
        trace_path.display()
    );
    println!("resistance scale    {:.5}", file.resistance_scale);
    println!("inductance scale    {:.5}", file.inductance_scale);
    println!("back-EMF scale      {:.5}", file.back_emf_scale);
    println!("nominal residual    {:.4e} A²·s", file.nominal_residual);
    println!(
        "mismatch (relative RMS of the filtered equivalent current): {:.2} % before, {:.2} % after",
        100.0 * file.mismatch_before,
        100.0 * file.mismatch_after
    );
    println!(
        "({} monitor-model runs) wrote {}",
        file.evaluations,
        out.display()
    );
    Ok(())
}

fn verdict_text(v: Verdict) -> &'static str {
    match v {
        Verdict::Healthy => "healthy",
        Verdict::Faulty => "FAULT",
        Verdict::NotApplicable => "-",
    }
}

fn assessment_text(a: Assessment) -> String {
    match a {
        Assessment::Healthy => "healthy".into(),
        Assessment::Suspect => "suspect".into(),
        Assessment::Faulty => "FAULT".into(),
        Assessment::Ambiguous { with } => format!(
            "ambiguous/{}",
            FAULT_NAMES.get(usize::from(with)).copied().unwrap_or("?")
        ),
        Assessment::NotApplicable => "-".into(),
    }
}

fn report(id: &Identified, truth: Option<&FaultVector>, heading: &[(String, String)], json: bool) {
    let found = id.result.faults;
    let verdicts = found.verdicts();
    let assessments = id.assessments();
    let uncertainty = id.uncertainty.as_ref().map(|(u, _)| u);
    if json {
        let mut obj = json!({
            "faults": found.as_array(),
            "fitness": id.result.fitness,
            "evaluations": id.result.evaluations,
            "seconds": id.seconds,
            "stop_reason": format!("{:?}", id.result.stop_reason),
            "verdicts": assessments.iter().map(|&a| assessment_text(a)).collect::<Vec<_>>(),
            "threshold_verdicts": verdicts.iter().map(|&v| verdict_text(v)).collect::<Vec<_>>(),
        });
        if let Some(u) = uncertainty {
            // NaN (undetermined) is written as null.
            let finite = |x: f32| x.is_finite().then_some(x);
            obj["std"] = json!(u.std.map(finite));
            obj["interval90"] = json!((0..FAULT_COUNT)
                .map(|i| finite(u.std[i]).map(|_| [u.lower[i], u.upper[i]]))
                .collect::<Vec<_>>());
            obj["worst_correlation"] = json!({
                "pair": [FAULT_NAMES[usize::from(u.worst_pair.0)], FAULT_NAMES[usize::from(u.worst_pair.1)]],
                "value": u.worst_correlation,
            });
        }
        if let Some(t) = truth {
            obj["truth"] = json!(t.as_array());
            obj["errors"] = json!(component_errors(&found, t));
            obj["e_tot"] = json!(total_error(&found, t));
        }
        for (k, v) in heading {
            obj[k.as_str()] = json!(v);
        }
        println!("{obj}");
        return;
    }
    for (k, v) in heading {
        println!("{k:<13} {v}");
    }
    println!();
    let errors = truth.map(|t| component_errors(&found, t));
    match truth {
        Some(_) => println!(
            "{:<13} {:>8} {:>8} {:>17} {:>22} {:>8} {:>8}",
            "fault", "found", "std", "90 % interval", "reading", "true", "e_i [%]"
        ),
        None => println!(
            "{:<13} {:>8} {:>8} {:>17} {:>22}",
            "fault", "found", "std", "90 % interval", "reading"
        ),
    }
    for i in 0..FAULT_COUNT {
        let k = found.as_array()[i];
        let (std, interval) = match uncertainty {
            Some(u) if u.std[i].is_finite() => (
                format!("{:.4}", u.std[i]),
                format!("[{:.4}, {:.4}]", u.lower[i], u.upper[i]),
            ),
            _ => ("-".to_string(), "-".to_string()),
        };
        let mut line = format!(
            "{:<13} {k:>8.4} {std:>8} {interval:>17} {:>22}",
            FAULT_NAMES[i],
            assessment_text(assessments[i])
        );
        if let (Some(t), Some(e)) = (truth, errors.as_ref()) {
            line += &format!(" {:>8.4} {:>8.3}", t.as_array()[i], e[i]);
        }
        println!("{line}");
    }
    let phase_deg = -180.0 + 360.0 * f64::from(found.eccentricity_phase());
    println!("(eccentricity phase {phase_deg:.0}° from phase A; a location, read only with an eccentricity fault)");
    if let Some(u) = uncertainty {
        println!(
            "(FAULT: the whole 90 % interval is beyond the {} detection threshold; suspect: the \
             value is, its interval is not; most correlated pair: {} and {}, {:.2})",
            shared::fault::DETECTION_THRESHOLD,
            FAULT_NAMES[usize::from(u.worst_pair.0)],
            FAULT_NAMES[usize::from(u.worst_pair.1)],
            u.worst_correlation
        );
    }
    if let Some(t) = truth {
        println!("e_tot         {:.3} %", total_error(&found, t));
    }
    println!(
        "fitness       {:.4e} A²·s (nominal residual subtracted)",
        id.result.fitness
    );
    println!(
        "evaluations   {} (stopped: {:?})",
        id.result.evaluations, id.result.stop_reason
    );
    println!("seconds       {:.3}", id.seconds);
}

fn identify_command(
    trace_path: &Path,
    calibration: Option<&Path>,
    seed: u64,
    truth: Option<FaultVector>,
    json: bool,
    checkpointing: Option<&Checkpointing>,
) -> Result<()> {
    let trace = Trace::read(trace_path)?;
    let measured = trace.measured(&ActuatorParams::REFERENCE)?;
    let (calibration, cal_name) = load_calibration(calibration, measured.test())?;
    let (outcome, resumption) = identify_checkpointed(
        &measured,
        &calibration,
        seed,
        progress_wanted(json),
        checkpointing,
    )?;
    if let Some(c) = checkpointing {
        let file = c.path.display();
        match resumption {
            Resumption::Fresh => {}
            Resumption::Resumed(n) => eprintln!("resumed from {file} at {n} evaluations"),
            Resumption::Refused(e) => {
                eprintln!("checkpoint {file} refused ({e:?}): the identification restarted")
            }
        }
    }
    let id = match outcome {
        Outcome::Finished(id) => *id,
        Outcome::Interrupted { evaluations } => {
            eprintln!(
                "stopped after {evaluations} evaluations (simulated power loss); checkpoint in {}",
                checkpointing.map_or(String::new(), |c| c.path.display().to_string())
            );
            return Err(ExitWith(EXIT_INTERRUPTED).into());
        }
    };
    let mut heading = vec![
        ("trace".to_string(), trace_path.display().to_string()),
        ("calibration".to_string(), cal_name),
        ("ga_seed".to_string(), seed.to_string()),
    ];
    let (line, verdict) = domain_heading(
        trace
            .domain_monitor(&ActuatorParams::REFERENCE)
            .assess(&DomainLimits::REFERENCE_ACTUATOR, id.result.fitness),
    );
    heading.push(line);
    if checkpointing.is_some() {
        let said = match resumption {
            Resumption::Fresh => "fresh start".to_string(),
            Resumption::Resumed(n) => format!("resumed at {n} evaluations"),
            Resumption::Refused(e) => format!("refused ({e:?}), restarted"),
        };
        heading.push(("checkpoint".to_string(), said));
    }
    report(&id, truth.as_ref(), &heading, json);
    verdict
}

fn preflight(
    faults: FaultVector,
    noise: f64,
    seed: u64,
    test: PreflightTest,
    ga_seed: u64,
    trace_out: Option<&Path>,
    json: bool,
) -> Result<()> {
    let (trace, rm_seconds) = simulate_scenario(faults, noise, seed, test);
    if let Some(path) = trace_out {
        trace.write(path, format_from_extension(path))?;
    }
    let measured = trace.measured(&ActuatorParams::REFERENCE)?;
    let (calibration, cal_name) = load_calibration(None, &test)?;
    let id = identify(&measured, &calibration, ga_seed, progress_wanted(json))?;
    let mut heading = vec![
        (
            "actuator".to_string(),
            format!(
                "reference model, {} test, noise {noise}, seed {seed} ({rm_seconds:.3} s)",
                test.name().unwrap_or("custom")
            ),
        ),
        ("calibration".to_string(), cal_name),
        ("ga_seed".to_string(), ga_seed.to_string()),
    ];
    let (line, verdict) = domain_heading(
        trace
            .domain_monitor(&ActuatorParams::REFERENCE)
            .assess(&DomainLimits::REFERENCE_ACTUATOR, id.result.fitness),
    );
    heading.push(line);
    report(&id, Some(&faults), &heading, json);
    verdict
}

fn campaign_command(
    table: CampaignTable,
    runs: u64,
    test: PreflightTest,
    out: Option<&Path>,
    plot: Option<&Path>,
) -> Result<()> {
    use host_sim::campaign::{self, HEALTHY, TABLE_2};
    let (title, cases) = match table {
        CampaignTable::One => ("Table I: single faults", TABLE_1.to_vec()),
        CampaignTable::Two => ("Table II: multiple faults, and the healthy actuator", {
            let mut v = TABLE_2.to_vec();
            v.push(HEALTHY);
            v
        }),
        CampaignTable::Random => (
            "Random multi-fault vectors (not tuned on)",
            campaign::untuned_random_cases(8),
        ),
    };
    let start = Instant::now();
    let summaries = campaign::run_campaign(&cases, runs, test, std::io::stderr().is_terminal())?;
    let mut text = campaign::markdown(title, &summaries, runs);
    if matches!(table, CampaignTable::Random) {
        text += "\nVectors:\n\n";
        for c in &summaries {
            text += &format!(
                "- {}: [{}]\n",
                c.case.name,
                c.case
                    .faults
                    .iter()
                    .map(|x| format!("{x:.3}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
    }
    print!("{text}");
    println!(
        "\n({} identifications in {:.1} s wall time)",
        summaries.iter().map(|c| c.runs.len()).sum::<usize>(),
        start.elapsed().as_secs_f64()
    );
    if let Some(path) = out {
        std::fs::write(path, &text).with_context(|| format!("writing {}", path.display()))?;
    }
    if let Some(path) = plot {
        campaign::plot(path, title, &summaries)?;
    }
    Ok(())
}

fn plot_command(
    trace_path: &Path,
    calibration: Option<&Path>,
    seed: u64,
    out: &Path,
) -> Result<()> {
    let trace = Trace::read(trace_path)?;
    let measured = trace.measured(&ActuatorParams::REFERENCE)?;
    let (calibration, _) = load_calibration(calibration, measured.test())?;
    let id = identify(&measured, &calibration, seed, progress_wanted(false))?;
    let k = id.result.faults;
    let title = format!(
        "{}: found k = [{}]",
        trace_path
            .file_name()
            .map_or_else(|| "trace".into(), |n| n.to_string_lossy()),
        k.as_array()
            .iter()
            .map(|x| format!("{x:.3}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    host_sim::plot::identification_svg(out, &measured, &calibration, &k, &id.history, &title)
        .with_context(|| format!("plotting into {}", out.display()))?;
    println!("wrote {}", out.display());
    Ok(())
}

fn measured_from_monitor(
    model: &MonitorModel,
    truth: &FaultVector,
) -> Result<Box<OnboardMeasured>> {
    let filter = LowPass::for_control_period(model.params().control_period)
        .map_err(|e| anyhow::anyhow!("conditioning filter: {e:?}"))?;
    // The product's default test (the standstill segment, then the chirp).
    let mut measured = Box::new(OnboardMeasured::for_test(filter, PreflightTest::STANDSTILL));
    record_monitor_trace(model, truth, &mut measured)
        .map_err(|e| anyhow::anyhow!("recording the trace: {e:?}"))?;
    Ok(measured)
}

fn mismatch_bias_command(
    designs: &[host_sim::identifiability::Design],
    weights: &[f64],
    seeds: u64,
    step: f32,
    out: Option<&Path>,
) -> Result<()> {
    use host_sim::campaign::{random_cases, TABLE_2};
    use host_sim::identifiability::{mismatch_bias, Design};
    use std::fmt::Write;
    let designs = if designs.is_empty() {
        vec![Design::Paper, Design::Standstill]
    } else {
        designs.to_vec()
    };
    let mut variants = Vec::new();
    for d in designs {
        match d {
            Design::Paper => variants.push((d, 0.0)),
            Design::Standstill => variants.extend(weights.iter().map(|&w| (d, w))),
            other => anyhow::bail!(
                "the monitor model does not play design {other:?}: --bias takes paper, standstill"
            ),
        }
    }
    let cases: Vec<(&'static str, FaultVector)> = TABLE_1
        .iter()
        .chain(TABLE_2.iter())
        .chain(random_cases(6).iter())
        .filter(|c| c.noise == 0.0)
        .map(|c| (c.name, FaultVector::saturating(c.faults)))
        .collect();
    let bar = host_sim::progress_bar(
        (cases.len() * variants.len()) as u64,
        "{elapsed_precise} [{bar:40}] {pos}/{len} cases {msg}",
        std::io::stderr().is_terminal(),
    );
    let mut text = format!(
        "Reference actuator as calibrated, {seeds} seeds, step {step}: predicted \
         identification error k_found − k_true (in % of the range) from the monitor model's \
         structural mismatch alone.\n"
    );
    for (design, weight) in variants {
        let _ = write!(
        text,
        "\n### {}{}\n\n\
         | case | mismatch RMS (%) | k1 | k2 | k3 | k4 | k5 | k6 | k7 | k8 | predicted e_tot (%) |\n\
         | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n",
        design.label(),
        if design == Design::Standstill { format!(", standstill weight {weight}") } else { String::new() }
    );
        for &(name, k) in &cases {
            bar.set_message(name);
            let b = mismatch_bias(name, &k, design.test(), weight, seeds, step)?;
            let cells: Vec<String> = b
                .bias
                .iter()
                .map(|x| x.map_or("—".into(), |v| format!("{:+.2}", 100.0 * v)))
                .collect();
            let _ = writeln!(
                text,
                "| {name} | {:.2} | {} | {:.2} |",
                b.mismatch_rms,
                cells.join(" | "),
                b.e_tot(&k)
            );
            bar.inc(1);
        }
    }
    bar.finish_and_clear();
    print!("{text}");
    if let Some(path) = out {
        std::fs::write(path, &text).with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(())
}

fn identifiability_command(
    designs: &[host_sim::identifiability::Design],
    seeds: u64,
    step: f32,
    anti_alias_hz: f64,
    noise: f64,
    out: Option<&Path>,
) -> Result<()> {
    use host_sim::identifiability::{markdown, points, study, Design};
    let designs = if designs.is_empty() {
        Design::ALL.to_vec()
    } else {
        designs.to_vec()
    };
    let jobs: Vec<_> = designs
        .iter()
        .flat_map(|&d| points().map(|(name, k)| (d, name, k)))
        .collect();
    let bar = host_sim::progress_bar(
        jobs.len() as u64,
        "{elapsed_precise} [{bar:40}] {pos}/{len} design × point {msg}",
        std::io::stderr().is_terminal(),
    );
    let mut studies = Vec::new();
    for (design, name, k) in jobs {
        bar.set_message(format!("{design:?} @ {name}"));
        studies.push(study(design, name, &k, seeds, step, anti_alias_hz, noise)?);
        bar.inc(1);
    }
    bar.finish_and_clear();
    let text = markdown(&studies, seeds, step, anti_alias_hz, noise);
    print!("{text}");
    if let Some(path) = out {
        std::fs::write(path, &text).with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(())
}

fn separability_command(a: &FaultVector, b: &FaultVector, seeds: u64) -> Result<()> {
    let s = host_sim::separability::separability(a, b, seeds)?;
    println!("A: {:?}", a.as_array());
    println!("B: {:?}", b.as_array());
    println!(
        "signature A vs B      {:6.3} % of the signal RMS ({seeds} seeds each)",
        s.signature
    );
    println!("one test's scatter    {:6.3} %", s.test_scatter);
    println!(
        "(mean-vs-mean noise   {:6.3} %, removed from the signature)",
        s.mean_noise
    );
    let verdict = if s.signature >= 2.0 * s.test_scatter {
        "separable in one test"
    } else if s.signature >= 0.5 * s.test_scatter {
        "marginal: the signature is comparable to one test's scatter"
    } else {
        "not separable in one test: the signature is buried in one test's scatter"
    };
    println!("{verdict}");
    Ok(())
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
        "total                                 {total:>6} B ({:.1} KiB; with the firmware's \
         preflight task, budget 32 KiB)",
        total as f64 / 1024.0
    );
}

fn bench(evaluations: u32, identifications: u64) -> Result<()> {
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
    let table = Box::new(CommandTable::<TEST_SAMPLES>::new(
        ChirpCommand::PREFLIGHT,
        params.control_period,
    ));
    let tabled = problem
        .clone()
        .with_command_table(&table)
        .map_err(|e| anyhow::anyhow!("fitness: {e:?}"))?;
    let pick = |i: u32| &candidates[i as usize % candidates.len()];
    let per_evaluation = |f: &mut dyn FnMut(u32)| {
        let start = Instant::now();
        for i in 0..evaluations {
            f(i);
        }
        start.elapsed().as_secs_f64() / f64::from(evaluations)
    };
    let mm_chirp =
        per_evaluation(&mut |i| simulate_into(&model, pick(i), model.command(), &mut buffer));
    let mm_table = per_evaluation(&mut |i| simulate_into(&model, pick(i), &*table, &mut buffer));
    let mut sink = 0.0f32;
    let fit_chirp = per_evaluation(&mut |i| sink += problem.error(pick(i)));
    let fit_table = per_evaluation(&mut |i| sink += tabled.error(pick(i)));
    std::hint::black_box(sink);
    println!(
        "one evaluation, {steps} steps (0.5 s), one core, mean of {evaluations} (target ≤ 100 µs):"
    );
    for (what, seconds) in [
        ("monitor model, chirp at each step (firmware)", mm_chirp),
        ("monitor model, command table (host)", mm_table),
        ("fitness eq. (3), chirp at each step (firmware)", fit_chirp),
        ("fitness eq. (3), command table (host)", fit_table),
    ] {
        println!(
            "  {what:<48} {:>7.1} µs  {:>5.1} ns/step",
            seconds * 1e6,
            seconds * 1e9 / steps as f64
        );
    }
    let rm = ReferenceModel::new(ReferenceSettings::REFERENCE);
    let runs = 5;
    let start = Instant::now();
    for seed in 0..runs {
        let sim = rm.simulate(&Scenario {
            faults: truth,
            current_ref_noise: 0.0,
            seed,
        });
        std::hint::black_box(&sim);
    }
    let rm_seconds = start.elapsed().as_secs_f64() / runs as f64;
    println!(
        "reference model, 0.5 s test ({} steps of {} µs): {rm_seconds:.3} s/run (mean of {runs}; target ≤ 1 s)",
        (f64::from(rm.settings().params.control_period) / rm.settings().step).round() as usize
            * rm.test_samples(),
        rm.settings().step * 1e6
    );
    bench_speedups(&rm)?;
    if identifications > 0 {
        bench_identifications(&rm, identifications)?;
    }
    Ok(())
}

fn optimisers_command(
    seeds: u64,
    cap: u64,
    source: SourceArg,
    target: f32,
    out: Option<&Path>,
    plot: Option<&Path>,
) -> Result<()> {
    if !(target.is_finite() && target > 0.0) {
        anyhow::bail!("--target must be a positive e_tot in percent, got {target}");
    }
    let source = match source {
        SourceArg::Reference => TraceSource::Reference,
        SourceArg::Monitor => TraceSource::Monitor,
    };
    let cap = usize::try_from(cap)?;
    let started = Instant::now();
    let solvers = optimisers::compare(&TABLE_1, seeds, cap, source, progress_wanted(false))?;
    let md = optimisers::markdown(&solvers, target, cap, source);
    println!("{md}");
    println!(
        "({:.0} s wall on {} threads)",
        started.elapsed().as_secs_f64(),
        rayon::current_num_threads()
    );
    if let Some(path) = out {
        std::fs::write(path, &md).with_context(|| format!("writing {}", path.display()))?;
    }
    if let Some(path) = plot {
        let curves: Vec<(&str, Vec<f64>)> = solvers
            .iter()
            .map(|s| (s.optimiser.name(), optimisers::median_curve(s, cap)))
            .collect();
        plot::optimisers_svg(
            path,
            &curves,
            f64::from(target),
            &format!(
                "Optimisers on {} (median over {} runs)",
                source.name(),
                solvers.first().map_or(0, |s| s.runs.len())
            ),
        )?;
        println!("plot: {}", path.display());
    }
    Ok(())
}

/// One monitor-model run from rest into `buffer` (the equivalent current), reading the
/// command from `command`; monomorphised, as in the fitness.
fn simulate_into(
    model: &MonitorModel,
    k: &FaultVector,
    command: &impl CommandSource,
    buffer: &mut [f32],
) {
    let mut slots = buffer.iter_mut();
    model.run_with(k, ShaftAngles::ZERO, slots.len(), command, |s| {
        if let Some(slot) = slots.next() {
            *slot = s.current;
        }
        ControlFlow::Continue(())
    });
    std::hint::black_box(buffer);
}

/// The same identification four ways: command evaluated or tabled, every candidate evaluated
/// in full or stopped at the GA's acceptance bound. All four must give the same bits.
fn bench_speedups(rm: &ReferenceModel) -> Result<()> {
    struct Exact<'p, 'a>(&'p FitnessProblem<'a, TEST_SAMPLES>);
    impl shared::Problem for Exact<'_, '_> {
        fn fitness(&mut self, genes: &[f32; FAULT_COUNT]) -> f32 {
            self.0.error(&FaultVector::saturating(*genes))
        }
    }
    let case = &TABLE_1[1];
    let truth = FaultVector::new(case.faults).map_err(|e| anyhow::anyhow!("{e:?}"))?;
    let params = ActuatorParams::REFERENCE;
    let calibration = Calibration::REFERENCE_ACTUATOR;
    let measured = rm
        .simulate(&Scenario {
            faults: truth,
            current_ref_noise: 0.0,
            seed: 0,
        })
        .trace
        .measured(&params)?;
    let table = Box::new(CommandTable::<TEST_SAMPLES>::new(
        ChirpCommand::PREFLIGHT,
        params.control_period,
    ));
    let chirp = FitnessProblem::new(&measured, params, &calibration)
        .map_err(|e| anyhow::anyhow!("fitness: {e:?}"))?;
    let tabled = chirp
        .clone()
        .with_command_table(&table)
        .map_err(|e| anyhow::anyhow!("fitness: {e:?}"))?;
    println!();
    println!(
        "one identification of {} (RM seed 0, GA seed 1), median of 3 on one core:",
        case.name
    );
    let mut reference: Option<SteadyStateGa<POPULATION>> = None;
    let mut differ = false;
    for (what, problem, bounded) in [
        ("chirp at each step, every candidate in full", &chirp, false),
        ("command table, every candidate in full", &tabled, false),
        ("chirp at each step, bounded (firmware)", &chirp, true),
        ("command table, bounded (host)", &tabled, true),
    ] {
        let mut seconds = Vec::new();
        let fresh = || {
            SteadyStateGa::<POPULATION>::new(GaSettings::FDI, 1)
                .map_err(|e| anyhow::anyhow!("{e:?}"))
        };
        let mut last = None;
        for _ in 0..3 {
            let mut ga = fresh()?;
            let start = Instant::now();
            if bounded {
                ga.run(&mut problem.clone());
            } else {
                ga.run(&mut Exact(problem));
            }
            seconds.push(start.elapsed().as_secs_f64());
            last = Some(ga);
        }
        let ga = last.ok_or_else(|| anyhow::anyhow!("no identification ran"))?;
        let same = match &reference {
            None => {
                reference = Some(ga.clone());
                "reference"
            }
            Some(r) if *r == ga => "same bits",
            Some(_) => {
                differ = true;
                "DIFFERENT BITS"
            }
        };
        println!(
            "  {what:<46} {:>6.3} s  {:>5} evaluations  {same}",
            median(&seconds).unwrap_or(f64::NAN),
            ga.evaluations()
        );
    }
    if differ {
        anyhow::bail!("the speed-ups changed the identification's bits");
    }
    Ok(())
}

/// The paper's time for one identification [s] (MATLAB, 4-core i5-3340, parallel GA).
const PAPER_IDENTIFICATION_SECONDS: f64 = 400.0;

/// Times full identifications of every Table I case, one at a time on this thread.
fn bench_identifications(rm: &ReferenceModel, seeds: u64) -> Result<()> {
    let total = seeds * TABLE_1.len() as u64;
    let bar = host_sim::progress_bar(total, "identifications {bar:40} {pos}/{len} {msg}", true);
    println!();
    println!(
        "one full identification on one core (command table + GA, the RM simulation not counted; median of {seeds} RM seeds per Table I case)"
    );
    println!(
        "{:<24} {:>10} {:>12} {:>10} {:>12}",
        "case", "median [s]", "evaluations", "e_tot [%]", "× faster"
    );
    let mut all = Vec::new();
    for case in &TABLE_1 {
        bar.set_message(case.name);
        let mut seconds = Vec::new();
        let mut evaluations = Vec::new();
        let mut errors = Vec::new();
        for run in 0..seeds {
            let r = run_once(rm, &Calibration::REFERENCE_ACTUATOR, case, run)?;
            seconds.push(r.seconds);
            evaluations.push(f64::from(r.evaluations));
            errors.push(r.e_tot);
            bar.inc(1);
        }
        all.extend_from_slice(&seconds);
        let s = median(&seconds).unwrap_or(f64::NAN);
        bar.suspend(|| {
            println!(
                "{:<24} {s:>10.3} {:>12.0} {:>10.2} {:>12.0}",
                case.name,
                median(&evaluations).unwrap_or(f64::NAN),
                median(&errors).unwrap_or(f64::NAN),
                PAPER_IDENTIFICATION_SECONDS / s
            )
        });
    }
    bar.finish_and_clear();
    let s = median(&all).unwrap_or(f64::NAN);
    println!(
        "all {} identifications: median {s:.3} s, {:.0}× faster than the paper's {PAPER_IDENTIFICATION_SECONDS:.0} s (target ≤ 1 s, ≥ 400×)",
        all.len(),
        PAPER_IDENTIFICATION_SECONDS / s
    );
    Ok(())
}
