//! The ground floor: what every other floor stands on and that imports nothing of the crate.
//! Bit-identical arithmetic on x86 and the Cortex-M4F ([`math`]), the GA's seeded generator
//! ([`random`]), work in bounded steps ([`steps`]) and the buffers' capacities
//! ([`capacity`]). May import: nothing of the crate.

pub mod capacity;
pub mod math;
pub mod random;
pub mod steps;
