//! Trace files against traces the reference model writes: CSV round trips exactly, binary to
//! the fixed-point bits, versions 1–3 written and read, both forms condition into the same
//! bits, a trace longer than its test refused. (Here rather than in `files/trace.rs`, so that
//! the file format does not import the plant that writes it.)

use host_sim::files::trace::*;
use host_sim::plant::reference::{ReferenceModel, ReferenceSettings, Scenario};
use shared::fdi::OnboardMeasured;
use shared::test_design::PreflightTest;
use shared::ActuatorParams;
use shared::FaultVector;

fn trace() -> Trace {
    let k = FaultVector::new([0.3, 0.1, 0.2, 0.0, 0.0, 0.1, 0.4, 0.6, 0.0]).unwrap();
    // The step design (5 520 rows) on the ideal drive: exact bus readings.
    ReferenceModel::new(ReferenceSettings::IDEAL_DRIVE)
        .with_test(PreflightTest::STANDSTILL)
        .simulate(&Scenario::new(k))
        .trace
}

#[test]
fn csv_round_trips_exactly_and_binary_to_the_fixed_point_bits() {
    let t = trace();
    assert!(t.has_conditions());
    let csv = t.to_csv();
    // Version 3: the design on a comment line, then the header with the day's columns.
    assert!(csv
        .starts_with(b"# test: standstill\nt,theta_cmd,i_a,i_b,i_c,theta_m,theta_u,v_bus,temp\n"));
    assert_eq!(Trace::from_csv(&csv).unwrap(), t);
    let bin = t.to_bin().unwrap();
    assert_eq!(bin.len(), 16 + 32 * 5520 + 4);
    assert_eq!(&bin[4..8], &[3, 0, 8, 1]);
    let back = Trace::from_bin(&bin).unwrap();
    assert_eq!(back.test(), t.test());
    for (a, b) in t.samples().iter().zip(back.samples()) {
        assert_eq!(a.row(), b.row());
        assert_eq!(a.time, b.time);
        assert_eq!(b.bus_voltage, Some(270.0));
    }
    // Without the day's readings: version 2, as before.
    let t = t.without_conditions();
    let csv = t.to_csv();
    assert!(csv.starts_with(b"# test: standstill\nt,theta_cmd,i_a,i_b,i_c,theta_m,theta_u\n"));
    assert_eq!(Trace::from_csv(&csv).unwrap(), t);
    let bin = t.to_bin().unwrap();
    assert_eq!(bin.len(), 16 + 24 * 5520 + 4);
    assert_eq!(&bin[4..8], &[2, 0, 6, 1]);
    for (a, b) in t
        .samples()
        .iter()
        .zip(Trace::from_bin(&bin).unwrap().samples())
    {
        assert_eq!(a.row(), b.row());
        assert_eq!(b.bus_voltage, None);
    }
    // One condition column without the other is a missing column (named at the header).
    let text = String::from_utf8(trace().to_csv()).unwrap();
    let half = text.replacen(",temp\n", "\n", 1);
    assert!(matches!(
        Trace::from_csv(half.as_bytes()),
        Err(IngestError::MissingColumn { name: "temp" })
    ));
    // The paper's test without the day's readings is still written, and read, as
    // version 1.
    let paper = ReferenceModel::new(ReferenceSettings::REFERENCE)
        .with_test(PreflightTest::PAPER)
        .simulate(&Scenario::new(FaultVector::NOMINAL))
        .trace
        .without_conditions();
    let csv = paper.to_csv();
    assert!(csv.starts_with(b"t,theta_cmd,i_a,i_b,i_c,theta_m,theta_u\n"));
    assert_eq!(Trace::from_csv(&csv).unwrap(), paper);
    let bin = paper.to_bin().unwrap();
    assert_eq!(bin.len(), 16 + 24 * 5000 + 4);
    assert_eq!(&bin[4..8], &[1, 0, 6, 0]);
    assert_eq!(*Trace::from_bin(&bin).unwrap().test(), PreflightTest::PAPER);
}

#[test]
fn csv_and_binary_condition_into_the_same_bits() {
    let t = trace();
    let p = ActuatorParams::REFERENCE;
    let from_csv = Trace::from_csv(&t.to_csv()).unwrap().measured(&p).unwrap();
    let from_bin = Trace::from_bin(&t.to_bin().unwrap())
        .unwrap()
        .measured(&p)
        .unwrap();
    let bits = |m: &OnboardMeasured| m.samples().iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&from_csv), bits(&from_bin));
    assert_eq!(from_csv.inv_kappa(), from_bin.inv_kappa());
}

#[test]
fn too_long_a_trace_is_refused_not_truncated() {
    let mut t = trace();
    let last = *t.samples().last().unwrap();
    t.push(TraceSample {
        time: last.time + 1e-4,
        ..last
    });
    let e = format!("{:#}", t.measured(&ActuatorParams::REFERENCE).unwrap_err());
    assert!(
        e.contains("5521 samples") && e.contains("holds 5520"),
        "{e}"
    );
    // A file is refused past its own test's length.
    let mut csv = String::from_utf8(t.to_csv()).unwrap();
    csv = csv.replacen("# test: standstill\n", "", 1);
    let e = Trace::from_csv(csv.as_bytes()).unwrap_err();
    assert_eq!(e.kind(), "too-many-samples", "{e}");
    let unknown = String::from_utf8(t.to_csv())
        .unwrap()
        .replacen("standstill", "wobble", 1);
    let e = Trace::from_csv(unknown.as_bytes()).unwrap_err();
    assert_eq!(e.kind(), "unknown-test");
    assert!(
        e.to_string()
            .contains("line 1: unknown test design `wobble`"),
        "{e}"
    );
}
