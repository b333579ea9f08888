//! How well `calibrate --estimate-offset` finds an installation's start offset: over draws
//! of the physics family (`host_sim::studies::physics`), each with its own rigging offset the
//! record does not know, the first frame's reading against the scan of the calibration's
//! mismatch (`host_sim::fdi::calibration::estimate_offset`). Prints one line per draw and the
//! RMS error of each. About 2 s per draw.
//!
//! `cargo run --release -p host-sim --example offset_scan -- [FIRST] [DRAWS]`

use host_sim::fdi::calibration::{estimate_offset, first_frame_offset};
use host_sim::files::actuator::Actuator;
use host_sim::plant::reference::{ReferenceModel, Scenario};
use host_sim::studies::physics::PhysicsDraw;
use shared::FaultVector;

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1).map(|a| a.parse::<u64>());
    let first = args.next().transpose()?.unwrap_or(0);
    let draws = args.next().transpose()?.unwrap_or(20);
    let actuator = Actuator::reference();
    let base = actuator.reference_settings()?;
    let (mut frame_sq, mut scan_sq, mut n) = (0.0, 0.0, 0);
    for seed in first..first + draws {
        let draw = PhysicsDraw::draw(seed);
        let mut prior = actuator.record.calibration;
        prior.duty_delay = draw.duty_delay as f32;
        let model =
            ReferenceModel::new(draw.settings(&base, 0.0, true)).with_test(actuator.record.test);
        let sim = model.simulate(&Scenario::new(FaultVector::NOMINAL));
        let params = actuator.record.params;
        let frame = first_frame_offset(&sim.trace, &params).unwrap_or(f32::NAN);
        let truth = (base.encoder_offset + draw.rigging_offset) as f32;
        let scanned = estimate_offset(&sim.trace, params, &prior);
        let Some((offset, mismatch)) = scanned else {
            println!("draw {seed}: rigging {truth:+.4}: no offset calibrates");
            continue;
        };
        println!(
            "draw {seed}: rigging {truth:+.4} rad; first frame {frame:+.4} (error {:+.4}); scan \
             {offset:+.4} (error {:+.4}, mismatch {:.2} %)",
            frame - truth,
            offset - truth,
            100.0 * mismatch
        );
        frame_sq += f64::from(frame - truth).powi(2);
        scan_sq += f64::from(offset - truth).powi(2);
        n += 1;
    }
    let n = f64::from(n.max(1));
    println!(
        "RMS error over {n} draws: first frame {:.4} rad, scan {:.4} rad",
        (frame_sq / n).sqrt(),
        (scan_sq / n).sqrt()
    );
    Ok(())
}
