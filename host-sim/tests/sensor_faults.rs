//! Sensor faults are named, never read as actuator faults: each kind the reference model can
//! inject (`SensorFault`), at a size that matters, puts the test outside the monitor model's
//! domain with its own reason in every one of 10 seeds, on a healthy actuator and on one
//! with friction 1.0 (whose motor sticks longest at the chirp's reversals); no healthy or
//! faulty actuator read through sound sensors is flagged (paper Tables I and II, 2 seeds).

use host_sim::plant::reference::{ReferenceModel, ReferenceSettings, Scenario, SensorFault};
use host_sim::studies::campaign::{TABLE_1, TABLE_2};
use shared::domain::OutsideReason;
use shared::{ActuatorParams, FaultVector};

fn sensor_verdict(
    faults: [f32; 9],
    noise: f64,
    seed: u64,
    fault: Option<SensorFault>,
) -> Option<OutsideReason> {
    let sim = ReferenceModel::new(ReferenceSettings::REFERENCE)
        .with_sensor_fault(fault)
        .simulate(&Scenario {
            faults: FaultVector::new(faults).unwrap(),
            current_ref_noise: noise,
            seed,
        });
    sim.trace
        .domain_monitor(&ActuatorParams::REFERENCE)
        .sensor_fault()
}

const HEALTHY: [f32; 9] = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0];
const STICKY: [f32; 9] = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0];

fn named(kind: &str, is: fn(&OutsideReason) -> bool) {
    let fault = SensorFault::parse(kind).unwrap();
    for actuator in [HEALTHY, STICKY] {
        let hits = (0..10)
            .filter(|&seed| {
                sensor_verdict(actuator, 0.0, seed, Some(fault)).is_some_and(|r| is(&r))
            })
            .count();
        assert!(hits >= 10, "{kind} on {actuator:?}: named in {hits} of 10");
    }
}

#[test]
fn a_stuck_encoder_for_10_ms_is_named() {
    named(
        "encoder-stuck:0.01",
        |r| matches!(r, OutsideReason::EncoderStuck { samples } if *samples >= 90),
    );
}

#[test]
fn an_encoder_glitch_is_named() {
    named("encoder-glitch:0.2", |r| {
        matches!(r, OutsideReason::EncoderGlitch { .. })
    });
}

#[test]
fn a_current_sense_offset_of_0_2_a_is_named() {
    named(
        "current-offset:0.2",
        |r| matches!(r, OutsideReason::CurrentSenseOffset { amps } if (amps - 0.2).abs() < 0.03),
    );
}

#[test]
fn a_current_sense_gain_drift_of_10_percent_is_named() {
    named("current-gain:1.1", |r| {
        matches!(r, OutsideReason::CurrentSenseGain { .. })
    });
}

#[test]
fn a_surface_transducer_slip_is_named() {
    named(
        "transducer-slip:0.005",
        |r| matches!(r, OutsideReason::TransducerDisagrees { spread } if *spread > 0.004),
    );
}

#[test]
fn sound_sensors_are_never_flagged() {
    for case in TABLE_1.iter().chain(TABLE_2.iter()) {
        for seed in 0..2 {
            let v = sensor_verdict(case.faults, case.noise, seed, None);
            assert_eq!(v, None, "{} seed {seed}", case.name);
        }
    }
}

#[test]
fn a_sensor_fault_spec_is_checked() {
    assert!(SensorFault::parse("encoder-wobble").is_err());
    assert!(SensorFault::parse("current-offset:abc").is_err());
    assert_eq!(
        SensorFault::parse("current-offset").unwrap(),
        SensorFault::CurrentOffset {
            phase: 0,
            amps: 0.2
        }
    );
}

#[test]
fn preflight_names_the_sensor_and_exits_with_status_4() {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args([
            "preflight",
            "--faults",
            "0,0,0,0,0,0,0.5,0.5",
            "--sensor-fault",
            "current-offset:0.2",
            "--json",
        ])
        .output()
        .unwrap();
    assert_eq!(
        out.status.code(),
        Some(4),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let domain = json["domain"].as_str().unwrap();
    assert!(
        domain.starts_with("outside: CurrentSenseOffset"),
        "{domain}"
    );
}
