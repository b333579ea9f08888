//! The preflight self-test of the actuator controller, as a `no_std` library that builds and
//! tests on the host: where the ADC frames come from ([`source`]) and the self-test itself
//! ([`preflight`]), a state machine that does a bounded amount of work per poll. The binary
//! (`main.rs`) runs it under embassy on the Cortex-M4F; only its hardware glue is
//! `cfg(target_os = "none")`.
#![no_std]
// No panic on any input (issue 7): these lints make unwraps, panics and unchecked indexing
// compile errors in this crate; unit tests may use them.
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::indexing_slicing
    )
)]

pub mod acquisition;
pub mod bridge;
pub mod cooperate;
pub mod flight;
pub mod health;
pub mod position_loop;
pub mod preflight;
pub mod sequencer;
pub mod source;
pub mod storage;

pub use preflight::{
    CheckpointError, Preflight, PreflightError, PreflightSettings, Progress, Report, Reruns, Stage,
};
pub use source::{Acquired, CurrentSource, TraceBytes, TraceSource, TraceSourceError};
