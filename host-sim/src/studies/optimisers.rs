//! Optimiser comparison on the FDI's own problem: the same fitness (eq. 3 against one measured
//! test, calibrated monitor model), the same genes in `[0, 1]⁸` (the eccentricity phase wraps,
//! the others reflect at the bounds), the same nominal starting guess, seven solvers:
//!
//! * [`Optimiser::Flown`] — the solver the controller flies: the GA with `GaSettings::FDI`
//!   (its budget and stall rule), then the Gauss–Newton polish (`PolishSettings::FDI`), each
//!   of the polish's sums recorded as the nine monitor-model runs it costs.
//! * [`Optimiser::SteadyState`] — ours, `GaSettings::FDI` as flown, with only the evaluation
//!   budget raised to the comparison's cap and the stall stop removed, so that its error can
//!   be read at every budget. Up to its flown budget (1 400) it takes the flown decisions.
//! * [`Optimiser::MatlabGa`] — a generational GA configured as the paper's MATLAB `ga`
//!   ([`MatlabGaSettings::PAPER`]): population 200, 10 elites, crossover fraction 0.8, rank
//!   fitness scaling, stochastic-uniform selection, scattered crossover, adaptive feasible
//!   mutation, 300 generations, stall 50 generations at tolerance 1e-12.
//! * [`Optimiser::DifferentialEvolution`] — DE/rand/1/bin (Storn & Price), 40 members,
//!   F = 0.5, CR = 0.9.
//! * Third-party peers, on the same recorder: [`Optimiser::CmaEs`] — CMA-ES (the `cmaes`
//!   crate) with IPOP restarts (population doubling at each restart); [`Optimiser::MhDe`] and [`Optimiser::MhPso`] — differential evolution and
//!   particle swarm from `metaheuristics-nature` with their default coefficients and 40
//!   members. They see the genes as a box: a candidate outside `[0, 1]` is folded back as
//!   ours are (reflect, the phase wraps) before evaluation; none of them knows the phase is
//!   circular. CMA-ES's first run starts at the nominal guess; the `metaheuristics-nature`
//!   methods take no starting point, so the guess is evaluated first and their own random
//!   population follows.
//!
//! Every evaluation is recorded: the e_tot (eq. 4) of the best candidate so far, so that the
//! evaluations to reach an error and the error at a budget come from the same run. Work: one
//! monitor-model run per evaluation, at most `cap` evaluations per run; seeded RNGs, so a run
//! is reproducible.

use anyhow::{anyhow, Result};
use rand_core::{RngCore, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use rayon::prelude::*;
use shared::command::CommandTable;
use shared::fault::CIRCULAR;
use shared::fault::FAULT_COUNT;
use shared::fdi::{record_monitor_trace, OnboardMeasured, POPULATION, TEST_SAMPLES};
use shared::fitness::CurvatureRun;
use shared::ga::{reflect_unit, wrap_unit, Genes, Problem, GENES};
use shared::metrics::total_error;
use shared::polish::{Polish, PolishAsk, PolishSettings};
use shared::{
    ActuatorParams, Calibration, ChirpCommand, FaultVector, FitnessProblem, GaSettings, LowPass,
    MonitorModel, SteadyStateGa, StopReason,
};

use crate::median;
use crate::plant::reference::{ReferenceModel, ReferenceSettings, Scenario};
use crate::studies::campaign::Case;

/// The nominal fault vector, the starting guess every solver receives.
const GUESS: Genes = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0];

/// The solvers compared.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Optimiser {
    Flown,
    SteadyState,
    MatlabGa,
    DifferentialEvolution,
    CmaEs,
    MhDe,
    MhPso,
}

impl Optimiser {
    pub const ALL: [Optimiser; 7] = [
        Optimiser::Flown,
        Optimiser::SteadyState,
        Optimiser::MatlabGa,
        Optimiser::DifferentialEvolution,
        Optimiser::CmaEs,
        Optimiser::MhDe,
        Optimiser::MhPso,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Optimiser::Flown => "flown: GA (budget 1 400, stall rule) + Gauss–Newton polish",
            Optimiser::SteadyState => "steady-state GA (ours, P = 32)",
            Optimiser::MatlabGa => "MATLAB-default GA (P = 200)",
            Optimiser::DifferentialEvolution => "DE/rand/1/bin (NP = 40)",
            Optimiser::CmaEs => "CMA-ES, IPOP restarts (cmaes crate)",
            Optimiser::MhDe => "DE (metaheuristics-nature, NP = 40)",
            Optimiser::MhPso => "PSO (metaheuristics-nature, 40 particles)",
        }
    }

    /// Short name for file columns.
    pub fn key(self) -> &'static str {
        match self {
            Optimiser::Flown => "flown",
            Optimiser::SteadyState => "steady_state_ga",
            Optimiser::MatlabGa => "matlab_ga",
            Optimiser::DifferentialEvolution => "de_rand_1_bin",
            Optimiser::CmaEs => "cmaes_ipop",
            Optimiser::MhDe => "mh_de",
            Optimiser::MhPso => "mh_pso",
        }
    }
}

/// Why a compared run stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RunStop {
    /// The comparison's evaluation cap.
    Cap,
    /// The solver's own generation limit.
    GenerationLimit,
    /// The solver's own stall test.
    Stalled,
    /// The solver's own evaluation budget (the flown solver's GA, then its polish).
    Budget,
}

/// One solver run: e_tot [%] of the best-so-far candidate after each evaluation.
#[derive(Clone, Debug)]
pub struct Trajectory {
    pub e_tot: Vec<f32>,
    pub stop: RunStop,
}

impl Trajectory {
    /// Evaluations until the best-so-far e_tot first is ≤ `target` [%].
    pub fn evaluations_to(&self, target: f32) -> Option<usize> {
        self.e_tot.iter().position(|&e| e <= target).map(|i| i + 1)
    }

    /// e_tot of the best-so-far after `budget` evaluations (its final value if the solver
    /// stopped earlier).
    pub fn e_tot_at(&self, budget: usize) -> f32 {
        match self.e_tot.get(budget.saturating_sub(1)) {
            Some(&e) => e,
            None => self.e_tot.last().copied().unwrap_or(f32::INFINITY),
        }
    }
}

/// The fitness with a record of every evaluation.
struct Recorder<'p, 'a> {
    problem: &'p FitnessProblem<'a, TEST_SAMPLES>,
    truth: FaultVector,
    best_fitness: f32,
    best_e_tot: f32,
    e_tot: Vec<f32>,
    cap: usize,
}

impl<'p, 'a> Recorder<'p, 'a> {
    fn new(problem: &'p FitnessProblem<'a, TEST_SAMPLES>, truth: FaultVector, cap: usize) -> Self {
        Self {
            problem,
            truth,
            best_fitness: f32::INFINITY,
            best_e_tot: f32::INFINITY,
            e_tot: Vec::with_capacity(cap),
            cap,
        }
    }

    fn full(&self) -> bool {
        self.e_tot.len() >= self.cap
    }

    fn record(&mut self, genes: &Genes, fitness: f32) {
        if fitness < self.best_fitness {
            self.best_fitness = fitness;
            self.best_e_tot = total_error(&FaultVector::saturating(*genes), &self.truth);
        }
        self.e_tot.push(self.best_e_tot);
    }

    /// Work that finds no candidate: `runs` monitor-model runs (a Gauss–Newton sum is nine),
    /// each recorded as an evaluation at the best so far.
    fn record_runs(&mut self, runs: usize) {
        for _ in 0..runs {
            if self.full() {
                return;
            }
            self.e_tot.push(self.best_e_tot);
        }
    }

    /// The exact fitness (`error_below` with no bound gives `error`'s bits).
    fn evaluate(&mut self, genes: &Genes) -> f32 {
        self.fitness_below(genes, f32::INFINITY)
    }
}

impl Problem for Recorder<'_, '_> {
    fn fitness(&mut self, genes: &Genes) -> f32 {
        self.evaluate(genes)
    }

    /// Our GA's bounded evaluation: a value at or above `bound` never changes the best, so
    /// the record is the same as with exact evaluations.
    fn fitness_below(&mut self, genes: &Genes, bound: f32) -> f32 {
        let f = self
            .problem
            .error_below(&FaultVector::saturating(*genes), bound);
        let f = if f.is_nan() { f32::INFINITY } else { f };
        self.record(genes, f);
        f
    }
}

/// Runs `optimiser` with `seed` for at most `cap` evaluations of `problem`, whose true faults
/// are `truth`.
pub fn run(
    optimiser: Optimiser,
    problem: &FitnessProblem<'_, TEST_SAMPLES>,
    truth: FaultVector,
    seed: u64,
    cap: usize,
) -> Trajectory {
    let mut recorder = Recorder::new(problem, truth, cap);
    let stop = match optimiser {
        Optimiser::Flown => flown(&mut recorder, seed),
        Optimiser::SteadyState => steady_state(&mut recorder, seed),
        Optimiser::MatlabGa => matlab_ga(&mut recorder, &MatlabGaSettings::PAPER, seed),
        Optimiser::DifferentialEvolution => {
            differential_evolution(&mut recorder, &DifferentialEvolutionSettings::CLASSIC, seed)
        }
        Optimiser::CmaEs => cma_es(&mut recorder, seed),
        Optimiser::MhDe => nature(&mut recorder, metaheuristics_nature::De::default(), seed),
        Optimiser::MhPso => nature(&mut recorder, metaheuristics_nature::Pso::default(), seed),
    };
    Trajectory {
        e_tot: recorder.e_tot,
        stop,
    }
}

/// The generational GA with other settings than the paper's.
pub fn run_matlab_ga(
    problem: &FitnessProblem<'_, TEST_SAMPLES>,
    truth: FaultVector,
    settings: &MatlabGaSettings,
    seed: u64,
    cap: usize,
) -> Trajectory {
    let mut recorder = Recorder::new(problem, truth, cap);
    let stop = matlab_ga(&mut recorder, settings, seed);
    Trajectory {
        e_tot: recorder.e_tot,
        stop,
    }
}

fn steady_state(recorder: &mut Recorder<'_, '_>, seed: u64) -> RunStop {
    let settings = GaSettings {
        max_evaluations: u32::try_from(recorder.cap).unwrap_or(u32::MAX),
        max_generations: u32::MAX,
        stall_generations: u32::MAX,
        ..GaSettings::FDI
    };
    let Ok(mut ga) = SteadyStateGa::<POPULATION>::new(settings, seed) else {
        return RunStop::Cap;
    };
    ga.run(recorder);
    RunStop::Cap
}

/// The flown solver as `Identification::run` runs it: the GA with `GaSettings::FDI` (its
/// budget and stall rule), then `PolishSettings::FDI`; each Gauss–Newton sum counts as the
/// nine monitor-model runs it costs.
fn flown(recorder: &mut Recorder<'_, '_>, seed: u64) -> RunStop {
    let Ok(mut ga) = SteadyStateGa::<POPULATION>::new(GaSettings::FDI, seed) else {
        return RunStop::Cap;
    };
    let reason = ga.run(recorder);
    let best = ga.best();
    let mut polish = Polish::new(
        PolishSettings::FDI,
        FaultVector::saturating(best.genes),
        best.fitness,
    );
    let mut sums = Box::new(CurvatureRun::IDLE);
    loop {
        if recorder.full() {
            return RunStop::Cap;
        }
        match polish.ask() {
            PolishAsk::Curvature(k) => {
                let c = recorder.problem.curvature_in(&mut sums, &k);
                recorder.record_runs(FAULT_COUNT + 1);
                polish.tell_curvature(&c);
            }
            PolishAsk::Fitness { k, bound } => {
                let f = recorder.fitness_below(k.as_array(), bound);
                polish.tell_fitness(f);
            }
            PolishAsk::Done { .. } => {
                return match reason {
                    StopReason::Stalled => RunStop::Stalled,
                    StopReason::GenerationLimit => RunStop::GenerationLimit,
                    StopReason::EvaluationBudget => RunStop::Budget,
                }
            }
        }
    }
}

/// The genes a box-bounded solver proposes, folded into `[0, 1]` as ours are.
fn fold(x: &[f64]) -> Genes {
    core::array::from_fn(|g| bounded(g, x.get(g).copied().unwrap_or(0.0)))
}

/// The recorded fitness as the third-party solvers take it: f64, and a large finite value
/// instead of `+∞` (CMA-ES's ranking and the crates' comparisons need finite values).
fn as_objective(f: f32) -> f64 {
    if f.is_finite() {
        f64::from(f)
    } else {
        1e30
    }
}

/// CMA-ES with IPOP restarts (Auger & Hansen 2005) on the `cmaes` crate: the first run
/// starts at the nominal guess, each restart from a uniform random point with the population
/// doubled; initial step 0.3 (the crate's other defaults, its own stop tests ending each
/// run), until `cap` evaluations.
fn cma_es(recorder: &mut Recorder<'_, '_>, seed: u64) -> RunStop {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let cap = recorder.cap;
    // The guess itself first, as with every solver here.
    recorder.evaluate(&GUESS);
    let mut population = 4 + (3.0 * (GENES as f64).ln()).floor() as usize;
    let mut restart = 0u64;
    while !recorder.full() {
        let mean: Vec<f64> = if restart == 0 {
            GUESS.iter().map(|&g| f64::from(g)).collect()
        } else {
            (0..GENES).map(|_| uniform(&mut rng)).collect()
        };
        let left = cap.saturating_sub(recorder.e_tot.len());
        let run = cmaes::CMAESOptions::new(mean, 0.3)
            .population_size(population)
            .max_function_evals(left)
            .seed(seed.wrapping_mul(1000).wrapping_add(restart))
            .build(|x: &cmaes::DVector<f64>| {
                if recorder.full() {
                    return 1e30;
                }
                as_objective(recorder.evaluate(&fold(x.as_slice())))
            });
        let Ok(mut run) = run else {
            return RunStop::Stalled;
        };
        let _ = run.run();
        population = population.saturating_mul(2);
        restart += 1;
    }
    RunStop::Cap
}

/// The fitness as `metaheuristics-nature` asks for it (`&self`): the recorder behind a
/// `RefCell`, the evaluations counted where the stop test can read them.
struct NatureProblem<'r, 'p, 'a> {
    recorder: std::cell::RefCell<&'r mut Recorder<'p, 'a>>,
    evaluations: &'r std::sync::atomic::AtomicUsize,
    bounds: [[f64; 2]; GENES],
}

impl metaheuristics_nature::Bounded for NatureProblem<'_, '_, '_> {
    fn bound(&self) -> &[[f64; 2]] {
        &self.bounds
    }
}

impl metaheuristics_nature::ObjFunc for NatureProblem<'_, '_, '_> {
    type Ys = f64;

    fn fitness(&self, xs: &[f64]) -> f64 {
        let mut recorder = self.recorder.borrow_mut();
        if recorder.full() {
            return 1e30;
        }
        let f = recorder.evaluate(&fold(xs));
        self.evaluations
            .store(recorder.e_tot.len(), std::sync::atomic::Ordering::Relaxed);
        as_objective(f)
    }
}

/// A `metaheuristics-nature` method with 40 members, seeded, until `cap` evaluations.
fn nature<A: metaheuristics_nature::AlgCfg>(
    recorder: &mut Recorder<'_, '_>,
    method: A,
    seed: u64,
) -> RunStop {
    use std::sync::atomic::{AtomicUsize, Ordering};
    let cap = recorder.cap;
    // The nominal guess first, as every solver here starts from it (these methods draw their
    // first population at random and take no starting point).
    recorder.evaluate(&GUESS);
    let evaluations = AtomicUsize::new(recorder.e_tot.len());
    let problem = NatureProblem {
        recorder: std::cell::RefCell::new(recorder),
        evaluations: &evaluations,
        bounds: [[0.0, 1.0]; GENES],
    };
    let _solved = metaheuristics_nature::Solver::build(method, problem)
        .pop_num(40)
        .seed(seed)
        .task(|_| evaluations.load(Ordering::Relaxed) >= cap)
        .solve();
    RunStop::Cap
}

/// Settings of the generational GA (MATLAB `ga` names in brackets).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MatlabGaSettings {
    /// [PopulationSize]
    pub population: usize,
    /// [EliteCount]
    pub elites: usize,
    /// [CrossoverFraction]
    pub crossover_fraction: f64,
    /// [MaxGenerations]
    pub max_generations: usize,
    /// [MaxStallGenerations]
    pub stall_generations: usize,
    /// [FunctionTolerance]
    pub tolerance: f64,
}

impl MatlabGaSettings {
    /// The paper's configuration (SPEC §6).
    pub const PAPER: Self = Self {
        population: 200,
        elites: 10,
        crossover_fraction: 0.8,
        max_generations: 300,
        stall_generations: 50,
        tolerance: 1e-12,
    };
}

fn uniform(rng: &mut Xoshiro256PlusPlus) -> f64 {
    (rng.next_u64() >> 11) as f64 * (1.0 / 9_007_199_254_740_992.0)
}

fn index(rng: &mut Xoshiro256PlusPlus, n: usize) -> usize {
    ((u128::from(rng.next_u64()) * n as u128) >> 64) as usize
}

/// `n` evaluated members: the nominal guess, then uniform in `[0, 1]⁸`. `None` if the cap is
/// reached first.
fn initial_population(
    recorder: &mut Recorder<'_, '_>,
    rng: &mut Xoshiro256PlusPlus,
    n: usize,
) -> Option<Vec<(Genes, f32)>> {
    let mut population = Vec::with_capacity(n);
    for i in 0..n {
        if recorder.full() {
            return None;
        }
        let genes = if i == 0 {
            GUESS
        } else {
            core::array::from_fn(|_| uniform(rng) as f32)
        };
        let f = recorder.evaluate(&genes);
        population.push((genes, f));
    }
    Some(population)
}

/// Keeps gene `g` of a candidate in its domain: wraps the circular gene, reflects the others.
fn bounded(g: usize, v: f64) -> f32 {
    if CIRCULAR.get(g).copied().unwrap_or(false) {
        wrap_unit(v as f32)
    } else {
        reflect_unit(v as f32)
    }
}

/// MATLAB's `ga` for a bound-constrained problem, generation by generation:
/// * rank scaling (`fitscalingrank`): expectation ∝ 1/√rank, summing to the parents needed;
/// * stochastic uniform selection (`selectionstochunif`), parents shuffled;
/// * `elites` best copied unevaluated; `round(fraction · (P − elites))` children by scattered
///   crossover (`crossoverscattered`: each gene from either parent); the rest by mutation;
/// * adaptive feasible mutation (`mutationadaptfeasible`): the step is 1 for the first two
///   generations, then ×4 (at most 1) after a generation that improved the best and ÷4 (at
///   least √ε) after one that did not; a mutant moves its parent along a random direction by
///   that step times a random length, halving the step until it is inside the bounds;
/// * stops at `max_generations`, or when the best improved by ≤ `tolerance` over the last
///   `stall_generations` generations.
fn matlab_ga(recorder: &mut Recorder<'_, '_>, s: &MatlabGaSettings, seed: u64) -> RunStop {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let n = s.population;
    let Some(mut population) = initial_population(recorder, &mut rng, n) else {
        return RunStop::Cap;
    };
    let crossover_children = (s.crossover_fraction * (n - s.elites) as f64).round() as usize;
    let mutation_children = n - s.elites - crossover_children;
    let parents_needed = 2 * crossover_children + mutation_children;
    // Rank scaling: the same expectations every generation (the population is sorted).
    let raw: Vec<f64> = (1..=n).map(|r| 1.0 / (r as f64).sqrt()).collect();
    let total: f64 = raw.iter().sum();
    let expectation: Vec<f64> = raw
        .iter()
        .map(|e| e * parents_needed as f64 / total)
        .collect();
    let mut step = 1.0f64;
    let mut best_history: Vec<f64> = Vec::new();
    for generation in 1..=s.max_generations {
        population.sort_by(|a, b| a.1.total_cmp(&b.1));
        let best = f64::from(population.first().map_or(f32::INFINITY, |p| p.1));
        // Adaptive step after the rule of mutationadaptfeasible.
        if generation > 2 {
            let improved = best_history.last().is_some_and(|&previous| best < previous);
            step = if improved {
                (step * 4.0).min(1.0)
            } else {
                (step / 4.0).max(f64::EPSILON.sqrt())
            };
        }
        best_history.push(best);
        if best_history.len() > s.stall_generations {
            let then = best_history[best_history.len() - 1 - s.stall_generations];
            if then - best <= s.tolerance {
                return RunStop::Stalled;
            }
        }
        // Stochastic uniform selection on the rank-scaled expectations.
        let mut parents = Vec::with_capacity(parents_needed);
        let mut pointer = uniform(&mut rng);
        let mut cumulative = 0.0;
        for (i, e) in expectation.iter().enumerate() {
            cumulative += e;
            while pointer < cumulative && parents.len() < parents_needed {
                parents.push(i);
                pointer += 1.0;
            }
        }
        while parents.len() < parents_needed {
            parents.push(n - 1);
        }
        for i in (1..parents.len()).rev() {
            let j = index(&mut rng, i + 1);
            parents.swap(i, j);
        }
        let mut next: Vec<(Genes, f32)> = population.iter().take(s.elites).copied().collect();
        for c in 0..crossover_children {
            let (a, b) = (
                population[parents[2 * c]].0,
                population[parents[2 * c + 1]].0,
            );
            let child: Genes =
                core::array::from_fn(|g| if rng.next_u32() & 1 == 0 { a[g] } else { b[g] });
            if recorder.full() {
                return RunStop::Cap;
            }
            let f = recorder.evaluate(&child);
            next.push((child, f));
        }
        for m in 0..mutation_children {
            let parent = population[parents[2 * crossover_children + m]].0;
            let direction: [f64; GENES] = core::array::from_fn(|_| 2.0 * uniform(&mut rng) - 1.0);
            let mut length = step * uniform(&mut rng);
            let mut child = parent;
            for _ in 0..30 {
                let inside = (0..GENES).all(|g| {
                    CIRCULAR[g]
                        || (0.0..=1.0).contains(&(f64::from(parent[g]) + length * direction[g]))
                });
                if inside {
                    child = core::array::from_fn(|g| {
                        bounded(g, f64::from(parent[g]) + length * direction[g])
                    });
                    break;
                }
                length *= 0.5;
            }
            if recorder.full() {
                return RunStop::Cap;
            }
            let f = recorder.evaluate(&child);
            next.push((child, f));
        }
        population = next;
    }
    RunStop::GenerationLimit
}

/// Settings of DE/rand/1/bin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DifferentialEvolutionSettings {
    /// Members (NP).
    pub population: usize,
    /// Differential weight F.
    pub weight: f64,
    /// Crossover probability CR.
    pub crossover: f64,
}

impl DifferentialEvolutionSettings {
    /// Storn & Price's usual choice: NP = 5·D, F = 0.5, CR = 0.9.
    pub const CLASSIC: Self = Self {
        population: 40,
        weight: 0.5,
        crossover: 0.9,
    };
}

/// DE/rand/1/bin: for each member, a mutant `x_r1 + F·(x_r2 − x_r3)` (three distinct others,
/// the circular gene's difference on the circle), binomial crossover with one gene forced,
/// bounds as the GA's; the trial replaces the member if not worse (synchronous generations).
/// Runs until the cap.
fn differential_evolution(
    recorder: &mut Recorder<'_, '_>,
    s: &DifferentialEvolutionSettings,
    seed: u64,
) -> RunStop {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let n = s.population;
    let Some(mut population) = initial_population(recorder, &mut rng, n) else {
        return RunStop::Cap;
    };
    loop {
        let mut next = population.clone();
        for i in 0..n {
            let mut pick = |taken: &[usize]| loop {
                let r = index(&mut rng, n);
                if !taken.contains(&r) {
                    return r;
                }
            };
            let r1 = pick(&[i]);
            let r2 = pick(&[i, r1]);
            let r3 = pick(&[i, r1, r2]);
            let forced = index(&mut rng, GENES);
            let (x1, x2, x3, target) = (
                population[r1].0,
                population[r2].0,
                population[r3].0,
                population[i].0,
            );
            let trial: Genes = core::array::from_fn(|g| {
                let take = g == forced || uniform(&mut rng) < s.crossover;
                if !take {
                    return target[g];
                }
                let mut d = f64::from(x2[g]) - f64::from(x3[g]);
                if CIRCULAR[g] {
                    d -= d.round();
                }
                bounded(g, f64::from(x1[g]) + s.weight * d)
            });
            if recorder.full() {
                return RunStop::Cap;
            }
            let f = recorder.evaluate(&trial);
            if f <= population[i].1 {
                next[i] = (trial, f);
            }
        }
        population = next;
    }
}

/// Where the compared traces come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TraceSource {
    /// The reference model (the "real actuator"), RM seed = run index: the real problem, whose
    /// best fit is not the truth (model mismatch and noise).
    Reference,
    /// The calibrated monitor model itself: the truth is the global optimum, so the
    /// comparison measures the solvers alone.
    Monitor,
}

impl TraceSource {
    pub fn name(self) -> &'static str {
        match self {
            TraceSource::Reference => "reference-model traces",
            TraceSource::Monitor => "monitor-model traces (truth = optimum)",
        }
    }
}

/// Every trajectory of one solver over all cases and seeds.
#[derive(Clone, Debug)]
pub struct SolverRuns {
    pub optimiser: Optimiser,
    /// (case name, seed, trajectory).
    pub runs: Vec<(&'static str, u64, Trajectory)>,
}

impl SolverRuns {
    /// Median evaluations to reach e_tot ≤ `target` (runs that never do count as `+∞`), and
    /// how many runs reached it.
    pub fn evaluations_to(&self, target: f32) -> (f64, usize) {
        let v: Vec<f64> = self
            .runs
            .iter()
            .map(|(_, _, t)| t.evaluations_to(target).map_or(f64::INFINITY, |n| n as f64))
            .collect();
        let reached = v.iter().filter(|x| x.is_finite()).count();
        (median(&v).unwrap_or(f64::INFINITY), reached)
    }

    /// Median e_tot [%] after `budget` evaluations.
    pub fn e_tot_at(&self, budget: usize) -> f64 {
        let v: Vec<f64> = self
            .runs
            .iter()
            .map(|(_, _, t)| f64::from(t.e_tot_at(budget)))
            .collect();
        median(&v).unwrap_or(f64::INFINITY)
    }
}

/// The measured test of `case`, run `run`, from `source`.
pub fn measured_for(
    case: &Case,
    run: u64,
    source: TraceSource,
    rm: &ReferenceModel,
) -> Result<Box<OnboardMeasured>> {
    let truth = FaultVector::new(case.faults).map_err(|e| anyhow!("case {}: {e:?}", case.name))?;
    let params = ActuatorParams::REFERENCE;
    match source {
        TraceSource::Reference => {
            let sim = rm.simulate(&Scenario {
                faults: truth,
                current_ref_noise: case.noise,
                seed: run,
            });
            sim.trace.measured(&params)
        }
        TraceSource::Monitor => {
            let filter = LowPass::for_control_period(params.control_period)
                .map_err(|e| anyhow!("conditioning filter: {e:?}"))?;
            let mut measured = Box::new(OnboardMeasured::new(filter));
            let model = MonitorModel::new(params, &Calibration::REFERENCE_ACTUATOR);
            record_monitor_trace(&model, &truth, &mut measured)
                .map_err(|e| anyhow!("monitor trace: {e:?}"))?;
            Ok(measured)
        }
    }
}

/// Runs every solver on every case × `seeds` (solver seed `1 + run`), in parallel, at most
/// `cap` evaluations each.
pub fn compare(
    cases: &[Case],
    seeds: u64,
    cap: usize,
    source: TraceSource,
    progress: bool,
) -> Result<Vec<SolverRuns>> {
    let rm = ReferenceModel::new(ReferenceSettings::REFERENCE);
    let jobs: Vec<(usize, u64, Optimiser)> = (0..cases.len())
        .flat_map(|c| (0..seeds).flat_map(move |r| Optimiser::ALL.map(|o| (c, r, o))))
        .collect();
    let bar = crate::progress_bar(
        jobs.len() as u64,
        "optimiser runs {bar:40} {pos}/{len}, {elapsed} elapsed, ~{eta} left",
        progress,
    );
    let results: Vec<Result<(Optimiser, &'static str, u64, Trajectory)>> = jobs
        .par_iter()
        .map(|&(c, run, optimiser)| {
            let case = &cases[c];
            let truth =
                FaultVector::new(case.faults).map_err(|e| anyhow!("case {}: {e:?}", case.name))?;
            let measured = measured_for(case, run, source, &rm)?;
            let params = ActuatorParams::REFERENCE;
            let table = Box::new(CommandTable::<TEST_SAMPLES>::new(
                ChirpCommand::PREFLIGHT,
                params.control_period,
            ));
            let problem = FitnessProblem::new(&measured, params, &Calibration::REFERENCE_ACTUATOR)
                .and_then(|p| p.with_command_table(&table))
                .map_err(|e| anyhow!("fitness: {e:?}"))?;
            let t = self::run(optimiser, &problem, truth, 1 + run, cap);
            bar.inc(1);
            Ok((optimiser, case.name, run, t))
        })
        .collect();
    bar.finish_and_clear();
    let mut out: Vec<SolverRuns> = Optimiser::ALL
        .iter()
        .map(|&optimiser| SolverRuns {
            optimiser,
            runs: Vec::new(),
        })
        .collect();
    for r in results {
        let (optimiser, name, run, t) = r?;
        if let Some(s) = out.iter_mut().find(|s| s.optimiser == optimiser) {
            s.runs.push((name, run, t));
        }
    }
    Ok(out)
}

/// Median best-so-far e_tot [%] after each evaluation, over all runs of a solver (runs that
/// stopped early keep their final value).
pub fn median_curve(solver: &SolverRuns, cap: usize) -> Vec<f64> {
    (1..=cap).map(|n| solver.e_tot_at(n)).collect()
}

/// Budgets at which the comparison reads each solver's error.
pub const BUDGETS: [usize; 4] = [500, 1_000, 3_000, 10_000];

fn evaluations_text(n: f64) -> String {
    if n.is_finite() {
        format!("{n:.0}")
    } else {
        "not reached".into()
    }
}

/// The comparison as Markdown: the summary table, the ratio to the MATLAB-default GA, and the
/// evaluations to `target` per case.
pub fn markdown(solvers: &[SolverRuns], target: f32, cap: usize, source: TraceSource) -> String {
    use std::fmt::Write as _;
    let mut md = String::new();
    let runs = solvers.first().map_or(0, |s| s.runs.len());
    let _ = writeln!(
        md,
        "Optimisers on {} — {runs} runs each (paper Table I cases × seeds), at most {cap} evaluations per run; medians over runs.\n",
        source.name()
    );
    let fine = target / 10.0;
    let _ = write!(
        md,
        "| solver | evaluations to e_tot ≤ {target} % | runs reaching it | evaluations to e_tot ≤ {fine} % | runs reaching it |"
    );
    for b in BUDGETS {
        let _ = write!(md, " e_tot @ {b} [%] |");
    }
    let _ = writeln!(md, " stops (cap / generations / stall / own budget) |");
    let _ = writeln!(
        md,
        "|---|---:|---:|---:|---:|{}---|",
        "---:|".repeat(BUDGETS.len())
    );
    for s in solvers {
        let (n, reached) = s.evaluations_to(target);
        let (n_fine, reached_fine) = s.evaluations_to(fine);
        let _ = write!(
            md,
            "| {} | {} | {reached}/{} | {} | {reached_fine}/{} |",
            s.optimiser.name(),
            evaluations_text(n),
            s.runs.len(),
            evaluations_text(n_fine),
            s.runs.len()
        );
        for b in BUDGETS {
            let _ = write!(md, " {:.2} |", s.e_tot_at(b));
        }
        let count = |stop: RunStop| s.runs.iter().filter(|r| r.2.stop == stop).count();
        let _ = writeln!(
            md,
            " {} / {} / {} / {} |",
            count(RunStop::Cap),
            count(RunStop::GenerationLimit),
            count(RunStop::Stalled),
            count(RunStop::Budget)
        );
    }
    // Ours is the flown solver; the GA alone (without its stops) is one of the compared.
    if let Some(ours) = solvers.iter().find(|s| s.optimiser == Optimiser::Flown) {
        let (a, _) = ours.evaluations_to(target);
        let _ = writeln!(
            md,
            "\nEvaluations each solver needs to reach e_tot ≤ {target} % (median), as a multiple of ours ({}):\n",
            evaluations_text(a)
        );
        for s in solvers.iter().filter(|s| s.optimiser != Optimiser::Flown) {
            let (b, _) = s.evaluations_to(target);
            let ratio = if a.is_finite() && b.is_finite() {
                format!("{:.1}×", b / a)
            } else if a.is_finite() {
                format!(
                    "not reached in the median run within {cap} (≥ {:.1}×)",
                    cap as f64 / a
                )
            } else {
                "no ratio: ours does not reach it in the median run".into()
            };
            let _ = writeln!(md, "- {}: {ratio}", s.optimiser.name());
        }
        let fewest = solvers
            .iter()
            .filter(|s| s.optimiser != Optimiser::Flown)
            .all(|s| s.evaluations_to(target).0 >= a);
        let _ = writeln!(
            md,
            "\nOurs needs the fewest evaluations of every solver compared: {}.",
            if fewest { "yes" } else { "**no**" }
        );
    }
    // Per case.
    let _ = writeln!(
        md,
        "\nMedian evaluations to e_tot ≤ {target} % per case (over seeds):\n"
    );
    let _ = write!(md, "| case |");
    for s in solvers {
        let _ = write!(md, " {} |", s.optimiser.name());
    }
    let _ = writeln!(md, "\n|---|{}", "---:|".repeat(solvers.len()));
    let mut cases: Vec<&'static str> = Vec::new();
    for (name, _, _) in solvers.first().map_or(&[][..], |s| &s.runs[..]) {
        if !cases.contains(name) {
            cases.push(name);
        }
    }
    for case in cases {
        let _ = write!(md, "| {case} |");
        for s in solvers {
            let v: Vec<f64> = s
                .runs
                .iter()
                .filter(|r| r.0 == case)
                .map(|r| {
                    r.2.evaluations_to(target)
                        .map_or(f64::INFINITY, |n| n as f64)
                })
                .collect();
            let _ = write!(
                md,
                " {} |",
                evaluations_text(median(&v).unwrap_or(f64::INFINITY))
            );
        }
        let _ = writeln!(md);
    }
    md
}
