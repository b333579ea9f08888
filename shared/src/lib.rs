//! ema-fdi's flight core: everything the actuator controller runs for the preflight fault
//! detection and identification (FDI), and that the ground tools run bit for bit the same.
//!
//! `no_std`, no heap, no panics on flight paths; capacity in types; time passed in.
//!
//! * [`params`] — the actuator's physical parameters, in one documented struct.
//! * [`actuator`] — the actuator record: parameters, test, calibration, settings, as checked bytes.
//! * [`fault`] — the 8-component fault vector and its physical mapping.
//! * [`command`] — the preflight chirp.
//! * [`conditioning`] — ADC frames → equivalent current → low-pass; the measured buffer.
//! * [`conditions`] — the day of one test: winding temperature from the injection, friction
//!   from the measured temperature, the measured bus.
//! * [`monitor`] — the monitor model (single-phase equivalent, fixed step).
//! * [`calibration`] — how the monitor model is fitted to one actuator (plain data).
//! * [`fitness`] — eq. (3) (the problem).
//! * [`ga`] — the memory-bounded steady-state GA (solver, ask/tell, `step(budget)`).
//! * [`metrics`] — e_i and e_tot, eq. (4).
//! * [`fdi`] — the pieces wired together with the onboard sizes and settings.
//! * [`trace`] — the binary preflight trace format (header, fixed-point rows, CRC-32).
//! * [`domain`] — is the actuator inside the monitor model's domain (jam, open phase, other
//!   command, fitness floor)?
//! * [`grease`] — the grease's drag and dry friction read from the chirp's torque balance.
//! * [`health`] — the health log: one record per preflight, a bounded ring, its store.
//! * [`prognosis`] — degradation trend and remaining useful life per fault, from the log.
//! * [`test_design`] — the preflight test: standstill segment, chirp, what is commanded when.
//! * [`uncertainty`] — a standard deviation and a 90 % interval per identified component.
//! * [`random`] — the GA's seeded xoshiro128++ (state readable for checkpoints).
//! * [`steps`] — work in bounded steps: a future that pauses once, and one to poll to the end.
//! * [`window`] — identification from a window of flight (its command, load and drift).
//! * [`pinned`] — a window the load model cannot fit, read with the surface pinned to its
//!   sensor (the backlash and the gain drift).
//! * [`fusion`] — a flight's reading from several windows (their fits' quadratics added).
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

pub mod actuator;
pub mod calibration;
pub mod capacity;
pub mod command;
pub mod conditioning;
pub mod conditions;
pub mod domain;
pub mod drive;
pub mod fault;
pub mod fdi;
pub mod fitness;
pub mod fusion;
pub mod ga;
pub mod grease;
pub mod health;
pub mod math;
pub mod metrics;
pub mod monitor;
pub mod params;
pub mod pinned;
pub mod polish;
pub mod prognosis;
pub mod random;
pub mod steps;
pub mod test_design;
pub mod trace;
pub mod uncertainty;
pub mod window;

pub use calibration::Calibration;
pub use command::ChirpCommand;
pub use conditioning::{AdcFrame, LowPass, MeasuredCurrent, ShaftAngles};
pub use fault::{FaultVector, Verdict, FAULT_COUNT};
pub use fitness::FitnessProblem;
pub use ga::{GaSettings, Problem, Status, SteadyStateGa, StopReason};
pub use monitor::MonitorModel;
pub use params::ActuatorParams;
