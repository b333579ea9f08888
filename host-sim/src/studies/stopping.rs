//! Choosing the flown GA's stop rule on the campaigns (`host-sim stopping`).
//!
//! Every case × seed of the campaigns (paper Tables I and II, the healthy noisy actuator, the
//! untuned random vectors) is identified once with the flown settings but the budget at
//! [`CAP`] and no stall stop, recording at every generation (32 evaluations) the best fitness
//! and the e_tot (eq. 4) of the best vector. Each candidate rule is then replayed on those
//! records with the very [`StallTest`] the GA runs, so the stop generation, the evaluations
//! and the e_tot at the stop are exactly what the flown GA with that rule would give (the GA
//! draws the same candidates whatever its stop rule). Work: one identification of `CAP`
//! evaluations per run; the replay is O(generations) per rule and run.

use anyhow::{anyhow, Result};
use rayon::prelude::*;
use shared::actuator::ActuatorRecord;
use shared::fdi::POPULATION;
use shared::ga::StallTest;
use shared::metrics::total_error;
use shared::{FaultVector, GaSettings};

use crate::fdi::identify::{command_table, onboard_identification};
use crate::plant::reference::{ReferenceModel, Scenario};
use crate::studies::campaign::Case;

/// Evaluations recorded per run: the budget flown before this study.
pub const CAP: u32 = 6_000;

/// One generation boundary of a recorded run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Generation {
    pub evaluations: u32,
    pub best_fitness: f32,
    /// e_tot [%] of the best vector (for the healthy case: 100 × its largest component).
    pub e_tot: f32,
}

/// One recorded run.
#[derive(Clone, Debug)]
pub struct RunRecord {
    pub case: &'static str,
    /// Which campaign the case belongs to (for the per-campaign means).
    pub group: &'static str,
    pub seed: u64,
    pub generations: Vec<Generation>,
}

/// A stall rule: stop after `window` generations in which the best fitness improved by no
/// more than `tolerance` [A²·s] (the flown GA's [`StallTest`]), never before
/// `CAP` when `window` is 0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rule {
    pub window: u32,
    pub tolerance: f32,
}

impl Rule {
    /// The generation index at which a run with this rule stops, replayed with the GA's own
    /// [`StallTest`] (the last one if it never stalls within the record).
    pub fn stop_index(&self, run: &RunRecord) -> usize {
        let mut stall = StallTest::NEW;
        for (i, g) in run.generations.iter().enumerate() {
            if stall.update(g.best_fitness, self.tolerance) >= self.window && self.window > 0 {
                return i;
            }
        }
        run.generations.len().saturating_sub(1)
    }

    pub fn label(&self) -> String {
        if self.window == 0 {
            format!("none ({CAP} evaluations)")
        } else {
            format!("{} generations, {}", self.window, self.tolerance)
        }
    }
}

/// Records every case × `seeds` (RM seed r, GA seed 1 + r) for `record`'s actuator.
pub fn record_runs(
    cases: &[(&'static str, Case)],
    seeds: u64,
    record: &ActuatorRecord,
    rm: &ReferenceModel,
    progress: bool,
) -> Result<Vec<RunRecord>> {
    let jobs: Vec<(usize, u64)> = (0..cases.len())
        .flat_map(|c| (0..seeds).map(move |r| (c, r)))
        .collect();
    let bar = crate::progress_bar(
        jobs.len() as u64,
        "recording runs {bar:40} {pos}/{len}, {elapsed} elapsed, ~{eta} left",
        progress,
    );
    let out: Result<Vec<RunRecord>> = jobs
        .par_iter()
        .map(|&(c, seed)| {
            let (group, case) = &cases[c];
            let run = record_run(case, group, seed, record, rm);
            bar.inc(1);
            run
        })
        .collect();
    bar.finish_and_clear();
    out
}

fn record_run(
    case: &Case,
    group: &'static str,
    seed: u64,
    record: &ActuatorRecord,
    rm: &ReferenceModel,
) -> Result<RunRecord> {
    let truth = FaultVector::new(case.faults).map_err(|e| anyhow!("case {}: {e:?}", case.name))?;
    let sim = rm.simulate(&Scenario {
        faults: truth,
        current_ref_noise: case.noise,
        seed,
    });
    let measured = sim.trace.measured(&record.params)?;
    let table = command_table(&measured, record);
    let settings = GaSettings {
        max_evaluations: CAP,
        max_generations: u32::MAX,
        stall_generations: u32::MAX,
        ..record.ga
    };
    let mut id = onboard_identification(&measured, record, settings, 1 + seed, &table)?;
    let mut generations = Vec::new();
    loop {
        let status = id.step(POPULATION as u32);
        let best = id.ga().best();
        let found = FaultVector::saturating(best.genes);
        let e_tot = if case.healthy {
            100.0 * found.largest_deviation()
        } else {
            total_error(&found, &truth)
        };
        generations.push(Generation {
            evaluations: id.ga().evaluations(),
            best_fitness: best.fitness,
            e_tot,
        });
        if matches!(status, shared::Status::Done(_)) {
            break;
        }
    }
    Ok(RunRecord {
        case: case.name,
        group,
        seed,
        generations,
    })
}

/// What a rule gives over all recorded runs.
#[derive(Clone, Debug, PartialEq)]
pub struct RuleSummary {
    pub rule: Rule,
    pub median_evaluations: f64,
    pub p90_evaluations: f64,
    pub max_evaluations: u32,
    /// Mean e_tot [%] at the stop, per group, in the order groups first appear.
    pub group_means: Vec<(&'static str, f64)>,
    /// Largest e_tot increase over the run's own e_tot at [`CAP`] [% points].
    pub worst_increase: f64,
    /// The run with that increase (case, seed).
    pub worst_run: (&'static str, u64),
}

fn quantile(values: &mut [f64], q: f64) -> f64 {
    values.sort_by(f64::total_cmp);
    if values.is_empty() {
        return f64::NAN;
    }
    let i = ((values.len() - 1) as f64 * q).round() as usize;
    values[i.min(values.len() - 1)]
}

/// Replays `rule` on every run.
pub fn summarise(rule: Rule, runs: &[RunRecord]) -> RuleSummary {
    let mut evaluations = Vec::new();
    let mut groups: Vec<(&'static str, f64, usize)> = Vec::new();
    let mut worst = (f64::NEG_INFINITY, ("", 0));
    for run in runs {
        let i = rule.stop_index(run);
        let (Some(stop), Some(end)) = (run.generations.get(i), run.generations.last()) else {
            continue;
        };
        evaluations.push(f64::from(stop.evaluations));
        match groups.iter_mut().find(|g| g.0 == run.group) {
            Some(g) => {
                g.1 += f64::from(stop.e_tot);
                g.2 += 1;
            }
            None => groups.push((run.group, f64::from(stop.e_tot), 1)),
        }
        let increase = f64::from(stop.e_tot) - f64::from(end.e_tot);
        if increase > worst.0 {
            worst = (increase, (run.case, run.seed));
        }
    }
    let max_evaluations = evaluations.iter().fold(0.0f64, |a, &b| a.max(b)) as u32;
    RuleSummary {
        rule,
        median_evaluations: quantile(&mut evaluations, 0.5),
        p90_evaluations: quantile(&mut evaluations, 0.9),
        max_evaluations,
        group_means: groups
            .into_iter()
            .map(|(g, sum, n)| (g, sum / n.max(1) as f64))
            .collect(),
        worst_increase: worst.0,
        worst_run: worst.1,
    }
}

/// The rules compared: no stop (the old budget), then windows × tolerances.
pub fn candidate_rules() -> Vec<Rule> {
    let mut rules = vec![Rule {
        window: 0,
        tolerance: 0.0,
    }];
    for window in [10, 15, 20, 25, 30] {
        for tolerance in [0.0, 1e-5, 2e-5, 3e-5, 5e-5] {
            rules.push(Rule { window, tolerance });
        }
    }
    rules
}

/// The comparison as Markdown.
pub fn markdown(summaries: &[RuleSummary], runs: usize, seeds: u64) -> String {
    use std::fmt::Write as _;
    let mut md = String::new();
    let _ = writeln!(
        md,
        "Stop rules replayed on {runs} recorded identifications (campaign cases × {seeds} seeds, \
         flown GA, {CAP} evaluations each). e_tot means per campaign at the stop [%]; \
         the healthy case reads 100 × its largest identified component.\n"
    );
    let groups: Vec<&'static str> = summaries
        .first()
        .map(|s| s.group_means.iter().map(|g| g.0).collect())
        .unwrap_or_default();
    let _ = write!(md, "| stall rule | evaluations: median | 90 % | max |");
    for g in &groups {
        let _ = write!(md, " {g} |");
    }
    let _ = writeln!(md, " worst e_tot increase [pp] (run) |");
    let _ = writeln!(
        md,
        "|---|---:|---:|---:|{}---|",
        "---:|".repeat(groups.len())
    );
    for s in summaries {
        let _ = write!(
            md,
            "| {} | {:.0} | {:.0} | {} |",
            s.rule.label(),
            s.median_evaluations,
            s.p90_evaluations,
            s.max_evaluations
        );
        for (_, m) in &s.group_means {
            let _ = write!(md, " {m:.2} |");
        }
        let _ = writeln!(
            md,
            " {:+.2} ({}, seed {}) |",
            s.worst_increase, s.worst_run.0, s.worst_run.1
        );
    }
    md
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A run whose best fitness improves by `steps[g]` at generation `g`, e_tot = 10 − g.
    fn run(group: &'static str, steps: &[f32]) -> RunRecord {
        let mut best = 1.0f32;
        let generations = steps
            .iter()
            .enumerate()
            .map(|(g, d)| {
                best -= d;
                Generation {
                    evaluations: 32 * (g as u32 + 1),
                    best_fitness: best,
                    e_tot: 10.0 - g as f32,
                }
            })
            .collect();
        RunRecord {
            case: "synthetic",
            group,
            seed: 0,
            generations,
        }
    }

    #[test]
    fn a_rule_stops_where_the_flown_stall_test_would() {
        // Progress of 0.1 for three generations, then creeping by 1e-4.
        let r = run("A", &[0.1, 0.1, 0.1, 1e-4, 1e-4, 1e-4, 1e-4, 1e-4, 1e-4]);
        let strict = Rule {
            window: 3,
            tolerance: 0.0,
        };
        assert_eq!(
            strict.stop_index(&r),
            8,
            "creeping counts without a tolerance"
        );
        let tolerant = Rule {
            window: 3,
            tolerance: 1e-3,
        };
        // Last progress at index 2; three generations without it: index 5.
        assert_eq!(tolerant.stop_index(&r), 5);
        let none = Rule {
            window: 0,
            tolerance: 0.0,
        };
        assert_eq!(none.stop_index(&r), 8);
    }

    #[test]
    fn the_summary_reads_the_stop_against_the_whole_run() {
        let runs = [
            run("A", &[0.1, 1e-4, 1e-4, 1e-4]),
            run("B", &[0.1, 0.1, 0.1, 0.1]),
        ];
        let s = summarise(
            Rule {
                window: 2,
                tolerance: 1e-3,
            },
            &runs,
        );
        // A stops at index 2 (96 evaluations, e_tot 8), B runs to its end (128, e_tot 7).
        assert_eq!(s.max_evaluations, 128);
        assert_eq!(s.group_means, vec![("A", 8.0), ("B", 7.0)]);
        assert_eq!(s.worst_increase, 1.0);
    }
}
