//! The preflight state machine and the trace source, on the host: stage order, work bounds
//! per poll, refusal of bad traces, and the same bits as the shared identification loop.

use firmware::source::{SliceBytes, SAMPLE_RATE_HZ};
use firmware::{
    Acquired, CheckpointError, CurrentSource, Preflight, PreflightError, PreflightSettings,
    Progress, Stage, TraceSource, TraceSourceError,
};
use shared::conditioning::commutation_signs;
use shared::domain::{Domain, OutsideReason};
use shared::fdi::{Identification, OnboardMeasured, OnboardRecord, POPULATION, TEST_SAMPLES};
use shared::fitness::CurvatureRun;
use shared::ga::RecordError;
use shared::test_design::PreflightTest;
use shared::trace::{Crc32, TraceError, TraceHeader, TraceRow};
use shared::{AdcFrame, Calibration, FaultVector, GaSettings, LowPass, MonitorModel, StopReason};

fn settings() -> PreflightSettings {
    // The MM-made traces here are the paper's test (the chirp alone); the standstill test
    // runs on the ELF in tests/firmware_qemu.rs.
    let mut s = PreflightSettings {
        evaluations_per_poll: 5,
        frames_per_poll: 700,
        ..PreflightSettings::ONBOARD.for_test(PreflightTest::PAPER)
    };
    s.actuator.ga = GaSettings {
        max_evaluations: 96,
        ..GaSettings::FDI
    };
    s
}

fn empty_buffer() -> Box<OnboardMeasured> {
    let filter = LowPass::for_control_period(1.0e-4).expect("the 10 kHz filter exists");
    Box::new(OnboardMeasured::new(filter))
}

/// The rows the controller would record from an actuator that behaves like the monitor
/// model with faults `k`.
fn monitor_rows(k: [f32; 9], samples: usize) -> Vec<TraceRow> {
    let s = settings();
    let model = MonitorModel::new(s.actuator.params, &Calibration::IDENTITY);
    let k = FaultVector::new(k).expect("a valid fault vector");
    let mut rows = Vec::new();
    model.run(&k, samples, |m| {
        let signs = commutation_signs(s.actuator.params.pole_pairs * m.motor_angle);
        rows.push(TraceRow::from_f64(
            f64::from(m.command),
            signs.map(|x| f64::from(x) * f64::from(m.current)),
            f64::from(m.motor_angle),
            f64::from(m.user_angle),
        ));
    });
    rows
}

fn trace_bytes(rows: &[TraceRow], sample_rate_hz: u32) -> Vec<u8> {
    let header = TraceHeader {
        sample_rate_hz,
        rows: rows.len() as u32,
        test: PreflightTest::PAPER,
        conditions: false,
        flight: false,
    };
    let mut out = header
        .encode()
        .expect("the paper's test has a code")
        .to_vec();
    for r in rows {
        out.extend_from_slice(r.encode().as_slice());
    }
    let mut crc = Crc32::new();
    crc.update(&out);
    out.extend_from_slice(&crc.finish().to_le_bytes());
    out
}

const FAULTS: [f32; 9] = [0.2, 0.3, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0];

#[test]
fn trace_source_gives_every_row_then_end_of_test() {
    let rows = monitor_rows(FAULTS, 1200);
    let bytes = trace_bytes(&rows, SAMPLE_RATE_HZ);
    let mut source = TraceSource::open(SliceBytes::new(&bytes)).expect("a valid trace");
    assert_eq!(source.header().rows, 1200);
    for (i, row) in rows.iter().enumerate() {
        assert_eq!(
            source.next_frame(),
            Ok(Acquired::Frame(row.adc_frame())),
            "row {i}"
        );
    }
    assert_eq!(source.next_frame(), Ok(Acquired::EndOfTest));
    assert_eq!(source.next_frame(), Ok(Acquired::EndOfTest));
}

#[test]
fn trace_source_refuses_bad_traces() {
    let rows = monitor_rows(FAULTS, 1200);
    let good = trace_bytes(&rows, SAMPLE_RATE_HZ);

    let open = |b: &[u8]| TraceSource::open(SliceBytes::new(b)).map(|_| ());
    assert_eq!(
        open(&trace_bytes(&rows, 20_000)),
        Err(TraceSourceError::SampleRate { found: 20_000 })
    );
    let truncated = &good[..good.len() - 10];
    assert!(matches!(
        open(truncated),
        Err(TraceSourceError::Trace(TraceError::LengthMismatch { .. }))
    ));
    assert!(matches!(
        open(&good[..7]),
        Err(TraceSourceError::Trace(TraceError::LengthMismatch { .. }))
    ));
    let mut magic = good.clone();
    magic[0] = b'X';
    assert_eq!(
        open(&magic),
        Err(TraceSourceError::Trace(TraceError::BadMagic))
    );

    // One flipped bit in a row is only caught by the checksum, after the last row.
    let mut flipped = good.clone();
    flipped[16 + 24 * 600 + 5] ^= 0x10;
    let mut source = TraceSource::open(SliceBytes::new(&flipped)).expect("header is fine");
    let mut frames = 0;
    let end = loop {
        match source.next_frame() {
            Ok(Acquired::Frame(_)) => frames += 1,
            other => break other,
        }
    };
    assert_eq!(frames, 1200);
    assert!(matches!(
        end,
        Err(TraceSourceError::Trace(TraceError::BadChecksum { .. }))
    ));
}

/// With an uncertainty buffer lent in: an Uncertainty stage of bounded polls, then the same
/// standard deviations and intervals, bit for bit, as the shared code in one go, and verdicts
/// that use them.
#[test]
fn the_uncertainty_stage_is_bounded_and_gives_the_shared_bits() {
    let rows = monitor_rows(FAULTS, TEST_SAMPLES);
    let bytes = trace_bytes(&rows, SAMPLE_RATE_HZ);
    let source = TraceSource::open(SliceBytes::new(&bytes)).expect("a valid trace");
    let s = settings();
    let mut buffer = empty_buffer();
    let mut curvature = Box::new(CurvatureRun::IDLE);
    let mut preflight =
        Preflight::new(&s, source, &mut buffer).with_curvature_buffer(&mut curvature);
    let mut uncertainty_polls = 0u32;
    let report = loop {
        match preflight.poll().expect("the preflight runs") {
            Progress::Working { stage } => {
                if stage == Stage::Uncertainty {
                    uncertainty_polls += 1;
                }
            }
            Progress::Finished(report) => break report,
        }
    };
    // Every sample in slices of `per_poll`: the poll that starts the stage, then one per
    // slice but the last, which moves to Report.
    let per_poll = s.uncertainty_samples_per_poll;
    assert_eq!(uncertainty_polls, (rows.len() as u32).div_ceil(per_poll));
    let u = report
        .uncertainty
        .expect("the test determines the components");

    let mut measured = empty_buffer();
    measured.clear_for(s.actuator.test);
    for r in &rows {
        measured
            .push_frame(r.adc_frame(), s.actuator.params.pole_pairs)
            .unwrap();
    }
    measured.finish().unwrap();
    let problem =
        shared::FitnessProblem::new(&measured, s.actuator.params, &s.actuator.calibration).unwrap();
    let (expected, correlation) = problem
        .uncertainty(&report.result.faults, &s.actuator.systematic)
        .unwrap();
    assert_eq!(u.std.map(f32::to_bits), expected.std.map(f32::to_bits));
    assert_eq!(u.lower.map(f32::to_bits), expected.lower.map(f32::to_bits));
    assert_eq!(
        report.assessments,
        expected.assess(&report.result.faults, &correlation)
    );
    // Every fault component is determined here (the eccentricity phase, without an
    // eccentricity, need not be), and every interval holds its own estimate.
    let k = report.result.faults.as_array();
    for i in [0, 1, 2, 3, 4, 5, 7] {
        assert!(u.std[i].is_finite() && u.std[i] > 0.0, "k{}: {u:?}", i + 1);
        assert!(
            u.lower[i] <= k[i] && k[i] <= u.upper[i],
            "k{}: {u:?}",
            i + 1
        );
    }
}

#[test]
fn preflight_walks_the_stages_in_bounded_polls_and_matches_the_shared_loop() {
    let rows = monitor_rows(FAULTS, TEST_SAMPLES);
    let bytes = trace_bytes(&rows, SAMPLE_RATE_HZ);
    let source = TraceSource::open(SliceBytes::new(&bytes)).expect("a valid trace");
    let s = settings();
    let mut buffer = empty_buffer();
    let mut preflight = Preflight::new(&s, source, &mut buffer);

    let mut stages = vec![preflight.stage()];
    let mut evaluations = 0;
    let report = loop {
        match preflight.poll().expect("the preflight runs") {
            Progress::Working { stage } => {
                let now = preflight.evaluations();
                assert!(now - evaluations <= s.evaluations_per_poll);
                evaluations = now;
                if stages.last() != Some(&stage) {
                    stages.push(stage);
                }
            }
            Progress::Finished(report) => break report,
        }
    };
    assert_eq!(
        stages,
        [
            Stage::Acquire,
            Stage::Condition,
            Stage::Identify,
            Stage::Report
        ]
    );
    assert_eq!(preflight.stage(), Stage::Done);
    assert_eq!(report.frames, TEST_SAMPLES as u32);
    assert_eq!(report.result.evaluations, 96);
    assert_eq!(report.result.stop_reason, StopReason::EvaluationBudget);
    assert_eq!(report.max_evaluations_per_poll, s.evaluations_per_poll);
    assert!(report.identify_polls >= 96 / s.evaluations_per_poll);
    assert_eq!(report.verdicts, report.result.faults.verdicts());
    // Polling a finished self-test gives the same report again.
    assert_eq!(preflight.poll(), Ok(Progress::Finished(report)));

    // The same frames through the shared loop in one go: the same bits (the GA alone: without
    // a curvature buffer the self-test skips the polish and the uncertainty).
    let mut measured = empty_buffer();
    for r in &rows {
        measured
            .push_frame(r.adc_frame(), s.actuator.params.pole_pairs)
            .expect("room for the test");
    }
    measured.finish().expect("a usable trace");
    let mut id = Identification::<TEST_SAMPLES, POPULATION>::new(
        &measured,
        s.actuator.params,
        &s.actuator.calibration,
        s.actuator.ga,
        s.seed,
    )
    .expect("identification starts");
    while id.step(u32::MAX) == shared::Status::Running {}
    let direct = id.result_so_far();
    assert_eq!(
        report.result.faults.as_array().map(f32::to_bits),
        direct.faults.as_array().map(f32::to_bits)
    );
    assert_eq!(report.result.fitness.to_bits(), direct.fitness.to_bits());
}

/// A source that makes the poll wait every other call, like an ADC between conversions.
struct Stuttering<S> {
    inner: S,
    wait: bool,
}

impl<S: CurrentSource> CurrentSource for Stuttering<S> {
    type Error = S::Error;
    fn next_frame(&mut self) -> Result<Acquired, S::Error> {
        self.wait = !self.wait;
        if self.wait {
            Ok(Acquired::NotYet)
        } else {
            self.inner.next_frame()
        }
    }
}

#[test]
fn acquire_ends_a_poll_when_the_source_has_nothing_yet() {
    let rows = monitor_rows(FAULTS, 1500);
    let bytes = trace_bytes(&rows, SAMPLE_RATE_HZ);
    let source = Stuttering {
        inner: TraceSource::open(SliceBytes::new(&bytes)).expect("a valid trace"),
        wait: false,
    };
    let mut buffer = empty_buffer();
    let s = settings();
    let mut preflight = Preflight::new(&s, source, &mut buffer);
    let mut acquire_polls = 0;
    while preflight.stage() == Stage::Acquire {
        preflight.poll().expect("acquisition runs");
        acquire_polls += 1;
    }
    // The first poll gets nothing, then one frame per poll (the next call waits), then one
    // poll sees the end of the test.
    assert_eq!(acquire_polls, 1 + 1500 + 1);
}

/// Polls until the self-test fails; a result is a test failure.
fn poll_until_error<S: CurrentSource>(preflight: &mut Preflight<'_, S>) -> PreflightError<S::Error>
where
    S::Error: core::fmt::Debug,
{
    loop {
        match preflight.poll() {
            Ok(Progress::Working { .. }) => continue,
            Ok(Progress::Finished(r)) => panic!("this test must not give a result: {r:?}"),
            Err(e) => break e,
        }
    }
}

#[test]
fn too_many_frames_are_refused_not_truncated() {
    let rows = monitor_rows(FAULTS, TEST_SAMPLES + 1);
    let bytes = trace_bytes(&rows, SAMPLE_RATE_HZ);
    let source = TraceSource::open(SliceBytes::new(&bytes)).expect("a valid trace");
    let mut buffer = empty_buffer();
    let s = settings();
    let mut preflight = Preflight::new(&s, source, &mut buffer);
    let error = poll_until_error(&mut preflight);
    assert_eq!(
        error,
        PreflightError::TooManyFrames {
            capacity: TEST_SAMPLES as u32
        }
    );
    assert_eq!(preflight.poll(), Err(PreflightError::AlreadyFailed));
}

#[test]
fn a_too_short_test_fails_in_condition() {
    let rows = monitor_rows(FAULTS, 500);
    let bytes = trace_bytes(&rows, SAMPLE_RATE_HZ);
    let source = TraceSource::open(SliceBytes::new(&bytes)).expect("a valid trace");
    let mut buffer = empty_buffer();
    let s = settings();
    let mut preflight = Preflight::new(&s, source, &mut buffer);
    let error = poll_until_error(&mut preflight);
    assert!(
        matches!(error, PreflightError::Conditioning(_)),
        "{error:?}"
    );
}

#[test]
fn an_adc_frame_survives_the_trace_round_trip() {
    let frame = AdcFrame::from_f32([1.5, -0.25, -1.25], 0.125, 2.0e-3);
    let row = TraceRow::from_f64(0.0, [1.5, -0.25, -1.25], 0.125, 2.0e-3);
    assert_eq!(row.adc_frame(), frame);
}

#[test]
fn a_clipped_current_stretch_is_refused_in_acquire() {
    let mut rows = monitor_rows(FAULTS, TEST_SAMPLES);
    for row in rows.iter_mut().skip(2000).take(12) {
        row.phase_currents[1] = fixed::types::I16F16::from_num(20);
    }
    let bytes = trace_bytes(&rows, SAMPLE_RATE_HZ);
    let source = TraceSource::open(SliceBytes::new(&bytes)).expect("a valid header");
    let mut buffer = empty_buffer();
    let s = settings();
    let mut preflight = Preflight::new(&s, source, &mut buffer);
    let error = poll_until_error(&mut preflight);
    assert_eq!(
        error,
        PreflightError::Source(TraceSourceError::Trace(TraceError::SaturatedCurrent {
            phase: 1,
            first_row: 2000
        }))
    );
}

/// Polls until the report, resuming from `record` when Identify begins (if given) and
/// taking a checkpoint into `save` after `stop_after` evaluations (then stops: power loss).
fn run_preflight(
    bytes: &[u8],
    record: Option<&[u8]>,
    stop_after: Option<(u32, &mut [u8])>,
) -> (
    Option<firmware::Report>,
    Option<Result<u32, CheckpointError>>,
) {
    let source = TraceSource::open(SliceBytes::new(bytes)).expect("a valid trace");
    let mut buffer = empty_buffer();
    let s = settings();
    let mut preflight = Preflight::new(&s, source, &mut buffer);
    let mut resumed = None;
    let mut stop_after = stop_after;
    loop {
        match preflight.poll().expect("no failure") {
            Progress::Finished(r) => return (Some(r), resumed),
            Progress::Working { stage } => {
                if stage == Stage::Identify && resumed.is_none() {
                    if let Some(record) = record {
                        resumed = Some(preflight.resume(record));
                    }
                }
                if let Some((at, out)) = stop_after.as_mut() {
                    if preflight.evaluations() >= *at {
                        // Polls do `evaluations_per_poll` (5) at a time: `at` is a multiple.
                        assert_eq!(preflight.checkpoint(out), Ok(*at));
                        return (None, resumed);
                    }
                }
            }
        }
    }
}

#[test]
fn a_preflight_cut_by_power_loss_resumes_to_the_same_report() {
    let bytes = trace_bytes(&monitor_rows(FAULTS, TEST_SAMPLES), SAMPLE_RATE_HZ);
    let (reference, _) = run_preflight(&bytes, None, None);
    let reference = reference.expect("a report");

    let mut record = [0u8; core::mem::size_of::<OnboardRecord>()];
    let (report, _) = run_preflight(&bytes, None, Some((40, &mut record)));
    assert!(report.is_none(), "stopped before the end");
    let (report, resumed) = run_preflight(&bytes, Some(&record), None);
    assert_eq!(resumed, Some(Ok(40)));
    let report = report.expect("a report");
    assert_eq!(report.result, reference.result);
    assert_eq!(
        report.result.fitness.to_bits(),
        reference.result.fitness.to_bits()
    );

    // A damaged record: refused, and the preflight restarts to the same report.
    record[700] ^= 0x04;
    let (report, resumed) = run_preflight(&bytes, Some(&record), None);
    assert!(matches!(
        resumed,
        Some(Err(CheckpointError::Record(
            RecordError::BadChecksum { .. }
        )))
    ));
    assert_eq!(report.expect("a report").result, reference.result);
}

#[test]
fn a_jammed_actuator_is_reported_outside_the_models_domain() {
    // The user shaft stands still whatever the command, and the motor with it through the
    // gear; the currents are the model's. (The surface alone frozen while the motor turns is
    // a transducer or a broken linkage: `TransducerDisagrees`, below.)
    let mut rows = monitor_rows(FAULTS, TEST_SAMPLES);
    let (stuck, motor) = (rows[0].user_angle, rows[0].motor_angle);
    for row in rows.iter_mut() {
        row.user_angle = stuck;
        row.motor_angle = motor;
    }
    let bytes = trace_bytes(&rows, SAMPLE_RATE_HZ);
    let (report, _) = run_preflight(&bytes, None, None);
    let report = report.expect("a report");
    assert!(
        matches!(
            report.domain,
            Domain::Outside(OutsideReason::NoMotion { travel }) if travel == 0.0
        ),
        "{:?}",
        report.domain
    );
    // The surface alone frozen: a sensor (or linkage) fault, named as such.
    let mut rows = monitor_rows(FAULTS, TEST_SAMPLES);
    let stuck = rows[0].user_angle;
    for row in rows.iter_mut() {
        row.user_angle = stuck;
    }
    let (report, _) = run_preflight(&trace_bytes(&rows, SAMPLE_RATE_HZ), None, None);
    assert!(
        matches!(
            report.expect("a report").domain,
            Domain::Outside(OutsideReason::TransducerDisagrees { .. })
        ),
        "the surface frozen under a turning motor"
    );
    // The untouched trace moves and is not refused for lack of motion.
    let bytes = trace_bytes(&monitor_rows(FAULTS, TEST_SAMPLES), SAMPLE_RATE_HZ);
    let (report, _) = run_preflight(&bytes, None, None);
    assert!(
        !matches!(
            report.expect("a report").domain,
            Domain::Outside(OutsideReason::NoMotion { .. })
        ),
        "the model's own trace moves"
    );
}

#[test]
fn each_preflight_appends_its_record_and_reassesses_the_trend() {
    use firmware::health::record_preflight;
    use shared::health::{HealthLog, HealthRecord, RamStore, ONBOARD_RECORDS};
    use shared::prognosis::{HealthTrend, TrendSettings};

    let trend_settings = TrendSettings::DEFAULT;
    let (report, _) = run_preflight(
        &trace_bytes(
            &monitor_rows(*FaultVector::NOMINAL.as_array(), 1200),
            10_000,
        ),
        None,
        None,
    );
    let mut report = report.expect("finished");
    // Earlier preflights saw friction grow by 0.02 per flight over flights 100..=130 (0.5,
    // the threshold, at flight 125); this one (flight 131) reports 0.4.
    let mut store = RamStore::<ONBOARD_RECORDS>::erased();
    let mut log = HealthLog::<ONBOARD_RECORDS>::new();
    let mut k = *FaultVector::NOMINAL.as_array();
    for f in 100..=130u32 {
        k[0] = 0.02 * (f - 100) as f32;
        let r = HealthRecord::new(f, FaultVector::new(k).unwrap(), 0.01, Domain::Within);
        log.append(&mut store, r).unwrap();
    }
    k[0] = 0.4;
    report.result.faults = FaultVector::new(k).unwrap();
    let day = shared::health::RecordedDay::new(Some(268.4), Some(-21.5), None);
    let update = record_preflight(&mut store, None, &report, day, &trend_settings).unwrap();
    assert_eq!(update.record.flight, 131, "one after the newest");
    assert_eq!(update.record.day, day, "the record keeps the day");
    assert_eq!(update.loaded.records, 31);
    assert_eq!(update.records, 32);
    assert_eq!(update.evicted, None);
    // The last level (0.4) is below the line's 0.62: an outlier for the trend, not the end.
    let friction = update.estimates[0].expect("a friction trend");
    assert_eq!(friction.outliers, 1);
    let rul = friction.rul.unwrap().rul.expect("a crossing");
    assert_eq!(rul, 0.0, "the line crossed 0.5 at flight 125");
    // The store now holds the record: a reload gives the same log and the same trend bits.
    let (reloaded, _) = HealthLog::<ONBOARD_RECORDS>::load(&mut store).unwrap();
    assert_eq!(reloaded.latest(), Some(&update.record));
    let again =
        HealthTrend::from_records(reloaded.iter(), &trend_settings).estimates(&trend_settings);
    assert_eq!(again, update.estimates);
    // Flight 140 goes to the slot after the newest's, the oldest record's (flight 100):
    // skipping flights 132..139 loses no other record, 101..=131 and 140 remain.
    let next = record_preflight(&mut store, Some(140), &report, day, &trend_settings).unwrap();
    assert_eq!(next.evicted.map(|r| r.flight), Some(100));
    assert_eq!(next.records, 32);
    let (reloaded, _) = HealthLog::<ONBOARD_RECORDS>::load(&mut store).unwrap();
    assert_eq!(reloaded.len(), 32);
    assert_eq!(
        HealthTrend::from_records(reloaded.iter(), &trend_settings).estimates(&trend_settings),
        next.estimates
    );
    // A record for the past is refused and the store is unchanged.
    let before = store.clone();
    assert!(record_preflight(&mut store, Some(120), &report, day, &trend_settings).is_err());
    assert_eq!(store, before);
}
