//! The plant: what plays the real actuator on the ground.
//!
//! * [`reference`] — the high-fidelity reference model (the "real actuator").
//! * [`bridge`] — its power bridge (PWM, dead time, losses, ADC) and operating day
//!   (temperatures, bus voltage).

pub mod bridge;
pub mod reference;
