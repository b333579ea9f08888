//! The top floor: what the readings become over an actuator's life. The health log, one
//! record per preflight or flight reading in a bounded ring ([`health`]), and each fault's
//! trend and remaining useful life from it ([`prognosis`]); a preflight's repeated tests made
//! one record ([`repeat`]). May import: every floor below.

pub mod health;
pub mod prognosis;
pub mod repeat;
