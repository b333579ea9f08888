//! ema-fdi's flight core: everything the actuator controller runs for the preflight fault
//! detection and identification (FDI), and that the ground tools run bit for bit the same.
//!
//! `no_std`, no heap, no panics on flight paths; capacity in types; time passed in.
//!
//! The crate is built in floors, one folder each; a floor imports only the floors below it
//! (`tests/layout.rs` checks it), from the ground up:
//!
//! 1. [`base`] — bit-identical maths, the seeded generator, bounded steps, capacities.
//! 2. [`physics`] — the actuator's parameters, bridge and grease; the fault vector.
//! 3. [`test`](mod@test) — the preflight test: chirp, test design, conditioning, the trace format.
//! 4. [`model`] — the monitor model, its calibration, the day's conditions, its domain.
//! 5. [`solver`] — eq. (3)'s fitness, the steady-state GA, the polish, the uncertainty.
//! 6. [`preflight`] — the actuator record, the onboard wiring, eq. (4)'s metrics.
//! 7. [`flight`] — a window of flight identified, pinned windows, a flight's fused reading.
//! 8. [`prognostics`] — the health log, trends and remaining useful life.
//!
//! Every module is also re-exported at the crate root under its own name
//! (`shared::monitor::MonitorModel` is `shared::model::monitor::MonitorModel`), so that
//! code written against the flat layout keeps building.
#![cfg_attr(not(test), no_std)]
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

pub mod base;
pub mod flight;
pub mod model;
pub mod physics;
pub mod preflight;
pub mod prognostics;
pub mod solver;
pub mod test;

pub use base::{capacity, math, random, steps};
pub use flight::{fusion, pinned, window};
pub use model::{calibration, conditions, domain, monitor};
pub use physics::{drive, fault, grease, magnets, params};
pub use preflight::{actuator, fdi, metrics};
pub use prognostics::{health, prognosis, repeat};
pub use solver::{fitness, ga, polish, uncertainty, weak_magnet};
pub use test::{command, conditioning, test_design, trace};

pub use calibration::Calibration;
pub use command::ChirpCommand;
pub use conditioning::{AdcFrame, LowPass, MeasuredCurrent, ShaftAngles};
pub use fault::{FaultVector, Verdict, FAULT_COUNT};
pub use fitness::FitnessProblem;
pub use ga::{GaSettings, Problem, Status, SteadyStateGa, StopReason};
pub use monitor::MonitorModel;
pub use params::ActuatorParams;
