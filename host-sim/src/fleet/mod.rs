//! The fleet store and report on the ground (`host-sim fleet`): every controller's health
//! log, ingested into one SQLite file keyed by actuator serial and flight, and one static HTML
//! page ranking the actuators by the lower bound of their remaining useful life.
//!
//! ## Store
//!
//! One file, no server (bundled SQLite). Table `records (serial, flight, test, version,
//! bytes)`, primary key `(serial, flight, test)`: `test` is the record's place in its flight
//! (0 the preflight, n its n-th window of flight, 255 the flight's reading from its windows:
//! `HealthRecord::window`), `bytes` the record exactly as the controller wrote it (version
//! 1 … 5, its checksum included), decoded again by `shared::health` when read.
//!
//! Schema 3 (in-flight entries beside their preflight). Older stores are migrated in place
//! when opened, in one transaction, and the schema set to 3, so that an older host-sim
//! refuses the store rather than misread it: a schema-2 store's records are kept as they
//! are, each under its own test; a schema-1 store's (records of eight components, versions
//! 1–3) are re-encoded as the current version (k9 = 0, its standard deviation not
//! determined).
//! Each log is ingested in one transaction:
//!
//! * a record already stored with the same bytes adds nothing (ingesting a log twice, or two
//!   downloads of an overlapping ring, is idempotent);
//! * a log with a damaged slot (checksum, field), a record version this tool does not read,
//!   or a record that contradicts a stored one (same serial and flight, other bytes) is
//!   refused whole: nothing of it is stored, and what was stored stays.
//!
//! ## Report
//!
//! Each actuator's whole stored history feeds `shared::prognosis` (the controller's trend,
//! over every flight instead of its 32-record ring). Actuators are ranked by the soonest
//! lower bound of the 90 % RUL interval over their faults; those whose newest preflight was
//! outside the monitor model's domain, or with out-of-domain preflights among their last ten,
//! are flagged (an in-flight entry's own verdict flags nothing), and the weak magnet the
//! newest trusted preflight read is shown. The page holds the ranking and, for the first
//! actuators, one SVG per fault heading for its threshold: identified levels, fit, 90 % cone
//! and RUL interval.
//!
//! Work: ingest O(records) statements; report O(records · faults · shapes) trend updates
//! plus one estimate per actuator and fault.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use rusqlite::{params, Connection, OptionalExtension};
use shared::fault::FAULT_COUNT;
use shared::health::{
    is_blank, record_len, DomainCode, HealthRecord, HealthRecordError, FLIGHT_READING,
    RECORD_BYTES, RECORD_VERSION,
};
use shared::magnets::WeakMagnet;
use shared::prognosis::{
    trended_value, HealthTrend, TrendEstimate, TrendSettings, TREND_COUNT, TREND_NAMES,
};

use crate::files::health::ImageStore;
use crate::studies::prognostics::{growth_name, stored_magnet_verdict};

/// The store's schema version (table `meta`).
const SCHEMA: i64 = 3;

/// The records table of [`SCHEMA`].
const RECORDS_TABLE: &str = "CREATE TABLE records (
    serial TEXT NOT NULL,
    flight INTEGER NOT NULL,
    test INTEGER NOT NULL,
    version INTEGER NOT NULL,
    bytes BLOB NOT NULL,
    PRIMARY KEY (serial, flight, test)
) WITHOUT ROWID;";

/// The fleet store: one SQLite file.
pub struct FleetStore {
    conn: Connection,
}

/// What ingesting one log did.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Ingested {
    pub serial: String,
    /// Sound records in the log.
    pub records: usize,
    /// Of those, new to the store.
    pub added: usize,
    /// Empty (erased) slots.
    pub empty: usize,
    /// Damaged slots skipped (only with `skip_damaged`).
    pub skipped_damaged: usize,
    /// The log's record version (1 … 5).
    pub version: u8,
}

/// Why a log was refused (nothing of it stored).
#[derive(Debug)]
pub enum Refusal {
    /// Not a health log: the length is not a whole number of records.
    NotALog(String),
    /// A slot holds a record of a version this tool does not read.
    UnknownVersion { slot: usize, version: u8 },
    /// Slots whose record fails its checksum or field checks.
    Damaged { slots: Vec<usize> },
    /// A stored record of the same serial, flight and test (`HealthRecord::window`) differs.
    Conflict { flight: u32, test: u8 },
    /// The log holds no record at all.
    Empty,
}

impl std::fmt::Display for Refusal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::NotALog(why) => write!(f, "not a health log: {why}"),
            Self::UnknownVersion { slot, version } => write!(
                f,
                "slot {slot} holds a version-{version} record; this host-sim reads versions 1 \
                 to {RECORD_VERSION} (update host-sim)"
            ),
            Self::Damaged { slots } => write!(
                f,
                "damaged slot(s) {slots:?} (checksum or field); nothing stored \
                 (--skip-damaged stores the sound records)"
            ),
            Self::Conflict { flight, test } => write!(
                f,
                "flight {flight}'s {} is already stored for this serial with other contents \
                 (wrong serial, or a controller whose flight counter went back); nothing stored",
                test_name(*test)
            ),
            Self::Empty => write!(f, "no record in the log"),
        }
    }
}

impl std::error::Error for Refusal {}

/// An actuator serial: 1–64 characters of letters, digits, `-`, `_`, `.`.
pub fn check_serial(serial: &str) -> Result<()> {
    if serial.is_empty()
        || serial.len() > 64
        || !serial
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'))
    {
        bail!(
            "\"{serial}\" is not an actuator serial (1–64 letters, digits, '-', '_' or '.'); \
             name the log after its actuator or give --serial"
        );
    }
    Ok(())
}

/// What a record's test is called in messages: `preflight`, `window n`, `flight reading`.
fn test_name(test: u8) -> String {
    match test {
        0 => "preflight".into(),
        FLIGHT_READING => "flight reading".into(),
        n => format!("window {n}"),
    }
}

/// Moves the records of a store of schema `from` (1 or 2, keyed by serial and flight) into
/// the records table of [`SCHEMA`], each under its own test, a schema-1 store's re-encoded as
/// the current version, and sets the schema, in one transaction (a store that fails is left
/// as it was). Returns the records moved.
fn migrate(conn: &Connection, from: i64) -> Result<usize> {
    let tx = conn.unchecked_transaction()?;
    let rows: Vec<(String, i64, i64, Vec<u8>)> = {
        let mut all = tx.prepare("SELECT serial, flight, version, bytes FROM records")?;
        let rows = all.query_map([], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?)))?;
        rows.collect::<rusqlite::Result<_>>()?
    };
    tx.execute_batch(&format!("DROP TABLE records; {RECORDS_TABLE}"))?;
    let mut put = tx.prepare(
        "INSERT INTO records (serial, flight, test, version, bytes) VALUES (?1, ?2, ?3, ?4, ?5)",
    )?;
    for (serial, flight, version, bytes) in &rows {
        let record = HealthRecord::decode(bytes).map_err(|e| {
            anyhow::anyhow!("record of {serial}, flight {flight} does not decode: {e:?}")
        })?;
        // A schema-1 record is re-encoded; a schema-2 one kept as it was sent.
        let (version, bytes) = if from == 1 {
            (i64::from(RECORD_VERSION), record.encode().to_vec())
        } else {
            (*version, bytes.clone())
        };
        put.execute(params![serial, flight, record.window, version, bytes])?;
    }
    drop(put);
    tx.execute("UPDATE meta SET value = ?1 WHERE key = 'schema'", [SCHEMA])?;
    tx.commit()?;
    Ok(rows.len())
}

impl FleetStore {
    /// Opens (or creates) the store at `path`; a store of schema 1 is migrated first.
    pub fn open(path: &Path) -> Result<Self> {
        let conn = Connection::open(path)
            .with_context(|| format!("opening fleet store {}", path.display()))?;
        conn.execute_batch(
            "CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value INTEGER NOT NULL);
             CREATE TABLE IF NOT EXISTS ingests (
                 id INTEGER PRIMARY KEY,
                 source TEXT NOT NULL,
                 serial TEXT NOT NULL,
                 records INTEGER NOT NULL,
                 added INTEGER NOT NULL
             );",
        )
        .with_context(|| format!("{}: not a fleet store", path.display()))?;
        let schema: Option<i64> = conn
            .query_row("SELECT value FROM meta WHERE key = 'schema'", [], |r| {
                r.get(0)
            })
            .optional()?;
        match schema {
            None => {
                conn.execute_batch(RECORDS_TABLE)
                    .with_context(|| format!("{}: not a fleet store", path.display()))?;
                conn.execute("INSERT INTO meta VALUES ('schema', ?1)", [SCHEMA])?;
            }
            Some(SCHEMA) => {}
            Some(from @ (1 | 2)) => {
                let n = migrate(&conn, from).with_context(|| {
                    format!("{}: migrating schema {from} to {SCHEMA}", path.display())
                })?;
                let how = if from == 1 {
                    format!(", re-encoded as version {RECORD_VERSION}")
                } else {
                    String::new()
                };
                eprintln!(
                    "{}: fleet store migrated from schema {from} to {SCHEMA} ({n} records, each \
                     under its test in its flight{how})",
                    path.display()
                );
            }
            Some(v) => bail!(
                "{}: fleet store schema {v}; this host-sim reads schema {SCHEMA}",
                path.display()
            ),
        }
        Ok(Self { conn })
    }

    /// Ingests the health-log image `image` (slots of either record version) of actuator
    /// `serial`, from `source` (a file name, for the ingest table). One transaction: refused
    /// whole ([`Refusal`]) or stored whole.
    pub fn ingest(
        &mut self,
        serial: &str,
        image: &[u8],
        source: &str,
        skip_damaged: bool,
    ) -> Result<Ingested> {
        check_serial(serial)?;
        let store = ImageStore::new(image).map_err(|e| Refusal::NotALog(format!("{e:#}")))?;
        let version = store.version();
        let mut empty = 0;
        let mut damaged = Vec::new();
        let mut found: Vec<(HealthRecord, &[u8])> = Vec::new();
        for (slot, bytes) in store.slots_bytes().enumerate() {
            match HealthRecord::decode(bytes) {
                Ok(r) => found.push((r, bytes)),
                Err(HealthRecordError::BadMagic) if is_blank(bytes) => empty += 1,
                Err(HealthRecordError::UnsupportedVersion(v)) => {
                    return Err(Refusal::UnknownVersion { slot, version: v }.into())
                }
                Err(_) => damaged.push(slot),
            }
        }
        if !damaged.is_empty() && !skip_damaged {
            return Err(Refusal::Damaged { slots: damaged }.into());
        }
        if found.is_empty() {
            return Err(Refusal::Empty.into());
        }
        found.sort_by_key(|(r, _)| r.order());
        let tx = self.conn.transaction()?;
        let mut added = 0;
        {
            let mut get = tx.prepare_cached(
                "SELECT bytes FROM records WHERE serial = ?1 AND flight = ?2 AND test = ?3",
            )?;
            let mut put = tx.prepare_cached(
                "INSERT INTO records (serial, flight, test, version, bytes) \
                 VALUES (?1, ?2, ?3, ?4, ?5)",
            )?;
            for (r, bytes) in &found {
                // The record without the slot's erased tail (a decoded record's version is
                // one `record_len` knows).
                let len = bytes
                    .get(4)
                    .and_then(|&v| record_len(v))
                    .unwrap_or(bytes.len());
                let bytes = bytes.get(..len).unwrap_or(bytes);
                let stored: Option<Vec<u8>> = get
                    .query_row(params![serial, r.flight, r.window], |row| row.get(0))
                    .optional()?;
                match stored {
                    Some(s) if s == bytes => {}
                    Some(s) => {
                        // The same record in the other version (a v1 log upgraded on the
                        // controller) is the same record.
                        let same = HealthRecord::decode(&s).is_ok_and(|old| {
                            old.flight == r.flight
                                && old.window == r.window
                                && old.faults == r.faults
                                && old.fitness.to_bits() == r.fitness.to_bits()
                                && old.domain == r.domain
                        });
                        if !same {
                            return Err(Refusal::Conflict {
                                flight: r.flight,
                                test: r.window,
                            }
                            .into());
                        }
                    }
                    None => {
                        put.execute(params![
                            serial,
                            r.flight,
                            r.window,
                            bytes.get(4).copied(),
                            bytes
                        ])?;
                        added += 1;
                    }
                }
            }
        }
        tx.execute(
            "INSERT INTO ingests (source, serial, records, added) VALUES (?1, ?2, ?3, ?4)",
            params![source, serial, found.len() as i64, added as i64],
        )?;
        tx.commit()?;
        Ok(Ingested {
            serial: serial.to_string(),
            records: found.len(),
            added,
            empty,
            skipped_damaged: damaged.len(),
            version,
        })
    }

    /// Records stored, and actuators.
    pub fn counts(&self) -> Result<(u64, u64)> {
        Ok(self.conn.query_row(
            "SELECT COUNT(*), COUNT(DISTINCT serial) FROM records",
            [],
            |r| Ok((r.get::<_, i64>(0)? as u64, r.get::<_, i64>(1)? as u64)),
        )?)
    }

    /// Every actuator's records, oldest first, serials in order.
    pub fn histories(&self) -> Result<BTreeMap<String, Vec<HealthRecord>>> {
        let mut out: BTreeMap<String, Vec<HealthRecord>> = BTreeMap::new();
        let mut q = self
            .conn
            .prepare("SELECT serial, flight, bytes FROM records ORDER BY serial, flight, test")?;
        let mut rows = q.query([])?;
        while let Some(row) = rows.next()? {
            let serial: String = row.get(0)?;
            let flight: i64 = row.get(1)?;
            let bytes: Vec<u8> = row.get(2)?;
            let record = HealthRecord::decode(&bytes).map_err(|e| {
                anyhow::anyhow!("stored record {serial} flight {flight} does not decode: {e:?}")
            })?;
            out.entry(serial).or_default().push(record);
        }
        Ok(out)
    }
}

/// The serial a log file stands for: its name without extension.
pub fn serial_of(path: &Path) -> Result<String> {
    let stem = path
        .file_stem()
        .and_then(|s| s.to_str())
        .with_context(|| format!("{}: no file name", path.display()))?;
    check_serial(stem).with_context(|| format!("{}", path.display()))?;
    Ok(stem.to_string())
}

/// The files to ingest: each path, or every file in a folder (sorted).
pub fn log_files(paths: &[PathBuf]) -> Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    for p in paths {
        if p.is_dir() {
            let mut inner: Vec<PathBuf> = std::fs::read_dir(p)
                .with_context(|| format!("reading folder {}", p.display()))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.is_file())
                .collect();
            inner.sort();
            out.extend(inner);
        } else {
            out.push(p.clone());
        }
    }
    Ok(out)
}

/// One actuator's line in the report.
#[derive(Clone, Debug)]
pub struct ActuatorStatus {
    pub serial: String,
    pub records: usize,
    pub newest: u32,
    pub trend: HealthTrend,
    pub estimates: [Option<TrendEstimate>; TREND_COUNT],
    /// The fault whose RUL lower bound is soonest, and that bound (`None`: beyond the
    /// horizon).
    pub limiting: Option<(usize, Option<f32>)>,
    /// The newest preflight's verdict when it was outside the domain.
    pub newest_outside: Option<DomainCode>,
    /// Out-of-domain preflights among the last ten (an in-flight entry's verdict — a
    /// window's turbulence, an unconfirmed flight reading — flags nothing).
    pub recent_outside: usize,
    /// The newest trusted preflight's flight, its weak magnet and that magnet's deviation as
    /// kept (`None`: it read even magnets, or no preflight was trusted).
    pub weak_magnet: Option<(u32, WeakMagnet, Option<f32>)>,
}

impl ActuatorStatus {
    pub fn of(serial: &str, records: &[HealthRecord], settings: &TrendSettings) -> Self {
        let trend = HealthTrend::from_records(records, settings);
        let estimates = trend.estimates(settings);
        let mut limiting: Option<(usize, Option<f32>)> = None;
        for (i, e) in estimates.iter().enumerate() {
            let Some(rul) = e.and_then(|e| e.rul) else {
                continue;
            };
            let sooner = match limiting {
                None => true,
                Some((_, b)) => rank_key(rul.lower) < rank_key(b),
            };
            if sooner {
                limiting = Some((i, rul.lower));
            }
        }
        let newest = records.last();
        let preflights = || records.iter().rev().filter(|r| r.window == 0);
        let trusted = preflights().find(|r| r.is_trusted());
        Self {
            serial: serial.to_string(),
            records: records.len(),
            newest: newest.map_or(0, |r| r.flight),
            trend,
            estimates,
            limiting,
            newest_outside: preflights()
                .next()
                .filter(|r| !r.is_trusted())
                .map(|r| r.domain),
            recent_outside: preflights().take(10).filter(|r| !r.is_trusted()).count(),
            weak_magnet: trusted
                .map(|r| (r.flight, r.magnet.magnets(), r.magnet.std()))
                .filter(|(_, m, _)| !m.is_none()),
        }
    }

    /// Sort key: the soonest lower bound first, "beyond the horizon" last.
    pub fn key(&self) -> f64 {
        self.limiting.map_or(f64::INFINITY, |(_, b)| rank_key(b))
    }

    /// The limiting fault's RUL median (ties of [`Self::key`] are broken by it).
    fn median(&self) -> f64 {
        self.limiting
            .and_then(|(i, _)| self.estimates.get(i).copied().flatten())
            .and_then(|e| e.rul)
            .map_or(f64::INFINITY, |r| rank_key(r.rul))
    }

    pub fn flagged(&self) -> bool {
        self.newest_outside.is_some() || self.recent_outside > 0
    }
}

fn rank_key(lower: Option<f32>) -> f64 {
    lower.map_or(f64::MAX, f64::from)
}

/// Every actuator's status, ranked (soonest RUL lower bound first; ties by the median, then
/// the serial).
pub fn ranked(
    histories: &BTreeMap<String, Vec<HealthRecord>>,
    settings: &TrendSettings,
) -> Vec<ActuatorStatus> {
    let mut out: Vec<ActuatorStatus> = histories
        .iter()
        .map(|(s, r)| ActuatorStatus::of(s, r, settings))
        .collect();
    out.sort_by(|a, b| {
        a.key()
            .total_cmp(&b.key())
            .then(a.median().total_cmp(&b.median()))
            .then(a.serial.cmp(&b.serial))
    });
    out
}

fn flights(v: Option<f32>) -> String {
    v.map_or("beyond".into(), |x| format!("{x:.1}"))
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The report page: the ranking of every actuator, and the trend pictures of the first
/// `detail` ones.
pub fn report_html(
    statuses: &[ActuatorStatus],
    histories: &BTreeMap<String, Vec<HealthRecord>>,
    settings: &TrendSettings,
    detail: usize,
) -> String {
    let records: usize = statuses.iter().map(|s| s.records).sum();
    let flagged = statuses.iter().filter(|s| s.flagged()).count();
    let within = |s: &ActuatorStatus, n: f64| s.key() <= n;
    let mut h = String::new();
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <title>ema-fdi fleet report</title>\n<style>\
         body{{font-family:sans-serif;margin:1.5em;color:#222}}\
         table{{border-collapse:collapse;font-size:0.9em}}\
         th,td{{border:1px solid #ccc;padding:0.2em 0.5em;text-align:right}}\
         td.l,th.l{{text-align:left}} tr.flag td{{background:#fff4d6}}\
         .soon{{color:#b00;font-weight:bold}} svg{{margin:0.3em}}\
         </style></head><body>\n<h1>Fleet report</h1>\n"
    );
    let _ = writeln!(
        h,
        "<p id=\"summary\">{} actuators, {records} health records. RUL lower bound (5 % point \
         of the end-of-life distribution) within 10 flights: <b>{}</b>; within 50: <b>{}</b>. \
         Outside the monitor model's domain (newest preflight, or any of the last ten): \
         <b>{flagged}</b>. A weak magnet read by the newest trusted preflight: <b>{}</b>.</p>",
        statuses.len(),
        statuses.iter().filter(|s| within(s, 10.0)).count(),
        statuses.iter().filter(|s| within(s, 50.0)).count(),
        statuses.iter().filter(|s| s.weak_magnet.is_some()).count(),
    );
    let _ = writeln!(
        h,
        "<p>Ranked by the soonest lower bound of the 90 % RUL interval over each actuator's \
         faults (flights after its newest record; \"beyond\": no crossing within {} flights). \
         Thresholds: {}. Trends use the tests inside the monitor model's domain only.</p>",
        settings.horizon,
        (0..TREND_COUNT)
            .filter_map(|i| settings
                .threshold(i)
                .map(|t| format!("{} {t}", TREND_NAMES[i])))
            .collect::<Vec<_>>()
            .join(", ")
    );
    h += "<table id=\"ranking\"><tr><th>rank</th><th class=\"l\">serial</th><th>records</th>\
          <th>newest flight</th><th class=\"l\">limiting fault</th><th>level</th>\
          <th>RUL lower</th><th>RUL median</th><th>RUL upper</th><th class=\"l\">growth</th>\
          <th class=\"l\">domain</th><th class=\"l\">weak magnet</th></tr>\n";
    for (rank, s) in statuses.iter().enumerate() {
        let (fault, level, lo, mid, hi, growth) = match s.limiting {
            Some((i, _)) => {
                let e = s.estimates[i];
                let r = e.and_then(|e| e.rul);
                (
                    TREND_NAMES[i].to_string(),
                    e.map_or("-".into(), |e| format!("{:.3}", e.level)),
                    flights(r.and_then(|r| r.lower)),
                    flights(r.and_then(|r| r.rul)),
                    flights(r.and_then(|r| r.upper)),
                    e.map_or("-".into(), |e| {
                        format!("{} ({:.0} %)", growth_name(e.growth), 100.0 * e.weight)
                    }),
                )
            }
            None => (
                "-".into(),
                "-".into(),
                "-".into(),
                "-".into(),
                "-".into(),
                "-".into(),
            ),
        };
        let magnet = s.weak_magnet.map_or("-".into(), |(flight, m, std)| {
            let verdict = stored_magnet_verdict(&m, std).map_or(String::new(), |(_, v)| {
                format!(", ± {:.3}, {v}", std.unwrap_or(f32::NAN))
            });
            format!(
                "{:.2} of its flux lost at {:.0}° (flight {flight}){verdict}",
                m.depth,
                m.centre.to_degrees()
            )
        });
        let domain = match (s.newest_outside, s.recent_outside) {
            (Some(code), n) => {
                format!("newest preflight outside ({}); {n} of last 10", code.name())
            }
            (None, 0) => "within".into(),
            (None, n) => format!("{n} of last 10 preflights outside"),
        };
        let soon = if s.key() <= 10.0 {
            " class=\"soon\""
        } else {
            ""
        };
        let link = if rank < detail {
            format!("<a href=\"#a-{0}\">{0}</a>", escape(&s.serial))
        } else {
            escape(&s.serial)
        };
        let _ = writeln!(
            h,
            "<tr{}><td>{}</td><td class=\"l\">{link}</td><td>{}</td><td>{}</td><td class=\"l\">{fault}</td>\
             <td>{level}</td><td{soon}>{lo}</td><td>{mid}</td><td>{hi}</td><td class=\"l\">{growth}</td>\
             <td class=\"l\">{domain}</td><td class=\"l\">{magnet}</td></tr>",
            if s.flagged() { " class=\"flag\"" } else { "" },
            rank + 1,
            s.records,
            s.newest,
        );
    }
    h += "</table>\n";
    for s in statuses.iter().take(detail) {
        let _ = write!(
            h,
            "<h2 id=\"a-{0}\">{0}</h2>\n<p>{1} records up to flight {2}.</p>\n",
            escape(&s.serial),
            s.records,
            s.newest
        );
        let records = histories.get(&s.serial).map_or(&[][..], |r| &r[..]);
        for i in 0..TREND_COUNT {
            let (Some(t), Some(e)) = (settings.threshold(i), s.estimates[i]) else {
                continue;
            };
            let heading = e.level > shared::fault::DETECTION_THRESHOLD
                || e.rul
                    .is_some_and(|r| r.upper.is_some() || r.lower.is_some());
            if heading {
                h += &fault_svg(s, records, i, t, settings);
            }
        }
    }
    h += "</body></html>\n";
    h
}

/// One fault's picture: the identified levels (dots; crosses outside the domain), the
/// likeliest shape's fit, the 90 % cone of the shapes with weight, the threshold and the RUL
/// interval on it.
fn fault_svg(
    s: &ActuatorStatus,
    records: &[HealthRecord],
    i: usize,
    threshold: f32,
    settings: &TrendSettings,
) -> String {
    const W: f64 = 460.0;
    const HT: f64 = 230.0;
    const L: f64 = 48.0;
    const B: f64 = 30.0;
    let Some(trend) = s.trend.fault(i) else {
        return String::new();
    };
    let e = s.estimates[i];
    let first = f64::from(records.first().map_or(0, |r| r.flight));
    let newest = f64::from(s.newest);
    let span = (newest - first).max(1.0);
    let ahead = e
        .and_then(|e| e.rul)
        .and_then(|r| r.upper.or(r.rul))
        .map_or(0.3 * span, f64::from)
        .clamp(0.1 * span, span);
    let x_end = newest + 1.1 * ahead;
    let threshold = f64::from(threshold);
    let y_hi = records
        .iter()
        .filter_map(|r| trended_value(r, i).map(f64::from))
        .fold(threshold * 1.2, f64::max)
        .min(1.0);
    let x = |f: f64| L + (f - first) / (x_end - first) * (W - L - 8.0);
    let y = |v: f64| HT - B - v.clamp(0.0, y_hi) / y_hi * (HT - B - 8.0);
    let mut g = format!(
        "<svg class=\"fault\" data-fault=\"{}\" width=\"{W}\" height=\"{HT}\" \
         viewBox=\"0 0 {W} {HT}\" xmlns=\"http://www.w3.org/2000/svg\" font-size=\"11\">\
         <rect x=\"0\" y=\"0\" width=\"{W}\" height=\"{HT}\" fill=\"white\" stroke=\"#ccc\"/>\
         <text x=\"{L}\" y=\"14\" font-weight=\"bold\">{} {}</text>",
        TREND_NAMES[i],
        escape(&s.serial),
        TREND_NAMES[i]
    );
    // Axes and labels.
    let _ = write!(
        g,
        "<line x1=\"{L}\" y1=\"{0}\" x2=\"{1}\" y2=\"{0}\" stroke=\"#888\"/>\
         <line x1=\"{L}\" y1=\"8\" x2=\"{L}\" y2=\"{0}\" stroke=\"#888\"/>\
         <text x=\"{L}\" y=\"{2}\">{3:.0}</text><text x=\"{4}\" y=\"{2}\" text-anchor=\"end\">flight {5:.0}</text>\
         <text x=\"{6}\" y=\"{7}\" text-anchor=\"end\">{8:.2}</text><text x=\"{6}\" y=\"{0}\" text-anchor=\"end\">0</text>",
        HT - B,
        W - 8.0,
        HT - B + 14.0,
        first,
        W - 8.0,
        x_end,
        L - 4.0,
        y(y_hi) + 4.0,
        y_hi
    );
    // Cone and fit.
    let steps = 60;
    let grid: Vec<f64> = (0..=steps)
        .map(|k| newest + (x_end - newest) * f64::from(k) / f64::from(steps))
        .collect();
    let cone: Vec<(f64, (f64, f64))> = grid
        .iter()
        .map(|&f| (f, trend.envelope(f, settings)))
        .collect();
    let mut poly = String::new();
    for &(f, (_, hi)) in &cone {
        let _ = write!(poly, "{:.1},{:.1} ", x(f), y(hi));
    }
    for &(f, (lo, _)) in cone.iter().rev() {
        let _ = write!(poly, "{:.1},{:.1} ", x(f), y(lo));
    }
    let _ = write!(
        g,
        "<polygon class=\"cone\" points=\"{poly}\" fill=\"#d33\" fill-opacity=\"0.15\"/>"
    );
    let mut fit = String::new();
    for k in 0..=steps {
        let f = first + (x_end - first) * f64::from(k) / f64::from(steps);
        let _ = write!(fit, "{:.1},{:.1} ", x(f), y(trend.band(f, settings).0));
    }
    let _ = write!(
        g,
        "<polyline class=\"fit\" points=\"{fit}\" fill=\"none\" stroke=\"#d33\" stroke-width=\"1.5\"/>"
    );
    // Observations.
    for r in records {
        let Some(d) = trended_value(r, i) else {
            continue;
        };
        let (px, py) = (x(f64::from(r.flight)), y(f64::from(d)));
        if r.is_trusted() {
            let _ = write!(
                g,
                "<circle class=\"obs\" cx=\"{px:.1}\" cy=\"{py:.1}\" r=\"1.8\" fill=\"#1f5fbf\"/>"
            );
        } else {
            let _ = write!(
                g,
                "<path class=\"outside\" d=\"M{0:.1},{1:.1}l5,5m0,-5l-5,5\" stroke=\"black\"/>",
                px - 2.5,
                py - 2.5
            );
        }
    }
    // Threshold and the RUL interval on it.
    let _ = write!(
        g,
        "<line class=\"threshold\" x1=\"{L}\" y1=\"{0:.1}\" x2=\"{1}\" y2=\"{0:.1}\" stroke=\"green\" stroke-dasharray=\"4 3\"/>\
         <text x=\"{1}\" y=\"{2:.1}\" text-anchor=\"end\" fill=\"green\">threshold {3}</text>",
        y(threshold),
        W - 8.0,
        y(threshold) - 3.0,
        threshold
    );
    if let Some(r) = e.and_then(|e| e.rul) {
        let lo = r.lower.map_or(x_end, |v| newest + f64::from(v)).min(x_end);
        let hi = r.upper.map_or(x_end, |v| newest + f64::from(v)).min(x_end);
        let _ = write!(
            g,
            "<rect class=\"interval\" x=\"{:.1}\" y=\"{:.1}\" width=\"{:.1}\" height=\"6\" fill=\"green\" fill-opacity=\"0.6\"/>",
            x(lo),
            y(threshold) - 3.0,
            (x(hi) - x(lo)).max(1.0)
        );
        let _ = write!(
            g,
            "<text x=\"{L}\" y=\"{0}\" dx=\"6\" dy=\"14\">RUL {1} [{2}, {3}] flights</text>",
            8.0,
            flights(r.rul),
            flights(r.lower),
            flights(r.upper)
        );
    }
    g += "</svg>\n";
    g
}

/// A synthetic fleet for the benchmark: `actuators` health logs of `flights` records each
/// (no reference model: one fault per actuator grows along a power law of random exponent
/// to a random final level, most actuators staying healthy; each record reads it with a
/// scatter of about 0.01; 2 % of the tests are outside the domain), written as
/// `ACT-NNNNN.bin` into `dir`.
pub fn synthetic_fleet(dir: &Path, actuators: u32, flights: u32, seed: u64) -> Result<()> {
    use rand_core::{RngCore, SeedableRng};
    use shared::domain::{Domain, OutsideReason};
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed);
    let mut uniform = move || (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
    for a in 0..actuators {
        let fault = [0usize, 1, 2, 5, 7][(uniform() * 5.0) as usize % 5];
        let end = 0.7 * uniform().powi(2);
        let power = 1.0 + 2.0 * uniform();
        let mut image = vec![0xFFu8; flights as usize * RECORD_BYTES];
        for f in 0..flights {
            let s = f64::from(f) / f64::from(flights.max(2) - 1);
            let mut k = *shared::FaultVector::NOMINAL.as_array();
            let scatter = 0.01 * (uniform() + uniform() + uniform() - 1.5) * 2.0;
            let level = (end * s.powf(power) + scatter).clamp(0.0, 1.0) as f32;
            k[fault] = if fault == 7 { 0.5 + 0.5 * level } else { level };
            let domain = if uniform() < 0.02 {
                Domain::Outside(OutsideReason::NoMotion { travel: 0.0 })
            } else {
                Domain::Within
            };
            let faults = shared::FaultVector::saturating(k);
            let record = HealthRecord::new(f, faults, 1e-3, domain).with_std([0.012; FAULT_COUNT]);
            let at = f as usize * RECORD_BYTES;
            image[at..at + RECORD_BYTES].copy_from_slice(&record.encode());
        }
        std::fs::write(dir.join(format!("ACT-{a:05}.bin")), &image)?;
    }
    Ok(())
}
