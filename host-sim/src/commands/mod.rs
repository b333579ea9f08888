//! One module per command (or family of commands); `main.rs` keeps the command line and the
//! dispatch.

pub(crate) mod actuator;
pub(crate) mod bench;
pub(crate) mod calibrate;
pub(crate) mod campaign;
pub(crate) mod domain;
pub(crate) mod fleet;
pub(crate) mod identify;
pub(crate) mod import;
pub(crate) mod physics;
pub(crate) mod plot;
pub(crate) mod prognostics;
pub(crate) mod simulate;
pub(crate) mod studies;
