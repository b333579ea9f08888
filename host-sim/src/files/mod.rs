//! File formats the ground tools read and write.
//!
//! * [`actuator`] — the actuator description file (TOML) and the record it becomes.
//! * [`trace`] — CSV and binary trace files.
//! * [`rig`] — recordings from a real rig (any column names, units and rate) → traces.
//! * [`health`] — the health log in a file, and history CSV files.
//! * [`schedule`] — the preflight test's schedule as a CSV, control period by control period.
//! * [`flash_pair`] — the board's records as flash images (an A/B pair of sectors).

pub mod actuator;
pub mod flash_pair;
pub mod health;
pub mod rig;
pub mod schedule;
pub mod trace;
