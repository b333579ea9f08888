//! Seeded random draws of the plant: standard normal values from a xoshiro256++ (Box–Muller),
//! one stream per seed. O(1) per draw; no state beyond the generator and one spare value.

use rand_core::{RngCore, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use std::f64::consts::TAU;

/// Standard normal draws (Box–Muller) from a seeded xoshiro256++.
pub(crate) struct Gaussian {
    rng: Xoshiro256PlusPlus,
    spare: Option<f64>,
}

impl Gaussian {
    pub(crate) fn new(seed: u64) -> Self {
        Self {
            rng: Xoshiro256PlusPlus::seed_from_u64(seed),
            spare: None,
        }
    }

    pub(crate) fn uniform(&mut self) -> f64 {
        // 53 random bits in (0, 1].
        ((self.rng.next_u64() >> 11) as f64 + 1.0) * (1.0 / (1u64 << 53) as f64)
    }

    pub(crate) fn next(&mut self) -> f64 {
        if let Some(x) = self.spare.take() {
            return x;
        }
        let r = (-2.0 * self.uniform().ln()).sqrt();
        let a = TAU * self.uniform();
        self.spare = Some(r * a.sin());
        r * a.cos()
    }
}
