//! What a two-part grease's drag on the motor shaft does to the gain drift's reading on its
//! calibration day (issue 68): the reference actuator with its one-factor grease and with a
//! two-part one (`ThermalLaws::with_two_part_grease`, Arrhenius), each calibrated in its
//! climatic chamber as README says, then Table I's gain drift 0.0 and 1.0 and the healthy
//! actuator identified at the calibration's own temperature. Prints each calibration's
//! scales (the monitor model plays no grease drag: the fit folds it into the dry friction
//! and the user shaft's damping) and per run the friction and gain drift read, the fitness
//! found and at the truth.
//!
//! `cargo run --release -p host-sim --example two_part_gain_drift -- [SEEDS]` (≈ 1 min on
//! two cores).

use host_sim::files::actuator::{Actuator, Day};
use host_sim::plant::reference::ReferenceModel;
use host_sim::studies::campaign::{run_once, Case, HEALTHY_QUIET, TABLE_1};

fn main() -> anyhow::Result<()> {
    let seeds = std::env::args()
        .nth(1)
        .map(|a| a.parse::<u64>())
        .transpose()?
        .unwrap_or(2);
    let greases = [("one-factor", false), ("two-part", true)];
    let cases: Vec<&Case> = ["gain drift k8 = 0.0", "gain drift k8 = 1.0"]
        .iter()
        .filter_map(|name| TABLE_1.iter().find(|c| c.name == *name))
        .chain([&HEALTHY_QUIET])
        .collect();
    let lines = std::thread::scope(|scope| {
        let handles: Vec<_> = greases
            .iter()
            .map(|&(name, two_part)| {
                let cases = &cases;
                scope.spawn(move || run(name, two_part, cases, seeds))
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().map_err(|_| anyhow::anyhow!("a run panicked"))?)
            .collect::<anyhow::Result<Vec<_>>>()
    })?;
    for l in lines.concat() {
        println!("{l}");
    }
    Ok(())
}

/// The grease `name` calibrated, then `cases` over `seeds` seeds: one line each.
fn run(name: &str, two_part: bool, cases: &[&Case], seeds: u64) -> anyhow::Result<Vec<String>> {
    let actuator = Actuator::reference().with_day(Day {
        two_part_grease: two_part,
        ..Default::default()
    })?;
    let settings = actuator.reference_settings()?;
    let mut record = actuator.record;
    let chamber = ReferenceModel::new(settings).with_test(record.test);
    record.calibration =
        host_sim::fdi::calibration::reference_calibration(&chamber, &record.calibration)?;
    let c = &record.calibration;
    let mut out = vec![format!(
        "{name}: scales R {:.3} L {:.3} k_e {:.4} friction {:.3}, user damping {:.2} N·m·s/rad, nominal residual {:.5}",
        c.resistance_scale,
        c.inductance_scale,
        c.back_emf_scale,
        c.friction_scale,
        c.damping,
        c.nominal_residual
    )];
    for case in cases {
        for seed in 0..seeds {
            let r = run_once(&chamber, &record, case, seed)?;
            out.push(format!(
                "{name}, {}, seed {seed}: e_tot {:.2} %, friction {:.3}, gain drift {:.3}, fitness {:.5} (truth {:.5})",
                case.name,
                r.e_tot,
                r.found.friction(),
                r.found.gain_drift(),
                r.fitness,
                r.fitness_at_truth
            ));
        }
    }
    Ok(out)
}
