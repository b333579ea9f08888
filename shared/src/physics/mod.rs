//! What the actuator is and what can go wrong with it: its physical parameters
//! ([`params`]), the power bridge it is driven through ([`drive`]), its grease's drag
//! ([`grease`]) and the fault vector with its physical mapping ([`fault`]). SI units
//! throughout. May import: [`crate::base`].

pub mod drive;
pub mod fault;
pub mod grease;
pub mod params;
