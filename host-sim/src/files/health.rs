//! The health log on the ground: a file-backed [`HealthStore`] (the same slots the controller
//! keeps in flash, one 84-byte record each, each record in the slot after the newest's; logs
//! of older records —
//! 76-byte version 3, 68-byte version 2, 52-byte version 1, all of eight components — are
//! read too, and upgraded in place before anything is appended to them), and the history CSV
//! that `host-sim degrade` writes and `host-sim prognose` reads.
//!
//! History CSV, one row per preflight, readable by `pandas.read_csv` as is:
//!
//! ```text
//! flight,friction,backlash,short_a,short_b,short_c,eccentricity,ecc_phase,gain_drift,demagnetization,fitness,domain[,std_friction,…,std_demagnetization][,v_bus,temp,winding_rise][,magnet_depth,magnet_centre[,magnet_std]][,true_friction,…,true_demagnetization]
//! ```
//!
//! A history written before the ninth fault (no `demagnetization`, `std_demagnetization` or
//! `true_demagnetization` column) is read with no demagnetization (its standard deviation
//! not determined).
//!
//! `std_*` (empty where not determined) are the identification's standard deviations, as a
//! record keeps them; `v_bus` [V], `temp` [°C] and `winding_rise` [K] the test's day as a
//! version-3 record keeps it (empty where not measured); `magnet_depth` (the share of its
//! flux lost) and `magnet_centre` [° of the rotor from the encoder's zero] the weak magnet
//! the test read, or the preflight's that a flight's windows held, as a version-5 record
//! keeps it (both empty where none was read; written when a row has one), and `magnet_std`
//! its depth's standard deviation as a version-6 record keeps it (in 512ths of the flux,
//! rounded up; empty where not determined; a file without the column reads none).
//!
//! `domain` is `within` or the reason (`no_motion`, `open_phase`, `command_mismatch`,
//! `fitness_floor`, `segment_carried_nothing`, `bus_out_of_range`,
//! `temperature_out_of_range`); the `true_*` columns (simulated histories only) give the fault vector the
//! reference model played, and a last column `intrusion` what the test met outside the fault
//! vector (`jammed`, `open_phase`, `other_command`; empty for none).

use std::fs::{File, OpenOptions};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use shared::fault::{FAULT_COUNT, FAULT_NAMES, PAPER_FAULT_COUNT};
use shared::health::{
    record_len, ComponentStd, DomainCode, EncodedRecord, HealthLog, HealthRecord, HealthStore,
    LoadSummary, RecordedDay, RecordedMagnet, FLIGHT_READING, RECORD_BYTES, RECORD_VERSION,
};
use shared::FaultVector;

/// What a flight's preflight test met outside the fault vector (simulated histories).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Intrusion {
    /// The user shaft seized where it started.
    Jammed,
    /// Phase B disconnected.
    OpenPhase,
    /// The test was run with twice the chirp's amplitude (another test, or a wrong record).
    OtherCommand,
}

impl Intrusion {
    pub const ALL: [Self; 3] = [Self::Jammed, Self::OpenPhase, Self::OtherCommand];

    /// Name in the history CSV's `intrusion` column.
    pub fn name(self) -> &'static str {
        match self {
            Self::Jammed => "jammed",
            Self::OpenPhase => "open_phase",
            Self::OtherCommand => "other_command",
        }
    }

    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|i| i.name() == name)
    }
}

/// A [`HealthStore`] in a file of `slots · 76` bytes; each write is flushed to the disk.
#[derive(Debug)]
pub struct FileStore {
    path: PathBuf,
    file: File,
    slots: usize,
}

impl FileStore {
    /// Opens `path`, creating it with `slots` zeroed (empty) slots when it does not exist. An
    /// existing file keeps its own slot count and must hold whole records; a log of older
    /// slots is rewritten as the current version first (its records kept, without what their
    /// version lacks: standard deviations, the day).
    pub fn open(path: &Path, slots: usize) -> Result<Self> {
        let exists = path.exists();
        if exists {
            let bytes = std::fs::read(path)
                .with_context(|| format!("reading health log {}", path.display()))?;
            if !bytes.is_empty() && slot_bytes(&bytes)? != RECORD_BYTES {
                let upgraded = upgrade(&bytes)?;
                std::fs::write(path, upgraded)
                    .with_context(|| format!("upgrading health log {}", path.display()))?;
            }
        }
        let file = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(path)
            .with_context(|| format!("opening health log {}", path.display()))?;
        let len = file.metadata()?.len() as usize;
        let slots = if exists && len > 0 {
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

/// Every record version this code reads, newest first, with its slot size.
fn versions() -> impl Iterator<Item = (u8, usize)> {
    (1..=RECORD_VERSION)
        .rev()
        .filter_map(|v| record_len(v).map(|len| (v, len)))
}

/// The slot size of a health-log image: 84 (versions 4 and 5), 76 (version 3), 68 (version 2) or 52
/// (version 1).
/// An image several divide is taken as the one whose slots decode the most sound records
/// (the newest version on a tie).
pub fn slot_bytes(image: &[u8]) -> Result<usize> {
    let sound = |size: usize| {
        image
            .chunks_exact(size)
            .filter(|c| HealthRecord::decode(c).is_ok())
            .count()
    };
    let mut best: Option<(usize, usize)> = None;
    for (_, size) in versions().filter(|(_, size)| image.len() % size == 0) {
        let n = sound(size);
        if best.is_none_or(|(_, most)| n > most) {
            best = Some((size, n));
        }
    }
    match best {
        Some((size, _)) => Ok(size),
        None => bail!(
            "{} bytes is not a whole number of health records ({})",
            image.len(),
            versions()
                .map(|(v, size)| format!("{size} bytes for version {v}"))
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// An image of older slots as a current image of as many slots
/// ([`shared::health::upgrade_image`]).
fn upgrade(image: &[u8]) -> Result<Vec<u8>> {
    let old_bytes = slot_bytes(image)?;
    let slots = image.len() / old_bytes;
    let mut out = image.to_vec();
    out.resize(slots * RECORD_BYTES, 0xFF);
    shared::health::upgrade_image(&mut out, slots, old_bytes);
    Ok(out)
}

/// A health-log image in memory, of either record version (read-only).
#[derive(Debug)]
pub struct ImageStore<'a> {
    image: &'a [u8],
    slot_bytes: usize,
}

impl<'a> ImageStore<'a> {
    /// The store in `image` ([`slot_bytes`] tells its version).
    pub fn new(image: &'a [u8]) -> Result<Self> {
        Ok(Self {
            image,
            slot_bytes: slot_bytes(image)?,
        })
    }

    /// The record version of its slots (1 … 5; 84-byte slots read as the newest, 5, whose
    /// decoder reads version 4 too).
    pub fn version(&self) -> u8 {
        versions()
            .find(|(_, size)| *size == self.slot_bytes)
            .map_or(RECORD_VERSION, |(v, _)| v)
    }

    /// Every slot's bytes, in slot order.
    pub fn slots_bytes(&self) -> impl Iterator<Item = &'a [u8]> {
        self.image.chunks_exact(self.slot_bytes)
    }
}

impl HealthStore for ImageStore<'_> {
    type Error = anyhow::Error;

    fn slots(&self) -> usize {
        self.image.len() / self.slot_bytes
    }

    fn read(&mut self, slot: usize, out: &mut EncodedRecord) -> Result<()> {
        let at = slot * self.slot_bytes;
        let src = self
            .image
            .get(at..at + self.slot_bytes)
            .with_context(|| format!("no slot {slot}"))?;
        out.fill(0xFF);
        out[..self.slot_bytes].copy_from_slice(src);
        Ok(())
    }

    fn write(&mut self, _slot: usize, _record: &EncodedRecord) -> Result<()> {
        bail!("an image store is read-only")
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
    /// What the test met outside the fault vector (simulated histories).
    pub intrusion: Option<Intrusion>,
}

/// The CSV text of `rows`; `std_*` columns when a row has a standard deviation, `true_*`
/// columns when every row has a truth.
pub fn history_csv(rows: &[HistoryRow]) -> String {
    let with_truth = !rows.is_empty() && rows.iter().all(|r| r.truth.is_some());
    let with_std = rows.iter().any(|r| r.record.std != ComponentStd::UNKNOWN);
    let with_day = rows.iter().any(|r| r.record.day != RecordedDay::UNKNOWN);
    let with_window = rows.iter().any(|r| r.record.window != 0);
    let with_fused = rows
        .iter()
        .any(|r| r.record.window == FLIGHT_READING || r.record.fused > 0);
    let with_magnet = rows.iter().any(|r| r.record.magnet != RecordedMagnet::NONE);
    let mut out = String::from("flight");
    if with_window {
        out += ",window";
    }
    if with_fused {
        out += ",fused";
    }
    for n in FAULT_NAMES {
        out += &format!(",{n}");
    }
    out += ",fitness,domain";
    if with_std {
        for n in FAULT_NAMES {
            out += &format!(",std_{n}");
        }
    }
    if with_day {
        out += ",v_bus,temp,winding_rise";
    }
    if with_magnet {
        out += ",magnet_depth,magnet_centre,magnet_std";
    }
    if with_truth {
        for n in FAULT_NAMES {
            out += &format!(",true_{n}");
        }
        out += ",intrusion";
    }
    out.push('\n');
    for r in rows {
        out += &r.record.flight.to_string();
        if with_window {
            match r.record.window {
                FLIGHT_READING => out += ",flight",
                w => out += &format!(",{w}"),
            }
        }
        if with_fused {
            out += &format!(",{}", r.record.fused);
        }
        for k in r.record.faults.as_array() {
            out += &format!(",{k}");
        }
        out += &format!(",{},{}", r.record.fitness, r.record.domain.name());
        if with_std {
            for i in 0..FAULT_COUNT {
                out.push(',');
                if let Some(sd) = r.record.std.get(i) {
                    out += &sd.to_string();
                }
            }
        }
        if with_day {
            let d = &r.record.day;
            for v in [d.bus_voltage(), d.temperature(), d.winding_rise()] {
                out.push(',');
                if let Some(v) = v {
                    out += &v.to_string();
                }
            }
        }
        if with_magnet {
            let m = r.record.magnet.magnets();
            if m.is_none() {
                out += ",,,";
            } else {
                out += &format!(",{},{},", m.depth, m.centre.to_degrees());
                if let Some(sd) = r.record.magnet.std() {
                    out += &sd.to_string();
                }
            }
        }
        if let (true, Some(t)) = (with_truth, r.truth) {
            for k in t.as_array() {
                out += &format!(",{k}");
            }
            out.push(',');
            out += r.intrusion.map_or("", Intrusion::name);
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
                intrusion: None,
            })
            .collect())
    }
}

/// Loads the health log in `path` (a [`FileStore`] file, either record version) into a log of
/// capacity `N`.
pub fn load_log<const N: usize>(path: &Path) -> Result<(Box<HealthLog<N>>, LoadSummary)> {
    if !path.exists() {
        bail!("{}: no such health log", path.display());
    }
    let image = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    let mut store = ImageStore::new(&image).with_context(|| format!("{}", path.display()))?;
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
    let window_col = column("window");
    let fused_col = column("fused");
    // The paper's eight columns are needed; a history from before the ninth fault has no
    // `demagnetization` column (nor its `std_`/`true_`): it reads as none.
    let columns = |prefix: &str| -> Vec<Option<usize>> {
        FAULT_NAMES
            .iter()
            .map(|n| column(&format!("{prefix}{n}")))
            .collect()
    };
    let complete = |cols: Vec<Option<usize>>| -> Option<Vec<Option<usize>>> {
        cols.iter()
            .take(PAPER_FAULT_COUNT)
            .all(Option::is_some)
            .then_some(cols)
    };
    for n in &FAULT_NAMES[..PAPER_FAULT_COUNT] {
        need(n)?;
    }
    let fault_cols = columns("");
    let fitness_col = need("fitness")?;
    let domain_col = column("domain");
    let intrusion_col = column("intrusion");
    let day_cols = [column("v_bus"), column("temp"), column("winding_rise")];
    let magnet_cols = match (column("magnet_depth"), column("magnet_centre")) {
        (Some(d), Some(c)) => Some((d, c)),
        (None, None) => None,
        _ => bail!("\"magnet_depth\" and \"magnet_centre\" come together or not at all"),
    };
    let magnet_std_col = column("magnet_std");
    if magnet_std_col.is_some() && magnet_cols.is_none() {
        bail!("\"magnet_std\" needs \"magnet_depth\" and \"magnet_centre\"");
    }
    let std_cols = complete(columns("std_"));
    let truth_cols = complete(columns("true_"));
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
        let vector = |cols: &[Option<usize>]| -> Result<FaultVector> {
            let mut k = *FaultVector::NOMINAL.as_array();
            for (v, c) in k.iter_mut().zip(cols) {
                if let Some(c) = *c {
                    *v = number(c)?;
                }
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
        let window: u8 = match window_col.map(cell) {
            None | Some("") => 0,
            Some("flight") => FLIGHT_READING,
            Some(w) => w.parse().with_context(|| {
                format!(
                    "line {line_no}: window \"{w}\" is neither a whole number 0…254 nor \
                     \"flight\" (the flight's reading)"
                )
            })?,
        };
        let fused: u8 = match fused_col.map(cell) {
            None | Some("") => 0,
            Some(n) => n.parse().with_context(|| {
                format!("line {line_no}: fused \"{n}\" is not a whole number 0…255")
            })?,
        };
        let fused_fits = match window {
            FLIGHT_READING => fused > 0,
            0 => true,
            _ => fused == 0,
        };
        if !fused_fits {
            bail!(
                "line {line_no}: fused {fused}: a flight's reading (window \"flight\") has at \
                 least one window fused, a preflight the tests it averaged (0 or 1: one), a \
                 window's own entry none"
            );
        }
        if let Some(last) = rows.last() {
            if (flight, window) <= (last.record.flight, last.record.window) {
                bail!(
                    "line {line_no}: flight {flight} window {window} does not follow flight {} \
                     window {} (0: the preflight)",
                    last.record.flight,
                    last.record.window
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
        record.window = window;
        record.fused = fused;
        if let Some(cols) = &std_cols {
            let mut sd = [f32::NAN; FAULT_COUNT];
            for (v, c) in sd.iter_mut().zip(cols) {
                let Some(c) = *c else { continue };
                if !cell(c).is_empty() {
                    *v = number(c)?;
                    if *v < 0.0 {
                        bail!(
                            "line {line_no}, column \"{}\": a negative standard deviation",
                            header[c]
                        );
                    }
                }
            }
            record = record.with_std(sd);
        }
        let [bus, temp, rise] = day_cols.map(|c| match c.map(cell) {
            None | Some("") => Ok(None),
            Some(_) => c.map(&number).transpose(),
        });
        record = record.with_day(RecordedDay::new(bus?, temp?, rise?));
        if let Some((d, c)) = magnet_cols {
            match (cell(d), cell(c)) {
                ("", "") => {}
                ("", _) | (_, "") => {
                    bail!("line {line_no}: a weak magnet needs both its depth and its centre")
                }
                _ => {
                    let depth = number(d)?;
                    if !(depth > 0.0 && depth <= 1.0) {
                        bail!(
                            "line {line_no}, column \"magnet_depth\": {depth} is not a share \
                             of the magnet's flux in (0, 1]"
                        );
                    }
                    let centre = number(c)?.to_radians();
                    record = record.with_magnet(&shared::magnets::WeakMagnet::new(depth, centre));
                    if let Some(s) = magnet_std_col.filter(|&s| !cell(s).is_empty()) {
                        let sd = number(s)?;
                        if !(sd.is_finite() && sd >= 0.0) {
                            bail!(
                                "line {line_no}, column \"magnet_std\": {sd} is not a \
                                 standard deviation"
                            );
                        }
                        record = record.with_magnet_std(sd);
                    }
                }
            }
        }
        let truth = match &truth_cols {
            Some(cols) => Some(vector(cols)?),
            None => None,
        };
        let intrusion = match intrusion_col.map(cell) {
            None | Some("") => None,
            Some(name) => Some(
                Intrusion::from_name(name)
                    .with_context(|| format!("line {line_no}: unknown intrusion \"{name}\""))?,
            ),
        };
        rows.push(HistoryRow {
            record,
            truth,
            intrusion,
        });
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
            intrusion: (flight == 4).then_some(Intrusion::Jammed),
        }
    }

    #[test]
    fn history_csv_round_trips() {
        let mut with_std = row(2, 0.09, Domain::Within);
        with_std.record =
            with_std
                .record
                .with_std([0.01, f32::NAN, 0.02, 0.0, 0.5, 0.03, f32::NAN, 0.004, 0.01]);
        let rows = vec![
            with_std,
            row(3, 0.1, Domain::Within),
            row(
                4,
                0.125,
                Domain::Outside(OutsideReason::FitnessFloor { fitness: 1.0 }),
            ),
        ];
        let text = history_csv(&rows);
        assert_eq!(parse_history_csv(&text).unwrap(), rows);
        assert!(text.starts_with("flight,") && text.contains(",std_friction,"));
        let bad = text.replace(",0.125,", ",x,");
        let e = parse_history_csv(&bad).unwrap_err();
        assert!(format!("{e:#}").contains("line 4"), "{e:#}");
        let swapped = format!("{}\n{}", text.trim_end(), text.lines().nth(1).unwrap());
        assert!(
            format!("{:#}", parse_history_csv(&swapped).unwrap_err()).contains("does not follow")
        );
    }

    #[test]
    fn a_weak_magnet_round_trips_and_needs_both_its_cells() {
        let mut read = row(3, 0.1, Domain::Within);
        read.record = read
            .record
            .with_magnet(&shared::magnets::WeakMagnet::new(0.5, 2.4))
            .with_magnet_std(0.032);
        let rows = vec![row(2, 0.09, Domain::Within), read];
        let text = history_csv(&rows);
        assert!(
            text.contains(",magnet_depth,magnet_centre,magnet_std"),
            "{text}"
        );
        assert_eq!(parse_history_csv(&text).unwrap(), rows);
        let m = read.record.magnet.magnets();
        let cells = format!(",{},{},", m.depth, m.centre.to_degrees());
        assert!(text.contains(&cells), "{text}");
        // Its deviation as stored (17/512, rounded up from 0.032), which reads back as itself.
        assert!(
            text.contains(&format!("{cells}{}", 17.0f32 / 512.0)),
            "{text}"
        );
        // Flight 2 read none: all three cells empty.
        assert!(text.lines().nth(1).unwrap().contains(",,,"), "{text}");
        // Without the deviation's column: the magnet, no deviation.
        let at = text
            .lines()
            .next()
            .unwrap()
            .split(',')
            .position(|c| c == "magnet_std")
            .unwrap();
        let without: Vec<String> = text
            .lines()
            .map(|l| {
                let mut cells: Vec<&str> = l.split(',').collect();
                cells.remove(at);
                cells.join(",")
            })
            .collect();
        let old = parse_history_csv(&(without.join("\n") + "\n")).unwrap();
        assert_eq!(old[1].record.magnet.std(), None);
        assert_eq!(old[1].record.magnet.magnets(), m);
        let e = parse_history_csv(&text.replace(&cells, ",,137.8125,")).unwrap_err();
        assert!(
            format!("{e:#}").contains("both its depth and its centre"),
            "{e:#}"
        );
        let e = parse_history_csv(&text.replace(&cells, ",1.5,137.8125,")).unwrap_err();
        assert!(format!("{e:#}").contains("magnet_depth"), "{e:#}");
    }

    #[test]
    fn in_flight_entries_round_trip_after_their_preflight() {
        let mut window = row(3, 0.11, Domain::Within);
        window.record = window.record.in_flight(1);
        window.record.domain = DomainCode::PlayUnseen;
        let mut second = row(3, 0.12, Domain::Within);
        second.record = second.record.in_flight(2);
        let mut flight = row(3, 0.115, Domain::Within);
        flight.record = flight.record.flight_reading(2);
        let rows = vec![
            row(2, 0.09, Domain::Within),
            row(3, 0.1, Domain::Within),
            window,
            second,
            flight,
            row(4, 0.13, Domain::Within),
        ];
        let text = history_csv(&rows);
        assert!(text.starts_with("flight,window,fused,friction,"), "{text}");
        assert!(text.contains(",play_unseen,"));
        assert!(text.contains("\n3,flight,2,0.115,"), "{text}");
        assert_eq!(parse_history_csv(&text).unwrap(), rows);
        // A flight's reading has windows fused, a window's own entry none.
        let e = parse_history_csv(&text.replace("\n3,flight,2,", "\n3,flight,0,")).unwrap_err();
        assert!(format!("{e:#}").contains("line 6"), "{e:#}");
        let e = parse_history_csv(&text.replace("\n3,2,0,", "\n3,2,1,")).unwrap_err();
        assert!(format!("{e:#}").contains("fused 1"), "{e:#}");
        // A preflight of repeated tests keeps how many it averaged.
        let mut repeated = rows.clone();
        repeated[1].record.fused = 4;
        let text4 = history_csv(&repeated);
        assert!(text4.contains("\n3,0,4,0.1,"), "{text4}");
        assert_eq!(parse_history_csv(&text4).unwrap(), repeated);
        let alone = history_csv(&repeated[..2]);
        assert!(alone.starts_with("flight,fused,friction,"), "{alone}");
        assert_eq!(parse_history_csv(&alone).unwrap(), &repeated[..2]);
        let rows = [&rows[..4], &rows[5..]].concat();
        let text = history_csv(&rows);
        assert!(text.starts_with("flight,window,friction,"), "{text}");
        // A history without in-flight entries keeps its columns as before.
        assert!(history_csv(&rows[..2]).starts_with("flight,friction,"));
        // (flight, window) must increase: a preflight after its own window is refused.
        let lines: Vec<&str> = text.lines().collect();
        let swapped = [lines[0], lines[1], lines[3], lines[2]].join("\n");
        let e = format!("{:#}", parse_history_csv(&swapped).unwrap_err());
        assert!(
            e.contains("line 4") && e.contains("window 0 does not follow"),
            "{e}"
        );
    }

    #[test]
    fn a_history_of_the_eight_component_version_reads_with_no_demagnetization() {
        let mut rows = vec![row(2, 0.09, Domain::Within), row(3, 0.1, Domain::Within)];
        rows[0].record =
            rows[0]
                .record
                .with_std([0.01, 0.01, 0.02, 0.0, 0.5, 0.03, f32::NAN, 0.004, f32::NAN]);
        let text = history_csv(&rows);
        assert!(text.contains(",demagnetization,") && text.contains(",true_demagnetization"));
        // What `degrade` wrote before the ninth fault: no demagnetization column of any kind.
        let drop = |name: &str, text: &str| -> String {
            let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
            let at = header.iter().position(|h| *h == name).unwrap();
            text.lines()
                .map(|l| {
                    let mut cells: Vec<&str> = l.split(',').collect();
                    cells.remove(at);
                    cells.join(",") + "\n"
                })
                .collect()
        };
        let mut old = text.clone();
        for name in [
            "demagnetization",
            "std_demagnetization",
            "true_demagnetization",
        ] {
            old = drop(name, &old);
        }
        assert!(!old.contains("demagnetization"));
        assert_eq!(parse_history_csv(&old).unwrap(), rows);
        // The paper's eight are still needed.
        let e = parse_history_csv(&drop("gain_drift", &old)).unwrap_err();
        assert!(format!("{e:#}").contains("\"gain_drift\""), "{e:#}");
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
        assert_eq!(
            std::fs::metadata(&path).unwrap().len(),
            4 * RECORD_BYTES as u64
        );
        let rows = read_history(&path).unwrap();
        assert_eq!(
            rows.iter().map(|r| r.record.flight).collect::<Vec<_>>(),
            [2, 3, 4, 5]
        );
        std::fs::write(&path, [0u8; 50]).unwrap();
        assert!(FileStore::open(&path, 4).is_err());
    }

    #[test]
    fn older_logs_are_read_and_upgraded_before_an_append() {
        use shared::health::{RECORD_V1_BYTES, RECORD_V2_BYTES, RECORD_V3_BYTES};
        let std = [0.02; FAULT_COUNT];
        for (old_bytes, version) in [
            (RECORD_V1_BYTES, 1u8),
            (RECORD_V2_BYTES, 2),
            (RECORD_V3_BYTES, 3),
        ] {
            let dir = tempfile::tempdir().unwrap();
            let path = dir.path().join("old.bin");
            // Three older slots holding flights 3, 4, 5 (slot = flight mod 3).
            let mut image = vec![0xFF; 3 * old_bytes];
            for f in 3..6u32 {
                let s = (f % 3) as usize * old_bytes;
                let r = row(f, 0.1, Domain::Within).record.with_std(std);
                let bytes = match version {
                    1 => r.encode_v1().to_vec(),
                    2 => r.encode_v2().to_vec(),
                    _ => r.encode_v3().to_vec(),
                };
                image[s..s + old_bytes].copy_from_slice(&bytes);
            }
            std::fs::write(&path, &image).unwrap();
            assert_eq!(ImageStore::new(&image).unwrap().version(), version);
            let rows = read_history(&path).unwrap();
            assert_eq!(
                rows.iter().map(|r| r.record.flight).collect::<Vec<_>>(),
                [3, 4, 5]
            );
            // Eight components kept: the demagnetization's standard deviation is unknown.
            let mut eight = std;
            eight[8] = f32::NAN;
            let kept_std = if version == 1 {
                ComponentStd::UNKNOWN
            } else {
                ComponentStd::new(eight)
            };
            assert!(rows.iter().all(|r| r.record.std == kept_std));
            assert!(rows.iter().all(|r| r.record.day == RecordedDay::UNKNOWN));
            // Appending rewrites it as the current version first: the old records stay.
            let mut store = FileStore::open(&path, 3).unwrap();
            let (mut log, _) = HealthLog::<3>::load(&mut store).unwrap();
            let new = row(6, 0.2, Domain::Within)
                .record
                .with_std([0.01; FAULT_COUNT])
                .with_day(RecordedDay::new(Some(270.5), Some(-12.25), Some(-33.0)));
            log.append(&mut store, new).unwrap();
            drop(store);
            assert_eq!(
                std::fs::metadata(&path).unwrap().len(),
                3 * RECORD_BYTES as u64
            );
            let rows = read_history(&path).unwrap();
            assert_eq!(
                rows.iter().map(|r| r.record.flight).collect::<Vec<_>>(),
                [4, 5, 6]
            );
            assert_eq!(rows[2].record, new);
            assert_eq!(rows[0].record.std, kept_std);
            // The history CSV carries the day and reads it back.
            let csv = history_csv(&rows);
            assert!(csv.contains(",v_bus,temp,winding_rise"), "{csv}");
            let csv_path = dir.path().join("h.csv");
            std::fs::write(&csv_path, &csv).unwrap();
            let back = read_history(&csv_path).unwrap();
            assert_eq!(back[2].record.day, new.day);
            assert_eq!(back[0].record.day, RecordedDay::UNKNOWN);
        }
    }
}
