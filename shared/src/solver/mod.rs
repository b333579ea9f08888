//! The search for the fault vector, kept apart from the problem it solves: the problem
//! (eq. (3)'s [`fitness`]), the memory-bounded steady-state GA ([`ga`], with its checkpoint),
//! the Gauss–Newton polish after it ([`polish`]), the weak-magnet search after that
//! ([`weak_magnet`]) and each component's uncertainty
//! ([`uncertainty`]). Every solver step does bounded work and says so. May import: the floors
//! below ([`crate::base`] … [`crate::model`]).

pub mod fitness;
pub mod ga;
pub mod polish;
pub mod uncertainty;
pub mod weak_magnet;
