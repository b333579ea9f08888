//! `host-sim`: the ground tools of ema-fdi, as a library (the CLI in `main.rs` and the
//! workspace tests use it).
//!
//! * [`reference`] — the high-fidelity reference model (the "real actuator").
//! * [`trace_file`] — CSV and binary trace files.
//! * [`calibration`] — fitting the monitor model to a healthy trace.
//! * [`campaign`] — accuracy campaigns over the paper's fault cases.
//! * [`identify`] — the onboard FDI driven on the host, with progress and history.
//! * [`plot`] — SVG pictures of an identification.
//! * [`faults`] — parsing fault vectors from the command line.

pub mod calibration;
pub mod campaign;
pub mod faults;
pub mod identify;
pub mod optimisers;
pub mod plot;
pub mod reference;
pub mod separability;
pub mod trace_file;
