//! `actuator`: checks an actuator description and writes the record the firmware loads.

use crate::cli::*;

pub(crate) fn actuator_command(file: &Path, out: Option<&Path>) -> Result<()> {
    let actuator = Actuator::load(file).map_err(|e| ActuatorRefused(format!("{e:#}")))?;
    let r = &actuator.record;
    let p = &r.params;
    println!("actuator       {}", actuator.name);
    println!(
        "motor          {} V bus, {} pole pairs, R {} Ω, L {} H, k_e {} V·s/rad",
        p.dc_bus_voltage, p.pole_pairs, p.phase_resistance, p.phase_inductance, p.back_emf_constant
    );
    println!(
        "mechanics      gear {}, J_m {} kg·m², J_u {} kg·m², backlash {} rad, encoder offset {} rad",
        p.gear_ratio, p.motor_inertia, p.user_inertia, p.nominal_backlash, p.encoder_offset
    );
    println!(
        "test           {} ({} samples at {} s)",
        r.test.kind_name(),
        r.test.samples(p.control_period),
        p.control_period
    );
    println!(
        "tests          at most {} a preflight, as many as its noise calls for (⌈fitness / \
         the calibration's nominal residual⌉; [test] max_tests)",
        r.max_tests
    );
    println!(
        "calibration    {}",
        if actuator.calibrated {
            format!("{:?}", r.calibration)
        } else {
            "none yet (host-sim calibrate HEALTHY --actuator FILE --out X.rec)".to_string()
        }
    );
    println!("threshold      {}", r.detection_threshold);
    println!(
        "systematic     gain drift {} ({} where a gear play is read), added to a preflight's \
         deviation",
        r.systematic.gain_drift, r.systematic.play_gain_drift
    );
    if !actuator.systematic_stated {
        println!(
            "               (the reference actuator's where [uncertainty] gain_drift_systematic \
             or play_gain_drift_systematic is missing: survey this actuator's own with \
             `host-sim campaign --table 1+2 --runs 10 --actuator {}`, README step 4)",
            file.display()
        );
    }
    if let Some(path) = out {
        std::fs::write(path, actuator.record_bytes())
            .with_context(|| format!("writing {}", path.display()))?;
        println!(
            "wrote {} ({} bytes, version {}, CRC-32)",
            path.display(),
            shared::actuator::RECORD_BYTES,
            shared::actuator::RECORD_VERSION
        );
    }
    Ok(())
}
