//! Stored tables: the exact bits the monitor model and the fitness produce for fixed inputs.
//!
//! The firmware and the host must agree bit for bit, and the calibration and the accuracy
//! campaigns were measured with these bits. A speed-up of the monitor model or the fitness
//! that changes a single bit of any sample fails here. If the model's numerics are changed on
//! purpose, the tables are regenerated (the failure message prints the new values) and the
//! calibration and campaigns must be measured again.

use shared::command::CommandTable;
use shared::conditioning::{LowPass, ShaftAngles};
use shared::fdi::{
    record_monitor_trace, Identification, OnboardMeasured, POPULATION, TEST_SAMPLES,
};
use shared::fitness::{FitnessError, FitnessProblem};
use shared::ga::Problem;
use shared::monitor::MonitorSample;
use shared::test_design::PreflightTest;
use shared::trace::Crc32;
use shared::{
    ActuatorParams, Calibration, ChirpCommand, FaultVector, GaSettings, MonitorModel, SteadyStateGa,
};

/// Fault vectors that exercise every branch of the step: healthy, friction and gain drift,
/// backlash, each short, eccentricity at several phases, everything at once.
const VECTORS: [[f32; 9]; 8] = [
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0],
    [0.6, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.1, 0.0],
    [0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.9, 0.0],
    [0.0, 0.0, 0.3, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0],
    [0.0, 0.0, 0.0, 0.2, 0.4, 0.0, 0.5, 0.5, 0.0],
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.13, 0.5, 0.0],
    [0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.87, 0.5, 0.0],
    [0.1, 0.1, 0.1, 0.05, 0.02, 0.1, 0.25, 0.4, 0.0],
];

/// A start away from zero, as a measured test's first sample gives (the currents a position
/// hold leaves in the windings, where a standstill segment starts).
const START: ShaftAngles = ShaftAngles {
    motor: 1.234,
    user: 0.0021,
    currents: [0.05, -0.11, 0.06],
};

/// CRC-32 over every field of every sample of a 5 000-sample run of the paper's test from
/// [`START`] with `Calibration::REFERENCE_ACTUATOR_STEPS`, one per vector of [`VECTORS`]
/// (regenerated with that calibration's refit at the actuator-record change).
const RUN_CRC: [u32; 8] = [
    0x4e45214e, 0xd48c5ef3, 0x2c9ae056, 0xf335454d, 0xd31696b9, 0x40b50754, 0xd282a63c, 0x6954e0e8,
];

/// The same over the 5 520 samples of the standstill test (segment, then chirp). Regenerated
/// when the segment's pair current began at the first fitted frame, held through the settle.
const RUN_CRC_STANDSTILL: [u32; 8] = [
    0x03547510, 0x999d0aad, 0x618bb408, 0xa2aa9228, 0xb84de9b3, 0x0da4530a, 0x9f93f262, 0x30798141,
];

/// Bits of `FitnessProblem::raw_error` of every vector of [`VECTORS`] against the
/// standstill-test trace the monitor model records for the last one.
const FITNESS_BITS: [u32; 8] = [
    0x3cdc2903, 0x3decf56f, 0x4080b7d2, 0x3ced68a7, 0x3e28f1a8, 0x3d23310f, 0x3de419c4, 0x2e3d4c32,
];

fn model() -> MonitorModel {
    MonitorModel::new(
        ActuatorParams::REFERENCE,
        &Calibration::REFERENCE_ACTUATOR_STEPS,
    )
}

fn sample_bytes(s: &MonitorSample) -> [u8; 24] {
    let mut out = [0u8; 24];
    let fields = [
        s.time,
        s.command,
        s.current,
        s.current_ref,
        s.motor_angle,
        s.user_angle,
    ];
    for (chunk, x) in out.chunks_exact_mut(4).zip(fields) {
        chunk.copy_from_slice(&x.to_bits().to_le_bytes());
    }
    out
}

#[test]
fn monitor_runs_match_the_stored_bits() {
    for (m, stored, name) in [
        (model(), RUN_CRC, "paper"),
        (
            model().with_test(&PreflightTest::STANDSTILL),
            RUN_CRC_STANDSTILL,
            "standstill",
        ),
    ] {
        let samples = m.test_samples();
        let crcs: Vec<u32> = VECTORS
            .iter()
            .map(|k| {
                let mut crc = Crc32::new();
                m.run_from(&FaultVector::new(*k).unwrap(), START, samples, |s| {
                    crc.update(&sample_bytes(s))
                });
                crc.finish()
            })
            .collect();
        assert_eq!(
            crcs, stored,
            "monitor-model bits changed ({name} test); new table: {:#010x?}",
            crcs
        );
    }
}

/// The lockstep stepper (`MonitorModel::start_run`, used by the uncertainty) gives the same
/// bits as `run_from`: the same stored tables.
#[test]
fn the_stepper_gives_the_stored_bits() {
    for (m, stored) in [
        (model(), RUN_CRC),
        (
            model().with_test(&PreflightTest::STANDSTILL),
            RUN_CRC_STANDSTILL,
        ),
    ] {
        let crcs: Vec<u32> = VECTORS
            .iter()
            .map(|k| {
                let mut run = m.start_run(&FaultVector::new(*k).unwrap(), START);
                let mut crc = Crc32::new();
                for _ in 0..m.test_samples() {
                    let command = match run.next_command_index(&m) {
                        Some(i) => m.sampler().at(i),
                        None => 0.0,
                    };
                    crc.update(&sample_bytes(&run.next_sample(&m, command)));
                }
                crc.finish()
            })
            .collect();
        assert_eq!(crcs, stored);
    }
}

/// A run stepped with its state by value (`MonitorRun::steps`, a window's evaluation) gives
/// the same bits as `run_from` on a test without a standstill segment: the stored table,
/// stepped in slices of 37 samples as a controller's idle time steps it.
#[test]
fn the_by_value_steps_give_the_stored_bits() {
    let m = model();
    assert_eq!(m.lead_samples(), 0);
    let crcs: Vec<u32> = VECTORS
        .iter()
        .map(|k| {
            let mut run = m.start_run(&FaultVector::new(*k).unwrap(), START);
            let mut crc = Crc32::new();
            let n = m.test_samples();
            for slice in (0..n).collect::<Vec<_>>().chunks(37) {
                run.steps(|steps| {
                    for &i in slice {
                        let command = m.sampler().at(i);
                        crc.update(&sample_bytes(&steps.next_motion_sample(&m, command)));
                    }
                });
            }
            crc.finish()
        })
        .collect();
    assert_eq!(crcs, RUN_CRC);
}

#[test]
fn fitness_matches_the_stored_bits() {
    let m = model();
    let mut measured = Box::new(OnboardMeasured::for_test(
        LowPass::for_control_period(ActuatorParams::REFERENCE.control_period).unwrap(),
        PreflightTest::STANDSTILL,
    ));
    let truth = FaultVector::new(VECTORS[7]).unwrap();
    record_monitor_trace(&m, &truth, &mut measured).unwrap();
    let problem = FitnessProblem::new(
        &measured,
        ActuatorParams::REFERENCE,
        &Calibration::REFERENCE_ACTUATOR_STEPS,
    )
    .unwrap();
    let bits: Vec<u32> = VECTORS
        .iter()
        .map(|k| problem.raw_error(&FaultVector::new(*k).unwrap()).to_bits())
        .collect();
    assert_eq!(
        bits, FITNESS_BITS,
        "fitness bits changed; new table: {:#010x?}",
        bits
    );
    // The truth scores lowest against its own (quantised) trace.
    let errors: Vec<f32> = bits.iter().map(|b| f32::from_bits(*b)).collect();
    assert!(
        errors[..7].iter().all(|e| *e > 1e3 * errors[7]),
        "{errors:?}"
    );
}

/// The command table and the bounded evaluation are speed-ups only: the same bits below the
/// bound, a value at or above it otherwise, and a whole identification that takes every
/// decision the exact evaluation takes.
#[test]
fn table_and_bound_keep_the_bits() {
    let m = model();
    let params = ActuatorParams::REFERENCE;
    let mut measured = Box::new(OnboardMeasured::for_test(
        LowPass::for_control_period(params.control_period).unwrap(),
        PreflightTest::STANDSTILL,
    ));
    let truth = FaultVector::new(VECTORS[7]).unwrap();
    record_monitor_trace(&m, &truth, &mut measured).unwrap();
    let cal = Calibration::REFERENCE_ACTUATOR_STEPS;
    let table = Box::new(CommandTable::<TEST_SAMPLES>::new(
        ChirpCommand::PREFLIGHT,
        params.control_period,
    ));
    let plain = FitnessProblem::new(&measured, params, &cal).unwrap();
    let tabled = plain.clone().with_command_table(&table).unwrap();
    for k in VECTORS {
        let k = FaultVector::new(k).unwrap();
        let exact = plain.error(&k);
        assert_eq!(tabled.error(&k).to_bits(), exact.to_bits());
        for p in [&plain, &tabled] {
            assert_eq!(p.error_below(&k, f32::INFINITY).to_bits(), exact.to_bits());
            let above = exact + 1e-4 * exact.abs() + 1e-9;
            assert_eq!(p.error_below(&k, above).to_bits(), exact.to_bits());
            let below = exact - 0.5 * exact.abs();
            let cut = p.error_below(&k, below);
            assert!(cut >= below && cut <= exact, "{cut} vs {below}, {exact}");
        }
    }
    // A table of another command or period is refused.
    let other = Box::new(CommandTable::<TEST_SAMPLES>::new(
        ChirpCommand {
            end_frequency: 14.0,
            ..ChirpCommand::PREFLIGHT
        },
        params.control_period,
    ));
    assert_eq!(
        plain.clone().with_command_table(&other).err(),
        Some(FitnessError::CommandTableMismatch)
    );

    // Exact evaluation only: a problem that does not override `fitness_below`.
    struct Exact<'p, 'a>(&'p FitnessProblem<'a, TEST_SAMPLES>);
    impl Problem for Exact<'_, '_> {
        fn fitness(&mut self, genes: &[f32; 9]) -> f32 {
            self.0.error(&FaultVector::saturating(*genes))
        }
    }
    let mut exact_ga = SteadyStateGa::<POPULATION>::new(GaSettings::FDI, 4).unwrap();
    exact_ga.run(&mut Exact(&plain));
    let mut fast = Identification::<TEST_SAMPLES, POPULATION>::new(
        &measured,
        params,
        &cal,
        GaSettings::FDI,
        4,
    )
    .unwrap()
    .with_command_table(&table)
    .unwrap();
    fast.run();
    assert!(exact_ga.evaluations() >= 700);
    assert_eq!(fast.ga(), &exact_ga);
}
