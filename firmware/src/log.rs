//! The emulation image's defmt logger: raw frames to the host's stdout over semihosting
//! (QEMU), decoded by `defmt-print` in `firmware/qemu-run`. One SYS_WRITE per chunk the
//! encoder hands over; interrupts are masked from `acquire` to `release`, as a defmt logger
//! must.
//!
//! It replaces `defmt-semihosting`, whose `write_all` keeps a slice-index panic and with it
//! `core::fmt`'s number and string formatting in the image (about 2 kB of flash with the
//! other such panics, measured): this one slices with `get` only.

use core::cell::UnsafeCell;
use core::sync::atomic::{AtomicBool, Ordering};

use semihosting::io::Stdout;

use crate::emulation::write_all;

#[defmt::global_logger]
struct Logger;

/// The encoder and the host's stdout, touched only between `acquire` and `release`.
struct Frames {
    encoder: defmt::Encoder,
    out: Option<Stdout>,
    /// Whether interrupts were enabled at `acquire` (restored at `release`).
    interrupts_were_on: bool,
}

struct Shared(UnsafeCell<Frames>);

// SAFETY: the cell is used only while `TAKEN` is held with interrupts masked (one core).
unsafe impl Sync for Shared {}

static TAKEN: AtomicBool = AtomicBool::new(false);
static FRAMES: Shared = Shared(UnsafeCell::new(Frames {
    encoder: defmt::Encoder::new(),
    out: None,
    interrupts_were_on: false,
}));

fn send(out: &mut Option<Stdout>, bytes: &[u8]) {
    if let Some(out) = out {
        // A lost log line cannot be reported anywhere else.
        let _ = write_all(out, bytes);
    }
}

// SAFETY: `acquire` masks interrupts and takes the one lock before any access to `FRAMES`;
// `release` gives both back; `write` and `flush` run in between (defmt's contract).
unsafe impl defmt::Logger for Logger {
    fn acquire() {
        let interrupts_were_on = cortex_m::register::primask::read().is_active();
        cortex_m::interrupt::disable();
        if TAKEN.swap(true, Ordering::Acquire) {
            // A log from inside a log: no interrupt handler logs in this image.
            #[allow(clippy::panic)]
            {
                panic!("defmt logger taken reentrantly")
            }
        }
        // SAFETY: the lock is ours and interrupts are masked.
        let frames = unsafe { &mut *FRAMES.0.get() };
        frames.interrupts_were_on = interrupts_were_on;
        if frames.out.is_none() {
            frames.out = semihosting::io::stdout().ok();
        }
        let Frames { encoder, out, .. } = frames;
        encoder.start_frame(|b| send(out, b));
    }

    unsafe fn flush() {
        // Semihosting blocks until the host has the bytes: nothing is buffered here.
    }

    unsafe fn release() {
        // SAFETY: called after `acquire` (defmt's contract): the lock is ours.
        let frames = unsafe { &mut *FRAMES.0.get() };
        let Frames { encoder, out, .. } = frames;
        encoder.end_frame(|b| send(out, b));
        let restore = frames.interrupts_were_on;
        TAKEN.store(false, Ordering::Release);
        if restore {
            // SAFETY: interrupts were enabled before `acquire` masked them.
            unsafe { cortex_m::interrupt::enable() };
        }
    }

    unsafe fn write(bytes: &[u8]) {
        // SAFETY: called between `acquire` and `release` (defmt's contract).
        let frames = unsafe { &mut *FRAMES.0.get() };
        let Frames { encoder, out, .. } = frames;
        encoder.write(bytes, |b| send(out, b));
    }
}
