//! `simulate` and `preflight`: the reference model plays an actuator through a test and writes its trace, or hands it straight to the onboard FDI.

use crate::*;

pub(crate) fn simulate_scenario(
    faults: FaultVector,
    noise: f64,
    seed: u64,
    test: PreflightTest,
) -> (Trace, f64) {
    let rm = ReferenceModel::new(ReferenceSettings::REFERENCE).with_test(test);
    let start = Instant::now();
    let sim = rm.simulate(&Scenario {
        faults,
        current_ref_noise: noise,
        seed,
    });
    (sim.trace, start.elapsed().as_secs_f64())
}

pub(crate) fn format_from_extension(path: &Path) -> TraceFormat {
    match path.extension().and_then(|e| e.to_str()) {
        Some(e) if e.eq_ignore_ascii_case("bin") => TraceFormat::Bin,
        _ => TraceFormat::Csv,
    }
}

pub(crate) fn simulate(
    faults: FaultVector,
    noise: f64,
    seed: u64,
    test: PreflightTest,
    format: TraceFormat,
    out: &Path,
) -> Result<()> {
    let (trace, seconds) = simulate_scenario(faults, noise, seed, test);
    trace.write(out, format)?;
    println!(
        "wrote {} ({format}, {} samples at 10 kHz; reference model {seconds:.3} s)",
        out.display(),
        trace.samples().len()
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
    model.run_with(k, ShaftAngles::ZERO, slots.len(), command, |s| {
        if let Some(slot) = slots.next() {
            *slot = s.current;
        }
        ControlFlow::Continue(())
    });
    std::hint::black_box(buffer);
}

pub(crate) fn preflight(
    faults: FaultVector,
    noise: f64,
    seed: u64,
    test: PreflightTest,
    ga_seed: u64,
    trace_out: Option<&Path>,
    json: bool,
) -> Result<()> {
    let (trace, rm_seconds) = simulate_scenario(faults, noise, seed, test);
    if let Some(path) = trace_out {
        trace.write(path, format_from_extension(path))?;
    }
    let measured = trace.measured(&ActuatorParams::REFERENCE)?;
    let (calibration, cal_name) = load_calibration(None, &test)?;
    let id = identify(&measured, &calibration, ga_seed, progress_wanted(json))?;
    let mut heading = vec![
        (
            "actuator".to_string(),
            format!(
                "reference model, {} test, noise {noise}, seed {seed} ({rm_seconds:.3} s)",
                test.name().unwrap_or("custom")
            ),
        ),
        ("calibration".to_string(), cal_name),
        ("ga_seed".to_string(), ga_seed.to_string()),
    ];
    let (line, verdict) = domain_heading(
        trace
            .domain_monitor(&ActuatorParams::REFERENCE)
            .assess(&DomainLimits::REFERENCE_ACTUATOR, id.result.fitness),
    );
    heading.push(line);
    report(&id, Some(&faults), &heading, json);
    verdict
}
