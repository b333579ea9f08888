//! Trace ingestion → conditioning → fitness, on both paths that read traces: the host's
//! (`Trace::from_bytes`, CSV or binary, then `Trace::measured`) and the firmware's
//! (`TraceSource` frames into `OnboardMeasured`). Neither may panic on any input, and every
//! trace they accept must give a finite fitness for a fault vector in [0, 1]^8.
//!
//! Input: byte 0 picks the mode, bytes 1..9 the fault vector (each byte / 255), the rest is
//! either a whole trace file (mode even) or raw 24-byte rows that the harness seals with a
//! valid header and checksum, repeated up to the fitness's minimum length (mode odd), so that
//! mutations reach conditioning and the fitness past the checksum. Bit 1 of the mode picks
//! the sealed trace's test: the paper's (version 1) or the standstill design (version 2).
#![no_main]

use firmware::source::{SliceBytes, SAMPLE_RATE_HZ};
use firmware::{Acquired, CurrentSource, TraceSource};
use host_sim::files::trace::Trace;
use libfuzzer_sys::fuzz_target;
use shared::fdi::{OnboardMeasured, TEST_SAMPLES};
use shared::test_design::PreflightTest;
use shared::trace::{Crc32, TraceHeader, ROW_BYTES};
use shared::{ActuatorParams, Calibration, FaultVector, FitnessProblem, LowPass};

fn fault_vector(bytes: &[u8]) -> FaultVector {
    let mut k = [0.5f32; 9];
    for (slot, b) in k.iter_mut().zip(bytes) {
        *slot = f32::from(*b) / 255.0;
    }
    FaultVector::saturating(k)
}

/// A binary trace of `test` made of `rows` (repeated to at least `min_rows`), header and CRC
/// right.
fn sealed(rows: &[u8], min_rows: usize, test: PreflightTest) -> Vec<u8> {
    let chunks: Vec<&[u8]> = rows.chunks_exact(ROW_BYTES).collect();
    if chunks.is_empty() {
        return Vec::new();
    }
    let n = chunks
        .len()
        .max(min_rows + test.lead_samples())
        .min(TEST_SAMPLES);
    let header = TraceHeader {
        sample_rate_hz: SAMPLE_RATE_HZ,
        rows: n as u32,
        test,
        conditions: false,
        flight: false,
    };
    let Ok(head) = header.encode() else {
        return Vec::new();
    };
    let mut out = head.to_vec();
    for row in chunks.iter().cycle().take(n) {
        out.extend_from_slice(row);
    }
    let mut crc = Crc32::new();
    crc.update(&out);
    out.extend_from_slice(&crc.finish().to_le_bytes());
    out
}

fn check_fitness(measured: &OnboardMeasured, k: &FaultVector) {
    let problem = FitnessProblem::new(
        measured,
        ActuatorParams::REFERENCE,
        &Calibration::reference_actuator(measured.test()),
    )
    .expect("a finished buffer makes a problem");
    let f = problem.error(k);
    assert!(f.is_finite(), "fitness {f} for {:?}", k.as_array());
}

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    let (k_bytes, body) = rest.split_at(rest.len().min(8));
    let k = fault_vector(k_bytes);
    let test = if mode & 2 == 0 {
        PreflightTest::PAPER
    } else {
        PreflightTest::STANDSTILL
    };
    let file = if mode % 2 == 1 {
        sealed(body, OnboardMeasured::MIN_SAMPLES, test)
    } else {
        body.to_vec()
    };
    let params = ActuatorParams::REFERENCE;

    // Host path.
    if let Ok(trace) = Trace::from_bytes(&file) {
        if let Ok(measured) = trace.measured(&params) {
            check_fitness(&measured, &k);
        }
    }

    // Firmware path.
    let Ok(mut source) = TraceSource::open(SliceBytes::new(&file)) else {
        return;
    };
    let filter = LowPass::for_control_period(params.control_period).expect("10 kHz filter");
    let mut measured = Box::new(OnboardMeasured::for_test(filter, source.header().test));
    loop {
        match source.next_frame() {
            Ok(Acquired::Frame(frame)) => {
                if measured.push_frame(frame, params.pole_pairs).is_err() {
                    return; // refused: more frames than the buffer holds
                }
            }
            Ok(Acquired::NotYet) => continue,
            Ok(Acquired::EndOfTest) => break,
            Err(_) => return,
        }
    }
    if measured.finish().is_ok() {
        check_fitness(&measured, &k);
    }
});
