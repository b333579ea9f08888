//! The domain survey (`host-sim domain`): the statistics [`shared::domain`] judges, measured
//! on actuators the monitor model explains (Table I and II cases, the healthy actuator, with
//! process noise and several seeds) and on actuators it does not (jammed, each phase open,
//! tests run with other commands), so that each limit of
//! [`DomainLimits::REFERENCE_ACTUATOR`] can be seen to separate the two groups.
//! One row = one reference-model test (0.05 s) + one identification (≈ 1 s).

use anyhow::Result;
use rayon::prelude::*;
use shared::domain::{Domain, DomainLimits, DomainMonitor};
use shared::{Calibration, ChirpCommand, FaultVector};

use shared::actuator::ActuatorRecord;

use crate::fdi::identify::identify_for;
use crate::files::actuator::Actuator;
use crate::files::trace::Trace;
use crate::plant::reference::{Anomaly, ReferenceModel, Scenario};
use crate::studies::campaign::{HEALTHY, TABLE_1, TABLE_2};

/// One surveyed test.
#[derive(Clone, Debug)]
pub struct SurveyRow {
    pub name: String,
    /// Whether the monitor model explains this actuator (what the verdict should say).
    pub inside: bool,
    pub travel: f32,
    /// Smallest phase ratio (mean commutated current over the largest phase's).
    pub phase_ratio: f32,
    pub tracking: f32,
    /// Largest phase's mean commutated current [A].
    pub phase_current: f32,
    pub fitness: f32,
    pub domain: Domain,
}

/// The statistics and the verdict for `trace`, with the built-in calibration and GA seed 1.
pub fn assess(trace: &Trace, limits: &DomainLimits) -> Result<(DomainMonitor, f32, Domain)> {
    let record = ActuatorRecord {
        test: *trace.test(),
        calibration: Calibration::reference_actuator(trace.test()),
        domain: *limits,
        ..ActuatorRecord::REFERENCE
    };
    assess_for(trace, &record)
}

/// The statistics and the verdict for `trace` of the actuator `record` describes (its
/// parameters, calibration and limits), GA seed 1.
pub fn assess_for(trace: &Trace, record: &ActuatorRecord) -> Result<(DomainMonitor, f32, Domain)> {
    let params = record.params;
    let trace = trace.clone().with_test(record.test);
    let monitor = trace.domain_monitor(&params);
    let measured = trace.measured(&params)?;
    let id = identify_for(&measured, record, 1, false)?;
    let fitness = id.result.fitness;
    Ok((monitor, fitness, id.domain(&monitor, &record.domain)))
}

/// Everything the survey runs: (name, inside?, model, scenario).
fn tests(rm: ReferenceModel, seeds: u64) -> Vec<(String, bool, ReferenceModel, Scenario)> {
    let amplitude = rm.test().chirp.amplitude;
    let end = rm.test().chirp.end_frequency;
    let mut out = Vec::new();
    let inside = TABLE_1.iter().chain(TABLE_2.iter()).chain([&HEALTHY]);
    for case in inside {
        for noise in [case.noise, 0.1] {
            for seed in 0..seeds {
                let mut s = Scenario::new(FaultVector::saturating(case.faults));
                s.current_ref_noise = noise;
                s.seed = seed;
                out.push((
                    format!("{} (noise {noise}, seed {seed})", case.name),
                    true,
                    rm,
                    s,
                ));
            }
        }
    }
    let outside = [
        ("jammed", rm.with_anomaly(Anomaly::Jammed)),
        ("phase A open", rm.with_anomaly(Anomaly::OpenPhase(0))),
        ("phase B open", rm.with_anomaly(Anomaly::OpenPhase(1))),
        ("phase C open", rm.with_anomaly(Anomaly::OpenPhase(2))),
        (
            "command: chirp ×2 amplitude",
            rm.with_command(chirp(2.0 * amplitude, end)),
        ),
        (
            "command: chirp ×0.4 amplitude",
            rm.with_command(chirp(0.4 * amplitude, end)),
        ),
        (
            "command: chirp to 5 Hz",
            rm.with_command(chirp(amplitude, end / 3.0)),
        ),
        (
            "command: chirp to 30 Hz",
            rm.with_command(chirp(amplitude, 2.0 * end)),
        ),
    ];
    for (name, model) in outside {
        for faults in [
            [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0],
            [0.3, 0.3, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0],
        ] {
            for seed in 0..seeds {
                let mut s = Scenario::new(FaultVector::saturating(faults));
                s.seed = seed;
                let label = if faults[0] > 0.0 {
                    ", friction + backlash 0.3"
                } else {
                    ""
                };
                out.push((format!("{name}{label} (seed {seed})"), false, model, s));
            }
        }
    }
    out
}

fn chirp(amplitude: f32, end_frequency: f32) -> ChirpCommand {
    ChirpCommand {
        amplitude,
        end_frequency,
        ..ChirpCommand::PREFLIGHT
    }
}

/// Runs the survey of `actuator` in parallel (`seeds` RM seeds per case), judged against
/// `limits`.
pub fn survey(
    actuator: &Actuator,
    seeds: u64,
    limits: &DomainLimits,
    progress: bool,
) -> Result<Vec<SurveyRow>> {
    let mut record = actuator.record_for(&actuator.record.test)?;
    record.domain = *limits;
    let rm = ReferenceModel::new(actuator.reference_settings()?).with_test(record.test);
    let tests = tests(rm, seeds);
    let bar = crate::progress_bar(
        tests.len() as u64,
        "domain survey {bar:40} {pos}/{len}",
        progress,
    );
    let rows = tests
        .into_par_iter()
        .map(|(name, inside, model, scenario)| {
            let trace = model.simulate(&scenario).trace;
            let (monitor, fitness, domain) = assess_for(&trace, &record)?;
            let phase_ratio = monitor
                .phase_ratios(limits.min_phase_samples)
                .iter()
                .flatten()
                .fold(f32::INFINITY, |a, &b| a.min(b));
            bar.inc(1);
            Ok(SurveyRow {
                name,
                inside,
                travel: monitor.travel(),
                phase_ratio,
                tracking: monitor.tracking(),
                phase_current: monitor.largest_phase_mean(limits.min_phase_samples),
                fitness,
                domain,
            })
        })
        .collect::<Result<Vec<_>>>();
    bar.finish_and_clear();
    rows
}

/// Limits placed from the survey of the explained actuators alone (for an actuator whose
/// limits are not known yet): half the least travel and phase ratio, 1.5 × the largest
/// tracking ratio, 2 × the largest best fitness seen inside; `min_phase_samples` and
/// `min_phase_current` kept from `base`. How many unexplained tests each catches is in the
/// survey's table.
pub fn suggested_limits(rows: &[SurveyRow], base: &DomainLimits) -> DomainLimits {
    let inside = rows.iter().filter(|r| r.inside);
    let (mut travel, mut ratio, mut tracking, mut fitness) =
        (f32::INFINITY, f32::INFINITY, 0.0f32, 0.0f32);
    for r in inside {
        travel = travel.min(r.travel);
        if r.phase_ratio.is_finite() {
            ratio = ratio.min(r.phase_ratio);
        }
        tracking = tracking.max(r.tracking);
        fitness = fitness.max(r.fitness);
    }
    let round = |x: f32| {
        // Two significant digits: a limit a person can read and edit.
        if x > 0.0 && x.is_finite() {
            let p = 10f32.powf(x.log10().floor() - 1.0);
            (x / p).round() * p
        } else {
            x
        }
    };
    DomainLimits {
        min_travel: round(0.5 * travel),
        min_phase_ratio: if ratio.is_finite() {
            round(0.5 * ratio)
        } else {
            base.min_phase_ratio
        },
        max_tracking: round(1.5 * tracking),
        max_fitness: round(2.0 * fitness),
        ..*base
    }
}

/// The survey as a Markdown table, with the range of each statistic per group.
pub fn markdown(rows: &[SurveyRow], limits: &DomainLimits) -> String {
    let mut out = String::new();
    out += "| test | monitor model explains it | user travel [mrad] | phase current [A] | min phase ratio | tracking | best fitness [A²·s] | verdict |\n";
    out += "| --- | --- | ---: | ---: | ---: | ---: | ---: | --- |\n";
    for r in rows {
        let verdict = match r.domain {
            Domain::Within => "within".to_string(),
            Domain::Outside(reason) => format!("outside: {reason:?}"),
        };
        out += &format!(
            "| {} | {} | {:.2} | {:.2} | {:.3} | {:.3} | {:.2e} | {} |\n",
            r.name,
            if r.inside { "yes" } else { "no" },
            r.travel * 1e3,
            r.phase_current,
            r.phase_ratio,
            r.tracking,
            r.fitness,
            verdict
        );
    }
    let group = |inside: bool| rows.iter().filter(move |r| r.inside == inside);
    let range = |inside: bool, f: fn(&SurveyRow) -> f32| {
        let (lo, hi) = group(inside)
            .map(f)
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), x| {
                (a.min(x), b.max(x))
            });
        format!("{lo:.3e} … {hi:.3e}")
    };
    let wrong_inside = group(true).filter(|r| r.domain != Domain::Within).count();
    let wrong_outside = group(false).filter(|r| r.domain == Domain::Within).count();
    for (inside, lead) in [(true, "\nInside the model"), (false, "Outside")] {
        out += &format!(
            "{lead} ({} tests): travel {} rad, phase current {} A, phase ratio {}, tracking {}, fitness {}.\n",
            group(inside).count(),
            range(inside, |r| r.travel),
            range(inside, |r| r.phase_current),
            range(inside, |r| r.phase_ratio),
            range(inside, |r| r.tracking),
            range(inside, |r| r.fitness)
        );
    }
    out += &format!(
        "\nLimits: phase ratio ≥ {} (checked when a phase carries ≥ {} A), travel ≥ {} rad, \
         tracking ≤ {}, fitness ≤ {} A²·s.\n\
         Verdicts wrong: {wrong_inside} explained actuators called outside, {wrong_outside} \
         unexplained ones called within.\n",
        limits.min_phase_ratio,
        limits.min_phase_current,
        limits.min_travel,
        limits.max_tracking,
        limits.max_fitness
    );
    out
}
