//! The demagnetization study (issue 35): what the FDI reads on an actuator whose magnets
//! lost flux — uniformly (every pole) or one magnet — against the same actuator whose winding
//! is hot (the magnets' reversible flux change, which the day plays), and whether the test
//! tells the flux from the other faults at all. Its first part measured the eight-component
//! FDI (docs/identifiability.md §0d: the loss read as friction and gain drift, a brute-force
//! profile over the flux finding it); the FDI now carries the ninth component, k9, and this
//! study measures what it reads.
//!
//! Two parts, all on the reference model (RM):
//! * [`demagnetization_study`]: per case, `seeds` RM runs of the healthy actuator with the
//!   magnets' loss, each identified by the flown FDI (GA and polish, the record's
//!   calibration), and again told the flux left (then k9 should read none): 2
//!   identifications per run.
//! * [`weak_magnet_against_eccentricity`] (RM only) and [`flux_cosines`] (monitor model
//!   only): whether the signals can be told apart at all.
//!
//! The cost is the identifications, ≈ 0.2 s each on one core: about a minute for the whole
//! study with 10 seeds.

use anyhow::{anyhow, Result};
use rayon::prelude::*;
use shared::actuator::ActuatorRecord;
use shared::fault::DEMAGNETIZATION_INDEX;
use shared::metrics::{total_error, total_error_all};
use shared::uncertainty::Assessment;
use shared::{FaultVector, FAULT_COUNT};

use crate::fdi::identify::identify_for;
use crate::plant::reference::{Demagnetization, ReferenceModel, ReferenceSettings, Scenario};
use crate::studies::grease::Bench;

/// Components the verdicts are counted over: every one but the eccentricity's phase.
const JUDGED: [usize; 7] = [0, 1, 2, 3, 4, 5, 7];

/// One case of the study: what the reference model plays (faults, the magnets' loss, the
/// winding above the calibration day's).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DemagnetizationCase {
    pub name: &'static str,
    pub faults: [f32; FAULT_COUNT],
    pub demagnetization: Demagnetization,
    /// Winding (and magnet) temperature above the calibration day's [K].
    pub winding_rise: f64,
}

/// The healthy actuator's fault vector.
pub(crate) const HEALTHY: [f32; FAULT_COUNT] = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0];
const NONE: Demagnetization = Demagnetization::None;

/// A case named `name`: the reference model's `faults`, its magnets and its winding's rise.
pub(crate) const fn case(
    name: &'static str,
    faults: [f32; FAULT_COUNT],
    demagnetization: Demagnetization,
    winding_rise: f64,
) -> DemagnetizationCase {
    DemagnetizationCase {
        name,
        faults,
        demagnetization,
        winding_rise,
    }
}

const fn uniform(loss: f64) -> Demagnetization {
    Demagnetization::Uniform { loss }
}

/// One magnet, pole `pole`, that lost `loss` of its flux.
pub(crate) const fn one_magnet(loss: f64, pole: u32) -> Demagnetization {
    Demagnetization::Partial { loss, pole }
}

/// The study's cases: the healthy actuator at the day and hot, each form at three sizes
/// (k9 = 0.1 / 0.2 / 0.5 at the mapping, k9 = 1 for half the flux: a loss of 5, 10
/// and 25 % of every pole's flux, or of one magnet's 10, 20 and 50 %), and a uniform loss
/// on a hot winding.
pub const CASES: [DemagnetizationCase; 10] = [
    case("healthy", HEALTHY, NONE, 0.0),
    case(
        "healthy, winding +60 K (the reversible change only)",
        HEALTHY,
        NONE,
        60.0,
    ),
    case(
        "uniform, 5 % of the flux (k9 0.1)",
        HEALTHY,
        uniform(0.05),
        0.0,
    ),
    case("uniform, 10 % (k9 0.2)", HEALTHY, uniform(0.10), 0.0),
    case("uniform, 25 % (k9 0.5)", HEALTHY, uniform(0.25), 0.0),
    case("uniform, 10 %, winding +60 K", HEALTHY, uniform(0.10), 60.0),
    case(
        "one magnet, 10 % of its flux",
        HEALTHY,
        one_magnet(0.10, 0),
        0.0,
    ),
    case("one magnet, 20 %", HEALTHY, one_magnet(0.20, 0), 0.0),
    case("one magnet, 50 %", HEALTHY, one_magnet(0.50, 0), 0.0),
    case(
        "one magnet, 50 %, another pole (3)",
        HEALTHY,
        one_magnet(0.50, 3),
        0.0,
    ),
];

/// The reference model `case` plays on `bench` (its winding's day, its magnets) and its
/// fault vector.
pub(crate) fn case_model(
    bench: &Bench,
    case: &DemagnetizationCase,
) -> Result<(ReferenceModel, FaultVector)> {
    let mut settings: ReferenceSettings = bench.settings;
    settings.conditions = settings
        .conditions
        .at_temperature(bench.day() + case.winding_rise);
    let rm = ReferenceModel::new(settings)
        .with_test(bench.test)
        .with_demagnetization(case.demagnetization);
    let truth = FaultVector::new(case.faults).map_err(|e| anyhow!("case {}: {e:?}", case.name))?;
    Ok((rm, truth))
}

/// What the FDI read on one case, over its seeds.
#[derive(Clone, Debug, PartialEq)]
pub struct DemagnetizationRow {
    pub case: DemagnetizationCase,
    /// The share of the rotor's flux lost irreversibly (the poles' mean).
    pub flux_lost: f64,
    /// The demagnetization k9 the loss amounts to (the truth of the ninth component; the
    /// others are healthy).
    pub k9: f64,
    /// Mean of each component read.
    pub found: [f64; FAULT_COUNT],
    /// Mean e_tot of the paper's eight components against the healthy vector [%].
    pub e_tot: f64,
    /// Mean e_tot over all nine, k9 against the loss played [%].
    pub e_tot_all: f64,
    /// Healthy components read `FAULT` / `suspect` (7 per run).
    pub faults: usize,
    pub suspects: usize,
    /// Runs the domain check left within (they would be acted on).
    pub within: usize,
    pub runs: usize,
    /// The day's flux scale the FDI estimated from the winding's temperature (mean).
    pub day_flux: f64,
    /// Best fitness, the nominal residual subtracted (mean) [A²·s].
    pub fitness: f64,
    /// Mean e_tot over all nine [%] when the FDI is told the flux left (the calibration's
    /// back-EMF scale times the poles' mean flux; k9's truth is then none): whether one flux
    /// scale in the monitor model explains the loss.
    pub e_tot_told: f64,
}

/// Runs every case with `seeds` seeds on `bench` (its record: calibration and domain).
/// `progress` is told each case as it starts.
pub fn demagnetization_study(
    bench: &Bench,
    record: &ActuatorRecord,
    seeds: u64,
    mut progress: impl FnMut(&str),
) -> Result<Vec<DemagnetizationRow>> {
    let mut rows = Vec::new();
    for case in CASES {
        progress(case.name);
        let (rm, truth) = case_model(bench, &case)?;
        let settings = *rm.settings();
        let pole_pairs = settings.params.pole_pairs as u32;
        let lost = case.demagnetization.truth(&truth, pole_pairs);
        let flux_left = case
            .demagnetization
            .flux_left(settings.params.pole_pairs as u32);
        let told = ActuatorRecord {
            calibration: shared::Calibration {
                back_emf_scale: record.calibration.back_emf_scale * flux_left as f32,
                ..record.calibration
            },
            ..*record
        };
        type Run = (FaultVector, f64, [Assessment; FAULT_COUNT], bool, f32, f64);
        // The ninth component's truth is the loss; told the flux, it is none.
        let runs: Vec<Run> = (0..seeds)
            .into_par_iter()
            .map(|seed| {
                let mut scenario = Scenario::new(truth);
                scenario.seed = seed;
                let sim = rm.simulate(&scenario);
                let measured = sim.trace.measured(&record.params)?;
                let id = identify_for(&measured, record, 1 + seed, false)?;
                let told = identify_for(&measured, &told, 1 + seed, false)?;
                let within = id.domain(&sim.trace.domain_monitor(&record.params), &record.domain)
                    == shared::domain::Domain::Within;
                Ok((
                    id.result.faults,
                    f64::from(id.result.fitness),
                    id.assessments_at(record.detection_threshold),
                    within,
                    id.conditions.flux_scale,
                    f64::from(total_error_all(&told.result.faults, &truth)),
                ))
            })
            .collect::<Result<_>>()?;
        let n = runs.len().max(1) as f64;
        let mut found = [0.0; FAULT_COUNT];
        for (k, ..) in &runs {
            for (f, v) in found.iter_mut().zip(k.as_array()) {
                *f += f64::from(*v) / n;
            }
        }
        let mean_of = |e: &dyn Fn(&FaultVector) -> f32| {
            runs.iter().map(|(k, ..)| f64::from(e(k))).sum::<f64>() / n
        };
        let e_tot = mean_of(&|k| total_error(k, &lost));
        let e_tot_all = mean_of(&|k| total_error_all(k, &lost));
        let (mut faults, mut suspects) = (0, 0);
        for (_, _, a, ..) in &runs {
            for i in JUDGED {
                match a[i] {
                    Assessment::Faulty => faults += 1,
                    Assessment::Suspect | Assessment::Ambiguous { .. } => suspects += 1,
                    _ => {}
                }
            }
        }
        let fitness = runs.iter().map(|r| r.1).sum::<f64>() / n;
        rows.push(DemagnetizationRow {
            case,
            k9: f64::from(lost.demagnetization()),
            e_tot_all,
            flux_lost: 1.0
                - case
                    .demagnetization
                    .flux_left(settings.params.pole_pairs as u32),
            found,
            e_tot,
            faults,
            suspects,
            within: runs.iter().filter(|r| r.3).count(),
            runs: runs.len(),
            day_flux: runs.iter().map(|r| f64::from(r.4)).sum::<f64>() / n,
            fitness,
            e_tot_told: runs.iter().map(|r| r.5).sum::<f64>() / n,
        });
    }
    if rows.is_empty() {
        return Err(anyhow!("no case ran"));
    }
    Ok(rows)
}

/// On the reference model (noise-free truth currents, the bench's test): the cosine between
/// the equivalent current's change with one weak magnet (pole `pole` at 10 % loss) and with
/// a small eccentricity (k6 0.1) at each of `phases` phases around the stator, the largest
/// and where: whether the physics itself tells a weak magnet from an off-centre rotor on
/// this test. Also the rotor's travel over the test [mechanical revolutions]: a weak magnet
/// is fixed to the rotor, an eccentricity to the stator, and only a rotor that turns shows
/// which. O(phases) reference-model runs.
pub fn weak_magnet_against_eccentricity(
    bench: &Bench,
    pole: u32,
    phases: usize,
) -> (f64, f64, f64) {
    let rm = |d: Demagnetization| {
        ReferenceModel::new(bench.settings)
            .with_test(bench.test)
            .with_demagnetization(d)
    };
    let p = bench.settings.params.pole_pairs;
    let current = |sim: &crate::plant::reference::Simulation| -> Vec<f64> {
        sim.truth
            .iter()
            .map(|t| {
                let signs = shared::conditioning::commutation_signs(p * t.motor_angle as f32);
                0.5 * (0..3)
                    .map(|x| f64::from(signs[x]) * t.phase_currents[x])
                    .sum::<f64>()
            })
            .collect()
    };
    let healthy_sim = rm(Demagnetization::None).simulate(&Scenario::new(FaultVector::NOMINAL));
    let healthy = current(&healthy_sim);
    let (lo, hi) = healthy_sim
        .truth
        .iter()
        .fold((f64::MAX, f64::MIN), |(l, h), t| {
            (l.min(t.motor_angle), h.max(t.motor_angle))
        });
    let travel = (hi - lo) / std::f64::consts::TAU;
    let column = |v: Vec<f64>| -> Vec<f64> { v.iter().zip(&healthy).map(|(a, b)| a - b).collect() };
    let weak = column(current(
        &rm(Demagnetization::Partial { loss: 0.1, pole })
            .simulate(&Scenario::new(FaultVector::NOMINAL)),
    ));
    let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    let (mut best, mut at) = (0.0f64, 0.0f64);
    for j in 0..phases {
        let phase = j as f32 / phases as f32;
        let mut k = *FaultVector::NOMINAL.as_array();
        k[5] = 0.1;
        k[6] = phase;
        let Ok(k) = FaultVector::new(k) else { continue };
        let ecc = column(current(
            &rm(Demagnetization::None).simulate(&Scenario::new(k)),
        ));
        let cos =
            weak.iter().zip(&ecc).map(|(a, b)| a * b).sum::<f64>() / (norm(&weak) * norm(&ecc));
        if cos.abs() > best.abs() {
            (best, at) = (cos, f64::from(phase));
        }
    }
    (best, at, travel)
}

/// On the monitor model, at the healthy actuator: the cosine between the equivalent
/// current's change with the magnets' flux (the back-EMF scale, h = 2 %) and its change with
/// each fault component (one-sided from nominal, h = 0.02; the eccentricity's phase at an
/// eccentricity of 0.2). Near 1 in magnitude: one test cannot tell the flux from that
/// component; the GA would trade one for the other.
pub fn flux_cosines(record: &ActuatorRecord) -> [f64; FAULT_COUNT] {
    let test = record.test;
    let run = |k: &FaultVector, flux: f32| {
        let calibration = shared::Calibration {
            back_emf_scale: record.calibration.back_emf_scale * flux,
            ..record.calibration
        };
        let model = shared::MonitorModel::new(record.params, &calibration).with_test(&test);
        let mut out = vec![0.0f32; model.test_samples()];
        model.simulate(k, &mut out);
        out.into_iter().map(f64::from).collect::<Vec<f64>>()
    };
    let nominal = FaultVector::NOMINAL;
    let base = run(&nominal, 1.0);
    let column =
        |other: &[f64]| -> Vec<f64> { other.iter().zip(&base).map(|(a, b)| a - b).collect() };
    let flux = column(&run(&nominal, 0.98));
    let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    let mut out = [0.0; FAULT_COUNT];
    for (i, cos) in out.iter_mut().enumerate() {
        let mut k = *nominal.as_array();
        let mut from = k;
        if i == 6 {
            from[5] = 0.2;
            k[5] = 0.2;
        }
        k[i] += 0.02;
        let (Ok(k), Ok(from)) = (FaultVector::new(k), FaultVector::new(from)) else {
            continue;
        };
        let a = run(&k, 1.0);
        let b = run(&from, 1.0);
        let col: Vec<f64> = a.iter().zip(&b).map(|(x, y)| x - y).collect();
        let (nf, nc) = (norm(&flux), norm(&col));
        if nf > 0.0 && nc > 0.0 {
            *cos = flux.iter().zip(&col).map(|(x, y)| x * y).sum::<f64>() / (nf * nc);
        }
    }
    out
}

/// The rows as a markdown table.
pub fn demagnetization_markdown(
    actuator: &str,
    rows: &[DemagnetizationRow],
    cosines: &[f64; FAULT_COUNT],
    seeds: u64,
) -> String {
    let mut text = format!(
        "### {actuator}\n\n\
         The healthy actuator with demagnetized magnets, {seeds} seeds per case, identified \
         by the nine-component FDI (the built-in calibration, injection test, real bridge). \
         The eight paper components' truth is healthy: whatever they read is the magnets' \
         loss read as something else; k9's truth is the mean flux lost (k9 = 2 × the share). \
         `e_tot`: over the paper's eight, then over all nine; `FAULT / suspect`: on the \
         eight's healthy components; `day flux`: the flux scale the FDI took from the \
         winding's estimated temperature (the reversible part the day plays); `fitness`: the \
         best fitness, the nominal residual subtracted [A²·s] (the domain's floor: \
         `[domain] max_fitness`); `told`: e_tot of all nine when the FDI is told the flux \
         left (its back-EMF scale times the poles' mean flux; k9 should then read none): \
         what one flux scale in the monitor model can explain.\n\n\
         | case | flux lost | k9 played | k9 read | friction | backlash | short A | short B | short C | eccentricity | gain drift | e_tot of 8 / of 9 [%] | FAULT / suspect (of {}) | within | day flux | fitness | told: e_tot of 9 [%] |\n\
         | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n",
        7 * seeds
    );
    for r in rows {
        let f = r.found;
        text.push_str(&format!(
            "| {} | {:.1} % | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.2} / {:.2} | {} / {} | {} of {} | ×{:.4} | {:.2e} | {:.2} |\n",
            r.case.name,
            100.0 * r.flux_lost,
            r.k9,
            f[DEMAGNETIZATION_INDEX],
            f[0],
            f[1],
            f[2],
            f[3],
            f[4],
            f[5],
            f[7],
            r.e_tot,
            r.e_tot_all,
            r.faults,
            r.suspects,
            r.within,
            r.runs,
            r.day_flux,
            r.fitness,
            r.e_tot_told
        ));
    }
    text.push_str(
        "\nOn the monitor model at the healthy actuator, the cosine between the current's \
         change with the magnets' flux and with each component (`flux_cosines`; ±1: the test \
         cannot tell them apart):\n\n\
         | friction | backlash | short A | short B | short C | eccentricity | its phase | gain drift | demagnetization (the flux itself) |\n\
         | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n",
    );
    let cells: Vec<String> = cosines.iter().map(|c| format!("{c:+.3}")).collect();
    text.push_str(&format!("| {} |\n", cells.join(" | ")));
    text
}
