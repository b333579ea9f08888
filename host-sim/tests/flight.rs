//! Today's FDI on windows of flight (issue 36): the monitor model plays the preflight chirp
//! alone, so a window of flight (the flight control computer's corrections, trim and
//! turbulence on the surface) must never be read `within` — it is named outside, whatever
//! the phase, the turbulence and the faults.

use host_sim::plant::reference::{ReferenceModel, ReferenceSettings};
use host_sim::studies::flight::flight_campaign;
use shared::actuator::ActuatorRecord;
use shared::domain::Domain;

#[test]
fn no_flight_window_is_read_within() {
    let rm = ReferenceModel::new(ReferenceSettings::REFERENCE);
    let rows =
        flight_campaign(&rm, &ActuatorRecord::REFERENCE, 1, |_| {}).expect("the campaign runs");
    assert_eq!(rows.len(), 18);
    for row in &rows {
        for run in &row.runs {
            let (domain, e_tot) = &run.preflight;
            assert_ne!(
                *domain,
                Domain::Within,
                "{} in {:?}: read within at e_tot {e_tot:.1} %",
                row.case,
                row.window
            );
        }
    }
}
