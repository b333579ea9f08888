//! `calibrate`: fits the monitor model to a healthy trace and writes the calibration, alone
//! (JSON) or into the actuator's record (`.rec`).

use crate::cli::*;
use host_sim::fdi::calibration::{first_frame_offset, OFFSET_SCAN_HALF_WIDTH};

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
    refuse_flight(&trace, trace_path)?;
    let mut record = ActuatorRecord {
        test: *trace.test(),
        ..actuator.record
    };
    if estimate_offset {
        let first = trace
            .samples()
            .first()
            .context("the trace has no samples")?;
        let frame = first_frame_offset(&trace, &record.params).unwrap_or(f32::NAN);
        // The first frame reads the motor through the gear's play and compliance and the
        // transducer's offset: the offset whose calibration explains the trace best, around it.
        match host_sim::fdi::calibration::estimate_offset(
            &trace,
            record.params,
            &actuator.record.calibration,
        ) {
            Some((offset, mismatch)) => {
                record.params.encoder_offset = offset;
                println!(
                    "encoder offset      {offset:.5} rad (estimated: the least mismatch, {:.2} %, \
                     within ±{OFFSET_SCAN_HALF_WIDTH} rad of the first frame's {frame:.5} rad: \
                     motor {:.5} rad, surface {:.3e} rad; --keep-offset keeps the \
                     description's {:.5} rad)",
                    100.0 * mismatch,
                    first.motor_angle,
                    first.user_angle,
                    actuator.record.params.encoder_offset,
                );
            }
            None => {
                // No offset calibrates: the description's, refused, says with its figures why.
                let measured = trace.measured(&record.params)?;
                calibrate(&measured, record.params, &actuator.record.calibration).with_context(
                    || {
                        format!(
                            "no start offset within ±{OFFSET_SCAN_HALF_WIDTH} rad of the first \
                             frame's {frame:.5} rad calibrates the trace, nor the description's \
                             {:.5} rad",
                            record.params.encoder_offset
                        )
                    },
                )?;
                println!(
                    "encoder offset      {:.5} rad (the description's: no other within \
                     ±{OFFSET_SCAN_HALF_WIDTH} rad of the first frame's {frame:.5} rad calibrates)",
                    record.params.encoder_offset
                );
            }
        }
    }
    let measured = trace.measured(&record.params)?;
    let mut file = calibrate(&measured, record.params, &actuator.record.calibration)?;
    if estimate_offset {
        file.encoder_offset = Some(record.params.encoder_offset);
    }
    let [low, high] = record.domain.temperature;
    let mut seen: Vec<(PathBuf, f32)> = vec![(trace_path.to_path_buf(), file.temperature)];
    if !at.is_empty() {
        // First every trace, checked; then the grease's drag law; then each point's friction.
        let mut traces = Vec::new();
        for path in at {
            let other = actuator.read_trace(path)?;
            refuse_flight(&other, path)?;
            let measured = other.measured(&record.params)?;
            let celsius = measured.conditions().temperature().with_context(|| {
                format!(
                    "--at {}: the trace carries no measured temperature (a version 3 trace \
                     has `temp`): it cannot place a point of the friction law",
                    path.display()
                )
            })?;
            if !(low..=high).contains(&celsius) {
                anyhow::bail!(
                    "--at {}: measured {celsius:.1} °C, outside the description's [domain] \
                     temperature [{low}, {high}] °C: the law would be measured where the FDI \
                     refuses to identify. Widen [domain] temperature if the actuator is to \
                     be verified there",
                    path.display()
                );
            }
            for (earlier, t) in &seen {
                if same_file(earlier, path) || (celsius - t).abs() < MIN_POINT_SPACING {
                    anyhow::bail!(
                        "--at {}: {} ({:.1} °C against {:.1} °C): each --at trace must be \
                         another healthy trace at its own temperature, at least {} K from \
                         the others and from the calibration's",
                        path.display(),
                        if same_file(earlier, path) {
                            format!("the same trace as {}", earlier.display())
                        } else {
                            format!("the same temperature as {}", earlier.display())
                        },
                        celsius,
                        t,
                        MIN_POINT_SPACING
                    );
                }
            }
            seen.push((path.clone(), celsius));
            traces.push((path, measured));
        }
        let refs: Vec<&shared::fdi::OnboardMeasured> = traces.iter().map(|t| &*t.1).collect();
        let law = host_sim::fdi::calibration::grease_law(&measured, &refs);
        file.viscous = law.as_ref().map_or(0.0, |l| l.0);
        let mut points = Vec::new();
        for (j, (path, measured)) in traces.iter().enumerate() {
            let point = host_sim::fdi::calibration::friction_point(
                measured,
                record.params,
                &file.calibration(),
            )
            .with_context(|| format!("friction law from {}", path.display()))?;
            let drag = law.as_ref().map_or(0.0, |l| l.1[j]);
            println!(
                "friction at {:>6.1} °C ×{:.3}{}  ({})",
                point[0],
                point[1],
                if drag > 0.0 {
                    format!(", drag ×{drag:.2}")
                } else {
                    String::new()
                },
                path.display()
            );
            points.push((point, drag));
        }
        // The record keeps them rising in temperature (shared::conditions::friction_factor).
        (file.friction_points, file.drag_points) = host_sim::fdi::calibration::friction_law(points);
    } else if actuator.built_in {
        // The built-in record's law is the reference model's grease, not this actuator's.
        file.friction_points = [[0.0; 2]; 4];
        file.viscous = 0.0;
        file.drag_points = [0.0; 4];
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
    let law: Vec<String> = file
        .friction_points
        .iter()
        .filter(|p| p[1] > 0.0)
        .map(|p| format!("{:.1} °C ×{:.3}", p[0], p[1]))
        .collect();
    println!(
        "friction law        {}",
        if law.is_empty() {
            "none: friction does not move with temperature (measure one with --at)".to_string()
        } else if at.is_empty() {
            format!(
                "{} (kept from the description's [calibration])",
                law.join(", ")
            )
        } else {
            law.join(", ")
        }
    );
    if !law.is_empty() {
        println!(
            "grease              {}",
            if file.viscous > 0.0 {
                "a drag of its own: the chirp's drag reads the gearbox's state and sets the \
                 healthy friction (the friction law by drag)"
            } else {
                "no drag that moves with temperature: friction follows the thermistor"
            }
        );
    }
    if file.duty_delay > 0.0 {
        println!(
            "controller timing   volts {:.1} µs after their sample ([drive] duty_delay)",
            1e6 * file.duty_delay
        );
    }
    if let Some(held) = file.held_at_data_sheet {
        println!(
            "R and L held       at the data sheet's: the free fit ran them to ×{:.3} and ×{:.3} \
             (a bound) for a mismatch of {:.2} %, held {:.2} % — the chirp does not tell them",
            held.free_resistance,
            held.free_inductance,
            100.0 * held.free_mismatch,
            100.0 * held.held_mismatch
        );
    }
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

/// Least spacing of the friction law's temperatures [K]: closer points make its slope the
/// thermistor's noise.
const MIN_POINT_SPACING: f32 = 2.0;

/// Whether two paths name one file (the same path, or the same file reached two ways).
fn same_file(a: &Path, b: &Path) -> bool {
    a == b
        || matches!(
            (std::fs::canonicalize(a), std::fs::canonicalize(b)),
            (Ok(x), Ok(y)) if x == y
        )
}

/// A calibration is measured on the preflight test of a healthy actuator on the ground, never
/// on a window of flight (its hinge load and the flight's commands are not the test's).
fn refuse_flight(trace: &host_sim::files::trace::Trace, path: &Path) -> Result<()> {
    if trace.is_flight() {
        anyhow::bail!(
            "{}: a window of flight (`# test: flight`) cannot calibrate: give a healthy \
             actuator's preflight trace",
            path.display()
        );
    }
    Ok(())
}
