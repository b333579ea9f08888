//! A preflight whose test is played more than once where the current's noise calls for it
//! (how many: [`crate::preflight::actuator::ActuatorRecord::tests_called_for`]), and the one
//! record its tests make ([`RepeatedTests`]).
//!
//! Under I_ref noise a test's reading scatters by what one test's current holds (friction
//! 0.019, eccentricity 0.025 at 50 % noise, docs/prognostics.md); `n` tests, each with the
//! noise drawn anew, average that scatter by `√n`, not the mean the noise puts into the
//! drive's current.
//!
//! Units: fault vector (normalised), fitness [A²·s]. Work: O([`FAULT_COUNT`]) per test added
//! and per reading. Host and controller alike, bit for bit.

use crate::physics::fault::{FaultVector, ECCENTRICITY_PHASE_INDEX, FAULT_COUNT};
use crate::preflight::actuator::ActuatorRecord;
use crate::prognostics::health::HealthRecord;

/// The records of one preflight's tests, added as they are played, and the one record they
/// make: the mean of the trusted tests' vectors and fitnesses, the root mean square of their
/// deviations over the root of their number (independent noise, each test's drawn anew),
/// the eccentricity's phase, day and weak magnet the first trusted test's, and byte 71
/// ([`HealthRecord::fused`]) the trusted tests averaged. Without a trusted test, the first
/// test's record as it is; with one, that test's record as it is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RepeatedTests {
    /// The first test's record, then (from the first trusted test) the first trusted one's.
    first: HealthRecord,
    /// Tests added.
    played: u32,
    /// Trusted tests added.
    trusted: u32,
    /// Sum of the trusted tests' components.
    sum: [f32; FAULT_COUNT],
    /// Sum of the trusted tests' variances (a deviation not determined: NaN).
    variance: [f32; FAULT_COUNT],
    /// Sum of the trusted tests' fitnesses.
    fitness: f32,
}

impl RepeatedTests {
    /// No test yet; every byte zero (a buffer of the controller's `.bss`).
    pub const EMPTY: Self = Self {
        first: HealthRecord::ZEROED,
        played: 0,
        trusted: 0,
        sum: [0.0; FAULT_COUNT],
        variance: [0.0; FAULT_COUNT],
        fitness: 0.0,
    };

    /// Adds one test's record (of the same flight). O([`FAULT_COUNT`]). Out of line.
    #[inline(never)]
    pub fn add(&mut self, record: &HealthRecord) {
        if self.played == 0 {
            self.first = *record;
        }
        self.played = self.played.saturating_add(1);
        if !record.is_trusted() {
            return;
        }
        if self.trusted == 0 {
            self.first = *record;
        }
        self.trusted = self.trusted.saturating_add(1);
        let k = record.faults.as_array();
        for (i, ((sum, variance), v)) in self
            .sum
            .iter_mut()
            .zip(self.variance.iter_mut())
            .zip(k.iter())
            .enumerate()
        {
            *sum += *v;
            let s = record.std.get(i).unwrap_or(f32::NAN);
            *variance += s * s;
        }
        self.fitness += record.fitness;
    }

    /// The tests this preflight's noise calls for, `actuator` its record: the call of its
    /// first trusted test ([`ActuatorRecord::tests_called_for`]), one before any (a first
    /// test outside the monitor model's domain is not repeated: the controllers stop there).
    /// O(1).
    pub fn called_for(&self, actuator: &ActuatorRecord) -> u32 {
        if self.trusted == 0 {
            1
        } else {
            actuator.tests_called_for(self.first.fitness)
        }
    }

    /// Tests added.
    pub fn played(&self) -> u32 {
        self.played
    }

    /// Trusted tests added.
    pub fn trusted(&self) -> u32 {
        self.trusted
    }

    /// The preflight's record ([`RepeatedTests`]); before the first test ([`Self::played`]
    /// 0) a record of zeros, not a reading. O([`FAULT_COUNT`]).
    pub fn reading(&self) -> HealthRecord {
        let first = self.first;
        if self.trusted <= 1 {
            return first;
        }
        let n = self.trusted as f32;
        let mut k = self.sum;
        let mut std = self.variance;
        for (k, std) in k.iter_mut().zip(std.iter_mut()) {
            *k /= n;
            if !std.is_nan() {
                *std = crate::base::math::sqrt(*std / n / n);
            }
        }
        // A constant index within the array, checked when compiling.
        #[allow(clippy::indexing_slicing)]
        {
            k[ECCENTRICITY_PHASE_INDEX] = first.faults.as_array()[ECCENTRICITY_PHASE_INDEX];
        }
        let mut record = HealthRecord::new(
            first.flight,
            FaultVector::saturating(k),
            self.fitness / n,
            crate::model::domain::Domain::Within,
        )
        .with_std(std)
        .with_day(first.day);
        record.magnet = first.magnet;
        record.fused = u8::try_from(self.trusted).unwrap_or(u8::MAX);
        record
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::domain::{Domain, OutsideReason};

    fn record(friction: f32, std: f32, domain: Domain) -> HealthRecord {
        let mut k = *FaultVector::NOMINAL.as_array();
        k[0] = friction;
        k[ECCENTRICITY_PHASE_INDEX] = friction;
        HealthRecord::new(3, FaultVector::saturating(k), 0.05, domain).with_std([std; FAULT_COUNT])
    }

    #[test]
    fn repeated_tests_average_the_trusted_readings() {
        let outside = record(
            0.9,
            0.01,
            Domain::Outside(OutsideReason::NoMotion { travel: 0.0 }),
        );
        let mut r = RepeatedTests::EMPTY;
        assert_eq!((r.played(), r.reading()), (0, HealthRecord::ZEROED));
        r.add(&outside);
        assert_eq!(r.reading(), outside, "no trusted test: the first as it is");
        let a = record(0.20, 0.02, Domain::Within);
        r.add(&a);
        assert_eq!(r.reading(), a, "one trusted test: its record as it is");
        let b = record(0.24, 0.02, Domain::Within);
        r.add(&b);
        r.add(&outside);
        assert_eq!((r.played(), r.trusted()), (4, 2));
        let mean = r.reading();
        assert!((mean.faults.as_array()[0] - 0.22).abs() < 1e-6, "{mean:?}");
        assert_eq!(
            mean.faults.as_array()[ECCENTRICITY_PHASE_INDEX],
            a.faults.as_array()[ECCENTRICITY_PHASE_INDEX],
            "the phase is the first trusted test's"
        );
        let s = mean.std.get(0).expect("a deviation");
        assert!((s - 0.02 / 2f32.sqrt()).abs() < 3e-5, "{s}");
        assert!(mean.is_trusted());
        assert_eq!(mean.fused, 2);
        assert_eq!(mean.flight, 3);
        assert_eq!(mean.window, 0, "still a preflight");
    }
}
