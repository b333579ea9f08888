//! The preflight identification assembled: the actuator record that carries one actuator's
//! parameters, test, calibration and settings as checked bytes ([`actuator`]), the onboard
//! wiring with its sizes ([`fdi`]) and the paper's error metric, eq. (4) ([`metrics`]). May
//! import: the floors below ([`crate::base`] … [`crate::solver`]).

pub mod actuator;
pub mod fdi;
pub mod metrics;
