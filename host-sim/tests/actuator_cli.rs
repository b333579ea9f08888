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

/// A preflight's test played again (`identify --again`), as the controller reads it: only
/// where the first test's noise calls for more, at most the file's `[test] max_tests`, the
/// mean of the trusted readings given; a trace of another test is refused.
#[test]
fn identify_reads_the_tests_played_again_that_the_noise_calls_for() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    for (seed, name) in [("21", "t0.bin"), ("22", "t1.bin"), ("23", "t2.bin")] {
        let o = host_sim(&[
            "simulate",
            "--faults",
            "0.2,0,0,0,0,0,0.5,0.5,0",
            "--noise",
            "0.5",
            "--seed",
            seed,
            "--format",
            "bin",
            "--out",
            &path(name),
        ]);
        assert!(o.status.success(), "{}", text(&o));
    }
    let reference = std::fs::read_to_string(example("reference.toml")).unwrap();
    let two = reference.replace("# max_tests = 4", "max_tests = 2");
    std::fs::write(path("two.toml"), two).unwrap();
    let identify = |actuator: &str| {
        let o = host_sim(&[
            "identify",
            &path("t0.bin"),
            "--actuator",
            actuator,
            "--again",
            &path("t1.bin"),
            "--again",
            &path("t2.bin"),
            "--json",
        ]);
        assert!(o.status.success(), "{}", text(&o));
        serde_json::from_slice::<serde_json::Value>(&o.stdout).unwrap()
    };
    // Two allowed: the noise (fitness ≈ 0.06 over a nominal residual of 0.014) calls for
    // more, so the second trace is read and the third left.
    let j = identify(&path("two.toml"));
    let r = &j["repeated"];
    assert_eq!(r["called_for"], 2, "{j}");
    assert_eq!(
        (r["played"].as_u64(), r["averaged"].as_u64()),
        (Some(2), Some(2))
    );
    let first = j["faults"][0].as_f64().unwrap();
    let mean = r["faults"][0].as_f64().unwrap();
    assert_ne!(first, mean, "the mean is not the first test's reading");
    assert!((mean - 0.2).abs() < 0.06, "{j}");
    let (sd, mean_sd) = (j["std"][0].as_f64().unwrap(), r["std"][0].as_f64().unwrap());
    assert!(
        mean_sd < sd,
        "two tests' deviation {mean_sd} against one's {sd}"
    );
    // The reference actuator's file allows one test: nothing else is read.
    let j = identify(example("reference.toml").to_str().unwrap());
    assert_eq!(j["repeated"]["played"], 1, "{j}");
    // A trace of another test design is refused, named (the actuator's test is the
    // injection's).
    let o = host_sim(&[
        "simulate",
        "--faults",
        "0.2,0,0,0,0,0,0.5,0.5,0",
        "--test",
        "paper",
        "--format",
        "bin",
        "--out",
        &path("paper.bin"),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let o = host_sim(&[
        "identify",
        &path("t0.bin"),
        "--actuator",
        &path("two.toml"),
        "--again",
        &path("paper.bin"),
    ]);
    assert!(!o.status.success());
    assert!(text(&o).contains("played the paper test"), "{}", text(&o));
}
