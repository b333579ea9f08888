//! The board image on an emulated STM32F405 (issue 70): the Cortex-M4F core from
//! unicorn-engine, and register-level models, written from RM0090, of what the image
//! drives — RCC and the flash wait states ([`clocks`]), the flash interface and its data
//! sectors ([`flash`]), TIM1/TIM2/TIM3 ([`timers`]), ADC1/ADC2's injected group ([`adc`]),
//! GPIO and the core's private registers ([`bus`]) — with a [`plant`] on the pins and the
//! RTT log read from RAM ([`rtt`]); what it fed the image, as a trace ([`feed`]); known faults read through the board beside the
//! actuator's own controller ([`campaign`]); what the board's drive and sensors cost a window
//! of flight, on the host ([`sensing`]). A test tool: never linked into `firmware` or
//! `host-sim` (unicorn-engine is GPL-2.0).
//!
//! Time: one core cycle per instruction (QEMU `-icount`'s convention), the peripherals
//! stepped every [`board::CHUNK`] instructions.

pub mod adc;
pub mod board;
pub mod bus;
pub mod campaign;
pub mod clocks;
pub mod elf;
pub mod feed;
pub mod flash;
pub mod plant;
pub mod rtt;
pub mod sensing;
pub mod timers;

pub use board::{Board, RunEnd};
