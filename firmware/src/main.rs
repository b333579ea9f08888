//! Preflight FDI firmware for the actuator controller (STM32F405, Cortex-M4F, 168 MHz).
//!
//! Two embassy tasks share one thread-mode executor: the preflight self-test
//! ([`firmware::Preflight`], one bounded slice of work per poll, then it yields) and a
//! heartbeat standing in for the control loop and bus traffic, which must keep running
//! while the GA works. Under QEMU (`cargo fw -- TRACE.bin`) the frames come from a binary
//! trace read through semihosting; the result is printed with defmt over semihosting and the
//! exit status says whether the self-test produced a result (0) or not (non-zero).
//!
//! Time: SysTick counts core clock cycles (24-bit, wraps counted in its exception). Under
//! `qemu-run` (QEMU `-icount shift=0`: one instruction = 1 ns of virtual time) a cycle count
//! converts to instructions as `cycles · 10⁹ / 168·10⁶`.
//!
//! With feature `hardware` the same binary is the board image instead (`board.rs`): the test
//! commanded through the bridge timer, frames from the timer-triggered ADC and encoder,
//! records in flash, the report over RTT.
//!
//! On the host the crate compiles to a stub so that `cargo test --workspace` stays runnable.
#![cfg_attr(target_os = "none", no_std)]
#![cfg_attr(target_os = "none", no_main)]
// No panic on any input (issue 7); the one deliberate panic (`--crash panic`, which proves the
// panic handler) carries its own `allow`.
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

// The emulation image (QEMU, semihosting): traces in, report and exit status out.
#[cfg(all(target_os = "none", not(feature = "hardware")))]
mod clock;
#[cfg(all(target_os = "none", not(feature = "hardware")))]
mod emulation;
#[cfg(all(target_os = "none", not(feature = "hardware")))]
mod log;
#[cfg(all(target_os = "none", not(feature = "hardware")))]
mod target;
#[cfg(all(target_os = "none", not(feature = "hardware")))]
mod vectors;
// The board image (feature `hardware`): the STM32F405's peripherals through embassy-stm32.
#[cfg(all(target_os = "none", feature = "hardware"))]
mod board;

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!(
        "firmware: this binary runs on the Cortex-M4F. Build it with `cargo fw-build`, or run \
         the preflight on a trace under QEMU with `cargo fw -- TRACE.bin`."
    );
    std::process::exit(2);
}
