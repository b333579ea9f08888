//! `simulate` and `preflight`: the reference model plays an actuator through a test and writes its trace, or hands it straight to the onboard FDI.

use crate::cli::*;
use crate::commands::identify::{calibration_name, domain_heading, report};

pub(crate) fn simulate_scenario(actuator: &Actuator, sim: &Simulated) -> Result<(Trace, f64)> {
    let Simulated {
        faults,
        noise,
        seed,
        sensor_fault,
        demagnetization,
        wind,
        flight,
    } = *sim;
    let settings = actuator.reference_settings()?;
    if let Demagnetization::Partial { pole, .. } = demagnetization {
        let poles = 2 * settings.params.pole_pairs as u32;
        if pole >= poles {
            anyhow::bail!(
                "--demagnetization: pole {pole} of an actuator with {poles} poles (0 … {})",
                poles - 1
            );
        }
    }
    // In flight the position loop flies the surface: the test is its chirp alone.
    let test = match flight {
        Some(_) => shared::test_design::PreflightTest {
            standstill: None,
            motion: None,
            ..actuator.record.test
        },
        None => actuator.record.test,
    };
    let rm = ReferenceModel::new(settings)
        .with_test(test)
        .with_flight(flight)
        .with_sensor_fault(sensor_fault)
        .with_demagnetization(demagnetization)
        .with_wind(wind);
    let start = Instant::now();
    let sim = rm.simulate(&Scenario {
        faults,
        current_ref_noise: noise,
        seed,
    });
    Ok((sim.trace, start.elapsed().as_secs_f64()))
}

pub(crate) fn format_from_extension(path: &Path) -> TraceFormat {
    match path.extension().and_then(|e| e.to_str()) {
        Some(e) if e.eq_ignore_ascii_case("bin") => TraceFormat::Bin,
        _ => TraceFormat::Csv,
    }
}

pub(crate) fn simulate(
    actuator: &Actuator,
    sim: &Simulated,
    format: TraceFormat,
    out: &Path,
) -> Result<()> {
    let (trace, seconds) = simulate_scenario(actuator, sim)?;
    trace.write(out, format)?;
    let wind = match (sim.wind, sim.flight) {
        (_, Some(f)) => {
            format!(", in flight: {:?}, {:?} turbulence", f.phase, f.turbulence).to_lowercase()
        }
        (Some(w), None) if w.gust_knots > w.mean_knots => {
            format!(", wind {} kt gusting {} kt", w.mean_knots, w.gust_knots)
        }
        (Some(w), None) => format!(", wind {} kt", w.mean_knots),
        (None, None) => String::new(),
    };
    println!(
        "wrote {} ({format}, {} samples at {:.0} Hz, {}{wind}; reference model {seconds:.3} s)",
        out.display(),
        trace.samples().len(),
        1.0 / actuator.params().control_period,
        actuator.name
    );
    Ok(())
}

/// One monitor-model run from rest into `buffer` (the equivalent current), reading the
/// command from `command`; monomorphised, as in the fitness.
pub(crate) fn simulate_into(
    model: &MonitorModel,
    k: &FaultVector,
    command: &impl CommandSource,
    buffer: &mut [f32],
) {
    let mut slots = buffer.iter_mut();
    model.run_with(
        k,
        ShaftAngles::ZERO,
        slots.len(),
        command,
        |s: &shared::monitor::MonitorSample| {
            if let Some(slot) = slots.next() {
                *slot = s.current;
            }
            ControlFlow::Continue(())
        },
    );
    std::hint::black_box(buffer);
}

pub(crate) fn preflight(
    actuator: &Actuator,
    sim: &Simulated,
    ga_seed: u64,
    trace_out: Option<&Path>,
    json: bool,
) -> Result<()> {
    if sim.flight.is_some() {
        // A window of flight: the window identification, not the preflight's.
        let (trace, _) = simulate_scenario(actuator, sim)?;
        if let Some(path) = trace_out {
            trace.write(path, format_from_extension(path))?;
        }
        let truth = sim
            .demagnetization
            .truth(&sim.faults, actuator.params().pole_pairs as u32);
        // The same flight's preflight, on the ground: the windows hold its shorts.
        let ground = Simulated {
            flight: None,
            ..*sim
        };
        let (preflight, _) = simulate_scenario(actuator, &ground)?;
        let held = crate::commands::identify::held_from_preflight_trace(
            actuator,
            &preflight,
            "the reference model's preflight on the ground",
            ga_seed,
        )?;
        return crate::commands::identify::window_report(
            actuator,
            &trace,
            "the reference model's window",
            &[],
            &held,
            ga_seed,
            Some(truth),
            json,
        );
    }
    let test = actuator.record.test;
    let record = actuator.record_for(&test)?;
    let (trace, rm_seconds) = simulate_scenario(actuator, sim)?;
    let Simulated {
        faults,
        noise,
        seed,
        demagnetization,
        wind,
        ..
    } = *sim;
    // A weak magnet or a loss beyond k9's is scored as the mean flux it took.
    let truth = demagnetization.truth(&faults, record.params.pole_pairs as u32);
    if let Some(path) = trace_out {
        trace.write(path, format_from_extension(path))?;
    }
    let measured = trace.measured(&record.params)?;
    let id = identify_for(&measured, &record, ga_seed, progress_wanted(json))?;
    let mut heading = vec![
        (
            "actuator".to_string(),
            format!(
                "{} played by the reference model, {} test, noise {noise}, seed {seed}{} ({rm_seconds:.3} s)",
                actuator.name,
                test.kind_name(),
                wind.map_or(String::new(), |w| format!(
                    ", wind {} kt gusting {} kt",
                    w.mean_knots, w.gust_knots
                ))
            ),
        ),
        ("calibration".to_string(), calibration_name(actuator, &test)),
        ("ga_seed".to_string(), ga_seed.to_string()),
    ];
    let (line, verdict) =
        domain_heading(id.domain(&trace.domain_monitor(&record.params), &record.domain));
    heading.push(line);
    report(
        &id,
        &record.params,
        Some(&truth),
        &heading,
        json,
        record.detection_threshold,
        None,
    );
    verdict
}
