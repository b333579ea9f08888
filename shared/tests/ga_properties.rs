//! Property tests of the steady-state GA on cheap problems (the monitor model is tested in
//! `monitor_physics.rs`, the two together in the workspace's inverse check).

use proptest::prelude::*;
use shared::ga::{GaError, GaSettings, Genes, Status, SteadyStateGa, GENES};

const P: usize = 12;

/// A multimodal test function with its minimum at `target` (circular gene 6 wraps).
fn problem(target: Genes) -> impl FnMut(&Genes) -> f32 {
    move |g: &Genes| {
        let mut f = 0.0f32;
        for i in 0..GENES {
            let mut d = g[i] - target[i];
            if i == 6 {
                d -= (d + 0.5).floor();
            }
            f += d * d + 0.05 * (1.0 - (12.0 * d).cos());
        }
        f
    }
}

fn settings(max_evaluations: u32) -> GaSettings {
    GaSettings {
        max_evaluations,
        ..GaSettings::FDI
    }
}

fn genes_strategy() -> impl Strategy<Value = Genes> {
    prop::array::uniform9(0.0f32..=1.0)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn every_candidate_stays_in_bounds(seed in any::<u64>(), target in genes_strategy()) {
        let mut ga = SteadyStateGa::<P>::new(settings(400), seed).unwrap();
        let mut f = problem(target);
        while let Ok(genes) = ga.ask() {
            for (i, &x) in genes.iter().enumerate() {
                prop_assert!(x.is_finite());
                if i == 6 {
                    prop_assert!((0.0..1.0).contains(&x), "circular gene {} = {}", i, x);
                } else {
                    prop_assert!((0.0..=1.0).contains(&x), "gene {} = {}", i, x);
                }
            }
            let fitness = f(&genes);
            ga.tell(fitness).unwrap();
        }
        for ind in ga.population() {
            prop_assert!(ind.genes.iter().all(|x| (0.0..=1.0).contains(x)));
        }
    }

    #[test]
    fn best_ever_never_worsens(seed in any::<u64>(), target in genes_strategy()) {
        let mut ga = SteadyStateGa::<P>::new(settings(400), seed).unwrap();
        let mut f = problem(target);
        let mut previous = f32::INFINITY;
        let mut lowest_told = f32::INFINITY;
        while let Ok(genes) = ga.ask() {
            let fitness = f(&genes);
            lowest_told = lowest_told.min(fitness);
            ga.tell(fitness).unwrap();
            let best = ga.best().fitness;
            prop_assert!(best <= previous);
            prop_assert_eq!(best, lowest_told);
            // The best-ever is also in the population (replace-worst never drops it).
            prop_assert!(ga.population().iter().any(|i| i.fitness == best));
            previous = best;
        }
    }

    #[test]
    fn same_seed_gives_same_bits(seed in any::<u64>(), target in genes_strategy()) {
        let run = || {
            let mut ga = SteadyStateGa::<P>::new(settings(300), seed).unwrap();
            ga.run(&mut problem(target));
            ga
        };
        let (a, b) = (run(), run());
        prop_assert_eq!(a.best().genes.map(f32::to_bits), b.best().genes.map(f32::to_bits));
        prop_assert_eq!(a.best().fitness.to_bits(), b.best().fitness.to_bits());
        prop_assert_eq!(a, b);
    }

    #[test]
    fn ask_tell_is_the_same_as_step(seed in any::<u64>(), target in genes_strategy()) {
        let mut stepped = SteadyStateGa::<P>::new(settings(300), seed).unwrap();
        stepped.step(&mut problem(target), u32::MAX);
        let mut manual = SteadyStateGa::<P>::new(settings(300), seed).unwrap();
        let mut f = problem(target);
        while let Ok(genes) = manual.ask() {
            manual.tell(f(&genes)).unwrap();
        }
        prop_assert_eq!(stepped, manual);
    }

    #[test]
    fn stop_anywhere_and_resume_is_bit_identical(
        seed in any::<u64>(),
        target in genes_strategy(),
        slices in prop::collection::vec(1u32..60, 1..20),
    ) {
        let mut whole = SteadyStateGa::<P>::new(settings(350), seed).unwrap();
        whole.run(&mut problem(target));

        // Same run cut into arbitrary slices, with a checkpoint (clone) taken and resumed
        // from at every cut, and an interrupted ask (asked twice before telling).
        let mut ga = SteadyStateGa::<P>::new(settings(350), seed).unwrap();
        let mut f = problem(target);
        let mut i = 0;
        while ga.status() == Status::Running {
            let budget = slices[i % slices.len()];
            i += 1;
            ga.step(&mut f, budget);
            let checkpoint = ga.clone();
            ga = checkpoint;
            if let Ok(g) = ga.ask() {
                prop_assert_eq!(ga.ask().unwrap(), g);
            }
        }
        prop_assert_eq!(ga.best().genes.map(f32::to_bits), whole.best().genes.map(f32::to_bits));
        prop_assert_eq!(ga.evaluations(), whole.evaluations());
        prop_assert_eq!(ga.status(), whole.status());
    }

    #[test]
    fn step_never_exceeds_its_budget(seed in any::<u64>(), budget in 0u32..100) {
        let mut ga = SteadyStateGa::<P>::new(settings(1000), seed).unwrap();
        let mut calls = 0u32;
        ga.step(&mut |g: &Genes| { calls += 1; g.iter().sum() }, budget);
        prop_assert_eq!(calls, budget);
        prop_assert_eq!(ga.evaluations(), budget);
    }
}

#[test]
fn finds_the_minimum_of_the_multimodal_problem() {
    let target = [0.3, 0.05, 0.9, 0.5, 0.0, 0.7, 0.97, 0.45, 0.0];
    let mut ga = SteadyStateGa::<32>::new(settings(6000), 7).unwrap();
    ga.run(&mut problem(target));
    for (i, (&x, &t)) in ga.best().genes.iter().zip(&target).enumerate() {
        let mut d = x - t;
        if i == 6 {
            d -= (d + 0.5).floor();
        }
        assert!(d.abs() < 2e-3, "gene {i}: {x} vs {t}");
    }
}

#[test]
fn finished_run_refuses_ask_and_tell() {
    let mut ga = SteadyStateGa::<P>::new(settings(20), 1).unwrap();
    let reason = ga.run(&mut |g: &Genes| g[0]);
    assert_eq!(ga.evaluations(), 20);
    assert_eq!(ga.ask(), Err(GaError::Finished(reason)));
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    /// A run of `P` members in a GA of larger capacity (`restart_with`, what a window's
    /// search does in the preflight's GA) asks the same candidates, keeps the same
    /// population and stops at the same evaluation as a GA built for `P`, with a stall
    /// stop reached inside the budget. Fails if any step still reads the capacity.
    #[test]
    fn a_smaller_population_in_a_larger_ga_runs_the_same_bits(
        seed in any::<u64>(),
        target in genes_strategy(),
    ) {
        let settings = GaSettings { stall_generations: 6, tolerance: 1e-3, ..settings(900) };
        let mut exact = SteadyStateGa::<P>::new(settings, seed).unwrap();
        let mut roomy = SteadyStateGa::<32>::IDLE;
        roomy.restart_with(settings, seed, P).unwrap();
        prop_assert_eq!(roomy.members(), P);
        let mut f = problem(target);
        loop {
            let (a, b) = (exact.ask(), roomy.ask());
            prop_assert_eq!(a, b);
            let Ok(genes) = a else { break };
            let fitness = f(&genes);
            prop_assert_eq!(exact.acceptance_bound().to_bits(), roomy.acceptance_bound().to_bits());
            prop_assert_eq!(exact.tell(fitness), roomy.tell(fitness));
        }
        prop_assert_eq!(exact.population(), roomy.population());
        prop_assert_eq!(exact.generations(), roomy.generations());
        prop_assert_eq!(exact.best(), roomy.best());
    }
}

/// A population above the GA's capacity is refused, and a run of fewer members than the
/// capacity is neither checkpointed nor resumed into (a record holds the whole population).
#[test]
fn a_population_is_bounded_by_the_capacity_and_a_partial_run_is_not_checkpointed() {
    let mut ga = SteadyStateGa::<P>::IDLE;
    assert!(matches!(
        ga.restart_with(settings(100), 1, P + 1),
        Err(GaError::InvalidSettings(_))
    ));
    assert!(matches!(
        ga.restart_with(settings(100), 1, 1),
        Err(GaError::InvalidSettings(_))
    ));
    ga.restart_with(settings(100), 1, P / 2).unwrap();
    assert_eq!(ga.population().len(), P / 2);
    let mut record = [0u8; SteadyStateGa::<P>::RECORD_BYTES];
    assert!(ga.save(1, &mut record).is_err());
    let whole = SteadyStateGa::<P>::new(settings(100), 1).unwrap();
    whole.save(1, &mut record).unwrap();
    assert!(ga.resume_from(1, &record).is_err());
    assert_eq!(ga.members(), P / 2);
}
