//! What the actuator is and what can go wrong with it: its physical parameters
//! ([`params`]), the power bridge it is driven through ([`drive`]), its grease's drag
//! ([`grease`]), its rotor's magnets ([`magnets`]) and the fault vector with its physical mapping ([`fault`]). SI units
//! throughout. May import: [`crate::base`].

pub mod drive;
pub mod fault;
pub mod grease;
pub mod magnets;
pub mod params;
