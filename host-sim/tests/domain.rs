//! Out-of-model actuators get the verdict "outside the monitor model's domain", not a
//! confident wrong fault vector; actuators the model explains stay "within". Each test is a
//! reference-model trace identified by the onboard FDI code (≈ 1 s each), judged with
//! `DomainLimits::REFERENCE_ACTUATOR`; the CLI exits with status 4 on such a trace.

use std::process::Command;

use host_sim::files::trace::{Trace, TraceFormat};
use host_sim::plant::reference::{Anomaly, ReferenceModel, ReferenceSettings, Scenario};
use host_sim::studies::domain::assess;
use shared::domain::{Domain, DomainLimits, OutsideReason};
use shared::{ChirpCommand, FaultVector};

fn rm() -> ReferenceModel {
    ReferenceModel::new(ReferenceSettings::REFERENCE)
}

fn trace(model: ReferenceModel, faults: [f32; 9]) -> Trace {
    model
        .simulate(&Scenario::new(FaultVector::new(faults).unwrap()))
        .trace
}

fn verdict(t: &Trace) -> Domain {
    assess(t, &DomainLimits::REFERENCE_ACTUATOR).unwrap().2
}

const HEALTHY: [f32; 9] = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0];
const WORN: [f32; 9] = [0.3, 0.3, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0];

#[test]
fn actuators_the_model_explains_are_within() {
    for faults in [HEALTHY, WORN, [0.0, 0.0, 0.3, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0]] {
        assert_eq!(verdict(&trace(rm(), faults)), Domain::Within, "{faults:?}");
    }
}

#[test]
fn a_jammed_actuator_is_outside_for_lack_of_motion() {
    for faults in [HEALTHY, WORN] {
        let v = verdict(&trace(rm().with_anomaly(Anomaly::Jammed), faults));
        assert!(
            matches!(v, Domain::Outside(OutsideReason::NoMotion { travel }) if travel < 1e-4),
            "{v:?}"
        );
    }
}

#[test]
fn an_open_phase_is_outside() {
    // Phase A open: the motor still creeps on the B–C pair; phase A is seen carrying nothing.
    let v = verdict(&trace(rm().with_anomaly(Anomaly::OpenPhase(0)), HEALTHY));
    assert!(
        matches!(
            v,
            Domain::Outside(OutsideReason::OpenPhase { phase: 0, ratio }) if ratio < 0.1
        ),
        "{v:?}"
    );
    // Phases B and C open: the rotor sits where the open phase must conduct, nothing flows
    // and nothing moves.
    for x in [1, 2] {
        let v = verdict(&trace(rm().with_anomaly(Anomaly::OpenPhase(x)), WORN));
        assert!(matches!(v, Domain::Outside(_)), "phase {x}: {v:?}");
    }
}

#[test]
fn a_trace_of_another_command_is_outside() {
    let chirp = |amplitude, end_frequency| ChirpCommand {
        amplitude,
        end_frequency,
        ..ChirpCommand::PREFLIGHT
    };
    for (command, name) in [
        (chirp(10.0e-3, 15.0), "twice the amplitude"),
        (chirp(5.0e-3, 5.0), "to 5 Hz"),
        (chirp(5.0e-3, 30.0), "to 30 Hz"),
    ] {
        let v = verdict(&trace(rm().with_command(command), HEALTHY));
        assert!(
            matches!(v, Domain::Outside(OutsideReason::CommandMismatch { .. })),
            "{name}: {v:?}"
        );
    }
    // A smaller chirp is followed well enough to pass the tracking check; the fitness floor
    // catches it.
    let v = verdict(&trace(rm().with_command(chirp(2.0e-3, 15.0)), HEALTHY));
    assert!(matches!(v, Domain::Outside(_)), "{v:?}");
}

#[test]
fn the_cli_says_outside_and_exits_with_status_4() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("jammed.bin");
    trace(rm().with_anomaly(Anomaly::Jammed), HEALTHY)
        .write(&path, TraceFormat::Bin)
        .unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(["identify", "--json"])
        .arg(&path)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(4));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("outside the monitor model's domain"),
        "{stderr}"
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(
        json["domain"]
            .as_str()
            .unwrap()
            .starts_with("outside: NoMotion"),
        "{json}"
    );
}
