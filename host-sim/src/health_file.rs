//! The health log on the ground: a file-backed [`HealthStore`] (the same slots the controller
//! keeps in flash, one 52-byte record each, slot `flight mod slots`), and the history CSV that
//! `host-sim degrade` writes and `host-sim prognose` reads.
//!
//! History CSV, one row per preflight, readable by `pandas.read_csv` as is:
//!
//! ```text
//! flight,friction,backlash,short_a,short_b,short_c,eccentricity,ecc_phase,gain_drift,fitness,domain[,true_friction,…,true_gain_drift]
//! ```
//!
//! `domain` is `within` or the reason (`no_motion`, `open_phase`, `command_mismatch`,
//! `fitness_floor`); the `true_*` columns (simulated histories only) give the fault vector the
//! reference model played.

use std::fs::{File, OpenOptions};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use shared::fault::{FAULT_COUNT, FAULT_NAMES};
use shared::health::{
    DomainCode, EncodedRecord, HealthLog, HealthRecord, HealthStore, LoadSummary, RECORD_BYTES,
};
use shared::FaultVector;

/// A [`HealthStore`] in a file of `slots · 52` bytes; each write is flushed to the disk.
#[derive(Debug)]
pub struct FileStore {
    path: PathBuf,
    file: File,
    slots: usize,
}

impl FileStore {
    /// Opens `path`, creating it with `slots` zeroed (empty) slots when it does not exist. An
    /// existing file keeps its own slot count and must hold whole records.
    pub fn open(path: &Path, slots: usize) -> Result<Self> {
        let exists = path.exists();
        let file = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(path)
            .with_context(|| format!("opening health log {}", path.display()))?;
        let len = file.metadata()?.len() as usize;
        let slots = if exists && len > 0 {
            if len % RECORD_BYTES != 0 {
                bail!(
                    "{}: {len} bytes is not a whole number of {RECORD_BYTES}-byte health records",
                    path.display()
                );
            }
            len / RECORD_BYTES
        } else {
            file.set_len((slots * RECORD_BYTES) as u64)?;
            slots
        };
        Ok(Self {
            path: path.to_owned(),
            file,
            slots,
        })
    }
}

impl HealthStore for FileStore {
    type Error = anyhow::Error;

    fn slots(&self) -> usize {
        self.slots
    }

    fn read(&mut self, slot: usize, out: &mut EncodedRecord) -> Result<()> {
        self.file
            .seek(SeekFrom::Start((slot * RECORD_BYTES) as u64))
            .and_then(|_| self.file.read_exact(out))
            .with_context(|| format!("reading slot {slot} of {}", self.path.display()))
    }

    fn write(&mut self, slot: usize, record: &EncodedRecord) -> Result<()> {
        if slot >= self.slots {
            bail!(
                "slot {slot} beyond the {} of {}",
                self.slots,
                self.path.display()
            );
        }
        self.file
            .seek(SeekFrom::Start((slot * RECORD_BYTES) as u64))
            .and_then(|_| self.file.write_all(record))
            .and_then(|_| self.file.sync_data())
            .with_context(|| format!("writing slot {slot} of {}", self.path.display()))
    }
}

/// One preflight of a history file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HistoryRow {
    pub record: HealthRecord,
    /// The fault vector the reference model played (simulated histories).
    pub truth: Option<FaultVector>,
}

/// The CSV text of `rows`; `true_*` columns when every row has a truth.
pub fn history_csv(rows: &[HistoryRow]) -> String {
    let with_truth = !rows.is_empty() && rows.iter().all(|r| r.truth.is_some());
    let mut out = String::from("flight");
    for n in FAULT_NAMES {
        out += &format!(",{n}");
    }
    out += ",fitness,domain";
    if with_truth {
        for n in FAULT_NAMES {
            out += &format!(",true_{n}");
        }
    }
    out.push('\n');
    for r in rows {
        out += &r.record.flight.to_string();
        for k in r.record.faults.as_array() {
            out += &format!(",{k}");
        }
        out += &format!(",{},{}", r.record.fitness, r.record.domain.name());
        if let (true, Some(t)) = (with_truth, r.truth) {
            for k in t.as_array() {
                out += &format!(",{k}");
            }
        }
        out.push('\n');
    }
    out
}

/// Reads a history: the CSV above, or a health-log file (slots of records, as the
/// controller's store and `degrade --log` write them), told apart by the first bytes.
pub fn read_history(path: &Path) -> Result<Vec<HistoryRow>> {
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    if bytes.starts_with(b"flight") {
        let text = std::str::from_utf8(&bytes)
            .with_context(|| format!("{}: not UTF-8 text", path.display()))?;
        parse_history_csv(text).with_context(|| format!("reading history {}", path.display()))
    } else {
        let (log, summary) = load_log::<4096>(path)?;
        if log.is_empty() {
            bail!(
                "{}: neither a history CSV (header starting \"flight\") nor a health log with a \
                 sound record ({} slots: {} empty, {} damaged)",
                path.display(),
                summary.empty + summary.damaged,
                summary.empty,
                summary.damaged
            );
        }
        Ok(log
            .iter()
            .map(|&record| HistoryRow {
                record,
                truth: None,
            })
            .collect())
    }
}

/// Loads the health log in `path` (a [`FileStore`] file) into a log of capacity `N`.
pub fn load_log<const N: usize>(path: &Path) -> Result<(Box<HealthLog<N>>, LoadSummary)> {
    if !path.exists() {
        bail!("{}: no such health log", path.display());
    }
    let mut store = FileStore::open(path, 0)?;
    let (log, summary) = HealthLog::<N>::load(&mut store)?;
    Ok((Box::new(log), summary))
}

fn parse_history_csv(text: &str) -> Result<Vec<HistoryRow>> {
    let mut lines = text.lines().enumerate();
    let header: Vec<&str> = match lines.next() {
        Some((_, h)) => h.split(',').map(str::trim).collect(),
        None => bail!("empty file"),
    };
    let column = |name: &str| header.iter().position(|h| *h == name);
    let need = |name: &str| column(name).with_context(|| format!("no column \"{name}\""));
    let flight_col = need("flight")?;
    let fault_cols: Vec<usize> = FAULT_NAMES.iter().map(|n| need(n)).collect::<Result<_>>()?;
    let fitness_col = need("fitness")?;
    let domain_col = column("domain");
    let truth_cols: Option<Vec<usize>> = FAULT_NAMES
        .iter()
        .map(|n| column(&format!("true_{n}")))
        .collect();
    let mut rows: Vec<HistoryRow> = Vec::new();
    for (i, line) in lines {
        let line_no = i + 1;
        if line.trim().is_empty() {
            continue;
        }
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        if cells.len() != header.len() {
            bail!(
                "line {line_no}: {} cells, the header has {}",
                cells.len(),
                header.len()
            );
        }
        let cell = |c: usize| cells.get(c).copied().unwrap_or("");
        let number = |c: usize| -> Result<f32> {
            let v: f32 = cell(c).parse().with_context(|| {
                format!(
                    "line {line_no}, column \"{}\": \"{}\" is not a number",
                    header[c],
                    cell(c)
                )
            })?;
            if !v.is_finite() {
                bail!("line {line_no}, column \"{}\": not finite", header[c]);
            }
            Ok(v)
        };
        let vector = |cols: &[usize]| -> Result<FaultVector> {
            let mut k = [0f32; FAULT_COUNT];
            for (v, &c) in k.iter_mut().zip(cols) {
                *v = number(c)?;
            }
            FaultVector::new(k)
                .map_err(|e| anyhow::anyhow!("line {line_no}: fault vector out of [0, 1] ({e:?})"))
        };
        let flight: u32 = cell(flight_col).parse().with_context(|| {
            format!(
                "line {line_no}: flight \"{}\" is not a whole number",
                cell(flight_col)
            )
        })?;
        if let Some(last) = rows.last() {
            if flight <= last.record.flight {
                bail!(
                    "line {line_no}: flight {flight} does not follow flight {}",
                    last.record.flight
                );
            }
        }
        let domain = match domain_col {
            Some(c) => DomainCode::from_name(cell(c)).with_context(|| {
                format!("line {line_no}: unknown domain verdict \"{}\"", cell(c))
            })?,
            None => DomainCode::Within,
        };
        let mut record = HealthRecord::new(
            flight,
            vector(&fault_cols)?,
            number(fitness_col)?,
            shared::domain::Domain::Within,
        );
        record.domain = domain;
        let truth = match &truth_cols {
            Some(cols) => Some(vector(cols)?),
            None => None,
        };
        rows.push(HistoryRow { record, truth });
    }
    if rows.is_empty() {
        bail!("no rows");
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared::domain::{Domain, OutsideReason};

    fn row(flight: u32, friction: f32, domain: Domain) -> HistoryRow {
        let mut k = *FaultVector::NOMINAL.as_array();
        k[0] = friction;
        let v = FaultVector::new(k).unwrap();
        HistoryRow {
            record: HealthRecord::new(flight, v, 0.02, domain),
            truth: Some(v),
        }
    }

    #[test]
    fn history_csv_round_trips() {
        let rows = vec![
            row(3, 0.1, Domain::Within),
            row(
                4,
                0.125,
                Domain::Outside(OutsideReason::FitnessFloor { fitness: 1.0 }),
            ),
        ];
        let text = history_csv(&rows);
        assert_eq!(parse_history_csv(&text).unwrap(), rows);
        let bad = text.replace(",0.125,", ",x,");
        let e = parse_history_csv(&bad).unwrap_err();
        assert!(format!("{e:#}").contains("line 3"), "{e:#}");
        let swapped = format!("{}\n{}", text.trim_end(), text.lines().nth(1).unwrap());
        assert!(
            format!("{:#}", parse_history_csv(&swapped).unwrap_err()).contains("does not follow")
        );
    }

    #[test]
    fn file_store_persists_records_across_opens() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("health.bin");
        {
            let mut store = FileStore::open(&path, 4).unwrap();
            let mut log = HealthLog::<8>::new();
            for f in 0..6 {
                log.append(&mut store, row(f, 0.1, Domain::Within).record)
                    .unwrap();
            }
        }
        assert_eq!(std::fs::metadata(&path).unwrap().len(), 4 * 52);
        let rows = read_history(&path).unwrap();
        assert_eq!(
            rows.iter().map(|r| r.record.flight).collect::<Vec<_>>(),
            [2, 3, 4, 5]
        );
        std::fs::write(&path, [0u8; 50]).unwrap();
        assert!(FileStore::open(&path, 4).is_err());
    }
}
