//! `host-sim`: the ground tools of ema-fdi, as a library (the CLI in `main.rs` and the
//! workspace tests use it).
//!
//! * [`actuator_file`] — the actuator description file (TOML) and the record it becomes.
//! * [`reference`] — the high-fidelity reference model (the "real actuator").
//! * [`trace_file`] — CSV and binary trace files.
//! * [`rig`] — recordings from a real rig (any column names, units and rate) → traces.
//! * [`calibration`] — fitting the monitor model to a healthy trace.
//! * [`campaign`] — accuracy campaigns over the paper's fault cases.
//! * [`domain`] — the survey behind the "outside the monitor model's domain" limits.
//! * [`identifiability`] — which test design can tell every fault apart (sensitivity study).
//! * [`identify`] — the onboard FDI driven on the host, with progress and history.
//! * [`plot`] — SVG pictures of an identification.
//! * [`health_file`] — the health log in a file, and history CSV files.
//! * [`prognostics`] — simulated degradations, trend and RUL reports and pictures.
//! * [`fleet`] — the fleet store (SQLite) of every controller's health log, and its report.
//! * [`faults`] — parsing fault vectors from the command line.

pub mod actuator_file;
pub mod bridge;
pub mod calibration;
pub mod campaign;
pub mod domain;
pub mod faults;
pub mod fleet;
pub mod health_file;
pub mod identifiability;
pub mod identify;
pub mod optimisers;
pub mod plot;
pub mod prognostics;
pub mod reference;
pub mod rig;
pub mod separability;
pub mod stopping;
pub mod trace_file;

use indicatif::{ProgressBar, ProgressStyle};

/// A progress bar on stderr with `template` (indicatif syntax), or a hidden one when
/// `visible` is false.
pub fn progress_bar(len: u64, template: &str, visible: bool) -> ProgressBar {
    if !visible {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(len);
    bar.set_style(
        ProgressStyle::with_template(template).unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar
}

/// Median of `values` (`+∞` sorts last); `None` when there are none.
pub fn median(values: &[f64]) -> Option<f64> {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => None,
        n if n % 2 == 1 => v.get(n / 2).copied(),
        n => Some(0.5 * (v[n / 2 - 1] + v[n / 2])),
    }
}
