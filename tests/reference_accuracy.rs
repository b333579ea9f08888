//! CI-sized accuracy check against the reference model with the default test (standstill
//! segment + chirp): a few paper Table I cases and the Table II medium vector, one seed (RM
//! seed 0, GA seed 1), each must reach e_tot ≤ 2 % (the target for low and medium damage).
//! The full campaign is `host-sim campaign --table 1|2|random` (docs/accuracy.md).

use host_sim::campaign::{run_once, TABLE_1, TABLE_2};
use host_sim::reference::{ReferenceModel, ReferenceSettings};
use shared::Calibration;

fn check(name: &str) {
    let case = TABLE_1
        .iter()
        .chain(TABLE_2.iter())
        .find(|c| c.name == name)
        .expect("a Table I or II case");
    let rm = ReferenceModel::new(ReferenceSettings::REFERENCE);
    let r = run_once(&rm, &Calibration::REFERENCE_ACTUATOR, case, 0).expect("identification runs");
    println!(
        "{name}: e_tot {:.3} %, found {:?}",
        r.e_tot,
        r.found.as_array()
    );
    assert!(r.e_tot <= 2.0, "{name}: e_tot {:.3} % > 2 %", r.e_tot);
}

#[test]
fn friction_medium() {
    check("friction k1 = 0.4");
}

#[test]
fn backlash_low() {
    check("backlash k2 = 0.1");
}

#[test]
fn short_circuit_medium() {
    check("short A k3 = 0.2");
}

#[test]
fn gain_drift_low() {
    check("gain drift k8 = 0.4");
}

/// Large play (1 mrad): the case the monitor model's start from the measured shaft angles
/// fixed (it was 1.3 % mean with one 4.9 % run when the model started at zero).
#[test]
fn backlash_high() {
    check("backlash k2 = 1.0");
}

/// Eccentricity: the paper's test and eq. (2) gave 10 % here; the standstill segment pins
/// the shorts so that the chirp's couplings go to the eccentricity.
#[test]
fn eccentricity_medium() {
    check("eccentricity k6 = 0.2");
}

/// Every fault at once (Table II medium: friction, backlash, three shorts, eccentricity,
/// gain drift); 9.7 % with the paper's test and eq. (2).
#[test]
fn multi_fault_medium() {
    check("medium");
}
