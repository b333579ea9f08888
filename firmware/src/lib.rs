//! The preflight self-test of the actuator controller, as a `no_std` library that builds and
//! tests on the host: where the ADC frames come from ([`source`]) and the self-test itself
//! ([`preflight`]), a state machine that does a bounded amount of work per poll. The binary
//! (`main.rs`) runs it under embassy on the Cortex-M4F; only its hardware glue is
//! `cfg(target_os = "none")`.
#![no_std]

pub mod preflight;
pub mod source;

pub use preflight::{Preflight, PreflightError, PreflightSettings, Progress, Report, Stage};
pub use source::{Acquired, CurrentSource, TraceBytes, TraceSource, TraceSourceError};
