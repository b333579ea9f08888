//! `host-sim`: the ground tools of ema-fdi.
//!
//! `preflight` simulates a (faulty) actuator with the reference model and identifies it with
//! the onboard FDI; `simulate`, `calibrate`, `identify` and `plot` do the same step by step
//! with trace files; `actuator` and `import` bring another actuator and a rig's recordings
//! (every command takes `--actuator FILE`); `inverse`, `footprint` and `bench` check the
//! FDI core on its own. This file holds the command line and the dispatch; each command's
//! body is in `commands/`.

mod cli;
mod commands;
mod faults;

use cli::*;

#[allow(clippy::wildcard_imports)]
use commands::{
    actuator::*, bench::*, calibrate::*, campaign::*, domain::*, fleet::*, identify::*, import::*,
    physics::*, plot::*, prognostics::*, simulate::*, studies::*,
};

#[derive(Parser)]
#[command(
    name = "host-sim",
    version,
    about = "Ground tools for the ema-fdi onboard actuator prognostics",
    help_template = help_template(),
    after_help = EXIT_HELP
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// The actuator: a description file (TOML, see actuators/reference.toml) or a record
    /// from `host-sim actuator` / `calibrate --out X.rec`. Default: the built-in reference
    /// actuator. Used by the reference model and by the FDI.
    #[arg(long, global = true, value_name = "FILE")]
    actuator: Option<PathBuf>,
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
    /// Simulate the actuator's preflight test with the reference model and write the trace
    /// (default: the injection test, 46 ms of tones at standstill then the 0.5 s chirp).
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
        /// Output, by its extension: `.toml`, the --actuator description rewritten with this
        /// calibration in its `[calibration]` section (what a user keeps and edits);
        /// `.rec`, the actuator record with the calibration in it (what the firmware loads
        /// and flashes: the --actuator file's record); any other extension, the calibration
        /// alone as JSON (for `identify --calibration`).
        #[arg(long)]
        out: PathBuf,
        /// Keep the description's `[installation] encoder_offset` instead of estimating it.
        /// By default the installation's start offset is estimated and written with the
        /// calibration: the offset whose calibration leaves the least mismatch within
        /// ±0.03 rad of the first frame's reading (motor angle − gear ratio × surface angle),
        /// 25 calibrations (≈ 1 s).
        #[arg(long)]
        keep_offset: bool,
        /// The default (the start offset is estimated); kept so that older scripts run.
        #[arg(long, hide = true, conflicts_with = "keep_offset")]
        estimate_offset: bool,
        /// A healthy trace of the same actuator at another temperature (version 3: it
        /// carries the measured temperature): its friction, against the calibration's,
        /// becomes a point of the friction law. Up to 4 (e.g. from a climatic chamber at
        /// −45, −25, 0 and +75 °C), each within the file's `[domain] temperature`, at least
        /// 2 K from the calibration's and from each other; between points the law
        /// interpolates. Without --at the calibration has no friction law (friction does not
        /// move with temperature), unless the --actuator description's own `[calibration]`
        /// has one, which is kept.
        #[arg(long = "at", value_name = "TRACE")]
        at: Vec<PathBuf>,
    },
    /// Convert a rig recording (a data logger's CSV: any column names, units, delimiter and
    /// rate at or above the control rate, idle before the test) into a trace of the
    /// actuator's test at the control rate, for `identify`, `plot` and the firmware.
    Import {
        /// The recording (CSV).
        recording: PathBuf,
        /// The rig's column names, `our=theirs,…`, e.g.
        /// `t=Time,theta_cmd=Cmd,i_a=Ia,i_b=Ib,i_c=Ic,theta_m=MotorAngle,theta_u=SurfaceAngle`
        /// (default: the actuator file's `[rig] columns`, else our names).
        #[arg(long, value_parser = RigFormat::parse_columns)]
        columns: Option<std::collections::BTreeMap<String, String>>,
        /// Multipliers to SI units, `our=factor,…`, e.g. `t=1e-3` for milliseconds
        /// (default: the actuator file's `[rig] scales`, else 1).
        #[arg(long, value_parser = RigFormat::parse_scales)]
        scales: Option<std::collections::BTreeMap<String, f64>>,
        /// Start of the test in the recording [s] (default: found from the command column;
        /// with --flight, required: where the superimposed chirp starts).
        #[arg(long)]
        start: Option<f64>,
        /// The recording is a window of flight (issue 36): the actuator's chirp superimposed
        /// on the flight control computer's commands, under the flight's hinge load. The
        /// trace holds the chirp's length from --start and is marked `# test: flight` (CSV
        /// only), for `identify` (with `--preflight`, `--same-flight`) and `plot`.
        #[arg(long)]
        flight: bool,
        /// Field delimiter (default: sniffed from the header: `,`, `;` or tab).
        #[arg(long)]
        delimiter: Option<char>,
        /// The controller's current-sense anti-alias filter the currents are read through
        /// [Hz] (2nd-order Butterworth); 0 = none. Default: the actuator file's
        /// `[sensors] anti_alias_hz` (0 for both example actuators, as calibrated).
        #[arg(long)]
        anti_alias_hz: Option<f64>,
        /// Output trace (`.bin` binary, else CSV).
        #[arg(long)]
        out: PathBuf,
    },
    /// Check an actuator description (TOML) and write the record the firmware loads.
    Actuator {
        /// Actuator description (TOML) or record.
        file: PathBuf,
        /// Write the record (binary, versioned, CRC-32) here.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Identify the nine faults behind a trace with the onboard FDI (firmware code and
    /// settings): a preflight, or a window of flight (`# test: flight`) read with its
    /// flight's preflight (--preflight) and fused with its other windows (--same-flight).
    Identify {
        /// Trace (CSV or binary).
        trace: PathBuf,
        /// Further windows of the same flight as TRACE (a window of flight, `# test: flight`),
        /// repeatable: each is identified, and those identified or named only for their
        /// turbulence are fused with TRACE into the flight's reading (docs/in-flight.md),
        /// whose verdict sets the exit status. Windows must not overlap.
        #[arg(long, value_name = "WINDOW")]
        same_flight: Vec<PathBuf>,
        /// With a window of flight: the same flight's preflight trace. It is identified
        /// first; when `within`, the windows hold the stator shorts at its reading (a window
        /// has no standstill segment and cannot tell a short from an eccentricity,
        /// docs/in-flight.md). Without it the window reads the shorts itself.
        #[arg(long, value_name = "PREFLIGHT")]
        preflight: Option<PathBuf>,
        /// With a preflight: the same test played again (its noise drawn anew), repeatable.
        /// As the controller: read only where the first test's noise calls for more
        /// (⌈fitness / the calibration's nominal residual⌉, at most the actuator's `[test]
        /// max_tests`), and the mean of the trusted readings given as the record the
        /// controller logs (docs/preflight.md, "Repeated tests").
        #[arg(long, value_name = "TRACE")]
        again: Vec<PathBuf>,
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
        /// GA checkpoint file (the firmware's 1 412-byte record): resumed from if it is a
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
        /// the healthy actuator with noise), 1+2 (both: what the preflight's uncertainty is
        /// calibrated on), random (multi-fault vectors nobody tuned on),
        /// demagnetization (the ninth fault: uniform and one magnet, with a short, on a hot
        /// and a cold day, and the short and the days that must not read as it).
        #[arg(long, value_enum, required_unless_present_any = ["conditions", "wind", "flight", "physics"])]
        table: Option<CampaignTable>,
        /// Robustness: Table I, Table II and the healthy actuator over a grid of days and
        /// drives (winding temperature −60 … +60 K from calibration with the friction law,
        /// bus 250 / 280 V, two corners, 1 µs of dead time), one row per point.
        #[arg(long, conflicts_with_all = ["table", "plot"])]
        conditions: bool,
        /// The preflight on a parked surface in wind (issue 36): the healthy actuator, three
        /// Table I faults and two Table II mixes in still air and in 5–30 kt winds, steady and
        /// gusting, with the moved-load verdict's statistics (docs/in-flight.md).
        #[arg(long, conflicts_with_all = ["table", "plot", "conditions"])]
        wind: bool,
        /// The FDI on windows of flight (issue 36): the healthy actuator, friction 0.2 and
        /// Table II medium (with --table 1: the paper's Table I; 2: Table II without its
        /// noise case, and the healthy actuator; demagnetization: its uniform cases on the
        /// calibration's day, and the healthy actuator) in climb, cruise and approach (--phase),
        /// light and moderate turbulence; each window identified by the window
        /// identification (recorded command, fitted hinge load, the window's verdicts,
        /// accuracy) and read by the preflight FDI (verdicts by reason: none should be
        /// `within`).
        #[arg(long, conflicts_with_all = ["plot", "conditions", "wind"])]
        flight: bool,
        /// The reference model's nuisance physics drawn from a family instead of the file's
        /// (issue 68; `host_sim::studies::physics`): per draw its grease (one factor or two
        /// parts, split and activation), the gearbox apart from the winding, the
        /// eccentricity's physics, a declared duty delay, a rigging offset the record does not
        /// know and the harness; each draw calibrated as a user would (healthy trace and
        /// climatic chamber), then Table I, Table II and the healthy actuator identified on
        /// its calibration day, 60 K colder and 60 K warmer, one row per draw and day.
        #[arg(long, value_enum, conflicts_with_all = ["table", "plot", "conditions", "wind", "flight"])]
        physics: Option<PhysicsFamily>,
        /// With --physics: how many draws (seeds FIRST … FIRST + draws − 1, --first-draw).
        #[arg(long, requires = "physics", default_value_t = 10, value_parser = clap::value_parser!(u64).range(1..=1000))]
        draws: u64,
        /// With --physics: the first draw's seed (choose limits on other draws than those
        /// the figures are reported on).
        #[arg(long, requires = "physics", default_value_t = 0)]
        first_draw: u64,
        /// With --physics: calibrate each draw without its climatic chamber (no friction
        /// law: friction does not move with temperature), to compare the same cases and
        /// draws with and without the law.
        #[arg(long, requires = "physics")]
        without_friction_law: bool,
        /// With --flight: only these phases (comma-separated; all three by default).
        #[arg(long, requires = "flight", value_enum, value_delimiter = ',')]
        phase: Vec<FlightPhase>,
        /// With --flight: the superimposed test's study instead — the window's chirp at each
        /// of these amplitudes [mrad, comma-separated], in cruise, light and moderate
        /// turbulence, the healthy actuator and friction 0.2 (docs/in-flight.md).
        #[arg(long, requires = "flight", value_delimiter = ',', value_name = "MRAD")]
        test_amplitudes: Option<Vec<f64>>,
        /// With --flight: the first seed of each row (seeds FIRST … FIRST + runs − 1), e.g.
        /// to choose a limit on other seeds than those it is reported on.
        #[arg(
            long,
            requires = "flight",
            conflicts_with = "test_amplitudes",
            default_value_t = 0
        )]
        first_seed: u64,
        /// With --flight: windows per flight (each seed a flight). Above one, each flight's
        /// windows that are identified or named only for turbulence are fused into the
        /// flight's reading (`shared::fusion`, docs/in-flight.md), reported in a table of
        /// its own after the windows'.
        #[arg(
            long,
            requires = "flight",
            conflicts_with = "test_amplitudes",
            default_value_t = 1,
            value_parser = clap::value_parser!(u32).range(1..=16)
        )]
        flight_windows: u32,
        /// With --flight-windows: a flight flies more windows, one at a time up to this
        /// many, while only its friction deviation keeps its reading out and more windows
        /// can bring it within the limit (`shared::fusion::FlightLength`, docs/in-flight.md)
        /// — a long phase's rule: the cruise rule is --phase cruise --flight-windows 8
        /// --flight-windows-max 24 (`shared::fusion::CRUISE_LENGTH`). Default:
        /// --flight-windows exactly, in every phase.
        #[arg(
            long,
            requires = "flight_windows",
            value_name = "N",
            value_parser = clap::value_parser!(u32).range(2..=32)
        )]
        flight_windows_max: Option<u32>,
        /// With --flight: each window's two GAs at most EVALUATIONS evaluations each, of
        /// population POPULATION (2 to 32), instead of the controller's 300 of 16: what
        /// another window search costs or gains (its model runs in the runs CSV).
        #[arg(
            long,
            requires = "flight",
            conflicts_with = "test_amplitudes",
            value_name = "EVALUATIONS:POPULATION",
            value_parser = parse_window_search
        )]
        window_search: Option<host_sim::fdi::window::WindowSearch>,
        /// Runs (seeds) per case.
        #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u64).range(1..=1000))]
        runs: u64,
        /// Also write the table as Markdown to this file.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Also write every run as a CSV row to this file (case, run, e_tot, fitness, fitness
        /// at the truth, evaluations, domain, the found vector): the distribution behind the
        /// table, e.g. of evaluations per identification. With --flight: every window (phase,
        /// turbulence, case, seed, verdict, e_tot, false FAULTs, turbulence level, misfit,
        /// the preflight FDI's verdict, the found vector and its deviations; with
        /// --flight-windows, each flight's fused reading too). Not with --wind or --physics.
        #[arg(long, value_name = "FILE.csv", conflicts_with_all = ["wind", "physics"])]
        runs_csv: Option<PathBuf>,
        /// Also draw e_tot per case (ours vs paper) into this SVG.
        #[arg(long)]
        plot: Option<PathBuf>,
        /// Preflight test design of the built-in actuator (an actuator file carries its own).
        #[arg(long, value_enum)]
        test: Option<TestChoice>,
        /// The installation's rigging offset [rad, motor side] (see `simulate --help`).
        #[arg(long, value_name = "RAD", allow_hyphen_values = true)]
        encoder_offset: Option<f64>,
        #[command(flatten)]
        day: DayArgs,
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
    /// the nine fault components (central differences on the reference model, averaged over
    /// noise seeds) at the healthy point and the Table II low and medium vectors; singular
    /// values, condition number and the predicted one-test standard deviation of each
    /// component. How the default test was chosen (docs/identifiability.md).
    Identifiability {
        /// Designs to study (default: all).
        #[arg(long, value_delimiter = ',')]
        designs: Vec<host_sim::studies::identifiability::Design>,
        /// Noise seeds per point (each costs one reference-model run plus two per component
        /// studied: nine, eight where no eccentricity gives its phase a meaning).
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
        /// Instead of the designs: the day study of the injection test on the real bridge —
        /// per nuisance (winding ±30/±60 K with the friction law, bus 250/280 V, 1 µs of dead
        /// time, 50 mΩ more harness), what it does to the fitted signal and the linearised
        /// identification error it causes with the day ignored and with the day estimated,
        /// at the healthy point and the Table II low and medium vectors.
        #[arg(long, conflicts_with = "bias")]
        day: bool,
        /// Instead of the designs: the grease study — whether the chirp's torque balance
        /// tells the grease's viscous drag from its dry friction (one-factor and two-part
        /// grease, gear and winding temperatures apart, wear, backlash, a short), and the wear
        /// read with the healthy friction taken from the fitted drag against from the
        /// thermistor (docs/identifiability.md §0c). Runs on `--actuator`'s file too.
        #[arg(long, conflicts_with_all = ["bias", "day"])]
        grease: bool,
        /// Instead of the designs: the demagnetization study — what an eight-component FDI
        /// (without the ninth component) reads on a healthy actuator whose magnets lost flux (every pole, or one
        /// magnet; 5 to 25 % of the flux), beside the same actuator with a hot winding (the
        /// reversible flux change the day already plays), then whether the test finds the
        /// flux lost: the FDI run at ten flux scales per test, the least fitness kept (a few
        /// minutes with 10 seeds). Runs on `--actuator`'s file too.
        #[arg(long, conflicts_with_all = ["bias", "day", "grease"])]
        demagnetization: bool,
        /// Instead of the designs: one weak magnet against an eccentricity — the flown FDI's
        /// reading beside the best weak magnet the monitor model's rotor picture finds on the
        /// same fitness (healthy, one magnet at 10–100 %, two eccentricities; ≈ 1 min with
        /// 10 seeds). Runs on `--actuator`'s file too.
        #[arg(long, conflicts_with_all = ["bias", "day", "grease", "demagnetization"])]
        weak_magnet: bool,
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
        /// Write the suggested limits into this actuator description (its `[domain]` keys;
        /// comments and everything else kept).
        #[arg(long, value_name = "FILE.toml")]
        write: Option<PathBuf>,
    },
    /// Optimiser comparison on the same fitness and traces (paper Table I cases): the flown
    /// solver (the steady-state GA and its polish), the GA alone, a generational GA configured
    /// as the paper's MATLAB `ga`, DE/rand/1/bin, CMA-ES with IPOP restarts (`cmaes`), and
    /// `metaheuristics-nature`'s DE and PSO. Prints evaluations to reach the target e_tot and
    /// e_tot at fixed budgets.
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
    /// Stop rules for the flown GA, replayed on recorded campaign identifications (Tables I
    /// and II, the healthy noisy actuator, untuned random vectors): evaluations saved against
    /// e_tot lost, per rule.
    Stopping {
        /// Seeds per case (reference-model seed r, GA seed 1 + r).
        #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u64).range(1..=100))]
        seeds: u64,
        /// Also write the table as Markdown to this file.
        #[arg(long)]
        out: Option<PathBuf>,
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
        /// Also append every record to this health-log file (the controller's 84-byte
        /// records, 32 slots: the newest 32 flights), as the firmware's --health reads it.
        #[arg(long)]
        log: Option<PathBuf>,
        /// Share of flights whose test meets something outside the fault vector (a jammed
        /// shaft, an open phase, or a test run with twice the chirp amplitude, in turn).
        #[arg(long, default_value_t = 0.0, value_parser = parse_share)]
        out_of_domain: f64,
        /// Windows of flight identified in each flight (0–8), each kept as an in-flight
        /// entry: the reference model flies the surface (a phase and turbulence drawn per
        /// window) with the chirp superimposed, the FDI identifies the window (≈ 0.4 s each);
        /// from two on, the flight's reading from its windows fused follows them (window
        /// `flight`, the entry the trend takes).
        #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u8).range(0..=8))]
        windows: u8,
        /// One magnet losing its flux along the same path: END@POLE, END the share of its
        /// flux lost by the last flight (none at the first), POLE 0 … 2P − 1 as
        /// `preflight --demagnetization partial:LOSS@POLE` counts them.
        #[arg(long, value_name = "END@POLE", value_parser = MagnetLoss::parse)]
        weak_magnet: Option<MagnetLoss>,
    },
    /// Trend and remaining useful life (RUL, in flights) of each fault from a history CSV or
    /// a health-log file: the onboard prognosis (shared::prognosis) run on the ground.
    Prognose {
        /// History CSV (`degrade --out`) or health log (`degrade --log`, the firmware's).
        history: PathBuf,
        #[command(flatten)]
        trend: TrendArgs,
        /// Use only the flights up to and including this one.
        #[arg(long)]
        at: Option<u32>,
        /// Draw the history, the fit and the RUL cone into this SVG.
        #[arg(long)]
        plot: Option<PathBuf>,
        /// Print one JSON object instead of the table.
        #[arg(long)]
        json: bool,
    },
    /// Evaluate the prognosis like ProgPy's metrics: simulated degradations of every fault
    /// family (each fault alone, two pairs) growing linearly, exponentially and by a power
    /// law, at each I_ref noise level, with out-of-domain flights mixed in; the onboard trend
    /// replayed flight by flight; α-λ accuracy, share within ±α after half of the life, 90 %
    /// interval coverage, prognostic horizon. 21 scenarios × noise levels × seeds × flights
    /// identifications (≈ 25 min for the defaults).
    Prognostics {
        /// Runs per scenario (seeds F…F+N−1).
        #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u64).range(1..))]
        seeds: u64,
        /// The first seed F (another F gives runs no setting was chosen on).
        #[arg(long, default_value_t = 0)]
        first_seed: u64,
        /// Flights per run.
        #[arg(long, default_value_t = 40, value_parser = clap::value_parser!(u32).range(10..=1000))]
        flights: u32,
        /// I_ref noise levels (RMS as a fraction of the nominal I_ref RMS), comma-separated.
        #[arg(long, default_value = "0,0.5", value_delimiter = ',', value_parser = parse_noise)]
        noise: Vec<f64>,
        /// Share of flights whose test is outside the monitor model's domain.
        #[arg(long, default_value_t = 0.1, value_parser = parse_share)]
        out_of_domain: f64,
        #[arg(long, help = format!(
            "Standard deviation of the identification's systematic error in the trend \
             (default: the controller's, {})",
            TrendSettings::DEFAULT.systematic
        ))]
        systematic: Option<f64>,
        #[arg(long, help = format!(
            "Least standard deviation of one flight's reading in the trend (default: the \
             controller's, {})",
            TrendSettings::DEFAULT.noise_floor
        ))]
        noise_floor: Option<f64>,
        #[arg(long, help = format!(
            "How many times a flight's reading's stated standard deviation counts in the trend \
             (default: the controller's, {})",
            TrendSettings::DEFAULT.flight_scale
        ))]
        flight_scale: Option<f64>,
        /// Windows of flight identified in each flight (0–8); from two on, those identified
        /// or named only for turbulence are fused into the flight's reading, an in-flight
        /// entry the trend takes beside the preflights (each window's own entry is kept in
        /// the history, not trended). The tables then also give the same runs from their
        /// preflights alone.
        #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u8).range(0..=8))]
        windows: u8,
        /// The most tests per preflight (1–8), as an actuator record's `[test] max_tests`: a
        /// preflight whose first test is trusted plays as many as its noise calls for
        /// (⌈fitness / the calibration's nominal residual⌉), the I_ref noise drawn anew each
        /// time, and its record is their readings' mean (deviations over √N), as the
        /// controller's. Each test costs its drive time and its identification.
        #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u8).range(1..=8))]
        repeat: u8,
        /// Replace the FDI's readings by an ideal identification of this standard deviation
        /// (the same runs: each preflight without an intrusion reads its true fault vector
        /// plus seeded Gaussian noise of SIGMA, stating SIGMA): the trend's ceiling with
        /// readings of that precision. Preflights only. Several, comma-separated: a sweep
        /// (needs --histories), one row each beside the FDI's readings and the lean-removed
        /// oracle; --out and --plot then take the sweep's table and picture.
        #[arg(long, value_name = "SIGMA", value_delimiter = ',', conflicts_with = "windows", value_parser = parse_ideal_sigma)]
        ideal_readings: Vec<f32>,
        /// Take each run's mean error per component (reading − truth, over its trusted
        /// preflights at least 0.05 from nominal) off the FDI's readings: an oracle that says
        /// what the identification's lean costs the trend, beside its scatter. Preflights only.
        #[arg(long, conflicts_with_all = ["windows", "ideal_readings"])]
        lean_removed: bool,
        /// Evaluate one weak magnet instead of the fault families: a magnet losing its flux
        /// from none to 0.6 along each path shape (its pole the seed's, the reference
        /// actuator's poles in turn), its depth trended against the 0.5 threshold.
        #[arg(long, conflicts_with_all = ["ideal_readings", "lean_removed"])]
        weak_magnet: bool,
        /// Keep each run's history CSV in this folder, and read it from there when present
        /// (re-evaluate the trend without simulating again).
        #[arg(long)]
        histories: Option<PathBuf>,
        /// Accuracy bound α (relative).
        #[arg(long, default_value_t = 0.2)]
        alpha: f64,
        /// Also write the tables as Markdown to this file.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Also draw the α-λ picture into this SVG.
        #[arg(long)]
        plot: Option<PathBuf>,
    },
    /// The fleet store of every controller's health log (SQLite) and its report.
    Fleet {
        #[command(subcommand)]
        command: FleetCommand,
    },
    /// Bytes of the onboard FDI state (GA, measured-current buffer, monitor model).
    Footprint,
    /// Write the actuator's preflight test as the controller commands it, control period by
    /// control period (CSV: sample, t, mode position|voltage|off, pair, value), for a bench
    /// drive to play.
    TestSchedule {
        /// Output CSV.
        #[arg(long)]
        out: PathBuf,
    },
    /// The board's records as flash images: an A/B pair of 128 KiB sectors holding one item
    /// (--write: the actuator record from `actuator --out`, to flash at the address printed),
    /// or the newest item of a pair read back from the board (--read: a 256 KiB dump of the
    /// health pair gives the health log's image for `fleet ingest`).
    FlashPair {
        /// Which pair: the record (sectors 5–6, 0x08020000), the checkpoint (7–8,
        /// 0x08060000) or the health log (9–10, 0x080A0000).
        #[arg(long, value_enum)]
        store: PairStore,
        /// Make the pair's image holding this item.
        #[arg(long, conflicts_with = "read", required_unless_present = "read")]
        write: Option<PathBuf>,
        /// Take the newest item from this dump of the pair.
        #[arg(long)]
        read: Option<PathBuf>,
        /// The image (--write) or the item (--read).
        #[arg(long)]
        out: PathBuf,
    },
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

fn main() -> ExitCode {
    let cli = Cli::parse();
    let actuator = match Actuator::from_option(cli.actuator.as_deref()) {
        Ok(a) => a,
        Err(e) => {
            eprintln!("error: {e:#}");
            return ExitCode::from(EXIT_ACTUATOR_REFUSED);
        }
    };
    let with_test = |test: Option<TestChoice>, offset: Option<f64>, day: DayArgs| {
        actuator
            .clone()
            .with_encoder_offset(offset)
            .with_day(day.day())
            .and_then(|a| a.with_test_choice(test.map(TestChoice::test)))
    };
    let outcome = match cli.command {
        Command::Preflight {
            actuator,
            ga_seed,
            trace_out,
            json,
        } => with_test(actuator.test, actuator.encoder_offset, actuator.day).and_then(|a| {
            preflight(
                &a,
                &actuator.simulated()?,
                ga_seed,
                trace_out.as_deref(),
                json,
            )
        }),
        Command::Simulate {
            actuator,
            format,
            out,
        } => with_test(actuator.test, actuator.encoder_offset, actuator.day)
            .and_then(|a| simulate(&a, &actuator.simulated()?, format, &out)),
        Command::Calibrate {
            nominal_trace,
            out,
            keep_offset,
            estimate_offset: _,
            at,
        } => calibrate_command(&actuator, &nominal_trace, &out, !keep_offset, &at),
        Command::Actuator { file, out } => actuator_command(&file, out.as_deref()),
        Command::Import {
            recording,
            columns,
            scales,
            start,
            flight,
            delimiter,
            anti_alias_hz,
            out,
        } => import_command(
            &actuator,
            &recording,
            columns,
            scales,
            start,
            flight,
            delimiter,
            anti_alias_hz,
            &out,
        ),
        Command::Identify {
            trace,
            same_flight,
            preflight,
            again,
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
                &actuator,
                &trace,
                &FlightFiles {
                    same_flight: &same_flight,
                    preflight: preflight.as_deref(),
                    again: &again,
                },
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
        } => plot_command(&actuator, &trace, calibration.as_deref(), seed, &out),
        Command::Campaign {
            table,
            conditions,
            wind,
            flight,
            physics,
            draws,
            first_draw,
            without_friction_law,
            test_amplitudes,
            first_seed,
            flight_windows,
            flight_windows_max,
            window_search,
            phase,
            runs,
            out,
            runs_csv,
            plot,
            test,
            encoder_offset,
            day,
        } => with_test(test, encoder_offset, day).and_then(|actuator| match table {
            _ if wind => wind_campaign_command(&actuator, runs, out.as_deref()),
            _ if physics.is_some() => physics_campaign_command(
                &actuator,
                first_draw..first_draw.saturating_add(draws),
                runs,
                !without_friction_law,
                out.as_deref(),
            ),
            _ if flight => {
                let seeds = first_seed..first_seed.saturating_add(runs);
                let most = flight_windows_max.unwrap_or(flight_windows);
                if most < flight_windows || (most > flight_windows && flight_windows < 2) {
                    anyhow::bail!(
                        "--flight-windows-max {most}: at least --flight-windows \
                         ({flight_windows}), and a flight that may fly more needs \
                         --flight-windows 2 or more (one window is never read alone)"
                    );
                }
                flight_campaign_command(
                    &actuator,
                    seeds,
                    &FlightCampaignRun {
                        table,
                        phases: &phase,
                        length: shared::fusion::FlightLength {
                            least: flight_windows,
                            most,
                        },
                        search: window_search
                            .unwrap_or(host_sim::fdi::window::WindowSearch::ONBOARD),
                    },
                    test_amplitudes.as_deref(),
                    out.as_deref(),
                    runs_csv.as_deref(),
                )
            }
            Some(table) if !conditions => campaign_command(
                &actuator,
                table,
                runs,
                out.as_deref(),
                runs_csv.as_deref(),
                plot.as_deref(),
            ),
            _ => conditions_campaign_command(&actuator, runs, out.as_deref()),
        }),
        Command::Inverse { faults, seed, json } => actuator
            .built_in_only("inverse")
            .and_then(|()| inverse(faults, seed, json)),
        Command::Separability {
            faults,
            versus,
            seeds,
        } => actuator
            .built_in_only("separability")
            .and_then(|()| separability_command(&faults, &versus, seeds)),
        Command::Optimisers {
            seeds,
            cap,
            source,
            target,
            out,
            plot,
        } => actuator.built_in_only("optimisers").and_then(|()| {
            optimisers_command(seeds, cap, source, target, out.as_deref(), plot.as_deref())
        }),
        Command::Stopping { seeds, out } => stopping_command(&actuator, seeds, out.as_deref()),
        Command::Domain { seeds, out, write } => {
            domain_command(&actuator, seeds, out.as_deref(), write.as_deref())
        }
        Command::Identifiability {
            seeds,
            grease: true,
            out,
            ..
        } => grease_study_command(&actuator, seeds, out.as_deref()),
        Command::Identifiability {
            seeds,
            demagnetization: true,
            out,
            ..
        } => demagnetization_study_command(&actuator, seeds, out.as_deref()),
        Command::Identifiability {
            seeds,
            weak_magnet: true,
            out,
            ..
        } => weak_magnet_study_command(&actuator, seeds, out.as_deref()),
        Command::Identifiability {
            designs,
            seeds,
            step,
            anti_alias,
            noise,
            bias,
            day,
            weights,
            out,
            ..
        } => actuator.built_in_only("identifiability").and_then(|()| {
            if day {
                day_study_command(seeds, step, out.as_deref())
            } else if bias {
                mismatch_bias_command(&designs, &weights, seeds, step, out.as_deref())
            } else {
                identifiability_command(&designs, seeds, step, anti_alias, noise, out.as_deref())
            }
        }),
        Command::Degrade {
            faults_start,
            faults_end,
            flights,
            shape,
            noise,
            seed,
            out,
            log,
            out_of_domain,
            windows,
            weak_magnet,
        } => actuator.built_in_only("degrade").and_then(|()| {
            degrade_command(
                &DegradationPath {
                    start: faults_start,
                    end: faults_end,
                    flights,
                    shape,
                    magnet: weak_magnet,
                },
                noise,
                seed,
                out_of_domain,
                windows,
                &out,
                log.as_deref(),
            )
        }),
        Command::Prognose {
            history,
            trend,
            at,
            plot,
            json,
        } => prognose_command(&history, &trend.settings(), at, plot.as_deref(), json),
        Command::Prognostics {
            seeds,
            first_seed,
            flights,
            noise,
            out_of_domain,
            systematic,
            noise_floor,
            flight_scale,
            windows,
            repeat,
            ideal_readings,
            lean_removed,
            weak_magnet,
            histories,
            alpha,
            out,
            plot,
        } => actuator.built_in_only("prognostics").and_then(|()| {
            let mut settings = TrendSettings::DEFAULT;
            if let Some(s) = systematic {
                settings.systematic = s;
            }
            if let Some(f) = noise_floor {
                settings.noise_floor = f;
            }
            if let Some(f) = flight_scale {
                settings.flight_scale = f;
            }
            prognostics_command(
                &EvalRun {
                    seeds,
                    first_seed,
                    flights,
                    noises: noise,
                    intrusions: out_of_domain,
                    windows,
                    repeat,
                    readings: match (&ideal_readings[..], lean_removed) {
                        ([], false) => vec![prognostics::Readings::Fdi],
                        ([], true) => vec![prognostics::Readings::LeanRemoved],
                        (&[sigma], _) => vec![prognostics::Readings::Ideal(sigma)],
                        (sweep, _) => [
                            prognostics::Readings::Fdi,
                            prognostics::Readings::LeanRemoved,
                        ]
                        .into_iter()
                        .chain(sweep.iter().map(|&s| prognostics::Readings::Ideal(s)))
                        .collect(),
                    },
                    settings,
                    histories,
                    alpha,
                    weak_magnet,
                },
                out.as_deref(),
                plot.as_deref(),
            )
        }),
        Command::Fleet { command } => {
            return match fleet_command(command) {
                Ok(code) => code,
                Err(e) => {
                    eprintln!("error: {e:#}");
                    ExitCode::FAILURE
                }
            };
        }
        Command::Footprint => {
            footprint();
            Ok(())
        }
        Command::TestSchedule { out } => host_sim::files::schedule::write_schedule(&actuator, &out),
        Command::FlashPair {
            store,
            write,
            read,
            out,
        } => {
            let store = store.store();
            match (write, read) {
                (Some(item), _) => flash_pair::write_pair_image(store, &item, &out),
                (None, Some(dump)) => flash_pair::read_pair_dump(store, &dump, &out),
                (None, None) => Err(anyhow::anyhow!("flash-pair: --write ITEM or --read DUMP")),
            }
        }
        Command::Bench {
            evaluations,
            identifications,
        } => actuator
            .built_in_only("bench")
            .and_then(|()| bench(evaluations, identifications)),
    };
    match outcome {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if e.is::<ExitWith>() => match e.downcast_ref::<ExitWith>() {
            Some(ExitWith(code)) => ExitCode::from(*code),
            None => ExitCode::FAILURE,
        },
        Err(e) => {
            eprintln!("error: {e:#}");
            if e.chain().any(|c| c.is::<ActuatorRefused>()) {
                ExitCode::from(EXIT_ACTUATOR_REFUSED)
            } else if e
                .chain()
                .any(|c| c.is::<IngestError>() || c.is::<host_sim::files::rig::RigError>())
            {
                ExitCode::from(EXIT_TRACE_REFUSED)
            } else {
                ExitCode::FAILURE
            }
        }
    }
}

/// `EVALUATIONS:POPULATION` for `campaign --flight --window-search`.
fn parse_window_search(text: &str) -> Result<host_sim::fdi::window::WindowSearch, String> {
    use host_sim::fdi::window::WindowSearch;
    let (evaluations, population) = text
        .split_once(':')
        .ok_or_else(|| format!("{text:?}: EVALUATIONS:POPULATION, e.g. 300:16"))?;
    let evaluations: u32 = evaluations
        .trim()
        .parse()
        .map_err(|e| format!("evaluations {evaluations:?}: {e}"))?;
    let population: usize = population
        .trim()
        .parse()
        .map_err(|e| format!("population {population:?}: {e}"))?;
    if !WindowSearch::POPULATIONS.contains(&population) {
        return Err(format!(
            "population {population}: {} to {}",
            WindowSearch::POPULATIONS.start(),
            WindowSearch::POPULATIONS.end()
        ));
    }
    if evaluations < population as u32 {
        return Err(format!(
            "{evaluations} evaluations: at least the population ({population})"
        ));
    }
    Ok(WindowSearch {
        evaluations,
        population,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    #[test]
    fn the_help_groups_every_command_by_task() {
        let listed: Vec<&str> = COMMANDS_BY_TASK
            .iter()
            .flat_map(|(_, commands)| commands.iter().map(|(name, _)| *name))
            .collect();
        let mut names: Vec<String> = Cli::command()
            .get_subcommands()
            .map(|c| c.get_name().to_string())
            .collect();
        names.sort();
        let mut sorted = listed.clone();
        sorted.sort();
        assert_eq!(
            sorted, names,
            "every command listed once by task, and no other"
        );
        let help = Cli::command().render_help().to_string();
        for name in &listed {
            assert!(
                help.contains(&format!("  {name} ")),
                "{name} missing from:\n{help}"
            );
        }
        assert!(
            help.contains("Options:") && help.contains("--actuator"),
            "{help}"
        );
    }

    #[test]
    fn a_window_search_is_evaluations_and_a_population_the_ga_is_built_for() {
        use host_sim::fdi::window::WindowSearch;
        assert_eq!(
            parse_window_search("300:16"),
            Ok(WindowSearch {
                evaluations: 300,
                population: 16
            })
        );
        assert_eq!(
            parse_window_search(" 300 : 16 ").map(|s| s == WindowSearch::ONBOARD),
            Ok(true)
        );
        assert!(parse_window_search("600:32").is_ok());
        for bad in ["300", "300:1", "300:33", "8:16", "x:16", "300:"] {
            assert!(parse_window_search(bad).is_err(), "{bad}");
        }
    }
}
