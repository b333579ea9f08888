//! Rig recordings: a 50 kHz logger CSV with the rig's own column names, units, delimiter
//! and 0.2 s of idle before the test identifies like the same test at the control rate;
//! what is wrong with a recording is refused with a named error.

use std::fmt::Write as _;

use host_sim::fdi::identify::identify;
use host_sim::files::rig::{import, RigError, RigFormat};
use host_sim::files::trace::TraceSample;
use host_sim::plant::reference::{ReferenceModel, ReferenceSettings, Scenario};
use shared::metrics::total_error;
use shared::test_design::PreflightTest;
use shared::{Calibration, FaultVector};

const NAMES: [&str; 9] = [
    "Time [ms]",
    "Cmd",
    "Ia",
    "Ib",
    "Ic",
    "MotorAngle",
    "SurfaceAngle",
    "Vbus",
    "Thermistor",
];

fn rig_csv(rows: &[TraceSample]) -> String {
    let mut out =
        String::from("# logger export, 50 kHz\n# channel units: ms, rad, A, A, A, rad, rad\n");
    out += &NAMES
        .iter()
        .map(|n| format!("\"{n}\""))
        .collect::<Vec<_>>()
        .join(";");
    out.push('\n');
    for r in rows {
        let _ = writeln!(
            out,
            "{};{};{};{};{};{};{};{};{}",
            r.time * 1e3,
            r.command,
            r.phase_currents[0],
            r.phase_currents[1],
            r.phase_currents[2],
            r.motor_angle,
            r.user_angle,
            r.bus_voltage.unwrap_or(f64::NAN),
            r.temperature.unwrap_or(f64::NAN)
        );
    }
    out
}

fn format() -> RigFormat {
    let columns =
        "t=Time [ms],theta_cmd=Cmd,i_a=Ia,i_b=Ib,i_c=Ic,theta_m=MotorAngle,theta_u=SurfaceAngle,v_bus=Vbus,temp=Thermistor";
    RigFormat {
        columns: RigFormat::parse_columns(columns).unwrap(),
        scales: RigFormat::parse_scales("t=1e-3").unwrap(),
        ..RigFormat::default()
    }
}

fn recorded(faults: [f32; 9], seed: u64) -> (host_sim::files::trace::Trace, Vec<TraceSample>) {
    let settings = ReferenceSettings {
        pre_roll: 0.21, // 0.2 s of idle in the recording before the usual 10 ms hold
        ..ReferenceSettings::REFERENCE
    };
    let mut scenario = Scenario::new(FaultVector::new(faults).unwrap());
    scenario.seed = seed;
    let sim = ReferenceModel::new(settings)
        .with_recording(50_000.0)
        .simulate(&scenario);
    (sim.trace, sim.recording)
}

#[test]
fn a_50_khz_recording_with_idle_and_renamed_columns_identifies_like_the_10_khz_trace() {
    let truth = [0.0, 0.0, 0.2, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0];
    let (at_control_rate, rows) = recorded(truth, 4);
    assert!(rows.len() > 5 * at_control_rate.samples().len() + 9_000);
    let csv = rig_csv(&rows);
    let imported = import(csv.as_bytes(), &format(), &PreflightTest::INJECTION, 1e-4)
        .expect("imported")
        .checked()
        .expect("a sound trace");
    assert_eq!(imported.samples().len(), at_control_rate.samples().len());
    // The window found from the command is the test's: the commands agree sample by sample.
    for (a, b) in imported.samples().iter().zip(at_control_rate.samples()) {
        assert!(
            (a.command - b.command).abs() < 1e-12,
            "{} vs {}",
            a.command,
            b.command
        );
    }
    let truth = FaultVector::new(truth).unwrap();
    let e_tot = |t: &host_sim::files::trace::Trace| {
        let measured = t.measured(&shared::ActuatorParams::REFERENCE).unwrap();
        let id = identify(&measured, &Calibration::REFERENCE_ACTUATOR, 1, false).unwrap();
        f64::from(total_error(&id.result.faults, &truth))
    };
    let (rig, control) = (e_tot(&imported), e_tot(&at_control_rate));
    println!("e_tot: 50 kHz rig recording {rig:.3} %, 10 kHz trace {control:.3} %");
    assert!(
        (rig - control).abs() <= 0.1,
        "rig {rig} vs control rate {control}"
    );
}

#[test]
fn what_is_wrong_with_a_recording_is_refused_by_name() {
    let (_, rows) = recorded([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0], 1);
    let test = PreflightTest::STANDSTILL;
    let refused = |csv: &str, f: &RigFormat| import(csv.as_bytes(), f, &test, 1e-4).unwrap_err();

    // A column the mapping names is missing.
    let e = refused(&rig_csv(&rows).replacen("\"Ib\"", "\"I_b\"", 1), &format());
    assert!(
        matches!(e, RigError::MissingColumn { ours: "i_b", .. }),
        "{e}"
    );
    // A cell that is not a number, with its line.
    let csv = rig_csv(&rows);
    let line_5: Vec<&str> = csv.lines().collect();
    let bad = csv.replacen(line_5[4], &line_5[4].replacen(';', ";x", 1), 1);
    let e = refused(&bad, &format());
    assert!(matches!(e, RigError::NotNumeric { line: 5, .. }), "{e}");
    // An irregular time step.
    let mut gap = rows.clone();
    gap.remove(1000);
    let e = refused(&rig_csv(&gap), &format());
    assert!(matches!(e, RigError::IrregularTime { .. }), "{e}");
    // Recorded below the control rate.
    let slow: Vec<TraceSample> = rows.iter().step_by(10).copied().collect();
    let e = refused(&rig_csv(&slow), &format());
    assert!(matches!(e, RigError::TooSlow { .. }), "{e}");
    // Too short after trimming: the recording stops before the test ends.
    let cut = &rows[..rows.len() - 5000];
    let e = refused(&rig_csv(cut), &format());
    assert!(matches!(e, RigError::TooShort { .. }), "{e}");
    // No command and no start: the test cannot be placed.
    let idle: Vec<TraceSample> = rows[..8000].to_vec();
    let e = refused(&rig_csv(&idle), &format());
    assert!(matches!(e, RigError::NoTestStart { .. }), "{e}");
    // A start before the recording.
    let early = RigFormat {
        start: Some(-1.0),
        ..format()
    };
    let e = refused(&rig_csv(&rows), &early);
    assert!(matches!(e, RigError::NoTestStart { .. }), "{e}");
    // Unbalanced quoting is a CSV error with its line.
    let e = refused(&rig_csv(&rows).replacen("\"Cmd\"", "\"Cmd", 1), &format());
    assert!(!e.to_string().is_empty());
}

#[test]
fn a_recording_that_ends_at_the_tests_last_instant_is_whole() {
    // Seen by a user: a 10 kHz recording whose last row is the test's last sample instant was
    // refused as too short. The trace itself, written as a rig recording, is exactly that.
    let (trace, _) = recorded([0.0, 0.0, 0.2, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0], 2);
    let rows = trace.samples();
    let last = rows.last().unwrap().time;
    assert!(
        (last - (rows.len() - 1) as f64 * 1e-4).abs() < 1e-9,
        "{last}"
    );
    let imported = import(
        rig_csv(rows).as_bytes(),
        &format(),
        &PreflightTest::INJECTION,
        1e-4,
    )
    .expect("a recording that ends at the last instant is whole");
    assert_eq!(imported.samples().len(), rows.len());
    // One row fewer is short.
    let e = import(
        rig_csv(&rows[..rows.len() - 1]).as_bytes(),
        &format(),
        &PreflightTest::INJECTION,
        1e-4,
    )
    .unwrap_err();
    assert!(matches!(e, RigError::TooShort { .. }), "{e}");
}
