//! Trace files: one row per control period (10 kHz), SI units.
//!
//! * **CSV** — header `t,theta_cmd,i_a,i_b,i_c,theta_m,theta_u`: time [s], commanded user
//!   angle [rad], phase currents [A], motor-shaft angle [rad], user-shaft angle [rad]. Values
//!   are printed in Rust's shortest round-trip form, so reading gives back the same `f64`s.
//!   Version 2: a first line `# test: NAME` names the test design (`standstill`: the
//!   standstill segment's rows first, then the chirp's); without it (version 1) the trace is
//!   the paper's test. `pandas.read_csv(f, comment="#")` reads both.
//! * **Binary** — `shared::trace` format v1 (the paper's test) or v2 (the design in the
//!   header): header, fixed-point rows, CRC-32; what the firmware reads. Time is implied by
//!   the row index and the sample rate.
//!
//! Reading detects the form from the first bytes (`EMAT` = binary). Both forms condition into
//! the same bits: values go through `shared::trace::TraceRow::from_f64` either way.

use std::fmt;
use std::io::{Read, Write};
use std::path::Path;

use anyhow::{bail, Context, Result};

/// The CSV `# test:` name of a window of flight.
pub const FLIGHT_TEST: &str = "flight";
use fixed::types::{I16F16, I4F28};
use shared::domain::DomainMonitor;
use shared::fdi::{OnboardMeasured, TEST_SAMPLES};
use shared::test_design::PreflightTest;
use shared::trace::{
    ConditionReading, Crc32, SaturationCheck, TraceError, TraceHeader, TraceRow,
    CURRENT_FULL_SCALE, HEADER_BYTES, MAGIC, SATURATION_RUN, TRAILER_BYTES,
};
use shared::{ActuatorParams, LowPass};

/// The CSV header, column for column.
pub const CSV_HEADER: [&str; 7] = ["t", "theta_cmd", "i_a", "i_b", "i_c", "theta_m", "theta_u"];
/// The optional columns of version 3 (both or neither): what the controller measured of its
/// day, the DC bus voltage [V] and a temperature [°C].
pub const CONDITION_HEADER: [&str; 2] = ["v_bus", "temp"];

/// Sample rate of every trace this project writes [Hz].
pub const SAMPLE_RATE_HZ: u32 = 10_000;

/// One row of a trace.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TraceSample {
    pub time: f64,
    pub command: f64,
    pub phase_currents: [f64; 3],
    pub motor_angle: f64,
    pub user_angle: f64,
    /// DC bus voltage the controller measured [V], where the trace carries it.
    pub bus_voltage: Option<f64>,
    /// Temperature the controller measured [°C], where the trace carries it.
    pub temperature: Option<f64>,
}

impl TraceSample {
    /// The stored fixed-point form (the firmware's view).
    pub fn row(&self) -> TraceRow {
        let row = TraceRow::from_f64(
            self.command,
            self.phase_currents,
            self.motor_angle,
            self.user_angle,
        );
        match (self.bus_voltage, self.temperature) {
            (Some(v), Some(t)) => row.with_conditions(ConditionReading::from_f64(v, t)),
            _ => row,
        }
    }
}

/// A whole test.
#[derive(Clone, Debug, PartialEq)]
pub struct Trace {
    samples: Vec<TraceSample>,
    test: PreflightTest,
    /// A window of flight (CSV `# test: flight`): the chirp on the flight's commands, read by
    /// the window identification.
    flight: bool,
}

impl Default for Trace {
    /// An empty trace of the paper's test.
    fn default() -> Self {
        Self::with_capacity(0)
    }
}

/// On-disk form of a trace.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum TraceFormat {
    Csv,
    Bin,
}

impl fmt::Display for TraceFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Csv => "csv",
            Self::Bin => "bin",
        })
    }
}

impl Trace {
    /// An empty trace of the paper's test.
    pub fn with_capacity(n: usize) -> Self {
        Self {
            samples: Vec::with_capacity(n),
            test: PreflightTest::PAPER,
            flight: false,
        }
    }

    /// The same trace, declared a window of flight.
    pub fn as_flight(mut self) -> Self {
        self.flight = true;
        self
    }

    /// Whether the trace is a window of flight.
    pub fn is_flight(&self) -> bool {
        self.flight
    }

    /// The same trace, declared as coming from `test`.
    pub fn with_test(mut self, test: PreflightTest) -> Self {
        self.test = test;
        self
    }

    /// The same trace without the bus and temperature readings (what versions 1 and 2 hold).
    pub fn without_conditions(mut self) -> Self {
        for s in &mut self.samples {
            s.bus_voltage = None;
            s.temperature = None;
        }
        self
    }

    /// Whether every sample carries the bus voltage and temperature (version 3).
    pub fn has_conditions(&self) -> bool {
        !self.samples.is_empty()
            && self
                .samples
                .iter()
                .all(|s| s.bus_voltage.is_some() && s.temperature.is_some())
    }

    /// The test design the samples come from.
    pub fn test(&self) -> &PreflightTest {
        &self.test
    }

    /// The samples of the chirp (after any standstill segment).
    pub fn chirp_samples(&self) -> &[TraceSample] {
        let lead = self.test.lead_samples().min(self.samples.len());
        &self.samples[lead..]
    }

    pub fn push(&mut self, s: TraceSample) {
        self.samples.push(s);
    }

    pub fn samples(&self) -> &[TraceSample] {
        &self.samples
    }

    /// The domain statistics of this test ([`shared::domain`]), as the controller gathers
    /// them frame by frame against the test's chirp.
    pub fn domain_monitor(&self, params: &ActuatorParams) -> DomainMonitor {
        let mut monitor = DomainMonitor::new(self.test.chirp, params);
        for s in self.chirp_samples() {
            monitor.push(&s.row().adc_frame());
        }
        monitor
    }

    /// Conditions the trace exactly as the controller does: fixed-point ADC frames →
    /// equivalent current → low-pass → eq. (3) normalisation.
    pub fn measured(&self, params: &ActuatorParams) -> Result<Box<OnboardMeasured>> {
        let filter = LowPass::for_control_period(params.control_period)
            .map_err(|e| anyhow::anyhow!("conditioning filter: {e:?}"))?;
        let mut measured = Box::new(OnboardMeasured::for_test(filter, self.test));
        let capacity = shared::fdi::TEST_SAMPLES;
        if self.samples.len() > capacity {
            bail!(
                "the trace has {} samples; the onboard buffer holds {capacity}",
                self.samples.len()
            );
        }
        for s in &self.samples {
            if measured
                .push_frame(s.row().adc_frame(), params.pole_pairs)
                .is_err()
            {
                bail!("the onboard buffer is full");
            }
        }
        measured.finish().map_err(|e| match e {
            shared::conditioning::ConditioningError::TooFewSamples { have, need } => {
                anyhow::anyhow!("the trace has {have} samples; the fitness needs at least {need}")
            }
            other => anyhow::anyhow!("conditioning the trace: {other:?}"),
        })?;
        Ok(measured)
    }

    pub fn write(&self, path: &Path, format: TraceFormat) -> Result<()> {
        let bytes = match format {
            TraceFormat::Csv => self.to_csv(),
            TraceFormat::Bin => self.to_bin()?,
        };
        std::fs::write(path, bytes).with_context(|| format!("writing {}", path.display()))
    }

    pub fn to_csv(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(80 * (self.samples.len() + 2));
        if self.flight {
            let _ = writeln!(out, "# test: {FLIGHT_TEST}");
        } else if self.test != PreflightTest::PAPER {
            let name = self.test.kind_name();
            let _ = writeln!(out, "# test: {name}");
        }
        let conditions = self.has_conditions();
        let _ = write!(out, "{}", CSV_HEADER.join(","));
        if conditions {
            let _ = write!(out, ",{}", CONDITION_HEADER.join(","));
        }
        let _ = writeln!(out);
        for s in &self.samples {
            let [a, b, c] = s.phase_currents;
            let _ = write!(
                out,
                "{},{},{},{},{},{},{}",
                s.time, s.command, a, b, c, s.motor_angle, s.user_angle
            );
            if let (true, Some(v), Some(t)) = (conditions, s.bus_voltage, s.temperature) {
                let _ = write!(out, ",{v},{t}");
            }
            let _ = writeln!(out);
        }
        out
    }

    pub fn to_bin(&self) -> Result<Vec<u8>> {
        let rows = u32::try_from(self.samples.len()).context("too many rows for format v1")?;
        let conditions = self.has_conditions();
        let header = TraceHeader {
            sample_rate_hz: SAMPLE_RATE_HZ,
            rows,
            test: self.test,
            conditions,
            flight: self.flight,
        };
        let mut out = Vec::with_capacity(header.file_bytes() as usize);
        out.extend_from_slice(
            &header
                .encode()
                .map_err(|_| anyhow::anyhow!("this test design has no code in format v2"))?,
        );
        for s in &self.samples {
            let row = if conditions {
                s.row()
            } else {
                TraceRow {
                    conditions: None,
                    ..s.row()
                }
            };
            out.extend_from_slice(row.encode().as_slice());
        }
        let mut crc = Crc32::new();
        crc.update(&out);
        out.extend_from_slice(&crc.finish().to_le_bytes());
        Ok(out)
    }

    /// Reads a CSV or binary trace (detected from the first bytes) and checks it
    /// ([`IngestError`] lists every refusal).
    pub fn read(path: &Path) -> Result<Self> {
        let mut file = std::fs::File::open(path)
            .with_context(|| format!("cannot open trace {}", path.display()))?;
        let mut bytes = Vec::new();
        file.read_to_end(&mut bytes)
            .with_context(|| format!("reading {}", path.display()))?;
        Self::from_bytes(&bytes)
            .map_err(anyhow::Error::new)
            .with_context(|| format!("trace {} refused", path.display()))
    }

    /// A trace from a file's bytes: binary if they start with `EMAT` or are not text, CSV
    /// otherwise.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, IngestError> {
        if bytes.starts_with(&MAGIC) || looks_binary(bytes) {
            Self::from_bin(bytes)
        } else {
            Self::from_csv(bytes)
        }
    }

    pub fn from_bin(bytes: &[u8]) -> Result<Self, IngestError> {
        let Some(head) = bytes.first_chunk::<HEADER_BYTES>() else {
            return Err(IngestError::Truncated {
                bytes: bytes.len() as u64,
                need: (HEADER_BYTES + TRAILER_BYTES) as u64,
            });
        };
        let header = TraceHeader::decode(head).map_err(|e| match e {
            TraceError::BadMagic => IngestError::BadMagic {
                found: [head[0], head[1], head[2], head[3]],
            },
            TraceError::UnsupportedVersion { found } => IngestError::UnsupportedVersion { found },
            TraceError::BadColumns { found } => IngestError::BadColumnCount { found },
            TraceError::UnknownTest { code } => IngestError::UnknownTest {
                line: 0,
                name: format!("code {code}"),
            },
            other => IngestError::Binary(other),
        })?;
        let need = header.file_bytes();
        let have = bytes.len() as u64;
        if have < need {
            return Err(IngestError::Truncated { bytes: have, need });
        }
        if have > need {
            return Err(IngestError::TrailingBytes {
                extra: have - need,
                rows: header.rows,
            });
        }
        if header.sample_rate_hz != SAMPLE_RATE_HZ {
            return Err(IngestError::WrongSampleRate {
                found_hz: f64::from(header.sample_rate_hz),
            });
        }
        let body_end = bytes.len() - TRAILER_BYTES;
        let (body, trailer) = bytes.split_at(body_end);
        let mut crc = Crc32::new();
        crc.update(body);
        let stored = u32::from_le_bytes([trailer[0], trailer[1], trailer[2], trailer[3]]);
        if stored != crc.finish() {
            return Err(IngestError::BadChecksum {
                stored,
                computed: crc.finish(),
            });
        }
        let rate = f64::from(header.sample_rate_hz);
        let samples = body[HEADER_BYTES..]
            .chunks_exact(header.row_bytes())
            .enumerate()
            .map(|(k, chunk)| {
                let r = TraceRow::decode(chunk);
                TraceSample {
                    time: k as f64 / rate,
                    command: r.command.to_num(),
                    phase_currents: r.phase_currents.map(|x| x.to_num()),
                    motor_angle: r.motor_angle.to_num(),
                    user_angle: r.user_angle.to_num(),
                    bus_voltage: r.conditions.map(|c| c.bus_voltage.to_num()),
                    temperature: r.conditions.map(|c| c.temperature.to_num()),
                }
            })
            .collect();
        let trace = Self {
            samples,
            test: header.test,
            flight: header.flight,
        };
        trace.check(Form::Binary)?;
        Ok(trace)
    }

    /// Reads the CSV form. The header names the columns, in any order; each must appear
    /// exactly once.
    pub fn from_csv(bytes: &[u8]) -> Result<Self, IngestError> {
        let text = match std::str::from_utf8(bytes) {
            Ok(t) => t,
            Err(e) => {
                let line = 1 + bytes[..e.valid_up_to()]
                    .iter()
                    .filter(|&&b| b == b'\n')
                    .count();
                return Err(IngestError::NotText { line });
            }
        };
        let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l));
        // Comment lines before the header; `# test: NAME` names the design (version 2).
        let mut test = PreflightTest::PAPER;
        let mut flight = false;
        let (header_line, header) = loop {
            let Some((line, l)) = lines.find(|(_, l)| !l.trim().is_empty()) else {
                return Err(IngestError::Empty);
            };
            let Some(comment) = l.trim().strip_prefix('#') else {
                break (line, l);
            };
            if let Some(name) = comment.trim().strip_prefix("test:") {
                let name = name.trim();
                if name == FLIGHT_TEST {
                    // The chirp alone, on the flight's commands.
                    flight = true;
                    continue;
                }
                test = PreflightTest::from_name(name).ok_or_else(|| IngestError::UnknownTest {
                    line,
                    name: name.to_string(),
                })?;
            }
        };
        // Where each CSV_HEADER (then CONDITION_HEADER) column sits in the file.
        let names: Vec<&str> = header.split(',').map(str::trim).collect();
        let all: Vec<&'static str> = CSV_HEADER
            .iter()
            .chain(&CONDITION_HEADER)
            .copied()
            .collect();
        let mut position = [usize::MAX; 9];
        for (at, name) in names.iter().enumerate() {
            let Some(j) = all.iter().position(|c| c == name) else {
                return Err(IngestError::UnknownColumn {
                    name: (*name).to_string(),
                    position: at + 1,
                });
            };
            if position[j] != usize::MAX {
                return Err(IngestError::DuplicateColumn { name: all[j] });
            }
            position[j] = at;
        }
        // The conditions come as a pair: one without the other is a missing column.
        let conditions = position[7..].iter().any(|&p| p != usize::MAX);
        let needed = if conditions { 9 } else { 7 };
        if let Some(j) = position[..needed].iter().position(|&p| p == usize::MAX) {
            return Err(IngestError::MissingColumn { name: all[j] });
        }
        let mut samples = Vec::new();
        for (line, text) in lines {
            if text.trim().is_empty() {
                continue;
            }
            if samples.len() > TEST_SAMPLES {
                // Enough to know it is too long; stop parsing.
                return Err(IngestError::TooManySamples {
                    have: samples.len(),
                    capacity: TEST_SAMPLES,
                });
            }
            let cells: Vec<&str> = text.split(',').map(str::trim).collect();
            if cells.len() < names.len() {
                return Err(IngestError::MissingCells {
                    line,
                    found: cells.len(),
                    expected: names.len(),
                });
            }
            if cells.len() > names.len() {
                return Err(IngestError::ExtraCells {
                    line,
                    found: cells.len(),
                    expected: names.len(),
                });
            }
            let mut v = [0.0f64; 9];
            for ((slot, &at), &column) in v.iter_mut().zip(&position[..needed]).zip(&all) {
                let cell = cells[at];
                let x: f64 = cell.parse().map_err(|_| IngestError::NotNumeric {
                    line,
                    column,
                    cell: cell.to_string(),
                })?;
                if !x.is_finite() {
                    return Err(IngestError::NotFinite {
                        line,
                        column,
                        cell: cell.to_string(),
                    });
                }
                *slot = x;
            }
            samples.push(TraceSample {
                time: v[0],
                command: v[1],
                phase_currents: [v[2], v[3], v[4]],
                motor_angle: v[5],
                user_angle: v[6],
                bus_voltage: conditions.then_some(v[7]),
                temperature: conditions.then_some(v[8]),
            });
        }
        let trace = Self {
            samples,
            test,
            flight,
        };
        trace.check(Form::Csv { header_line })?;
        Ok(trace)
    }

    /// The checks a binary trace gets (sample count, fixed-point range, no clipped current
    /// stretch), for a trace built in memory (e.g. from a rig recording).
    pub fn checked(self) -> Result<Self, IngestError> {
        self.check(Form::Binary)?;
        Ok(self)
    }

    /// What both forms must satisfy: sample count, time base, fixed-point range, no clipped
    /// current stretch.
    fn check(&self, form: Form) -> Result<(), IngestError> {
        let n = self.samples.len();
        let need = OnboardMeasured::MIN_SAMPLES + self.test.lead_samples();
        if n < need {
            return Err(IngestError::TooFewSamples { have: n, need });
        }
        let capacity = self
            .test
            .samples(1.0 / SAMPLE_RATE_HZ as f32)
            .min(TEST_SAMPLES);
        if n > capacity {
            return Err(IngestError::TooManySamples { have: n, capacity });
        }
        if let Form::Csv { .. } = form {
            check_time_base(&self.samples)?;
        }
        let mut saturation = SaturationCheck::new();
        for (row, s) in self.samples.iter().enumerate() {
            let line = form.line(row);
            let angle_limit = f64::from(I4F28::MAX);
            let wide_limit = f64::from(I16F16::MAX);
            let [a, b, c] = s.phase_currents;
            let ranged = [
                ("theta_cmd", s.command, angle_limit),
                ("i_a", a, wide_limit),
                ("i_b", b, wide_limit),
                ("i_c", c, wide_limit),
                ("theta_m", s.motor_angle, wide_limit),
                ("theta_u", s.user_angle, angle_limit),
            ];
            for (column, value, limit) in ranged {
                if value.abs() >= limit {
                    return Err(IngestError::OutOfRange {
                        line,
                        column,
                        value,
                        limit,
                    });
                }
            }
            if let Err(TraceError::SaturatedCurrent { phase, first_row }) =
                saturation.push(&s.row().adc_frame())
            {
                let first_row = first_row as usize;
                return Err(IngestError::SaturatedCurrent {
                    column: CSV_HEADER[2 + usize::from(phase).min(2)],
                    first_line: form.line(first_row),
                    first_row,
                    samples: SATURATION_RUN as usize,
                });
            }
        }
        Ok(())
    }
}

/// A NUL or other control byte (not tab, CR, LF) in the first 64 bytes: not a CSV.
fn looks_binary(bytes: &[u8]) -> bool {
    bytes
        .iter()
        .take(64)
        .any(|&b| b < 0x20 && !matches!(b, b'\t' | b'\n' | b'\r'))
}

/// Which form a trace was read from (for error locations).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Form {
    /// The header on this 1-based line.
    Csv {
        header_line: usize,
    },
    Binary,
}

impl Form {
    /// The 1-based line of sample `row` in a CSV; `0` for a binary.
    fn line(self, row: usize) -> usize {
        match self {
            Self::Csv { header_line } => header_line + 1 + row,
            Self::Binary => 0,
        }
    }
}

/// Why a trace file was refused. Every variant names the field, and the line (CSV, 1-based,
/// the header is line 1) or the row (sample index from 0) where it applies.
#[derive(Clone, Debug, PartialEq)]
pub enum IngestError {
    /// No bytes, or only blank lines.
    Empty,
    /// A CSV line that is not UTF-8 text.
    NotText {
        line: usize,
    },
    /// A header name that is not one of [`CSV_HEADER`] (an extra column, or a typo).
    UnknownColumn {
        name: String,
        position: usize,
    },
    DuplicateColumn {
        name: &'static str,
    },
    MissingColumn {
        name: &'static str,
    },
    /// A row with fewer cells than the header.
    MissingCells {
        line: usize,
        found: usize,
        expected: usize,
    },
    /// A row with more cells than the header.
    ExtraCells {
        line: usize,
        found: usize,
        expected: usize,
    },
    NotNumeric {
        line: usize,
        column: &'static str,
        cell: String,
    },
    /// NaN or ±∞.
    NotFinite {
        line: usize,
        column: &'static str,
        cell: String,
    },
    /// A value the controller's fixed-point words cannot hold (|θ| ≥ 8 rad for the user and
    /// commanded angles, ≥ 32 768 for the currents and the motor angle).
    OutOfRange {
        line: usize,
        column: &'static str,
        value: f64,
        limit: f64,
    },
    /// The first sample is not at t = 0.
    TimeOrigin {
        time: f64,
    },
    /// Time stands still or goes back.
    TimeNotIncreasing {
        line: usize,
        time: f64,
        previous: f64,
    },
    /// A row off the 10 kHz grid (a dropped or repeated sample, jitter beyond 1 % of a period).
    IrregularTime {
        line: usize,
        time: f64,
        expected: f64,
    },
    /// A regular trace at another rate than 10 kHz.
    WrongSampleRate {
        found_hz: f64,
    },
    TooFewSamples {
        have: usize,
        need: usize,
    },
    /// More samples than the onboard buffer holds: refused, never truncated.
    TooManySamples {
        have: usize,
        capacity: usize,
    },
    /// A binary trace shorter than its header announces (or than a header).
    Truncated {
        bytes: u64,
        need: u64,
    },
    /// Bytes after the checksum the header announces.
    TrailingBytes {
        extra: u64,
        rows: u32,
    },
    /// Not a binary trace: the first four bytes are not `EMAT`.
    BadMagic {
        found: [u8; 4],
    },
    UnsupportedVersion {
        found: u16,
    },
    /// A binary header announcing another number of columns than 6.
    BadColumnCount {
        found: u16,
    },
    BadChecksum {
        stored: u32,
        computed: u32,
    },
    /// A phase current at the ADC's full scale for [`SATURATION_RUN`] samples in a row.
    SaturatedCurrent {
        column: &'static str,
        first_row: usize,
        /// CSV line of `first_row` (0 for a binary trace).
        first_line: usize,
        samples: usize,
    },
    /// Any other refusal of the binary format.
    /// A test design this code does not know (CSV `# test:` line; line 0 for a binary
    /// header's code).
    UnknownTest {
        line: usize,
        name: String,
    },
    Binary(TraceError),
}

impl IngestError {
    /// A short stable name per kind (tests, JSON).
    pub fn kind(&self) -> &'static str {
        match self {
            Self::Empty => "empty",
            Self::NotText { .. } => "not-text",
            Self::UnknownColumn { .. } => "unknown-column",
            Self::DuplicateColumn { .. } => "duplicate-column",
            Self::MissingColumn { .. } => "missing-column",
            Self::MissingCells { .. } => "missing-cells",
            Self::ExtraCells { .. } => "extra-cells",
            Self::NotNumeric { .. } => "not-numeric",
            Self::NotFinite { .. } => "not-finite",
            Self::OutOfRange { .. } => "out-of-range",
            Self::TimeOrigin { .. } => "time-origin",
            Self::TimeNotIncreasing { .. } => "time-not-increasing",
            Self::IrregularTime { .. } => "irregular-time",
            Self::WrongSampleRate { .. } => "wrong-sample-rate",
            Self::TooFewSamples { .. } => "too-few-samples",
            Self::TooManySamples { .. } => "too-many-samples",
            Self::Truncated { .. } => "truncated",
            Self::TrailingBytes { .. } => "trailing-bytes",
            Self::BadMagic { .. } => "bad-magic",
            Self::UnsupportedVersion { .. } => "unsupported-version",
            Self::BadColumnCount { .. } => "bad-column-count",
            Self::BadChecksum { .. } => "bad-checksum",
            Self::SaturatedCurrent { .. } => "saturated-current",
            Self::UnknownTest { .. } => "unknown-test",
            Self::Binary(_) => "binary",
        }
    }
}

impl fmt::Display for IngestError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let header = CSV_HEADER.join(",");
        match self {
            Self::Empty => write!(f, "empty file: expected the CSV header `{header}` or a binary trace"),
            Self::NotText { line } => write!(f, "line {line}: not UTF-8 text"),
            Self::UnknownColumn { name, position } => write!(
                f,
                "line 1, column {position}: unknown column `{name}` (the columns are `{header}`)"
            ),
            Self::DuplicateColumn { name } => write!(f, "line 1: column `{name}` appears twice"),
            Self::MissingColumn { name } => {
                write!(f, "line 1: column `{name}` is missing (the columns are `{header}`)")
            }
            Self::MissingCells { line, found, expected } => {
                write!(f, "line {line}: {found} cells, the header has {expected}")
            }
            Self::ExtraCells { line, found, expected } => {
                write!(f, "line {line}: {found} cells, the header has only {expected}")
            }
            Self::NotNumeric { line, column, cell } => {
                write!(f, "line {line}, column {column}: `{cell}` is not a number")
            }
            Self::NotFinite { line, column, cell } => {
                write!(f, "line {line}, column {column}: `{cell}` is not finite")
            }
            Self::OutOfRange { line, column, value, limit } => write!(
                f,
                "{}column {column}: {value} is outside the controller's range (±{limit})",
                at_line(*line)
            ),
            Self::TimeOrigin { time } => {
                write!(f, "line 2, column t: the first sample is at {time} s, expected 0")
            }
            Self::TimeNotIncreasing { line, time, previous } => write!(
                f,
                "line {line}, column t: {time} s does not follow {previous} s (time must increase)"
            ),
            Self::IrregularTime { line, time, expected } => write!(
                f,
                "line {line}, column t: {time} s, expected {expected} s (one row per 100 µs: a \
                 dropped, repeated or jittered sample)"
            ),
            Self::WrongSampleRate { found_hz } => write!(
                f,
                "sampled at {found_hz} Hz; the FDI is built for {SAMPLE_RATE_HZ} Hz traces"
            ),
            Self::TooFewSamples { have, need } => write!(
                f,
                "{have} samples; the fitness needs at least {need} (0.1 s at 10 kHz)"
            ),
            Self::TooManySamples { have, capacity } => write!(
                f,
                "more than {capacity} samples ({have} read so far); the onboard buffer holds \
                 {capacity} (0.5 s at 10 kHz), and a trace is refused, never truncated"
            ),
            Self::Truncated { bytes, need } => write!(
                f,
                "binary trace truncated: {bytes} bytes, the header announces {need}"
            ),
            Self::TrailingBytes { extra, rows } => write!(
                f,
                "binary trace has {extra} bytes after the checksum of its {rows} rows"
            ),
            Self::BadMagic { found } => write!(
                f,
                "not a trace: starts with {found:02x?}, a binary trace starts with `EMAT`"
            ),
            Self::UnsupportedVersion { found } => write!(
                f,
                "binary trace format version {found}; this tool reads version {}",
                shared::trace::VERSION
            ),
            Self::BadColumnCount { found } => write!(
                f,
                "binary trace header announces {found} columns per row; format v1 has {}",
                shared::trace::COLUMNS
            ),
            Self::BadChecksum { stored, computed } => write!(
                f,
                "binary trace checksum mismatch (stored {stored:#010x}, computed {computed:#010x}): \
                 the file is damaged"
            ),
            Self::SaturatedCurrent { column, first_row, first_line, samples } => write!(
                f,
                "{}column {column}: the current ADC clipped at full scale (±{} A) for {samples} \
                 samples in a row from sample {first_row} (t = {} s): the real current is unknown",
                at_line(*first_line),
                CURRENT_FULL_SCALE,
                *first_row as f64 / f64::from(SAMPLE_RATE_HZ)
            ),
            Self::UnknownTest { line, name } => write!(
                f,
                "{}unknown test design `{name}` (known: {})",
                if *line > 0 { format!("line {line}: ") } else { "header: ".into() },
                shared::test_design::TEST_NAMES.join(", ")
            ),
            Self::Binary(e) => write!(f, "binary trace refused: {e:?}"),
        }
    }
}

impl std::error::Error for IngestError {}

/// "line N, " for a CSV location; nothing for a binary trace (line 0).
fn at_line(line: usize) -> String {
    if line == 0 {
        String::new()
    } else {
        format!("line {line}, ")
    }
}

/// Time must start at 0 and advance by one 10 kHz period per row (±1 % of a period).
fn check_time_base(samples: &[TraceSample]) -> Result<(), IngestError> {
    let rate = f64::from(SAMPLE_RATE_HZ);
    let dt = 1.0 / rate;
    let tolerance = 0.01 * dt;
    let Some(first) = samples.first() else {
        return Ok(());
    };
    if first.time.abs() > tolerance {
        return Err(IngestError::TimeOrigin { time: first.time });
    }
    // A regular trace at another rate: say so rather than point at line 3.
    if let Some(second) = samples.get(1) {
        let step = second.time - first.time;
        let regular = samples
            .iter()
            .enumerate()
            .all(|(k, s)| (s.time - k as f64 * step).abs() <= 0.01 * step.abs());
        if step > 0.0 && (step - dt).abs() > tolerance && regular {
            return Err(IngestError::WrongSampleRate {
                found_hz: (1.0 / step * 1000.0).round() / 1000.0,
            });
        }
    }
    // Order first (a swapped pair is "not increasing", not "irregular"), then the grid.
    for (k, pair) in samples.windows(2).enumerate() {
        let (previous, time) = (pair[0].time, pair[1].time);
        if time <= previous {
            return Err(IngestError::TimeNotIncreasing {
                line: k + 3,
                time,
                previous,
            });
        }
    }
    for (row, s) in samples.iter().enumerate() {
        let expected = row as f64 / rate;
        if (s.time - expected).abs() > tolerance {
            return Err(IngestError::IrregularTime {
                line: row + 2,
                time: s.time,
                expected,
            });
        }
    }
    Ok(())
}
