//! A flight's windows on the controller (issue 69): each window's frames and the command its
//! position loop followed are acquired into the preflight's buffers, the window is read by
//! the window identification (`shared::window::identify_stepwise`, with its load fitted)
//! holding what the flight's preflight read, and the windows that may enter are fused into
//! the flight's reading (`shared::fusion`) — the host's `identify W --preflight P
//! --same-flight …`, the same bits. Both images read a window with [`read_window`]: the
//! emulation image from trace files, the board from its converters while it flies
//! ([`FlightCommand`]: the demand followed, the window's chirp superimposed).
//!
//! Units: the command in rad, 10 kHz frames. Work bounds: [`WindowAcquisition::poll`] takes
//! at most its `frames` frames per call (O(1) each); [`FlightCommand::tick`] is O(1); the
//! set-up's, the identification's and the fusion's polls are theirs (`shared`'s stepwise
//! forms: each within 30 % of a 100 µs control period on the Cortex-M4F but the set-up's two
//! moves, docs/controller.md), one per [`Slices`] slice.
//! No allocation: the command buffer's capacity is in its type ([`KeptCommand`]).
//!
//! Not on the controller yet: a window the load model leaves at its fitness floor is read
//! on the host again with its surface pinned to its sensor (`shared::pinned`); the controller
//! names such a window ([`WindowOutcome::NeedsPinned`]) and leaves it out of the flight.

use core::future::Future;
use core::pin::{pin, Pin};

use shared::actuator::ActuatorRecord;
use shared::conditioning::ConditioningError;
use shared::conditions::TestConditions;
use shared::fdi::{OnboardMeasured, POPULATION, TEST_SAMPLES};
use shared::fitness::CurvatureRun;
use shared::fusion::WindowFusion;
use shared::ga::GaError;
use shared::repeat::RepeatedTests;
use shared::test_design::PreflightTest;
use shared::window::{
    fusable, identify_stepwise, window_ga, HeldComponents, WindowError, WindowLimits, WindowLoad,
    WindowProblem, WindowReading, WindowReason, COMMAND_STRIDE, WINDOW_INFLATION,
};

use crate::sequencer::{Drive, Sequenced, TestSequencer};
use crate::source::{Acquired, CurrentSource, TraceBytes, TraceSource};

/// Windows of one flight read at most: a flight of eight.
pub const MAX_WINDOWS: usize = 8;

/// Frames a window's acquisition takes per poll in flight: on the controller one frame
/// arrives per control period; the emulation image reads them from its trace file one at a
/// time too (a row's read, its checksum and its conditioning: ≈ 2.9 × 10³ instructions).
pub const WINDOW_FRAMES_PER_POLL: u32 = 1;

/// Commands kept of a window of at most [`TEST_SAMPLES`] frames: every
/// [`COMMAND_STRIDE`]-th.
pub const KEPT_COMMANDS: usize = (TEST_SAMPLES - 1) / COMMAND_STRIDE + 1;

/// The window's command as the controller keeps it: frame `j·COMMAND_STRIDE`'s at `j`
/// (5.5 kB).
pub struct KeptCommand {
    values: [f32; KEPT_COMMANDS],
    len: usize,
}

impl KeptCommand {
    pub const EMPTY: Self = Self {
        values: [0.0; KEPT_COMMANDS],
        len: 0,
    };

    pub fn clear(&mut self) {
        self.len = 0;
    }

    /// Keeps frame `index`'s command `command` [rad] if it is a kept one; `Err` hands it
    /// back when the buffer is full. O(1).
    pub fn push_frame(&mut self, index: usize, command: f32) -> Result<(), f32> {
        if index % COMMAND_STRIDE != 0 {
            return Ok(());
        }
        let slot = self.values.get_mut(self.len).ok_or(command)?;
        *slot = command;
        self.len += 1;
        Ok(())
    }

    /// The kept commands.
    pub fn as_slice(&self) -> &[f32] {
        self.values.get(..self.len).unwrap_or(&[])
    }
}

/// The preflight's uncertainty runs (with its repeated tests' record, when the noise calls
/// for more than one test) and a window's kept command in one buffer: a flight's windows are
/// read after its preflight, never during it, so the two share the RAM (4.5 kB + 5.5 kB in
/// one 5.5 kB buffer).
#[allow(clippy::large_enum_variant)] // both are large: the point is that they share
pub enum Scratch {
    Curvature(CurvatureRun, RepeatedTests),
    Command(KeptCommand),
}

impl Scratch {
    pub const IDLE: Self = Self::Curvature(CurvatureRun::IDLE, RepeatedTests::EMPTY);

    /// The buffer as the preflight's uncertainty runs and its tests' record, none yet (idle
    /// runs if it held a command). Never `None`.
    pub fn curvature(&mut self) -> Option<(&mut CurvatureRun, &mut RepeatedTests)> {
        if let Self::Command(_) = self {
            *self = Self::IDLE;
        }
        match self {
            Self::Curvature(c, tests) => {
                *tests = RepeatedTests::EMPTY;
                Some((c, tests))
            }
            Self::Command(_) => None,
        }
    }

    /// The buffer as a window's kept command (empty if it held the runs). Never `None`.
    pub fn command(&mut self) -> Option<&mut KeptCommand> {
        if let Self::Curvature(..) = self {
            *self = Self::Command(KeptCommand::EMPTY);
        }
        match self {
            Self::Command(k) => Some(k),
            Self::Curvature(..) => None,
        }
    }
}

/// A source of a window's frames that also gives each frame's command: a trace of a window
/// of flight under emulation, the flight's command stream on the controller.
pub trait CommandedSource: CurrentSource {
    /// The commanded user-shaft angle of the last frame handed out [rad].
    fn command(&self) -> f32;
    /// Whether the source holds a window of flight (a trace's flight mark).
    fn is_window(&self) -> bool;
}

impl<B: TraceBytes> CommandedSource for TraceSource<B> {
    fn command(&self) -> f32 {
        TraceSource::command(self)
    }

    fn is_window(&self) -> bool {
        self.header().flight
    }
}

/// Why a window could not be acquired.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(any(feature = "defmt", target_os = "none"), derive(defmt::Format))]
pub enum WindowAcquireError<E> {
    Source(E),
    /// The source holds a preflight test, not a window of flight.
    NotAWindow,
    /// More frames than the buffer holds.
    TooManyFrames {
        capacity: u32,
    },
    Conditioning(ConditioningError),
}

/// One window's acquisition in bounded polls: frames into the measured buffer (cleared for
/// the window's test first), commands into the kept command.
pub struct WindowAcquisition {
    frames: u32,
    pole_pairs: f32,
}

impl WindowAcquisition {
    /// Starts acquiring into `measured` and `kept` (both cleared) from a source of the
    /// window's `test`; refuses a source that holds no window.
    pub fn start<S: CommandedSource>(
        source: &S,
        test: shared::test_design::PreflightTest,
        pole_pairs: f32,
        measured: &mut OnboardMeasured,
        kept: &mut KeptCommand,
    ) -> Result<Self, WindowAcquireError<S::Error>> {
        if !source.is_window() {
            return Err(WindowAcquireError::NotAWindow);
        }
        measured.clear_for(test);
        kept.clear();
        Ok(Self {
            frames: 0,
            pole_pairs,
        })
    }

    /// Takes at most `frames` frames: `Ok(true)` when the window's frames are all in (its
    /// current is then sealed by `MeasuredCurrent::finish_stepwise`). O(`frames`).
    pub fn poll<S: CommandedSource>(
        &mut self,
        source: &mut S,
        measured: &mut OnboardMeasured,
        kept: &mut KeptCommand,
        frames: u32,
    ) -> Result<bool, WindowAcquireError<S::Error>> {
        let full = || WindowAcquireError::TooManyFrames {
            capacity: TEST_SAMPLES as u32,
        };
        for _ in 0..frames {
            match source.next_frame().map_err(WindowAcquireError::Source)? {
                Acquired::Frame(frame) => {
                    measured
                        .push_frame(frame, self.pole_pairs)
                        .map_err(|_| full())?;
                    kept.push_frame(self.frames as usize, source.command())
                        .map_err(|_| full())?;
                    self.frames = self.frames.saturating_add(1);
                }
                Acquired::NotYet => return Ok(false),
                Acquired::EndOfTest => return Ok(true),
            }
        }
        Ok(false)
    }

    /// Frames taken.
    pub fn frames(&self) -> u32 {
        self.frames
    }
}

/// What became of one window of a flight.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(any(feature = "defmt", target_os = "none"), derive(defmt::Format))]
pub enum WindowOutcome {
    /// Read with its load fitted; whether it entered the flight's reading.
    Read { entered: bool },
    /// The load model is at its fitness floor and the preflight was trusted: the host reads
    /// such a window with its surface pinned (`shared::pinned`), which the controller does
    /// not carry yet. Left out of the flight.
    NeedsPinned,
}

impl WindowOutcome {
    /// The outcome of a window read with its load fitted, its `verdict`, holding `held`
    /// and `entered` (added to the flight).
    pub fn of(verdict: &Result<(), WindowReason>, held: &HeldComponents, entered: bool) -> Self {
        if shared::pinned::wants_pinned(verdict, held) {
            Self::NeedsPinned
        } else {
            Self::Read { entered }
        }
    }
}

/// The demand's low-pass cutoff [Hz]: a converter's count steps (0.24 mrad) would kick the
/// position loop's derivative into the current limit; the flight control computer's
/// corrections (≤ 2 Hz) pass with ≤ 6° of lag.
pub const DEMAND_CUTOFF_HZ: f32 = 20.0;

/// The flight's position command, one control period at a time: the flight control
/// computer's demand, low-passed ([`DEMAND_CUTOFF_HZ`], backward Euler), followed, and
/// during a window the window's chirp (the test's chirp alone) superimposed on it — the loop
/// is never suspended in flight. Each frame commands the next period (the bridge loads its
/// duties at the next update), so the command acting in a frame's period is the one given at
/// the frame before: what a window's kept command records. O(1) per frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlightCommand {
    window: Option<TestSequencer>,
    /// The command given at the last frame [rad]: it acts in the next frame's period.
    given: f32,
    /// The low-passed demand [rad] (`None` before the first frame) and the filter's share
    /// per control period.
    demand: Option<f32>,
    share: f32,
}

impl FlightCommand {
    /// Following the demand at control period `period` [s]; nothing given yet (0 rad acts
    /// in the first period).
    pub fn follow(period: f32) -> Self {
        let w = 2.0 * core::f32::consts::PI * DEMAND_CUTOFF_HZ * period;
        Self {
            window: None,
            given: 0.0,
            demand: None,
            share: w / (1.0 + w),
        }
    }

    /// From the next frame on, `test`'s chirp superimposed on the demand, one sample per
    /// control period of `period` [s], until its last sample.
    pub fn begin_window(&mut self, test: PreflightTest, period: f32) {
        self.window = Some(TestSequencer::new(test.chirp_only(), period));
    }

    /// Whether a window's chirp is being played.
    pub fn in_window(&self) -> bool {
        self.window.is_some()
    }

    /// One frame, at which the demand read `demand` [rad]: commands the next period through
    /// `drive` (the low-passed demand, plus the chirp's next sample in a window) and returns
    /// the command acting in this frame's period. O(1).
    pub fn tick(&mut self, demand: f32, drive: &mut impl Drive) -> f32 {
        let acting = self.given;
        let demand = match self.demand {
            Some(d) => d + self.share * (demand - d),
            None => demand,
        };
        self.demand = Some(demand);
        let mut superimposed = Superimposed {
            drive,
            demand,
            given: demand,
        };
        let played = self
            .window
            .as_mut()
            .map(|w| w.tick(&mut superimposed) != Sequenced::Done);
        if played != Some(true) {
            self.window = None;
            superimposed.position(0.0);
        }
        self.given = superimposed.given;
        acting
    }
}

/// A drive with the demand added to every position command.
struct Superimposed<'a, D> {
    drive: &'a mut D,
    demand: f32,
    given: f32,
}

impl<D: Drive> Drive for Superimposed<'_, D> {
    fn position(&mut self, rad: f32) {
        self.given = rad + self.demand;
        self.drive.position(self.given);
    }

    // A window's test is its chirp alone: these are never asked for.
    fn pair_voltage(&mut self, pair: u8, volts: f32) {
        self.drive.pair_voltage(pair, volts);
    }

    fn off(&mut self, pair: u8) {
        self.drive.off(pair);
    }

    fn lead(&self) -> usize {
        self.drive.lead()
    }
}

/// Where a window's reading stands ([`Slices::stage`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(any(feature = "defmt", target_os = "none"), derive(defmt::Format))]
pub enum WindowStage {
    /// The day's estimate, the model and the problem's sums.
    SetUp,
    /// The two GAs, the polish, the curvature and the verdict.
    Identify,
    /// The window's evidence added to the flight's.
    Fuse,
}

/// How the pieces of a window's reading run: one poll of a piece's future per slice, and
/// between two slices what the executor has to do — the emulation image times each poll,
/// the board serves its control loop.
#[allow(async_fn_in_trait)] // used by this crate's images only, never behind `dyn`
pub trait Slices {
    /// Runs `future` to its end, one poll per slice.
    async fn run<F: Future>(&mut self, future: Pin<&mut F>) -> F::Output;
    /// The reading enters `stage`. O(1).
    fn stage(&mut self, _stage: WindowStage) {}
}

/// One window read ([`read_window`]).
pub struct WindowRead {
    pub reading: WindowReading,
    /// The day the window's set-up estimated.
    pub conditions: TestConditions,
    /// Whether the window entered the flight's reading.
    pub fused: bool,
}

/// Why a window could not be read.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(any(feature = "defmt", target_os = "none"), derive(defmt::Format))]
pub enum WindowReadError {
    /// The window's problem could not be built (too short, flat, singular).
    SetUp(WindowError),
    /// The record's GA settings were refused.
    Search(GaError),
}

/// Reads the window whose current is sealed in `measured` and whose kept command is `kept`,
/// for `record` (its chirp-only test), holding `held` (the flight's preflight's reading),
/// with GA seed `seed`, and adds it to `fusion` if it may enter: the set-up, the
/// identification and the fusion, each a future run by `slices`. The window's problem is
/// built in place, in this future's state (≈ 1.9 kB never moved).
pub async fn read_window<S: Slices>(
    slices: &mut S,
    measured: &OnboardMeasured,
    kept: &[f32],
    record: &ActuatorRecord,
    held: &HeldComponents,
    seed: u64,
    fusion: &mut WindowFusion,
) -> Result<WindowRead, WindowReadError> {
    let guess = WindowLoad::spring(record.params.aero_stiffness, 0.0);
    let mut built = None;
    slices.stage(WindowStage::SetUp);
    let conditions = slices
        .run(pin!(WindowProblem::of_record_into_stepwise(
            &mut built, measured, kept, record, guess,
        )))
        .await
        .map_err(WindowReadError::SetUp)?;
    let problem = built
        .as_mut()
        .ok_or(WindowReadError::SetUp(WindowError::Singular))?;
    problem.hold(*held);
    slices.stage(WindowStage::Identify);
    let reading = slices
        .run(pin!(identify_stepwise::<_, POPULATION>(
            problem,
            window_ga(&record.ga),
            seed,
            &WindowLimits::REFERENCE,
        )))
        .await
        .map_err(WindowReadError::Search)?;
    slices.stage(WindowStage::Fuse);
    let fused = fusable(&reading.verdict)
        && slices
            .run(pin!(fusion.add_holding_stepwise(
                &reading.faults,
                &reading.curvature,
                &WINDOW_INFLATION,
                held,
                &reading.coupling,
            )))
            .await
            .is_ok();
    Ok(WindowRead {
        reading,
        conditions,
        fused,
    })
}

/// The window's reading as bits, the line both images print and the tests compare with the
/// host's: `window_bits n=… faults=… fitness=… std=…`.
#[cfg(target_os = "none")]
pub fn print_window_bits(n: u32, reading: &WindowReading) {
    defmt::println!(
        "window_bits n={=u32} faults={:08x} fitness={=u32:08x} std={:08x}",
        n,
        reading.faults.as_array().map(f32::to_bits),
        reading.fit.error.to_bits(),
        reading
            .uncertainty
            .as_ref()
            .map_or([u32::MAX; shared::FAULT_COUNT], |(u, _)| u
                .std
                .map(f32::to_bits))
    );
}

/// The flight's reading as bits: `flight_bits faults=… std=…`.
#[cfg(target_os = "none")]
pub fn print_flight_bits(reading: &shared::fusion::FlightReading) {
    defmt::println!(
        "flight_bits faults={:08x} std={:08x}",
        reading.faults.as_array().map(f32::to_bits),
        reading.uncertainty.0.std.map(f32::to_bits)
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_kept_command_keeps_every_strideth_frame_and_hands_back_when_full() {
        let mut kept = KeptCommand::EMPTY;
        for i in 0..(2 * COMMAND_STRIDE + 1) {
            kept.push_frame(i, i as f32).unwrap();
        }
        assert_eq!(
            kept.as_slice(),
            &[0.0, COMMAND_STRIDE as f32, 2.0 * COMMAND_STRIDE as f32]
        );
        kept.clear();
        for j in 0..KEPT_COMMANDS {
            kept.push_frame(j * COMMAND_STRIDE, 1.0).unwrap();
        }
        assert_eq!(
            kept.push_frame(KEPT_COMMANDS * COMMAND_STRIDE, 2.5),
            Err(2.5)
        );
        // A frame between kept ones is never refused.
        assert_eq!(
            kept.push_frame(KEPT_COMMANDS * COMMAND_STRIDE + 1, 2.5),
            Ok(())
        );
    }

    #[test]
    fn the_scratch_buffer_turns_from_runs_to_a_command_and_back() {
        let mut scratch = Scratch::IDLE;
        assert!(scratch.curvature().is_some());
        let kept = scratch.command().unwrap();
        assert!(kept.as_slice().is_empty());
        kept.push_frame(0, 1.5).unwrap();
        assert_eq!(scratch.command().unwrap().as_slice(), &[1.5]);
        assert!(scratch.curvature().is_some());
        assert!(scratch.command().unwrap().as_slice().is_empty());
    }

    /// A drive that keeps the position commands it was given.
    #[derive(Default)]
    struct Given {
        positions: std::vec::Vec<f32>,
        lead: usize,
    }

    impl Drive for Given {
        fn position(&mut self, rad: f32) {
            self.positions.push(rad);
        }
        fn pair_voltage(&mut self, _: u8, _: f32) {
            panic!("a window's test has no pair segment");
        }
        fn off(&mut self, _: u8) {
            panic!("a window's test has no pair segment");
        }
        fn lead(&self) -> usize {
            self.lead
        }
    }

    extern crate std;

    #[test]
    fn a_window_superimposes_its_chirp_on_the_demand_a_period_ahead() {
        let test = PreflightTest::INJECTION;
        let period = 1.0e-4;
        let chirp = |k: usize| match test.chirp_only().drive(k, period) {
            shared::test_design::Drive::Position(x) => x,
            shared::test_design::Drive::Pair(_) => panic!("chirp only"),
        };
        let samples = test.chirp_only().samples(period);
        // A constant demand passes its filter unchanged: the chirp's timing alone is tested.
        let demand = |_: usize| -1.5e-3f32;
        let mut drive = Given {
            lead: 1,
            ..Given::default()
        };
        let mut command = FlightCommand::follow(period);
        // Following: each frame gives its own demand; the first period had nothing.
        assert_eq!(command.tick(demand(0), &mut drive), 0.0);
        assert_eq!(command.tick(demand(1), &mut drive), demand(0));
        command.begin_window(test, period);
        assert!(command.in_window());
        let acting: std::vec::Vec<f32> = (0..samples)
            .map(|k| command.tick(demand(2 + k), &mut drive))
            .collect();
        // The window's first period acts the demand given before it; then each frame's
        // demand with the chirp's next sample.
        assert_eq!(acting[0], demand(1));
        for (k, &a) in acting.iter().enumerate().skip(1) {
            assert_eq!(a, chirp(k) + demand(1 + k), "frame {k}");
        }
        assert!(chirp(samples / 2) != 0.0);
        // Its last frame holds the last sample; then the demand alone again.
        assert!(command.in_window());
        let after = command.tick(demand(2 + samples), &mut drive);
        assert_eq!(after, chirp(samples - 1) + demand(1 + samples));
        assert!(!command.in_window());
        assert_eq!(command.tick(0.5, &mut drive), demand(2 + samples));
        assert_eq!(drive.positions.len(), samples + 4);
    }

    #[test]
    fn the_demand_is_low_passed_a_count_step_is_spread() {
        let period = 1.0e-4;
        let mut drive = Given::default();
        let mut command = FlightCommand::follow(period);
        command.tick(0.0, &mut drive);
        let step = 1.0 / 4096.0;
        for _ in 0..20 {
            command.tick(step, &mut drive);
        }
        let after = *drive.positions.last().unwrap();
        // 2 ms at 20 Hz: 1 − e^(−2π·20·0.002) ≈ 22 % of the step.
        assert!(after > 0.18 * step && after < 0.26 * step, "{after}");
        for _ in 0..2_000 {
            command.tick(step, &mut drive);
        }
        assert!((drive.positions.last().unwrap() - step).abs() < 1.0e-3 * step);
    }
}
