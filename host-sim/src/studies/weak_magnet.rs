//! One weak magnet against an eccentricity, as the FDI reads it (issue 69): the GA and the
//! polish over the nine components, then the weak-magnet search
//! ([`shared::weak_magnet::WeakMagnetSearch`]) on the monitor model that carries the rotor's
//! magnets over the mechanical angle ([`shared::magnets::WeakMagnet`]).
//!
//! Per case and seed the reference model (RM) plays the test and the host's identification
//! (the flown code, [`identify_for`]) reads it. Scored: whether a weak magnet was read, its
//! pole (the RM's pole `k` is centred `k·π/P` from the encoder's zero), its depth, the
//! eccentricity and the uniform loss read, and e_tot over the nine components and the depth
//! ([`shared::metrics::total_error_with_magnets`]; the RM's weak magnet is no uniform loss).
//!
//! Cost: one identification per run (≈ 0.2 s on one core).

use anyhow::Result;
use rayon::prelude::*;
use shared::actuator::ActuatorRecord;
use shared::magnets::WeakMagnet;
use shared::metrics::total_error_with_magnets;
use shared::FAULT_COUNT;

use crate::fdi::identify::identify_for;
use crate::plant::reference::{Demagnetization, Scenario};
use crate::studies::demagnetization::{case, case_model, one_magnet, DemagnetizationCase, HEALTHY};
use crate::studies::grease::Bench;

/// The eccentricity's index in the fault vector (k6) and the uniform loss's (k9).
const ECCENTRICITY: usize = 5;
const UNIFORM_LOSS: usize = 8;

/// One case: the RM's faults, its magnets and its winding's temperature (the
/// demagnetization study's case).
pub type WeakMagnetCase = DemagnetizationCase;

const EVEN: Demagnetization = Demagnetization::None;

const fn eccentric(z: f32, phase: f32) -> [f32; FAULT_COUNT] {
    [0.0, 0.0, 0.0, 0.0, 0.0, z, phase, 0.5, 0.0]
}

/// The cases: healthy, one magnet at four depths and four poles, at the day's temperature
/// and ±60 K, three eccentricities (the search's settings were chosen on these), then
/// [`HELD_OUT`] more on which no choice was made.
pub const CASES: [WeakMagnetCase; 19] = [
    case("healthy", HEALTHY, EVEN, 0.0),
    case("healthy, winding +60 K", HEALTHY, EVEN, 60.0),
    case("healthy, winding −60 K", HEALTHY, EVEN, -60.0),
    case("one magnet, 10 %, pole 0", HEALTHY, one_magnet(0.1, 0), 0.0),
    case("one magnet, 20 %, pole 0", HEALTHY, one_magnet(0.2, 0), 0.0),
    case("one magnet, 50 %, pole 0", HEALTHY, one_magnet(0.5, 0), 0.0),
    case("one magnet, 50 %, pole 3", HEALTHY, one_magnet(0.5, 3), 0.0),
    case(
        "one magnet, 100 %, pole 5",
        HEALTHY,
        one_magnet(1.0, 5),
        0.0,
    ),
    case(
        "one magnet, 20 %, pole 2, +60 K",
        HEALTHY,
        one_magnet(0.2, 2),
        60.0,
    ),
    case(
        "one magnet, 20 %, pole 2, −60 K",
        HEALTHY,
        one_magnet(0.2, 2),
        -60.0,
    ),
    case("eccentricity 0.1", eccentric(0.1, 0.1), EVEN, 0.0),
    case("eccentricity 0.2", eccentric(0.2, 0.3), EVEN, 0.0),
    case("eccentricity 0.5", eccentric(0.5, 0.7), EVEN, 0.0),
    // Held out.
    case(
        "held out: one magnet, 15 %, pole 4",
        HEALTHY,
        one_magnet(0.15, 4),
        0.0,
    ),
    case(
        "held out: one magnet, 30 %, pole 6, +30 K",
        HEALTHY,
        one_magnet(0.3, 6),
        30.0,
    ),
    case(
        "held out: one magnet, 40 %, pole 7, −30 K",
        HEALTHY,
        one_magnet(0.4, 7),
        -30.0,
    ),
    case(
        "held out: one magnet, 70 %, pole 1",
        HEALTHY,
        one_magnet(0.7, 1),
        0.0,
    ),
    case(
        "held out: eccentricity 0.3",
        eccentric(0.3, 0.55),
        EVEN,
        0.0,
    ),
    case("held out: healthy, winding +30 K", HEALTHY, EVEN, 30.0),
];

/// The last cases of [`CASES`], run after the search's settings were chosen.
pub const HELD_OUT: usize = 6;

/// One run: what the FDI read.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WeakMagnetRun {
    /// The weak magnet read ([`WeakMagnet::NONE`]: none) and the pole nearest its centre.
    pub magnets: WeakMagnet,
    pub pole: u32,
    /// The eccentricity (k6) and the uniform loss (k9) read.
    pub eccentricity: f32,
    pub uniform_loss: f32,
    /// e_tot over the nine components and the depth [%].
    pub e_tot: f32,
    /// The reading's fitness [A²·s].
    pub fitness: f32,
}

/// One case's runs.
#[derive(Clone, Debug, PartialEq)]
pub struct WeakMagnetRow {
    pub case: WeakMagnetCase,
    pub runs: Vec<WeakMagnetRun>,
}

impl WeakMagnetRow {
    /// The RM's weak magnet: its depth and pole (`None` without one).
    pub fn played(&self) -> Option<(f32, u32)> {
        match self.case.demagnetization {
            Demagnetization::Partial { loss, pole } => Some((loss as f32, pole)),
            _ => None,
        }
    }

    /// Runs that read a weak magnet.
    pub fn read(&self) -> usize {
        self.runs.iter().filter(|r| !r.magnets.is_none()).count()
    }

    /// Runs that read the RM's weak magnet at its pole.
    pub fn pole_right(&self) -> usize {
        let Some((_, pole)) = self.played() else {
            return 0;
        };
        self.runs
            .iter()
            .filter(|r| !r.magnets.is_none() && r.pole == pole)
            .count()
    }
}

/// Every case with `seeds` seeds on `bench` and its `record`; `progress` is told each case.
pub fn weak_magnet_study(
    bench: &Bench,
    record: &ActuatorRecord,
    seeds: u64,
    mut progress: impl FnMut(&str),
) -> Result<Vec<WeakMagnetRow>> {
    let params = record.params;
    let pitch = shared::magnets::pole_pitch(&params);
    let mut rows = Vec::new();
    for case in CASES {
        progress(case.name);
        let (rm, truth) = case_model(bench, &case)?;
        let played = match case.demagnetization {
            Demagnetization::Partial { loss, pole } => {
                WeakMagnet::new(loss as f32, pitch * pole as f32)
            }
            _ => WeakMagnet::NONE,
        };
        let runs = (0..seeds)
            .into_par_iter()
            .map(|seed| {
                let mut scenario = Scenario::new(truth);
                scenario.seed = seed;
                let sim = rm.simulate(&scenario);
                let measured = sim.trace.measured(&params)?;
                let id = identify_for(&measured, record, 1 + seed, false)?;
                let r = id.result;
                let k = r.faults.as_array();
                Ok(WeakMagnetRun {
                    magnets: r.magnets,
                    pole: r.magnets.pole(&params),
                    eccentricity: k[ECCENTRICITY],
                    uniform_loss: k[UNIFORM_LOSS],
                    e_tot: total_error_with_magnets(&r.faults, &r.magnets, &truth, &played),
                    fitness: r.fitness,
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
         The FDI's reading (GA and polish over nine components, then the weak-magnet search), \
         {seeds} seeds per case. `read`: runs that read a weak magnet; `pole right`: of those, \
         at the reference model's pole; `depth`: mean depth read (over the runs that read one); \
         `eccentricity`, `uniform loss` (k6, k9): mean read; `e_tot`: over the nine components \
         and the depth, mean and worst [%].\n\n\
         | case | read | pole right | depth | eccentricity | uniform loss | e_tot mean / worst [%] |\n\
         | --- | ---: | ---: | ---: | ---: | ---: | ---: |\n"
    );
    for row in rows {
        let n = row.runs.len().max(1) as f32;
        let mean = |f: &dyn Fn(&WeakMagnetRun) -> f32| row.runs.iter().map(f).sum::<f32>() / n;
        let read = row.read();
        let depth = if read == 0 {
            "–".to_string()
        } else {
            let sum: f32 = row
                .runs
                .iter()
                .filter(|r| !r.magnets.is_none())
                .map(|r| r.magnets.depth)
                .sum();
            format!("{:.3}", sum / read as f32)
        };
        let pole = match row.played() {
            Some(_) => format!("{} of {read}", row.pole_right()),
            None => "–".to_string(),
        };
        let worst = row.runs.iter().map(|r| r.e_tot).fold(0.0f32, f32::max);
        text.push_str(&format!(
            "| {} | {read} of {} | {pole} | {depth} | {:.3} | {:.3} | {:.2} / {:.2} |\n",
            row.case.name,
            row.runs.len(),
            mean(&|r| r.eccentricity),
            mean(&|r| r.uniform_loss),
            mean(&|r| r.e_tot),
            worst,
        ));
    }
    text
}
