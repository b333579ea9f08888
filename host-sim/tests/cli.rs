//! The CLI end to end: bad input exits non-zero with a message naming the problem (never a
//! panic); the demo and the footprint run and report.

use std::process::Output;

mod common;
use common::*;

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn wrong_number_of_faults_is_refused_by_name() {
    let o = host_sim(&["inverse", "--faults", "0.1,0.2,0.3"]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("expected 9") && stderr(&o).contains("the paper's first 8"),
        "{}",
        stderr(&o)
    );
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
fn prognostics_help_gives_the_controllers_trend_defaults() {
    let o = host_sim(&["prognostics", "--help"]);
    assert!(o.status.success());
    let help = String::from_utf8_lossy(&o.stdout).into_owned();
    let flown = shared::prognosis::TrendSettings::DEFAULT;
    for (option, value) in [
        ("--noise-floor", flown.noise_floor),
        ("--systematic", flown.systematic),
    ] {
        let line = help
            .lines()
            .find(|l| l.contains(option))
            .unwrap_or_else(|| panic!("no {option} in\n{help}"));
        assert!(
            line.contains(&format!("the controller's, {value})")),
            "{line}"
        );
    }
}

#[test]
fn the_prognostics_reading_studies_are_refused_beside_windows_or_out_of_range() {
    for (args, expected) in [
        (
            &["--ideal-readings", "0.005", "--windows", "4"][..],
            "--windows",
        ),
        (&["--lean-removed", "--windows", "4"][..], "--windows"),
        (
            &["--lean-removed", "--ideal-readings", "0"][..],
            "--ideal-readings",
        ),
        (&["--ideal-readings", "0.7"][..], "outside [0, 0.5]"),
        (&["--ideal-readings", "x"][..], "not a number"),
        (&["--ideal-readings", "0,0.01"][..], "give --histories DIR"),
    ] {
        let o = host_sim(&[&["prognostics"][..], args].concat());
        assert!(!o.status.success(), "{args:?}");
        let e = stderr(&o);
        assert!(
            e.contains(expected) && !e.contains("panicked"),
            "{args:?}: {e}"
        );
    }
}

#[test]
fn every_command_has_help() {
    for cmd in [
        vec!["--help"],
        vec!["inverse", "--help"],
        vec!["footprint", "--help"],
        vec!["flash-pair", "--help"],
        vec!["bench", "--help"],
        vec!["preflight", "--help"],
        vec!["simulate", "--help"],
        vec!["calibrate", "--help"],
        vec!["identify", "--help"],
        vec!["plot", "--help"],
        vec!["degrade", "--help"],
        vec!["prognose", "--help"],
        vec!["prognostics", "--help"],
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

fn json(o: &Output) -> serde_json::Value {
    let out = String::from_utf8_lossy(&o.stdout);
    assert_eq!(out.lines().count(), 1, "exactly one JSON line: {out}");
    serde_json::from_str(&out).expect("valid JSON")
}

fn path(dir: &tempfile::TempDir, name: &str) -> String {
    dir.path().join(name).to_string_lossy().into_owned()
}

const FRICTION: &str = "0.4,0,0,0,0,0,0.5,0.5";

#[test]
fn simulate_then_identify_finds_a_clear_single_fault() {
    let dir = tempfile::tempdir().unwrap();
    let bin = path(&dir, "friction.bin");
    let csv = path(&dir, "friction.csv");
    for (file, format) in [(&bin, "bin"), (&csv, "csv")] {
        let o = host_sim(&[
            "simulate", "--faults", FRICTION, "--format", format, "--out", file,
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let o = host_sim(&["identify", &bin, "--truth", FRICTION, "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).is_empty(),
        "no progress bar in JSON mode: {}",
        stderr(&o)
    );
    let v = json(&o);
    let faults: Vec<f64> = v["faults"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert_eq!(faults.len(), 9);
    for key in ["fitness", "evaluations", "seconds", "e_tot", "e_tot_all"] {
        assert!(v[key].is_number(), "{key} in {v}");
    }
    assert!((faults[0] - 0.4).abs() < 0.05, "{v}");
    assert!(v["e_tot"].as_f64().unwrap() < 2.0, "{v}");
    let verdicts: Vec<&str> = v["verdicts"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_str().unwrap())
        .collect();
    assert_eq!(
        verdicts,
        [
            "FAULT", "healthy", "healthy", "healthy", "healthy", "healthy", "-", "healthy",
            "healthy"
        ],
        "{v}"
    );

    // The CSV of the same simulation identifies to the same bits.
    let o = host_sim(&["identify", &csv, "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let w = json(&o);
    assert_eq!(w["faults"], v["faults"]);
    assert_eq!(w["fitness"], v["fitness"]);
    assert!(w.get("e_tot").is_none(), "no e_tot without --truth: {w}");
}

#[test]
fn calibrate_then_identify_and_plot() {
    let dir = tempfile::tempdir().unwrap();
    let healthy = path(&dir, "healthy.csv");
    let cal = path(&dir, "cal.json");
    let svg = path(&dir, "fit.svg");
    let o = host_sim(&[
        "simulate",
        "--faults",
        "0,0,0,0,0,0,0.5,0.5",
        "--seed",
        "4",
        "--out",
        &healthy,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = host_sim(&["calibrate", &healthy, "--out", &cal]);
    assert!(o.status.success(), "{}", stderr(&o));
    let c: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&cal).unwrap()).unwrap();
    assert_eq!(c["format"], "ema-fdi calibration");
    assert!(c["mismatch_after"].as_f64().unwrap() <= c["mismatch_before"].as_f64().unwrap());
    // A healthy trace against its own calibration: nothing flagged.
    let o = host_sim(&["identify", &healthy, "--calibration", &cal, "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v = json(&o);
    assert!(
        v["verdicts"]
            .as_array()
            .unwrap()
            .iter()
            .all(|x| x != "FAULT"),
        "{v}"
    );
    let o = host_sim(&["plot", &healthy, "--calibration", &cal, "--out", &svg]);
    assert!(o.status.success(), "{}", stderr(&o));
    let picture = std::fs::read_to_string(&svg).unwrap();
    assert!(
        picture.starts_with("<svg") && picture.contains("<polyline"),
        "an SVG with lines"
    );
}

#[test]
fn missing_or_broken_files_are_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let missing = path(&dir, "nope.csv");
    let o = host_sim(&["identify", &missing]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("cannot open trace") && stderr(&o).contains("nope.csv"),
        "{}",
        stderr(&o)
    );

    let garbage = path(&dir, "garbage.csv");
    std::fs::write(&garbage, "time,current\n0,1\n").unwrap();
    let o = host_sim(&["calibrate", &garbage, "--out", &path(&dir, "c.json")]);
    assert_eq!(o.status.code(), Some(3), "trace refused");
    assert!(
        stderr(&o).contains("unknown column `time`"),
        "{}",
        stderr(&o)
    );

    let bad_cal = path(&dir, "bad.json");
    std::fs::write(
        &bad_cal,
        "{\"format\":\"ema-fdi calibration\",\"version\":7}",
    )
    .unwrap();
    let trace = path(&dir, "t.bin");
    let o = host_sim(&[
        "simulate", "--faults", FRICTION, "--format", "bin", "--out", &trace,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = host_sim(&["identify", &trace, "--calibration", &bad_cal]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("bad.json"), "{}", stderr(&o));

    for args in [
        vec![
            "simulate", "--faults", FRICTION, "--noise", "-1", "--out", &missing,
        ],
        vec!["simulate", "--faults", "0,0,0", "--out", &missing],
        vec!["preflight", "--faults", "0,0,0,0,0,0,0.5,1.5"],
    ] {
        let o = host_sim(&args);
        assert!(!o.status.success(), "{args:?}");
        let e = stderr(&o);
        assert!(!e.contains("panicked"), "{e}");
        assert!(
            e.contains("-1") || e.contains("expected 9") || e.contains("value 8"),
            "{args:?}: {e}"
        );
    }
}

#[test]
fn a_campaign_writes_every_run_as_a_csv_row() {
    let dir = tempfile::tempdir().unwrap();
    let csv = path(&dir, "runs.csv");
    let o = host_sim(&[
        "campaign",
        "--table",
        "1",
        "--runs",
        "1",
        "--runs-csv",
        &csv,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    assert!(lines.next().unwrap().starts_with(
        "case,run,e_tot,e_tot_all,fitness,fitness_at_truth,evaluations,curvatures,within,friction,"
    ));
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(
        rows.len(),
        host_sim::studies::campaign::TABLE_1.len(),
        "one row per Table I case: {text}"
    );
    for r in &rows {
        assert_eq!(r.len(), 27, "{r:?}");
        // The friction's standard deviation is determined on every Table I case.
        let std: f64 = r[18].parse().unwrap();
        assert!(std > 0.0 && std < 1.0, "{r:?}");
        let e_tot: f64 = r[2].parse().unwrap();
        let evaluations: u32 = r[6].parse().unwrap();
        assert!((0.0..20.0).contains(&e_tot), "{r:?}");
        assert!((32..=6000).contains(&evaluations), "{r:?}");
        // A preflight's gain-drift deviation states its systematic error: a play's where it
        // reads one (Table I's backlash cases), the one of all runs elsewhere.
        let (backlash, std_gain_drift): (f32, f32) =
            (r[10].parse().unwrap(), r[25].parse().unwrap());
        let systematic = if backlash >= shared::fault::DETECTION_THRESHOLD {
            shared::uncertainty::PLAY_GAIN_DRIFT_SYSTEMATIC
        } else {
            shared::uncertainty::SYSTEMATIC[7]
        };
        assert!(std_gain_drift >= systematic, "{r:?}");
    }
    assert!(
        rows.iter().any(|r| r[0].starts_with("backlash")
            && r[10].parse::<f32>().unwrap() >= shared::fault::DETECTION_THRESHOLD),
        "a backlash case reads its play: {text}"
    );
    // The calibration's rule, over all runs and over those that read a play.
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("the least systematic error"), "{out}");
    assert!(
        out.contains("The same over the runs that read a gear play"),
        "{out}"
    );
}

/// The board's record pair: the image `flash-pair --write` makes from `actuator --out`'s
/// record reads back (`--read`, as from a dump of the pair) to the same record bytes; a dump
/// of the wrong size and one with no item are refused by name.
#[test]
fn a_record_goes_to_a_flash_pair_image_and_back() {
    let dir = tempfile::tempdir().unwrap();
    let record = path(&dir, "light.rec");
    let image = path(&dir, "record-pair.bin");
    let back = path(&dir, "back.rec");
    let o = host_sim(&["actuator", "../actuators/light-28v.toml", "--out", &record]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = host_sim(&[
        "flash-pair",
        "--store",
        "record",
        "--write",
        &record,
        "--out",
        &image,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("flash it at 0x08020000"));
    assert_eq!(std::fs::metadata(&image).unwrap().len(), 256 * 1024);
    let o = host_sim(&[
        "flash-pair",
        "--store",
        "record",
        "--read",
        &image,
        "--out",
        &back,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(&back).unwrap(),
        std::fs::read(&record).unwrap()
    );
    // Half a pair, and an erased pair.
    let half = path(&dir, "half.bin");
    std::fs::write(&half, vec![0xFFu8; 128 * 1024]).unwrap();
    let o = host_sim(&[
        "flash-pair",
        "--store",
        "health",
        "--read",
        &half,
        "--out",
        &back,
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("two 128 KiB sectors"), "{}", stderr(&o));
    let erased = path(&dir, "erased.bin");
    std::fs::write(&erased, vec![0xFFu8; 256 * 1024]).unwrap();
    let o = host_sim(&[
        "flash-pair",
        "--store",
        "health",
        "--read",
        &erased,
        "--out",
        &back,
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("no whole item"), "{}", stderr(&o));
    assert!(!stderr(&o).contains("panicked"));
}

/// Windows of one flight fused (`identify W1 --same-flight W2 …`): eight cruise windows in
/// light turbulence, friction 0.2, read to a flight's reading whose friction σ is smaller
/// than any one window's and whose value is right; a preflight trace is refused as a window.
#[test]
fn windows_of_one_flight_are_read_together() {
    let dir = tempfile::tempdir().unwrap();
    let truth = "0.2,0,0,0,0,0,0.5,0.5,0";
    let windows: Vec<String> = (1..=8)
        .map(|seed| {
            let file = path(&dir, &format!("w{seed}.csv"));
            let o = host_sim(&[
                "simulate",
                "--flight",
                "cruise",
                "--turbulence",
                "light",
                "--faults",
                truth,
                "--seed",
                &seed.to_string(),
                "--out",
                &file,
            ]);
            assert!(o.status.success(), "{}", stderr(&o));
            file
        })
        .collect();
    let mut args = vec!["identify", &windows[0], "--truth", truth, "--json"];
    for w in &windows[1..] {
        args.extend(["--same-flight", w.as_str()]);
    }
    let o = host_sim(&args);
    let v = json(&o);
    let flight = &v["flight"];
    assert_eq!(flight["windows"], 8, "{v}");
    assert_eq!(v["windows"].as_array().map(Vec::len), Some(8), "{v}");
    let std = flight["std"][0].as_f64().unwrap();
    let friction = flight["faults"][0].as_f64().unwrap();
    // One window reads friction to σ ≈ 0.07 here (calibrated), eight to about a third of
    // that: below the flight's limit 0.03 (`shared::fusion::FLIGHT_MAX_FRICTION_STD`).
    assert!(std < 0.045, "friction σ {std}: {flight}");
    assert!(
        (friction - 0.2).abs() < 0.06,
        "friction {friction}: {flight}"
    );
    assert_eq!(flight["verdict"], "within", "{flight}");
    assert!(o.status.success(), "{}", stderr(&o));

    let pre = path(&dir, "preflight.csv");
    let o = host_sim(&["simulate", "--faults", FRICTION, "--out", &pre]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = host_sim(&["identify", &windows[0], "--same-flight", &pre]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("not a window of flight"),
        "{}",
        stderr(&o)
    );
}

/// A window whose current the window's load cannot follow (a gear play a hundred times
/// nominal, cruise) is named `fitness_floor` and says what that most often means, in text
/// and JSON; a window identified says nothing of the kind. Given the same flight's
/// preflight, the worn window is read with its surface pinned to its sensor instead.
#[test]
fn a_window_at_the_fitness_floor_names_the_play_and_is_read_pinned_after_a_preflight() {
    let dir = tempfile::tempdir().unwrap();
    let window = |faults: &str, name: &str| {
        let file = path(&dir, name);
        let o = host_sim(&[
            "simulate",
            "--flight",
            "cruise",
            "--turbulence",
            "light",
            "--faults",
            faults,
            "--seed",
            "1",
            "--out",
            &file,
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        file
    };
    let worn = window("0,1,0,0,0,0,0.5,0.5,0", "worn.csv");
    let o = host_sim(&["identify", &worn]);
    assert!(!o.status.success());
    let text = String::from_utf8_lossy(&o.stdout).to_string();
    assert!(text.contains("fitness_floor"), "{text}");
    assert!(text.contains("gear play several times nominal"), "{text}");
    assert!(text.contains("Noise on the current"), "{text}");
    let v = json(&host_sim(&["identify", &worn, "--json"]));
    assert_eq!(v["verdict"], "fitness_floor", "{v}");
    assert!(v["hint"]
        .as_str()
        .is_some_and(|h| h.contains("preflight reads the backlash")));

    let sound = window("0.2,0,0,0,0,0,0.5,0.5,0", "sound.csv");
    let v = json(&host_sim(&["identify", &sound, "--json"]));
    assert_eq!(v["verdict"], "within", "{v}");
    assert!(v["hint"].is_null(), "{v}");
    assert_eq!(v["model"], "load", "{v}");

    // With the same flight's preflight the worn window is read again with its surface
    // pinned to its sensor: the play and the gain drift read, the friction the preflight's.
    let pre = path(&dir, "worn-preflight.csv");
    let o = host_sim(&[
        "simulate",
        "--faults",
        "0,1,0,0,0,0,0.5,0.5,0",
        "--seed",
        "1",
        "--out",
        &pre,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v = json(&host_sim(&[
        "identify",
        &worn,
        "--preflight",
        &pre,
        "--truth",
        "0,1,0,0,0,0,0.5,0.5,0",
        "--json",
    ]));
    assert_eq!(v["verdict"], "within", "{v}");
    assert_eq!(v["model"], "pinned", "{v}");
    let k = v["faults"].as_array().unwrap();
    assert!(k[1].as_f64().unwrap() > 0.95, "backlash {v}");
    assert!(
        (k[7].as_f64().unwrap() - 0.5).abs() < 0.01,
        "gain drift {v}"
    );
    assert!(v["e_tot"].as_f64().unwrap() < 2.0, "{v}");
    let o = host_sim(&["identify", &worn, "--preflight", &pre]);
    let text = String::from_utf8_lossy(&o.stdout).to_string();
    assert!(text.contains("read with the surface pinned"), "{text}");

    // A healthy gear in moderate climb whose load model is at its floor: pinned, the play's
    // two ends fit alike (read as a play of 0.99 before the contrast was judged).
    let v = healthy_moderate_window(&dir, &[], "climb");
    assert_eq!(v["verdict"], "fitness_floor", "{v}");
    assert_eq!(v["pinned_verdict"], "play_unseen", "{v}");
    assert!(v["hint"]
        .as_str()
        .is_some_and(|h| h.contains("two ends fit about as well")));
}

/// A healthy window flown under the paper's 50 % I_ref noise is named `fitness_floor`, never
/// read, and its hint names the noise beside the play.
#[test]
fn a_noisy_window_is_named_at_the_floor_and_its_hint_names_the_noise() {
    let dir = tempfile::tempdir().unwrap();
    let file = path(&dir, "noisy.csv");
    let o = host_sim(&[
        "simulate",
        "--flight",
        "cruise",
        "--turbulence",
        "light",
        "--faults",
        "0,0,0,0,0,0,0.5,0.5,0",
        "--noise",
        "0.5",
        "--seed",
        "2",
        "--out",
        &file,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v = json(&host_sim(&["identify", &file, "--json"]));
    assert_eq!(v["verdict"], "fitness_floor", "{v}");
    assert!(
        v["hint"]
            .as_str()
            .is_some_and(|h| h.contains("Noise on the current") && h.contains("gear play")),
        "{v}"
    );
}

/// A healthy gear flown in `phase` in moderate turbulence (seed 7) and its flight's preflight
/// (seed 1007), simulated under `dir` for the actuator `actuator` names (`--actuator FILE`,
/// or none: the built-in one), and the window identified with that preflight (GA seed 8,
/// the truth given): `identify --json`'s answer.
fn healthy_moderate_window(
    dir: &tempfile::TempDir,
    actuator: &[&str],
    phase: &str,
) -> serde_json::Value {
    let healthy = "0,0,0,0,0,0,0.5,0.5,0";
    let (window, ground) = (path(dir, &format!("{phase}.csv")), path(dir, "ground.csv"));
    for (args, out) in [
        (
            vec!["--flight", phase, "--turbulence", "moderate", "--seed", "7"],
            &window,
        ),
        (vec!["--seed", "1007"], &ground),
    ] {
        let mut a = vec!["simulate", "--faults", healthy, "--out", out.as_str()];
        a.extend(actuator);
        a.extend(args);
        let o = host_sim(&a);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let mut a = vec!["identify", &window, "--preflight", &ground, "--seed", "8"];
    a.extend(actuator);
    a.extend(["--truth", healthy, "--json"]);
    json(&host_sim(&a))
}

/// A healthy gear's window whose gain-drift needle lies elsewhere at a middle play than at
/// none (the light actuator in moderate approach, seed 7): its pinned search scans the
/// needle at both plays and reads it (`fitness_floor` when it scanned at 0.5 alone: 3.7 %
/// of the current left).
#[test]
fn a_healthy_gears_window_is_read_pinned_with_its_gain_drift_scanned_at_no_play() {
    let dir = tempfile::tempdir().unwrap();
    let v = healthy_moderate_window(
        &dir,
        &["--actuator", "../actuators/light-28v.toml"],
        "approach",
    );
    assert_eq!(v["verdict"], "within", "{v}");
    assert_eq!(v["model"], "pinned", "{v}");
    let k = v["faults"].as_array().unwrap();
    assert!(k[1].as_f64().unwrap() < 0.05, "backlash {v}");
    assert!(
        (k[7].as_f64().unwrap() - 0.5).abs() < 0.01,
        "gain drift {v}"
    );
    assert!(v["e_tot"].as_f64().unwrap() < 1.0, "{v}");
}

/// The light actuator with `faults` simulated in a cruise window (light turbulence, seed 1)
/// and in the same flight's preflight, into `window` and `preflight` under `dir`.
fn light_cruise(
    dir: &tempfile::TempDir,
    faults: &str,
    window: &str,
    preflight: &str,
) -> (String, String) {
    let (window, pre) = (path(dir, window), path(dir, preflight));
    for (args, out) in [
        (vec!["--flight", "cruise", "--turbulence", "light"], &window),
        (vec![], &pre),
    ] {
        let mut a = vec![
            "simulate",
            "--actuator",
            "../actuators/light-28v.toml",
            "--faults",
            faults,
            "--seed",
            "1",
            "--out",
            out.as_str(),
        ];
        a.extend(args);
        let o = host_sim(&a);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    (window, pre)
}

/// Another actuator's window of flight (its file's test plays tones before the chirp, a window
/// carries the chirp alone) is identified and plotted from the command line with the same
/// flight's preflight, read with that actuator's record (the window's test is not checked against the
/// preflight's); a window does not calibrate; the
/// same window from a rig's logger is imported as a window of flight (`import --flight`).
#[test]
fn another_actuators_window_is_identified_and_plotted_from_the_command_line() {
    let dir = tempfile::tempdir().unwrap();
    let light = "../actuators/light-28v.toml";
    let healthy = "0,0,0,0,0,0,0.5,0.5,0";
    let (window, pre) = light_cruise(&dir, healthy, "window.csv", "preflight.csv");
    let o = host_sim(&[
        "identify",
        &window,
        "--actuator",
        light,
        "--preflight",
        &pre,
        "--json",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v = json(&o);
    assert_eq!(v["window"], true, "{v}");
    assert_eq!(v["verdict"], "within", "{v}");
    assert_eq!(v["model"], "load", "{v}");
    // The light actuator's spring (2 kN·m/rad) and cruise's aerodynamic stiffness, not the
    // built-in aileron's 50 kN·m/rad.
    let stiffness = v["stiffness"].as_f64().unwrap();
    assert!((1_500.0..4_000.0).contains(&stiffness), "{v}");
    let friction = v["faults"][0].as_f64().unwrap();
    assert!(friction < 0.05, "{v}");
    let svg = path(&dir, "window.svg");
    let o = host_sim(&["plot", &window, "--actuator", light, "--out", &svg]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(std::fs::read_to_string(&svg).unwrap().contains("<svg"));
    // A window of flight does not calibrate an actuator (its load is not the test's).
    let rec = path(&dir, "unit.rec");
    let o = host_sim(&["calibrate", &window, "--actuator", light, "--out", &rec]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("cannot calibrate"), "{}", stderr(&o));

    // The same window as a rig's logger wrote it (its own column names, milliseconds, `;`,
    // 50 ms of flight before the window whose command never rests at 0), imported as a
    // window of flight, identifies as the simulated one.
    let trace = host_sim::files::trace::Trace::read(std::path::Path::new(&window)).unwrap();
    let rows = trace.samples();
    let dt = rows[1].time - rows[0].time;
    let mut rig = String::from("Time [ms];Cmd;Ia;Ib;Ic;MotorAngle;SurfaceAngle\n");
    let lead = 500;
    for k in 0..lead + rows.len() {
        let r = &rows[k.saturating_sub(lead)];
        let command = if k < lead { 1e-3 } else { r.command };
        rig += &format!(
            "{};{};{};{};{};{};{}\n",
            k as f64 * dt * 1e3,
            command,
            r.phase_currents[0],
            r.phase_currents[1],
            r.phase_currents[2],
            r.motor_angle,
            r.user_angle
        );
    }
    let recording = path(&dir, "logger.csv");
    std::fs::write(&recording, rig).unwrap();
    let imported = path(&dir, "imported.csv");
    let columns =
        "t=Time [ms],theta_cmd=Cmd,i_a=Ia,i_b=Ib,i_c=Ic,theta_m=MotorAngle,theta_u=SurfaceAngle";
    let import = |extra: &[&str], out: &str| {
        let mut a = vec![
            "import",
            &recording,
            "--actuator",
            light,
            "--flight",
            "--columns",
            columns,
            "--scales",
            "t=1e-3",
            "--out",
            out,
        ];
        a.extend(extra);
        host_sim(&a)
    };
    let o = import(&[], &imported);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("give --start"), "{}", stderr(&o));
    let start = format!("{}", lead as f64 * dt);
    // The binary form carries the flight mark: it reads as a window, as the CSV does.
    let imported_bin = path(&dir, "imported.bin");
    let o = import(&["--start", &start], &imported_bin);
    assert!(o.status.success(), "{}", stderr(&o));
    let wb = json(&host_sim(&[
        "identify",
        &imported_bin,
        "--actuator",
        light,
        "--json",
    ]));
    assert_eq!(wb["model"], "load", "not read as a window: {wb}");
    let o = import(&["--start", &start], &imported);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(std::fs::read_to_string(&imported)
        .unwrap()
        .starts_with("# test: flight"));
    let w = json(&host_sim(&[
        "identify",
        &imported,
        "--actuator",
        light,
        "--preflight",
        &pre,
        "--json",
    ]));
    assert_eq!(w["verdict"], "within", "{w}");
    for j in 0..9 {
        let (a, b) = (
            v["faults"][j].as_f64().unwrap(),
            w["faults"][j].as_f64().unwrap(),
        );
        assert!(
            (a - b).abs() < 2e-3,
            "component {j}: {a} simulated, {b} imported: {w}"
        );
    }

    // A worn gear (Table II medium) in the same cruise: the load model is at its floor and
    // the pinned model's misfit is above the built-in actuator's 0.5 % by the light
    // actuator's surface sensor (1 µrad steps over a spring a twenty-fifth of the built-in
    // one's): counted, the window is read.
    let medium = "0.4,0.4,0.2,0.1,0.05,0.2,0.75,0.6,0";
    let (window, pre) = light_cruise(&dir, medium, "worn.csv", "worn-pre.csv");
    let o = host_sim(&[
        "identify",
        &window,
        "--actuator",
        light,
        "--preflight",
        &pre,
        "--truth",
        medium,
        "--json",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v = json(&o);
    assert_eq!(
        (&v["verdict"], &v["model"]),
        (&"within".into(), &"pinned".into()),
        "{v}"
    );
    let (misfit, floor) = (
        v["pinned_misfit"].as_f64().unwrap(),
        v["pinned_sensor_floor"].as_f64().unwrap(),
    );
    assert!(
        misfit > 0.005 && floor > 0.0 && misfit - floor <= 0.005,
        "{v}"
    );
    assert!((v["faults"][1].as_f64().unwrap() - 0.4).abs() < 0.01, "{v}");
    assert!(v["e_tot"].as_f64().unwrap() < 2.0, "{v}");
    let o = host_sim(&[
        "identify",
        &window,
        "--actuator",
        light,
        "--preflight",
        &pre,
    ]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("the surface sensor's own error"), "{text}");
}

/// A window of flight cannot tell a stator short from an eccentricity (it has no standstill
/// segment): given the same flight's preflight (`--preflight`), it holds the shorts and the
/// eccentricity at the preflight's reading and reads the window right; a preflight given as
/// a window, or a window given as the preflight, is refused by name.
#[test]
fn a_window_holds_the_shorts_its_flights_preflight_read() {
    let dir = tempfile::tempdir().unwrap();
    let truth = "0,0,0.2,0,0,0,0.5,0.5,0";
    let window = path(&dir, "window.csv");
    let pre = path(&dir, "preflight.csv");
    for (args, out) in [
        (vec!["--flight", "cruise", "--turbulence", "light"], &window),
        (vec![], &pre),
    ] {
        let mut a = vec!["simulate", "--faults", truth, "--out", out.as_str()];
        a.extend(args);
        let o = host_sim(&a);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let v = json(&host_sim(&[
        "identify",
        &window,
        "--preflight",
        &pre,
        "--truth",
        truth,
        "--json",
    ]));
    assert!(
        v["shorts"]
            .as_str()
            .unwrap()
            .starts_with("shorts, eccentricity and demagnetization held at the preflight's"),
        "{v}"
    );
    for held in [
        "eccentricity",
        "demagnetization",
        "error carried",
        " ± ",
        "weak magnet held: none",
    ] {
        assert!(v["shorts"].as_str().unwrap().contains(held), "{v}");
    }
    let k = v["faults"].as_array().unwrap();
    assert!((k[2].as_f64().unwrap() - 0.2).abs() < 0.02, "{v}");
    assert!(k[5].as_f64().unwrap() < 0.1, "eccentricity {v}");
    assert!(v["e_tot"].as_f64().unwrap() < 3.0, "{v}");
    let free = json(&host_sim(&["identify", &window, "--json"]));
    assert!(
        free["shorts"].as_str().unwrap().contains("no --preflight"),
        "{free}"
    );
    let o = host_sim(&["identify", &window, "--preflight", &window]);
    assert!(
        !o.status.success() && stderr(&o).contains("not a preflight"),
        "{}",
        stderr(&o)
    );
    let o = host_sim(&["identify", &pre, "--preflight", &pre]);
    assert!(
        !o.status.success() && stderr(&o).contains("not a window"),
        "{}",
        stderr(&o)
    );
}
