//! Power loss during a preflight: the identification stopped at any point and resumed from its
//! checkpoint record finishes with the very bits of an uninterrupted run; a damaged, foreign
//! or erased record is refused and the identification restarts cleanly.

use proptest::prelude::*;
use shared::fdi::{record_monitor_trace, Identification, OnboardMeasured, OnboardRecord};
use shared::fdi::{POPULATION, TEST_SAMPLES};
use shared::ga::{RecordError, Status};
use shared::trace::Crc32;
use shared::{ActuatorParams, Calibration, FaultVector, GaSettings, LowPass, MonitorModel};

/// A short run (the resume logic does not depend on the length): 300 evaluations.
const SETTINGS: GaSettings = GaSettings {
    max_evaluations: 300,
    ..GaSettings::FDI
};

type Id<'a> = Identification<'a, TEST_SAMPLES, POPULATION>;

fn measured() -> Box<OnboardMeasured> {
    let filter = LowPass::for_control_period(1.0e-4).unwrap();
    let mut m = Box::new(OnboardMeasured::new(filter));
    let model = MonitorModel::new(
        ActuatorParams::REFERENCE,
        &Calibration::REFERENCE_ACTUATOR_STEPS,
    );
    let k = FaultVector::new([0.3, 0.2, 0.0, 0.1, 0.0, 0.0, 0.5, 0.6, 0.0]).unwrap();
    record_monitor_trace(&model, &k, &mut m).unwrap();
    m
}

fn fresh(m: &OnboardMeasured, seed: u64) -> Id<'_> {
    Identification::new(
        m,
        ActuatorParams::REFERENCE,
        &Calibration::REFERENCE_ACTUATOR_STEPS,
        SETTINGS,
        seed,
    )
    .unwrap()
}

/// The uninterrupted run's whole GA state at the end.
fn uninterrupted(m: &OnboardMeasured) -> Id<'_> {
    let mut id = fresh(m, 1);
    id.run();
    id
}

/// Runs `stops[0]` evaluations, "loses power" (only the record survives), resumes in a new
/// identification, runs to `stops[1]`, and so on, then to the end.
fn interrupted<'a>(m: &'a OnboardMeasured, stops: &[u32]) -> Id<'a> {
    let mut record: OnboardRecord = [0; core::mem::size_of::<OnboardRecord>()];
    let mut id = fresh(m, 1);
    for &stop in stops {
        let done = id.ga().evaluations();
        id.step(stop.saturating_sub(done));
        id.save(&mut record).unwrap();
        // Power lost: the old state is gone, a new identification starts from the record.
        id = fresh(m, 1);
        let resumed = id.resume(&record).unwrap();
        assert_eq!(resumed, stop.min(SETTINGS.max_evaluations));
    }
    id.run();
    id
}

#[test]
fn stopped_anywhere_and_resumed_gives_the_same_bits() {
    let m = measured();
    let reference = uninterrupted(&m);
    assert_eq!(reference.ga().evaluations(), 300);
    // Before the first evaluation, inside the initial population, at its end, one past,
    // mid-run, one before the end, at the end, and a chain of several losses.
    for stops in [
        &[0][..],
        &[1],
        &[31],
        &[32],
        &[33],
        &[157],
        &[299],
        &[300],
        &[5, 64, 65, 200, 201],
    ] {
        let resumed = interrupted(&m, stops);
        assert_eq!(resumed.ga(), reference.ga(), "stops {stops:?}");
        let (a, b) = (resumed.result_so_far(), reference.result_so_far());
        assert_eq!(
            a.faults.as_array().map(f32::to_bits),
            b.faults.as_array().map(f32::to_bits)
        );
        assert_eq!(a.fitness.to_bits(), b.fitness.to_bits());
        assert_eq!(a.stop_reason, b.stop_reason);
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    #[test]
    fn any_stop_point_resumes_to_the_same_bits(stop in 0u32..=300, second in 0u32..=300) {
        let m = measured();
        let reference = uninterrupted(&m);
        let mut stops = [stop, second];
        stops.sort_unstable();
        let resumed = interrupted(&m, &stops);
        prop_assert_eq!(resumed.ga(), reference.ga());
    }
}

#[test]
fn a_pending_candidate_survives_the_record() {
    // Power lost between `ask` and `tell`: the same candidate is asked again after resume.
    let mut ga = shared::SteadyStateGa::<POPULATION>::new(SETTINGS, 9).unwrap();
    for _ in 0..40 {
        let g = ga.ask().unwrap();
        ga.tell(g.iter().sum()).unwrap();
    }
    let pending = ga.ask().unwrap();
    let mut record = [0u8; shared::SteadyStateGa::<POPULATION>::RECORD_BYTES];
    ga.save(7, &mut record).unwrap();
    let mut back = shared::SteadyStateGa::<POPULATION>::restore(SETTINGS, 7, &record).unwrap();
    assert_eq!(back, ga);
    assert_eq!(back.ask().unwrap(), pending);
}

#[test]
fn every_damaged_byte_is_detected_and_the_run_restarts_cleanly() {
    let m = measured();
    let reference = uninterrupted(&m);
    let mut record: OnboardRecord = [0; core::mem::size_of::<OnboardRecord>()];
    let mut id = fresh(&m, 1);
    id.step(120);
    id.save(&mut record).unwrap();
    assert_eq!(record.len(), 1412);

    for at in 0..record.len() {
        for flip in [0x01u8, 0x80, 0xFF] {
            let mut damaged = record;
            damaged[at] ^= flip;
            let mut restarted = fresh(&m, 1);
            let before = restarted.ga().clone();
            let e = restarted.resume(&damaged).unwrap_err();
            assert!(
                matches!(
                    e,
                    RecordError::BadChecksum { .. }
                        | RecordError::BadMagic
                        | RecordError::UnsupportedVersion { .. }
                        | RecordError::WrongShape { .. }
                ),
                "byte {at} ^ {flip:#x}: {e:?}"
            );
            assert_eq!(restarted.ga(), &before, "a refused record changes nothing");
        }
    }
    // A torn write: the first half new, the rest still erased flash.
    let mut torn = [0xFFu8; 1412];
    torn[..600].copy_from_slice(&record[..600]);
    let mut restarted = fresh(&m, 1);
    assert!(matches!(
        restarted.resume(&torn),
        Err(RecordError::BadChecksum { .. })
    ));
    restarted.run();
    assert_eq!(
        restarted.ga(),
        reference.ga(),
        "the clean restart finishes as usual"
    );
}

#[test]
fn foreign_erased_short_and_forged_records_are_refused() {
    let m = measured();
    let mut record: OnboardRecord = [0; core::mem::size_of::<OnboardRecord>()];
    let mut id = fresh(&m, 1);
    id.step(50);
    id.save(&mut record).unwrap();

    // Another seed is another run.
    let mut other = fresh(&m, 2);
    assert!(matches!(
        other.resume(&record),
        Err(RecordError::OtherRun { .. })
    ));
    // Another measured test is another run.
    let filter = LowPass::for_control_period(1.0e-4).unwrap();
    let mut m2 = Box::new(OnboardMeasured::new(filter));
    let model = MonitorModel::new(
        ActuatorParams::REFERENCE,
        &Calibration::REFERENCE_ACTUATOR_STEPS,
    );
    record_monitor_trace(&model, &FaultVector::NOMINAL, &mut m2).unwrap();
    assert!(matches!(
        fresh(&m2, 1).resume(&record),
        Err(RecordError::OtherRun { .. })
    ));
    // Erased flash, a short buffer.
    assert_eq!(
        fresh(&m, 1).resume(&[0xFF; 1412]),
        Err(RecordError::BadMagic)
    );
    assert_eq!(
        fresh(&m, 1).resume(&record[..1000]),
        Err(RecordError::WrongLength {
            found: 1000,
            expected: 1412
        })
    );
    let mut short = [0u8; 10];
    assert!(matches!(
        id.save(&mut short),
        Err(RecordError::WrongLength { .. })
    ));
    // A sound checksum over impossible contents (a NaN fitness in the population).
    let mut forged = record;
    forged[128 + 36..128 + 40].copy_from_slice(&f32::NAN.to_bits().to_le_bytes());
    let end = forged.len() - 4;
    let mut crc = Crc32::new();
    crc.update(&forged[..end]);
    forged[end..].copy_from_slice(&crc.finish().to_le_bytes());
    assert_eq!(fresh(&m, 1).resume(&forged), Err(RecordError::Inconsistent));
    // And the unforged record resumes.
    let mut resumed = fresh(&m, 1);
    assert_eq!(resumed.resume(&record), Ok(50));
    assert_eq!(resumed.ga().status(), Status::Running);
}

/// The record is loaded in place (no copy of the GA on the controller's stack): a sound
/// checksum over contents no GA can hold — in any field, down to the last member — is
/// refused before anything is written, and the GA is left as it was.
#[test]
fn an_impossible_state_is_refused_before_anything_is_loaded() {
    let m = measured();
    let mut record: OnboardRecord = [0; core::mem::size_of::<OnboardRecord>()];
    let mut id = fresh(&m, 1);
    id.step(50);
    id.save(&mut record).unwrap();
    let last_member_fitness = record.len() - 4 - 4;
    let forgeries: [(&str, usize, &[u8]); 7] = [
        ("all-zero random generator", 16, &[0; 16]),
        ("NaN stall reference", 44, &f32::NAN.to_bits().to_le_bytes()),
        ("more members evaluated than the population", 48, &[33, 0]),
        ("unknown status", 50, &[9]),
        ("pending flag 2", 51, &[2]),
        ("best gene above 1", 88, &2.0f32.to_bits().to_le_bytes()),
        (
            "NaN fitness of the last member",
            last_member_fitness,
            &f32::NAN.to_bits().to_le_bytes(),
        ),
    ];
    for (what, at, bytes) in forgeries {
        let mut forged = record;
        forged[at..at + bytes.len()].copy_from_slice(bytes);
        let end = forged.len() - 4;
        let mut crc = Crc32::new();
        crc.update(&forged[..end]);
        forged[end..].copy_from_slice(&crc.finish().to_le_bytes());
        let mut other = fresh(&m, 1);
        other.step(10);
        let before = other.ga().clone();
        assert_eq!(
            other.resume(&forged),
            Err(RecordError::Inconsistent),
            "{what}"
        );
        assert_eq!(
            other.ga(),
            &before,
            "{what}: a refused record changes nothing"
        );
    }
    // The unforged record, loaded over a GA that had run on, is the saved state.
    let mut other = fresh(&m, 1);
    other.step(120);
    assert_eq!(other.resume(&record), Ok(50));
    assert_eq!(other.ga(), id.ga());
}

/// `record` (version 2, nine genes) as a controller before the ninth fault wrote it.
fn as_version_1(record: &[u8]) -> Vec<u8> {
    let mut out = vec![0u8; record.len()];
    let len = shared::ga::as_version_1::<POPULATION>(record, &mut out).unwrap();
    out.truncate(len);
    out
}

/// A checkpoint of the eight-gene version resumes: every gene it stored, the ninth
/// (demagnetization) nominal; the run then finishes. A version-1 record that claims nine
/// genes, or has the version-2 length, is refused.
#[test]
fn an_eight_gene_checkpoint_resumes_with_no_demagnetization() {
    let m = measured();
    let mut record: OnboardRecord = [0; core::mem::size_of::<OnboardRecord>()];
    let mut id = fresh(&m, 1);
    id.step(50);
    id.save(&mut record).unwrap();
    let old = as_version_1(&record);
    assert_eq!(old.len(), 1276);
    let mut resumed = fresh(&m, 1);
    assert_eq!(resumed.resume(&old), Ok(50));
    let (new, back) = (id.ga().population(), resumed.ga().population());
    assert_eq!(new.len(), back.len());
    for (a, b) in new.iter().zip(back) {
        assert_eq!(a.genes[..8], b.genes[..8]);
        assert_eq!((b.genes[8], b.fitness), (0.0, a.fitness));
    }
    assert_eq!(resumed.ga().evaluations(), id.ga().evaluations());
    resumed.run();
    assert!(matches!(resumed.ga().status(), Status::Done(_)));

    let mut nine = old.clone();
    nine[8..10].copy_from_slice(&9u16.to_le_bytes());
    assert!(matches!(
        fresh(&m, 1).resume(&nine),
        Err(RecordError::WrongShape { genes: 9, .. })
    ));
    let mut long = record;
    long[4..6].copy_from_slice(&1u16.to_le_bytes());
    assert_eq!(
        fresh(&m, 1).resume(&long),
        Err(RecordError::WrongLength {
            found: 1412,
            expected: 1276
        })
    );
}

/// The fingerprint covers the actuator record: a checkpoint of the same trace, seed and
/// settings taken with other actuator parameters (here another rigging offset or gear
/// ratio) is refused.
#[test]
fn a_checkpoint_of_another_actuator_is_refused() {
    let m = measured();
    let mut id = fresh(&m, 1);
    id.step(50);
    let mut record: OnboardRecord = [0; core::mem::size_of::<OnboardRecord>()];
    id.save(&mut record).unwrap();
    for params in [
        ActuatorParams {
            encoder_offset: 0.5,
            ..ActuatorParams::REFERENCE
        },
        ActuatorParams {
            gear_ratio: 499.0,
            ..ActuatorParams::REFERENCE
        },
    ] {
        let mut other = Identification::<TEST_SAMPLES, POPULATION>::new(
            &m,
            params,
            &Calibration::REFERENCE_ACTUATOR_STEPS,
            SETTINGS,
            1,
        )
        .unwrap();
        assert_ne!(other.fingerprint(), id.fingerprint());
        assert!(matches!(
            other.resume(&record),
            Err(RecordError::OtherRun { .. })
        ));
    }
    // The same actuator resumes.
    assert_eq!(fresh(&m, 1).resume(&record), Ok(50));
}
