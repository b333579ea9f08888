//! The preflight in wind (issue 36): what a gust on the parked surface does to the
//! identification, and what the controller sees of it.
//!
//! Per case and wind, `seeds` reference-model runs with the wind's hinge moment
//! ([`crate::plant::aero`]), each identified by the flown FDI and judged by the flown domain
//! checks, with what the test showed of the load (`shared::domain::LoadSigns`). The cost
//! is the identifications, ≈ 0.25 s each on one core.

use anyhow::Result;
use rayon::prelude::*;
use shared::actuator::ActuatorRecord;
use shared::domain::Domain;
use shared::fault::Verdict;
use shared::metrics::total_error;
use shared::uncertainty::Assessment;
use shared::FaultVector;

use crate::fdi::identify::identify_for;
use crate::plant::aero::GroundWind;
use crate::plant::reference::{ReferenceModel, Scenario};
use crate::studies::campaign::TABLE_2;

/// One run in wind: what the FDI read and what the test showed of the load.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WindRun {
    pub e_tot: f64,
    /// Healthy components (true nominal) the FDI calls `FAULT`: their whole 90 % interval
    /// beyond the detection threshold (`shared::uncertainty::Assessment::Faulty`, the verdict
    /// `identify` prints and the health log keeps).
    pub false_faults: u32,
    /// Healthy components whose reading alone is beyond the detection threshold (`FAULT` or
    /// `suspect`).
    pub healthy_above: u32,
    pub domain: Domain,
    /// The flown check's statistics ([`shared::domain::LoadSigns`]).
    pub load: shared::domain::LoadSigns,
}

/// Runs `seeds` tests of `faults` in `wind` (None: still air). O(seeds) identifications,
/// in parallel.
pub fn wind_runs(
    rm: &ReferenceModel,
    record: &ActuatorRecord,
    faults: FaultVector,
    wind: Option<GroundWind>,
    seeds: u64,
) -> Result<Vec<WindRun>> {
    let rm = rm.with_wind(wind);
    (0..seeds)
        .into_par_iter()
        .map(|seed| one_run(&rm, record, faults, seed))
        .collect()
}

fn one_run(
    rm: &ReferenceModel,
    record: &ActuatorRecord,
    truth: FaultVector,
    seed: u64,
) -> Result<WindRun> {
    let sim = rm.simulate(&Scenario {
        faults: truth,
        current_ref_noise: 0.0,
        seed,
    });
    let params = record.params;
    let measured = sim.trace.measured(&params)?;
    let id = identify_for(&measured, record, 1 + seed, false)?;
    let found = id.result.faults;
    let domain = id.domain(&sim.trace.domain_monitor(&params), &record.domain);
    let healthy = |j: usize| truth.as_array()[j] == FaultVector::NOMINAL.as_array()[j];
    let false_faults = id
        .assessments_at(record.detection_threshold)
        .iter()
        .enumerate()
        .filter(|&(j, a)| *a == Assessment::Faulty && healthy(j))
        .count() as u32;
    let healthy_above = found
        .verdicts_at(record.detection_threshold)
        .iter()
        .enumerate()
        .filter(|&(j, v)| *v == Verdict::Faulty && healthy(j))
        .count() as u32;
    Ok(WindRun {
        e_tot: f64::from(total_error(&found, &truth)),
        false_faults,
        healthy_above,
        domain,
        load: id.load,
    })
}

/// The winds of the campaign: (mean, peak gust) [kt]; (0, 0) is still air.
pub const WINDS: [(f64, f64); 9] = [
    (0.0, 0.0),
    (5.0, 5.0),
    (10.0, 10.0),
    (15.0, 15.0),
    (20.0, 20.0),
    (30.0, 30.0),
    (10.0, 20.0),
    (15.0, 30.0),
    (20.0, 30.0),
];

/// The cases of the campaign: the healthy actuator, three single faults of Table I and two
/// mixes of Table II.
pub const WIND_CASES: [(&str, [f32; shared::FAULT_COUNT]); 6] = [
    ("healthy", *FaultVector::NOMINAL.as_array()),
    (
        "friction k1 = 0.1",
        [0.1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0],
    ),
    (
        "backlash k2 = 1.0",
        [0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0],
    ),
    (
        "short A k3 = 0.2",
        [0.0, 0.0, 0.2, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0],
    ),
    ("Table II medium", TABLE_2[1].faults),
    ("Table II high", TABLE_2[2].faults),
];

/// One row of the campaign: a case in a wind, `runs` seeds.
#[derive(Clone, Debug)]
pub struct WindRow {
    pub case: &'static str,
    pub wind: (f64, f64),
    pub runs: Vec<WindRun>,
}

impl WindRow {
    /// Runs named as a moved load.
    pub fn named(&self) -> usize {
        self.runs.iter().filter(|r| load_moved(&r.domain)).count()
    }
}

/// Whether `d` names a moved load.
pub fn load_moved(d: &Domain) -> bool {
    matches!(
        d,
        Domain::Outside(
            shared::domain::OutsideReason::LoadMoved { .. }
                | shared::domain::OutsideReason::LoadMovedAtRest { .. }
        )
    )
}

/// Every case in every wind, `runs` seeds each; `progress` is told each row as it ends.
pub fn wind_campaign(
    rm: &ReferenceModel,
    record: &ActuatorRecord,
    runs: u64,
    mut progress: impl FnMut(&WindRow),
) -> Result<Vec<WindRow>> {
    let mut rows = Vec::new();
    for (case, faults) in WIND_CASES {
        let truth = FaultVector::new(faults).map_err(|e| anyhow::anyhow!("{case}: {e:?}"))?;
        for wind in WINDS {
            let ground = if wind.0 == 0.0 && wind.1 == 0.0 {
                None
            } else {
                Some(GroundWind::new(wind.0, wind.1).map_err(anyhow::Error::msg)?)
            };
            let row = WindRow {
                case,
                wind,
                runs: wind_runs(rm, record, truth, ground, runs)?,
            };
            progress(&row);
            rows.push(row);
        }
    }
    Ok(rows)
}

/// The campaign as Markdown: per case and wind, the runs named, the others' verdicts and
/// accuracy, then the totals against issue 36's targets.
pub fn wind_markdown(rows: &[WindRow], actuator: &str) -> String {
    let mut text = format!(
        "### Preflight in wind: {actuator}, {} runs per row\n\n\
         Wind: mean / peak gust [kt] on the parked surface (`[surface]`). `named`: runs the \
         domain check put outside as a moved load (`LoadMoved` over the chirp, \
         `LoadMovedAtRest` in the standstill segment); `other outside`: any other reason; \
         then over the runs left `within`: e_tot median and largest [%], their healthy \
         components the FDI calls `FAULT` (its verdict: the whole 90 % interval beyond the \
         detection threshold) and those read beyond the threshold at all (`FAULT` or \
         `suspect`; component-runs); `off > 5 %`: runs whose e_tot is above 5 % \
         and of them named; largest load signs (offset, standstill) over the row.\n\n\
         | case | wind | named | other outside | within: e_tot median / max | within: false FAULT | within: healthy read > threshold | off > 5 %: named / all | largest offset / standstill |\n\
         | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n",
        rows.first().map_or(0, |r| r.runs.len())
    );
    for row in rows {
        let within: Vec<&WindRun> = row
            .runs
            .iter()
            .filter(|r| r.domain == Domain::Within)
            .collect();
        let mut e: Vec<f64> = within.iter().map(|r| r.e_tot).collect();
        e.sort_by(f64::total_cmp);
        let median = e.get(e.len() / 2).copied();
        let max = e.last().copied();
        let other = row.runs.len() - within.len() - row.named();
        let false_faults: u32 = within.iter().map(|r| r.false_faults).sum();
        let healthy_above: u32 = within.iter().map(|r| r.healthy_above).sum();
        let off: Vec<&WindRun> = row.runs.iter().filter(|r| r.e_tot > 5.0).collect();
        let off_named = off.iter().filter(|r| load_moved(&r.domain)).count();
        let offset = row
            .runs
            .iter()
            .map(|r| f64::from(r.load.offset.abs()))
            .fold(0.0, f64::max);
        let standstill = row
            .runs
            .iter()
            .map(|r| f64::from(r.load.standstill))
            .fold(0.0, f64::max);
        let wind = if row.wind.0 == 0.0 {
            "still".to_string()
        } else if row.wind.0 == row.wind.1 {
            format!("{:.0}", row.wind.0)
        } else {
            format!("{:.0} / {:.0}", row.wind.0, row.wind.1)
        };
        let fmt = |v: Option<f64>| v.map_or("–".to_string(), |v| format!("{v:.2}"));
        text.push_str(&format!(
            "| {} | {wind} | {} | {other} | {} / {} | {false_faults} | {healthy_above} | {off_named} / {} | {offset:.4} / {standstill:.4} |\n",
            row.case,
            row.named(),
            fmt(median),
            fmt(max),
            off.len()
        ));
    }
    let windy: Vec<&WindRun> = rows
        .iter()
        .filter(|r| r.wind.0 > 0.0)
        .flat_map(|r| &r.runs)
        .collect();
    let still: Vec<&WindRun> = rows
        .iter()
        .filter(|r| r.wind.0 == 0.0)
        .flat_map(|r| &r.runs)
        .collect();
    let off: Vec<&&WindRun> = windy.iter().filter(|r| r.e_tot > 5.0).collect();
    let off_named = off.iter().filter(|r| load_moved(&r.domain)).count();
    let within_ff = |runs: &[&WindRun]| {
        runs.iter()
            .filter(|r| r.domain == Domain::Within && r.false_faults > 0)
            .count()
    };
    let within_above = |runs: &[&WindRun]| {
        runs.iter()
            .filter(|r| r.domain == Domain::Within && r.healthy_above > 0)
            .count()
    };
    text.push_str(&format!(
        "\nIn wind: {} runs, {} named as a moved load; of the {} runs off by more than 5 %, {} \
         named ({:.0} %); runs left `within` with a healthy component the FDI calls `FAULT`: {} \
         (in still air {} of {}); with one read beyond the threshold (`FAULT` or `suspect`): \
         {} (in still air {}); still-air runs named as a moved load: {}.\n",
        windy.len(),
        windy.iter().filter(|r| load_moved(&r.domain)).count(),
        off.len(),
        off_named,
        100.0 * off_named as f64 / off.len().max(1) as f64,
        within_ff(&windy),
        within_ff(&still),
        still.len(),
        within_above(&windy),
        within_above(&still),
        still.iter().filter(|r| load_moved(&r.domain)).count(),
    ));
    text
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared::domain::LoadSigns;

    fn run(domain: Domain, false_faults: u32, healthy_above: u32) -> WindRun {
        WindRun {
            e_tot: 1.0,
            false_faults,
            healthy_above,
            domain,
            load: LoadSigns {
                offset: 0.0,
                standstill: 0.0,
            },
        }
    }

    /// The table counts the FDI's `FAULT` apart from a reading merely beyond the threshold,
    /// and only over the runs left `within`.
    #[test]
    fn a_suspect_healthy_component_is_not_counted_as_a_false_fault() {
        let named = Domain::Outside(shared::domain::OutsideReason::LoadMoved { offset: 0.02 });
        let rows = [
            WindRow {
                case: "backlash",
                wind: (0.0, 0.0),
                runs: vec![run(Domain::Within, 0, 1), run(Domain::Within, 0, 0)],
            },
            WindRow {
                case: "backlash",
                wind: (5.0, 5.0),
                runs: vec![run(Domain::Within, 1, 2), run(named, 3, 3)],
            },
        ];
        let text = wind_markdown(&rows, "test");
        assert!(
            text.contains("| backlash | still | 0 | 0 | 1.00 / 1.00 | 0 | 1 |"),
            "{text}"
        );
        assert!(
            text.contains("| backlash | 5 | 1 | 0 | 1.00 / 1.00 | 1 | 2 |"),
            "{text}"
        );
        assert!(
            text.contains("calls `FAULT`: 1 (in still air 0 of 2); with one read beyond the threshold (`FAULT` or `suspect`): 1 (in still air 1)"),
            "{text}"
        );
    }
}
