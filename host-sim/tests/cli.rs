//! The CLI end to end: bad input exits non-zero with a message naming the problem (never a
//! panic); the demo and the footprint run and report.

use std::process::{Command, Output};

fn host_sim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(args)
        .output()
        .expect("host-sim runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn wrong_number_of_faults_is_refused_by_name() {
    let o = host_sim(&["inverse", "--faults", "0.1,0.2,0.3"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("expected 8"), "{}", stderr(&o));
    assert!(!stderr(&o).contains("panicked"));
}

#[test]
fn value_outside_unit_range_is_refused_by_name() {
    let o = host_sim(&["inverse", "--faults", "0,0,0,0,0,-0.2,0.5,0.5"]);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(
        e.contains("value 6") && e.contains("eccentricity") && e.contains("-0.2"),
        "{e}"
    );
}

#[test]
fn every_command_has_help() {
    for cmd in [
        vec!["--help"],
        vec!["inverse", "--help"],
        vec!["footprint", "--help"],
        vec!["bench", "--help"],
    ] {
        let o = host_sim(&cmd);
        assert!(o.status.success(), "{cmd:?}");
        assert!(
            String::from_utf8_lossy(&o.stdout).contains("Usage"),
            "{cmd:?}"
        );
    }
}

#[test]
fn footprint_is_within_the_budget() {
    let o = host_sim(&["footprint"]);
    assert!(o.status.success());
    let out = String::from_utf8_lossy(&o.stdout);
    let total: usize = out
        .lines()
        .find(|l| l.starts_with("total"))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|n| n.parse().ok())
        .expect("a total line");
    assert!(total <= 24 * 1024, "{out}");
}

#[test]
fn inverse_demo_reports_json() {
    let o = host_sim(&[
        "inverse",
        "--faults",
        "0,0,0,0,0,0,0.5,0.9",
        "--seed",
        "3",
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert_eq!(out.lines().count(), 1, "{out}");
    let e_tot: f64 = out
        .split("\"e_tot\":")
        .nth(1)
        .and_then(|r| r.split([',', '}']).next())
        .and_then(|v| v.parse().ok())
        .expect("e_tot in the JSON");
    assert!(e_tot <= 0.5, "{out}");
}
