//! Memory-bounded steady-state genetic algorithm (SPEC §6), solver half of the FDI.
//!
//! * Population of up to `P` individuals in a const-generic array (a run may use fewer,
//!   [`restart_with`](SteadyStateGa::restart_with), with the same bits as a GA of that
//!   size); no heap. State size is `size_of::<SteadyStateGa<P>>()` ≈ `36·P + 160` bytes.
//! * Genes are the [`FAULT_COUNT`] fault components in `[0, 1]`; genes flagged circular (the
//!   eccentricity phase) wrap, the others reflect at the bounds. Every operator keeps every
//!   gene in bounds.
//! * One offspring per step: two parents by tournament, BLX-α blend crossover; with some
//!   probability a differential step `F·(x_r1 − x_r2)` between two random members (it follows
//!   the correlated valleys of the fault space, e.g. friction against gain drift); then
//!   per-gene Gaussian mutation whose width follows the population's spread around the best
//!   individual (so the search narrows as the population converges) plus a floor. The
//!   offspring replaces the worst individual if it is better, so the best is never lost.
//! * Seeded [`Xoshiro128PlusPlus`]; no transcendental functions, only `+ − × ÷` on f32, so
//!   the same seed and fitness give the same bits on every IEEE-754 target.
//! * Interface: [`ask`](SteadyStateGa::ask) / [`tell`](SteadyStateGa::tell) at the core;
//!   [`step`](SteadyStateGa::step) runs at most `budget` evaluations of a [`Problem`] and
//!   returns. Stopping anywhere and resuming gives bit-identical results: the GA is plain data.
//! * A "generation" is as many offspring as the population's members. Stops ([`StopReason`]): evaluation budget, generation
//!   limit, or stall — best fitness improved by no more than `tolerance` over
//!   `stall_generations` generations.

use crate::base::random::Xoshiro128PlusPlus;
use crate::base::steps::{pause, run_to_end};

pub mod checkpoint;

pub use checkpoint::{as_version_1, record_bytes, RecordError};

use crate::physics::fault::{FaultVector, CIRCULAR, FAULT_COUNT};

/// Number of genes of an individual.
pub const GENES: usize = FAULT_COUNT;

/// A candidate solution: one value per gene, each in `[0, 1]`.
pub type Genes = [f32; GENES];

/// The objective the GA minimises. Lower is better; a non-finite value counts as `+∞`.
pub trait Problem {
    fn fitness(&mut self, genes: &Genes) -> f32;

    /// The fitness if it is below `bound`; otherwise any value `≥ bound`, as soon as that is
    /// certain. The GA passes the fitness a candidate must beat to enter the population, so a
    /// problem whose cost only grows as it is evaluated (a sum of non-negative terms) can stop
    /// early without changing a single decision of the run. Default: the exact fitness.
    fn fitness_below(&mut self, genes: &Genes, bound: f32) -> f32 {
        let _ = bound;
        self.fitness(genes)
    }
}

impl<F: FnMut(&Genes) -> f32> Problem for F {
    fn fitness(&mut self, genes: &Genes) -> f32 {
        self(genes)
    }
}

/// GA settings, split from the running state.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GaSettings {
    /// Stop after this many fitness evaluations (including the initial population).
    pub max_evaluations: u32,
    /// Stop after this many generations (of as many offspring as the population's members).
    pub max_generations: u32,
    /// Stop when the best fitness improved by no more than `tolerance` over this many
    /// generations ([`StallTest`]).
    pub stall_generations: u32,
    /// Improvement that counts as progress for the stall test (fitness units; 0 = any
    /// improvement counts).
    pub tolerance: f32,
    /// Individuals drawn per tournament (≥ 1).
    pub tournament_size: u8,
    /// BLX-α extension of the parents' interval on each side.
    pub crossover_alpha: f32,
    /// Probability that each gene of an offspring is mutated.
    pub mutation_probability: f32,
    /// Mutation standard deviation as a multiple of the population's spread in that gene.
    pub mutation_scale: f32,
    /// Mutation standard deviation added regardless of spread.
    pub mutation_floor: f32,
    /// Probability that an offspring also takes a differential step `F·(x_r1 − x_r2)` between
    /// two random members (follows correlated valleys the per-gene mutation cannot).
    pub differential_probability: f32,
    /// Scale `F` of the differential step.
    pub differential_scale: f32,
    /// Genes that wrap around (0 ≡ 1) instead of reflecting at the bounds.
    pub circular: [bool; GENES],
    /// An individual placed in the initial population (e.g. the nominal fault vector).
    pub initial_guess: Option<Genes>,
}

impl GaSettings {
    /// Settings of the onboard FDI. The stall stop ends a run once the best fitness has
    /// improved by no more than 2·10⁻⁵ A²·s over 25 generations: on the campaigns it stops
    /// after a median 1 888 evaluations (90 % by 3 392, all by 5 024) with the mean e_tot of
    /// every campaign within seed noise of the full 6 000 (`host-sim stopping`,
    /// docs/stopping.md). The budget stays as the bound on the work.
    pub const FDI: Self = Self {
        max_evaluations: 1400,
        max_generations: 300,
        stall_generations: 25,
        tolerance: 2.0e-5,
        tournament_size: 3,
        crossover_alpha: 0.3,
        mutation_probability: 0.3,
        mutation_scale: 0.5,
        mutation_floor: 2.0e-4,
        differential_probability: 0.9,
        differential_scale: 0.7,
        circular: CIRCULAR,
        initial_guess: Some(*FaultVector::NOMINAL.as_array()),
    };

    /// Whether these settings can run a population of `population` (what
    /// [`SteadyStateGa::new`] checks). O(1).
    pub fn check(&self, population: usize) -> Result<(), GaError> {
        self.validate(population)
    }

    fn validate(&self, population: usize) -> Result<(), GaError> {
        let probability_ok = (0.0..=1.0).contains(&self.mutation_probability)
            && (0.0..=1.0).contains(&self.differential_probability);
        let finite = self.crossover_alpha.is_finite()
            && self.differential_scale.is_finite()
            && self.differential_scale >= 0.0
            && self.mutation_scale.is_finite()
            && self.mutation_floor.is_finite()
            && self.tolerance.is_finite();
        let guess_ok = match &self.initial_guess {
            Some(g) => g.iter().all(|x| (0.0..=1.0).contains(x)),
            None => true,
        };
        if population < 2 {
            Err(GaError::InvalidSettings("population below 2"))
        } else if population > u16::MAX as usize {
            Err(GaError::InvalidSettings("population larger than 65535"))
        } else if self.tournament_size == 0 {
            Err(GaError::InvalidSettings("tournament size 0"))
        } else if !probability_ok
            || !finite
            || self.crossover_alpha < 0.0
            || self.mutation_scale < 0.0
            || self.mutation_floor < 0.0
            || self.tolerance < 0.0
        {
            Err(GaError::InvalidSettings("rate or width out of range"))
        } else if !guess_ok {
            Err(GaError::InvalidSettings("guess outside [0, 1]"))
        } else {
            Ok(())
        }
    }
}

impl Default for GaSettings {
    fn default() -> Self {
        Self::FDI
    }
}

/// Why a run stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StopReason {
    /// `max_evaluations` reached.
    EvaluationBudget,
    /// `max_generations` reached.
    GenerationLimit,
    /// No improvement beyond `tolerance` for `stall_generations` generations.
    Stalled,
}

/// Where a run stands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Status {
    Running,
    Done(StopReason),
}

/// Misuse of the ask/tell interface or bad settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GaError {
    InvalidSettings(&'static str),
    /// The run is over; nothing more to ask.
    Finished(StopReason),
    /// `tell` without a candidate from `ask`.
    NothingPending,
}

/// One member of the population.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Individual {
    pub genes: Genes,
    /// Fitness (lower is better); `+∞` for not yet evaluated.
    pub fitness: f32,
}

impl Individual {
    const UNEVALUATED: Self = Self {
        genes: [0.0; GENES],
        fitness: f32::INFINITY,
    };
}

/// The steady-state GA (module docs). Plain data: clone it to checkpoint.
#[derive(Clone, Debug, PartialEq)]
pub struct SteadyStateGa<const P: usize> {
    settings: GaSettings,
    rng: Xoshiro128PlusPlus,
    population: [Individual; P],
    /// Members in play: the first `members` of `population` (`P` unless
    /// [`restart_with`](SteadyStateGa::restart_with) set fewer).
    members: u16,
    /// Members of the initial population evaluated so far (`members` once it is complete).
    filled: u16,
    pending: Option<Genes>,
    evaluations: u32,
    generations: u32,
    best: Individual,
    stall: StallTest,
    status: Status,
}

impl<const P: usize> SteadyStateGa<P> {
    /// A run that has not started (done, asks nothing): the place a controller's task keeps
    /// for one, started in place by [`restart`](Self::restart).
    pub const IDLE: Self = Self {
        settings: GaSettings::FDI,
        rng: Xoshiro128PlusPlus::IDLE,
        population: [Individual::UNEVALUATED; P],
        members: if P > u16::MAX as usize {
            u16::MAX
        } else {
            P as u16
        },
        filled: 0,
        pending: None,
        evaluations: 0,
        generations: 0,
        best: Individual::UNEVALUATED,
        stall: StallTest::NEW,
        status: Status::Done(StopReason::EvaluationBudget),
    };

    /// Starts a fresh run in place, with the given settings and seed: the same run as
    /// [`new`](Self::new), without building a second GA to move (≈ 1.5 kB). O(P).
    pub fn restart(&mut self, settings: GaSettings, seed: u64) -> Result<(), GaError> {
        self.restart_with(settings, seed, P)
    }

    /// [`restart`](Self::restart) with a population of `members` (≤ `P`, the capacity): the
    /// same bits as a `SteadyStateGa<members>`, so that runs of several sizes share one
    /// compiled GA. Such a run is not checkpointed ([`save`](Self::save) holds all `P`).
    /// O(P).
    pub fn restart_with(
        &mut self,
        settings: GaSettings,
        seed: u64,
        members: usize,
    ) -> Result<(), GaError> {
        settings.validate(members)?;
        if members > P {
            return Err(GaError::InvalidSettings(
                "population above the GA's capacity",
            ));
        }
        self.members = members as u16;
        self.settings = settings;
        self.rng = Xoshiro128PlusPlus::seed_from_u64(seed);
        for member in &mut self.population {
            *member = Individual::UNEVALUATED;
        }
        self.filled = 0;
        self.pending = None;
        self.evaluations = 0;
        self.generations = 0;
        self.best = Individual::UNEVALUATED;
        self.stall = StallTest::NEW;
        self.status = Status::Running;
        Ok(())
    }

    /// A fresh run with the given settings and seed.
    pub fn new(settings: GaSettings, seed: u64) -> Result<Self, GaError> {
        let mut ga = Self::IDLE;
        ga.restart(settings, seed)?;
        Ok(ga)
    }

    pub fn settings(&self) -> &GaSettings {
        &self.settings
    }
    pub fn status(&self) -> Status {
        self.status
    }
    /// Fitness evaluations told so far.
    pub fn evaluations(&self) -> u32 {
        self.evaluations
    }
    /// Members in play (`P` unless [`restart_with`](Self::restart_with) set fewer).
    pub fn members(&self) -> usize {
        usize::from(self.members)
    }
    /// Completed generations (of [`members`](Self::members) offspring after the initial
    /// population).
    pub fn generations(&self) -> u32 {
        self.generations
    }
    /// Best individual ever evaluated (`fitness = +∞` before the first `tell`).
    pub fn best(&self) -> &Individual {
        &self.best
    }
    /// The population in play (members not yet evaluated have `fitness = +∞`).
    pub fn population(&self) -> &[Individual] {
        self.population.get(..self.members()).unwrap_or(&[])
    }

    /// The next candidate to evaluate. Asking again before `tell` returns the same candidate,
    /// so an interrupted evaluation is simply asked for again.
    pub fn ask(&mut self) -> Result<Genes, GaError> {
        run_to_end(self.ask_stepwise())
    }

    /// [`ask`](Self::ask) in steps, for a controller's idle time: breeding an offspring
    /// pauses after every [`SPREAD_MEMBERS_PER_POLL`] members of the population's spread,
    /// and the breeding itself is a poll of its own.
    /// The same candidate.
    pub async fn ask_stepwise(&mut self) -> Result<Genes, GaError> {
        if let Status::Done(reason) = self.status {
            return Err(GaError::Finished(reason));
        }
        if let Some(genes) = self.pending {
            return Ok(genes);
        }
        let genes = if self.filled < self.members {
            match (self.filled, self.settings.initial_guess) {
                (0, Some(guess)) => guess,
                _ => core::array::from_fn(|_| self.uniform()),
            }
        } else {
            let spread = self.spread_stepwise().await;
            pause().await;
            self.offspring(&spread)
        };
        self.pending = Some(genes);
        Ok(genes)
    }

    /// Reports the fitness of the pending candidate. Returns the run's status afterwards.
    pub fn tell(&mut self, fitness: f32) -> Result<Status, GaError> {
        if let Status::Done(reason) = self.status {
            return Err(GaError::Finished(reason));
        }
        let genes = self.pending.take().ok_or(GaError::NothingPending)?;
        let fitness = if fitness.is_nan() {
            f32::INFINITY
        } else {
            fitness
        };
        let child = Individual { genes, fitness };
        self.evaluations = self.evaluations.saturating_add(1);

        if self.filled < self.members {
            if let Some(slot) = self.population.get_mut(usize::from(self.filled)) {
                *slot = child;
            }
            self.filled += 1;
        } else if let Some(worst) = self.worst_mut() {
            if child.fitness < worst.fitness {
                *worst = child;
            }
        }
        if child.fitness < self.best.fitness {
            self.best = child;
        }

        self.update_status();
        Ok(self.status)
    }

    /// Runs at most `budget` evaluations of `problem`, then returns the status. Bounded work:
    /// `budget` fitness calls plus O(`budget · P`) bookkeeping.
    pub fn step(&mut self, problem: &mut impl Problem, budget: u32) -> Status {
        for _ in 0..budget {
            let genes = match self.ask() {
                Ok(g) => g,
                Err(_) => break,
            };
            let fitness = problem.fitness_below(&genes, self.acceptance_bound());
            if let Ok(Status::Done(_)) | Err(_) = self.tell(fitness) {
                break;
            }
        }
        self.status
    }

    /// Runs until the GA stops (the settings bound the work).
    pub fn run(&mut self, problem: &mut impl Problem) -> StopReason {
        loop {
            if let Status::Done(reason) = self.step(problem, u32::MAX) {
                return reason;
            }
        }
    }

    fn update_status(&mut self) {
        let s = &self.settings;
        let members = u32::from(self.members);
        let offspring = self.evaluations.saturating_sub(members);
        if self.filled == self.members && offspring.checked_rem(members) == Some(0) {
            // A generation boundary (the completed initial population counts as one).
            if offspring > 0 {
                self.generations += 1;
            }
            self.stall.update(self.best.fitness, s.tolerance);
        }
        self.status = if self.evaluations >= s.max_evaluations {
            Status::Done(StopReason::EvaluationBudget)
        } else if self.generations >= s.max_generations {
            Status::Done(StopReason::GenerationLimit)
        } else if self.stall.generations >= s.stall_generations {
            Status::Done(StopReason::Stalled)
        } else {
            Status::Running
        };
    }

    /// The fitness the pending candidate must beat to change the run: `+∞` while the
    /// initial population fills, then the worst member's. A candidate told a fitness `≥` this
    /// neither enters the population nor becomes the best, so its exact value is never read
    /// ([`Problem::fitness_below`]). O(P).
    pub fn acceptance_bound(&self) -> f32 {
        if self.filled < self.members {
            return f32::INFINITY;
        }
        self.population()
            .iter()
            .fold(f32::NEG_INFINITY, |worst, ind| {
                if ind.fitness > worst {
                    ind.fitness
                } else {
                    worst
                }
            })
    }

    fn worst_mut(&mut self) -> Option<&mut Individual> {
        let mut worst: Option<&mut Individual> = None;
        for ind in self.population.iter_mut().take(usize::from(self.members)) {
            match &worst {
                // Fitness is never NaN (`tell` maps NaN to +∞).
                Some(w) if ind.fitness <= w.fitness => {}
                _ => worst = Some(ind),
            }
        }
        worst
    }

    /// Uniform in `[0, 1)` with 24 random bits.
    fn uniform(&mut self) -> f32 {
        (self.rng.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    /// Index uniform in `0..n` (n ≤ 65535), by multiply-shift.
    fn index(&mut self, n: usize) -> usize {
        ((u64::from(self.rng.next_u32()) * n as u64) >> 32) as usize
    }

    /// Approximately standard normal: Irwin–Hall sum of four uniforms, rescaled.
    fn normal(&mut self) -> f32 {
        let sum = self.uniform() + self.uniform() + self.uniform() + self.uniform();
        (sum - 2.0) * 1.732_050_8
    }

    fn tournament(&mut self) -> Individual {
        let mut winner = Individual::UNEVALUATED;
        for _ in 0..self.settings.tournament_size {
            let i = self.index(self.members());
            if let Some(candidate) = self.population.get(i) {
                if candidate.fitness < winner.fitness || winner.fitness == f32::INFINITY {
                    winner = *candidate;
                }
            }
        }
        winner
    }

    /// An offspring bred with the population's `spread` ([`spread_stepwise`](Self::spread_stepwise)).
    fn offspring(&mut self, spread: &Genes) -> Genes {
        let a = self.tournament();
        let b = self.tournament();
        let s = self.settings;
        let differential = self.uniform() < s.differential_probability;
        let (r1, r2) = (self.index(self.members()), self.index(self.members()));
        let (x1, x2) = match (self.population.get(r1), self.population.get(r2)) {
            (Some(x1), Some(x2)) if differential => (x1.genes, x2.genes),
            _ => ([0.0; GENES], [0.0; GENES]),
        };
        let mut child = [0.0f32; GENES];
        for g in 0..GENES {
            let (
                Some(&x),
                Some(&y),
                Some(slot),
                Some(&sigma),
                Some(&circular),
                Some(&d1),
                Some(&d2),
            ) = (
                a.genes.get(g),
                b.genes.get(g),
                child.get_mut(g),
                spread.get(g),
                s.circular.get(g),
                x1.get(g),
                x2.get(g),
            )
            else {
                continue;
            };
            // BLX-α between the parents (the shorter arc for circular genes).
            let delta = if circular {
                wrap_difference(y - x)
            } else {
                y - x
            };
            let u = self.uniform();
            let mut v = x + delta * (u * (1.0 + 2.0 * s.crossover_alpha) - s.crossover_alpha);
            let step = if circular {
                wrap_difference(d1 - d2)
            } else {
                d1 - d2
            };
            v += s.differential_scale * step;
            let mutate = self.uniform() < s.mutation_probability;
            if mutate {
                v += (s.mutation_scale * sigma + s.mutation_floor) * self.normal();
            }
            *slot = if circular {
                wrap_unit(v)
            } else {
                reflect_unit(v)
            };
        }
        child
    }

    /// Mean absolute distance of the population from the best individual, per gene
    /// (shortest arc for circular genes), pausing after every [`SPREAD_MEMBERS_PER_POLL`]
    /// members.
    async fn spread_stepwise(&self) -> Genes {
        let mut spread = [0.0f32; GENES];
        for (n, ind) in self.population().iter().enumerate() {
            if n > 0 && n % SPREAD_MEMBERS_PER_POLL == 0 {
                pause().await;
            }
            for (g, out) in spread.iter_mut().enumerate() {
                let (Some(&x), Some(&b), Some(&circular)) = (
                    ind.genes.get(g),
                    self.best.genes.get(g),
                    self.settings.circular.get(g),
                ) else {
                    continue;
                };
                let d = if circular {
                    wrap_difference(x - b)
                } else {
                    x - b
                };
                *out += if d < 0.0 { -d } else { d };
            }
        }
        spread.map(|s| s * (1.0 / f32::from(self.members)))
    }
}

/// Members of the population whose distance from the best one poll of
/// [`SteadyStateGa::ask_stepwise`] sums (about 1 500 instructions on the Cortex-M4F).
pub const SPREAD_MEMBERS_PER_POLL: usize = 8;

/// The stall stop's memory, updated once per generation: the best fitness when it last
/// improved by more than the tolerance, and the generations since. O(1) state, so
/// the rule costs nothing in RAM or in the checkpoint; `host-sim stopping` replays the same
/// code on recorded runs to choose the settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StallTest {
    /// Best fitness when progress last counted (`+∞` before the first generation).
    pub reference: f32,
    /// Generations since then.
    pub generations: u32,
}

impl StallTest {
    pub const NEW: Self = Self {
        reference: f32::INFINITY,
        generations: 0,
    };

    /// One generation boundary with best-so-far fitness `best`: progress counts when `best`
    /// is more than `tolerance` below the reference (the first finite best always counts).
    /// Returns the generations without progress. O(1).
    pub fn update(&mut self, best: f32, tolerance: f32) -> u32 {
        if self.reference - best > tolerance {
            self.reference = best;
            self.generations = 0;
        } else {
            self.generations = self.generations.saturating_add(1);
        }
        self.generations
    }
}

/// Difference on the unit circle, reduced to `[-0.5, 0.5)`.
fn wrap_difference(d: f32) -> f32 {
    wrap_unit(d + 0.5) - 0.5
}

/// Reduces to `[0, 1)`. Non-finite input maps to 0.5.
pub fn wrap_unit(v: f32) -> f32 {
    if !v.is_finite() {
        return 0.5;
    }
    let w = v - crate::base::math::floor(v);
    // `v − ⌊v⌋` can round up to exactly 1.0 for tiny negative v.
    if w >= 1.0 {
        0.0
    } else {
        w
    }
}

/// Reflects into `[0, 1]` at the bounds (then clamps, for far excursions). Non-finite → 0.5.
pub fn reflect_unit(v: f32) -> f32 {
    if !v.is_finite() {
        return 0.5;
    }
    let r = if v < 0.0 {
        -v
    } else if v > 1.0 {
        2.0 - v
    } else {
        v
    };
    r.clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sphere(target: Genes) -> impl FnMut(&Genes) -> f32 {
        move |g: &Genes| g.iter().zip(target).map(|(a, b)| (a - b) * (a - b)).sum()
    }

    #[test]
    fn rejects_bad_settings() {
        let mut s = GaSettings::FDI;
        s.tournament_size = 0;
        assert!(matches!(
            SteadyStateGa::<8>::new(s, 1),
            Err(GaError::InvalidSettings(_))
        ));
        assert!(matches!(
            SteadyStateGa::<1>::new(GaSettings::FDI, 1),
            Err(GaError::InvalidSettings(_))
        ));
        let mut s = GaSettings::FDI;
        s.mutation_probability = 1.5;
        assert!(matches!(
            SteadyStateGa::<8>::new(s, 1),
            Err(GaError::InvalidSettings(_))
        ));
        let mut s = GaSettings::FDI;
        s.initial_guess = Some([2.0; GENES]);
        assert!(matches!(
            SteadyStateGa::<8>::new(s, 1),
            Err(GaError::InvalidSettings(_))
        ));
    }

    #[test]
    fn tell_without_ask_is_an_error_and_ask_is_idempotent() {
        let mut ga = SteadyStateGa::<8>::new(GaSettings::FDI, 3).unwrap();
        assert_eq!(ga.tell(1.0), Err(GaError::NothingPending));
        let a = ga.ask().unwrap();
        assert_eq!(ga.ask().unwrap(), a);
        ga.tell(1.0).unwrap();
        assert_ne!(ga.ask().unwrap(), a);
    }

    #[test]
    fn first_candidate_is_the_initial_guess() {
        let mut ga = SteadyStateGa::<8>::new(GaSettings::FDI, 3).unwrap();
        assert_eq!(Some(ga.ask().unwrap()), GaSettings::FDI.initial_guess);
    }

    #[test]
    fn converges_on_a_sphere_and_stops_for_a_reason() {
        let target = [0.1, 0.9, 0.3, 0.0, 1.0, 0.25, 0.02, 0.6, 0.0];
        let mut settings = GaSettings::FDI;
        settings.max_evaluations = 4000;
        let mut ga = SteadyStateGa::<24>::new(settings, 11).unwrap();
        let reason = ga.run(&mut sphere(target));
        assert!(ga.best().fitness < 1e-6, "best {}", ga.best().fitness);
        assert!(ga.evaluations() <= 4000);
        assert!(matches!(
            reason,
            StopReason::EvaluationBudget | StopReason::Stalled
        ));
        assert_eq!(ga.ask(), Err(GaError::Finished(reason)));
        assert_eq!(ga.tell(0.0), Err(GaError::Finished(reason)));
    }

    #[test]
    fn circular_gene_is_found_across_the_wrap() {
        // Optimum at 0.99 on a circular gene: the distance wraps, 0.01 is as close as 0.97.
        let mut problem = |g: &Genes| {
            let d = wrap_difference(g[6] - 0.99);
            d * d + g[0] * g[0]
        };
        let mut ga = SteadyStateGa::<16>::new(GaSettings::FDI, 5).unwrap();
        ga.run(&mut problem);
        assert!(wrap_difference(ga.best().genes[6] - 0.99).abs() < 1e-3);
    }

    #[test]
    fn stalls_on_a_flat_problem() {
        let mut settings = GaSettings::FDI;
        settings.stall_generations = 5;
        let mut ga = SteadyStateGa::<8>::new(settings, 1).unwrap();
        let reason = ga.run(&mut |_: &Genes| 1.0);
        assert_eq!(reason, StopReason::Stalled);
        // initial population (first boundary sets the reference) + 5 stalled generations
        assert_eq!(ga.evaluations(), 8 + 5 * 8);
    }

    #[test]
    fn stall_test_counts_only_improvements_beyond_the_tolerance() {
        let mut stall = StallTest::NEW;
        assert_eq!(stall.update(1.0, 0.1), 0, "the first finite best counts");
        assert_eq!(
            stall.update(0.95, 0.1),
            1,
            "0.05 better: within the tolerance"
        );
        assert_eq!(
            stall.update(0.91, 0.1),
            2,
            "0.09 below the reference: still within"
        );
        assert_eq!(
            stall.update(0.85, 0.1),
            0,
            "0.15 below the reference: progress"
        );
        assert_eq!(stall.reference, 0.85);
        // Negative fitness (the nominal residual is subtracted) works the same way.
        let mut stall = StallTest::NEW;
        stall.update(-1.0, 0.1);
        assert_eq!(stall.update(-1.05, 0.1), 1);
        assert_eq!(stall.update(-1.2, 0.1), 0);
    }

    #[test]
    fn a_slowly_improving_run_stalls_under_a_tolerance_but_not_without() {
        // Every evaluation improves the best by 1e-6: progress for tolerance 0, stall for 1e-4.
        let run = |tolerance: f32| {
            let settings = GaSettings {
                stall_generations: 5,
                tolerance,
                max_generations: u32::MAX,
                ..GaSettings::FDI
            };
            let mut ga = SteadyStateGa::<8>::new(settings, 1).unwrap();
            let mut n = 0.0f32;
            let reason = ga.run(&mut |_: &Genes| {
                n -= 1e-6;
                n
            });
            (reason, ga.evaluations())
        };
        assert_eq!(run(0.0).0, StopReason::EvaluationBudget);
        let (reason, evaluations) = run(1e-4);
        assert_eq!(reason, StopReason::Stalled);
        assert_eq!(evaluations, 8 + 5 * 8);
    }

    #[test]
    fn generation_limit_stops() {
        let mut settings = GaSettings::FDI;
        settings.max_generations = 3;
        let mut ga = SteadyStateGa::<8>::new(settings, 1).unwrap();
        let mut n = 0.0f32;
        // Always improving, so it never stalls.
        let reason = ga.run(&mut |_: &Genes| {
            n -= 1.0;
            n
        });
        assert_eq!(reason, StopReason::GenerationLimit);
        assert_eq!(ga.generations(), 3);
        assert_eq!(ga.evaluations(), 8 + 3 * 8);
    }

    #[test]
    fn nan_fitness_counts_as_worst() {
        let mut ga = SteadyStateGa::<4>::new(GaSettings::FDI, 1).unwrap();
        let mut calls = 0;
        ga.step(
            &mut |_: &Genes| {
                calls += 1;
                if calls % 2 == 0 {
                    f32::NAN
                } else {
                    1.0
                }
            },
            50,
        );
        assert_eq!(ga.best().fitness, 1.0);
    }

    #[test]
    fn wrapping_and_reflection_stay_in_bounds() {
        for v in [
            -3.7f32,
            -1e-9,
            -0.0,
            0.0,
            0.5,
            1.0,
            1.0 + 1e-7,
            2.9,
            1e30,
            -1e30,
        ] {
            let w = wrap_unit(v);
            assert!((0.0..1.0).contains(&w), "wrap {v} -> {w}");
            let r = reflect_unit(v);
            assert!((0.0..=1.0).contains(&r), "reflect {v} -> {r}");
        }
        assert_eq!(wrap_unit(f32::NAN), 0.5);
        assert_eq!(reflect_unit(f32::INFINITY), 0.5);
        assert!((wrap_difference(0.95 - 0.05) + 0.1).abs() < 1e-6);
    }
}
