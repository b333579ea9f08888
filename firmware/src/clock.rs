//! The SysTick cycle clock of the emulation images (the preflight's and the window bench's):
//! the 24-bit counter at the core clock, its wraps counted in the SysTick exception (O(1)).
//! Under `qemu-run` (QEMU `-icount shift=0`: one instruction = 1 ns of virtual time) a cycle
//! count converts to instructions as `cycles · 10⁹ / 168·10⁶`. [`PollTimer`] times a task's
//! polls with it.

use core::future::Future;
use core::pin::Pin;
use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::SYST;
use cortex_m_rt::exception;

/// SysTick wraps of the 24-bit counter.
static WRAPS: AtomicU32 = AtomicU32::new(0);

const SYST_RELOAD: u32 = 0x00FF_FFFF;

/// Core clock of the reference MCU [Hz].
pub const CORE_HZ: u64 = 168_000_000;

pub fn start_cycle_clock(mut syst: SYST) {
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(SYST_RELOAD);
    syst.clear_current();
    syst.enable_interrupt();
    syst.enable_counter();
}

/// Core cycles since [`start_cycle_clock`].
pub fn cycles() -> u64 {
    loop {
        let wraps = WRAPS.load(Ordering::Acquire);
        let current = SYST::get_current();
        if WRAPS.load(Ordering::Acquire) == wraps {
            return (u64::from(wraps) << 24) | u64::from(SYST_RELOAD.saturating_sub(current));
        }
    }
}

#[exception]
fn SysTick() {
    WRAPS.fetch_add(1, Ordering::AcqRel);
}

/// Instructions under QEMU's `-icount shift=0` of `cycles` core cycles.
pub fn instructions_under_icount(cycles: u64) -> u64 {
    // u128: no overflow for any u64 cycle count.
    u64::try_from(u128::from(cycles) * 1_000_000_000 / u128::from(CORE_HZ)).unwrap_or(u64::MAX)
}

/// The polls of a piece of the controller's work, timed one by one: how many, and the
/// longest [core cycles]. O(1) per poll.
#[derive(Clone, Copy, Default)]
pub struct PollTimer {
    pub polls: u32,
    pub longest: u64,
}

impl PollTimer {
    /// Runs `future` (pinned where the caller keeps it: not moved into this one's state) to
    /// its end, timing each of its polls.
    pub async fn run<F: Future>(&mut self, mut future: Pin<&mut F>) -> F::Output {
        core::future::poll_fn(|cx| {
            let start = cycles();
            let poll = future.as_mut().poll(cx);
            self.stop(start);
            poll
        })
        .await
    }

    /// One poll that began at `start` [cycles] is over. Not inlined: one copy for every
    /// future timed.
    #[inline(never)]
    fn stop(&mut self, start: u64) {
        self.longest = self.longest.max(cycles().saturating_sub(start));
        self.polls = self.polls.saturating_add(1);
    }

    /// Takes `other`'s polls in: their count, and its longest if it is longer.
    pub fn absorb(&mut self, other: &PollTimer) {
        self.polls = self.polls.saturating_add(other.polls);
        self.longest = self.longest.max(other.longest);
    }

    /// The longest poll's instructions under QEMU's `-icount shift=0`.
    pub fn longest_instructions(&self) -> u64 {
        instructions_under_icount(self.longest)
    }
}
