//! The preflight test played on the drive: one command per control period, read from the
//! actuator's test design (`PreflightTest::drive`, the schedule `host-sim test-schedule`
//! writes), handed to a [`Drive`] — the board's bridge and position loop, or a recorder on the
//! host. Time is the control period's index, passed in by the caller's tick; O(1) per tick
//! (one chirp sample or one tone sample), no allocation.

use shared::test_design::{Drive as Command, PreflightTest};

/// What the test needs of the drive, one call per control period.
pub trait Drive {
    /// Close the position loop on this user-shaft angle command [rad].
    fn position(&mut self, rad: f32);
    /// Suspend the position loop and apply `volts` across phase pair `pair` (signs
    /// `PAIR_SIGNS[pair]`: + leg high, − leg low, the third open).
    fn pair_voltage(&mut self, pair: u8, volts: f32);
    /// Every leg of pair `pair` off: its current freewheels (the tone's pauses and the
    /// settle before the first pair).
    fn off(&mut self, pair: u8);
    /// Control periods between the frame a command is given on and the period it acts in
    /// (1 for a timer that loads its compare registers at the next update): the sequencer
    /// gives each period's command that much early. O(1).
    fn lead(&self) -> usize {
        0
    }
}

/// Where the sequencer stands after a tick.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(any(feature = "defmt", target_os = "none"), derive(defmt::Format))]
pub enum Sequenced {
    /// Control period `index` was commanded.
    Commanded { index: usize },
    /// The test is over: nothing was commanded (the caller hands the drive back to flight).
    Done,
}

/// Plays `test` at control period `period` [s], one period per [`TestSequencer::tick`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TestSequencer {
    test: PreflightTest,
    period: f32,
    samples: usize,
    next: usize,
}

impl TestSequencer {
    pub fn new(test: PreflightTest, period: f32) -> Self {
        Self {
            test,
            period,
            samples: test.samples(period),
            next: 0,
        }
    }

    /// Control periods the whole test takes.
    pub fn samples(&self) -> usize {
        self.samples
    }

    /// Commands the next control period through `drive`: the test's command for the period
    /// `drive.lead()` on (the last one held past the end). O(1).
    pub fn tick(&mut self, drive: &mut impl Drive) -> Sequenced {
        let index = self.next;
        if index >= self.samples {
            return Sequenced::Done;
        }
        self.next += 1;
        let acting = index
            .saturating_add(drive.lead())
            .min(self.samples.saturating_sub(1));
        match self.test.drive(acting, self.period) {
            Command::Position(rad) => drive.position(rad),
            Command::Pair(d) => {
                // `pair` is 0..3 by construction; saturate rather than wrap.
                let pair = u8::try_from(d.pair).unwrap_or(u8::MAX);
                if d.volts == 0.0 {
                    drive.off(pair);
                } else {
                    drive.pair_voltage(pair, d.voltage(self.period));
                }
            }
        }
        Sequenced::Commanded { index }
    }
}
