//! `identify`: the onboard FDI on a trace file, and the report (table or JSON) shared with `preflight`.

use crate::cli::*;

/// The domain verdict as a heading line, and the exit status it calls for.
pub(crate) fn domain_heading(domain: Domain) -> ((String, String), Result<()>) {
    match domain {
        Domain::Within => (("domain".to_string(), "within".to_string()), Ok(())),
        Domain::Outside(reason) => {
            eprintln!(
                "warning: the actuator is outside the monitor model's domain ({reason:?}): \
                 do not act on the fault vector"
            );
            if let OutsideReason::LoadMoved { .. } | OutsideReason::LoadMovedAtRest { .. } = reason
            {
                eprintln!(
                    "note: the surface carried a moment other than its hinge spring during the \
                     test (wind or a gust on the parked aircraft, a hand on the surface): the \
                     test is spoiled, not the actuator; run it again when the surface is quiet"
                );
            }
            (
                ("domain".to_string(), format!("outside: {reason:?}")),
                Err(ExitWith(EXIT_OUTSIDE_DOMAIN).into()),
            )
        }
    }
}

/// The calibration file at `path`, or the built-in one of the trace's test.
/// The record the FDI runs with for `test`: the actuator's, with the calibration from
/// `--calibration FILE` (JSON) when given; and a name for the calibration.
pub(crate) fn load_record(
    actuator: &Actuator,
    path: Option<&Path>,
    test: &PreflightTest,
) -> Result<(ActuatorRecord, String)> {
    match path {
        Some(p) => {
            let file = CalibrationFile::read(p)?;
            let mut record = ActuatorRecord {
                calibration: file.calibration(),
                test: *test,
                ..actuator.record
            };
            // The start offset `calibrate` estimated travels with the calibration.
            if let Some(offset) = file.encoder_offset {
                record.params.encoder_offset = offset;
            }
            Ok((record, p.display().to_string()))
        }
        None => Ok((actuator.record_for(test)?, calibration_name(actuator, test))),
    }
}

/// Where the calibration comes from, in words.
pub(crate) fn calibration_name(actuator: &Actuator, test: &PreflightTest) -> String {
    if actuator.built_in {
        format!("built-in ({} test)", test.kind_name())
    } else {
        format!("{}'s calibration", actuator.name)
    }
}

pub(crate) fn verdict_text(v: Verdict) -> &'static str {
    match v {
        Verdict::Healthy => "healthy",
        Verdict::Faulty => "FAULT",
        Verdict::NotApplicable => "-",
    }
}

pub(crate) fn assessment_text(a: Assessment) -> String {
    match a {
        Assessment::Healthy => "healthy".into(),
        Assessment::Suspect => "suspect".into(),
        Assessment::Faulty => "FAULT".into(),
        Assessment::Ambiguous { with } => format!(
            "ambiguous/{}",
            FAULT_NAMES.get(usize::from(with)).copied().unwrap_or("?")
        ),
        Assessment::NotApplicable => "-".into(),
    }
}

/// The weak magnet of a reading on the rotor of `params`, as the reports write it.
pub(crate) fn weak_magnet_text(
    magnets: &shared::magnets::WeakMagnet,
    params: &ActuatorParams,
) -> String {
    if magnets.is_none() {
        return "none (the magnets read alike)".to_string();
    }
    format!(
        "pole {} of {} (centre {:.1}° from the encoder's zero), {:.2} of its flux lost",
        magnets.pole(params),
        shared::magnets::poles(params),
        magnets.centre.to_degrees().rem_euclid(360.0),
        magnets.depth
    )
}

/// A read weak magnet's deviation, 90 % interval and verdict, as the reports write them
/// (empty without a magnet).
fn weak_magnet_uncertainty_text(depth: f32, std: f32, verdict: Assessment) -> String {
    if depth <= 0.0 {
        return String::new();
    }
    let interval = if std.is_finite() {
        let (lo, hi) = shared::uncertainty::magnet_interval(depth, std);
        format!("± {std:.3} (1 σ), 90 % [{lo:.3}, {hi:.3}], ")
    } else {
        "deviation unknown, ".to_string()
    };
    format!("; {interval}{}", assessment_text(verdict))
}

pub(crate) fn report(
    id: &Identified,
    params: &ActuatorParams,
    truth: Option<&FaultVector>,
    heading: &[(String, String)],
    json: bool,
    threshold: f32,
    repeated: Option<&Repeated>,
) {
    let magnets = id.result.magnets;
    let found = id.result.faults;
    let verdicts = found.verdicts_at(threshold);
    let assessments = id.assessments_at(threshold);
    let magnet_verdict = id.magnet_assessment_at(threshold);
    let magnet_std = id.magnet_std();
    let uncertainty = id.uncertainty.as_ref().map(|(u, _)| u);
    if json {
        let mut obj = json!({
            "faults": found.as_array(),
            "fitness": id.result.fitness,
            "evaluations": id.result.evaluations,
            "seconds": id.seconds,
            "stop_reason": format!("{:?}", id.result.stop_reason),
            "verdicts": assessments.iter().map(|&a| assessment_text(a)).collect::<Vec<_>>(),
            "threshold_verdicts": verdicts.iter().map(|&v| verdict_text(v)).collect::<Vec<_>>(),
            "weak_magnet": (!magnets.is_none()).then(|| json!({
                "depth": magnets.depth,
                "centre_rad": magnets.centre,
                "pole": magnets.pole(params),
                "poles": shared::magnets::poles(params),
                "std": magnet_std.is_finite().then_some(magnet_std),
                "interval90": magnet_std.is_finite().then(|| {
                    let (lo, hi) = shared::uncertainty::magnet_interval(magnets.depth, magnet_std);
                    [lo, hi]
                }),
                "verdict": assessment_text(magnet_verdict),
            })),
        });
        if let Some(u) = uncertainty {
            // NaN (undetermined) is written as null.
            let finite = |x: f32| x.is_finite().then_some(x);
            obj["std"] = json!(u.std.map(finite));
            obj["interval90"] = json!((0..FAULT_COUNT)
                .map(|i| finite(u.std[i]).map(|_| [u.lower[i], u.upper[i]]))
                .collect::<Vec<_>>());
            obj["worst_correlation"] = json!({
                "pair": [FAULT_NAMES[usize::from(u.worst_pair.0)], FAULT_NAMES[usize::from(u.worst_pair.1)]],
                "value": u.worst_correlation,
            });
        }
        if let Some(t) = truth {
            obj["truth"] = json!(t.as_array());
            obj["errors"] = json!(component_errors(&found, t));
            obj["e_tot"] = json!(total_error(&found, t));
            obj["e_tot_all"] = json!(total_error_all(&found, t));
        }
        for (k, v) in heading {
            obj[k.as_str()] = json!(v);
        }
        if let Some(r) = repeated {
            let mean = r.tests.reading();
            let finite = |x: Option<f32>| x.filter(|v| v.is_finite());
            obj["repeated"] = json!({
                "called_for": r.called_for,
                "played": r.tests.played(),
                "averaged": r.tests.trusted(),
                "faults": mean.faults.as_array(),
                "std": (0..FAULT_COUNT).map(|i| finite(mean.std.get(i))).collect::<Vec<_>>(),
                "fitness": mean.fitness,
                "domain": mean.domain.name(),
            });
        }
        let c = &id.conditions;
        obj["conditions"] = json!({
            "winding_rise_k": c.winding_rise,
            "winding_disagreement_k": c.winding_disagreement,
            "winding_estimate": format!("{:?}", c.winding),
            "flux_scale": c.flux_scale,
            "magnet_flux_left": found.effects().flux_scale,
            "friction_scale": c.friction_scale,
            "measured_temperature_c": c.measured_temperature,
            "bus_voltage_v": c.bus_voltage,
        });
        println!("{obj}");
        return;
    }
    for (k, v) in heading {
        println!("{k:<13} {v}");
    }
    println!();
    let errors = truth.map(|t| component_errors(&found, t));
    match truth {
        Some(_) => println!(
            "{:<15} {:>8} {:>8} {:>17} {:>22} {:>8} {:>8}",
            "fault", "found", "std", "90 % interval", "reading", "true", "e_i [%]"
        ),
        None => println!(
            "{:<15} {:>8} {:>8} {:>17} {:>22}",
            "fault", "found", "std", "90 % interval", "reading"
        ),
    }
    for i in 0..FAULT_COUNT {
        let k = found.as_array()[i];
        let (std, interval) = match uncertainty {
            Some(u) if u.std[i].is_finite() => (
                format!("{:.4}", u.std[i]),
                format!("[{:.4}, {:.4}]", u.lower[i], u.upper[i]),
            ),
            _ => ("-".to_string(), "-".to_string()),
        };
        let mut line = format!(
            "{:<15} {k:>8.4} {std:>8} {interval:>17} {:>22}",
            FAULT_NAMES[i],
            assessment_text(assessments[i])
        );
        if let (Some(t), Some(e)) = (truth, errors.as_ref()) {
            line += &format!(" {:>8.4} {:>8.3}", t.as_array()[i], e[i]);
        }
        println!("{line}");
    }
    let phase_deg = -180.0 + 360.0 * f64::from(found.eccentricity_phase());
    println!("(eccentricity phase {phase_deg:.0}° from phase A; a location, read only with an eccentricity fault)");
    println!(
        "weak magnet   {}{}",
        weak_magnet_text(&magnets, params),
        weak_magnet_uncertainty_text(magnets.depth, magnet_std, magnet_verdict)
    );
    if let Some(u) = uncertainty {
        println!(
            "(FAULT: the whole 90 % interval is beyond the {} detection threshold; suspect: the \
             value is, its interval is not; most correlated pair: {} and {}, {:.2})",
            threshold,
            FAULT_NAMES[usize::from(u.worst_pair.0)],
            FAULT_NAMES[usize::from(u.worst_pair.1)],
            u.worst_correlation
        );
    }
    if let Some(t) = truth {
        println!(
            "e_tot         {:.3} % (the paper's eight components, eq. 4); {:.3} % over all nine",
            total_error(&found, t),
            total_error_all(&found, t)
        );
    }
    println!("{}", conditions_text(&id.conditions));
    if id.friction_nuisance > 0.0 {
        println!(
            "nuisance      healthy friction read ×{:.3} of the day's estimate (estimated with \
             the faults, down to e^-2σ); the friction's deviation carries {:.4} of it (its law \
             moves {:.2} %/K here × the gearbox's declared spread from the thermistor, \
             [uncertainty] gear_temperature_spread)",
            id.healthy_friction,
            id.friction_nuisance,
            100.0 * id.conditions.friction_slope
        );
    }
    println!(
        "fitness       {:.4e} A²·s (nominal residual subtracted)",
        id.result.fitness
    );
    println!(
        "evaluations   {} (stopped: {:?})",
        id.result.evaluations, id.result.stop_reason
    );
    println!("seconds       {:.3}", id.seconds);
    if let Some(r) = repeated {
        repeated_text(r);
    }
}

/// The table's lines of a preflight's repeated tests: how many, and their mean record.
fn repeated_text(r: &Repeated) {
    let mean = r.tests.reading();
    println!();
    println!(
        "tests         the first's noise calls for {} (⌈fitness / nominal residual⌉, at most \
         [test] max_tests); {} read, {} within and averaged",
        r.called_for,
        r.tests.played(),
        r.tests.trusted()
    );
    if r.tests.trusted() < 2 {
        return;
    }
    println!("{:<15} {:>8} {:>8}", "mean of tests", "value", "std");
    for (i, name) in FAULT_NAMES.iter().enumerate() {
        let std = mean
            .std
            .get(i)
            .map_or("-".to_string(), |s| format!("{s:.4}"));
        println!("{name:<15} {:>8.4} {std:>8}", mean.faults.as_array()[i]);
    }
    println!(
        "(the record the controller logs: deviations over √n; fitness {:.4e})",
        mean.fitness
    );
}

/// The day the FDI estimated, in one line.
pub(crate) fn conditions_text(c: &shared::conditions::TestConditions) -> String {
    let measured =
        |x: Option<f32>, unit: &str| x.map_or("-".to_string(), |v| format!("{v:.1} {unit}"));
    let winding = match c.winding {
        shared::conditions::WindingEstimate::Injection => {
            format!(
                "{:+.1} K from calibration (estimated; injection − thermistor {:+.1} K)",
                c.winding_rise, c.winding_disagreement
            )
        }
        other => format!("not estimated ({other:?})"),
    };
    format!(
        "day           winding {winding}; flux ×{:.4} (the day's, reversible); healthy friction ×{:.3}; measured {} and {}",
        c.flux_scale,
        c.friction_scale,
        measured(c.measured_temperature, "°C"),
        measured(c.bus_voltage, "V")
    )
}

/// The other traces of a flight: a window's further windows and its preflight, or a
/// preflight's test played again.
pub(crate) struct FlightFiles<'a> {
    pub same_flight: &'a [std::path::PathBuf],
    pub preflight: Option<&'a Path>,
    pub again: &'a [std::path::PathBuf],
}

/// A preflight's tests played again where its noise called for them
/// (`shared::repeat::RepeatedTests`): how many, and the record their mean makes.
pub(crate) struct Repeated {
    pub called_for: u32,
    pub tests: shared::repeat::RepeatedTests,
}

/// The components the windows of a flight hold: the stator shorts and the demagnetization
/// at the reading of the flight's `preflight` trace when it is `within`, with a line for the
/// report that says so.
fn held_from_preflight(
    actuator: &Actuator,
    preflight: Option<&Path>,
    seed: u64,
) -> Result<(shared::window::HeldComponents, String)> {
    let Some(path) = preflight else {
        return Ok((
            shared::window::HeldComponents::NONE,
            "shorts, eccentricity and demagnetization read from the window (no --preflight: a \
             window cannot tell a short from an eccentricity, nor a demagnetization from \
             friction under its unknown load)"
                .into(),
        ));
    };
    let trace = actuator.read_trace(path)?;
    if trace.is_flight() {
        anyhow::bail!(
            "--preflight {}: a window of flight, not a preflight",
            path.display()
        );
    }
    held_from_preflight_trace(actuator, &trace, &path.display().to_string(), seed)
}

/// [`held_from_preflight`] of a preflight `trace` named `name`.
pub(crate) fn held_from_preflight_trace(
    actuator: &Actuator,
    trace: &host_sim::files::trace::Trace,
    name: &str,
    seed: u64,
) -> Result<(shared::window::HeldComponents, String)> {
    use shared::window::HeldComponents;
    let (record, _) = load_record(actuator, None, trace.test())?;
    let measured = trace.measured(&record.params)?;
    let id = host_sim::fdi::identify::identify_for(&measured, &record, seed, false)?;
    let domain = id.domain(&trace.domain_monitor(&record.params), &record.domain);
    if domain != Domain::Within {
        return Ok((
            HeldComponents::NONE,
            format!(
                "shorts, eccentricity and demagnetization read from the window: the \
                 preflight {name} is outside ({})",
                shared::health::DomainCode::from(domain).name()
            ),
        ));
    }
    let k = id.result.faults.as_array();
    let held = host_sim::fdi::window::held_from(&id, true);
    // The held values' error the window's deviations carry (the preflight's σ scaled by
    // `shared::window::HELD_ERROR_SCALE`).
    let c = held.covariance();
    let s = |i: usize| c[i][i].max(0.0).sqrt();
    let (ecc, phase, demag) = (
        shared::fault::ECCENTRICITY_INDEX,
        shared::fault::ECCENTRICITY_PHASE_INDEX,
        shared::fault::DEMAGNETIZATION_INDEX,
    );
    Ok((
        held,
        format!(
            "shorts, eccentricity and demagnetization held at the preflight's ({name}), their \
             error carried into the deviations: shorts A {:.3} ± {:.3}, B {:.3} ± {:.3}, \
             C {:.3} ± {:.3}; eccentricity {:.3} ± {:.3} at phase {:.3} ± {:.3}; \
             demagnetization {:.3} ± {:.3} (1 σ); weak magnet held: {}",
            k[2],
            s(2),
            k[3],
            s(3),
            k[4],
            s(4),
            k[ecc],
            s(ecc),
            k[phase],
            s(phase),
            k[demag],
            s(demag),
            weak_magnet_text(&held.magnets(), &record.params)
        ),
    ))
}

#[allow(clippy::too_many_arguments)]
pub(crate) fn identify_command(
    actuator: &Actuator,
    trace_path: &Path,
    files: &FlightFiles,
    calibration: Option<&Path>,
    seed: u64,
    truth: Option<FaultVector>,
    json: bool,
    checkpointing: Option<&Checkpointing>,
) -> Result<()> {
    let trace = actuator.read_trace(trace_path)?;
    if trace.is_flight() {
        if checkpointing.is_some() || calibration.is_some() {
            anyhow::bail!(
                "{}: a window of flight is identified in one go with the actuator's own \
                 record (no --checkpoint, no --calibration)",
                trace_path.display()
            );
        }
        let others = files
            .same_flight
            .iter()
            .map(|path| {
                let other = actuator.read_trace(path)?;
                if !other.is_flight() {
                    anyhow::bail!(
                        "--same-flight {}: not a window of flight (its first line has no \
                         `# test: flight`)",
                        path.display()
                    );
                }
                Ok((path.display().to_string(), other))
            })
            .collect::<Result<Vec<_>>>()?;
        if !files.again.is_empty() {
            anyhow::bail!(
                "--again: {} is a window of flight; only a preflight's test is played again",
                trace_path.display()
            );
        }
        let held = held_from_preflight(actuator, files.preflight, seed)?;
        return window_report(
            actuator,
            &trace,
            &trace_path.display().to_string(),
            &others,
            &held,
            seed,
            truth,
            json,
        );
    }
    if files.preflight.is_some() {
        anyhow::bail!(
            "--preflight: {} is a preflight, not a window of flight",
            trace_path.display()
        );
    }
    if !files.same_flight.is_empty() {
        anyhow::bail!(
            "--same-flight: {} is a preflight, not a window of flight; only windows are fused",
            trace_path.display()
        );
    }
    let (record, cal_name) = load_record(actuator, calibration, trace.test())?;
    let measured = trace.measured(&record.params)?;
    let (outcome, resumption) = identify_checkpointed(
        &measured,
        &record,
        seed,
        progress_wanted(json),
        checkpointing,
    )?;
    if let Some(c) = checkpointing {
        let file = c.path.display();
        match resumption {
            Resumption::Fresh => {}
            Resumption::Resumed(n) => eprintln!("resumed from {file} at {n} evaluations"),
            Resumption::Refused(e) => {
                eprintln!("checkpoint {file} refused ({e:?}): the identification restarted")
            }
        }
    }
    let id = match outcome {
        Outcome::Finished(id) => *id,
        Outcome::Interrupted { evaluations } => {
            eprintln!(
                "stopped after {evaluations} evaluations (simulated power loss); checkpoint in {}",
                checkpointing.map_or(String::new(), |c| c.path.display().to_string())
            );
            return Err(ExitWith(EXIT_INTERRUPTED).into());
        }
    };
    let mut heading = vec![
        ("trace".to_string(), trace_path.display().to_string()),
        ("actuator".to_string(), actuator.name.clone()),
        ("calibration".to_string(), cal_name),
        ("ga_seed".to_string(), seed.to_string()),
    ];
    let domain = id.domain(&trace.domain_monitor(&record.params), &record.domain);
    let (line, verdict) = domain_heading(domain);
    heading.push(line);
    let repeated = repeated_tests(
        actuator,
        &trace,
        &id,
        domain,
        files.again,
        &record,
        seed,
        json,
    )?;
    if let Domain::Outside(
        shared::domain::OutsideReason::FitnessFloor { .. }
        | shared::domain::OutsideReason::InstallationChanged { .. },
    ) = domain
    {
        // What did not fit: the part of the test that holds the unexplained current.
        let parts = host_sim::fdi::calibration::residual_by_part(
            &measured,
            record.params,
            &record.calibration,
            &id.conditions,
            &id.result.faults,
        );
        let text = parts
            .iter()
            .map(|(name, share, misfit)| format!("{name} {share:.0} % ({misfit:.1} % RMS)"))
            .collect::<Vec<_>>()
            .join(", ");
        eprintln!("unexplained current at the result, by part of the test: {text}");
        heading.push(("unexplained".to_string(), text));
    }
    if checkpointing.is_some() {
        let said = match resumption {
            Resumption::Fresh => "fresh start".to_string(),
            Resumption::Resumed(n) => format!("resumed at {n} evaluations"),
            Resumption::Refused(e) => format!("refused ({e:?}), restarted"),
        };
        heading.push(("checkpoint".to_string(), said));
    }
    report(
        &id,
        &record.params,
        truth.as_ref(),
        &heading,
        json,
        record.detection_threshold,
        repeated.as_ref(),
    );
    verdict
}

/// The `--again` traces a preflight's first reading `first` (judged `domain`) calls for, read
/// as the controller reads them; `None` without `--again`. Each must be the first trace's
/// test: its rows, design and kind.
#[allow(clippy::too_many_arguments)]
fn repeated_tests(
    actuator: &Actuator,
    trace: &Trace,
    first: &Identified,
    domain: Domain,
    again: &[std::path::PathBuf],
    record: &ActuatorRecord,
    seed: u64,
    json: bool,
) -> Result<Option<Repeated>> {
    if again.is_empty() {
        return Ok(None);
    }
    let mut tests = shared::repeat::RepeatedTests::EMPTY;
    tests.add(&first.health_record(0, domain));
    let called_for = tests.called_for(record);
    let shape = |t: &Trace| (t.samples().len(), t.test().kind(), t.is_flight());
    for path in again.iter().take(called_for.saturating_sub(1) as usize) {
        let other = actuator.read_trace(path)?;
        if shape(&other) != shape(trace) {
            anyhow::bail!(
                "--again {}: not the same test as the first trace (its rows, test design or \
                 kind differ)",
                path.display()
            );
        }
        let measured = other.measured(&record.params)?;
        let id = identify_for(&measured, record, seed, progress_wanted(json))?;
        let domain = id.domain(&other.domain_monitor(&record.params), &record.domain);
        tests.add(&id.health_record(0, domain));
    }
    Ok(Some(Repeated { called_for, tests }))
}

/// What would bring a flight's reading named `outside` within: for its friction deviation,
/// the windows that, adding as these did (their own part of σ ∝ 1/√n, the held values'
/// part staying), reach the limit, or that none can; for disagreeing windows, not more of
/// them.
fn more_windows(f: &shared::fusion::FlightReading) -> String {
    use shared::fusion::{CALIBRATED_WINDOWS, CRUISE_LENGTH, FLIGHT_MAX_FRICTION_STD};
    use shared::window::WindowReason;
    match f.verdict {
        Err(WindowReason::TurbulenceTooHigh { friction_std }) if friction_std.is_finite() => {
            match f.windows_to_reach(FLIGHT_MAX_FRICTION_STD) {
                Some(needed) if needed <= CRUISE_LENGTH.most => format!(
                    "its friction σ {friction_std:.3} is above {FLIGHT_MAX_FRICTION_STD}; \
                     windows adding as these did would reach it at {needed} (in cruise the \
                     rule flies up to {} while only the friction keeps the reading out; \
                     climb and approach fly {CALIBRATED_WINDOWS} — docs/in-flight.md)",
                    CRUISE_LENGTH.most
                ),
                Some(needed) => format!(
                    "its friction σ {friction_std:.3} is above {FLIGHT_MAX_FRICTION_STD}; \
                     windows adding as these did would reach it at {needed}, beyond the \
                     cruise rule's {}: this flight's friction stays unread",
                    CRUISE_LENGTH.most
                ),
                None => format!(
                    "its friction σ {friction_std:.3} is above {FLIGHT_MAX_FRICTION_STD}, and \
                     the preflight's held values alone leave σ {:.3}: no number of windows \
                     brings it within",
                    f.shared_std[0]
                ),
            }
        }
        Err(WindowReason::Unconfirmed { windows, .. }) if windows < 2 => {
            "a reading needs two windows that can be fused".to_string()
        }
        Err(WindowReason::Unconfirmed { .. }) => {
            "the windows disagree beyond their deviations: one of them is wrong, and more \
             windows do not outvote it"
                .to_string()
        }
        _ => "more windows are needed".to_string(),
    }
}

/// Identifies a window of flight (`# test: flight`; `host_sim::fdi::window`) and prints the
/// window's verdict, the faults, the fitted load and, given the truth, e_tot; with `others`
/// (further windows of the same flight, each a source name and its trace), each of them in a
/// line and the flight's reading from all of them fused (`shared::fusion`), whose verdict
/// then sets the exit status.
#[allow(clippy::too_many_arguments)]
pub(crate) fn window_report(
    actuator: &Actuator,
    trace: &host_sim::files::trace::Trace,
    source: &str,
    others: &[(String, host_sim::files::trace::Trace)],
    (held, held_line): &(shared::window::HeldComponents, String),
    seed: u64,
    truth: Option<FaultVector>,
    json: bool,
) -> Result<()> {
    use host_sim::fdi::window::WindowModel;
    use host_sim::studies::flight::{flight_record, window_reason};
    use shared::fusion::{WindowFusion, FLIGHT_MAX_FRICTION_STD};
    let record = flight_record(&actuator.record);
    let measured = trace.measured(&record.params)?;
    let start = std::time::Instant::now();
    let id = host_sim::fdi::window::identify_window(trace, &measured, &record, *held, seed)?;
    let mut fusion = WindowFusion::EMPTY;
    let mut windows = Vec::new();
    for (i, (name, window)) in std::iter::once((source, trace))
        .chain(others.iter().map(|(n, t)| (n.as_str(), t)))
        .enumerate()
    {
        let w = if i == 0 {
            id.clone()
        } else {
            let measured = window.measured(&record.params)?;
            host_sim::fdi::window::identify_window(window, &measured, &record, *held, seed)?
        };
        let fused = w.enter(&mut fusion);
        windows.push((name.to_string(), w, fused));
    }
    let flight = (!others.is_empty()).then(|| fusion.final_reading(FLIGHT_MAX_FRICTION_STD).ok());
    let seconds = start.elapsed().as_secs_f64();
    let verdict = window_reason(&id.verdict);
    let e_tot = truth.map(|t| shared::metrics::total_error(&id.faults, &t));
    // With other windows the flight's reading decides; a flight no window could be fused
    // into is outside.
    let status = match &flight {
        None => window_status(&id.verdict),
        Some(Some(f)) => window_status(&f.verdict),
        Some(None) => Err(ExitWith(EXIT_OUTSIDE_DOMAIN).into()),
    };
    if json {
        let mut obj = serde_json::json!({
            "trace": source,
            "window": true,
            "verdict": verdict,
            "reason": format!("{:?}", id.verdict),
            "faults": id.faults.as_array().to_vec(),
            "misfit": id.misfit,
            "turbulence": id.turbulence,
            "stiffness": id.load.stiffness,
            "moment": id.load.moment,
            "e_tot": e_tot,
            "seconds": seconds,
            "shorts": held_line,
            "hint": floor_hint(&id.verdict, id.pinned_reason.as_ref()),
            "model": id.model.name(),
            "pinned_misfit": id.pinned_misfit,
            "pinned_sensor_floor": id.pinned_sensor_floor,
            "pinned_verdict": id.pinned_reason.as_ref().map(|r| window_reason(&Err(*r))),
        });
        if let Some(flight) = &flight {
            obj["windows"] = windows
                .iter()
                .map(|(name, w, fused)| {
                    serde_json::json!({
                        "trace": name,
                        "verdict": window_reason(&w.verdict),
                        "faults": w.faults.as_array().to_vec(),
                        "fused": fused,
                        "model": w.model.name(),
                    })
                })
                .collect();
            obj["flight"] = flight.as_ref().map_or(serde_json::Value::Null, |f| {
                serde_json::json!({
                    "verdict": window_reason(&f.verdict),
                    "windows": f.windows,
                    "faults": f.faults.as_array().to_vec(),
                    "std": f.uncertainty.0.std.to_vec(),
                    "lower": f.uncertainty.0.lower.to_vec(),
                    "upper": f.uncertainty.0.upper.to_vec(),
                    "e_tot": truth.map(|t| shared::metrics::total_error(&f.faults, &t)),
                    "friction_held": f.friction_held,
                })
            });
        }
        println!("{obj}");
        return status;
    }
    println!(
        "window of flight: {source} ({}, GA seed {seed})",
        actuator.name
    );
    match id.verdict {
        Ok(()) => println!("verdict: within (the window identified)"),
        Err(reason) => println!(
            "verdict: outside — {verdict} ({reason:?}): the window is not identified; the \
             faults below are not a reading"
        ),
    }
    if let Some(hint) = floor_hint(&id.verdict, id.pinned_reason.as_ref()) {
        println!("  {hint}");
    }
    match (id.model, id.pinned_misfit) {
        (WindowModel::Pinned, _) => println!(
            "read with the surface pinned to its sensor (the fitted load left the window at its \
             fitness floor): start in the play under {:.1} N·m; fit {:.3e} A²·s, {:.2} % of the \
             current unexplained ({:.2} % of it the surface sensor's own error); the \
             backlash and the gain drift read, the friction held at the preflight's beside the \
             components the next line names",
            id.load.moment,
            id.fitness,
            100.0 * id.misfit,
            100.0 * id.pinned_sensor_floor.unwrap_or(0.0)
        ),
        (WindowModel::Load, pinned) => {
            println!(
                "load fitted: stiffness {:.0} N·m/rad, moment at the start {:.1} N·m; fit \
                 {:.3e} A²·s, {:.2} % of the current unexplained; the load moved beyond its \
                 spring by {:.0} % of the test's moment (RMS: turbulence, trim)",
                id.load.stiffness,
                id.load.moment,
                id.fitness,
                100.0 * id.misfit,
                100.0 * id.turbulence
            );
            if let (Some(m), Some(r)) = (pinned, id.pinned_reason) {
                println!(
                    "  with the surface pinned to its sensor: {:.2} % unexplained ({:.2} % of \
                     it the surface sensor's own error), not read either ({})",
                    100.0 * m,
                    100.0 * id.pinned_sensor_floor.unwrap_or(0.0),
                    window_reason(&Err(r))
                );
            }
        }
    }
    println!("{held_line}");
    let names = shared::fault::FAULT_NAMES;
    for (name, k) in names.iter().zip(id.faults.as_array()) {
        println!("  {name:<24} {k:.3}");
    }
    if let Some(e) = e_tot {
        println!("e_tot against the truth: {e:.2} %");
    }
    if let Some(flight) = &flight {
        println!("\nthe flight's windows:");
        for (i, (name, w, fused)) in windows.iter().enumerate() {
            println!(
                "  {}. {name}: {}{}",
                i + 1,
                window_reason(&w.verdict),
                if *fused {
                    ", fused"
                } else {
                    ", not fused (it does not fit, or shows no play)"
                }
            );
        }
        match flight {
            None => println!(
                "the flight's reading: none — no window is identified or named only for its \
                 turbulence"
            ),
            Some(f) => {
                match f.verdict {
                    Ok(()) if f.friction_held => println!(
                        "the flight's reading from {} windows: within (the friction is the \
                         preflight's, as a window read with its surface pinned held it: no \
                         window read it, or they read it too loosely for the limit)",
                        f.windows
                    ),
                    Ok(()) => println!(
                        "the flight's reading from {} windows: within (friction read to σ {:.3})",
                        f.windows, f.uncertainty.0.std[0]
                    ),
                    Err(reason) => println!(
                        "the flight's reading from {} windows: outside — {} ({reason:?}): {}; \
                         the faults below are not a reading",
                        f.windows,
                        window_reason(&f.verdict),
                        more_windows(f)
                    ),
                }
                let u = &f.uncertainty.0;
                for (j, (name, k)) in names.iter().zip(f.faults.as_array()).enumerate() {
                    println!(
                        "  {name:<24} {k:.3}  σ {:.3}  90 % [{:.3}, {:.3}]",
                        u.std[j], u.lower[j], u.upper[j]
                    );
                }
                if let Some(t) = truth {
                    println!(
                        "e_tot of the flight's reading against the truth: {:.2} %",
                        shared::metrics::total_error(&f.faults, &t)
                    );
                }
            }
        }
    }
    let runs: u32 = windows.iter().map(|(_, w, _)| w.evaluations).sum();
    println!("{runs} model runs, {seconds:.2} s");
    status
}

/// The other known cause of a window at its fitness floor: noise on the measured current,
/// told by the same flight's preflight (measured in docs/prognostics.md, "Noise").
macro_rules! noise_cause {
    () => {
        "Noise on the current puts a window here too: at the paper's 50 % I_ref noise 6 711 \
         of 6 720 windows were at this floor. The same flight's preflight then leaves a fitness \
         of about 0.06 A²·s on an actuator whose quiet test leaves under 0.005 (a large \
         multi-fault leaves up to 0.04 without noise; docs/prognostics.md)."
    };
}

/// What a window named `fitness_floor` most often means, from the campaigns, and why the
/// pinned surface did not read it when it was tried (`pinned`: a trusted preflight was
/// given); none for another verdict.
fn floor_hint(
    verdict: &Result<(), shared::window::WindowReason>,
    pinned: Option<&shared::window::WindowReason>,
) -> Option<&'static str> {
    use shared::window::WindowReason;
    if !matches!(verdict, Err(WindowReason::FitnessFloor { .. })) {
        return None;
    }
    Some(match pinned {
        Some(WindowReason::PlayUnseen { .. }) => {
            "the window's load model does not explain this current, and with its surface \
             pinned to its sensor the play's two ends fit about as well: the window cannot \
             tell a wide play from none (campaigns: a halved or doubled gain, a healthy gear \
             in moderate climb). Not a reading: the next preflight reads the backlash."
        }
        Some(_) => concat!(
            "neither the window's load model nor its surface pinned to its sensor explains \
             this current. ",
            noise_cause!(),
            " Not a reading: the next preflight reads the actuator."
        ),
        None => concat!(
            "the window's load model does not explain this current. One known cause is a \
             gear play several times nominal (docs/in-flight.md); the light \
             actuator's windows in moderate turbulence are named so too. ",
            noise_cause!(),
            " Given the same flight's preflight (--preflight), a window at this floor is read \
             again with its surface pinned to its sensor, which reads the play; without it, \
             the next preflight reads the backlash."
        ),
    })
}

/// The exit status of a window's report: outside is [`EXIT_OUTSIDE_DOMAIN`], as for a
/// preflight.
fn window_status(verdict: &Result<(), shared::window::WindowReason>) -> Result<()> {
    match verdict {
        Ok(()) => Ok(()),
        Err(_) => Err(ExitWith(EXIT_OUTSIDE_DOMAIN).into()),
    }
}
