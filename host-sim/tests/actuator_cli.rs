//! The actuator file on the command line: a record written by `host-sim actuator` is what
//! `identify --actuator` and the firmware read; bad files and records are refused with exit
//! status 7, naming the key and its line.

use std::path::{Path, PathBuf};

mod common;
use common::*;

fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../actuators")
        .join(name)
}

#[test]
fn a_record_is_written_read_back_and_refused_when_damaged() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("light.rec");
    let light = example("light-28v.toml");
    let o = host_sim(&[
        "actuator",
        light.to_str().unwrap(),
        "--out",
        rec.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let bytes = std::fs::read(&rec).unwrap();
    assert_eq!(bytes.len(), shared::actuator::RECORD_BYTES);
    let o = host_sim(&["actuator", rec.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("5 pole pairs"), "{}", text(&o));
    // The light actuator's own systematic error, from its file's `[uncertainty]`.
    assert!(
        text(&o).contains("systematic     gain drift 0.009 (0.018 where a gear play is read)"),
        "{}",
        text(&o)
    );

    assert!(
        !text(&o).contains("survey this actuator's own"),
        "{}",
        text(&o)
    );
    // A description without its own survey is told to make one.
    let reference = std::fs::read_to_string(example("reference.toml")).unwrap();
    let start = reference.find("[uncertainty]").unwrap();
    let end = start + reference[start..].find("\n[").unwrap() + 1;
    let unsurveyed = dir.path().join("unsurveyed.toml");
    std::fs::write(
        &unsurveyed,
        format!("{}{}", &reference[..start], &reference[end..]),
    )
    .unwrap();
    let o = host_sim(&["actuator", unsurveyed.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        text(&o).contains("survey this actuator's own with `host-sim campaign --table 1+2"),
        "{}",
        text(&o)
    );

    let mut damaged = bytes.clone();
    damaged[100] ^= 0x04;
    let bad = dir.path().join("damaged.rec");
    std::fs::write(&bad, &damaged).unwrap();
    let o = host_sim(&["actuator", bad.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(7), "{}", text(&o));
    assert!(text(&o).contains("CRC-32"), "{}", text(&o));

    // A record cannot drive the simulator: it holds no sensors or extra physics.
    let trace = dir.path().join("t.csv");
    let o = host_sim(&[
        "simulate",
        "--actuator",
        rec.to_str().unwrap(),
        "--faults",
        "0,0,0,0,0,0,0.5,0.5",
        "--out",
        trace.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(7), "{}", text(&o));
    assert!(text(&o).contains("description (TOML)"), "{}", text(&o));
}

#[test]
fn a_bad_description_is_refused_with_its_key_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let source = std::fs::read_to_string(example("reference.toml")).unwrap();
    let bad = source.replace("user_inertia = 2.0 ", "user_inertia = -2.0");
    let line = bad
        .lines()
        .position(|l| l.starts_with("user_inertia"))
        .unwrap()
        + 1;
    let path = dir.path().join("bad.toml");
    std::fs::write(&path, bad).unwrap();
    for args in [
        vec!["actuator", path.to_str().unwrap()],
        vec![
            "preflight",
            "--actuator",
            path.to_str().unwrap(),
            "--faults",
            "0,0,0,0,0,0,0.5,0.5",
        ],
    ] {
        let o = host_sim(&args);
        assert_eq!(o.status.code(), Some(7), "{}", text(&o));
        let t = text(&o);
        assert!(
            t.contains("mechanics.user_inertia") && t.contains(&format!("line {line}")),
            "{t}"
        );
    }
    // --test cannot contradict the file's own test.
    let o = host_sim(&[
        "simulate",
        "--actuator",
        example("reference.toml").to_str().unwrap(),
        "--test",
        "paper",
        "--faults",
        "0,0,0,0,0,0,0.5,0.5",
        "--out",
        dir.path().join("x.csv").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(7), "{}", text(&o));
}
