//! Trace files: one row per control period (10 kHz), SI units.
//!
//! * **CSV** — header `t,theta_cmd,i_a,i_b,i_c,theta_m,theta_u`: time [s], commanded user
//!   angle [rad], phase currents [A], motor-shaft angle [rad], user-shaft angle [rad]. Values
//!   are printed in Rust's shortest round-trip form, so reading gives back the same `f64`s.
//!   `pandas.read_csv` reads it as is.
//! * **Binary** — `shared::trace` format v1 (header, fixed-point rows, CRC-32); what the
//!   firmware reads. Time is implied by the row index and the sample rate.
//!
//! Reading detects the form from the first bytes (`EMAT` = binary). Both forms condition into
//! the same bits: values go through `shared::trace::TraceRow::from_f64` either way.

use std::fmt;
use std::io::{BufRead, BufReader, Read, Write};
use std::path::Path;

use anyhow::{bail, Context, Result};
use shared::fdi::OnboardMeasured;
use shared::trace::{Crc32, TraceHeader, TraceRow, HEADER_BYTES, MAGIC, ROW_BYTES, TRAILER_BYTES};
use shared::{ActuatorParams, LowPass};

/// The CSV header, column for column.
pub const CSV_HEADER: [&str; 7] = ["t", "theta_cmd", "i_a", "i_b", "i_c", "theta_m", "theta_u"];

/// Sample rate of every trace this project writes [Hz].
pub const SAMPLE_RATE_HZ: u32 = 10_000;

/// One row of a trace.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct TraceSample {
    pub time: f64,
    pub command: f64,
    pub phase_currents: [f64; 3],
    pub motor_angle: f64,
    pub user_angle: f64,
}

impl TraceSample {
    /// The stored fixed-point form (the firmware's view).
    pub fn row(&self) -> TraceRow {
        TraceRow::from_f64(
            self.command,
            self.phase_currents,
            self.motor_angle,
            self.user_angle,
        )
    }
}

/// A whole test.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Trace {
    samples: Vec<TraceSample>,
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
    pub fn with_capacity(n: usize) -> Self {
        Self {
            samples: Vec::with_capacity(n),
        }
    }

    pub fn push(&mut self, s: TraceSample) {
        self.samples.push(s);
    }

    pub fn samples(&self) -> &[TraceSample] {
        &self.samples
    }

    /// Conditions the trace exactly as the controller does: fixed-point ADC frames →
    /// equivalent current → low-pass → eq. (3) normalisation.
    pub fn measured(&self, params: &ActuatorParams) -> Result<Box<OnboardMeasured>> {
        let filter = LowPass::for_control_period(params.control_period)
            .map_err(|e| anyhow::anyhow!("conditioning filter: {e:?}"))?;
        let mut measured = Box::new(OnboardMeasured::new(filter));
        let capacity = shared::fdi::TEST_SAMPLES;
        if self.samples.len() > capacity {
            bail!(
                "the trace has {} samples; the onboard buffer holds {capacity} (0.5 s at 10 kHz)",
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
        let mut out = Vec::with_capacity(80 * (self.samples.len() + 1));
        let _ = writeln!(out, "{}", CSV_HEADER.join(","));
        for s in &self.samples {
            let [a, b, c] = s.phase_currents;
            let _ = writeln!(
                out,
                "{},{},{},{},{},{},{}",
                s.time, s.command, a, b, c, s.motor_angle, s.user_angle
            );
        }
        out
    }

    pub fn to_bin(&self) -> Result<Vec<u8>> {
        let rows = u32::try_from(self.samples.len()).context("too many rows for format v1")?;
        let header = TraceHeader {
            sample_rate_hz: SAMPLE_RATE_HZ,
            rows,
        };
        let mut out = Vec::with_capacity(header.file_bytes() as usize);
        out.extend_from_slice(&header.encode());
        for s in &self.samples {
            out.extend_from_slice(&s.row().encode());
        }
        let mut crc = Crc32::new();
        crc.update(&out);
        out.extend_from_slice(&crc.finish().to_le_bytes());
        Ok(out)
    }

    /// Reads a CSV or binary trace (detected from the first bytes).
    pub fn read(path: &Path) -> Result<Self> {
        let mut file = std::fs::File::open(path)
            .with_context(|| format!("cannot open trace {}", path.display()))?;
        let mut bytes = Vec::new();
        file.read_to_end(&mut bytes)
            .with_context(|| format!("reading {}", path.display()))?;
        let parsed = if bytes.starts_with(&MAGIC) {
            Self::from_bin(&bytes)
        } else {
            Self::from_csv(&bytes)
        };
        parsed.with_context(|| format!("trace {}", path.display()))
    }

    pub fn from_bin(bytes: &[u8]) -> Result<Self> {
        let Some(head) = bytes.first_chunk::<HEADER_BYTES>() else {
            bail!(
                "binary trace truncated: {} bytes, the header alone is {HEADER_BYTES}",
                bytes.len()
            );
        };
        let header = TraceHeader::decode(head).map_err(|e| anyhow::anyhow!("{e:?}"))?;
        header
            .check_length(bytes.len() as u64)
            .map_err(|e| anyhow::anyhow!("binary trace length: {e:?}"))?;
        if header.sample_rate_hz != SAMPLE_RATE_HZ {
            bail!(
                "sample rate {} Hz; this tool reads {SAMPLE_RATE_HZ} Hz traces",
                header.sample_rate_hz
            );
        }
        let body_end = bytes.len() - TRAILER_BYTES;
        let mut crc = Crc32::new();
        crc.update(&bytes[..body_end]);
        let stored = u32::from_le_bytes(
            bytes[body_end..]
                .try_into()
                .context("checksum trailer missing")?,
        );
        if stored != crc.finish() {
            bail!(
                "binary trace checksum mismatch (stored {stored:#010x}, computed {:#010x})",
                crc.finish()
            );
        }
        let rate = f64::from(header.sample_rate_hz);
        let samples = bytes[HEADER_BYTES..body_end]
            .chunks_exact(ROW_BYTES)
            .enumerate()
            .map(|(k, chunk)| {
                let mut raw = [0u8; ROW_BYTES];
                raw.copy_from_slice(chunk);
                let r = TraceRow::decode(&raw);
                TraceSample {
                    time: k as f64 / rate,
                    command: r.command.to_num(),
                    phase_currents: r.phase_currents.map(|x| x.to_num()),
                    motor_angle: r.motor_angle.to_num(),
                    user_angle: r.user_angle.to_num(),
                }
            })
            .collect();
        Ok(Self { samples })
    }

    pub fn from_csv(bytes: &[u8]) -> Result<Self> {
        let mut lines = BufReader::new(bytes).lines().enumerate();
        let Some((_, header)) = lines.next() else {
            bail!(
                "empty file: expected the CSV header {}",
                CSV_HEADER.join(",")
            );
        };
        let header = header.context("the CSV header is not UTF-8 text")?;
        let columns: Vec<&str> = header.trim().split(',').map(str::trim).collect();
        if columns != CSV_HEADER {
            bail!(
                "CSV header is `{}`; expected `{}`",
                header.trim(),
                CSV_HEADER.join(",")
            );
        }
        let mut samples = Vec::new();
        for (index, line) in lines {
            let line_no = index + 1;
            let line = line.with_context(|| format!("line {line_no}: not UTF-8 text"))?;
            if line.trim().is_empty() {
                continue;
            }
            let cells: Vec<&str> = line.split(',').map(str::trim).collect();
            if cells.len() != CSV_HEADER.len() {
                bail!(
                    "line {line_no}: {} columns, expected {}",
                    cells.len(),
                    CSV_HEADER.len()
                );
            }
            let mut v = [0.0f64; 7];
            for (j, (slot, cell)) in v.iter_mut().zip(&cells).enumerate() {
                let x: f64 = cell.parse().map_err(|_| {
                    anyhow::anyhow!(
                        "line {line_no}, column {}: `{cell}` is not a number",
                        CSV_HEADER[j]
                    )
                })?;
                if !x.is_finite() {
                    bail!(
                        "line {line_no}, column {}: `{cell}` is not finite",
                        CSV_HEADER[j]
                    );
                }
                *slot = x;
            }
            samples.push(TraceSample {
                time: v[0],
                command: v[1],
                phase_currents: [v[2], v[3], v[4]],
                motor_angle: v[5],
                user_angle: v[6],
            });
        }
        if samples.is_empty() {
            bail!("the CSV has a header but no samples");
        }
        check_time_base(&samples)?;
        Ok(Self { samples })
    }
}

/// Time must start at 0 and advance by one 10 kHz period per row (±1 % of a period).
fn check_time_base(samples: &[TraceSample]) -> Result<()> {
    let dt = 1.0 / f64::from(SAMPLE_RATE_HZ);
    for (k, s) in samples.iter().enumerate() {
        let expected = k as f64 / f64::from(SAMPLE_RATE_HZ);
        if (s.time - expected).abs() > 0.01 * dt {
            bail!(
                "line {}: t = {} s, expected {expected} s (one row per {} µs from t = 0)",
                k + 2,
                s.time,
                dt * 1e6
            );
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reference::{ReferenceModel, ReferenceSettings, Scenario};
    use shared::FaultVector;

    fn trace() -> Trace {
        let k = FaultVector::new([0.3, 0.1, 0.2, 0.0, 0.0, 0.1, 0.4, 0.6]).unwrap();
        ReferenceModel::new(ReferenceSettings::REFERENCE)
            .simulate(&Scenario::new(k))
            .trace
    }

    #[test]
    fn csv_round_trips_exactly_and_binary_to_the_fixed_point_bits() {
        let t = trace();
        let csv = t.to_csv();
        assert!(csv.starts_with(b"t,theta_cmd,i_a,i_b,i_c,theta_m,theta_u\n"));
        assert_eq!(Trace::from_csv(&csv).unwrap(), t);
        let bin = t.to_bin().unwrap();
        assert_eq!(bin.len(), 16 + 24 * 5000 + 4);
        let back = Trace::from_bin(&bin).unwrap();
        for (a, b) in t.samples().iter().zip(back.samples()) {
            assert_eq!(a.row(), b.row());
            assert_eq!(a.time, b.time);
        }
    }

    #[test]
    fn csv_and_binary_condition_into_the_same_bits() {
        let t = trace();
        let p = ActuatorParams::REFERENCE;
        let from_csv = Trace::from_csv(&t.to_csv()).unwrap().measured(&p).unwrap();
        let from_bin = Trace::from_bin(&t.to_bin().unwrap())
            .unwrap()
            .measured(&p)
            .unwrap();
        let bits =
            |m: &OnboardMeasured| m.samples().iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&from_csv), bits(&from_bin));
        assert_eq!(from_csv.inv_kappa(), from_bin.inv_kappa());
    }

    #[test]
    fn damaged_input_is_refused_with_a_reason() {
        let t = trace();
        let err = |r: Result<Trace>| format!("{:#}", r.unwrap_err());
        assert!(err(Trace::from_csv(b"")).contains("empty"));
        assert!(err(Trace::from_csv(b"a,b\n1,2\n")).contains("header"));
        assert!(err(Trace::from_csv(
            b"t,theta_cmd,i_a,i_b,i_c,theta_m,theta_u\n"
        ))
        .contains("no samples"));
        let e = err(Trace::from_csv(
            b"t,theta_cmd,i_a,i_b,i_c,theta_m,theta_u\n0,0,1,x,0,0,0\n",
        ));
        assert!(
            e.contains("line 2") && e.contains("i_b") && e.contains("`x`"),
            "{e}"
        );
        let e = err(Trace::from_csv(
            b"t,theta_cmd,i_a,i_b,i_c,theta_m,theta_u\n0,0,1,0,0,0\n",
        ));
        assert!(e.contains("line 2") && e.contains("6 columns"), "{e}");
        let e = err(Trace::from_csv(
            b"t,theta_cmd,i_a,i_b,i_c,theta_m,theta_u\n0,0,1,0,0,0,0\n0.0002,0,1,0,0,0,0\n",
        ));
        assert!(e.contains("line 3") && e.contains("expected 0.0001"), "{e}");
        let e = err(Trace::from_csv(
            b"t,theta_cmd,i_a,i_b,i_c,theta_m,theta_u\n0,0,inf,0,0,0,0\n",
        ));
        assert!(e.contains("not finite"), "{e}");

        let bin = t.to_bin().unwrap();
        assert!(err(Trace::from_bin(&bin[..10])).contains("truncated"));
        assert!(err(Trace::from_bin(&bin[..bin.len() - 24])).contains("length"));
        let mut flipped = bin.clone();
        flipped[1000] ^= 0x40;
        assert!(err(Trace::from_bin(&flipped)).contains("checksum"));
        let mut version = bin.clone();
        version[4] = 9;
        assert!(err(Trace::from_bin(&version)).contains("UnsupportedVersion"));
    }

    #[test]
    fn too_long_a_trace_is_refused_not_truncated() {
        let mut t = trace();
        let last = *t.samples().last().unwrap();
        t.push(TraceSample {
            time: last.time + 1e-4,
            ..last
        });
        let e = format!("{:#}", t.measured(&ActuatorParams::REFERENCE).unwrap_err());
        assert!(
            e.contains("5001 samples") && e.contains("holds 5000"),
            "{e}"
        );
    }
}
