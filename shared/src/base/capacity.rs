//! What the controller's FDI buffers hold: capacities fixed at build time, the types' const
//! generics (heapless style). The actuator record is checked against them and the FDI is
//! built with them; neither module owns the other's sizes.

/// Capacity of the measured buffer: the longest test the controller runs, the standstill
/// segment (52 ms) and the chirp (0.5 s) at 10 kHz.
pub const TEST_SAMPLES: usize = 5520;

/// Individuals in the onboard GA population.
pub const POPULATION: usize = 32;
