//! SKETCH, NOT TESTED: the current source of the real controller (feature `hardware`).
//!
//! QEMU's STM32F405 converts no real signals, so nothing here has run; it compiles, documents
//! the intended acquisition, and is not wired into `main` (which reads traces). Wiring it in
//! also needs the chirp command on the position loop, which this firmware does not drive.
//!
//! Acquisition at the control rate, 10 kHz, without the CPU in the loop:
//! - TIM2 counts the 84 MHz APB1 timer clock, ARR = 8 399 → update every 100 µs, TRGO = update.
//! - ADC1 regular sequence, triggered by TIM2 TRGO (EXTSEL = 0b0110, EXTEN = rising):
//!   IN0 i_a, IN1 i_b, IN2 i_c (shunt amplifiers), IN3 the user-shaft transducer, 15 cycles
//!   each, scan mode, DMA continuous (DDS = 1).
//! - DMA2 stream 0 channel 0 moves the four 16-bit results into [`Ring`], circular, so the
//!   write position is `RING_HALFWORDS − NDTR`.
//! - TIM3 in encoder mode on the motor encoder; its count is latched by the same TIM2 TRGO
//!   (TIM3 slave, trigger ITR1, capture on CH3) so it belongs to the same instant as the ADC
//!   sequence; the latch is read with each frame.
//!
//! Per poll [`AdcSource::next_frame`] converts at most one frame (O(1)): `NotYet` while the
//! DMA has not written past the read position, `EndOfTest` after `frames_in_test` frames.
//! Sensor scaling ([`SensorScaling`]) comes from the actuator's flash record, like the
//! calibration.

use core::ptr::{read_volatile, write_volatile};

use firmware::{Acquired, CurrentSource};
use shared::AdcFrame;

const DMA2_BASE: usize = 0x4002_6400;
/// DMA2 stream 0 number-of-data register.
const DMA2_S0NDTR: usize = DMA2_BASE + 0x10 + 0x04;
/// TIM3 capture/compare register 3 (the latched encoder count).
const TIM3_CCR3: usize = 0x4000_0400 + 0x3C;
/// TIM2 control register 1 (CEN starts the 10 kHz trigger).
const TIM2_CR1: usize = 0x4000_0000;

/// ADC results per frame: i_a, i_b, i_c, user-shaft transducer.
const CHANNELS: usize = 4;
/// Frames the DMA ring holds (the poll must keep up to within this many frames).
const RING_FRAMES: usize = 64;
const RING_HALFWORDS: usize = CHANNELS * RING_FRAMES;

/// The DMA target: written by DMA2 stream 0, read here.
#[repr(C, align(4))]
pub struct Ring(pub [u16; RING_HALFWORDS]);

/// ADC counts and encoder counts to SI units.
#[derive(Clone, Copy, Debug)]
pub struct SensorScaling {
    /// [A per count] and the count at 0 A, per phase.
    pub amps_per_count: [f32; 3],
    pub zero_count: [f32; 3],
    /// [rad per count] of the user-shaft transducer and its count at 0 rad.
    pub user_rad_per_count: f32,
    pub user_zero_count: f32,
    /// [rad per encoder count] of the motor shaft.
    pub motor_rad_per_count: f32,
}

/// Why the acquisition failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum AdcError {
    /// The poll fell more than a ring behind the DMA: frames were overwritten.
    Overrun,
}

/// Frames from the timer-triggered ADC.
pub struct AdcSource {
    ring: &'static Ring,
    scaling: SensorScaling,
    /// Next ring frame to convert.
    read_frame: usize,
    frames_read: u32,
    frames_in_test: u32,
}

impl AdcSource {
    /// Starts TIM2 (ADC1, DMA2 and TIM3 configured beforehand as the module docs say).
    pub fn start(ring: &'static Ring, scaling: SensorScaling, frames_in_test: u32) -> Self {
        // SAFETY: TIM2_CR1 is TIM2's control register on the STM32F405; setting CEN starts
        // the counter. Nothing else owns TIM2.
        unsafe { write_volatile(TIM2_CR1 as *mut u32, 1) };
        Self {
            ring,
            scaling,
            read_frame: 0,
            frames_read: 0,
            frames_in_test,
        }
    }

    /// The ring frame the DMA writes next.
    fn write_frame() -> usize {
        // SAFETY: DMA2 stream 0 NDTR, read-only use.
        let ndtr = unsafe { read_volatile(DMA2_S0NDTR as *const u32) } as usize;
        (RING_HALFWORDS.saturating_sub(ndtr) / CHANNELS) % RING_FRAMES
    }
}

impl CurrentSource for AdcSource {
    type Error = AdcError;

    fn next_frame(&mut self) -> Result<Acquired, AdcError> {
        if self.frames_read >= self.frames_in_test {
            return Ok(Acquired::EndOfTest);
        }
        if Self::write_frame() == self.read_frame {
            // Either nothing new, or a whole ring behind; the 10 kHz poll budget rules out
            // the latter, a hardware overrun flag (DMA TCIF counting) would tell them apart.
            return Ok(Acquired::NotYet);
        }
        let base = self.read_frame * CHANNELS;
        let counts = self
            .ring
            .0
            .get(base..base + CHANNELS)
            .ok_or(AdcError::Overrun)?;
        let s = &self.scaling;
        let mut currents = [0.0f32; 3];
        for ((i, &count), (gain, zero)) in currents
            .iter_mut()
            .zip(counts)
            .zip(s.amps_per_count.iter().zip(&s.zero_count))
        {
            *i = (f32::from(count) - zero) * gain;
        }
        let user = counts.get(3).map_or(0.0, |&c| {
            (f32::from(c) - s.user_zero_count) * s.user_rad_per_count
        });
        // SAFETY: TIM3 CCR3 holds the encoder count latched by the same trigger. Read as a
        // signed 16-bit count: the ±2 mrad chirp stays far inside half the counter range, a
        // general source would unwrap across the 16-bit wrap.
        let encoder = unsafe { read_volatile(TIM3_CCR3 as *const u32) } as u16 as i16;
        let motor = f32::from(encoder) * s.motor_rad_per_count;
        self.read_frame = (self.read_frame + 1) % RING_FRAMES;
        self.frames_read += 1;
        Ok(Acquired::Frame(AdcFrame::from_f32(currents, motor, user)))
    }
}
