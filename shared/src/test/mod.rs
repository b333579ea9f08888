//! The preflight test and what it measures: the chirp ([`command`]), what the controller
//! commands when ([`test_design`]), the conditioning of phase currents into one equivalent
//! current ([`conditioning`]) and the recorded test's binary format ([`trace`]). Step: one
//! control period (100 µs). May import: [`crate::base`], [`crate::physics`].

pub mod command;
pub mod conditioning;
pub mod test_design;
pub mod trace;
