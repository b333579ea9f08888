//! `calibrate`: fits the monitor model to a healthy trace and writes the calibration, alone
//! (JSON) or into the actuator's record (`.rec`).

use crate::cli::*;

pub(crate) fn calibrate_command(
    actuator: &Actuator,
    trace_path: &Path,
    out: &Path,
    estimate_offset: bool,
    at: &[PathBuf],
) -> Result<()> {
    if at.len() > shared::calibration::FRICTION_POINTS {
        anyhow::bail!(
            "--at takes at most {} traces (the record's friction law has that many points)",
            shared::calibration::FRICTION_POINTS
        );
    }
    let trace = actuator.read_trace(trace_path)?;
    let mut record = ActuatorRecord {
        test: *trace.test(),
        ..actuator.record
    };
    if estimate_offset {
        let first = trace
            .samples()
            .first()
            .context("the trace has no samples")?;
        let offset = first.motor_angle - f64::from(record.params.gear_ratio) * first.user_angle;
        record.params.encoder_offset = offset as f32;
        println!(
            "encoder offset      {:.5} rad (first frame: motor {:.5} rad, surface {:.3e} rad)",
            record.params.encoder_offset, first.motor_angle, first.user_angle
        );
    }
    let measured = trace.measured(&record.params)?;
    let mut file = calibrate(&measured, record.params, &actuator.record.calibration)?;
    if estimate_offset {
        file.encoder_offset = Some(record.params.encoder_offset);
    }
    if !at.is_empty() {
        let mut points = [[0.0f32; 2]; 4];
        for (slot, path) in points.iter_mut().zip(at) {
            let other = actuator.read_trace(path)?;
            let measured = other.measured(&record.params)?;
            *slot = host_sim::fdi::calibration::friction_point(
                &measured,
                record.params,
                &file.calibration(),
            )
            .with_context(|| format!("friction law from {}", path.display()))?;
            println!(
                "friction at {:>6.1} °C ×{:.3}  ({})",
                slot[0],
                slot[1],
                path.display()
            );
        }
        // The record keeps them rising in temperature (shared::conditions::friction_factor).
        points.sort_by(|a, b| a[0].total_cmp(&b[0]));
        file.friction_points = points;
    }
    record.calibration = file.calibration();
    let extension = out
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    let as_record = extension.as_deref() == Some("rec");
    if extension.as_deref() == Some("toml") {
        let source = actuator
            .source
            .clone()
            .filter(|_| actuator.reference.is_some())
            .context("--out X.toml rewrites the --actuator description (TOML): give one")?;
        let text = std::fs::read_to_string(&source)
            .with_context(|| format!("reading {}", source.display()))?;
        let mut text = Actuator::with_calibration_text(&text, &record.calibration);
        if estimate_offset {
            text = Actuator::with_key_text(
                &text,
                "installation.encoder_offset",
                &format!("{:?}", record.params.encoder_offset),
            )
            .context("the description has no [installation] encoder_offset to set")?;
        }
        Actuator::parse(&text).context("the rewritten description")?;
        std::fs::write(out, text).with_context(|| format!("writing {}", out.display()))?;
    } else if as_record {
        record
            .validate()
            .map_err(|e| ActuatorRefused(host_sim::files::actuator::describe(e)))?;
        std::fs::write(out, record.encode())
            .with_context(|| format!("writing {}", out.display()))?;
    } else {
        file.write(out)?;
    }
    println!(
        "calibration of the monitor model of {} against {}",
        actuator.name,
        trace_path.display()
    );
    println!("resistance scale    {:.5}", file.resistance_scale);
    println!("inductance scale    {:.5}", file.inductance_scale);
    println!("back-EMF scale      {:.5}", file.back_emf_scale);
    println!("nominal residual    {:.4e} A²·s", file.nominal_residual);
    println!(
        "mismatch (relative RMS of the filtered equivalent current): {:.2} % before, {:.2} % after",
        100.0 * file.mismatch_before,
        100.0 * file.mismatch_after
    );
    println!(
        "({} monitor-model runs) wrote {}{}",
        file.evaluations,
        out.display(),
        match extension.as_deref() {
            Some("rec") => " (actuator record: load it with --actuator, or flash it)",
            Some("toml") => " (the description with this calibration)",
            _ => "",
        }
    );
    Ok(())
}
