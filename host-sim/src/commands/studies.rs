//! `identifiability`, `separability` and `inverse`: what one test can tell apart, and the FDI checked on traces the monitor model made.

use crate::cli::*;

pub(crate) fn measured_from_monitor(
    model: &MonitorModel,
    truth: &FaultVector,
) -> Result<Box<OnboardMeasured>> {
    let filter = LowPass::for_control_period(model.params().control_period)
        .map_err(|e| anyhow::anyhow!("conditioning filter: {e:?}"))?;
    // The product's default test (the standstill segment, then the chirp).
    let mut measured = Box::new(OnboardMeasured::for_test(filter, PreflightTest::STANDSTILL));
    record_monitor_trace(model, truth, &mut measured)
        .map_err(|e| anyhow::anyhow!("recording the trace: {e:?}"))?;
    Ok(measured)
}

pub(crate) fn mismatch_bias_command(
    designs: &[host_sim::studies::identifiability::Design],
    weights: &[f64],
    seeds: u64,
    step: f32,
    out: Option<&Path>,
) -> Result<()> {
    use host_sim::studies::campaign::{random_cases, TABLE_2};
    use host_sim::studies::identifiability::{mismatch_bias, Design};
    use std::fmt::Write;
    let designs = if designs.is_empty() {
        vec![Design::Paper, Design::Standstill]
    } else {
        designs.to_vec()
    };
    let mut variants = Vec::new();
    for d in designs {
        match d {
            Design::Paper => variants.push((d, 0.0)),
            Design::Standstill => variants.extend(weights.iter().map(|&w| (d, w))),
            other => anyhow::bail!(
                "the monitor model does not play design {other:?}: --bias takes paper, standstill"
            ),
        }
    }
    let cases: Vec<(&'static str, FaultVector)> = TABLE_1
        .iter()
        .chain(TABLE_2.iter())
        .chain(random_cases(6).iter())
        .filter(|c| c.noise == 0.0)
        .map(|c| (c.name, FaultVector::saturating(c.faults)))
        .collect();
    let bar = host_sim::progress_bar(
        (cases.len() * variants.len()) as u64,
        "{elapsed_precise} [{bar:40}] {pos}/{len} cases {msg}",
        std::io::stderr().is_terminal(),
    );
    let mut text = format!(
        "Reference actuator as calibrated, {seeds} seeds, step {step}: predicted \
         identification error k_found − k_true (in % of the range) from the monitor model's \
         structural mismatch alone.\n"
    );
    for (design, weight) in variants {
        let _ = write!(
        text,
        "\n### {}{}\n\n\
         | case | mismatch RMS (%) | k1 | k2 | k3 | k4 | k5 | k6 | k7 | k8 | predicted e_tot (%) |\n\
         | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n",
        design.label(),
        if design == Design::Standstill { format!(", standstill weight {weight}") } else { String::new() }
    );
        for &(name, k) in &cases {
            bar.set_message(name);
            let b = mismatch_bias(name, &k, design.test(), weight, seeds, step)?;
            let cells: Vec<String> = b
                .bias
                .iter()
                .map(|x| x.map_or("—".into(), |v| format!("{:+.2}", 100.0 * v)))
                .collect();
            let _ = writeln!(
                text,
                "| {name} | {:.2} | {} | {:.2} |",
                b.mismatch_rms,
                cells.join(" | "),
                b.e_tot(&k)
            );
            bar.inc(1);
        }
    }
    bar.finish_and_clear();
    print!("{text}");
    if let Some(path) = out {
        std::fs::write(path, &text).with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(())
}

pub(crate) fn identifiability_command(
    designs: &[host_sim::studies::identifiability::Design],
    seeds: u64,
    step: f32,
    anti_alias_hz: f64,
    noise: f64,
    out: Option<&Path>,
) -> Result<()> {
    use host_sim::studies::identifiability::{markdown, points, study, Design};
    let designs = if designs.is_empty() {
        Design::ALL.to_vec()
    } else {
        designs.to_vec()
    };
    let jobs: Vec<_> = designs
        .iter()
        .flat_map(|&d| points().map(|(name, k)| (d, name, k)))
        .collect();
    let bar = host_sim::progress_bar(
        jobs.len() as u64,
        "{elapsed_precise} [{bar:40}] {pos}/{len} design × point {msg}",
        std::io::stderr().is_terminal(),
    );
    let mut studies = Vec::new();
    for (design, name, k) in jobs {
        bar.set_message(format!("{design:?} @ {name}"));
        studies.push(study(design, name, &k, seeds, step, anti_alias_hz, noise)?);
        bar.inc(1);
    }
    bar.finish_and_clear();
    let text = markdown(&studies, seeds, step, anti_alias_hz, noise);
    print!("{text}");
    if let Some(path) = out {
        std::fs::write(path, &text).with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(())
}

pub(crate) fn day_study_command(seeds: u64, step: f32, out: Option<&Path>) -> Result<()> {
    use host_sim::studies::identifiability::{day_markdown, day_nuisances, day_study, points};
    let points = points();
    let bar = host_sim::progress_bar(
        (day_nuisances().len() * points.len()) as u64,
        "{elapsed_precise} [{bar:40}] {pos}/{len} nuisance × point {msg}",
        std::io::stderr().is_terminal(),
    );
    let rows = day_study(PreflightTest::INJECTION, &points, seeds, step, |what| {
        bar.set_message(what.to_string());
        bar.inc(1);
    })?;
    bar.finish_and_clear();
    let text = day_markdown(&rows, &points, seeds);
    print!("{text}");
    if let Some(path) = out {
        std::fs::write(path, &text).with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(())
}

pub(crate) fn grease_study_command(
    actuator: &Actuator,
    seeds: u64,
    out: Option<&Path>,
) -> Result<()> {
    use host_sim::studies::grease::{grease_markdown, grease_study, Bench};
    let bench = Bench {
        settings: actuator.reference_settings()?,
        test: actuator.record.test,
    };
    let bar = host_sim::progress_bar(
        62,
        "{elapsed_precise} [{bar:40}] {pos}/{len} rows {msg}",
        std::io::stderr().is_terminal(),
    );
    let rows = grease_study(&bench, seeds, |what| {
        bar.set_message(what.to_string());
        bar.inc(1);
    })?;
    bar.finish_and_clear();
    let text = grease_markdown(&actuator.name, &rows, seeds);
    print!("{text}");
    if let Some(path) = out {
        std::fs::write(path, &text).with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(())
}

/// The bench the magnet studies run `actuator` on (its reference settings and test) and its
/// record for that test.
fn magnet_bench(actuator: &Actuator) -> Result<(host_sim::studies::grease::Bench, ActuatorRecord)> {
    let test = actuator.record.test;
    let bench = host_sim::studies::grease::Bench {
        settings: actuator.reference_settings()?,
        test,
    };
    Ok((bench, actuator.record_for(&test)?))
}

/// Runs `study` with a progress bar over `cases` cases, told each case as it starts.
fn with_case_bar<T>(
    cases: usize,
    study: impl FnOnce(&mut dyn FnMut(&str)) -> Result<T>,
) -> Result<T> {
    let bar = host_sim::progress_bar(
        cases as u64,
        "{elapsed_precise} [{bar:40}] {pos}/{len} cases {msg}",
        std::io::stderr().is_terminal(),
    );
    let out = study(&mut |what: &str| {
        bar.set_message(what.to_string());
        bar.inc(1);
    });
    bar.finish_and_clear();
    out
}

pub(crate) fn demagnetization_study_command(
    actuator: &Actuator,
    seeds: u64,
    out: Option<&Path>,
) -> Result<()> {
    use host_sim::studies::demagnetization::{
        demagnetization_markdown, demagnetization_study, CASES,
    };
    let (bench, record) = magnet_bench(actuator)?;
    let rows = with_case_bar(CASES.len(), |progress| {
        demagnetization_study(&bench, &record, seeds, progress)
    })?;
    let cosines = host_sim::studies::demagnetization::flux_cosines(&record);
    let mut text = demagnetization_markdown(&actuator.name, &rows, &cosines, seeds);
    let poles = 2 * bench.settings.params.pole_pairs as u32;
    text.push_str(
        "\nOn the reference model (noise-free truth), one magnet at 10 % loss against a \
         small eccentricity (k6 0.1) at 36 phases: the largest cosine between their currents' \
         changes, at which phase, and the rotor's travel over the test \
         (`weak_magnet_against_eccentricity`):\n\n\
         | weak pole | largest cosine | at phase (k7) | rotor travel [rev] |\n\
         | ---: | ---: | ---: | ---: |\n",
    );
    for pole in [0, poles / 2 - 1, poles - 1] {
        let (cos, phase, travel) =
            host_sim::studies::demagnetization::weak_magnet_against_eccentricity(&bench, pole, 36);
        text.push_str(&format!(
            "| {pole} | {cos:+.3} | {phase:.3} | {travel:.2} |\n"
        ));
    }
    print!("{text}");
    if let Some(path) = out {
        std::fs::write(path, &text).with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(())
}

pub(crate) fn weak_magnet_study_command(
    actuator: &Actuator,
    seeds: u64,
    out: Option<&Path>,
) -> Result<()> {
    use host_sim::studies::weak_magnet::{weak_magnet_markdown, weak_magnet_study, CASES};
    let (bench, record) = magnet_bench(actuator)?;
    let rows = with_case_bar(CASES.len(), |progress| {
        weak_magnet_study(&bench, &record, seeds, progress)
    })?;
    let text = weak_magnet_markdown(&actuator.name, &rows, seeds);
    print!("{text}");
    if let Some(path) = out {
        std::fs::write(path, &text).with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(())
}

pub(crate) fn separability_command(a: &FaultVector, b: &FaultVector, seeds: u64) -> Result<()> {
    let s = host_sim::studies::separability::separability(a, b, seeds)?;
    println!("A: {:?}", a.as_array());
    println!("B: {:?}", b.as_array());
    println!(
        "signature A vs B      {:6.3} % of the signal RMS ({seeds} seeds each)",
        s.signature
    );
    println!("one test's scatter    {:6.3} %", s.test_scatter);
    println!(
        "(mean-vs-mean noise   {:6.3} %, removed from the signature)",
        s.mean_noise
    );
    let verdict = if s.signature >= 2.0 * s.test_scatter {
        "separable in one test"
    } else if s.signature >= 0.5 * s.test_scatter {
        "marginal: the signature is comparable to one test's scatter"
    } else {
        "not separable in one test: the signature is buried in one test's scatter"
    };
    println!("{verdict}");
    Ok(())
}

pub(crate) fn inverse(truth: FaultVector, seed: u64, json: bool) -> Result<()> {
    let params = ActuatorParams::REFERENCE;
    let calibration = Calibration::IDENTITY;
    let model = MonitorModel::new(params, &calibration);
    let measured = measured_from_monitor(&model, &truth)?;
    let mut id = Identification::<TEST_SAMPLES, POPULATION>::new(
        &measured,
        params,
        &calibration,
        GaSettings::FDI,
        seed,
    )
    .map_err(|e| anyhow::anyhow!("setting up the identification: {e:?}"))?;
    let start = Instant::now();
    let result = id.run();
    let seconds = start.elapsed().as_secs_f64();
    let errors = component_errors(&result.faults, &truth);
    let e_tot = total_error(&result.faults, &truth);
    if json {
        let list = |v: &[f32]| {
            v.iter()
                .map(|x| format!("{x}"))
                .collect::<Vec<_>>()
                .join(",")
        };
        println!(
            "{{\"faults\":[{}],\"truth\":[{}],\"fitness\":{},\"evaluations\":{},\"seconds\":{seconds:.4},\"e_tot\":{e_tot},\"stop_reason\":\"{:?}\"}}",
            list(result.faults.as_array()),
            list(truth.as_array()),
            result.fitness,
            result.evaluations,
            result.stop_reason
        );
        return Ok(());
    }
    println!(
        "{:<14} {:>8} {:>8} {:>8}",
        "fault", "true", "found", "e_i [%]"
    );
    for (i, name) in FAULT_NAMES.iter().enumerate() {
        println!(
            "{name:<14} {:>8.4} {:>8.4} {:>8.3}",
            truth.as_array()[i],
            result.faults.as_array()[i],
            errors[i]
        );
    }
    println!("e_tot        {e_tot:.4} %");
    println!("fitness      {:.4e} A²·s", result.fitness);
    println!(
        "evaluations  {} (stopped: {:?})",
        result.evaluations, result.stop_reason
    );
    println!("seconds      {seconds:.3}");
    Ok(())
}
