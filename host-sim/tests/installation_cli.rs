//! The command line on a changed installation and a calibration that must say what it
//! measured: a replaced drive is named with what did not fit, a late controller's trace is
//! refused by `calibrate` with the delay that would explain it, `--at` traces that cannot
//! make a friction law are refused by name, and a trace without a temperature is not
//! identified against a friction law.

use std::process::Output;

mod common;
use common::*;

const HEALTHY: &str = "0,0,0,0,0,0,0.5,0.5";

fn path(dir: &tempfile::TempDir, name: &str) -> String {
    dir.path().join(name).to_string_lossy().into_owned()
}

fn simulate(out: &str, extra: &[&str]) {
    let mut args = vec!["simulate", "--faults", HEALTHY, "--out", out];
    args.extend_from_slice(extra);
    let o = host_sim(&args);
    assert!(o.status.success(), "{}", text(&o));
}

fn refused(o: &Output, words: &[&str]) {
    let t = text(o);
    assert!(!o.status.success(), "{t}");
    assert!(!t.contains("panicked"), "{t}");
    for w in words {
        assert!(t.contains(w), "{w:?} in {t}");
    }
}

#[test]
fn a_replaced_drive_is_named_with_the_part_of_the_test_that_did_not_fit() {
    let dir = tempfile::tempdir().unwrap();
    let trace = path(&dir, "slow-switches.bin");
    simulate(&trace, &["--dead-time", "2e-6", "--format", "bin"]);
    let o = host_sim(&["identify", &trace]);
    assert_eq!(o.status.code(), Some(4), "{}", text(&o));
    let t = text(&o);
    assert!(t.contains("InstallationChanged"), "{t}");
    assert!(
        t.contains("unexplained") && t.contains("injection A→B"),
        "{t}"
    );
}

#[test]
fn calibrate_names_an_undeclared_controller_delay() {
    let dir = tempfile::tempdir().unwrap();
    let trace = path(&dir, "late.csv");
    simulate(&trace, &["--duty-delay", "5e-5"]);
    let o = host_sim(&["calibrate", &trace, "--out", &path(&dir, "c.json")]);
    refused(&o, &["duty_delay", "µs after their sample"]);
}

#[test]
fn at_traces_that_cannot_make_a_friction_law_are_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let warm = path(&dir, "warm.csv");
    let cold = path(&dir, "cold.csv");
    let arctic = path(&dir, "arctic.csv");
    simulate(&warm, &[]);
    simulate(&cold, &["--temperature", "-25"]);
    simulate(&arctic, &["--temperature", "-60"]);
    let out = path(&dir, "c.json");
    let o = host_sim(&[
        "calibrate",
        &warm,
        "--at",
        &cold,
        "--at",
        &cold,
        "--out",
        &out,
    ]);
    refused(&o, &["the same trace as"]);
    let o = host_sim(&["calibrate", &warm, "--at", &warm, "--out", &out]);
    refused(&o, &["the same trace as"]);
    let o = host_sim(&["calibrate", &warm, "--at", &arctic, "--out", &out]);
    refused(&o, &["outside the description's [domain] temperature"]);
    // Without --at the built-in actuator's law is not written, and the report says so.
    let o = host_sim(&["calibrate", &warm, "--out", &out]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        text(&o).contains("friction law        none"),
        "{}",
        text(&o)
    );
    let c: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert!(
        c["friction_points"]
            .as_array()
            .unwrap()
            .iter()
            .all(|p| p[1].as_f64() == Some(0.0)),
        "{c}"
    );
    // With one --at trace, one point.
    let o = host_sim(&["calibrate", &warm, "--at", &cold, "--out", &out]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("friction at  -23.0 °C"), "{}", text(&o));
}

#[test]
fn a_trace_without_temperature_is_not_identified_against_a_friction_law() {
    let dir = tempfile::tempdir().unwrap();
    let trace = path(&dir, "v3.csv");
    simulate(&trace, &["--temperature", "-20"]);
    // The same trace as version 2: without the v_bus and temp columns.
    let v2: String = std::fs::read_to_string(&trace)
        .unwrap()
        .lines()
        .map(|line| {
            if line.starts_with('#') {
                line.to_string()
            } else {
                line.split(',').take(7).collect::<Vec<_>>().join(",")
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    let stripped = path(&dir, "v2.csv");
    std::fs::write(&stripped, v2 + "\n").unwrap();
    // The built-in calibration has the reference actuator's friction law.
    let o = host_sim(&["identify", &stripped]);
    refused(&o, &["no measured temperature", "friction law"]);
}

#[test]
fn the_grease_study_runs_on_an_actuator_file_and_other_studies_still_refuse_it() {
    let dir = tempfile::tempdir().unwrap();
    let out = path(&dir, "grease.md");
    let o = host_sim(&[
        "identifiability",
        "--grease",
        "--seeds",
        "3",
        "--actuator",
        "../actuators/light-28v.toml",
        "--out",
        &out,
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let table = std::fs::read_to_string(&out).unwrap();
    assert!(table.starts_with("### light EMA"), "{table}");
    // 2 greases × 6 days × 5 cases.
    let rows = table
        .lines()
        .filter(|l| l.starts_with("| one factor") || l.starts_with("| two-part"));
    assert_eq!(rows.count(), 60, "{table}");
    let o = host_sim(&[
        "identifiability",
        "--day",
        "--actuator",
        "../actuators/light-28v.toml",
    ]);
    assert_eq!(o.status.code(), Some(7), "{}", text(&o));
}

/// Demagnetized magnets on the command line (issue 35): a form the parser does not know, a
/// loss beyond the flux and a pole the rotor does not have are refused by name; a valid one
/// is played and the FDI's verdict printed.
#[test]
fn demagnetization_is_played_or_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let out = path(&dir, "demag.csv");
    for (arg, words) in [
        ("ring:0.1", &["expected uniform or partial"][..]),
        ("uniform:1.2", &["not a share"][..]),
        ("partial:0.5@8", &["pole 8", "8 poles"][..]),
    ] {
        let o = host_sim(&[
            "simulate",
            "--faults",
            HEALTHY,
            "--out",
            &out,
            "--demagnetization",
            arg,
        ]);
        refused(&o, words);
    }
    let o = host_sim(&[
        "preflight",
        "--faults",
        HEALTHY,
        "--demagnetization",
        "partial:0.5@7",
    ]);
    let t = text(&o);
    assert!(!t.contains("panicked"), "{t}");
    assert!(t.contains("gain_drift"), "{t}");
}
