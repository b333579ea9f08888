//! The monitor model and what it needs to stand for one actuator on one day: the model
//! itself ([`monitor`]), its calibration to the actuator ([`calibration`]), the day's
//! winding temperature, friction and bus ([`conditions`]) and the checks of whether the
//! measured actuator is inside the model's domain at all ([`domain`]). May import: the floors
//! below ([`crate::base`], [`crate::physics`], [`crate::test`]).

pub mod calibration;
pub mod conditions;
pub mod domain;
pub mod monitor;
