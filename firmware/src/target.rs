//! The Cortex-M4F side: the embassy tasks, the report (times from [`crate::clock`]), the panic
//! and HardFault handlers and the footprint read from the linker symbols and the painted stack.
//!
//! Work per executor turn: one [`Preflight::poll`] (≤ `evaluations_per_poll` monitor-model
//! evaluations, ≤ `frames_per_poll` frames) and one heartbeat; the SysTick exception does O(1).

use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m_rt::{exception, ExceptionFrame};
use embassy_executor::{Executor, Spawner};
use semihosting::process::exit;
use static_cell::{ConstStaticCell, StaticCell};

use core::ffi::CStr;
use core::pin::pin;

use firmware::cooperate::yield_now;
use firmware::flight::{
    print_flight_bits, print_window_bits, read_window, Scratch, Slices, WindowAcquireError,
    WindowAcquisition, WindowOutcome, WindowRead, WindowReadError, WindowStage,
    WINDOW_FRAMES_PER_POLL,
};
use firmware::health::{preflight_flight, record_entry, test_record};
use firmware::{Preflight, PreflightSettings, Progress, Report, Stage, TraceSource};
use shared::conditions::TestConditions;
use shared::domain::Domain;
use shared::fault::FAULT_NAMES;
use shared::fdi::OnboardMeasured;
use shared::fitness::CurvatureRun;
use shared::fusion::{WindowFusion, FLIGHT_MAX_FRICTION_STD};
use shared::health::{
    HealthRecord, Newest, RamStore, RecordedDay, FLIGHT_READING, ONBOARD_RECORDS,
};
use shared::prognosis::TrendSettings;
use shared::window::HeldComponents;
use shared::LowPass;

use crate::clock::{cycles, instructions_under_icount, start_cycle_clock, PollTimer};
use crate::emulation::{read_record_file, write_record_file, Command, Crash, HostFile};
use shared::actuator::{ActuatorRecord, RECORD_BYTES};
use shared::fdi::OnboardRecord;
use shared::params::ActuatorParams;
use shared::test_design::PreflightTest;

/// Exit statuses (semihosting SYS_EXIT_EXTENDED, QEMU's own exit status).
mod status {
    pub const SUCCESS: i32 = 0;
    pub const PREFLIGHT_FAILED: i32 = 1;
    pub const USAGE: i32 = 2;
    pub const BAD_TRACE: i32 = 3;
    pub const START_UP: i32 = 4;
    /// `--stop-after`: the simulated power loss cut the preflight (checkpoint written).
    pub const INTERRUPTED: i32 = 5;
    /// `--health`: the health-log file is not a store image (the preflight was reported).
    pub const HEALTH_LOG: i32 = 6;
    /// `--actuator`: the record is missing, damaged, of another version, out of range, or
    /// for another test than the trace's.
    pub const ACTUATOR_RECORD: i32 = 7;
    pub const PANIC: i32 = 101;
    pub const HARD_FAULT: i32 = 102;
}

/// The measured-current buffer (22 kB), in `.bss`.
static MEASURED: ConstStaticCell<OnboardMeasured> = ConstStaticCell::new(OnboardMeasured::ZEROED);

/// The preflight's uncertainty runs (≈ 4.5 kB) and, after it, a window's kept command
/// (5.5 kB): one buffer in `.bss`, never both at once.
static SCRATCH: ConstStaticCell<Scratch> = ConstStaticCell::new(Scratch::IDLE);

/// The health store: a flash sector on the controller; RAM here, loaded from and saved to the
/// `--health` file around each run.
static HEALTH_STORE: ConstStaticCell<HealthStoreImage> = ConstStaticCell::new(RamStore::ZEROED);

/// Heartbeat task runs.
static BEATS: AtomicU32 = AtomicU32::new(0);
/// Longest time between two heartbeat runs [core cycles].
static WORST_GAP: AtomicU32 = AtomicU32::new(0);

/// Evaluations between two progress lines.
const PROGRESS_EVERY: u32 = 1000;

/// Evaluations between two checkpoints (`--checkpoint`): at most this much work is redone
/// after a power loss; each write is one 1 412-byte record.
const CHECKPOINT_EVERY: u32 = 500;

/// Stands in for the control loop and the bus traffic: runs once per executor turn and
/// records the longest wait it saw.
#[embassy_executor::task]
async fn heartbeat() {
    let mut last = cycles();
    loop {
        let now = cycles();
        let gap = u32::try_from(now.saturating_sub(last)).unwrap_or(u32::MAX);
        WORST_GAP.fetch_max(gap, Ordering::Relaxed);
        last = now;
        BEATS.fetch_add(1, Ordering::Relaxed);
        yield_now().await;
    }
}

/// Starts the executor with the preflight task. Written out rather than
/// `#[embassy_executor::main]`, whose `unwrap` on the spawn keeps `core::fmt` in the image.
#[cortex_m_rt::entry]
fn main() -> ! {
    static EXECUTOR: StaticCell<Executor> = StaticCell::new();
    EXECUTOR
        .init(Executor::new())
        .run(|spawner| match preflight_task(spawner) {
            Ok(token) => spawner.spawn(token),
            Err(_) => {
                defmt::error!("cannot spawn the preflight task");
                exit(status::START_UP)
            }
        })
}

#[embassy_executor::task]
async fn preflight_task(spawner: Spawner) {
    let Some(core) = cortex_m::Peripherals::take() else {
        defmt::error!("core peripherals already taken");
        exit(status::START_UP)
    };
    start_cycle_clock(core.SYST);
    let code = preflight(spawner).await;
    exit(code)
}

/// What the executor saw while the preflight ran.
#[derive(Default)]
struct Observed {
    identify_start_cycles: u64,
    /// Stack peak when Identify began (start-up, semihosting, acquisition, conditioning).
    stack_peak_before_identify: u32,
    identify_cycles: u64,
    beats_during_identify: u32,
    /// Identify polls after which the heartbeat did not run before the next poll.
    polls_without_beat: u32,
}

async fn preflight(spawner: Spawner) -> i32 {
    let command = match Command::from_host() {
        Ok(c) => c,
        Err(e) => {
            defmt::error!(
                "usage: cargo fw -- TRACE.bin [--again T.bin ...] [--actuator RECORD] [--seed N] [--checkpoint FILE [--stop-after N]] [--health FILE [--flight N]] [--window W.bin ...]  (binary trace from `host-sim simulate --format bin`, record from `host-sim actuator`): {}",
                e
            );
            return status::USAGE;
        }
    };
    match command.crash {
        // Deliberate: `--crash panic` proves the panic handler reports and exits (test).
        #[allow(clippy::panic)]
        Some(Crash::Panic) => core::panic!("--crash panic"),
        Some(Crash::HardFault) => {
            // An unmapped address: the bus fault escalates to HardFault.
            let word = unsafe { core::ptr::read_volatile(0xFFFF_FFF0 as *const u32) };
            defmt::error!("read {=u32} from an unmapped address", word);
        }
        None => {}
    }
    let path = command.trace_path();
    let path_text = path.to_bytes();
    let source = match open_trace(path) {
        Ok(s) => s,
        Err(status) => return status,
    };
    // What a test played again must share with this one: its rows, its test design and its
    // kind (a preflight, not a window of flight).
    let shape = |h: &shared::trace::TraceHeader| (h.rows, h.test.kind(), h.flight);
    let first = shape(source.header());
    // The actuator record (a flash sector on the controller; the --actuator file here), or
    // the built-in reference actuator with the test the trace says it played.
    let mut settings = PreflightSettings::ONBOARD;
    if let Err(status) = preflight_settings(&command, &source.header().test, &mut settings) {
        return status;
    }
    let filter = match LowPass::for_control_period(settings.actuator.params.control_period) {
        Ok(f) => f,
        Err(e) => {
            defmt::error!("conditioning filter: {}", e);
            return status::START_UP;
        }
    };
    // Both buffers are `.bss` statics taken in place: nothing this size passes the stack.
    let Some(measured) = MEASURED.try_take() else {
        defmt::error!("measured-current buffer already in use");
        return status::START_UP;
    };
    measured.set_filter(filter);
    let Some(scratch) = SCRATCH.try_take() else {
        defmt::error!("uncertainty buffer already in use");
        return status::START_UP;
    };
    let Some((curvature, tests)) = scratch.curvature() else {
        return status::START_UP;
    };
    match heartbeat() {
        Ok(token) => spawner.spawn(token),
        Err(_) => {
            defmt::error!("cannot spawn the heartbeat task");
            return status::START_UP;
        }
    }
    defmt::info!(
        "preflight on {=[u8]:a}: {=u32} rows, GA seed {=u64}, {=u32} evaluations per tick, calibration at {=f32} C",
        path_text,
        source.header().rows,
        settings.seed,
        settings.evaluations_per_poll,
        settings.actuator.calibration.temperature
    );

    // The test, and where its noise calls for more (`ActuatorRecord::tests_called_for`) the
    // same test played again (`--again`), each reading added to the preflight's record. One
    // call site: the identification's future is polled from one place. The flight's windows
    // hold the last test's reading (the host's evaluation alike): no earlier report is kept
    // across a test.
    let mut again = command.again_paths();
    let mut source = source;
    let (report, called) = loop {
        let checkpoint = command.checkpoint_path().filter(|_| tests.played() == 0);
        let (report, observed, total_cycles, day) =
            match run_preflight(&command, checkpoint, &settings, source, measured, curvature).await
            {
                Ok(done) => done,
                Err(status) => return status,
            };
        print_report(&report, &settings.actuator.params, &observed, total_cycles);
        let day = RecordedDay::of(&day);
        tests.add(&test_record(0, &report, day));
        let called = tests.called_for(&settings.actuator);
        let Some(path) = again.next().filter(|_| tests.played() < called) else {
            break (report, called);
        };
        source = match open_trace(path) {
            Ok(s) if shape(s.header()) == first => s,
            Ok(_) => {
                defmt::error!("--again {=[u8]:a}: another test", path.to_bytes());
                return status::BAD_TRACE;
            }
            Err(status) => return status,
        };
    };
    if called > 1 {
        defmt::println!(
            "tests called_for={=u32} played={=u32} averaged={=u32}",
            called,
            tests.played(),
            tests.trusted()
        );
    }
    let reading = tests.reading();
    // The health log (a flash sector on the controller; the --health file here): this
    // preflight's record, then, after the flight's windows, their reading.
    let mut log = None;
    if let Some(path) = command.health_path() {
        let Some(store) = HEALTH_STORE.try_take() else {
            defmt::error!("health store already in use");
            return status::START_UP;
        };
        let entry = |newest| {
            let mut r = reading;
            r.flight = preflight_flight(command.flight, newest);
            r
        };
        match record_health(path, store, &entry) {
            Ok(flight) => log = Some((path, store, flight)),
            Err(status) => return status,
        }
    }
    if command.window_paths().next().is_none() {
        return status::SUCCESS;
    }
    fly_windows(&command, &settings, &report, measured, scratch, log).await
}

/// The preflight: its test's frames acquired, conditioned and identified in bounded polls
/// (a checkpoint written as it goes when `--checkpoint` asks), its day and bound printed.
/// Its own future, so that its state (≈ 3.8 kB) is gone when a flight's windows run in
/// the same task. `Err` is the exit status.
async fn run_preflight(
    command: &Command,
    checkpoint: Option<&CStr>,
    settings: &PreflightSettings,
    source: TraceSource<HostFile>,
    measured: &mut OnboardMeasured,
    curvature: &mut CurvatureRun,
) -> Result<(Report, Observed, u64, TestConditions), i32> {
    // The GA record (the flash page on the controller; the --checkpoint file here), read when
    // the identification starts and written every `CHECKPOINT_EVERY` evaluations; none for
    // a test played again.
    let mut next_checkpoint = CHECKPOINT_EVERY;

    let started = cycles();
    // The buffer is lent for the preflight alone: a flight's windows take it back after.
    let mut preflight =
        Preflight::new(settings, source, &mut *measured).with_curvature_buffer(curvature);
    let mut stage = preflight.stage();
    let mut observed = Observed::default();
    let mut next_progress = PROGRESS_EVERY;
    let report = loop {
        let progress = preflight.poll();
        let beats_after_poll = BEATS.load(Ordering::Relaxed);
        match progress {
            Ok(Progress::Finished(report)) => break report,
            Ok(Progress::Working { stage: next }) => {
                if next != stage {
                    defmt::info!("stage {}", next);
                    let now = cycles();
                    if next == Stage::Identify {
                        observed.identify_start_cycles = now;
                        observed.stack_peak_before_identify = stack_peak();
                        if let Some(path) = checkpoint {
                            resume_checkpoint(&mut preflight, path);
                            next_checkpoint =
                                preflight.evaluations().saturating_add(CHECKPOINT_EVERY);
                        }
                    } else if matches!(stage, Stage::Identify | Stage::Polish | Stage::Magnets)
                        && !matches!(next, Stage::Identify | Stage::Polish | Stage::Magnets)
                    {
                        // The identification: the GA, its polish and the weak-magnet search.
                        observed.identify_cycles =
                            now.saturating_sub(observed.identify_start_cycles);
                    }
                    stage = next;
                }
            }
            Err(e) => {
                defmt::error!("preflight failed in stage {}: {}", stage, e);
                return Err(status::PREFLIGHT_FAILED);
            }
        }
        let evaluations = preflight.evaluations();
        if let Some(path) = checkpoint {
            let cut = command.stop_after.is_some_and(|n| evaluations >= n);
            if stage == Stage::Identify && (evaluations >= next_checkpoint || cut) {
                next_checkpoint = evaluations.saturating_add(CHECKPOINT_EVERY);
                save_checkpoint(&preflight, path);
                if cut {
                    defmt::println!(
                        "stopped evaluations={=u32} (simulated power loss)",
                        evaluations
                    );
                    return Err(status::INTERRUPTED);
                }
            }
        }
        if evaluations >= next_progress {
            defmt::info!("identify: {=u32} evaluations", evaluations);
            next_progress = next_progress.saturating_add(PROGRESS_EVERY);
        }
        // Two yields: the executor's run queue alternates the order of ready tasks between
        // rounds, so one yield can hand the CPU straight back to this task.
        yield_now().await;
        yield_now().await;
        if matches!(stage, Stage::Identify | Stage::Polish | Stage::Magnets) {
            let beats = BEATS.load(Ordering::Relaxed).wrapping_sub(beats_after_poll);
            observed.beats_during_identify = observed.beats_during_identify.saturating_add(beats);
            if beats == 0 {
                observed.polls_without_beat = observed.polls_without_beat.saturating_add(1);
            }
        }
    };
    let total_cycles = cycles().saturating_sub(started);
    let day = preflight.day();
    defmt::println!(
        "day winding_rise={=f32} flux={=f32} friction={=f32} winding={}",
        day.winding_rise,
        day.flux_scale,
        day.friction_scale,
        day.winding
    );
    let (evaluations, curvatures) = preflight.work_bound();
    defmt::println!(
        "bound evaluations={=u32} curvatures={=u32}",
        evaluations,
        curvatures
    );
    let day = *day;
    Ok((report, observed, total_cycles, day))
}

async fn fly_windows(
    command: &Command,
    settings: &PreflightSettings,
    report: &Report,
    measured: &mut OnboardMeasured,
    scratch: &mut Scratch,
    log: Option<(&CStr, &mut HealthStoreImage, u32)>,
) -> i32 {
    let Some(kept) = scratch.command() else {
        return status::START_UP;
    };
    let held = if report.domain == Domain::Within {
        report.held
    } else {
        HeldComponents::NONE
    };
    let mut fusion = WindowFusion::EMPTY;
    let (mut read, mut entered) = (0u32, 0u32);
    // Every poll of the flight's FDI work (acquisition, set-up, identification, fusion),
    // timed; the reports between them are the emulation's output, not timed.
    let mut flight_polls = PollTimer::default();
    // What the flight's health entry takes of the windows that entered: their fitnesses'
    // sum, in order, and the first one's day.
    let (mut fitness_sum, mut first_day) = (0.0f32, None);
    for (n, path) in (1u32..).zip(command.window_paths()) {
        let name = path.to_bytes();
        let source = HostFile::open(path)
            .map_err(|e| defmt::error!("cannot read window {=[u8]:a}: {}", name, e))
            .ok()
            .and_then(|f| {
                TraceSource::open(f)
                    .map_err(|e| defmt::error!("window {=[u8]:a} refused: {}", name, e))
                    .ok()
            });
        let Some(mut source) = source else {
            return status::BAD_TRACE;
        };
        // The window's record: the built-in actuator's for the trace's test, or the
        // record's own chirp alone (as `host-sim identify` reads a window).
        let record = match command.actuator_path() {
            None => {
                PreflightSettings::ONBOARD
                    .for_test(source.header().test)
                    .actuator
            }
            Some(_) => ActuatorRecord {
                test: settings.actuator.test.chirp_only(),
                ..settings.actuator
            },
        };
        let mut window_polls = PollTimer::default();
        // The frames, at most `WINDOW_FRAMES_PER_POLL` per executor turn.
        let acquired = match WindowAcquisition::start(
            &source,
            record.test,
            record.params.pole_pairs,
            measured,
            kept,
        ) {
            Ok(mut acquisition) => {
                window_polls
                    .run(pin!(async {
                        loop {
                            match acquisition.poll(
                                &mut source,
                                measured,
                                kept,
                                WINDOW_FRAMES_PER_POLL,
                            ) {
                                Ok(false) => yield_now().await,
                                Ok(true) => break,
                                Err(e) => return Err(e),
                            }
                        }
                        match measured.finish_stepwise().await {
                            Ok(()) => Ok(acquisition.frames()),
                            Err(e) => Err(WindowAcquireError::Conditioning(e)),
                        }
                    }))
                    .await
            }
            Err(e) => Err(e),
        };
        let frames = match acquired {
            Ok(f) => f,
            Err(e) => {
                defmt::error!("window {=[u8]:a} not acquired: {}", name, e);
                return status::BAD_TRACE;
            }
        };
        let mut slices = WindowPolls::new(window_polls);
        let window = read_window(
            &mut slices,
            measured,
            kept.as_slice(),
            &record,
            &held,
            settings.seed,
            &mut fusion,
        )
        .await;
        let window_polls = slices.window();
        let WindowRead {
            reading,
            conditions,
            fused,
        } = match window {
            Ok(r) => r,
            Err(WindowReadError::SetUp(e)) => {
                defmt::error!("window {=[u8]:a} cannot be read: {}", name, e);
                return status::BAD_TRACE;
            }
            Err(WindowReadError::Search(_)) => {
                defmt::error!("window {=[u8]:a}: GA settings refused", name);
                return status::PREFLIGHT_FAILED;
            }
        };
        flight_polls.absorb(&window_polls);
        let outcome = WindowOutcome::of(&reading.verdict, &held, fused);
        read += 1;
        if fused {
            entered += 1;
            fitness_sum += reading.fit.error;
            first_day.get_or_insert(RecordedDay::of(&conditions));
        }
        defmt::println!(
            "window n={=u32} frames={=u32} verdict={} outcome={} evaluations={=u32} polls={=u32} longest_poll_instructions={=u64} identify_instructions={=u64}",
            n,
            frames,
            reading.verdict,
            outcome,
            reading.evaluations,
            slices.identify.polls,
            window_polls.longest_instructions(),
            instructions_under_icount(slices.identify_cycles)
        );
        print_window_bits(n, &reading);
    }
    let flight = flight_polls
        .run(pin!(fusion.final_reading_stepwise(FLIGHT_MAX_FRICTION_STD)))
        .await;
    match flight {
        Ok(f) => {
            defmt::println!(
                "flight windows={=u32} entered={=u32} verdict={} faults={} worst_poll_instructions={=u64} fdi_polls={=u32} stack_peak={=u32}",
                read,
                entered,
                f.verdict,
                f.faults.as_array(),
                flight_polls.longest_instructions(),
                flight_polls.polls,
                stack_peak()
            );
            print_flight_bits(&f);
            if let Some((path, store, flight)) = log {
                let day = first_day.unwrap_or(RecordedDay::UNKNOWN);
                let entry =
                    |_| {
                    HealthRecord::of_flight_reading(
                        flight,
                        &f,
                        fitness_sum,
                        entered,
                        day,
                        &held.magnets(),
                    )
                };
                if let Err(status) = record_health(path, store, &entry) {
                    return status;
                }
            }
        }
        Err(e) => defmt::println!(
            "flight windows={=u32} entered={=u32} verdict=none reason={} worst_poll_instructions={=u64} fdi_polls={=u32} stack_peak={=u32}",
            read,
            entered,
            e,
            flight_polls.longest_instructions(),
            flight_polls.polls,
            stack_peak()
        ),
    }
    status::SUCCESS
}

/// A window's reading under emulation: each poll timed, the identification's also on its own
/// with its cycles from its first poll to its last.
struct WindowPolls {
    window: PollTimer,
    identify: PollTimer,
    stage: WindowStage,
    identify_from: u64,
    identify_cycles: u64,
}

impl WindowPolls {
    /// After the window's acquisition, timed in `window`.
    fn new(window: PollTimer) -> Self {
        Self {
            window,
            identify: PollTimer::default(),
            stage: WindowStage::SetUp,
            identify_from: 0,
            identify_cycles: 0,
        }
    }

    /// Every poll of the window: acquisition, set-up, identification, fusion.
    fn window(&self) -> PollTimer {
        let mut all = self.window;
        all.absorb(&self.identify);
        all
    }
}

impl Slices for WindowPolls {
    async fn run<F: core::future::Future>(&mut self, future: core::pin::Pin<&mut F>) -> F::Output {
        let timer = match self.stage {
            WindowStage::Identify => &mut self.identify,
            _ => &mut self.window,
        };
        timer.run(future).await
    }

    fn stage(&mut self, stage: WindowStage) {
        match stage {
            WindowStage::Identify => self.identify_from = cycles(),
            WindowStage::Fuse => self.identify_cycles = cycles().saturating_sub(self.identify_from),
            WindowStage::SetUp => {}
        }
        self.stage = stage;
    }
}

/// The preflight's settings, written into `settings`: the actuator record's (`--actuator`;
/// the record's flash sector on the controller) or the built-in reference actuator with the
/// trace's test, and the command line's seed; the exit status that refuses a record. Its
/// own frame, so that the record's bytes and copies are on the stack only while it runs,
/// not under every later poll of the preflight task.
#[inline(never)]
fn preflight_settings(
    command: &Command,
    trace_test: &PreflightTest,
    settings: &mut PreflightSettings,
) -> Result<(), i32> {
    *settings = match command.actuator_path() {
        None => PreflightSettings::ONBOARD.for_test(*trace_test),
        Some(path) => load_actuator(path, trace_test)?,
    };
    if let Some(seed) = command.seed {
        settings.seed = seed;
    }
    Ok(())
}

/// The trace file at `path`, opened and its header read; `Err` the exit status, the reason
/// reported.
fn open_trace(path: &CStr) -> Result<TraceSource<HostFile>, i32> {
    let name = path.to_bytes();
    let file = HostFile::open(path).map_err(|e| {
        defmt::error!("cannot read trace {=[u8]:a}: {}", name, e);
        status::BAD_TRACE
    })?;
    TraceSource::open(file).map_err(|e| {
        defmt::error!("trace {=[u8]:a} refused: {}", name, e);
        status::BAD_TRACE
    })
}

/// The preflight this image runs: frames from a trace file on the host.
type HostPreflight<'a> = Preflight<'a, TraceSource<HostFile>>;

/// Resumes the identification from the GA record at `path`, if there is one of this run.
/// Out of line, as [`save_checkpoint`]: the record's buffer (1 412 B) is on the stack only
/// during the call, not in the preflight task's state nor under its deepest calls.
#[inline(never)]
fn resume_checkpoint(preflight: &mut HostPreflight<'_>, path: &CStr) {
    let mut record: OnboardRecord = [0; core::mem::size_of::<OnboardRecord>()];
    match read_record_file(path, &mut record) {
        // A checkpoint of an older version is shorter: its header tells.
        Ok(Some(len)) => match preflight.resume(record.get(..len).unwrap_or(&[])) {
            Ok(n) => defmt::println!("checkpoint resumed evaluations={=u32}", n),
            Err(e) => defmt::println!("checkpoint refused reason={} (restarting)", e),
        },
        Ok(None) => {}
        Err(e) => defmt::println!("checkpoint refused reason={} (restarting)", e),
    }
}

/// Writes the identification's GA record to `path`.
#[inline(never)]
fn save_checkpoint(preflight: &HostPreflight<'_>, path: &CStr) {
    let mut record: OnboardRecord = [0; core::mem::size_of::<OnboardRecord>()];
    let saved = preflight.checkpoint(&mut record);
    match saved.map(|n| (n, write_record_file(path, &record))) {
        Ok((n, Ok(()))) => defmt::info!("checkpoint written at {=u32} evaluations", n),
        Ok((_, Err(e))) => defmt::error!("checkpoint not written: {}", e),
        Err(e) => defmt::error!("checkpoint not taken: {}", e),
    }
}

/// The settings for the actuator record at `path`, or the exit status that refuses it.
fn load_actuator(path: &CStr, trace_test: &PreflightTest) -> Result<PreflightSettings, i32> {
    let mut bytes = [0u8; RECORD_BYTES];
    let name = path.to_bytes();
    // An older version's record is shorter; `decode` reads it by its header.
    match read_record_file(path, &mut bytes) {
        Ok(Some(_)) => {}
        Ok(None) => {
            defmt::error!("actuator record {=[u8]:a} not found", name);
            return Err(status::ACTUATOR_RECORD);
        }
        Err(e) => {
            defmt::error!("actuator record {=[u8]:a} refused: {}", name, e);
            return Err(status::ACTUATOR_RECORD);
        }
    }
    let record = match ActuatorRecord::decode(&bytes) {
        Ok(r) => r,
        Err(e) => {
            defmt::error!("actuator record {=[u8]:a} refused: {}", name, e);
            return Err(status::ACTUATOR_RECORD);
        }
    };
    if record.test.kind() != trace_test.kind() {
        defmt::error!(
            "actuator record {=[u8]:a} is for the {=str} test, the trace played {=str}",
            name,
            record.test.kind_name(),
            trace_test.kind_name()
        );
        return Err(status::ACTUATOR_RECORD);
    }
    defmt::info!(
        "actuator record {=[u8]:a}: {=f32} V, gear {=f32}, {=str} test",
        name,
        record.params.dc_bus_voltage,
        record.params.gear_ratio,
        record.test.kind_name()
    );
    Ok(PreflightSettings::ONBOARD.for_actuator(&record))
}

/// The health store: `ONBOARD_RECORDS` slots in RAM, loaded from and saved to a file here.
type HealthStoreImage = RamStore<ONBOARD_RECORDS>;

/// Appends the record `entry` makes of the log's newest (a preflight's, or a flight's reading)
/// to the health log kept in `path`, in `store`, and reports each fault's trend and RUL
/// (flights; `none` = beyond the horizon). `*_bits` give the f32 bits (`ffffffff` for none)
/// for the comparison with the host. The record's flight, or the exit status that says why
/// not. `entry` is a trait object: one copy of this function for both kinds of entry.
#[inline(never)]
fn record_health(
    path: &CStr,
    store: &mut HealthStoreImage,
    entry: &dyn Fn(Option<Newest>) -> HealthRecord,
) -> Result<u32, i32> {
    let started = cycles();
    let path_text = path.to_bytes();
    store.erase();
    let full = store.as_bytes_mut().len();
    match read_record_file(path, store.as_bytes_mut()) {
        Ok(Some(len)) if len == full => {}
        Ok(None) => defmt::println!("health log {=[u8]:a}: new", path_text),
        // A log kept before record version 4, read into the image's start: carry its
        // records over in place.
        Ok(Some(len)) => match store.upgrade_read(len) {
            Some((old_bytes, kept)) => defmt::println!(
                "upgraded health log {=[u8]:a}: {=usize}-byte slots, {=usize} records carried over",
                path_text,
                old_bytes,
                kept
            ),
            None => {
                defmt::error!(
                    "health log {=[u8]:a} refused: {=usize} bytes, no version's image",
                    path_text,
                    len
                );
                return Err(status::HEALTH_LOG);
            }
        },
        Err(e) => {
            defmt::error!("health log {=[u8]:a} refused: {}", path_text, e);
            return Err(status::HEALTH_LOG);
        }
    }
    let settings = TrendSettings::DEFAULT;
    let update = match record_entry(store, entry, &settings) {
        Ok(u) => u,
        Err(e) => {
            defmt::error!("health record not appended: {}", e);
            return Err(status::HEALTH_LOG);
        }
    };
    if let Err(e) = write_record_file(path, store.as_bytes()) {
        defmt::error!("health log {=[u8]:a} not written: {}", path_text, e);
        return Err(status::HEALTH_LOG);
    }
    let kind = if update.record.window == FLIGHT_READING {
        "reading"
    } else {
        "preflight"
    };
    defmt::println!(
        "health flight={=u32} entry={=str} records={=u32} loaded={} evicted={} skipped={=u32}",
        update.record.flight,
        kind,
        update.records,
        update.loaded,
        update.evicted.map(|r| r.flight),
        update.skipped
    );
    let bits = |v: Option<f32>| v.map_or(u32::MAX, f32::to_bits);
    for (name, estimate) in shared::prognosis::TREND_NAMES
        .iter()
        .zip(update.estimates.iter())
    {
        let Some(e) = estimate else { continue };
        let rul = e.rul.unwrap_or(shared::prognosis::RulEstimate {
            rul: None,
            lower: None,
            upper: None,
        });
        defmt::println!(
            "trend {=str} n={=u32} outliers={=u32} level={=f32} slope={=f32} growth={} weight={=f32} rul={} lower={} upper={} rul_bits={=u32:08x} lower_bits={=u32:08x} upper_bits={=u32:08x}",
            name,
            e.observations,
            e.outliers,
            e.level,
            e.slope,
            e.growth,
            e.weight,
            rul.rul,
            rul.lower,
            rul.upper,
            bits(rul.rul),
            bits(rul.lower),
            bits(rul.upper)
        );
    }
    // Cycles of the whole step (instructions under QEMU's -icount: as `cycles` above).
    defmt::println!(
        "health cycles={=u64} stack_peak={=u32}",
        cycles().saturating_sub(started),
        stack_peak()
    );
    Ok(update.record.flight)
}

fn print_report(report: &Report, params: &ActuatorParams, observed: &Observed, total_cycles: u64) {
    let r = &report.result;
    let faults = r.faults.as_array();
    defmt::println!(
        "result faults={} fitness={=f32} evaluations={=u32} curvatures={=u32}",
        faults,
        r.fitness,
        r.evaluations,
        r.curvatures
    );
    defmt::println!(
        "bits faults={:08x} fitness={=u32:08x}",
        faults.map(f32::to_bits),
        r.fitness.to_bits()
    );
    // One weak magnet ([`shared::weak_magnet`]): depth 0 when none was read; its depth's
    // deviation (NaN without one), its verdict among the assessments below.
    let magnet_std = report
        .uncertainty
        .as_ref()
        .map_or(f32::NAN, |u| u.magnet_std);
    defmt::println!(
        "magnets depth={=f32} centre={=f32} pole={=u32} std={=f32} bits={=u32:08x},{=u32:08x},{=u32:08x}",
        r.magnets.depth,
        r.magnets.centre,
        r.magnets.pole(params),
        magnet_std,
        r.magnets.depth.to_bits(),
        r.magnets.centre.to_bits(),
        magnet_std.to_bits()
    );
    match report.domain {
        Domain::Within => defmt::println!("domain within"),
        Domain::Outside(reason) => defmt::println!(
            "domain outside reason={} (outside the monitor model's domain: do not act on the fault vector)",
            reason
        ),
    }
    for (name, verdict) in FAULT_NAMES.iter().zip(report.verdicts.iter()) {
        defmt::println!("verdict {=str} {}", name, verdict);
    }
    match &report.uncertainty {
        Some(u) => {
            defmt::println!(
                "uncertainty std={} lower={} upper={}",
                u.std,
                u.lower,
                u.upper
            );
        }
        None => defmt::println!("uncertainty none"),
    }
    // The weak magnet's verdict after the nine's, in the same line.
    let magnet = ("weak_magnet", &report.magnet);
    for (name, a) in FAULT_NAMES
        .iter()
        .copied()
        .zip(report.assessments.iter())
        .chain([magnet])
    {
        defmt::println!("assessment {=str} {}", name, a);
    }
    defmt::println!("stop_reason {}", r.stop_reason);
    defmt::println!(
        "heartbeat beats_during_identify={=u32} identify_polls={=u32} polls_without_beat={=u32} worst_gap_cycles={=u32}",
        observed.beats_during_identify,
        report.identify_polls,
        observed.polls_without_beat,
        WORST_GAP.load(Ordering::Relaxed)
    );
    defmt::println!(
        "ticks max_evaluations_per_tick={=u32} frames={=u32}",
        report.max_evaluations_per_poll,
        report.frames
    );
    let fp = footprint();
    defmt::println!(
        "footprint flash={=u32} text={=u32} rodata={=u32} static_ram={=u32} stack_peak={=u32} stack_peak_before_identify={=u32} stack_size={=u32}",
        fp.flash,
        fp.text,
        fp.rodata,
        fp.static_ram,
        fp.stack_peak,
        observed.stack_peak_before_identify,
        fp.stack_size
    );
    defmt::println!(
        "cycles total={=u64} identify={=u64} instructions_icount={=u64} identify_instructions_icount={=u64}",
        total_cycles,
        observed.identify_cycles,
        instructions_under_icount(total_cycles),
        instructions_under_icount(observed.identify_cycles)
    );
}

/// Memory use from the linker symbols and the painted stack [bytes].
struct Footprint {
    /// Everything the image puts in flash: vector table, .text, .rodata and .data's image.
    flash: u32,
    text: u32,
    rodata: u32,
    /// .data + .bss + .uninit.
    static_ram: u32,
    /// Deepest the stack went since reset (cortex-m-rt `paint-stack`).
    stack_peak: u32,
    stack_size: u32,
}

#[allow(non_upper_case_globals)]
extern "C" {
    static __stext: u8;
    static __etext: u8;
    static __srodata: u8;
    static __erodata: u8;
    static __sdata: u8;
    static __edata: u8;
    static __sidata: u8;
    static __sbss: u8;
    static __ebss: u8;
    static __suninit: u8;
    static __euninit: u8;
    static _stack_start: u8;
    static _stack_end: u8;
}

const FLASH_ORIGIN: u32 = 0x0800_0000;
const STACK_PAINT: u32 = 0xCCCC_CCCC;

/// (top, bottom) of the stack region [address].
fn stack_bounds() -> (u32, u32) {
    (&raw const _stack_start as u32, &raw const _stack_end as u32)
}

/// Deepest the stack went since reset [bytes]: the lowest word whose paint was scrubbed off.
/// O(stack size) reads.
fn stack_peak() -> u32 {
    let (top, bottom) = stack_bounds();
    let mut word = bottom;
    while word < top {
        // In RAM, word-aligned, between the linker's stack bounds.
        if unsafe { core::ptr::read_volatile(word as *const u32) } != STACK_PAINT {
            break;
        }
        word += 4;
    }
    top.saturating_sub(word)
}

fn footprint() -> Footprint {
    let addr = |p: *const u8| p as u32;
    let (stext, etext) = (addr(&raw const __stext), addr(&raw const __etext));
    let (srodata, erodata) = (addr(&raw const __srodata), addr(&raw const __erodata));
    let (sdata, edata, sidata) = (
        addr(&raw const __sdata),
        addr(&raw const __edata),
        addr(&raw const __sidata),
    );
    let (sbss, ebss) = (addr(&raw const __sbss), addr(&raw const __ebss));
    let (suninit, euninit) = (addr(&raw const __suninit), addr(&raw const __euninit));
    let (stack_top, stack_bottom) = stack_bounds();
    Footprint {
        flash: sidata
            .saturating_add(edata.saturating_sub(sdata))
            .saturating_sub(FLASH_ORIGIN),
        text: etext.saturating_sub(stext),
        rodata: erodata.saturating_sub(srodata),
        static_ram: edata
            .saturating_sub(sdata)
            .saturating_add(ebss.saturating_sub(sbss))
            .saturating_add(euninit.saturating_sub(suninit)),
        stack_peak: stack_peak(),
        stack_size: stack_top.saturating_sub(stack_bottom),
    }
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    // Location and a literal message only: formatting the message would link `core::fmt`
    // for a path that never runs in flight.
    let (file, line) = info.location().map_or(("?", 0), |l| (l.file(), l.line()));
    let message = info.message().as_str().unwrap_or("(formatted message)");
    defmt::error!("panic: {=str} at {=str}:{=u32}", message, file, line);
    exit(status::PANIC)
}

#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    defmt::error!(
        "hard fault: pc={=u32:#010x} lr={=u32:#010x}",
        frame.pc(),
        frame.lr()
    );
    exit(status::HARD_FAULT)
}
