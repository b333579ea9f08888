//! Today's FDI on a window of flight (issue 36): the reference model flies the surface
//! ([`crate::plant::aero::FlightWindow`]: the flight control computer's corrections with the
//! test's chirp superimposed, the hinge moment of trim and turbulence) and the flown
//! identification and domain checks read the window as if it were a preflight. The monitor
//! model plays the chirp alone, so no window should come out `within`: this campaign
//! measures that it does not, and by which reason. ≈ 0.3 s per run on one core.

use anyhow::Result;
use rayon::prelude::*;
use shared::actuator::ActuatorRecord;
use shared::domain::Domain;
use shared::metrics::total_error;
use shared::test_design::PreflightTest;
use shared::{Calibration, FaultVector};

use crate::fdi::identify::identify_for;
use crate::plant::aero::{FlightPhase, FlightWindow, Turbulence};
use crate::plant::reference::{ReferenceModel, Scenario};

/// The cases: the healthy actuator, friction 0.2 and Table II medium.
pub const FLIGHT_CASES: [(&str, [f32; shared::FAULT_COUNT]); 3] = [
    ("healthy", *FaultVector::NOMINAL.as_array()),
    (
        "friction k1 = 0.2",
        [0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0],
    ),
    ("Table II medium", crate::studies::campaign::MEDIUM),
];

/// One case in one window, every seed's verdict and e_tot [%].
#[derive(Clone, Debug)]
pub struct FlightRow {
    pub case: &'static str,
    pub window: FlightWindow,
    pub runs: Vec<(Domain, f64)>,
}

/// The test a flight window carries (the record's chirp alone) and the record the FDI reads
/// it with (that test; the built-in actuator's calibration of the chirp-only test when the
/// record is the built-in one).
pub fn flight_record(record: &ActuatorRecord) -> ActuatorRecord {
    let test = PreflightTest {
        standstill: None,
        motion: None,
        ..record.test
    };
    let calibration = if *record == ActuatorRecord::REFERENCE {
        Calibration::reference_actuator(&test)
    } else {
        record.calibration
    };
    ActuatorRecord {
        test,
        calibration,
        ..*record
    }
}

/// Every case in every phase and turbulence, `runs` seeds each.
pub fn flight_campaign(
    rm: &ReferenceModel,
    record: &ActuatorRecord,
    runs: u64,
    mut progress: impl FnMut(&FlightRow),
) -> Result<Vec<FlightRow>> {
    let record = flight_record(record);
    let rm = rm.with_test(record.test);
    let mut rows = Vec::new();
    for phase in [
        FlightPhase::Climb,
        FlightPhase::Cruise,
        FlightPhase::Approach,
    ] {
        for turbulence in [Turbulence::Light, Turbulence::Moderate] {
            let window = FlightWindow { phase, turbulence };
            for (case, faults) in FLIGHT_CASES {
                let truth = FaultVector::new(faults).map_err(|e| anyhow::anyhow!("{e:?}"))?;
                let flying = rm.with_flight(Some(window));
                let runs = (0..runs)
                    .into_par_iter()
                    .map(|seed| -> Result<(Domain, f64)> {
                        let sim = flying.simulate(&Scenario {
                            seed,
                            ..Scenario::new(truth)
                        });
                        let measured = sim.trace.measured(&record.params)?;
                        let id = identify_for(&measured, &record, 1 + seed, false)?;
                        let domain =
                            id.domain(&sim.trace.domain_monitor(&record.params), &record.domain);
                        Ok((domain, f64::from(total_error(&id.result.faults, &truth))))
                    })
                    .collect::<Result<Vec<_>>>()?;
                let row = FlightRow { case, window, runs };
                progress(&row);
                rows.push(row);
            }
        }
    }
    Ok(rows)
}

/// The reason of a verdict, in the health log's words.
fn reason(d: &Domain) -> &'static str {
    shared::health::DomainCode::from(*d).name()
}

/// The campaign as Markdown: per window and case, the verdicts by reason.
pub fn flight_markdown(rows: &[FlightRow], actuator: &str) -> String {
    let mut text = format!(
        "### Today's FDI on flight windows: {actuator}, {} runs per row\n\n\
         The window: the test's chirp alone on the flight control computer's corrections, \
         the hinge moment of trim and Dryden turbulence at the phase's dynamic pressure \
         (docs/in-flight.md §1). The FDI reads it as a preflight: the monitor model plays \
         the chirp alone. Verdicts by reason; e_tot [%] of any run left `within`.\n\n\
         | phase | turbulence | case | verdicts | within: e_tot |\n\
         | --- | --- | --- | --- | ---: |\n",
        rows.first().map_or(0, |r| r.runs.len())
    );
    let mut within_total = 0;
    let mut total = 0;
    for row in rows {
        let mut counts: Vec<(&str, usize)> = Vec::new();
        for (d, _) in &row.runs {
            let name = reason(d);
            match counts.iter_mut().find(|(n, _)| *n == name) {
                Some((_, c)) => *c += 1,
                None => counts.push((name, 1)),
            }
        }
        let verdicts = counts
            .iter()
            .map(|(n, c)| format!("{n} {c}"))
            .collect::<Vec<_>>()
            .join(", ");
        let within: Vec<String> = row
            .runs
            .iter()
            .filter(|(d, _)| *d == Domain::Within)
            .map(|(_, e)| format!("{e:.1}"))
            .collect();
        within_total += within.len();
        total += row.runs.len();
        text.push_str(&format!(
            "| {:?} | {:?} | {} | {verdicts} | {} |\n",
            row.window.phase,
            row.window.turbulence,
            row.case,
            if within.is_empty() {
                "–".to_string()
            } else {
                within.join(", ")
            }
        ));
    }
    text.push_str(&format!(
        "\n{within_total} of {total} windows left `within`.\n"
    ));
    text
}
