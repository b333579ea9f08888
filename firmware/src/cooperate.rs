//! Cooperative scheduling for the firmware's tasks: a future that gives the executor back
//! once, so that the other tasks (the heartbeat, the flight software's share) run between
//! two slices of preflight work — `shared::steps::pause`, the one the window
//! identification's steps end with. O(1); no timer needed.

pub use shared::steps::Pause as YieldNow;

/// Gives the executor back once.
pub fn yield_now() -> YieldNow {
    shared::steps::pause()
}
