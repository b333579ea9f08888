//! Work done in bounded steps under an executor: a future that hands the caller back once
//! ([`pause`], the end of one step), and [`run_to_end`] that polls a stepwise future to its
//! end without an executor. The window identification pauses after each model run
//! ([`crate::flight::window::identify_stepwise`]); the firmware's tasks yield with the same future.
//! O(1) per poll; no timer, no allocation. With feature `pause-sites` each pause records
//! where it was made ([`last_pause`]), so a bench can name the two ends of its longest poll
//! (≈ 1.6 kB of flash: the product images build without it).

use core::future::Future;
use core::panic::Location;
use core::pin::Pin;
#[cfg(feature = "pause-sites")]
use core::sync::atomic::{AtomicPtr, Ordering};
use core::task::{Context, Poll, Waker};

/// A future that is pending once (waking itself), then ready; with feature `pause-sites`, it
/// knows where in the source it was made.
#[derive(Debug)]
pub struct Pause {
    done: bool,
    #[cfg(feature = "pause-sites")]
    at: &'static Location<'static>,
}

/// Where the last pause that handed the caller back was made (null before the first).
#[cfg(feature = "pause-sites")]
static LAST_PAUSE: AtomicPtr<Location<'static>> = AtomicPtr::new(core::ptr::null_mut());

impl Future for Pause {
    type Output = ();
    fn poll(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<()> {
        if self.done {
            Poll::Ready(())
        } else {
            self.done = true;
            #[cfg(feature = "pause-sites")]
            LAST_PAUSE.store(core::ptr::from_ref(self.at).cast_mut(), Ordering::Relaxed);
            cx.waker().wake_by_ref();
            Poll::Pending
        }
    }
}

/// Gives the caller (the executor) back once: the end of one bounded step.
#[cfg_attr(feature = "pause-sites", track_caller)]
pub fn pause() -> Pause {
    Pause {
        done: false,
        #[cfg(feature = "pause-sites")]
        at: Location::caller(),
    }
}

/// Where the last pause that handed its caller back stands in the source (`None` before
/// the first, and always without feature `pause-sites`): with the one before it, the two
/// ends of a poll, for a bench that looks for its longest (`firmware/window-bench`). O(1).
pub fn last_pause() -> Option<&'static Location<'static>> {
    #[cfg(feature = "pause-sites")]
    {
        // SAFETY: the pointer is null or was made from a `&'static Location`.
        unsafe { LAST_PAUSE.load(Ordering::Relaxed).as_ref() }
    }
    #[cfg(not(feature = "pause-sites"))]
    None
}

/// `Σ a[i]·b[i]` for `i` in `0..N`, summed in order from −0 (as `Iterator::sum` of `f64`:
/// the same bits), pausing after every [`TERMS_PER_POLL`] terms: a sum of soft-f64 products
/// on the Cortex-M4F in polls of a few thousand instructions. Walks both by iterator: no
/// bounds check (no panic path on the flight's code).
pub async fn dot_stepwise<const N: usize>(a: &[f64; N], b: &[f64; N]) -> f64 {
    let mut sum = -0.0f64;
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        sum += x * y;
        if (i + 1) % TERMS_PER_POLL == 0 && i + 1 < N {
            pause().await;
        }
    }
    sum
}

/// Terms of a [`dot_stepwise`] between two pauses.
pub const TERMS_PER_POLL: usize = 6;

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
    /// (Where it was made: `tests/pause_location.rs`, a process of its own.)
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
