//! One weak magnet against an eccentricity, read by the monitor model that carries the
//! rotor's magnets over the mechanical angle ([`shared::magnets::WeakMagnet`], issue 69).
//!
//! Per case and seed: the reference model (RM) plays the test, the flown FDI reads it (GA,
//! polish: nine components, an eccentricity where the physics is a weak magnet), then the
//! weak-magnet hypothesis is searched on the same fitness: the FDI's vector with its
//! eccentricity taken off and its uniform loss lowered by the weak magnet's mean, over
//! [`POSITIONS_PER_POLE`] centres per pole and [`DEPTHS`] depths. Whichever explains the
//! measured current better (the lower fitness) is what this study calls the reading.
//!
//! A study, not the product: the FDI's fault vector has no weak-magnet components yet, and
//! the search holds the other components where the GA put them.
//!
//! Cost: one identification (≈ 0.2 s) and 2P·[`POSITIONS_PER_POLE`]·[`DEPTHS`] model runs
//! (≈ 0.1 ms each) per run, on one core each.

use anyhow::{anyhow, Result};
use rayon::prelude::*;
use shared::actuator::ActuatorRecord;
use shared::fault::{DEMAGNETIZATION_INDEX, DEMAGNETIZATION_LOSS_MAX};
use shared::fdi::Identification;
use shared::magnets::WeakMagnet;
use shared::polish::PolishSettings;
use shared::{FaultVector, FAULT_COUNT};

use crate::fdi::identify::{command_table, onboard_identification};
use crate::plant::reference::{Demagnetization, ReferenceModel, Scenario};
use crate::studies::grease::Bench;

/// Candidate centres per pole pitch.
pub const POSITIONS_PER_POLE: usize = 4;

/// Candidate depths (share of the magnet's flux lost).
pub const DEPTHS: [f32; 10] = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0];

/// The eccentricity's index in the fault vector (k6).
const ECCENTRICITY: usize = 5;

/// One case: the RM's faults, its magnets and its winding's temperature.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WeakMagnetCase {
    pub name: &'static str,
    pub faults: [f32; FAULT_COUNT],
    pub demagnetization: Demagnetization,
    /// Winding (and magnet) temperature above the calibration day's [K].
    pub winding_rise: f64,
}

const HEALTHY: [f32; FAULT_COUNT] = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0];
const EVEN: Demagnetization = Demagnetization::None;

const fn case(
    name: &'static str,
    faults: [f32; FAULT_COUNT],
    demagnetization: Demagnetization,
    winding_rise: f64,
) -> WeakMagnetCase {
    WeakMagnetCase {
        name,
        faults,
        demagnetization,
        winding_rise,
    }
}

const fn eccentric(z: f32, phase: f32) -> [f32; FAULT_COUNT] {
    [0.0, 0.0, 0.0, 0.0, 0.0, z, phase, 0.5, 0.0]
}

const fn one_magnet(loss: f64, pole: u32) -> Demagnetization {
    Demagnetization::Partial { loss, pole }
}

/// The cases: healthy, one magnet at four depths and four poles, at the day's temperature
/// and ±60 K, three eccentricities.
pub const CASES: [WeakMagnetCase; 13] = [
    case("healthy", HEALTHY, EVEN, 0.0),
    case("healthy, winding +60 K", HEALTHY, EVEN, 60.0),
    case("healthy, winding −60 K", HEALTHY, EVEN, -60.0),
    case("one magnet, 10 %, pole 0", HEALTHY, one_magnet(0.1, 0), 0.0),
    case("one magnet, 20 %, pole 0", HEALTHY, one_magnet(0.2, 0), 0.0),
    case("one magnet, 50 %, pole 0", HEALTHY, one_magnet(0.5, 0), 0.0),
    case("one magnet, 50 %, pole 3", HEALTHY, one_magnet(0.5, 3), 0.0),
    case("one magnet, 100 %, pole 5", HEALTHY, one_magnet(1.0, 5), 0.0),
    case("one magnet, 20 %, pole 2, +60 K", HEALTHY, one_magnet(0.2, 2), 60.0),
    case("one magnet, 20 %, pole 2, −60 K", HEALTHY, one_magnet(0.2, 2), -60.0),
    case("eccentricity 0.1", eccentric(0.1, 0.1), EVEN, 0.0),
    case("eccentricity 0.2", eccentric(0.2, 0.3), EVEN, 0.0),
    case("eccentricity 0.5", eccentric(0.5, 0.7), EVEN, 0.0),
];

/// One run: what the FDI read and what the weak-magnet search found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WeakMagnetRun {
    /// The FDI's eccentricity (k6) and its fitness [A²·s].
    pub eccentricity: f32,
    pub fdi_fitness: f32,
    /// The best weak magnet: its centre [rad], the pole that centre is nearest (its centre
    /// `pole·π/P`), its depth, and the fitness [A²·s].
    pub centre: f32,
    pub pole: u32,
    pub depth: f32,
    pub weak_fitness: f32,
}

impl WeakMagnetRun {
    /// Whether the weak magnet explains the current better than the FDI's eccentricity.
    pub fn weak_wins(&self) -> bool {
        self.weak_fitness < self.fdi_fitness
    }
}

/// One case's runs.
#[derive(Clone, Debug, PartialEq)]
pub struct WeakMagnetRow {
    pub case: WeakMagnetCase,
    pub runs: Vec<WeakMagnetRun>,
}

/// The FDI's vector `k` with its eccentricity off and its uniform loss lowered by what a
/// weak magnet of `depth` takes on average (`depth/(2P)` of the flux), clamped to [0, 1].
fn without_eccentricity(k: &FaultVector, depth: f32, pole_pairs: f32) -> FaultVector {
    let mut a = *k.as_array();
    if let Some(z) = a.get_mut(ECCENTRICITY) {
        *z = 0.0;
    }
    if let Some(k9) = a.get_mut(DEMAGNETIZATION_INDEX) {
        let flux = 1.0 - DEMAGNETIZATION_LOSS_MAX * *k9;
        let mean_kept = 1.0 - depth / (2.0 * pole_pairs.max(1.0));
        *k9 = ((1.0 - flux / mean_kept) / DEMAGNETIZATION_LOSS_MAX).clamp(0.0, 1.0);
    }
    FaultVector::saturating(a)
}

/// The best weak magnet for the FDI's reading `k` on `id`'s problem. O(2P·positions·depths)
/// model runs.
fn search<const N: usize, const P: usize>(
    id: &Identification<'_, N, P>,
    record: &ActuatorRecord,
    k: &FaultVector,
) -> (f32, u32, f32, f32) {
    let params = &record.params;
    let pole_pairs = params.pole_pairs.max(1.0);
    let poles = (2.0 * pole_pairs).round() as usize;
    let pitch = std::f32::consts::PI / pole_pairs;
    let mut best = (0.0f32, 0u32, 0.0f32, f32::INFINITY);
    for j in 0..poles * POSITIONS_PER_POLE {
        let centre = pitch * j as f32 / POSITIONS_PER_POLE as f32;
        for depth in DEPTHS {
            let candidate = without_eccentricity(k, depth, pole_pairs);
            let fitness = id
                .problem()
                .error_with_magnets(&candidate, WeakMagnet::new(params, depth, centre));
            if fitness < best.3 {
                let pole = (centre / pitch).round() as u32 % poles as u32;
                best = (centre, pole, depth, fitness);
            }
        }
    }
    best
}

/// Every case with `seeds` seeds on `bench` and its `record`; `progress` is told each case.
pub fn weak_magnet_study(
    bench: &Bench,
    record: &ActuatorRecord,
    seeds: u64,
    mut progress: impl FnMut(&str),
) -> Result<Vec<WeakMagnetRow>> {
    let mut rows = Vec::new();
    for case in CASES {
        progress(case.name);
        let mut settings = bench.settings;
        settings.conditions = settings
            .conditions
            .at_temperature(bench.day() + case.winding_rise);
        let rm = ReferenceModel::new(settings)
            .with_test(bench.test)
            .with_demagnetization(case.demagnetization);
        let truth =
            FaultVector::new(case.faults).map_err(|e| anyhow!("case {}: {e:?}", case.name))?;
        let runs = (0..seeds)
            .into_par_iter()
            .map(|seed| {
                let mut scenario = Scenario::new(truth);
                scenario.seed = seed;
                let sim = rm.simulate(&scenario);
                let measured = sim.trace.measured(&record.params)?;
                let table = command_table(&measured, record);
                let mut id =
                    onboard_identification(&measured, record, record.ga, 1 + seed, &table)?;
                let _ = id.step(u32::MAX);
                let mut curvature = Box::new(shared::fitness::CurvatureRun::IDLE);
                let fdi = id.polished(PolishSettings::FDI, &mut curvature);
                let (centre, pole, depth, weak_fitness) = search(&id, record, &fdi.faults);
                Ok(WeakMagnetRun {
                    eccentricity: fdi.faults.as_array()[ECCENTRICITY],
                    fdi_fitness: fdi.fitness,
                    centre,
                    pole,
                    depth,
                    weak_fitness,
                })
            })
            .collect::<Result<Vec<_>>>()?;
        rows.push(WeakMagnetRow { case, runs });
    }
    Ok(rows)
}

/// The study's Markdown table for actuator `name`.
pub fn weak_magnet_markdown(name: &str, rows: &[WeakMagnetRow], seeds: u64) -> String {
    let mut text = format!(
        "### {name}\n\n\
         The flown FDI's reading (nine components, GA and polish) against the best weak magnet \
         on the same fitness ({POSITIONS_PER_POLE} centres per pole, depths 0.1 … 1.0; the \
         FDI's vector with its eccentricity off and its uniform loss lowered by the magnet's \
         mean), {seeds} seeds per case. `weak wins`: runs whose weak magnet explains the \
         current better; `pole`: the poles the winning weak magnets sat nearest; `depth`: \
         their mean depth.\n\n\
         | case | FDI eccentricity | FDI fitness | weak magnet's fitness | weak wins | pole | depth |\n\
         | --- | ---: | ---: | ---: | ---: | --- | ---: |\n"
    );
    for row in rows {
        let n = row.runs.len().max(1) as f32;
        let mean = |f: &dyn Fn(&WeakMagnetRun) -> f32| row.runs.iter().map(f).sum::<f32>() / n;
        let winners: Vec<&WeakMagnetRun> = row.runs.iter().filter(|r| r.weak_wins()).collect();
        let poles = winners
            .iter()
            .map(|r| r.pole.to_string())
            .collect::<Vec<_>>()
            .join(" ");
        let depth = if winners.is_empty() {
            "–".to_string()
        } else {
            format!(
                "{:.2}",
                winners.iter().map(|r| r.depth).sum::<f32>() / winners.len() as f32
            )
        };
        text.push_str(&format!(
            "| {} | {:.3} | {:.3e} | {:.3e} | {} of {} | {} | {} |\n",
            row.case.name,
            mean(&|r| r.eccentricity),
            mean(&|r| r.fdi_fitness),
            mean(&|r| r.weak_fitness),
            winners.len(),
            row.runs.len(),
            if poles.is_empty() { "–" } else { &poles },
            depth,
        ));
    }
    text
}
