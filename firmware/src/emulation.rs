//! Emulation glue (QEMU with semihosting): the command line and the trace file on the host.
//!
//! `cargo fw -- TRACE.bin [--again T.bin ...] [--actuator RECORD] [--seed N] [--checkpoint FILE
//! [--stop-after N]] [--health FILE [--flight N]] [--window W.bin ...]`: the runner (`firmware/qemu-run`) passes the ELF path and these arguments
//! through QEMU's semihosting command line; the trace is read with SYS_OPEN / SYS_FLEN /
//! SYS_READ, one row (24 B) per read. The checkpoint file stands in for the flash page that
//! keeps the GA record across a power loss; the health file for the flash that keeps the
//! health log (the RAM store's image, `ONBOARD_RECORDS` × 84 bytes, or an older version's
//! slots); the actuator file for the flash sector that holds the actuator record
//! (`host-sim actuator`, 492 bytes); each `--window` file (up to [`MAX_WINDOWS`], a window of
//! flight from `host-sim simulate --flight … --format bin`) for a window the flight's
//! control loop recorded after this preflight; each `--again` file (up to [`MAX_AGAIN`]) for
//! the same preflight's test played again, its noise drawn anew, read where the noise calls
//! for it (`ActuatorRecord::tests_called_for`). The command line is split at blanks (QEMU joins its
//! `arg=`s with spaces): paths cannot hold one.

use core::ffi::CStr;

use semihosting::fs::File;
use semihosting::io::{Read, Write};
use semihosting::sys::arm_compat::syscall::{syscall, OperationNumber, ParamRegW};

use firmware::TraceBytes;

/// Longest path accepted [bytes, NUL excluded].
pub const MAX_PATH: usize = 200;
/// Bytes for all the paths of one command line, each NUL-terminated (trace, checkpoint,
/// health log, actuator record, windows): one buffer, not one per path, to keep RAM small.
const PATHS_BYTES: usize = 512;

/// Bytes of the semihosting command line buffer.
const CMDLINE_BYTES: usize = 1024;

/// Windows of flight one run reads at most (`--window`, repeatable): a flight of eight.
pub use firmware::flight::MAX_WINDOWS;

/// Tests played again one run reads at most (`--again`, repeatable): the most tests a
/// preflight plays, the first one aside.
pub const MAX_AGAIN: usize = shared::actuator::MAX_TESTS as usize - 1;

/// What the command line asked for.
pub struct Command {
    paths: Paths,
    path: Option<u16>,
    checkpoint: Option<u16>,
    health: Option<u16>,
    actuator: Option<u16>,
    windows: [u16; MAX_WINDOWS],
    window_count: usize,
    again: [u16; MAX_AGAIN],
    again_count: usize,
    pub seed: Option<u64>,
    /// `--flight N`: the flight index of this preflight's health record (default: one after
    /// the newest in the log).
    pub flight: Option<u32>,
    /// Simulated power loss: stop after this many evaluations, checkpoint written.
    pub stop_after: Option<u32>,
    /// Fault injection for the handler tests (emulation only).
    pub crash: Option<Crash>,
}

/// `--crash panic|hard-fault`: proves the panic and HardFault handlers report and exit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Crash {
    Panic,
    HardFault,
}

/// A command line the firmware cannot follow.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum UsageError {
    /// The host gave no command line (QEMU without `-semihosting-config ...,arg=`).
    NoCommandLine,
    /// No trace path.
    MissingTrace,
    PathTooLong,
    /// `--seed` without a number, or an unknown option.
    BadOption,
    /// More than [`MAX_WINDOWS`] `--window`s, or more than [`MAX_AGAIN`] `--again`s.
    TooManyWindows,
}

impl Command {
    /// Reads the command line (module doc; plus `--crash panic|hard-fault`) from the semihosting
    /// command line.
    pub fn from_host() -> Result<Self, UsageError> {
        let mut line = [0; CMDLINE_BYTES];
        let line = host_command_line(&mut line).ok_or(UsageError::NoCommandLine)?;
        let mut words = line
            .split(|b| *b == b' ' || *b == b'\t')
            .filter(|w| !w.is_empty())
            .skip(1);
        let mut paths = Paths {
            bytes: [0; PATHS_BYTES],
            used: 0,
        };
        let mut path = None;
        let mut seed = None;
        let mut crash = None;
        let mut checkpoint = None;
        let mut stop_after = None;
        let mut health = None;
        let mut actuator = None;
        let mut flight = None;
        let mut windows = [0u16; MAX_WINDOWS];
        let mut window_count = 0;
        let mut again = [0u16; MAX_AGAIN];
        let mut again_count = 0;
        while let Some(word) = words.next() {
            let mut value = || option_value(&mut words);
            let number32 = |w: &[u8]| u32::try_from(number(w)?).map_err(|_| UsageError::BadOption);
            match word {
                b"--seed" => seed = Some(number(value()?)?),
                b"--stop-after" => stop_after = Some(number32(value()?)?),
                b"--flight" => flight = Some(number32(value()?)?),
                b"--actuator" => actuator = Some(paths.push(value()?)?),
                b"--health" => health = Some(paths.push(value()?)?),
                b"--checkpoint" => checkpoint = Some(paths.push(value()?)?),
                b"--window" => append(&mut windows, &mut window_count, paths.push(value()?)?)?,
                b"--again" => append(&mut again, &mut again_count, paths.push(value()?)?)?,
                b"--crash" => {
                    crash = match value()? {
                        b"panic" => Some(Crash::Panic),
                        b"hard-fault" => Some(Crash::HardFault),
                        _ => return Err(UsageError::BadOption),
                    }
                }
                _ if word.starts_with(b"--") || path.is_some() => {
                    return Err(UsageError::BadOption)
                }
                _ => path = Some(paths.push(word)?),
            }
        }
        if path.is_none() && crash.is_none() {
            return Err(UsageError::MissingTrace);
        }
        if stop_after.is_some() && checkpoint.is_none() {
            // A power loss without a checkpoint would only throw the work away.
            return Err(UsageError::BadOption);
        }
        if flight.is_some() && health.is_none() {
            return Err(UsageError::BadOption);
        }
        Ok(Self {
            paths,
            path,
            checkpoint,
            health,
            actuator,
            windows,
            window_count,
            again,
            again_count,
            seed,
            flight,
            stop_after,
            crash,
        })
    }

    /// The checkpoint file, NUL-terminated, if one was given.
    pub fn checkpoint_path(&self) -> Option<&CStr> {
        self.checkpoint.map(|at| self.paths.get(at))
    }

    /// The health-log file (the RAM store's image between runs), if one was given.
    pub fn health_path(&self) -> Option<&CStr> {
        self.health.map(|at| self.paths.get(at))
    }

    /// The actuator record file (the record's flash sector on the controller), if one was
    /// given; without one the firmware runs the built-in reference actuator.
    pub fn actuator_path(&self) -> Option<&CStr> {
        self.actuator.map(|at| self.paths.get(at))
    }

    /// The `--window` files, in the order given.
    pub fn window_paths(&self) -> impl Iterator<Item = &CStr> {
        self.windows
            .iter()
            .take(self.window_count)
            .map(|&at| self.paths.get(at))
    }

    /// The `--again` files (the same test played again), in the order given.
    pub fn again_paths(&self) -> impl Iterator<Item = &CStr> {
        self.again
            .iter()
            .take(self.again_count)
            .map(|&at| self.paths.get(at))
    }

    /// The trace path, NUL-terminated.
    pub fn trace_path(&self) -> &CStr {
        self.path.map_or(c"", |at| self.paths.get(at))
    }
}

/// The command line's paths, NUL-terminated one after the other in a zeroed buffer.
struct Paths {
    bytes: [u8; PATHS_BYTES],
    used: usize,
}

impl Paths {
    /// Stores `word` and its NUL; returns where it starts.
    fn push(&mut self, bytes: &[u8]) -> Result<u16, UsageError> {
        let end = self.used + bytes.len() + 1;
        if bytes.len() > MAX_PATH || end > PATHS_BYTES {
            return Err(UsageError::PathTooLong);
        }
        let at = self.used;
        if let Some(dst) = self.bytes.get_mut(at..at + bytes.len()) {
            dst.copy_from_slice(bytes);
        }
        self.used = end;
        Ok(at as u16)
    }

    /// The path stored at `at`.
    fn get(&self, at: u16) -> &CStr {
        // The buffer is zeroed and every stored path is followed by its NUL.
        self.bytes
            .get(usize::from(at)..)
            .and_then(|b| CStr::from_bytes_until_nul(b).ok())
            .unwrap_or(c"")
    }
}

/// Appends the path stored at `at` to `list`, of which `count` are taken.
fn append(list: &mut [u16], count: &mut usize, at: u16) -> Result<(), UsageError> {
    *list.get_mut(*count).ok_or(UsageError::TooManyWindows)? = at;
    *count += 1;
    Ok(())
}

/// The word after an option (`--seed N`): missing is a usage error.
fn option_value<'a>(words: &mut impl Iterator<Item = &'a [u8]>) -> Result<&'a [u8], UsageError> {
    words.next().ok_or(UsageError::BadOption)
}

/// A decimal number of at most 19 digits (any `u64` below 10¹⁹); anything else is a usage
/// error. Written out rather than `str::parse`, whose generic radix code costs flash.
fn number(word: &[u8]) -> Result<u64, UsageError> {
    if word.is_empty() || word.len() > 19 {
        return Err(UsageError::BadOption);
    }
    word.iter().try_fold(0u64, |n, &b| match b {
        b'0'..=b'9' => Ok(n * 10 + u64::from(b - b'0')),
        _ => Err(UsageError::BadOption),
    })
}

/// Reads the record file at `path` (the actuator record, the GA checkpoint, or the health
/// store's image) into the start of `record`, and returns its length: an older version's
/// record is shorter than the buffer, and its reader tells it by its header (or, for the
/// health store, by its length). `Ok(None)` when there is no file (the first run), `Err`
/// with the file's length when it is longer than `record`.
pub fn read_record_file(path: &CStr, record: &mut [u8]) -> Result<Option<usize>, RecordFileError> {
    let Ok(mut file) = File::open(path) else {
        return Ok(None);
    };
    let len = file
        .metadata()
        .map(|m| m.len())
        .map_err(|_| RecordFileError::Io)?;
    let Some(into) = usize::try_from(len).ok().and_then(|n| record.get_mut(..n)) else {
        return Err(RecordFileError::Length { bytes: len });
    };
    file.read_exact(into).map_err(|_| RecordFileError::Io)?;
    Ok(Some(into.len()))
}

/// Replaces the record file at `path` with `record`.
pub fn write_record_file(path: &CStr, record: &[u8]) -> Result<(), RecordFileError> {
    let mut file = File::create(path).map_err(|_| RecordFileError::Io)?;
    write_all(&mut file, record).map_err(|_| RecordFileError::Io)
}

/// Writes all of `bytes` (SYS_WRITE may take part of them per call). Written out rather than
/// the crate's `write_all`: its slicing keeps a panic, and with it `core::fmt`, in the image.
pub fn write_all(out: &mut impl Write, mut bytes: &[u8]) -> Result<(), ()> {
    while !bytes.is_empty() {
        match out.write(bytes) {
            Ok(n) if n > 0 => bytes = bytes.get(n..).unwrap_or(&[]),
            _ => return Err(()),
        }
    }
    Ok(())
}

/// The host's command line (SYS_GET_CMDLINE) in `buf`, without its NUL; `None` when the host
/// gives none. Called directly rather than through the crate's `sys_get_cmdline_uninit`,
/// whose slicing keeps a panic in the image.
fn host_command_line(buf: &mut [u8; CMDLINE_BYTES]) -> Option<&[u8]> {
    // The parameter block: the buffer's address and its length, which the host overwrites
    // with the line's length.
    let mut block = [buf.as_mut_ptr() as usize, CMDLINE_BYTES];
    // SAFETY: the block points to a live buffer of the length it gives; the host writes at
    // most that many bytes into it and the line's length into the block.
    let ret = unsafe {
        syscall(
            OperationNumber::SYS_GET_CMDLINE,
            ParamRegW::ptr(block.as_mut_ptr()),
        )
    };
    if ret.usize() != 0 {
        return None;
    }
    let [_, length] = block;
    buf.get(..length)
}

/// Why a record file (checkpoint, health store) could not be used.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum RecordFileError {
    Io,
    /// Longer than a record, or (a health store) no version's image.
    Length {
        bytes: u64,
    },
}

/// Why the trace file could not be read.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum HostFileError {
    Open,
    Length,
    Read,
}

/// A file on the host, read through semihosting.
pub struct HostFile(File);

impl HostFile {
    pub fn open(path: &CStr) -> Result<Self, HostFileError> {
        File::open(path).map(Self).map_err(|_| HostFileError::Open)
    }
}

impl TraceBytes for HostFile {
    type Error = HostFileError;

    fn total_len(&mut self) -> Result<u64, HostFileError> {
        self.0
            .metadata()
            .map(|m| m.len())
            .map_err(|_| HostFileError::Length)
    }

    fn read_exact(&mut self, buf: &mut [u8]) -> Result<(), HostFileError> {
        self.0.read_exact(buf).map_err(|_| HostFileError::Read)
    }
}
