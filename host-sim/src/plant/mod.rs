//! The plant: what plays the real actuator on the ground.
//!
//! * [`reference`] — the high-fidelity reference model (the "real actuator").
//! * [`bridge`] — its power bridge (PWM, dead time, losses, ADC) and operating day
//!   (temperatures, bus voltage).
//! * [`aero`] — the control surface's hinge moment and the wind on a parked surface.
//! * [`noise`] — the seeded random draws they share.
//! * [`pair_motor`] — a plain brushless motor on a rigid gear, for checking a drive's wiring.

pub mod aero;
pub mod bridge;
pub mod noise;
pub mod pair_motor;
pub mod reference;
