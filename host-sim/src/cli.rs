//! What the command line and every command share: the exit statuses, the argument groups
//! several commands flatten in (the simulated actuator, its day, the test), small parsers, and
//! the imports the commands use (`use crate::cli::*`). Imports nothing from `main.rs` or
//! `commands/`.

#![allow(unused_imports)]

pub(crate) use std::io::IsTerminal;
pub(crate) use std::ops::ControlFlow;
pub(crate) use std::path::{Path, PathBuf};
pub(crate) use std::process::ExitCode;
pub(crate) use std::time::Instant;

pub(crate) use anyhow::{Context, Result};
pub(crate) use clap::{Parser, Subcommand};
pub(crate) use host_sim::fdi::calibration::{calibrate, CalibrationFile};
pub(crate) use host_sim::files::actuator::{Actuator, ActuatorRefused, Day};
pub(crate) use host_sim::studies::campaign::{run_once, TABLE_1};

pub(crate) use host_sim::fdi::identify::{
    identify_checkpointed, identify_for, Checkpointing, Identified, Outcome, Resumption,
};
pub(crate) use host_sim::fdi::plot;
pub(crate) use host_sim::files::flash_pair;
pub(crate) use host_sim::files::health;
pub(crate) use host_sim::files::rig::RigFormat;
pub(crate) use host_sim::files::trace::{IngestError, Trace, TraceFormat};
pub(crate) use host_sim::median;
pub(crate) use host_sim::plant::aero::{FlightPhase, FlightWindow, GroundWind, Turbulence};
pub(crate) use host_sim::plant::reference::{
    Demagnetization, EccentricityPhysics, ReferenceModel, ReferenceSettings, Scenario, SensorFault,
};
pub(crate) use host_sim::studies::optimisers::{self, TraceSource};
pub(crate) use host_sim::studies::prognostics::{self, DegradationPath, MagnetLoss, PathShape};
pub(crate) use serde_json::json;
pub(crate) use shared::actuator::ActuatorRecord;
pub(crate) use shared::command::{CommandSource, CommandTable};
pub(crate) use shared::domain::{Domain, OutsideReason};
pub(crate) use shared::fault::{Verdict, FAULT_COUNT, FAULT_NAMES};
pub(crate) use shared::fdi::{
    record_monitor_trace, Identification, OnboardGa, OnboardMeasured, POPULATION, TEST_SAMPLES,
};
pub(crate) use shared::health::{HealthLog, FLIGHT_READING, ONBOARD_RECORDS};
pub(crate) use shared::metrics::{component_errors, total_error, total_error_all};
pub(crate) use shared::monitor::MonitorState;
pub(crate) use shared::prognosis::TrendSettings;
pub(crate) use shared::test_design::PreflightTest;
pub(crate) use shared::uncertainty::Assessment;
pub(crate) use shared::{
    ActuatorParams, Calibration, ChirpCommand, FaultVector, FitnessProblem, GaSettings, LowPass,
    MonitorModel, ShaftAngles, SteadyStateGa,
};

pub(crate) use crate::faults;

pub(crate) const EXIT_HELP: &str =
    "Exit status: 0 done; 1 error; 2 usage; 3 trace refused (the message \
names the field and the line or row); 4 identify/preflight: the actuator is outside the monitor \
model's domain (jammed, open phase, another command, unexplained residual; the result is \
printed but must not be acted on), or a window of flight was named outside (its reason printed); 5 identify stopped by --stop-after (checkpoint written); \
7 the --actuator file was refused (the message names the key and its line).";

/// The commands by task, as `host-sim --help` lists them (the top-level help template).
/// Every subcommand is named here once: `the_help_groups_every_command_by_task` checks it.
pub(crate) const COMMANDS_BY_TASK: &[(&str, &[(&str, &str)])] = &[
    (
        "A preflight",
        &[
            (
                "preflight",
                "the reference model plays an actuator with --faults, the onboard FDI reads it",
            ),
            (
                "simulate",
                "write the reference model's test as a trace (CSV or binary)",
            ),
            (
                "identify",
                "read the faults behind a trace (a preflight, or a window with --preflight)",
            ),
            (
                "plot",
                "measured against fitted current and the search's history (SVG)",
            ),
            (
                "test-schedule",
                "the test as the controller commands it, period by period, for a bench drive",
            ),
        ],
    ),
    (
        "Your own actuator and its calibration",
        &[
            (
                "actuator",
                "check a description file (TOML) and write the record the firmware loads",
            ),
            (
                "calibrate",
                "fit the monitor model to a healthy trace (and --at other temperatures)",
            ),
            (
                "domain",
                "survey the domain limits on the actuator (--write them into its file)",
            ),
            (
                "campaign",
                "accuracy over the paper's cases, the day grid, a family of physics, wind or flight",
            ),
        ],
    ),
    (
        "Rig recordings",
        &[(
            "import",
            "a data logger's CSV into a trace of the test (--flight: a window of flight)",
        )],
    ),
    (
        "Health log, prognostics and the fleet",
        &[
            (
                "degrade",
                "simulate a degrading actuator's preflights (and windows) into a history",
            ),
            (
                "prognose",
                "trend and remaining useful life of each fault from a history or a log",
            ),
            (
                "prognostics",
                "evaluate the prognosis over simulated degradations (α-λ, coverage)",
            ),
            (
                "fleet",
                "store every controller's health log (SQLite) and report the fleet (HTML)",
            ),
        ],
    ),
    (
        "The firmware and the board",
        &[
            (
                "flash-pair",
                "the board's records as flash images (--write a record, --read a dump)",
            ),
            ("footprint", "bytes of the onboard FDI state"),
        ],
    ),
    (
        "Studies and benchmarks",
        &[
            (
                "identifiability",
                "which test design tells the faults apart (and --bias, --day, --grease)",
            ),
            ("separability", "can one test tell two fault vectors apart?"),
            ("inverse", "identify monitor-model traces at known faults"),
            (
                "optimisers",
                "our GA against other optimisers on the same fitness",
            ),
            (
                "stopping",
                "stop rules for the flown GA, replayed on recorded identifications",
            ),
            (
                "bench",
                "time one model evaluation, one fitness and one reference-model test",
            ),
        ],
    ),
];

/// The top-level help: about, usage, the commands grouped by task, the options.
pub(crate) fn help_template() -> String {
    let mut t = String::from("{about-with-newline}\n{usage-heading} {usage}\n");
    for (task, commands) in COMMANDS_BY_TASK {
        t.push_str(&format!("\n{task}:\n"));
        for (name, what) in *commands {
            t.push_str(&format!("  {name:<16} {what}\n"));
        }
    }
    t.push_str("\n`host-sim help COMMAND` or `host-sim COMMAND --help` says more of each.\n");
    t.push_str("\nOptions:\n{options}{after-help}");
    t
}

/// Exit status when the actuator file or record is refused.
pub(crate) const EXIT_ACTUATOR_REFUSED: u8 = 7;

/// Exit status when a trace file is refused.
pub(crate) const EXIT_TRACE_REFUSED: u8 = 3;
/// Exit status of `identify --stop-after` (the simulated power loss).
pub(crate) const EXIT_INTERRUPTED: u8 = 5;

/// Exit status of `identify`/`preflight` when the actuator lies outside the monitor model's
/// domain (the result was printed, marked as not to be acted on).
pub(crate) const EXIT_OUTSIDE_DOMAIN: u8 = 4;

/// A command that said what it had to and ends with this exit status (no error message).
#[derive(Debug)]
pub(crate) struct ExitWith(pub(crate) u8);

impl std::fmt::Display for ExitWith {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "exit status {}", self.0)
    }
}

impl std::error::Error for ExitWith {}

pub(crate) const FAULTS_HELP: &str = "nine comma-separated values in [0, 1]: friction, backlash, \
short A, short B, short C, eccentricity, eccentricity phase, gain drift, demagnetization \
(nominal 0,0,0,0,0,0,0.5,0.5,0); the paper's eight (without demagnetization) are read with \
demagnetization 0";

/// The simulated actuator: its faults, process noise and seed.
#[derive(clap::Args)]
pub(crate) struct ActuatorArgs {
    /// True fault vector of the simulated actuator.
    #[arg(long, value_parser = faults::parse_fault_vector, allow_hyphen_values = true, long_help = FAULTS_HELP)]
    pub(crate) faults: FaultVector,
    /// Band-limited white noise on I_ref, RMS as a fraction of the nominal I_ref RMS.
    #[arg(long, default_value_t = 0.0, value_parser = parse_noise)]
    pub(crate) noise: f64,
    /// Seed of every random draw of the reference model (sensor and process noise).
    #[arg(long, default_value_t = 0)]
    pub(crate) seed: u64,
    /// Preflight test design of the built-in actuator: `injection` (default: a 500 Hz tone
    /// on each phase pair at standstill, then the chirp), `standstill` (the earlier voltage
    /// steps at standstill, then the chirp; an ideal drive only) or `paper` (the paper's
    /// chirp alone, currents only). An actuator file carries its own test.
    #[arg(long, value_enum)]
    pub(crate) test: Option<TestChoice>,
    /// The installation's rigging: what the motor encoder reads with the surface at zero
    /// [rad, motor side]. The reference model plays it and the FDI's record carries it (as
    /// measured at rigging). Default: the actuator file's `[installation] encoder_offset`.
    #[arg(long, value_name = "RAD", allow_hyphen_values = true)]
    pub(crate) encoder_offset: Option<f64>,
    #[command(flatten)]
    pub(crate) day: DayArgs,
    /// A faulty sensor between the simulated actuator and the controller:
    /// `encoder-stuck[:SECONDS]` (0.01), `encoder-glitch[:RAD]` (1.0),
    /// `current-offset[:AMPS]` (0.2, phase A), `current-gain[:GAIN]` (1.1, phase A) or
    /// `transducer-slip[:RAD]` (0.005); time-bound ones 0.25 s into the chirp. The FDI
    /// should name it (`outside the domain`), not read it as an actuator fault.
    #[arg(long, value_name = "KIND[:SIZE]", value_parser = SensorFault::parse)]
    pub(crate) sensor_fault: Option<SensorFault>,
    /// Demagnetized rotor magnets (irreversible flux loss, apart from the day's reversible
    /// change): `uniform:LOSS` (every pole lost LOSS of its flux, 0 … 1) or
    /// `partial:LOSS[@POLE]` (one magnet, pole 0 … 2P − 1, default 0), on top of the fault
    /// vector's ninth component. The FDI identifies the uniform form as k9, and one weak
    /// magnet by its depth and pole after the polish (the weak-magnet search; docs/limits.md).
    #[arg(long, value_name = "FORM:LOSS[@POLE]", value_parser = Demagnetization::parse)]
    pub(crate) demagnetization: Option<Demagnetization>,
    /// Mean wind on the parked surface during the test [kt]: its hinge moment from the
    /// actuator file's `[surface]`, with low-altitude Dryden turbulence. 0: no wind.
    #[arg(long, value_name = "KNOTS", default_value_t = 0.0)]
    pub(crate) wind: f64,
    /// Peak gust speed [kt] (at least --wind): (1 − cos) gusts of 0.3–1.5 s at random times,
    /// one every 3 s on average. Default: --wind (no discrete gusts).
    #[arg(long, value_name = "KNOTS")]
    pub(crate) gust: Option<f64>,
    /// A window of flight instead of the preflight (issue 36): the flight control computer's
    /// corrections (0.5 / 1 / 3 mrad RMS up to 1 / 1.5 / 2 Hz in cruise / climb / approach,
    /// plus a slow trim change) with the test's chirp alone superimposed, and the hinge moment
    /// of the file's `[surface]` at the phase's dynamic pressure (10 / 14 / 2.5 kPa) and trim.
    /// The trace's command column is what the position loop followed; `identify` reads the
    /// trace as a window of flight (`# test: flight`; with `--preflight`, the same seed's
    /// preflight trace holds its shorts, eccentricity and demagnetization; docs/in-flight.md).
    #[arg(long, value_enum, value_name = "PHASE", conflicts_with_all = ["wind", "gust"])]
    pub(crate) flight: Option<FlightPhase>,
    /// Turbulence of the flight window (Dryden, vertical gust σ 1.5 / 3 m/s).
    #[arg(long, value_enum, default_value = "light", requires = "flight")]
    pub(crate) turbulence: Turbulence,
}

/// The simulated actuator of `simulate` and `preflight`: its faults, process noise, seed and
/// sensor fault.
#[derive(Clone, Copy)]
pub(crate) struct Simulated {
    pub(crate) faults: FaultVector,
    pub(crate) noise: f64,
    pub(crate) seed: u64,
    pub(crate) sensor_fault: Option<SensorFault>,
    pub(crate) demagnetization: Demagnetization,
    pub(crate) wind: Option<GroundWind>,
    pub(crate) flight: Option<FlightWindow>,
}

impl ActuatorArgs {
    /// What the reference model simulates; an error for a wind that cannot blow.
    pub(crate) fn simulated(&self) -> Result<Simulated> {
        let wind = match (self.wind, self.gust) {
            (0.0, None) => None,
            (w, gust) => Some(
                GroundWind::new(w, gust.unwrap_or(w))
                    .map_err(|e| anyhow::anyhow!("--wind/--gust: {e}"))?,
            ),
        };
        Ok(Simulated {
            faults: self.faults,
            noise: self.noise,
            seed: self.seed,
            sensor_fault: self.sensor_fault,
            demagnetization: self.demagnetization.unwrap_or_default(),
            wind,
            flight: self.flight.map(|phase| FlightWindow {
                phase,
                turbulence: self.turbulence,
            }),
        })
    }
}

/// The day and the drive the reference model plays, over the actuator file's `[conditions]`
/// and `[drive]`.
#[derive(clap::Args, Clone, Copy, Debug, Default)]
pub(crate) struct DayArgs {
    /// Winding temperature of the simulated actuator [°C] (the gear's too, unless
    /// --gear-temperature). Default: the file's `[conditions] temperature` (20 °C).
    #[arg(long, value_name = "CELSIUS", allow_hyphen_values = true)]
    pub(crate) temperature: Option<f64>,
    /// Gear and bearing (grease) temperature [°C]: dry friction follows the file's law.
    #[arg(long, value_name = "CELSIUS", allow_hyphen_values = true)]
    pub(crate) gear_temperature: Option<f64>,
    /// Mean DC bus voltage [V] (MIL-STD-704: 250–280 V on a 270 V bus).
    #[arg(long, value_name = "VOLTS")]
    pub(crate) bus_voltage: Option<f64>,
    /// The bridge's dead time [s] (e.g. 1e-6), compensated as the file's `[drive]` says.
    #[arg(long, value_name = "SECONDS")]
    pub(crate) dead_time: Option<f64>,
    /// The controller's timing [s]: each period's duties and current reference take effect
    /// this long after the sample they were computed from (0 … one control period; e.g.
    /// 5e-5, one 20 kHz carrier). Default: the file's `[drive] duty_delay` (0).
    #[arg(long, value_name = "SECONDS")]
    pub(crate) duty_delay: Option<f64>,
    /// How the simulated eccentricity changes the back-EMF: `permeance` (the air gap over
    /// each coil, the reference actuator) or `phase-gain` (a constant gain per phase).
    #[arg(long, value_name = "PHYSICS")]
    pub(crate) eccentricity_physics: Option<EccentricityPhysics>,
    /// The grease as two things: a viscous drag ×10 at −40 °C and dry friction ×2.95,
    /// each by its own law (where the file's grease is one factor on dry friction); the drag
    /// at 20 °C is a fifth of the sliding friction at the chirp's typical motor speed.
    #[arg(long)]
    pub(crate) two_part_grease: bool,
}

impl DayArgs {
    pub(crate) fn day(self) -> Day {
        Day {
            temperature: self.temperature,
            gear_temperature: self.gear_temperature,
            bus_voltage: self.bus_voltage,
            dead_time: self.dead_time,
            duty_delay: self.duty_delay,
            eccentricity: self.eccentricity_physics,
            two_part_grease: self.two_part_grease,
        }
    }
}

/// The preflight test designs the FDI plays end to end.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum TestChoice {
    Injection,
    Standstill,
    Paper,
}

impl TestChoice {
    pub(crate) fn test(self) -> PreflightTest {
        match self {
            Self::Injection => PreflightTest::INJECTION,
            Self::Standstill => PreflightTest::STANDSTILL,
            Self::Paper => PreflightTest::PAPER,
        }
    }
}

/// The board's flash pairs (`flash-pair --store`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum PairStore {
    Record,
    Checkpoint,
    Health,
}

impl PairStore {
    pub(crate) fn store(self) -> flash_pair::Store {
        match self {
            Self::Record => flash_pair::Store::Record,
            Self::Checkpoint => flash_pair::Store::Checkpoint,
            Self::Health => flash_pair::Store::Health,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum SourceArg {
    Reference,
    Monitor,
}

/// Where `campaign --physics` takes the reference model's nuisance physics from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum PhysicsFamily {
    /// Seeded draws from the family `host_sim::studies::physics::PhysicsDraw::draw` states.
    Random,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum CampaignTable {
    #[value(name = "1")]
    One,
    #[value(name = "2")]
    Two,
    Random,
    /// Tables I and II together: the runs the preflight's uncertainty is calibrated on
    /// (`shared::uncertainty::INFLATION`) and an actuator's systematic error surveyed on
    /// (its file's `[uncertainty]`, printed on the last lines).
    #[value(name = "1+2")]
    OneAndTwo,
    /// The ninth fault: demagnetization in both forms, mixed with a short and a hot day.
    #[value(name = "demagnetization")]
    Demagnetization,
}

pub(crate) fn parse_noise(text: &str) -> Result<f64, String> {
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

pub(crate) fn parse_share(text: &str) -> Result<f64, String> {
    let x: f64 = text
        .trim()
        .parse()
        .map_err(|_| format!("{text:?} is not a number"))?;
    if (0.0..=1.0).contains(&x) {
        Ok(x)
    } else {
        Err(format!("{text} is outside [0, 1] (a share of the flights)"))
    }
}

/// `--ideal-readings`: an ideal identification's standard deviation, in fault-vector units.
pub(crate) fn parse_ideal_sigma(text: &str) -> Result<f32, String> {
    let x: f32 = text
        .trim()
        .parse()
        .map_err(|_| format!("{text:?} is not a number"))?;
    if (0.0..=0.5).contains(&x) {
        Ok(x)
    } else {
        Err(format!(
            "{text} is outside [0, 0.5] (a standard deviation of the fault vector's components)"
        ))
    }
}

pub(crate) fn progress_wanted(json: bool) -> bool {
    !json && std::io::stderr().is_terminal()
}
