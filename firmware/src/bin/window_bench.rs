//! The window identification's instruction count on the Cortex-M4F (issue 36, item 3), under
//! QEMU (`cargo window-bench`; `firmware/qemu-run`, `-icount shift=0`): the code the host runs
//! on every window of flight (`shared::window::identify_stepwise`, with the window's GA
//! budget `window_ga`), on a window recorded from the monitor model itself (the flight
//! control computer's corrections, 1 mrad RMS, with the 5 mrad chirp on top; a hinge spring
//! 1.4 times the actuator's carrying 120 N·m; friction 0.2 and a gain drift 0.6). Prints the
//! instructions of one window evaluation (a model run with the drift profiled out), one
//! curvature (thirteen lockstep runs), one load search, and the whole identification polled
//! as a controller's idle-time task would poll it: its polls, the longest poll's
//! instructions and where it starts and ends (feature `pause-sites`), the polls over 30 % of
//! a 100 µs control period by where they run, and its model-run count; then the window added
//! to a flight's reading (`shared::fusion`) and the reading formed.
//!
//! A bench, not the product: the emulation image reads real windows (`cargo fw -- P.bin
//! --window W.bin`, docs/controller.md); this binary times the parts of one on a window it
//! makes itself (built only with feature `window-bench`). Its window is the monitor model's
//! own, so the GA's stopping point is not a real window's: scale the per-run figure by a
//! real window's count (`identify w.csv` prints it) for a real window's cost.
#![no_std]
#![no_main]

use core::future::Future;
use core::panic::Location;
use core::task::{Context, Poll, Waker};

use cortex_m_rt::{entry, exception, ExceptionFrame};
use semihosting::process::exit;
use static_cell::ConstStaticCell;

use shared::actuator::ActuatorRecord;
use shared::command::{ChirpSampler, CommandSource};
use shared::fdi::{OnboardMeasured, POPULATION, TEST_SAMPLES};
use shared::fusion::{WindowFusion, FLIGHT_MAX_FRICTION_STD};
use shared::steps::last_pause;
use shared::window::{
    identify_stepwise, record_monitor_window, synthetic_command, window_ga, RecordedCommand,
    WindowLimits, WindowLoad, WindowProblem, COMMAND_STRIDE, WINDOW_INFLATION,
};
use shared::{Calibration, FaultVector, LowPass, MonitorModel};

#[allow(dead_code)] // `PollTimer`: the bench times its polls itself, naming their sites
#[path = "../clock.rs"]
mod clock;
#[allow(dead_code)] // the bench reads no trace: it only logs through the emulation's stdout
#[path = "../emulation.rs"]
mod emulation;
#[path = "../log.rs"]
mod log;
#[path = "../vectors.rs"]
mod vectors;

use clock::{cycles, instructions_under_icount, start_cycle_clock};

/// The window's measured current (22 kB, the preflight's buffer type) and its command as the
/// controller keeps it (every `COMMAND_STRIDE`-th sample, 5.5 kB), in `.bss`.
static MEASURED: ConstStaticCell<OnboardMeasured> = ConstStaticCell::new(OnboardMeasured::ZEROED);
const KEPT: usize = (TEST_SAMPLES - 1) / COMMAND_STRIDE + 1;
static COMMAND: ConstStaticCell<[f32; KEPT]> = ConstStaticCell::new([0.0; KEPT]);

/// The command the recorded actuator follows, every sample's.
struct Synthetic {
    sampler: ChirpSampler,
    period: f32,
}

impl CommandSource for Synthetic {
    fn position_at(&self, index: usize) -> f32 {
        synthetic_command(&self.sampler, 1.0e-3, self.period, index)
    }
}

/// A poll's budget in flight: 30 % of a 100 µs control period at 168 MHz [instructions].
const SLICE_BUDGET: u64 = 5_040;

/// Distinct places of polls over the budget the bench names.
const OVER_SITES: usize = 16;

/// Polls over the budget that started after the pause at `from` and ended at the one at
/// `to`: how many, and the longest [cycles].
#[derive(Clone, Copy)]
struct OverSite {
    from: Option<&'static Location<'static>>,
    to: Option<&'static Location<'static>>,
    count: u32,
    longest: u64,
}

/// A pause's file and line ("start"/"end" for none).
fn line_of(at: Option<&'static Location<'static>>) -> (&'static str, u32) {
    at.map_or(("-", 0), |l| (l.file(), l.line()))
}

/// Window evaluations timed together for the per-run figure.
const EVALUATIONS: u32 = 20;

#[entry]
fn main() -> ! {
    let Some(core) = cortex_m::Peripherals::take() else {
        exit(4)
    };
    start_cycle_clock(core.SYST);
    let record = ActuatorRecord::REFERENCE;
    let test = record.test.chirp_only();
    let model =
        MonitorModel::new(record.params, &Calibration::reference_actuator(&test)).with_test(&test);
    let period = record.params.control_period;
    let followed = Synthetic {
        sampler: model.sampler(),
        period,
    };
    let command = COMMAND.take();
    for (j, c) in command.iter_mut().enumerate() {
        *c = followed.position_at(j * COMMAND_STRIDE);
    }
    let mut genes = *FaultVector::NOMINAL.as_array();
    (genes[0], genes[7]) = (0.2, 0.6);
    let truth = FaultVector::saturating(genes);
    let load = WindowLoad::spring(1.4 * record.params.aero_stiffness, 120.0);
    let measured = MEASURED.take();
    let Ok(filter) = LowPass::for_control_period(period) else {
        exit(3)
    };
    measured.set_filter(filter);
    measured.clear_for(test);
    if record_monitor_window(
        &model,
        &truth,
        &load,
        &followed,
        TEST_SAMPLES,
        0.3,
        measured,
    )
    .is_err()
    {
        exit(3)
    }
    let samples = measured.samples().len();
    let guess = WindowLoad::spring(record.params.aero_stiffness, 0.0);
    let Ok(problem) = WindowProblem::new(
        measured,
        RecordedCommand::kept_every(COMMAND_STRIDE, command),
        model,
        guess,
    ) else {
        exit(3)
    };

    let start = cycles();
    let mut sink = 0.0f32;
    for _ in 0..EVALUATIONS {
        sink += problem.evaluate(&FaultVector::NOMINAL).error;
    }
    let evaluation =
        instructions_under_icount(cycles().saturating_sub(start)) / u64::from(EVALUATIONS);
    let start = cycles();
    let mut stepwise_polls = 0u32;
    for _ in 0..EVALUATIONS {
        let mut future = core::pin::pin!(problem.evaluate_stepwise(&FaultVector::NOMINAL, guess));
        let mut cx = Context::from_waker(Waker::noop());
        loop {
            stepwise_polls += 1;
            if let Poll::Ready(fit) = future.as_mut().poll(&mut cx) {
                sink += fit.error;
                break;
            }
        }
    }
    let evaluation_stepwise =
        instructions_under_icount(cycles().saturating_sub(start)) / u64::from(EVALUATIONS);
    defmt::println!(
        "window_bench evaluation_stepwise_instructions={=u64} polls_per_evaluation={=u32}",
        evaluation_stepwise,
        stepwise_polls / EVALUATIONS
    );
    let start = cycles();
    let curvature = problem.curvature(&truth);
    let curvature_instructions = instructions_under_icount(cycles().saturating_sub(start));
    let start = cycles();
    let (fitted, _) = problem.fit_load(&FaultVector::NOMINAL, guess.stiffness);
    let load_search = instructions_under_icount(cycles().saturating_sub(start));
    // The whole identification as the controller's idle-time task would run it: polled
    // step by step, each poll's instructions measured.
    let settings = window_ga(&record.ga);
    let mut problem = problem;
    let mut future = core::pin::pin!(identify_stepwise::<_, POPULATION>(
        &mut problem,
        settings,
        1,
        &WindowLimits::REFERENCE
    ));
    let state_bytes = core::mem::size_of_val(&*future);
    let mut cx = Context::from_waker(Waker::noop());
    let (mut polls, mut longest, mut longest_at, mut over) = (0u32, 0u64, 0u32, 0u32);
    // The budget in SysTick cycles (compared per poll without a division).
    let budget_cycles = SLICE_BUDGET * clock::CORE_HZ / 1_000_000_000;
    let mut over_bins = [0u32; 4];
    // The polls over the budget by their two ends (the pauses they start and end at): count
    // and longest [cycles], the first OVER_SITES pairs seen.
    let mut sites: [Option<OverSite>; OVER_SITES] = [None; OVER_SITES];
    let (mut longest_from, mut longest_to) = (None, None);
    let begin = cycles();
    let result = loop {
        let from = last_pause();
        let start = cycles();
        let poll = future.as_mut().poll(&mut cx);
        let took = cycles().saturating_sub(start);
        let to = last_pause();
        if took > longest {
            (longest, longest_at) = (took, polls);
            (longest_from, longest_to) = (from, to);
        }
        if took > budget_cycles {
            over += 1;
            // Over the budget: up to 2×, 10×, 100×, beyond.
            let bin = [2, 10, 100]
                .iter()
                .take_while(|&&m| took > m * budget_cycles)
                .count();
            if let Some(b) = over_bins.get_mut(bin) {
                *b += 1;
            }
            let key = (line_of(from), line_of(to));
            let slot = sites
                .iter_mut()
                .find(|s| s.is_none_or(|s| (line_of(s.from), line_of(s.to)) == key));
            if let Some(slot) = slot {
                let site = slot.get_or_insert(OverSite {
                    from,
                    to,
                    count: 0,
                    longest: 0,
                });
                site.count += 1;
                site.longest = site.longest.max(took);
            }
        }
        polls += 1;
        if let Poll::Ready(result) = poll {
            break result;
        }
    };
    let whole = instructions_under_icount(cycles().saturating_sub(begin));
    let Ok(reading) = result else { exit(2) };
    // The flight's reading (`shared::fusion`): this window added, the reading formed.
    let start = cycles();
    let mut fusion = WindowFusion::EMPTY;
    let added = fusion
        .add(&reading.faults, &reading.curvature, &WINDOW_INFLATION)
        .is_ok();
    let flight = fusion.final_reading(FLIGHT_MAX_FRICTION_STD);
    let fusion_instructions = instructions_under_icount(cycles().saturating_sub(start));
    let flight_friction = flight.map_or(f32::NAN, |f| f.faults.friction());
    defmt::println!(
        "window_bench samples={=usize} evaluation_instructions={=u64} curvature_instructions={=u64} load_search_instructions={=u64}",
        samples,
        evaluation,
        curvature_instructions,
        load_search,
    );
    defmt::println!(
        "window_bench identify_instructions={=u64} polls={=u32} longest_poll_instructions={=u64} longest_poll={=u32} polls_over_budget={=u32} state_bytes={=usize} ga_evaluations_cap={=u32} ga_population={=usize} model_runs={=u32} within={=bool} friction={=f32} gain_drift={=f32} stiffness={=f32} fitted_stiffness_at_nominal={=f32} check={=f32} fitted={=u32}",
        whole,
        polls,
        instructions_under_icount(longest),
        longest_at,
        over,
        state_bytes,
        settings.settings.max_evaluations,
        settings.population,
        reading.evaluations,
        reading.verdict.is_ok(),
        reading.faults.friction(),
        reading.faults.as_array().get(7).copied().unwrap_or(f32::NAN),
        reading.load.stiffness,
        fitted.stiffness,
        sink,
        curvature.fitted,
    );
    defmt::println!(
        "window_bench polls_over_budget_by_multiple to_2x={=u32} to_10x={=u32} to_100x={=u32} beyond={=u32}",
        over_bins[0],
        over_bins[1],
        over_bins[2],
        over_bins[3]
    );
    let (from, to) = (line_of(longest_from), line_of(longest_to));
    defmt::println!(
        "window_bench longest_poll_from={=str}:{=u32} longest_poll_to={=str}:{=u32}",
        from.0,
        from.1,
        to.0,
        to.1
    );
    for site in sites.iter().flatten() {
        let (from, to) = (line_of(site.from), line_of(site.to));
        defmt::println!(
            "window_bench over_budget from={=str}:{=u32} to={=str}:{=u32} polls={=u32} longest_instructions={=u64}",
            from.0,
            from.1,
            to.0,
            to.1,
            site.count,
            instructions_under_icount(site.longest)
        );
    }
    defmt::println!(
        "window_bench fusion_instructions={=u64} fusion_state_bytes={=usize} added={=bool} flight_friction={=f32}",
        fusion_instructions,
        core::mem::size_of::<WindowFusion>(),
        added,
        flight_friction,
    );
    exit(0)
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    let (file, line) = info.location().map_or(("?", 0), |l| (l.file(), l.line()));
    defmt::error!("panic at {=str}:{=u32}", file, line);
    exit(101)
}

#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    defmt::error!("hard fault: pc={=u32:#010x}", frame.pc());
    exit(102)
}
