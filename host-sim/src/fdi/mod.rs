//! The onboard FDI (`shared`) run on the ground.
//!
//! * [`identify`] — the very FDI the firmware runs, driven on the host with progress,
//!   checkpoints and history.
//! * [`calibration`] — fitting the monitor model to a healthy trace.
//! * [`plot`] — SVG pictures of an identification.

pub mod calibration;
pub mod identify;
pub mod plot;
pub mod window;
