//! Emulation glue (QEMU with semihosting): the command line and the trace file on the host.
//!
//! `cargo fw -- TRACE.bin [--seed N]`: the runner (`firmware/qemu-run`) passes the ELF path
//! and these arguments through QEMU's semihosting command line; the trace is read with
//! SYS_OPEN / SYS_FLEN / SYS_READ, one row (24 B) per read.

use core::ffi::CStr;

use semihosting::experimental::env;
use semihosting::fs::File;
use semihosting::io::Read;

use firmware::TraceBytes;

/// Longest trace path accepted [bytes, NUL excluded].
pub const MAX_PATH: usize = 200;

/// Bytes of the semihosting command line buffer.
const CMDLINE_BYTES: usize = 512;

/// What the command line asked for.
pub struct Command {
    path: [u8; MAX_PATH + 1],
    pub seed: Option<u64>,
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
    NotUtf8,
    /// `--seed` without a number, or an unknown option.
    BadOption,
}

impl Command {
    /// Reads `PROGRAM TRACE.bin [--seed N] [--crash panic|hard-fault]` from the semihosting
    /// command line.
    pub fn from_host() -> Result<Self, UsageError> {
        let args = env::args::<CMDLINE_BYTES>().map_err(|_| UsageError::NoCommandLine)?;
        let mut words = (&args).skip(1);
        let mut path = [0u8; MAX_PATH + 1];
        let mut have_path = false;
        let mut seed = None;
        let mut crash = None;
        while let Some(word) = words.next() {
            let word = word.map_err(|_| UsageError::NotUtf8)?;
            if word == "--seed" {
                let n = words
                    .next()
                    .and_then(|w| w.ok())
                    .and_then(|w| w.parse::<u64>().ok())
                    .ok_or(UsageError::BadOption)?;
                seed = Some(n);
            } else if word == "--crash" {
                crash = match words.next().and_then(|w| w.ok()) {
                    Some("panic") => Some(Crash::Panic),
                    Some("hard-fault") => Some(Crash::HardFault),
                    _ => return Err(UsageError::BadOption),
                };
            } else if word.starts_with("--") || have_path {
                return Err(UsageError::BadOption);
            } else {
                let bytes = word.as_bytes();
                if bytes.len() > MAX_PATH {
                    return Err(UsageError::PathTooLong);
                }
                for (d, s) in path.iter_mut().zip(bytes) {
                    *d = *s;
                }
                have_path = true;
            }
        }
        if !have_path && crash.is_none() {
            return Err(UsageError::MissingTrace);
        }
        Ok(Self { path, seed, crash })
    }

    /// The trace path, NUL-terminated.
    pub fn trace_path(&self) -> &CStr {
        // The buffer is zeroed and at most MAX_PATH bytes are written: a NUL always follows.
        CStr::from_bytes_until_nul(&self.path).unwrap_or(c"")
    }
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
