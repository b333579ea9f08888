//! `campaign --physics random`: Table I, Table II and the healthy actuator over draws of the
//! reference model's nuisance physics (`host_sim::studies::physics`), each draw calibrated
//! as a user would, on its calibration day and 60 K either side: one row per draw and day,
//! then the figures over the draws per day. Draws × 3 days × 21 cases × runs
//! identifications, in parallel.

use crate::cli::*;
use host_sim::studies::campaign::{CaseSummary, HEALTHY_QUIET, TABLE_2};
use host_sim::studies::physics::{physics_campaign, PhysicsRow, DAYS};

/// What one row of draws and day gave.
struct RowFigures {
    /// Table I's median case mean [%], and its worst case's mean and name.
    median: f64,
    worst: Option<(f64, &'static str)>,
    /// Runs read `within` above 6 % e_tot.
    wrong_within: usize,
    /// Runs that read a healthy component `FAULT`.
    false_fault: usize,
    /// Runs the domain check named, of all.
    outside: usize,
    total: usize,
    /// The healthy actuator's largest component read.
    largest: f64,
}

impl RowFigures {
    fn of(summaries: &[CaseSummary]) -> Self {
        let table_1: Vec<&CaseSummary> = summaries
            .iter()
            .filter(|c| TABLE_1.iter().any(|t| t.name == c.case.name))
            .collect();
        let mut means: Vec<f64> = table_1.iter().map(|c| c.mean()).collect();
        means.sort_by(f64::total_cmp);
        let runs = || summaries.iter().flat_map(|c| &c.runs);
        Self {
            median: means.get(means.len() / 2).copied().unwrap_or(f64::NAN),
            worst: table_1
                .iter()
                .max_by(|a, b| a.mean().total_cmp(&b.mean()))
                .map(|c| (c.mean(), c.case.name)),
            wrong_within: runs().filter(|r| r.within && r.e_tot > 6.0).count(),
            false_fault: summaries
                .iter()
                .map(|c| {
                    let truth = shared::FaultVector::new(c.case.faults)
                        .unwrap_or(shared::FaultVector::NOMINAL);
                    c.runs
                        .iter()
                        .filter(|r| r.false_alarm(&truth, false))
                        .count()
                })
                .sum(),
            outside: runs().filter(|r| !r.within).count(),
            total: runs().count(),
            largest: summaries
                .iter()
                .find(|c| c.case.name == HEALTHY_QUIET.name)
                .map_or(f64::NAN, |c| {
                    c.runs
                        .iter()
                        .map(|r| r.largest_component)
                        .fold(0.0, f64::max)
                }),
        }
    }
}

/// One day's figures over the draws.
struct DayTotals {
    day: &'static str,
    medians: Vec<f64>,
    worst: f64,
    wrong_within: usize,
    false_fault: usize,
    outside: usize,
    total: usize,
}

pub(crate) fn physics_campaign_command(
    actuator: &Actuator,
    seeds: std::ops::Range<u64>,
    runs: u64,
    friction_law: bool,
    out: Option<&Path>,
) -> Result<()> {
    let mut cases = TABLE_1.to_vec();
    cases.extend(TABLE_2);
    cases.push(HEALTHY_QUIET);
    let start = Instant::now();
    let (first, draws) = (seeds.start, seeds.end - seeds.start);
    let mut text = format!(
        "### A family of physics: {} ({} test), draws {}–{}, {runs} runs per case\n\n\
         Each draw plays its own nuisance physics (`host_sim::studies::physics::PhysicsDraw`: \
         grease, gearbox against winding, eccentricity physics, declared duty delay, rigging \
         offset the record does not know, harness), is calibrated on its healthy trace at the \
         calibration day{}, with the family's gearbox spread declared (`[uncertainty] \
         gear_temperature_spread` 11.5 K), then identified on that day and 60 K either side. \
         e_tot in % (eq. 4); `wrong within`: runs read `within` above 6 % e_tot; \
         `false FAULT`: runs that read a healthy component `FAULT` (Table I and II and the \
         healthy actuator); `outside`: runs the domain check named.\n\n\
         | draw | day | Table I median | Table I worst case (mean) | low | medium | high | medium + noise | healthy: largest | wrong within | false FAULT | outside |\n\
         | --- | --- | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n",
        actuator.name,
        actuator.record.test.kind_name(),
        seeds.start,
        seeds.end.saturating_sub(1),
        if friction_law {
            " and in the climatic chamber"
        } else {
            " alone (**no friction law**: `--without-friction-law`)"
        },
    );
    let mut labels = String::from("\nThe draws:\n\n");
    let mut totals: Vec<DayTotals> = DAYS
        .iter()
        .map(|(day, _)| DayTotals {
            day,
            medians: Vec::new(),
            worst: 0.0,
            wrong_within: 0,
            false_fault: 0,
            outside: 0,
            total: 0,
        })
        .collect();
    let mut refused = 0;
    let on_row = |row: &PhysicsRow| {
        let line = match &row.outcome {
            Err(why) => {
                refused += 1;
                format!(
                    "| {} | calibration | refused: {} | | | | | | | | | |\n",
                    row.draw.seed,
                    why.replace('|', "/")
                )
            }
            Ok(summaries) => {
                let f = RowFigures::of(summaries);
                let mean_of = |name: &str| {
                    summaries
                        .iter()
                        .find(|c| c.case.name == name)
                        .map_or("-".to_string(), |c| format!("{:.2}", c.mean()))
                };
                if let Some(t) = totals.iter_mut().find(|t| t.day == row.day) {
                    t.medians.push(f.median);
                    t.worst = f64::max(t.worst, f.worst.map_or(0.0, |(w, _)| w));
                    t.wrong_within += f.wrong_within;
                    t.false_fault += f.false_fault;
                    t.outside += f.outside;
                    t.total += f.total;
                }
                format!(
                    "| {} | {} | {:.2} | {} | {} | {} | {} | {} | {:.3} | {} | {} | {} of {} |\n",
                    row.draw.seed,
                    row.day,
                    f.median,
                    f.worst
                        .map_or("-".to_string(), |(m, n)| format!("{m:.2} ({n})")),
                    mean_of("low"),
                    mean_of("medium"),
                    mean_of("high"),
                    mean_of("medium + noise 50 %"),
                    f.largest,
                    f.wrong_within,
                    f.false_fault,
                    f.outside,
                    f.total,
                )
            }
        };
        if row.day == DAYS[0].0 {
            labels += &format!("- draw {}: {}\n", row.draw.seed, row.draw.label());
        }
        eprint!("{line}");
        text += &line;
    };
    physics_campaign(
        actuator,
        &cases,
        seeds,
        runs,
        friction_law,
        std::io::stderr().is_terminal(),
        on_row,
    )?;
    text += &labels;
    text += &format!(
        "\nOver the {draws} draws ({refused} refused by the calibration):\n\n\
         | day | Table I median, median over draws | Table I worst case, worst draw | wrong within | false FAULT | outside |\n\
         | --- | ---: | ---: | ---: | ---: | ---: |\n"
    );
    for mut t in totals {
        t.medians.sort_by(f64::total_cmp);
        let median = t
            .medians
            .get(t.medians.len() / 2)
            .copied()
            .unwrap_or(f64::NAN);
        text += &format!(
            "| {} | {median:.2} | {:.2} | {} | {} | {} of {} |\n",
            t.day, t.worst, t.wrong_within, t.false_fault, t.outside, t.total
        );
    }
    print!("{text}");
    println!(
        "\n({draws} draws × {} days in {:.0} s wall time)",
        DAYS.len(),
        start.elapsed().as_secs_f64()
    );
    if let Some(path) = out {
        let heading = format!(
            "# Accuracy over a family of physics\n\nWhat this answers: how the onboard FDI \
             reads Table I, Table II and the healthy actuator when the reference model's \
             nuisance physics is drawn from a family instead of being the actuator file's — \
             each draw calibrated as a user would, then identified on its calibration day and \
             60 K either side; what it means: docs/robustness.md. Generated by `host-sim \
             campaign --physics random --first-draw {first} --draws {draws} --runs {runs}{} \
             --out FILE`.\n\n",
            if friction_law {
                ""
            } else {
                " --without-friction-law"
            }
        );
        std::fs::write(path, heading + &text)
            .with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(())
}
