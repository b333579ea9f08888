//! The GA's random number generator: xoshiro128++ (Blackman & Vigna), seeded from a `u64`
//! through SplitMix64 exactly as `rand_xoshiro::Xoshiro128PlusPlus::seed_from_u64` does, so
//! the same seed gives the same stream (checked against that crate in the tests). Its own
//! type because a checkpoint must read and restore the four state words. O(1) per draw.

/// xoshiro128++ state: four words, never all zero.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Xoshiro128PlusPlus {
    s: [u32; 4],
}

impl Xoshiro128PlusPlus {
    /// A fixed state (SplitMix64's fallback), for a generator to be seeded in place.
    pub const IDLE: Self = Self {
        s: [0x9E37_79B9, 1, 2, 3],
    };

    /// Seeds the state with two SplitMix64 outputs (little-endian words).
    pub fn seed_from_u64(seed: u64) -> Self {
        let mut state = seed;
        let mut splitmix = || {
            state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        };
        let (a, b) = (splitmix(), splitmix());
        let s = [a as u32, (a >> 32) as u32, b as u32, (b >> 32) as u32];
        // SplitMix64 never gives two zero words in a row from one seed, but keep the rule.
        Self::from_state(s).unwrap_or(Self::IDLE)
    }

    /// A generator in the given state; `None` for the all-zero state, which never leaves zero.
    pub fn from_state(s: [u32; 4]) -> Option<Self> {
        if s == [0; 4] {
            None
        } else {
            Some(Self { s })
        }
    }

    /// The four state words (for a checkpoint).
    pub fn state(&self) -> [u32; 4] {
        self.s
    }

    pub fn next_u32(&mut self) -> u32 {
        let [s0, s1, s2, s3] = self.s;
        let result = s0.wrapping_add(s3).rotate_left(7).wrapping_add(s0);
        let t = s1 << 9;
        let s2 = s2 ^ s0;
        let s3 = s3 ^ s1;
        let s1 = s1 ^ s2;
        let s0 = s0 ^ s3;
        let s2 = s2 ^ t;
        let s3 = s3.rotate_left(11);
        self.s = [s0, s1, s2, s3];
        result
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_core::{RngCore, SeedableRng};

    #[test]
    fn same_stream_as_rand_xoshiro_for_the_same_seed() {
        for seed in [0u64, 1, 2, 42, u64::MAX, 0x0123_4567_89AB_CDEF] {
            let mut ours = Xoshiro128PlusPlus::seed_from_u64(seed);
            let mut theirs = rand_xoshiro::Xoshiro128PlusPlus::seed_from_u64(seed);
            for _ in 0..10_000 {
                assert_eq!(ours.next_u32(), theirs.next_u32(), "seed {seed}");
            }
        }
    }

    #[test]
    fn matches_the_reference_vector_and_restores_from_its_state() {
        // The published xoshiro128++ test vector for state [1, 2, 3, 4].
        let mut rng = Xoshiro128PlusPlus::from_state([1, 2, 3, 4]).unwrap();
        let expected = [641u32, 1_573_767, 3_222_811_527, 3_517_856_514, 836_907_274];
        for e in expected {
            assert_eq!(rng.next_u32(), e);
        }
        let mut copy = Xoshiro128PlusPlus::from_state(rng.state()).unwrap();
        assert_eq!(copy.next_u32(), rng.next_u32());
        assert_eq!(Xoshiro128PlusPlus::from_state([0; 4]), None);
    }
}
