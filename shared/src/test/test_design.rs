//! The preflight test design: what the controller commands, control period by control period.
//!
//! Units: volts (line voltage across a phase pair), rad (user shaft), samples of one control
//! period (100 µs). Every call is O(1); time is passed in as a sample index, never read.
//!
//! A test is a sequence of segments, all optional but the chirp:
//! 1. **Standstill** ([`StandstillSegment`]): the position loop is suspended and the drive
//!    applies a line voltage to each phase pair in turn (A→B, B→C, C→A), then lets the pair
//!    freewheel at zero volts. Two forms:
//!    * **Injection** ([`StandstillSegment::INJECTION`], the product's default): a tone of
//!      `frequency` (hundreds of Hz) and amplitude `volts` (tens of volts) per pair, whole
//!      periods, cosine from the first sample's centre so that the current starts and ends
//!      near zero with no DC part. The pair impedance is `R + jωL` with `ωL ≫ R`: the current's
//!      size is set by `L`, which a short of `N` healthy turns scales by `N²` and temperature
//!      hardly moves; its phase carries `R` (the winding's temperature). The volts are large
//!      against what a real bridge gets wrong (dead time, switch drops, one timer count),
//!      and the torque alternates faster than the rotor can follow.
//!    * **Steps** (`frequency` = 0, [`StandstillSegment::DEFAULT`], the earlier default): a
//!      small DC voltage below break-away torque. The current rises with `R` and `L`; on a
//!      real bridge the dead time swallows a step this small (docs/identifiability.md).
//! 2. **Motion** ([`MotionSegment`], studied, not the default): smooth user-shaft moves to
//!    `+A`, `−A` and back with plateaus, enough travel to turn the motor more than one
//!    mechanical revolution.
//! 3. **Chirp** ([`ChirpCommand`]): the paper's test (SPEC §5).
//!
//! [`PreflightTest::PAPER`] is the chirp alone (the paper's current-only test, trace format
//! version 1); [`PreflightTest::STANDSTILL`] is the product's default.

use crate::base::math::cos;
use crate::test::command::ChirpCommand;
use core::f32::consts::PI;

/// Signs of phases A, B, C for each standstill pair: current into the `+1` phase, out of the
/// `−1` phase, the `0` phase open. Pairs in order A→B, B→C, C→A.
pub const PAIR_SIGNS: [[i8; 3]; 3] = [[1, -1, 0], [0, 1, -1], [-1, 0, 1]];

/// One drive setting of the standstill segment.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PairDrive {
    /// Index into [`PAIR_SIGNS`].
    pub pair: usize,
    /// Line voltage across the pair, `+` phase minus `−` phase \[V\]: the step's, or the
    /// tone's amplitude; 0 while the pair freewheels.
    pub volts: f32,
    /// Tone frequency \[Hz\]; 0 for a step.
    pub frequency: f32,
    /// Control periods since the voltage came on (the tone's phase).
    pub on_index: u16,
}

impl PairDrive {
    /// The line voltage commanded over this control period \[V\], at control period `dt` \[s\]:
    /// the step's volts, or `volts · cos(2π·f·(on_index + ½)·dt)` (the tone sampled at the
    /// period's centre, so that the held value is the period's mean to second order). O(1).
    #[inline(never)]
    pub fn voltage(&self, dt: f32) -> f32 {
        if self.frequency == 0.0 || self.volts == 0.0 {
            return self.volts;
        }
        // Phase in turns, reduced before the cosine: the same bits on every target.
        let turns = self.frequency * dt * (f32::from(self.on_index) + 0.5);
        let turns = turns - crate::base::math::floor(turns);
        self.volts * cos(2.0 * PI * turns)
    }

    /// Signs of A, B, C for this pair.
    pub fn signs(&self) -> [i8; 3] {
        match PAIR_SIGNS.get(self.pair) {
            Some(s) => *s,
            None => [0; 3],
        }
    }
}

/// Voltage steps or tones on each phase pair at standstill.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StandstillSegment {
    /// Line voltage of the step, or amplitude of the tone \[V\].
    pub volts: f32,
    /// Frequency of the tone \[Hz\]; 0 for steps.
    pub frequency: f32,
    /// Control periods at zero volts on the first pair before the steps: the rotor, which
    /// the position hold may leave hunting inside the gear's play, comes to rest (the
    /// shorted pair brakes it, friction stops it). Not fitted: the shaft moves.
    pub settle_samples: u16,
    /// Control periods with the voltage applied, per pair.
    pub on_samples: u16,
    /// Control periods at zero volts (the pair freewheels) after each step.
    pub off_samples: u16,
}

impl StandstillSegment {
    /// The product's segment for the reference actuator: 10 ms settle, then 0.24 V
    /// (≈ 0.2 A in a healthy pair of 2 × 0.6 Ω, a torque of at most 0.052 N·m against
    /// 0.06 N·m of breakaway friction) for 8 ms (≈ 2 electrical time constants L/R =
    /// 4.2 ms) and 6 ms off per pair; 52 ms in all.
    pub const DEFAULT: Self = Self {
        volts: 0.24,
        frequency: 0.0,
        settle_samples: 100,
        on_samples: 80,
        off_samples: 60,
    };

    /// The product's injection for the reference actuator: 10 ms settle, then per pair
    /// 20 V at 500 Hz for 10 ms (5 periods: ≈ 1.2 A through ωL = 15.7 Ω of a healthy pair,
    /// 12 times the 2 × 0.8 V a 0.5 µs dead time costs the pair at 270 V) and 2 ms off;
    /// 46 ms in all.
    pub const INJECTION: Self = Self {
        volts: 20.0,
        frequency: 500.0,
        settle_samples: 100,
        on_samples: 100,
        off_samples: 20,
    };

    /// Whether the segment plays tones rather than steps.
    pub fn is_injection(&self) -> bool {
        self.frequency > 0.0
    }

    /// Control periods in the whole segment (settle and three pairs).
    pub const fn samples(&self) -> usize {
        self.settle_samples as usize + 3 * (self.on_samples as usize + self.off_samples as usize)
    }

    /// Whether sample `index` of the segment is fitted (past the settle).
    pub const fn fitted(&self, index: usize) -> bool {
        index >= self.settle_samples as usize && index < self.samples()
    }

    /// The drive during sample `index` of the segment, `None` past its end.
    pub fn at(&self, index: usize) -> Option<PairDrive> {
        let per_pair = self.on_samples as usize + self.off_samples as usize;
        if per_pair == 0 || index >= self.samples() {
            return None;
        }
        let Some(index) = index.checked_sub(self.settle_samples as usize) else {
            return Some(PairDrive {
                pair: 0,
                volts: 0.0,
                frequency: self.frequency,
                on_index: 0,
            });
        };
        let pair = index / per_pair;
        let within = index % per_pair;
        let on = within < self.on_samples as usize;
        Some(PairDrive {
            pair,
            volts: if on { self.volts } else { 0.0 },
            frequency: self.frequency,
            on_index: if on { within as u16 } else { 0 },
        })
    }

    /// The drives of samples `0, 1, …` in order, [`at`](Self::at)'s for each, kept by
    /// counting rather than dividing: O(1) a sample, for a model run's loop.
    pub fn drives(&self) -> StandstillDrives {
        let on_samples = usize::from(self.on_samples);
        let per_pair = on_samples + usize::from(self.off_samples);
        StandstillDrives {
            volts: self.volts,
            frequency: self.frequency,
            settle: usize::from(self.settle_samples),
            on_samples,
            per_pair,
            end: if per_pair == 0 { 0 } else { self.samples() },
            index: 0,
            pair: 0,
            within: 0,
        }
    }
}

/// The drives of a [`StandstillSegment`]'s samples in order ([`StandstillSegment::drives`]):
/// the segment's counts taken once, then the next sample's index, its pair and its place in
/// that pair's on and off periods.
#[derive(Clone, Debug)]
pub struct StandstillDrives {
    volts: f32,
    frequency: f32,
    settle: usize,
    on_samples: usize,
    per_pair: usize,
    /// Samples in the segment (none when its pairs have no periods, as `at` has it).
    end: usize,
    index: usize,
    pair: usize,
    within: usize,
}

impl Iterator for StandstillDrives {
    type Item = PairDrive;

    /// The settle on pair 0 at 0 V, then each pair's `on_samples` (the tone's index counts
    /// them) and its `off_samples`; `None` past the segment's end. O(1).
    #[inline]
    fn next(&mut self) -> Option<PairDrive> {
        if self.index >= self.end {
            return None;
        }
        let fitted = self.index >= self.settle;
        let on = fitted && self.within < self.on_samples;
        let drive = PairDrive {
            pair: self.pair,
            volts: if on { self.volts } else { 0.0 },
            frequency: self.frequency,
            on_index: if on { self.within as u16 } else { 0 },
        };
        if fitted {
            self.within += 1;
            if self.within == self.per_pair {
                self.within = 0;
                self.pair += 1;
            }
        }
        self.index += 1;
        Some(drive)
    }
}

/// Smooth position moves before the chirp: 0 → +A → −A → 0, raised-cosine ramps, plateaus
/// after each.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MotionSegment {
    /// Plateau angle at the user shaft \[rad\].
    pub amplitude: f32,
    /// Control periods of one ramp from 0 to ±A (the ±A → ∓A ramp takes twice as long).
    pub ramp_samples: u16,
    /// Control periods of each plateau.
    pub hold_samples: u16,
}

impl MotionSegment {
    /// ±7 mrad at the user shaft: 14 mrad peak to peak, 7 rad (1.1 revolutions) at the motor
    /// with the gear of 500; 40 ms ramps, 30 ms plateaus, 250 ms in all.
    pub const DEFAULT: Self = Self {
        amplitude: 7.0e-3,
        ramp_samples: 400,
        hold_samples: 300,
    };

    pub const fn samples(&self) -> usize {
        4 * self.ramp_samples as usize + 3 * self.hold_samples as usize
    }

    /// Commanded user angle at sample `index` \[rad\] (0 past the end).
    pub fn position(&self, index: usize) -> f32 {
        let r = self.ramp_samples as usize;
        let h = self.hold_samples as usize;
        let a = self.amplitude;
        // Raised-cosine ramp from `from` to `to` over `len` samples.
        let ramp = |from: f32, to: f32, i: usize, len: usize| {
            let x = if len == 0 { 1.0 } else { i as f32 / len as f32 };
            from + (to - from) * 0.5 * (1.0 - cos(PI * x))
        };
        let mut i = index;
        for (from, to, len) in [(0.0, a, r), (a, a, h), (a, -a, 2 * r), (-a, -a, h)] {
            if i < len {
                return ramp(from, to, i, len);
            }
            i -= len;
        }
        if i < r {
            return ramp(-a, 0.0, i, r);
        }
        0.0
    }
}

/// Names of the coded designs, by code (codes 4 and 6 name nothing: a tone needs a
/// standstill segment).
pub const TEST_NAMES: [&str; 8] = [
    "paper",
    "standstill",
    "motion",
    "standstill+motion",
    "",
    "injection",
    "",
    "injection+motion",
];

/// What the controller commands during one control period.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Drive {
    /// Position loop closed on this user-shaft angle \[rad\].
    Position(f32),
    /// Position loop suspended, this voltage across this pair.
    Pair(PairDrive),
}

/// A whole preflight test: optional standstill and motion segments, then the chirp.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PreflightTest {
    pub standstill: Option<StandstillSegment>,
    pub motion: Option<MotionSegment>,
    pub chirp: ChirpCommand,
}

impl PreflightTest {
    /// The paper's test: the chirp alone, currents only.
    pub const PAPER: Self = Self {
        standstill: None,
        motion: None,
        chirp: ChirpCommand::PREFLIGHT,
    };

    /// The product's default: the injection at standstill, then the paper's chirp.
    pub const INJECTION: Self = Self {
        standstill: Some(StandstillSegment::INJECTION),
        motion: None,
        chirp: ChirpCommand::PREFLIGHT,
    };

    /// The earlier default: voltage steps at standstill, then the paper's chirp.
    pub const STANDSTILL: Self = Self {
        standstill: Some(StandstillSegment::DEFAULT),
        motion: None,
        chirp: ChirpCommand::PREFLIGHT,
    };

    /// Design c of the identifiability study: the motion segment, then the chirp.
    pub const MOTION: Self = Self {
        standstill: None,
        motion: Some(MotionSegment::DEFAULT),
        chirp: ChirpCommand::PREFLIGHT,
    };

    /// The same test with another chirp.
    pub const fn with_chirp(mut self, chirp: ChirpCommand) -> Self {
        self.chirp = chirp;
        self
    }

    /// Control periods of the standstill segment (0 without one).
    pub fn standstill_samples(&self) -> usize {
        self.standstill.map_or(0, |s| s.samples())
    }

    /// Control periods before the chirp starts.
    pub fn lead_samples(&self) -> usize {
        self.standstill_samples()
            .saturating_add(self.motion.map_or(0, |m| m.samples()))
    }

    /// Control periods of the chirp at control period `dt` \[s\].
    /// A chirp too long to count (`duration / dt` beyond `usize`, or infinite) reads as
    /// `usize::MAX`, never as 0; NaN or a negative duration is 0.
    pub fn chirp_samples(&self, dt: f32) -> usize {
        let n = self.chirp.duration / dt + 0.5;
        if n > 0.0 {
            // `as` saturates: +∞ and anything beyond usize::MAX give usize::MAX.
            n as usize
        } else {
            0
        }
    }

    /// Control periods of the whole test (saturating: a chirp too long to count reads as
    /// `usize::MAX`, which every capacity refuses).
    pub fn samples(&self, dt: f32) -> usize {
        self.lead_samples().saturating_add(self.chirp_samples(dt))
    }

    /// What the controller commands during sample `index` of the test, at control period
    /// `dt` \[s\]. O(1).
    pub fn drive(&self, index: usize, dt: f32) -> Drive {
        let mut i = index;
        if let Some(s) = self.standstill {
            if let Some(d) = s.at(i) {
                return Drive::Pair(d);
            }
            // `at` is `None` past the segment, or for a segment without pair steps.
            i = i.saturating_sub(s.samples());
        }
        if let Some(m) = self.motion {
            if i < m.samples() {
                return Drive::Position(m.position(i));
            }
            i = i.saturating_sub(m.samples());
        }
        Drive::Position(self.chirp.position(i as f32 * dt))
    }

    /// A one-byte code of the design, stored in trace headers: its [`kind`](Self::kind),
    /// with the default segments and chirp only.
    pub fn code(&self) -> Option<u8> {
        let default_segments = self
            .standstill
            .is_none_or(|s| s == StandstillSegment::DEFAULT || s == StandstillSegment::INJECTION)
            && self.motion.is_none_or(|m| m == MotionSegment::DEFAULT)
            && self.chirp == ChirpCommand::PREFLIGHT;
        default_segments.then_some(self.kind())
    }

    /// The same test's chirp alone, without its segments: what a window of flight carries
    /// (the position loop cannot be suspended in flight, `crate::flight::window`).
    #[must_use]
    pub fn chirp_only(&self) -> Self {
        Self {
            standstill: None,
            motion: None,
            ..*self
        }
    }

    /// Which segments the test has, as trace headers store it: 0 = chirp alone, +1 with a
    /// standstill segment, +2 with a motion segment, +4 when the standstill segment plays
    /// tones. Segments and chirp of another actuator (from its record) keep the kind of the
    /// default design they follow.
    pub fn kind(&self) -> u8 {
        let tone = self.standstill.is_some_and(|s| s.is_injection());
        (self.standstill.is_some() as u8)
            | ((self.motion.is_some() as u8) << 1)
            | ((tone as u8) << 2)
    }

    /// The name of [`Self::kind`], as CSV traces write it.
    pub fn kind_name(&self) -> &'static str {
        TEST_NAMES
            .get(usize::from(self.kind()))
            .copied()
            .unwrap_or("unnamed")
    }

    /// The name of a coded design, as CSV traces and the command line write it.
    pub fn name(&self) -> Option<&'static str> {
        self.code()
            .and_then(|c| TEST_NAMES.get(usize::from(c)).copied())
    }

    /// The coded design of a name.
    pub fn from_name(name: &str) -> Option<Self> {
        if name.is_empty() {
            return None;
        }
        let code = TEST_NAMES.iter().position(|n| *n == name)?;
        Self::from_code(code as u8)
    }

    /// The design of a header code.
    pub fn from_code(code: u8) -> Option<Self> {
        let tone = code & 4 != 0;
        if code > 7 || (tone && code & 1 == 0) {
            return None;
        }
        let segment = if tone {
            StandstillSegment::INJECTION
        } else {
            StandstillSegment::DEFAULT
        };
        Some(Self {
            standstill: (code & 1 != 0).then_some(segment),
            motion: (code & 2 != 0).then_some(MotionSegment::DEFAULT),
            chirp: ChirpCommand::PREFLIGHT,
        })
    }
}

impl Default for PreflightTest {
    fn default() -> Self {
        Self::INJECTION
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The counted drives are `at`'s, sample by sample, to the segment's end and no further.
    #[test]
    fn the_counted_drives_are_the_indexed_ones() {
        let no_pairs = StandstillSegment {
            on_samples: 0,
            off_samples: 0,
            ..StandstillSegment::DEFAULT
        };
        for s in [
            StandstillSegment::DEFAULT,
            StandstillSegment::INJECTION,
            no_pairs,
        ] {
            let counted: Vec<_> = s.drives().collect();
            let indexed: Vec<_> = (0..s.samples() + 5).map_while(|i| s.at(i)).collect();
            assert_eq!(counted, indexed, "{s:?}");
        }
        assert_eq!(StandstillSegment::INJECTION.drives().count(), 460);
        assert_eq!(no_pairs.drives().count(), 0);
    }

    #[test]
    fn standstill_steps_each_pair_then_freewheels() {
        let s = StandstillSegment::DEFAULT;
        let drive = |pair, volts| {
            Some(PairDrive {
                pair,
                volts,
                frequency: 0.0,
                on_index: 0,
            })
        };
        assert_eq!(s.samples(), 520);
        assert_eq!(s.at(0), drive(0, 0.0));
        assert!(!s.fitted(99) && s.fitted(100) && s.fitted(519) && !s.fitted(520));
        assert_eq!(s.at(100), drive(0, 0.24));
        assert_eq!(s.at(179).map(|d| d.volts), Some(0.24));
        assert_eq!(s.at(179).map(|d| d.voltage(1e-4)), Some(0.24));
        assert_eq!(s.at(180), drive(0, 0.0));
        assert_eq!(s.at(240), drive(1, 0.24));
        assert_eq!(s.at(241).map(|d| d.on_index), Some(1));
        assert_eq!(s.at(519).map(|d| d.pair), Some(2));
        assert_eq!(s.at(520), None);
        for signs in PAIR_SIGNS {
            assert_eq!(signs.iter().map(|&x| i32::from(x)).sum::<i32>(), 0);
        }
    }

    #[test]
    fn the_injection_plays_whole_periods_of_a_zero_mean_tone_per_pair() {
        let s = StandstillSegment::INJECTION;
        assert!(s.is_injection());
        assert_eq!(s.samples(), 460);
        let dt = 1e-4;
        for pair in 0..3 {
            let start = 100 + pair * 120;
            let volts: [f32; 100] = core::array::from_fn(|j| {
                let d = s.at(start + j).unwrap();
                assert_eq!(d.pair, pair);
                d.voltage(dt)
            });
            // Five whole periods: zero mean, the amplitude reached, symmetric.
            let mean: f32 = volts.iter().sum::<f32>() / 100.0;
            assert!(mean.abs() < 1e-3, "{mean}");
            let peak = volts.iter().fold(0.0f32, |m, v| m.max(v.abs()));
            assert!(peak > 19.7 && peak <= 20.0, "{peak}");
            assert!((volts[0] - volts[19]).abs() < 1e-3);
            // Off: nothing applied.
            assert_eq!(s.at(start + 100).unwrap().voltage(dt), 0.0);
        }
        let t = PreflightTest::INJECTION;
        assert_eq!(t.samples(1e-4), 5460);
        assert_eq!(t.kind(), 5);
        assert_eq!(t.name(), Some("injection"));
        assert_eq!(PreflightTest::from_code(5), Some(t));
        assert_eq!(PreflightTest::from_code(4), None);
        assert_eq!(PreflightTest::from_name(""), None);
    }

    #[test]
    fn the_chirp_follows_the_segments_and_starts_at_its_own_zero() {
        let t = PreflightTest::STANDSTILL;
        assert_eq!(t.samples(1e-4), 5520);
        assert!(matches!(t.drive(519, 1e-4), Drive::Pair(_)));
        for i in 0..5000 {
            let Drive::Position(x) = t.drive(520 + i, 1e-4) else {
                panic!("sample {i}")
            };
            assert_eq!(x.to_bits(), t.chirp.position(i as f32 * 1e-4).to_bits());
        }
        assert_eq!(PreflightTest::PAPER.samples(1e-4), 5000);
    }

    #[test]
    fn motion_turns_the_motor_over_a_revolution_and_returns() {
        let m = MotionSegment::DEFAULT;
        let (mut lo, mut hi) = (0.0f32, 0.0f32);
        let mut previous = 0.0f32;
        for i in 0..m.samples() {
            let x = m.position(i);
            lo = lo.min(x);
            hi = hi.max(x);
            // Smooth: no step larger than the steepest ramp allows.
            assert!((x - previous).abs() < 4.0e-5, "sample {i}");
            previous = x;
        }
        assert!((hi - lo) * 500.0 > core::f32::consts::TAU);
        assert!(m.position(m.samples() - 1).abs() < 1e-6);
        assert_eq!(m.position(m.samples()), 0.0);
    }

    #[test]
    fn a_segment_without_pair_steps_never_underflows() {
        let t = PreflightTest {
            standstill: Some(StandstillSegment {
                on_samples: 0,
                off_samples: 0,
                ..StandstillSegment::DEFAULT
            }),
            ..PreflightTest::STANDSTILL
        };
        for i in 0..200 {
            assert!(matches!(t.drive(i, 1e-4), Drive::Position(_)));
        }
    }

    #[test]
    fn codes_round_trip() {
        for t in [
            PreflightTest::PAPER,
            PreflightTest::STANDSTILL,
            PreflightTest::MOTION,
            PreflightTest::INJECTION,
        ] {
            assert_eq!(PreflightTest::from_code(t.code().unwrap()), Some(t));
        }
        assert_eq!(PreflightTest::from_code(8), None);
        for name in TEST_NAMES.into_iter().filter(|n| !n.is_empty()) {
            assert_eq!(PreflightTest::from_name(name).unwrap().name(), Some(name));
        }
        assert_eq!(PreflightTest::from_name("chirp"), None);
        let odd = PreflightTest::PAPER.with_chirp(ChirpCommand {
            amplitude: 1e-3,
            ..ChirpCommand::PREFLIGHT
        });
        assert_eq!(odd.code(), None);
        assert_eq!(odd.kind(), 0);
        assert_eq!(odd.kind_name(), "paper");
        assert_eq!(PreflightTest::STANDSTILL.kind_name(), "standstill");
    }
}
