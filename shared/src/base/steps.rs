//! Work done in bounded steps under an executor: a future that hands the caller back once
//! ([`pause`], the end of one step), and [`run_to_end`] that polls a stepwise future to its
//! end without an executor. The window identification pauses after each model run
//! ([`crate::flight::window::identify_stepwise`]); the firmware's tasks yield with the same future.
//! O(1) per poll; no timer, no allocation.

use core::future::Future;
use core::pin::Pin;
use core::task::{Context, Poll, Waker};

/// A future that is pending once (waking itself), then ready.
#[derive(Debug)]
pub struct Pause(bool);

impl Future for Pause {
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

/// Gives the caller (the executor) back once: the end of one bounded step.
pub fn pause() -> Pause {
    Pause(false)
}

/// Polls `future` until it is ready, without an executor (a no-op waker): the stepwise work
/// in one call, the same bits.
pub fn run_to_end<F: Future>(future: F) -> F::Output {
    let mut future = core::pin::pin!(future);
    let mut cx = Context::from_waker(Waker::noop());
    loop {
        if let Poll::Ready(out) = future.as_mut().poll(&mut cx) {
            return out;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pause is pending exactly once; `run_to_end` sees through any number of them.
    #[test]
    fn a_pause_is_pending_once() {
        let mut p = core::pin::pin!(pause());
        let mut cx = Context::from_waker(Waker::noop());
        assert_eq!(p.as_mut().poll(&mut cx), Poll::Pending);
        assert_eq!(p.as_mut().poll(&mut cx), Poll::Ready(()));
        let three = async {
            pause().await;
            pause().await;
            pause().await;
            7
        };
        assert_eq!(run_to_end(three), 7);
    }
}
