//! `footprint`, `bench` and `optimisers`: the FDI's cost on the host and the optimiser comparison.

use crate::cli::*;
use crate::commands::simulate::simulate_into;
use crate::commands::studies::measured_from_monitor;

pub(crate) fn footprint() {
    use core::mem::size_of;
    let ga = size_of::<OnboardGa>();
    let measured = size_of::<OnboardMeasured>();
    let model = size_of::<MonitorModel>();
    let state = size_of::<MonitorState>();
    println!("onboard GA (population {POPULATION})          {ga:>6} B");
    println!("measured current ({TEST_SAMPLES} samples)      {measured:>6} B");
    println!("monitor model settings                {model:>6} B");
    println!("monitor model running state           {state:>6} B");
    let total = ga + measured + model + state;
    println!(
        "total                                 {total:>6} B ({:.1} KiB; with the firmware's \
         preflight task, budget 32 KiB)",
        total as f64 / 1024.0
    );
}

pub(crate) fn bench(evaluations: u32, identifications: u64) -> Result<()> {
    let params = ActuatorParams::REFERENCE;
    let model = MonitorModel::new(params, &Calibration::IDENTITY);
    let truth = FaultVector::new([0.1, 0.1, 0.1, 0.05, 0.0, 0.1, 0.25, 0.4, 0.0])
        .map_err(|e| anyhow::anyhow!("bench fault vector: {e:?}"))?;
    let measured = measured_from_monitor(&model, &truth)?;
    let problem = FitnessProblem::new(&measured, params, &Calibration::IDENTITY)
        .map_err(|e| anyhow::anyhow!("fitness: {e:?}"))?;
    // Candidates spread over the fault space, as the GA would ask (eccentricity on).
    let candidates: Vec<FaultVector> = (0..16)
        .map(|i| {
            let x = i as f32 / 16.0;
            FaultVector::saturating([
                x,
                1.0 - x,
                0.5 * x,
                0.3,
                0.1,
                0.2 + 0.5 * x,
                x,
                0.3 + 0.4 * x,
                0.2 * x,
            ])
        })
        .collect();
    let steps = model.test_samples();
    let mut buffer = vec![0.0f32; steps];
    let table = Box::new(CommandTable::<TEST_SAMPLES>::new(
        ChirpCommand::PREFLIGHT,
        params.control_period,
    ));
    let tabled = problem
        .clone()
        .with_command_table(&table)
        .map_err(|e| anyhow::anyhow!("fitness: {e:?}"))?;
    let pick = |i: u32| &candidates[i as usize % candidates.len()];
    let per_evaluation = |f: &mut dyn FnMut(u32)| {
        let start = Instant::now();
        for i in 0..evaluations {
            f(i);
        }
        start.elapsed().as_secs_f64() / f64::from(evaluations)
    };
    let mm_chirp =
        per_evaluation(&mut |i| simulate_into(&model, pick(i), &model.sampler(), &mut buffer));
    let mm_table = per_evaluation(&mut |i| simulate_into(&model, pick(i), &*table, &mut buffer));
    let mut sink = 0.0f32;
    let fit_chirp = per_evaluation(&mut |i| sink += problem.error(pick(i)));
    let fit_table = per_evaluation(&mut |i| sink += tabled.error(pick(i)));
    std::hint::black_box(sink);
    println!(
        "one evaluation, {steps} steps (0.5 s), one core, mean of {evaluations} (target ≤ 100 µs):"
    );
    for (what, seconds) in [
        ("monitor model, chirp at each step (firmware)", mm_chirp),
        ("monitor model, command table (host)", mm_table),
        ("fitness eq. (3), chirp at each step (firmware)", fit_chirp),
        ("fitness eq. (3), command table (host)", fit_table),
    ] {
        println!(
            "  {what:<48} {:>7.1} µs  {:>5.1} ns/step",
            seconds * 1e6,
            seconds * 1e9 / steps as f64
        );
    }
    let rm = ReferenceModel::new(ReferenceSettings::REFERENCE);
    let runs = 5;
    let start = Instant::now();
    for seed in 0..runs {
        let sim = rm.simulate(&Scenario {
            faults: truth,
            current_ref_noise: 0.0,
            seed,
        });
        std::hint::black_box(&sim);
    }
    let rm_seconds = start.elapsed().as_secs_f64() / runs as f64;
    println!(
        "reference model, 0.5 s test ({} steps of {} µs): {rm_seconds:.3} s/run (mean of {runs}; target ≤ 1 s)",
        (f64::from(rm.settings().params.control_period) / rm.settings().step).round() as usize
            * rm.test_samples(),
        rm.settings().step * 1e6
    );
    bench_speedups(&rm)?;
    if identifications > 0 {
        bench_identifications(&rm, identifications)?;
    }
    Ok(())
}

/// The same identification four ways: command evaluated or tabled, every candidate evaluated
/// in full or stopped at the GA's acceptance bound. All four must give the same bits.
pub(crate) fn bench_speedups(rm: &ReferenceModel) -> Result<()> {
    struct Exact<'p, 'a>(&'p FitnessProblem<'a, TEST_SAMPLES>);
    impl shared::Problem for Exact<'_, '_> {
        fn fitness(&mut self, genes: &[f32; FAULT_COUNT]) -> f32 {
            self.0.error(&FaultVector::saturating(*genes))
        }
    }
    let case = &TABLE_1[1];
    let truth = FaultVector::new(case.faults).map_err(|e| anyhow::anyhow!("{e:?}"))?;
    let params = ActuatorParams::REFERENCE;
    let calibration = Calibration::REFERENCE_ACTUATOR;
    let measured = rm
        .simulate(&Scenario {
            faults: truth,
            current_ref_noise: 0.0,
            seed: 0,
        })
        .trace
        .measured(&params)?;
    let table = Box::new(CommandTable::<TEST_SAMPLES>::new(
        ChirpCommand::PREFLIGHT,
        params.control_period,
    ));
    let chirp = FitnessProblem::new(&measured, params, &calibration)
        .map_err(|e| anyhow::anyhow!("fitness: {e:?}"))?;
    let tabled = chirp
        .clone()
        .with_command_table(&table)
        .map_err(|e| anyhow::anyhow!("fitness: {e:?}"))?;
    println!();
    println!(
        "one identification of {} (RM seed 0, GA seed 1), median of 3 on one core:",
        case.name
    );
    let mut reference: Option<SteadyStateGa<POPULATION>> = None;
    let mut differ = false;
    for (what, problem, bounded) in [
        ("chirp at each step, every candidate in full", &chirp, false),
        ("command table, every candidate in full", &tabled, false),
        ("chirp at each step, bounded (firmware)", &chirp, true),
        ("command table, bounded (host)", &tabled, true),
    ] {
        let mut seconds = Vec::new();
        let fresh = || {
            SteadyStateGa::<POPULATION>::new(GaSettings::FDI, 1)
                .map_err(|e| anyhow::anyhow!("{e:?}"))
        };
        let mut last = None;
        for _ in 0..3 {
            let mut ga = fresh()?;
            let start = Instant::now();
            if bounded {
                ga.run(&mut problem.clone());
            } else {
                ga.run(&mut Exact(problem));
            }
            seconds.push(start.elapsed().as_secs_f64());
            last = Some(ga);
        }
        let ga = last.ok_or_else(|| anyhow::anyhow!("no identification ran"))?;
        let same = match &reference {
            None => {
                reference = Some(ga.clone());
                "reference"
            }
            Some(r) if *r == ga => "same bits",
            Some(_) => {
                differ = true;
                "DIFFERENT BITS"
            }
        };
        println!(
            "  {what:<46} {:>6.3} s  {:>5} evaluations  {same}",
            median(&seconds).unwrap_or(f64::NAN),
            ga.evaluations()
        );
    }
    if differ {
        anyhow::bail!("the speed-ups changed the identification's bits");
    }
    Ok(())
}

/// The paper's time for one identification [s] (MATLAB, 4-core i5-3340, parallel GA).
pub(crate) const PAPER_IDENTIFICATION_SECONDS: f64 = 400.0;

/// Times full identifications of every Table I case, one at a time on this thread.
pub(crate) fn bench_identifications(rm: &ReferenceModel, seeds: u64) -> Result<()> {
    let total = seeds * TABLE_1.len() as u64;
    let bar = host_sim::progress_bar(total, "identifications {bar:40} {pos}/{len} {msg}", true);
    println!();
    println!(
        "one full identification on one core (command table + GA, the RM simulation not counted; median of {seeds} RM seeds per Table I case)"
    );
    println!(
        "{:<24} {:>10} {:>12} {:>10} {:>12}",
        "case", "median [s]", "evaluations", "e_tot [%]", "× faster"
    );
    let mut all = Vec::new();
    for case in &TABLE_1 {
        bar.set_message(case.name);
        let mut seconds = Vec::new();
        let mut evaluations = Vec::new();
        let mut errors = Vec::new();
        for run in 0..seeds {
            let r = run_once(rm, &ActuatorRecord::REFERENCE, case, run)?;
            seconds.push(r.seconds);
            evaluations.push(f64::from(r.evaluations));
            errors.push(r.e_tot);
            bar.inc(1);
        }
        all.extend_from_slice(&seconds);
        let s = median(&seconds).unwrap_or(f64::NAN);
        bar.suspend(|| {
            println!(
                "{:<24} {s:>10.3} {:>12.0} {:>10.2} {:>12.0}",
                case.name,
                median(&evaluations).unwrap_or(f64::NAN),
                median(&errors).unwrap_or(f64::NAN),
                PAPER_IDENTIFICATION_SECONDS / s
            )
        });
    }
    bar.finish_and_clear();
    let s = median(&all).unwrap_or(f64::NAN);
    println!(
        "all {} identifications: median {s:.3} s, {:.0}× faster than the paper's {PAPER_IDENTIFICATION_SECONDS:.0} s (target ≤ 1 s, ≥ 400×)",
        all.len(),
        PAPER_IDENTIFICATION_SECONDS / s
    );
    Ok(())
}

pub(crate) fn optimisers_command(
    seeds: u64,
    cap: u64,
    source: SourceArg,
    target: f32,
    out: Option<&Path>,
    plot: Option<&Path>,
) -> Result<()> {
    if !(target.is_finite() && target > 0.0) {
        anyhow::bail!("--target must be a positive e_tot in percent, got {target}");
    }
    let source = match source {
        SourceArg::Reference => TraceSource::Reference,
        SourceArg::Monitor => TraceSource::Monitor,
    };
    let cap = usize::try_from(cap)?;
    let started = Instant::now();
    let solvers = optimisers::compare(&TABLE_1, seeds, cap, source, progress_wanted(false))?;
    let md = optimisers::markdown(&solvers, target, cap, source);
    report_study(&md, started, out)?;
    if let Some(path) = plot {
        let curves: Vec<(&str, Vec<f64>)> = solvers
            .iter()
            .map(|s| (s.optimiser.name(), optimisers::median_curve(s, cap)))
            .collect();
        plot::optimisers_svg(
            path,
            &curves,
            f64::from(target),
            &format!(
                "Optimisers on {} (median over {} runs)",
                source.name(),
                solvers.first().map_or(0, |s| s.runs.len())
            ),
        )?;
        println!("plot: {}", path.display());
    }
    Ok(())
}

/// `stopping`: the stall rules replayed on recorded campaign runs (docs/stopping.md).
pub(crate) fn stopping_command(actuator: &Actuator, seeds: u64, out: Option<&Path>) -> Result<()> {
    use host_sim::studies::campaign::{untuned_random_cases, HEALTHY, TABLE_2};
    use host_sim::studies::stopping;
    let record = actuator.record;
    actuator.calibration_for(&record.test)?;
    let rm = ReferenceModel::new(actuator.reference_settings()?).with_test(record.test);
    let mut cases: Vec<(&'static str, host_sim::studies::campaign::Case)> =
        TABLE_1.iter().map(|&c| ("Table I", c)).collect();
    cases.extend(TABLE_2.iter().map(|&c| ("Table II", c)));
    cases.push(("healthy", HEALTHY));
    cases.extend(untuned_random_cases(8).into_iter().map(|c| ("random", c)));
    let started = Instant::now();
    let runs = stopping::record_runs(&cases, seeds, &record, &rm, progress_wanted(false))?;
    let summaries: Vec<_> = stopping::candidate_rules()
        .into_iter()
        .map(|rule| stopping::summarise(rule, &runs))
        .collect();
    let md = stopping::markdown(&summaries, runs.len(), seeds);
    report_study(&md, started, out)
}

/// A study's Markdown on stdout with its wall time, and into `out` if given.
fn report_study(md: &str, started: Instant, out: Option<&Path>) -> Result<()> {
    println!("{md}");
    println!(
        "({:.0} s wall on {} threads)",
        started.elapsed().as_secs_f64(),
        rayon::current_num_threads()
    );
    if let Some(path) = out {
        std::fs::write(path, md).with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(())
}
