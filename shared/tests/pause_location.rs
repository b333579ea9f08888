//! Where a pause was made (`shared::steps::last_pause`), in a process of its own: the record
//! is one for the whole program, and other tests' pauses would overwrite it between a poll
//! and its check.

use std::future::Future;
use std::task::{Context, Poll, Waker};

use shared::steps::{last_pause, pause};

/// A pause that hands its caller back names the line it was made on; a later one replaces
/// it; a pause polled to its end records nothing more. Fails if the location is the
/// future's poll (no `track_caller`) or is not recorded.
#[test]
fn a_pause_names_the_line_it_was_made_on() {
    assert!(last_pause().is_none());
    let mut cx = Context::from_waker(Waker::noop());
    let (mut first, line) = (Box::pin(pause()), line!());
    assert_eq!(first.as_mut().poll(&mut cx), Poll::Pending);
    assert_eq!(
        last_pause().map(|l| (l.file(), l.line())),
        Some((file!(), line))
    );
    let (mut second, later) = (Box::pin(pause()), line!());
    assert_eq!(first.as_mut().poll(&mut cx), Poll::Ready(()));
    assert_eq!(last_pause().map(|l| l.line()), Some(line));
    assert_eq!(second.as_mut().poll(&mut cx), Poll::Pending);
    assert_eq!(last_pause().map(|l| l.line()), Some(later));
}
