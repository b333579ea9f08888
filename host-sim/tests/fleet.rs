//! `host-sim fleet ingest` and `fleet report`: the store is keyed by serial, flight and
//! test (a preflight and its flight's in-flight entries side by side), idempotent, refuses damaged, unknown-version and contradicting logs whole without losing
//! what it held, and the report ranks, flags and draws what the records say.

mod common;

use std::path::Path;

use common::*;
use shared::domain::{Domain, OutsideReason};
use shared::fault::FAULT_COUNT;
use shared::health::{HealthRecord, RECORD_BYTES, RECORD_V1_BYTES};
use shared::FaultVector;

fn s(p: &Path) -> &str {
    p.to_str().expect("UTF-8 temp path")
}

/// A record of `flight` with friction at `friction` (other faults nominal).
fn record(flight: u32, friction: f32, domain: Domain) -> HealthRecord {
    let mut k = *FaultVector::NOMINAL.as_array();
    k[0] = friction;
    HealthRecord::new(flight, FaultVector::new(k).unwrap(), 1e-3, domain)
        .with_std([0.01; FAULT_COUNT])
}

/// A controller's ring of `slots` slots after flights `flights` (slot = flight mod slots),
/// friction growing 0.01 per flight from `start`.
fn log_image(slots: usize, flights: std::ops::Range<u32>, start: f32) -> Vec<u8> {
    let mut image = vec![0xFF; slots * RECORD_BYTES];
    for f in flights {
        let at = (f as usize % slots) * RECORD_BYTES;
        let r = record(f, start + 0.01 * f as f32, Domain::Within);
        image[at..at + RECORD_BYTES].copy_from_slice(&r.encode());
    }
    image
}

fn ingest(db: &Path, logs: &[&Path], extra: &[&str]) -> (bool, String) {
    let mut args = vec!["fleet", "ingest", "--db", s(db)];
    args.extend(logs.iter().map(|p| s(p)));
    args.extend(extra);
    let o = host_sim(&args);
    (o.status.success(), text(&o))
}

fn stored(db: &Path) -> i64 {
    let c = rusqlite::Connection::open(db).unwrap();
    c.query_row("SELECT COUNT(*) FROM records", [], |r| r.get(0))
        .unwrap()
}

#[test]
fn ingesting_twice_adds_nothing_and_overlapping_downloads_add_only_new_flights() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("fleet.sqlite");
    let first = dir.path().join("ACT-1.bin");
    std::fs::write(&first, log_image(16, 0..10, 0.1)).unwrap();
    let (ok, out) = ingest(&db, &[&first], &[]);
    assert!(ok, "{out}");
    assert!(
        out.contains("10 v6 records, 10 new, 6 empty slots"),
        "{out}"
    );
    assert_eq!(stored(&db), 10);
    let (ok, out) = ingest(&db, &[&first], &[]);
    assert!(ok && out.contains("10 v6 records, 0 new"), "{out}");
    assert_eq!(stored(&db), 10);
    // The next download of the same ring: flights 4..20 (the oldest overwritten).
    let later = dir.path().join("later").join("ACT-1.bin");
    std::fs::create_dir(later.parent().unwrap()).unwrap();
    std::fs::write(&later, log_image(16, 0..20, 0.1)).unwrap();
    let (ok, out) = ingest(&db, &[later.parent().unwrap()], &[]);
    assert!(ok && out.contains("16 v6 records, 10 new"), "{out}");
    assert_eq!(stored(&db), 20);
    // Another actuator's log under its own serial.
    let other = dir.path().join("renamed.bin");
    std::fs::write(&other, log_image(16, 0..3, 0.0)).unwrap();
    let (ok, out) = ingest(&db, &[&other], &["--serial", "ACT-2"]);
    assert!(ok, "{out}");
    assert_eq!(stored(&db), 23);
    let c = rusqlite::Connection::open(&db).unwrap();
    let serials: Vec<String> = c
        .prepare("SELECT DISTINCT serial FROM records ORDER BY serial")
        .unwrap()
        .query_map([], |r| r.get(0))
        .unwrap()
        .map(Result::unwrap)
        .collect();
    assert_eq!(serials, ["ACT-1", "ACT-2"]);
}

#[test]
fn damaged_unknown_and_contradicting_logs_are_refused_whole_and_the_store_keeps_its_records() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("fleet.sqlite");
    let good = dir.path().join("ACT-7.bin");
    std::fs::write(&good, log_image(8, 0..8, 0.1)).unwrap();
    assert!(ingest(&db, &[&good], &[]).0);
    assert_eq!(stored(&db), 8);
    let before = std::fs::read(&db).unwrap().len();

    // A later download with one torn slot (flight 10's): refused, nothing of it stored.
    let mut torn = log_image(8, 0..12, 0.1);
    torn[(10 % 8) * RECORD_BYTES + 20] ^= 0x40;
    let torn_path = dir.path().join("torn").join("ACT-7.bin");
    std::fs::create_dir(torn_path.parent().unwrap()).unwrap();
    std::fs::write(&torn_path, &torn).unwrap();
    let (ok, out) = ingest(&db, &[&torn_path], &[]);
    assert!(!ok, "{out}");
    assert!(
        out.contains("refused") && out.contains("damaged slot(s) [2]"),
        "{out}"
    );
    assert_eq!(stored(&db), 8);
    assert!(std::fs::read(&db).unwrap().len() >= before);
    // Asked to, the sound records of that log are stored (flights 8, 9, 11).
    let (ok, out) = ingest(&db, &[&torn_path], &["--skip-damaged"]);
    assert!(ok && out.contains("1 damaged slots skipped"), "{out}");
    assert_eq!(stored(&db), 11);

    // A record version this tool does not read: refused by name.
    let mut v7 = log_image(8, 12..14, 0.1);
    v7[(12 % 8) * RECORD_BYTES + 4] = 7;
    let v7_path = dir.path().join("ACT-8.bin");
    std::fs::write(&v7_path, &v7).unwrap();
    let (ok, out) = ingest(&db, &[&v7_path], &[]);
    assert!(!ok && out.contains("version-7 record"), "{out}");
    assert_eq!(stored(&db), 11);

    // Flight 3 of ACT-7 again, with other contents: refused, the stored one kept.
    let contradicting = dir.path().join("other").join("ACT-7.bin");
    std::fs::create_dir(contradicting.parent().unwrap()).unwrap();
    std::fs::write(&contradicting, log_image(8, 0..4, 0.3)).unwrap();
    let (ok, out) = ingest(&db, &[&contradicting], &[]);
    assert!(
        !ok && out.contains("flight 0's preflight is already stored"),
        "{out}"
    );
    assert_eq!(stored(&db), 11);

    // Not a log at all, and a good log in the same call: the good one is stored.
    let junk = dir.path().join("ACT-9.bin");
    std::fs::write(&junk, b"flight,friction\n").unwrap();
    let next = dir.path().join("ACT-10.bin");
    std::fs::write(&next, log_image(8, 0..2, 0.1)).unwrap();
    let (ok, out) = ingest(&db, &[&junk, &next], &[]);
    assert!(!ok && out.contains("not a health log"), "{out}");
    assert!(out.contains("2 logs: 1 ingested"), "{out}");
    assert_eq!(stored(&db), 13);
}

#[test]
fn a_version_1_log_is_ingested() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("fleet.sqlite");
    let mut image = vec![0xFF; 4 * RECORD_V1_BYTES];
    for f in 0..3u32 {
        let at = f as usize * RECORD_V1_BYTES;
        image[at..at + RECORD_V1_BYTES]
            .copy_from_slice(&record(f, 0.1, Domain::Within).encode_v1());
    }
    let path = dir.path().join("OLD-1.bin");
    std::fs::write(&path, &image).unwrap();
    let (ok, out) = ingest(&db, &[&path], &[]);
    assert!(ok && out.contains("3 v1 records, 3 new"), "{out}");
}

/// A store of schema 1 (records of eight components, as the tool wrote before the ninth
/// fault) is migrated in place when opened: every record re-encoded as the current version,
/// nothing lost, and the old log ingested again adds nothing.
/// A store of schema `schema` (1 or 2: keyed by serial and flight) holding the first
/// `flights` slots of `image` (`len` bytes each) of `serial` as they were sent.
fn old_store(db: &Path, schema: i64, serial: &str, image: &[u8], len: usize, flights: u32) {
    let c = rusqlite::Connection::open(db).unwrap();
    c.execute_batch(
        "CREATE TABLE meta (key TEXT PRIMARY KEY, value INTEGER NOT NULL);
         CREATE TABLE records (serial TEXT NOT NULL, flight INTEGER NOT NULL,
             version INTEGER NOT NULL, bytes BLOB NOT NULL,
             PRIMARY KEY (serial, flight)) WITHOUT ROWID;
         CREATE TABLE ingests (id INTEGER PRIMARY KEY, source TEXT NOT NULL,
             serial TEXT NOT NULL, records INTEGER NOT NULL, added INTEGER NOT NULL);",
    )
    .unwrap();
    c.execute("INSERT INTO meta VALUES ('schema', ?1)", [schema])
        .unwrap();
    for f in 0..flights {
        let bytes = &image[f as usize * len..(f as usize + 1) * len];
        c.execute(
            "INSERT INTO records VALUES (?1, ?2, ?3, ?4)",
            rusqlite::params![serial, f, bytes[4], bytes],
        )
        .unwrap();
    }
}

#[test]
fn a_schema_1_store_of_eight_component_records_is_migrated_in_place() {
    use shared::health::{RECORD_V3_BYTES, RECORD_VERSION};
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("fleet.sqlite");
    let mut image = vec![0xFF; 8 * RECORD_V3_BYTES];
    for f in 0..6u32 {
        let at = f as usize * RECORD_V3_BYTES;
        image[at..at + RECORD_V3_BYTES]
            .copy_from_slice(&record(f, 0.1 + 0.01 * f as f32, Domain::Within).encode_v3());
    }
    let path = dir.path().join("OLD-3.bin");
    std::fs::write(&path, &image).unwrap();
    // What the schema-1 tool kept: the version-3 bytes as sent, schema 1.
    old_store(&db, 1, "OLD-3", &image, RECORD_V3_BYTES, 6);
    let (ok, out) = ingest(&db, &[&path], &[]);
    assert!(ok, "{out}");
    assert!(
        out.contains("migrated from schema 1 to 3 (6 records"),
        "{out}"
    );
    assert!(out.contains("6 v3 records, 0 new"), "{out}");
    let c = rusqlite::Connection::open(&db).unwrap();
    let schema: i64 = c
        .query_row("SELECT value FROM meta WHERE key = 'schema'", [], |r| {
            r.get(0)
        })
        .unwrap();
    assert_eq!(schema, 3);
    let mut q = c
        .prepare("SELECT flight, version, bytes FROM records ORDER BY flight")
        .unwrap();
    let rows: Vec<(u32, u8, Vec<u8>)> = q
        .query_map([], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)))
        .unwrap()
        .map(Result::unwrap)
        .collect();
    assert_eq!(rows.len(), 6);
    for (f, version, bytes) in rows {
        assert_eq!((version, bytes.len()), (RECORD_VERSION, RECORD_BYTES));
        let r = HealthRecord::decode(&bytes).unwrap();
        let old = HealthRecord::decode(&image[f as usize * RECORD_V3_BYTES..]).unwrap();
        assert_eq!(r, old);
        assert_eq!(r.faults.demagnetization(), 0.0);
    }
    // Opening it again migrates nothing.
    let (ok, out) = ingest(&db, &[&path], &[]);
    assert!(ok && !out.contains("migrated"), "{out}");
}

/// A ring of flights 0..6, each a preflight (friction growing, flight 5's with a weak
/// magnet), its first window (its own verdict a fitness floor) and the flight's reading.
fn log_with_flights() -> Vec<u8> {
    use shared::health::FLIGHT_READING;
    use shared::magnets::WeakMagnet;
    let mut records = Vec::new();
    for f in 0..6u32 {
        let mut pre = record(f, 0.1 + 0.01 * f as f32, Domain::Within);
        if f == 5 {
            pre = pre
                .with_magnet(&WeakMagnet::new(0.5, 2.4))
                .with_magnet_std(0.03);
        }
        let mut window = record(f, 0.3, Domain::Within).in_flight(1);
        window.domain = shared::health::DomainCode::from_name("fitness_floor").unwrap();
        let reading = record(f, 0.1 + 0.01 * f as f32, Domain::Within).flight_reading(1);
        assert_eq!(reading.window, FLIGHT_READING);
        records.extend([pre, window, reading]);
    }
    let mut image = vec![0xFF; 32 * RECORD_BYTES];
    for (slot, r) in records.iter().enumerate() {
        image[slot * RECORD_BYTES..(slot + 1) * RECORD_BYTES].copy_from_slice(&r.encode());
    }
    image
}

#[test]
fn a_log_with_in_flight_entries_is_stored_whole_and_its_window_verdicts_flag_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("fleet.sqlite");
    let log = dir.path().join("ACT-7.bin");
    std::fs::write(&log, log_with_flights()).unwrap();
    let (ok, out) = ingest(&db, &[&log], &[]);
    assert!(ok && out.contains("18 new"), "{out}");
    let (ok, out) = ingest(&db, &[&log], &[]);
    assert!(ok && out.contains("0 new"), "{out}");
    assert_eq!(stored(&db), 18);
    // Another window 1 of flight 3 contradicts the stored one.
    let mut other = log_with_flights();
    let changed = record(3, 0.9, Domain::Within).in_flight(1);
    other[10 * RECORD_BYTES..11 * RECORD_BYTES].copy_from_slice(&changed.encode());
    let bad = dir.path().join("ACT-7-again.bin");
    std::fs::write(&bad, other).unwrap();
    let (ok, out) = ingest(&db, &[&bad], &["--serial", "ACT-7"]);
    assert!(
        !ok && out.contains("flight 3's window 1 is already stored"),
        "{out}"
    );
    assert_eq!(stored(&db), 18);
    let page = dir.path().join("report.html");
    let o = host_sim(&["fleet", "report", "--db", s(&db), "--out", s(&page)]);
    assert!(o.status.success(), "{}", text(&o));
    let html = std::fs::read_to_string(&page).unwrap();
    assert!(
        html.contains("ten): <b>0</b>"),
        "a window's fitness floor flags nothing"
    );
    assert!(
        html.contains("newest trusted preflight: <b>1</b>"),
        "{html}"
    );
    assert!(
        html.contains("0.50 of its flux lost at 138° (flight 5), ± 0.031, FAULT"),
        "{html}"
    );
}

#[test]
fn a_schema_2_store_is_migrated_with_its_records_under_their_tests() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("fleet.sqlite");
    let image = log_image(8, 0..5, 0.1);
    old_store(&db, 2, "ACT-2", &image, RECORD_BYTES, 5);
    let log = dir.path().join("ACT-2.bin");
    std::fs::write(&log, log_with_flights()).unwrap();
    let (ok, out) = ingest(&db, &[&log], &[]);
    assert!(
        ok && out.contains("migrated from schema 2 to 3 (5 records"),
        "{out}"
    );
    // The five stored preflights are the log's own: its other thirteen records are added.
    assert!(out.contains("18 v6 records, 13 new"), "{out}");
    let c = rusqlite::Connection::open(&db).unwrap();
    let rows: Vec<(u32, u8, Vec<u8>)> = c
        .prepare("SELECT flight, test, bytes FROM records WHERE test = 0 ORDER BY flight")
        .unwrap()
        .query_map([], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)))
        .unwrap()
        .map(Result::unwrap)
        .collect();
    assert_eq!(rows.len(), 6);
    for (f, test, bytes) in rows.into_iter().take(5) {
        assert_eq!(test, 0);
        let at = f as usize * RECORD_BYTES;
        assert_eq!(bytes, &image[at..at + RECORD_BYTES], "kept as stored");
    }
}

#[test]
fn the_report_ranks_by_the_rul_lower_bound_draws_the_trends_and_flags_the_domain() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("fleet.sqlite");
    let logs = dir.path().join("logs");
    std::fs::create_dir(&logs).unwrap();
    let write = |serial: &str, records: Vec<HealthRecord>| {
        let mut image = vec![0xFF; 64 * RECORD_BYTES];
        for r in records {
            let at = r.flight as usize * RECORD_BYTES;
            image[at..at + RECORD_BYTES].copy_from_slice(&r.encode());
        }
        std::fs::write(logs.join(format!("{serial}.bin")), image).unwrap();
    };
    let wiggle = |f: u32| 0.004 * ((f * 37 % 7) as f32 / 3.0 - 1.0);
    // FAST: friction 0.1 + 0.01/flight, at 0.49 after 40 flights: reaches 0.5 in about one.
    write(
        "FAST",
        (0..40)
            .map(|f| record(f, 0.1 + 0.01 * f as f32 + wiggle(f), Domain::Within))
            .collect(),
    );
    // SLOW: 0.004/flight from 0.1: about 50 flights to go.
    write(
        "SLOW",
        (0..40)
            .map(|f| record(f, 0.1 + 0.004 * f as f32 + wiggle(f), Domain::Within))
            .collect(),
    );
    // HEALTHY, whose newest test was run on a jammed shaft.
    write(
        "HEALTHY",
        (0..40)
            .map(|f| {
                let d = if f == 39 {
                    Domain::Outside(OutsideReason::NoMotion { travel: 0.0 })
                } else {
                    Domain::Within
                };
                record(f, 0.02 + wiggle(f), d)
            })
            .collect(),
    );
    assert!(ingest(&db, &[&logs], &[]).0);
    let html = dir.path().join("report.html");
    let o = host_sim(&[
        "fleet",
        "report",
        "--db",
        s(&db),
        "--out",
        s(&html),
        "--detail",
        "2",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        text(&o).contains("3 actuators, 120 records; 1 flagged"),
        "{}",
        text(&o)
    );
    let page = std::fs::read_to_string(&html).unwrap();
    assert!(page.starts_with("<!DOCTYPE html>") && page.trim_end().ends_with("</html>"));
    assert!(page.contains("3 actuators, 120 health records"), "summary");
    // Ranked FAST, SLOW, HEALTHY (no crossing within the horizon).
    let at = |needle: &str| {
        page.find(needle)
            .unwrap_or_else(|| panic!("{needle} missing"))
    };
    let fast = at(">FAST<");
    let slow = at(">SLOW<");
    let healthy = at("<td class=\"l\">HEALTHY</td>");
    assert!(
        fast < slow && slow < healthy,
        "order {fast} {slow} {healthy}"
    );
    // The whole table row around position `at`.
    let row = |at: usize| {
        let from = page[..at].rfind("<tr").unwrap();
        &page[from..from + page[from..].find("</tr>").unwrap()]
    };
    let cells = |r: &str| -> Vec<String> {
        r.split("<td")
            .skip(1)
            .map(|c| {
                let c = &c[c.find('>').unwrap() + 1..];
                let c = c.strip_suffix("</td>").unwrap_or(c);
                c.replace("</td>", "")
            })
            .collect()
    };
    let fast_row = cells(row(fast));
    assert_eq!(fast_row[4], "friction");
    let lower: f32 = fast_row[6].parse().unwrap();
    let median: f32 = fast_row[7].parse().unwrap();
    let upper: f32 = fast_row[8].parse().unwrap();
    assert!(
        lower <= median && median <= upper && median < 5.0,
        "{fast_row:?}"
    );
    let slow_row = cells(row(slow));
    let slow_median: f32 = slow_row[7].parse().unwrap();
    assert!((30.0..80.0).contains(&slow_median), "{slow_row:?}");
    // The healthy one: no crossing, flagged for its newest test.
    let healthy_row = row(healthy);
    assert!(
        healthy_row.starts_with("<tr class=\"flag\">"),
        "{healthy_row}"
    );
    assert!(
        healthy_row.contains("newest preflight outside (no_motion)"),
        "{healthy_row}"
    );
    assert_eq!(
        page.matches("<tr class=\"flag\">").count(),
        1,
        "only HEALTHY flagged"
    );
    // Pictures for the first two only, with the fit, cone, threshold and interval.
    assert!(page.contains("id=\"a-FAST\"") && page.contains("id=\"a-SLOW\""));
    assert!(!page.contains("id=\"a-HEALTHY\""));
    let svgs = page
        .matches("<svg class=\"fault\" data-fault=\"friction\"")
        .count();
    assert_eq!(svgs, 2, "one friction picture each");
    for part in [
        "class=\"fit\"",
        "class=\"cone\"",
        "class=\"threshold\"",
        "class=\"interval\"",
    ] {
        assert_eq!(page.matches(part).count(), 2, "{part}");
    }
    assert_eq!(page.matches("class=\"obs\"").count(), 80);
}

#[test]
fn the_report_refuses_a_missing_store() {
    let dir = tempfile::tempdir().unwrap();
    let o = host_sim(&[
        "fleet",
        "report",
        "--db",
        s(&dir.path().join("none.sqlite")),
        "--out",
        s(&dir.path().join("r.html")),
    ]);
    assert!(!o.status.success());
    assert!(text(&o).contains("no such fleet store"), "{}", text(&o));
}
