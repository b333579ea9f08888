//! `degrade` and `prognose` end to end: a simulated degradation gives a history whose
//! identified faults follow the truth, the health log written beside it reads back, and the
//! RUL `prognose` reports follows the threshold and the growth it is given.

use std::path::Path;
use std::process::Output;

use host_sim::files::health::{history_csv, HistoryRow};
use shared::domain::{Domain, OutsideReason};
use shared::health::HealthRecord;
use shared::FaultVector;

mod common;
use common::*;

fn path_str(p: &Path) -> &str {
    p.to_str().expect("UTF-8 temp path")
}

/// Friction 0.1 + 0.01·f over flights 0..n, with a ±0.006 deterministic wiggle; flight 7 lies
/// outside the domain (and reads 0.9).
fn friction_history(n: u32) -> String {
    let rows: Vec<HistoryRow> = (0..n)
        .map(|f| {
            let mut k = *FaultVector::NOMINAL.as_array();
            let truth = 0.1 + 0.01 * f as f32;
            k[0] = truth + 0.006 * (((f * 37) % 7) as f32 / 3.0 - 1.0);
            let domain = if f == 7 {
                k[0] = 0.9;
                Domain::Outside(OutsideReason::CommandMismatch { tracking: 0.5 })
            } else {
                Domain::Within
            };
            let mut t = *FaultVector::NOMINAL.as_array();
            t[0] = truth;
            HistoryRow {
                record: HealthRecord::new(f, FaultVector::new(k).unwrap(), 0.01, domain),
                truth: Some(FaultVector::new(t).unwrap()),
                intrusion: (f == 7).then_some(host_sim::files::health::Intrusion::OtherCommand),
            }
        })
        .collect();
    history_csv(&rows)
}

/// `degrade` from a healthy actuator to `end` over `flights` flights into `out`, with `extra`
/// arguments.
fn healthy_degrade(out: &Path, end: &str, flights: &str, extra: &[&str]) -> Output {
    let mut args = vec![
        "degrade",
        "--faults-start",
        "0,0,0,0,0,0,0.5,0.5,0",
        "--faults-end",
        end,
        "--flights",
        flights,
        "--out",
        path_str(out),
    ];
    args.extend_from_slice(extra);
    host_sim(&args)
}

fn json(o: &Output) -> serde_json::Value {
    assert!(o.status.success(), "{}", text(o));
    serde_json::from_slice(&o.stdout).expect("one JSON object")
}

#[test]
fn prognose_reports_the_rul_the_trend_and_the_threshold_give() {
    let dir = tempfile::tempdir().unwrap();
    let history = dir.path().join("history.csv");
    std::fs::write(&history, friction_history(20)).unwrap();
    let h = path_str(&history);

    // 0.1 + 0.01·f reaches 0.5 at flight 40: 21 flights after the newest (19).
    let v = json(&host_sim(&["prognose", h, "--json"]));
    assert_eq!(v["records"], 20);
    assert_eq!(v["skipped"], 1, "flight 7 is outside the domain");
    let rul = &v["faults"]["friction"]["rul"];
    let flights = rul["flights"].as_f64().unwrap();
    assert!((flights - 21.0).abs() < 2.0, "{rul}");
    assert!(rul["lower"].as_f64().unwrap() <= flights);
    assert!(rul["upper"].as_f64().unwrap() >= flights);
    assert!(
        v["faults"]["backlash"]["rul"]["flights"].is_null(),
        "no growth, no RUL"
    );
    assert!(v["faults"].get("ecc_phase").is_none());

    // A lower threshold is reached sooner (0.3 at flight 20: one flight on).
    let low = json(&host_sim(&[
        "prognose",
        h,
        "--json",
        "--threshold",
        "friction=0.3",
    ]));
    let f_low = low["faults"]["friction"]["rul"]["flights"]
        .as_f64()
        .unwrap();
    assert!((f_low - 1.0).abs() < 1.5, "{f_low}");
    // Up to flight 9 only: 0.5 is 31 flights on.
    let early = json(&host_sim(&["prognose", h, "--json", "--at", "9"]));
    let f_early = early["faults"]["friction"]["rul"]["flights"]
        .as_f64()
        .unwrap();
    assert!((f_early - 31.0).abs() < 6.0, "{f_early}");

    // The table and the picture.
    let svg = dir.path().join("h.svg");
    let o = host_sim(&["prognose", h, "--plot", path_str(&svg)]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("friction"));
    let picture = std::fs::read_to_string(&svg).unwrap();
    assert!(picture.contains("friction") && picture.contains("RUL"));
}

#[test]
fn prognose_refuses_bad_input_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let history = dir.path().join("history.csv");
    std::fs::write(&history, friction_history(6)).unwrap();
    let h = path_str(&history);
    for (args, expect) in [
        (vec!["--threshold", "1.5"], "outside (0, 1]"),
        (vec!["--threshold", "frication=0.3"], "unknown fault"),
        (vec!["--at", "x"], "invalid value"),
    ] {
        let mut all = vec!["prognose", h];
        all.extend(args);
        let o = host_sim(&all);
        assert_eq!(o.status.code(), Some(2), "{}", text(&o));
        assert!(text(&o).contains(expect), "{}", text(&o));
    }
    let bad = dir.path().join("bad.csv");
    let damaged = friction_history(6).replace("\n3,", "\n3,x");
    std::fs::write(&bad, damaged).unwrap();
    let o = host_sim(&["prognose", path_str(&bad)]);
    assert_eq!(o.status.code(), Some(1));
    assert!(text(&o).contains("line 5"), "{}", text(&o));
    let o = host_sim(&["prognose", path_str(&dir.path().join("missing.csv"))]);
    assert_eq!(o.status.code(), Some(1));
    assert!(!text(&o).contains("panicked"));
}

#[test]
fn degrade_simulates_each_flight_and_writes_history_and_log() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("h.csv");
    let log = dir.path().join("h.bin");
    let o = host_sim(&[
        "degrade",
        "--faults-start",
        "0.1,0,0,0,0,0,0.5,0.5",
        "--faults-end",
        "0.3,0,0.2,0,0,0,0.5,0.5",
        "--flights",
        "3",
        "--seed",
        "4",
        "--out",
        path_str(&out),
        "--log",
        path_str(&log),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let csv = std::fs::read_to_string(&out).unwrap();
    let rows: Vec<Vec<f64>> = csv
        .lines()
        .skip(1)
        .map(|l| {
            l.split(',')
                .map(|c| c.parse().unwrap_or(f64::NAN))
                .collect()
        })
        .collect();
    assert_eq!(rows.len(), 3);
    // Columns: flight, 9 identified, fitness, domain, 9 standard deviations, the day (bus,
    // temperature, winding rise), 9 true.
    assert!(csv
        .lines()
        .next()
        .unwrap()
        .contains(",std_demagnetization,v_bus,temp,winding_rise,true_friction,"));
    for (f, r) in rows.iter().enumerate() {
        assert_eq!(r[0], f as f64);
        let truth_friction = 0.1 + 0.1 * f as f64;
        let truth_short = 0.1 * f as f64;
        assert!((r[24] - truth_friction).abs() < 1e-6, "{r:?}");
        assert!((r[26] - truth_short).abs() < 1e-6, "{r:?}");
        assert_eq!(r[32], 0.0, "no demagnetization played {r:?}");
        // The day as the record keeps it: the measured bus and thermistor, the winding's rise.
        assert!((r[21] - 270.0).abs() < 5.0, "bus {r:?}");
        assert!((r[22] - 22.0).abs() < 1.0, "temperature {r:?}");
        assert!(r[23].abs() < 8.0, "winding rise {r:?}");
        // The identification's standard deviation of friction, as the record keeps it.
        assert!(r[12] > 0.0 && r[12] < 0.1, "std of friction {r:?}");
        assert!(
            (r[1] - truth_friction).abs() < 0.03,
            "identified friction {r:?}"
        );
        assert!(
            (r[3] - truth_short).abs() < 0.03,
            "identified short A {r:?}"
        );
    }
    assert!(csv.lines().skip(1).all(|l| l.contains(",within,")));
    // The log holds the same records, and prognose reads it.
    assert_eq!(
        std::fs::metadata(&log).unwrap().len(),
        32 * shared::health::RECORD_BYTES as u64
    );
    let from_log = json(&host_sim(&["prognose", path_str(&log), "--json"]));
    let from_csv = json(&host_sim(&["prognose", path_str(&out), "--json"]));
    assert_eq!(from_log, from_csv);
}

/// The ninth fault has its trend and RUL: magnets losing flux at a steady 1 % per flight
/// (k9 0 → 0.24 over 12 flights, the reference model's uniform loss, identified each flight)
/// give a level and a slope near the truth and an RUL to the 0.3 threshold whose 90 %
/// interval holds the true remaining flights; the components not degrading have none.
#[test]
fn a_demagnetizing_actuator_gets_its_own_trend_and_rul() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("magnets.csv");
    let o = healthy_degrade(&out, "0,0,0,0,0,0,0.5,0.5,0.24", "12", &[]);
    assert!(o.status.success(), "{}", text(&o));
    let v = json(&host_sim(&["prognose", path_str(&out), "--json"]));
    let k9 = &v["faults"]["demagnetization"];
    let level = k9["level"].as_f64().unwrap();
    let slope = k9["slope"].as_f64().unwrap();
    assert!((level - 0.24).abs() < 0.02, "{k9}");
    assert!((slope - 0.24 / 11.0).abs() < 0.004, "{k9}");
    assert_eq!(
        k9["threshold"].as_f64().map(|t| (t * 100.0).round()),
        Some(30.0)
    );
    // 0.3 is reached 0.06 / 0.0218 = 2.75 flights after the last.
    let rul = &k9["rul"];
    let (lower, upper) = (
        rul["lower"].as_f64().unwrap(),
        rul["upper"].as_f64().unwrap(),
    );
    assert!(lower <= 2.75 && 2.75 <= upper, "{k9}");
    for healthy in ["friction", "short_a", "gain_drift"] {
        assert!(
            v["faults"][healthy]["rul"]["flights"].is_null(),
            "{healthy}: {}",
            v["faults"][healthy]
        );
    }
}

#[test]
fn a_weakening_magnet_gets_its_own_trend_and_rul() {
    // One magnet at pole 3 from none to 0.45 of its flux over 12 flights (0.041 a flight):
    // read from about flight 2, 0.5 is reached 1.4 flights after the last.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("weak-magnet.csv");
    let o = healthy_degrade(
        &out,
        "0,0,0,0,0,0,0.5,0.5,0",
        "12",
        &["--weak-magnet", "0.45@3"],
    );
    assert!(o.status.success(), "{}", text(&o));
    let v = json(&host_sim(&["prognose", path_str(&out), "--json"]));
    let m = &v["faults"]["weak_magnet"];
    let level = m["level"].as_f64().unwrap();
    assert!((level - 0.45).abs() < 0.05, "{m}");
    assert_eq!(
        m["threshold"].as_f64().map(|t| (t * 100.0).round()),
        Some(50.0)
    );
    let n = m["observations"].as_u64().unwrap();
    assert!((7..=10).contains(&n), "from the first magnet read: {m}");
    let rul = &m["rul"];
    let (lower, upper) = (
        rul["lower"].as_f64().unwrap(),
        rul["upper"].as_f64().unwrap(),
    );
    assert!(lower <= 1.4 && 1.4 <= upper, "{m}");
    assert_eq!(v["weak_magnet"]["newest_verdict"], "FAULT", "{v}");
    // Nothing else grows; a threshold of 0.3 for the magnet is reached already.
    assert!(
        v["faults"]["eccentricity"]["rul"]["flights"].is_null(),
        "{v}"
    );
    let v = json(&host_sim(&[
        "prognose",
        path_str(&out),
        "--json",
        "--threshold",
        "weak_magnet=0.3",
    ]));
    assert_eq!(v["faults"]["weak_magnet"]["rul"]["flights"], 0.0, "{v}");
    // The path's pole and loss are checked as the command line writes them.
    let o = healthy_degrade(
        &out,
        "0,0,0,0,0,0,0.5,0.5,0",
        "3",
        &["--weak-magnet", "0.45@8"],
    );
    assert!(!o.status.success());
    assert!(text(&o).contains("poles 0 … 7"), "{}", text(&o));
}

/// With windows of flight, each flight's history holds its preflight, each window's own
/// entry and — when a window entered — the flight's reading from its windows fused (window
/// `flight`, the windows fused counted); the trend takes the preflights and the flights'
/// readings that are `within`, never a window's own entry. Eight windows per flight (the
/// design): a flight's friction must be read to σ ≤ 0.03
/// (`shared::fusion::FLIGHT_MAX_FRICTION_STD`), which fewer light windows seldom reach. Six
/// flights: with the flights' friction widened 1.1 times (`FLIGHT_INFLATION`) none of the
/// first four reaches it (σ 0.031–0.039), the fifth and sixth do; a flight
/// kept out by that limit alone into which a pinned window entered ends on the preflight's
/// friction (`WindowFusion::final_reading`: read, its friction not counted again).
#[test]
fn degrade_with_windows_writes_each_flights_reading_and_the_trend_takes_it() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("flown.csv");
    let o = host_sim(&[
        "degrade",
        "--faults-start",
        "0.1,0,0,0,0,0,0.5,0.5,0",
        "--faults-end",
        "0.4,0,0,0,0,0,0.5,0.5,0",
        "--flights",
        "6",
        "--windows",
        "8",
        "--out",
        path_str(&out),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("flights' readings"), "{}", text(&o));
    let csv = std::fs::read_to_string(&out).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    assert_eq!(&header[..4], ["flight", "window", "fused", "friction"]);
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (domain, true_friction, std_friction) =
        (col("domain"), col("true_friction"), col("std_friction"));
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    let mut trended = 0;
    let mut flights_read = 0;
    for flight in 0..6 {
        let of: Vec<&Vec<&str>> = rows.iter().filter(|r| r[0] == flight.to_string()).collect();
        let windows: Vec<&str> = of.iter().map(|r| r[1]).collect();
        assert!(
            windows[..9] == ["0", "1", "2", "3", "4", "5", "6", "7", "8"] && of.len() <= 10,
            "flight {flight}: {windows:?}"
        );
        trended += usize::from(of[0][domain] == "within");
        if let Some(read) = of.get(9) {
            assert_eq!(read[1], "flight", "{read:?}");
            let fused: u32 = read[2].parse().unwrap();
            assert!((1..=8).contains(&fused), "{read:?}");
            assert!(of[1..9].iter().all(|w| w[2] == "0"), "{of:?}");
            if read[domain] == "within" {
                flights_read += 1;
                // A flight that ends on its pinned windows' friction, the preflight's
                // (`WindowFusion::final_reading`), states no friction deviation: the trend
                // counts that friction once, at the preflight.
                let std: f64 = read[std_friction].parse().unwrap_or(f64::NAN);
                trended += usize::from(std.is_finite());
                if !std.is_finite() {
                    assert_eq!(read[3], of[0][3], "the preflight's friction: {of:?}");
                }
                let (found, truth): (f64, f64) = (
                    read[3].parse().unwrap(),
                    read[true_friction].parse().unwrap(),
                );
                assert!((found - truth).abs() < 0.08, "{read:?}");
            }
        }
    }
    assert!(flights_read >= 1, "no flight read from its windows:\n{csv}");
    let v = json(&host_sim(&["prognose", path_str(&out), "--json"]));
    assert_eq!(v["faults"]["friction"]["observations"], trended, "{v}");
}
