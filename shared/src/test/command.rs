//! The preflight test command (SPEC §5): a chirp of the user-shaft position.
//!
//! `θ_cmd(t) = A · sin(2π · f_end · t² / (2T))` for `t ∈ [0, T]`: frequency rising linearly
//! from 0 to `f_end` in `T` seconds. Units: rad (user side), s, Hz. O(1) per call; time is
//! passed in, never read.
//!
//! The monitor model reads the command through [`CommandSource`]: either a [`ChirpSampler`]
//! (the chirp at sample index `i`, from the phase `k·i²` in turns: two multiplications and a
//! parabolic sine per step, no division, no 2π), or a [`CommandTable`] of the same samples
//! computed once (the same bits, `N` × 4 bytes, one load per step).

use crate::base::math::{frac, sin, sin_turns, TAU};

/// A linear chirp from 0 Hz to `end_frequency` over `duration`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ChirpCommand {
    /// Amplitude at the user shaft \[rad\].
    pub amplitude: f32,
    /// Frequency reached at `duration` \[Hz\].
    pub end_frequency: f32,
    /// Length of the test \[s\].
    pub duration: f32,
}

impl ChirpCommand {
    /// The test of the paper (§III.2): 5e-3 rad, 0 → 15 Hz in 0.5 s.
    pub const PREFLIGHT: Self = Self {
        amplitude: 5.0e-3,
        end_frequency: 15.0,
        duration: 0.5,
    };

    /// Commanded user-shaft angle \[rad\] at time `t` \[s\]. Zero before the start; after
    /// `duration` the chirp simply continues (callers stop at `duration`).
    pub fn position(&self, t: f32) -> f32 {
        if t <= 0.0 || self.duration <= 0.0 {
            return 0.0;
        }
        // Phase in cycles, reduced to [0, 1) before the sine so that the approximation
        // works on a small argument at every t.
        let cycles = self.end_frequency * t * t / (2.0 * self.duration);
        self.amplitude * sin(TAU * frac(cycles))
    }

    /// The chirp sampled every `period` seconds ([`ChirpSampler`]).
    pub fn sampler(&self, period: f32) -> ChirpSampler {
        let rate = if self.duration > 0.0 {
            self.end_frequency * period * period / (2.0 * self.duration)
        } else {
            0.0
        };
        ChirpSampler {
            amplitude: self.amplitude,
            cycles_per_index_squared: rate,
        }
    }

    /// Instantaneous frequency \[Hz\] at time `t`.
    pub fn frequency(&self, t: f32) -> f32 {
        if self.duration <= 0.0 {
            return 0.0;
        }
        self.end_frequency * t.clamp(0.0, self.duration) / self.duration
    }
}

impl Default for ChirpCommand {
    fn default() -> Self {
        Self::PREFLIGHT
    }
}

/// Where the monitor model reads the commanded user-shaft angle \[rad\] of chirp sample
/// `index` (time `index · dt`). O(1) per call.
pub trait CommandSource {
    fn position_at(&self, index: usize) -> f32;
}

/// The chirp at sample indices of a fixed period, as the monitor model plays it: sample `i`
/// is `A · sin(2π · k · i²)` with `k = f_end · period² / (2T)` turns, the phase of
/// [`ChirpCommand::position`] at `t = i · period` computed from the index, and the same
/// parabolic sine evaluated on turns ([`crate::base::math::sin_turns`]), so no time,
/// division or reduction by 2π is needed per sample. It models the controller's command
/// (`position(i · period)`, unchanged) within 10⁻⁷ rad, 2·10⁻⁵ of the amplitude
/// (`sampler_follows_the_chirp`).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ChirpSampler {
    amplitude: f32,
    cycles_per_index_squared: f32,
}

impl ChirpSampler {
    /// Commanded user-shaft angle \[rad\] at sample `index` (0 at index 0). O(1).
    #[inline(always)]
    pub fn at(&self, index: usize) -> f32 {
        let n = index as f32;
        self.amplitude * sin_turns(self.cycles_per_index_squared * (n * n))
    }
}

impl CommandSource for ChirpSampler {
    #[inline(always)]
    fn position_at(&self, index: usize) -> f32 {
        self.at(index)
    }
}

/// A command sampled once at every control period: sample `i` holds exactly
/// `command.sampler(period).at(i)`, the value the monitor model's [`ChirpSampler`] gives at
/// that step, so a model driven by the table produces the same bits as one driven by the
/// sampler. Capacity `N` samples; beyond the table the sampler is evaluated. `4·N` bytes (20 kB for the 0.5 s
/// test): the host keeps one per identification; the firmware, short of RAM, evaluates the
/// chirp.
#[cfg(feature = "command-table")]
#[derive(Clone, Debug, PartialEq)]
pub struct CommandTable<const N: usize> {
    command: ChirpCommand,
    period: f32,
    sampler: ChirpSampler,
    samples: [f32; N],
}

#[cfg(feature = "command-table")]
impl<const N: usize> CommandTable<N> {
    /// Samples `command` at `i · period` for `i` in `0..N`. O(N).
    pub fn new(command: ChirpCommand, period: f32) -> Self {
        let sampler = command.sampler(period);
        Self {
            command,
            period,
            sampler,
            samples: core::array::from_fn(|i| sampler.at(i)),
        }
    }

    /// The command the table samples.
    pub fn command(&self) -> &ChirpCommand {
        &self.command
    }

    /// The sampling period \[s\].
    pub fn period(&self) -> f32 {
        self.period
    }

    pub fn samples(&self) -> &[f32; N] {
        &self.samples
    }
}

#[cfg(feature = "command-table")]
impl<const N: usize> CommandSource for CommandTable<N> {
    #[inline(always)]
    fn position_at(&self, index: usize) -> f32 {
        match self.samples.get(index) {
            Some(&x) => x,
            None => self.sampler.at(index),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn starts_at_rest_and_stays_within_amplitude() {
        let c = ChirpCommand::PREFLIGHT;
        assert_eq!(c.position(0.0), 0.0);
        let mut peak = 0.0f32;
        for i in 0..5000 {
            let p = c.position(i as f32 * 1e-4);
            assert!(p.abs() <= c.amplitude * 1.001);
            peak = peak.max(p.abs());
        }
        assert!(peak > 0.99 * c.amplitude);
    }

    #[test]
    fn matches_closed_form() {
        let c = ChirpCommand::PREFLIGHT;
        for i in 0..500 {
            let t = i as f64 * 1e-3;
            let exact = 5e-3 * (std::f64::consts::PI * 15.0 * t * t / 0.5).sin();
            let ours = c.position(t as f32) as f64;
            assert!((exact - ours).abs() < 2e-5, "t={t}: {exact} vs {ours}");
        }
    }

    #[cfg(feature = "command-table")]
    #[test]
    fn table_holds_the_samplers_bits() {
        let c = ChirpCommand::PREFLIGHT;
        let table = CommandTable::<5000>::new(c, 1e-4);
        let sampler = c.sampler(1e-4);
        for i in 0..5100 {
            assert_eq!(
                table.position_at(i).to_bits(),
                sampler.at(i).to_bits(),
                "sample {i}"
            );
        }
    }

    #[test]
    fn sampler_follows_the_chirp() {
        let c = ChirpCommand::PREFLIGHT;
        let sampler = c.sampler(1e-4);
        for i in 0..=5000 {
            let (a, b) = (sampler.at(i), c.position(i as f32 * 1e-4));
            // The sine's two evaluations differ by ≤ 1e-5 of the amplitude (micromath's
            // reduction through 2π against ours on turns) and the phase's rounding by a few
            // ulp of ≤ 7.5 turns: together well under 2e-5 of the 5e-3 rad amplitude.
            assert!((a - b).abs() < 1e-7, "sample {i}: {a} vs {b}");
        }
        assert_eq!(sampler.at(0), 0.0);
    }

    #[test]
    fn frequency_ramps_linearly() {
        let c = ChirpCommand::PREFLIGHT;
        assert_eq!(c.frequency(0.0), 0.0);
        assert_eq!(c.frequency(0.25), 7.5);
        assert_eq!(c.frequency(0.5), 15.0);
    }
}
