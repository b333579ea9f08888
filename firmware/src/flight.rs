//! A flight's windows on the controller (issue 69): each window's frames and the command its
//! position loop followed are acquired into the preflight's buffers, the window is read by
//! the window identification (`shared::window::identify_stepwise`, with its load fitted)
//! holding what the flight's preflight read, and the windows that may enter are fused into
//! the flight's reading (`shared::fusion`) — the host's `identify W --preflight P
//! --same-flight …`, the same bits.
//!
//! Units: the command in rad, 10 kHz frames. Work bounds: [`WindowAcquisition::poll`] takes
//! at most its `frames` frames per call (O(1) each); the set-up's, the identification's and
//! the fusion's polls are theirs (`shared`'s stepwise forms: each within 30 % of a 100 µs
//! control period on the Cortex-M4F but the set-up's two moves, docs/controller.md).
//! No allocation: the command buffer's capacity is in its type ([`KeptCommand`]).
//!
//! Not on the controller yet: a window the load model leaves at its fitness floor is read
//! on the host again with its surface pinned to its sensor (`shared::pinned`); the controller
//! names such a window ([`WindowOutcome::NeedsPinned`]) and leaves it out of the flight.

use shared::conditioning::ConditioningError;
use shared::fdi::{OnboardMeasured, TEST_SAMPLES};
use shared::fitness::CurvatureRun;
use shared::window::{HeldComponents, WindowReason, COMMAND_STRIDE};

use crate::source::{Acquired, CurrentSource, TraceBytes, TraceSource};

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

/// The preflight's uncertainty runs and a window's kept command in one buffer: a flight's
/// windows are read after its preflight, never during it, so the two share the RAM
/// (4.5 kB + 5.5 kB in one 5.5 kB buffer).
#[allow(clippy::large_enum_variant)] // both are large: the point is that they share
pub enum Scratch {
    Curvature(CurvatureRun),
    Command(KeptCommand),
}

impl Scratch {
    pub const IDLE: Self = Self::Curvature(CurvatureRun::IDLE);

    /// The buffer as the preflight's uncertainty runs (idle runs if it held a command).
    /// Never `None`.
    pub fn curvature(&mut self) -> Option<&mut CurvatureRun> {
        if let Self::Command(_) = self {
            *self = Self::IDLE;
        }
        match self {
            Self::Curvature(c) => Some(c),
            Self::Command(_) => None,
        }
    }

    /// The buffer as a window's kept command (empty if it held the runs). Never `None`.
    pub fn command(&mut self) -> Option<&mut KeptCommand> {
        if let Self::Curvature(_) = self {
            *self = Self::Command(KeptCommand::EMPTY);
        }
        match self {
            Self::Command(k) => Some(k),
            Self::Curvature(_) => None,
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
}
