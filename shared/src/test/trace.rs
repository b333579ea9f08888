//! The binary preflight trace, format versions 1 to 3: what `host-sim simulate --format bin`
//! writes and what the firmware reads under emulation. Decoding is O(1) per row, no
//! allocation.
//!
//! Layout, all integers little-endian:
//!
//! | offset | bytes | field |
//! | --- | --- | --- |
//! | 0 | 4 | magic `b"EMAT"` |
//! | 4 | 2 | format version, `u16`: 1, 2 or 3 |
//! | 6 | 1 | columns per row, `u8`: 6 (versions 1, 2), 8 (version 3) |
//! | 7 | 1 | versions 2, 3: the test design's kind ([`PreflightTest::kind`]), plus [`FLIGHT_MARK`] for a window of flight; version 1: 0 |
//! | 8 | 4 | sample rate \[Hz\], `u32` (10 000) |
//! | 12 | 4 | number of rows, `u32` |
//! | 16 | 24 or 32 · rows | rows, 6 or 8 × `i32` each (below) |
//! | end | 4 | CRC-32 (IEEE 802.3) of every byte before it |
//!
//! Version 1 (a `u16` column count at offset 6, the same bytes as version 2 with code 0) is
//! the paper's test, the chirp alone. A window of flight (the chirp on the flight's
//! commands, `theta_cmd` what the position loop followed) is written as version 2 or 3 with
//! [`FLIGHT_MARK`] set in its code; a reader that predates the mark refuses it as an unknown
//! test. A version 2 trace with a standstill segment holds its
//! samples first, then the chirp's; `theta_cmd` is 0 during the segment. Paper-test traces
//! are still written as version 1.
//!
//! A row is the sample at `t = index / sample_rate`, six fixed-point numbers stored as the
//! `i32` of their bits: commanded user angle θ_cmd \[rad\] as `I4F28`, phase currents i_a, i_b,
//! i_c \[A\] as `I16F16`, motor-shaft angle θ_m \[rad\] as `I16F16`, user-shaft angle θ_u \[rad\] as
//! `I4F28`. The currents and the two angles are exactly the controller's [`AdcFrame`].
//! Version 3 adds what the controller measured of its day, both `I16F16`: the DC bus voltage
//! \[V\] and a temperature [°C] (a winding thermistor, or the board).

use fixed::types::{I16F16, I4F28};

use crate::test::conditioning::AdcFrame;
pub use crate::test::conditioning::ConditionReading;
use crate::test::test_design::PreflightTest;

/// First four bytes of every binary trace.
pub const MAGIC: [u8; 4] = *b"EMAT";
/// The bit of the test code (offset 7) that marks a window of flight.
pub const FLIGHT_MARK: u8 = 0x80;
/// The newest format version this code reads and writes (it reads 1 and 2 too).
pub const VERSION: u16 = 3;
/// Columns per row of versions 1 and 2.
pub const COLUMNS: u16 = 6;
/// Columns per row of version 3: the six, the bus voltage and the temperature.
pub const CONDITION_COLUMNS: u16 = 8;
/// Bytes of the header.
pub const HEADER_BYTES: usize = 16;
/// Bytes of one row of versions 1 and 2.
pub const ROW_BYTES: usize = 4 * COLUMNS as usize;
/// Bytes of one row of version 3 (the largest row).
pub const MAX_ROW_BYTES: usize = 4 * CONDITION_COLUMNS as usize;
/// Bytes of the checksum trailer.
pub const TRAILER_BYTES: usize = 4;

/// Why a binary trace was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum TraceError {
    /// The first four bytes are not [`MAGIC`].
    BadMagic,
    /// A version this code does not read.
    UnsupportedVersion { found: u16 },
    /// A column count other than [`COLUMNS`].
    BadColumns { found: u16 },
    /// A test design code this code does not know.
    UnknownTest { code: u8 },
    /// The file length does not match the header's row count.
    LengthMismatch { rows: u32, bytes: u64 },
    /// The stored checksum differs from the computed one.
    BadChecksum { stored: u32, computed: u32 },
    /// Phase `phase` (0 = A) read full scale for [`SATURATION_RUN`] rows in a row, the
    /// first of them at row `first_row` (0-based): the ADC clipped, the current is unknown.
    SaturatedCurrent { phase: u8, first_row: u32 },
}

/// The controller's phase-current ADC range \[A\]: ±20 A, 12 bits (SPEC §4 sensors).
pub const CURRENT_FULL_SCALE: f32 = 20.0;
/// One count of the phase-current ADC \[A\].
pub const CURRENT_LSB: f32 = 2.0 * CURRENT_FULL_SCALE / 4096.0;
/// A reading at least this large in magnitude is a clipped one \[A\] (full scale less 2 counts).
pub const SATURATION_LEVEL: f32 = CURRENT_FULL_SCALE - 2.0 * CURRENT_LSB;
/// Clipped readings of one phase in a row that make a trace unusable: 1 ms at 10 kHz. A
/// single clipped sample (a spike) passes; a stretch means the real current is unknown.
pub const SATURATION_RUN: u32 = 10;

/// Streaming check for clipped phase-current stretches: O(1) per frame, 16 bytes of state.
/// Host ingestion and the firmware's trace source both run every frame through it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SaturationCheck {
    /// Clipped readings in a row so far, per phase.
    run: [u32; 3],
    /// Frames seen.
    rows: u32,
}

impl SaturationCheck {
    pub const fn new() -> Self {
        Self {
            run: [0; 3],
            rows: 0,
        }
    }

    /// Takes the next frame; refuses the trace at the [`SATURATION_RUN`]-th clipped reading in
    /// a row of one phase.
    pub fn push(&mut self, frame: &AdcFrame) -> Result<(), TraceError> {
        let row = self.rows;
        self.rows = self.rows.saturating_add(1);
        for ((phase, run), current) in (0u8..).zip(self.run.iter_mut()).zip(frame.phase_currents) {
            let magnitude = crate::test::conditioning::i16f16_to_f32(current);
            let clipped = magnitude >= SATURATION_LEVEL || magnitude <= -SATURATION_LEVEL;
            *run = if clipped { run.saturating_add(1) } else { 0 };
            if *run >= SATURATION_RUN {
                return Err(TraceError::SaturatedCurrent {
                    phase,
                    first_row: row.saturating_add(1).saturating_sub(*run),
                });
            }
        }
        Ok(())
    }
}

/// The header of a binary trace.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TraceHeader {
    /// Sample rate \[Hz\].
    pub sample_rate_hz: u32,
    /// Number of rows that follow.
    pub rows: u32,
    /// The test design the rows come from (version 1: the paper's).
    pub test: PreflightTest,
    /// Whether each row carries the bus voltage and temperature (version 3).
    pub conditions: bool,
    /// A window of flight ([`FLIGHT_MARK`]) rather than a preflight test.
    pub flight: bool,
}

impl TraceHeader {
    /// The header's bytes: the test is stored as its [`PreflightTest::kind`] (the segments'
    /// settings of another actuator come from its record).
    pub fn encode(&self) -> Result<[u8; HEADER_BYTES], TraceError> {
        let code = self.test.kind() | if self.flight { FLIGHT_MARK } else { 0 };
        let (version, columns): (u16, u16) = match (self.conditions, code) {
            (true, _) => (VERSION, CONDITION_COLUMNS),
            (false, 0) => (1, COLUMNS),
            (false, _) => (2, COLUMNS),
        };
        let mut out = [0u8; HEADER_BYTES];
        let fields = [
            &MAGIC[..],
            &version.to_le_bytes(),
            &[columns as u8, code],
            &self.sample_rate_hz.to_le_bytes(),
            &self.rows.to_le_bytes(),
        ];
        let mut at = 0;
        for f in fields {
            for (dst, src) in out.iter_mut().skip(at).zip(f) {
                *dst = *src;
            }
            at += f.len();
        }
        Ok(out)
    }

    pub fn decode(bytes: &[u8; HEADER_BYTES]) -> Result<Self, TraceError> {
        let [m0, m1, m2, m3, v0, v1, c0, c1, r0, r1, r2, r3, n0, n1, n2, n3] = *bytes;
        if [m0, m1, m2, m3] != MAGIC {
            return Err(TraceError::BadMagic);
        }
        let version = u16::from_le_bytes([v0, v1]);
        let (columns, code, conditions) = match version {
            1 => (u16::from_le_bytes([c0, c1]), 0, false),
            2 => (u16::from(c0), c1, false),
            3 => (u16::from(c0), c1, true),
            _ => return Err(TraceError::UnsupportedVersion { found: version }),
        };
        let expected = if conditions {
            CONDITION_COLUMNS
        } else {
            COLUMNS
        };
        if columns != expected {
            return Err(TraceError::BadColumns { found: columns });
        }
        let flight = code & FLIGHT_MARK != 0;
        let test = PreflightTest::from_code(code & !FLIGHT_MARK)
            .ok_or(TraceError::UnknownTest { code })?;
        Ok(Self {
            sample_rate_hz: u32::from_le_bytes([r0, r1, r2, r3]),
            rows: u32::from_le_bytes([n0, n1, n2, n3]),
            test,
            conditions,
            flight,
        })
    }

    /// Bytes of one row.
    pub fn row_bytes(&self) -> usize {
        if self.conditions {
            MAX_ROW_BYTES
        } else {
            ROW_BYTES
        }
    }

    /// Total file length this header announces \[bytes\].
    pub fn file_bytes(&self) -> u64 {
        (HEADER_BYTES + TRAILER_BYTES) as u64 + self.row_bytes() as u64 * u64::from(self.rows)
    }

    /// Checks a file length against the header.
    pub fn check_length(&self, bytes: u64) -> Result<(), TraceError> {
        if bytes == self.file_bytes() {
            Ok(())
        } else {
            Err(TraceError::LengthMismatch {
                rows: self.rows,
                bytes,
            })
        }
    }
}

/// One sample of a trace, in the stored fixed-point form.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
// No defmt derive: `fixed` numbers do not implement `defmt::Format`.
pub struct TraceRow {
    /// Commanded user-shaft angle \[rad\].
    pub command: I4F28,
    /// Phase currents i_a, i_b, i_c \[A\].
    pub phase_currents: [I16F16; 3],
    /// Motor-shaft angle \[rad\].
    pub motor_angle: I16F16,
    /// User-shaft angle \[rad\].
    pub user_angle: I4F28,
    /// What the controller measured of its day, where the trace carries it (version 3).
    pub conditions: Option<ConditionReading>,
}

/// One encoded row: [`TraceRow::encode`]'s bytes, 24 or 32 of them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RowBytes {
    bytes: [u8; MAX_ROW_BYTES],
    len: usize,
}

impl RowBytes {
    pub fn as_slice(&self) -> &[u8] {
        self.bytes.get(..self.len).unwrap_or(&self.bytes)
    }
}

impl TraceRow {
    /// Converts, saturating at the fixed-point range (NaN becomes 0: the conversion itself
    /// never panics; readers reject non-finite input before they get here). Every tool that
    /// reads a text trace goes through here, so a CSV and a binary trace of the same
    /// simulation condition into the same bits.
    pub fn from_f64(
        command: f64,
        phase_currents: [f64; 3],
        motor_angle: f64,
        user_angle: f64,
    ) -> Self {
        let nan_to_zero = |x: f64| if x.is_nan() { 0.0 } else { x };
        Self {
            command: I4F28::saturating_from_num(nan_to_zero(command)),
            phase_currents: phase_currents.map(|x| I16F16::saturating_from_num(nan_to_zero(x))),
            motor_angle: I16F16::saturating_from_num(nan_to_zero(motor_angle)),
            user_angle: I4F28::saturating_from_num(nan_to_zero(user_angle)),
            conditions: None,
        }
    }

    /// The same row carrying the controller's bus and temperature readings.
    pub fn with_conditions(mut self, reading: ConditionReading) -> Self {
        self.conditions = Some(reading);
        self
    }

    /// What the controller's ADC holds for this sample.
    pub fn adc_frame(&self) -> AdcFrame {
        AdcFrame {
            phase_currents: self.phase_currents,
            motor_angle: self.motor_angle,
            user_angle: self.user_angle,
            conditions: self.conditions,
        }
    }

    /// The row's bytes: 24, or 32 with the conditions.
    pub fn encode(&self) -> RowBytes {
        let c = self.conditions.unwrap_or_default();
        let words = [
            self.command.to_bits(),
            self.phase_currents[0].to_bits(),
            self.phase_currents[1].to_bits(),
            self.phase_currents[2].to_bits(),
            self.motor_angle.to_bits(),
            self.user_angle.to_bits(),
            c.bus_voltage.to_bits(),
            c.temperature.to_bits(),
        ];
        let mut out = [0u8; MAX_ROW_BYTES];
        for (chunk, w) in out.chunks_exact_mut(4).zip(words) {
            for (dst, src) in chunk.iter_mut().zip(w.to_le_bytes()) {
                *dst = src;
            }
        }
        RowBytes {
            bytes: out,
            len: if self.conditions.is_some() {
                MAX_ROW_BYTES
            } else {
                ROW_BYTES
            },
        }
    }

    /// A row from its bytes: 24 (versions 1, 2) or 32 (version 3, with the conditions);
    /// other lengths read as far as they go, missing words as 0.
    pub fn decode(bytes: &[u8]) -> Self {
        let mut words = [0i32; CONDITION_COLUMNS as usize];
        for (w, chunk) in words.iter_mut().zip(bytes.chunks_exact(4)) {
            let mut b = [0u8; 4];
            for (dst, src) in b.iter_mut().zip(chunk) {
                *dst = *src;
            }
            *w = i32::from_le_bytes(b);
        }
        let [cmd, a, b, c, m, u, bus, temperature] = words;
        Self {
            conditions: (bytes.len() >= MAX_ROW_BYTES).then(|| ConditionReading {
                bus_voltage: I16F16::from_bits(bus),
                temperature: I16F16::from_bits(temperature),
            }),
            command: I4F28::from_bits(cmd),
            phase_currents: [
                I16F16::from_bits(a),
                I16F16::from_bits(b),
                I16F16::from_bits(c),
            ],
            motor_angle: I16F16::from_bits(m),
            user_angle: I4F28::from_bits(u),
        }
    }
}

/// Streaming CRC-32 (IEEE 802.3, reflected, polynomial 0xEDB88320), a nibble at a time:
/// O(2) table look-ups per byte, a 64-byte table in flash.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Crc32(u32);

/// The CRC of each nibble value shifted through four bits of the register.
#[allow(clippy::indexing_slicing)] // n < 16, evaluated at compile time
const CRC32_NIBBLES: [u32; 16] = {
    let mut table = [0u32; 16];
    let mut n = 0;
    while n < 16 {
        let mut c = n as u32;
        let mut bit = 0;
        while bit < 4 {
            c = (c >> 1) ^ (0xEDB8_8320 & (c & 1).wrapping_neg());
            bit += 1;
        }
        table[n] = c;
        n += 1;
    }
    table
};

impl Crc32 {
    pub const fn new() -> Self {
        Self(0xFFFF_FFFF)
    }

    pub fn update(&mut self, bytes: &[u8]) {
        // A nibble indexes the 16 entries: `get` never misses (and compiles to a load).
        let nibble =
            |c: u32| (c >> 4) ^ CRC32_NIBBLES.get((c & 0xF) as usize).copied().unwrap_or(0);
        for &b in bytes {
            self.0 = nibble(nibble(self.0 ^ u32::from(b)));
        }
    }

    pub fn finish(&self) -> u32 {
        !self.0
    }
}

impl Default for Crc32 {
    fn default() -> Self {
        Self::new()
    }
}

/// A command \[rad\] as a trace's row holds it and a reader takes it back (`I4F28`, 2⁻²⁸ rad,
/// then `f32`): what a controller keeps of the command it followed in a window of flight, so
/// that the window it recorded and the trace written of it read the same bits. Idempotent;
/// NaN reads 0. O(1).
pub fn command_as_traced(rad: f32) -> f32 {
    TraceRow::from_f64(f64::from(rad), [0.0; 3], 0.0, 0.0)
        .command
        .to_num::<f64>() as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc_matches_the_standard_check_value() {
        let mut c = Crc32::new();
        c.update(b"123456789");
        assert_eq!(c.finish(), 0xCBF4_3926);
    }

    #[test]
    fn header_round_trips_and_rejects_foreign_bytes() {
        let h = TraceHeader {
            sample_rate_hz: 10_000,
            rows: 5000,
            test: PreflightTest::PAPER,
            conditions: false,
            flight: false,
        };
        let bytes = h.encode().unwrap();
        // The paper's test is written as version 1.
        assert_eq!(&bytes[4..8], &[1, 0, 6, 0]);
        assert_eq!(&bytes[..4], b"EMAT");
        assert_eq!(TraceHeader::decode(&bytes), Ok(h));
        assert_eq!(h.file_bytes(), 16 + 4 + 24 * 5000);
        assert!(h.check_length(h.file_bytes()).is_ok());
        assert_eq!(
            h.check_length(100),
            Err(TraceError::LengthMismatch {
                rows: 5000,
                bytes: 100
            })
        );
        let mut bad = bytes;
        bad[0] = b'X';
        assert_eq!(TraceHeader::decode(&bad), Err(TraceError::BadMagic));
        let mut bad = bytes;
        bad[4] = 4;
        assert_eq!(
            TraceHeader::decode(&bad),
            Err(TraceError::UnsupportedVersion { found: 4 })
        );
        // Version 1 has a u16 column count: a high byte is no design code there.
        let mut bad = bytes;
        bad[7] = 1;
        assert_eq!(
            TraceHeader::decode(&bad),
            Err(TraceError::BadColumns { found: 0x0106 })
        );
        let mut bad = bytes;
        bad[6] = 7;
        assert_eq!(
            TraceHeader::decode(&bad),
            Err(TraceError::BadColumns { found: 7 })
        );
    }

    #[test]
    fn version_2_carries_the_test_design() {
        let h = TraceHeader {
            sample_rate_hz: 10_000,
            rows: 5420,
            test: PreflightTest::STANDSTILL,
            conditions: false,
            flight: false,
        };
        let bytes = h.encode().unwrap();
        assert_eq!(&bytes[4..8], &[2, 0, 6, 1]);
        assert_eq!(TraceHeader::decode(&bytes), Ok(h));
        let mut bad = bytes;
        bad[7] = 9;
        assert_eq!(
            TraceHeader::decode(&bad),
            Err(TraceError::UnknownTest { code: 9 })
        );
        let odd = TraceHeader {
            test: PreflightTest::PAPER.with_chirp(crate::ChirpCommand {
                amplitude: 1.0e-3,
                ..crate::ChirpCommand::PREFLIGHT
            }),
            ..h
        };
        // Another actuator's chirp is stored by its kind; its settings come from the
        // actuator record, not from the trace.
        let odd_bytes = odd.encode().unwrap();
        assert_eq!(odd_bytes[7], 0);
        assert_eq!(
            TraceHeader::decode(&odd_bytes).unwrap().test,
            PreflightTest::PAPER
        );
    }

    #[test]
    fn a_window_of_flight_is_marked_in_the_test_code() {
        let h = TraceHeader {
            sample_rate_hz: 10_000,
            rows: 5000,
            test: PreflightTest::PAPER,
            conditions: true,
            flight: true,
        };
        let bytes = h.encode().unwrap();
        assert_eq!(&bytes[4..8], &[3, 0, 8, FLIGHT_MARK]);
        assert_eq!(TraceHeader::decode(&bytes), Ok(h));
        // Without the bus and temperature: version 2, never version 1 (no code there).
        let bare = TraceHeader {
            conditions: false,
            ..h
        };
        let bytes = bare.encode().unwrap();
        assert_eq!(&bytes[4..8], &[2, 0, 6, FLIGHT_MARK]);
        assert_eq!(TraceHeader::decode(&bytes), Ok(bare));
        // The mark on an unknown design is still refused, with the whole code.
        let mut bad = bytes;
        bad[7] = FLIGHT_MARK | 9;
        assert_eq!(
            TraceHeader::decode(&bad),
            Err(TraceError::UnknownTest {
                code: FLIGHT_MARK | 9
            })
        );
    }

    #[test]
    fn a_clipped_stretch_is_refused_and_a_spike_is_not() {
        let frame = |a: f32| AdcFrame::from_f32([a, -a, 0.0], 0.0, 0.0);
        let mut check = SaturationCheck::new();
        // A lone clipped sample between ordinary ones passes.
        for a in [1.0, 19.99, 1.0] {
            assert_eq!(check.push(&frame(a)), Ok(()));
        }
        for _ in 0..SATURATION_RUN - 1 {
            assert_eq!(check.push(&frame(-CURRENT_FULL_SCALE)), Ok(()));
        }
        assert_eq!(
            check.push(&frame(-CURRENT_FULL_SCALE)),
            Err(TraceError::SaturatedCurrent {
                phase: 0,
                first_row: 3
            })
        );
        // Just below the level never trips.
        let mut check = SaturationCheck::new();
        for _ in 0..100 {
            assert_eq!(check.push(&frame(SATURATION_LEVEL - 0.01)), Ok(()));
        }
    }

    #[test]
    fn version_3_carries_the_bus_and_temperature_in_32_byte_rows() {
        let h = TraceHeader {
            sample_rate_hz: 10_000,
            rows: 10,
            test: PreflightTest::STANDSTILL,
            conditions: true,
            flight: false,
        };
        let bytes = h.encode().unwrap();
        assert_eq!(&bytes[4..8], &[3, 0, 8, 1]);
        assert_eq!(TraceHeader::decode(&bytes), Ok(h));
        assert_eq!(h.file_bytes(), 16 + 4 + 32 * 10);
        // A version 3 header must say 8 columns, a version 2 header 6.
        let mut bad = bytes;
        bad[6] = 6;
        assert_eq!(
            TraceHeader::decode(&bad),
            Err(TraceError::BadColumns { found: 6 })
        );
        let r = TraceRow::from_f64(0.001, [1.0, -1.0, 0.0], 0.5, 0.0)
            .with_conditions(ConditionReading::from_f64(268.25, -39.5));
        let encoded = r.encode();
        assert_eq!(encoded.as_slice().len(), MAX_ROW_BYTES);
        assert_eq!(TraceRow::decode(encoded.as_slice()), r);
        let c = r.conditions.unwrap();
        assert_eq!(c.bus_voltage.to_num::<f32>(), 268.25);
        assert_eq!(c.temperature.to_num::<f32>(), -39.5);
    }

    #[test]
    fn row_round_trips_bit_for_bit() {
        let r = TraceRow::from_f64(-0.004_321, [1.25, -3.5, 0.0078], 2.5, 0.0049);
        assert_eq!(r.encode().as_slice().len(), ROW_BYTES);
        assert_eq!(TraceRow::decode(r.encode().as_slice()), r);
        assert_eq!(r.adc_frame().phase_currents[1], I16F16::from_num(-3.5));
        // Saturation instead of wrap-around.
        let big = TraceRow::from_f64(100.0, [1e9, -1e9, f64::NAN], 0.0, -100.0);
        assert_eq!(big.command, I4F28::MAX);
        assert_eq!(big.phase_currents[0], I16F16::MAX);
        assert_eq!(big.phase_currents[1], I16F16::MIN);
        assert_eq!(big.phase_currents[2], I16F16::ZERO);
        assert_eq!(big.user_angle, I4F28::MIN);
    }

    #[test]
    fn a_command_as_traced_is_what_a_row_gives_back_and_rounding_it_again_keeps_it() {
        for &x in &[1.0e-3f32, -4.4379e-3, 0.0213, 0.3, -0.49, 1.234_567e-7] {
            let row = TraceRow::decode(
                TraceRow::from_f64(f64::from(x), [0.0; 3], 0.0, 0.0)
                    .encode()
                    .as_slice(),
            );
            let traced = command_as_traced(x);
            assert_eq!(traced, row.command.to_num::<f64>() as f32);
            assert_eq!(command_as_traced(traced), traced);
        }
        // Off the grid: a command finer than 2⁻²⁸ rad is rounded.
        assert_ne!(command_as_traced(1.234_567e-3), 1.234_567e-3);
        assert_eq!(command_as_traced(f32::NAN), 0.0);
    }
}
