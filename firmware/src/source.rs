//! Where the preflight's ADC frames come from.
//!
//! [`CurrentSource`] hands out one 10 kHz [`AdcFrame`] per call (O(1) work): on the
//! controller, the timer-triggered ADC (`main.rs`, `hardware` feature, a documented sketch);
//! under emulation and in tests, a binary trace of any version ([`shared::trace`]) read through
//! [`TraceSource`], which checks header, length, sample rate and checksum the way
//! `host-sim` does, so both sides refuse the same files.

use shared::trace::{
    Crc32, SaturationCheck, TraceError, TraceHeader, TraceRow, HEADER_BYTES, MAX_ROW_BYTES,
    TRAILER_BYTES,
};
use shared::AdcFrame;

/// Sample rate the FDI is built for [Hz] (the control period of SPEC §5).
pub const SAMPLE_RATE_HZ: u32 = 10_000;

/// What one poll of a [`CurrentSource`] gave.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Acquired {
    /// The next frame of the test.
    Frame(AdcFrame),
    /// No new frame yet (a hardware source waits for the next conversion).
    NotYet,
    /// The test is over; every further poll says so again.
    EndOfTest,
}

/// A source of ADC frames for one preflight test. `next_frame` does O(1) work.
pub trait CurrentSource {
    type Error;
    fn next_frame(&mut self) -> Result<Acquired, Self::Error>;
}

/// Sequential access to a stored trace's bytes (a host file via semihosting, a
/// flash region, a slice in tests).
pub trait TraceBytes {
    type Error;
    /// Total length [bytes].
    fn total_len(&mut self) -> Result<u64, Self::Error>;
    /// Fills `buf` with the next bytes, or fails (a short read is an error).
    fn read_exact(&mut self, buf: &mut [u8]) -> Result<(), Self::Error>;
}

/// Why a stored trace was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(any(feature = "defmt", target_os = "none"), derive(defmt::Format))]
pub enum TraceSourceError<E> {
    /// Reading the bytes failed.
    Io(E),
    /// Header, length or checksum are wrong.
    Trace(TraceError),
    /// The trace was sampled at another rate than [`SAMPLE_RATE_HZ`].
    SampleRate { found: u32 },
}

/// Frames from a binary trace (versions 1–3). The checksum covers every row, so it is checked when the
/// last row has been read: [`Acquired::EndOfTest`] only follows a trace whose checksum matched.
#[derive(Debug)]
pub struct TraceSource<B> {
    bytes: B,
    header: TraceHeader,
    rows_read: u32,
    crc: Crc32,
    saturation: SaturationCheck,
    finished: bool,
    /// The last frame's commanded user-shaft angle [rad].
    command: f32,
}

impl<B: TraceBytes> TraceSource<B> {
    /// Reads and checks the header and the length.
    pub fn open(mut bytes: B) -> Result<Self, TraceSourceError<B::Error>> {
        let mut head = [0u8; HEADER_BYTES];
        let len = bytes.total_len().map_err(TraceSourceError::Io)?;
        if len < (HEADER_BYTES + TRAILER_BYTES) as u64 {
            return Err(TraceSourceError::Trace(TraceError::LengthMismatch {
                rows: 0,
                bytes: len,
            }));
        }
        bytes.read_exact(&mut head).map_err(TraceSourceError::Io)?;
        let header = TraceHeader::decode(&head).map_err(TraceSourceError::Trace)?;
        header.check_length(len).map_err(TraceSourceError::Trace)?;
        if header.sample_rate_hz != SAMPLE_RATE_HZ {
            return Err(TraceSourceError::SampleRate {
                found: header.sample_rate_hz,
            });
        }
        let mut crc = Crc32::new();
        crc.update(&head);
        Ok(Self {
            bytes,
            header,
            rows_read: 0,
            crc,
            saturation: SaturationCheck::new(),
            finished: false,
            command: 0.0,
        })
    }

    pub fn header(&self) -> &TraceHeader {
        &self.header
    }

    /// The commanded user-shaft angle of the last frame [`CurrentSource::next_frame`] handed
    /// out [rad] (0 before the first): a window of flight's command, which the window
    /// identification replays. Rounded to `f32` from the row's exact value, as the host reads
    /// it.
    pub fn command(&self) -> f32 {
        self.command
    }
}

impl<B: TraceBytes> CurrentSource for TraceSource<B> {
    type Error = TraceSourceError<B::Error>;

    fn next_frame(&mut self) -> Result<Acquired, Self::Error> {
        if self.finished {
            return Ok(Acquired::EndOfTest);
        }
        if self.rows_read == self.header.rows {
            let mut trailer = [0u8; TRAILER_BYTES];
            self.bytes
                .read_exact(&mut trailer)
                .map_err(TraceSourceError::Io)?;
            let stored = u32::from_le_bytes(trailer);
            let computed = self.crc.finish();
            if stored != computed {
                return Err(TraceSourceError::Trace(TraceError::BadChecksum {
                    stored,
                    computed,
                }));
            }
            self.finished = true;
            return Ok(Acquired::EndOfTest);
        }
        let mut bytes = [0u8; MAX_ROW_BYTES];
        let row = bytes.get_mut(..self.header.row_bytes()).unwrap_or(&mut []);
        self.bytes.read_exact(row).map_err(TraceSourceError::Io)?;
        self.crc.update(row);
        self.rows_read = self.rows_read.saturating_add(1);
        let row = TraceRow::decode(row);
        self.command = row.command.to_num::<f64>() as f32;
        let frame = row.adc_frame();
        self.saturation
            .push(&frame)
            .map_err(TraceSourceError::Trace)?;
        Ok(Acquired::Frame(frame))
    }
}

/// A trace held in memory (tests; a trace linked into flash).
#[derive(Clone, Copy, Debug)]
pub struct SliceBytes<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> SliceBytes<'a> {
    pub fn new(bytes: &'a [u8]) -> Self {
        Self { bytes, at: 0 }
    }
}

/// A read past the end of a [`SliceBytes`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(any(feature = "defmt", target_os = "none"), derive(defmt::Format))]
pub struct EndOfBytes;

impl TraceBytes for SliceBytes<'_> {
    type Error = EndOfBytes;

    fn total_len(&mut self) -> Result<u64, EndOfBytes> {
        Ok(self.bytes.len() as u64)
    }

    fn read_exact(&mut self, buf: &mut [u8]) -> Result<(), EndOfBytes> {
        let end = self.at.checked_add(buf.len()).ok_or(EndOfBytes)?;
        let src = self.bytes.get(self.at..end).ok_or(EndOfBytes)?;
        for (d, s) in buf.iter_mut().zip(src) {
            *d = *s;
        }
        self.at = end;
        Ok(())
    }
}
