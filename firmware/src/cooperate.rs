//! Cooperative scheduling for the firmware's tasks: a future that gives the executor back
//! once, so that the other tasks (the heartbeat, the flight software's share) run between
//! two slices of preflight work. O(1); no timer needed.

use core::future::Future;
use core::pin::Pin;
use core::task::{Context, Poll};

/// Pending once (waking itself), then ready.
pub struct YieldNow(bool);

impl Future for YieldNow {
    type Output = ();
    fn poll(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<()> {
        if self.0 {
            Poll::Ready(())
        } else {
            self.0 = true;
            cx.waker().wake_by_ref();
            Poll::Pending
        }
    }
}

/// Gives the executor back once.
pub fn yield_now() -> YieldNow {
    YieldNow(false)
}
