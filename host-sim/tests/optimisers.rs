//! The optimiser comparison's solvers and bookkeeping, on a monitor-model trace (where the
//! truth is the optimum) with small caps.

use host_sim::plant::reference::{ReferenceModel, ReferenceSettings};
use host_sim::studies::campaign::TABLE_1;
use host_sim::studies::optimisers::{
    self, run_matlab_ga, MatlabGaSettings, Optimiser, RunStop, TraceSource, Trajectory,
};
use shared::command::CommandTable;
use shared::fdi::TEST_SAMPLES;
use shared::{ActuatorParams, Calibration, ChirpCommand, FaultVector, FitnessProblem};

#[test]
fn trajectory_reads_evaluations_and_budgets() {
    let t = Trajectory {
        e_tot: vec![9.0, 5.0, 5.0, 0.8, 0.8, 0.5],
        stop: RunStop::Cap,
    };
    assert_eq!(t.evaluations_to(1.0), Some(4));
    assert_eq!(t.evaluations_to(0.5), Some(6));
    assert_eq!(t.evaluations_to(0.1), None);
    assert_eq!(t.e_tot_at(1), 9.0);
    assert_eq!(t.e_tot_at(3), 5.0);
    // A solver that stopped early keeps its final error.
    assert_eq!(t.e_tot_at(1000), 0.5);
    assert_eq!(host_sim::median(&[3.0, f64::INFINITY, 1.0]), Some(3.0));
    assert_eq!(host_sim::median(&[]), None);
}

/// Runs `f` against the monitor-model trace of Table I's backlash k2 = 0.4 case.
fn with_problem(f: impl FnOnce(&FitnessProblem<'_, TEST_SAMPLES>, FaultVector)) {
    let case = &TABLE_1[4];
    let rm = ReferenceModel::new(ReferenceSettings::REFERENCE);
    let measured = optimisers::measured_for(case, 0, TraceSource::Monitor, &rm).unwrap();
    let params = ActuatorParams::REFERENCE;
    let table = Box::new(CommandTable::<TEST_SAMPLES>::new(
        ChirpCommand::PREFLIGHT,
        params.control_period,
    ));
    let problem = FitnessProblem::new(&measured, params, &Calibration::REFERENCE_ACTUATOR)
        .unwrap()
        .with_command_table(&table)
        .unwrap();
    f(&problem, FaultVector::new(case.faults).unwrap());
}

#[test]
fn every_solver_improves_on_the_guess_and_is_reproducible() {
    with_problem(|problem, truth| {
        for o in Optimiser::ALL {
            let a = optimisers::run(o, problem, truth, 7, 2000);
            let b = optimisers::run(o, problem, truth, 7, 2000);
            assert_eq!(a.e_tot, b.e_tot, "{o:?} is not reproducible");
            if o == Optimiser::Flown {
                // Its own bound: the GA's budget, then the polish (a sum counts nine).
                let bound = shared::GaSettings::FDI.max_evaluations as usize
                    + shared::polish::PolishSettings::FDI.max_evaluations() as usize
                    + 9 * shared::polish::PolishSettings::FDI.max_curvatures() as usize;
                assert!(a.e_tot.len() <= bound.min(2000), "{}", a.e_tot.len());
                assert_ne!(a.stop, RunStop::Cap, "the flown solver ends before 2 000");
            } else {
                assert_eq!(a.e_tot.len(), 2000, "{o:?} did not use its budget");
                assert_eq!(a.stop, RunStop::Cap);
            }
            // The first evaluation is the nominal guess: e_tot of "no fault" against k2 = 0.4.
            let guess = a.e_tot[0];
            assert!((guess - 40.0 / 8f32.sqrt()).abs() < 0.01, "{o:?}: {guess}");
            let last = *a.e_tot.last().unwrap();
            // Every solver finds a vector the fitness prefers to the guess (the best-so-far
            // moved). Ours and the two written here also halve the error within 2 000
            // evaluations; the third-party peers are held to no accuracy (PSO does not get
            // there: a finding of the comparison, reported in BENCHMARKS.md).
            assert_ne!(last, guess, "{o:?} never beat the guess");
            if matches!(
                o,
                Optimiser::Flown
                    | Optimiser::SteadyState
                    | Optimiser::MatlabGa
                    | Optimiser::DifferentialEvolution
            ) {
                assert!(
                    last < 0.5 * guess,
                    "{o:?} did not improve: {guess} → {last}"
                );
            }
        }
    });
}

#[test]
fn generational_ga_keeps_its_elites_unevaluated_and_stops_at_its_limits() {
    with_problem(|problem, truth| {
        let settings = MatlabGaSettings {
            population: 20,
            elites: 2,
            max_generations: 3,
            ..MatlabGaSettings::PAPER
        };
        let t = run_matlab_ga(problem, truth, &settings, 3, 10_000);
        // 20 initial + 3 generations × (20 − 2 elites).
        assert_eq!(t.e_tot.len(), 20 + 3 * 18);
        assert_eq!(t.stop, RunStop::GenerationLimit);
        let stalled = MatlabGaSettings {
            population: 20,
            elites: 2,
            max_generations: 1000,
            stall_generations: 2,
            tolerance: 1e9,
            ..MatlabGaSettings::PAPER
        };
        let t = run_matlab_ga(problem, truth, &stalled, 3, 10_000);
        assert_eq!(t.stop, RunStop::Stalled);
        assert!(t.e_tot.len() < 20 + 10 * 18);
    });
}
