//! `host-sim`: the ground tools of ema-fdi, as a library (the CLI in `main.rs` and the
//! workspace tests use it). One folder per concern; no two modules import each other.
//!
//! * [`plant`] — the actuator the FDI is tested against: the high-fidelity reference model
//!   and its power bridge and operating day.
//! * [`files`] — what is read and written: the actuator description file and its record,
//!   trace files, rig recordings, the health log and history CSV files.
//! * [`fdi`] — the onboard FDI run on the ground: identification with progress and
//!   checkpoints, the calibration fit, the identification picture.
//! * [`studies`] — campaigns and studies: accuracy campaigns, the domain survey,
//!   identifiability, separability, the optimiser comparison, the stop rule, prognostics.
//! * [`fleet`] — the fleet store (SQLite) of every controller's health log, and its report.

pub mod fdi;
pub mod files;
pub mod fleet;
pub mod plant;
pub mod studies;

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
