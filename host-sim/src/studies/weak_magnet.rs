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
use shared::uncertainty::Assessment;
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
pub const CASES: [WeakMagnetCase; 22] = [
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
    // Held out, between the search's depth steps (0.05 apart).
    case(
        "held out: one magnet, 12 %, pole 6",
        HEALTHY,
        one_magnet(0.12, 6),
        0.0,
    ),
    case(
        "held out: one magnet, 33 %, pole 5",
        HEALTHY,
        one_magnet(0.33, 5),
        0.0,
    ),
    case(
        "held out: one magnet, 62 %, pole 2, −45 K",
        HEALTHY,
        one_magnet(0.62, 2),
        -45.0,
    ),
];

/// The last cases of [`CASES`], run after the search's settings were chosen (the last three
/// between the search's depth steps).
pub const HELD_OUT: usize = 9;

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
    /// The depth's standard deviation (`shared::uncertainty::depth_deviation`; NaN without
    /// a magnet) and the magnet's verdict against the record's threshold.
    pub std: f32,
    pub verdict: Assessment,
}

impl WeakMagnetRun {
    /// The least inflation of the depth's Gauss–Newton deviation
    /// (`shared::uncertainty::DEPTH_INFLATION`, the grid's deviation beside it as it is) with
    /// which this read's 90 % interval holds the truth ([`Self::truth`]); `None` where there
    /// is none.
    pub fn inflation_needed(&self, played: Option<(f32, u32)>) -> Option<f64> {
        let truth = self.truth(played)?;
        let q2 = f64::from(shared::uncertainty::DEPTH_QUANTIZATION).powi(2);
        let gauss_newton = (f64::from(self.std).powi(2) - q2).max(0.0).sqrt()
            / f64::from(shared::uncertainty::DEPTH_INFLATION);
        let half =
            f64::from(self.magnets.depth - truth).abs() / f64::from(shared::uncertainty::Z90);
        Some(((half * half - q2).max(0.0)).sqrt() / gauss_newton)
    }

    /// The depth this read is scored against: the `played` loss where the pole is right, 0
    /// elsewhere (a magnet read where none is weak). `None` without a magnet read or a
    /// deviation.
    fn truth(&self, played: Option<(f32, u32)>) -> Option<f32> {
        if self.magnets.is_none() || !self.std.is_finite() {
            return None;
        }
        Some(match played {
            Some((loss, pole)) if pole == self.pole => loss,
            _ => 0.0,
        })
    }

    /// Whether the depth's 90 % interval holds the truth ([`Self::truth`]); `None` where
    /// there is none.
    pub fn covers(&self, played: Option<(f32, u32)>) -> Option<bool> {
        let truth = self.truth(played)?;
        let (lo, hi) = shared::uncertainty::magnet_interval(self.magnets.depth, self.std);
        Some(lo <= truth && truth <= hi)
    }
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
                    std: id.magnet_std(),
                    verdict: id.magnet_assessment_at(record.detection_threshold),
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
         and the depth, mean and worst [%]; `verdict`: the magnet's, FAULT / suspect of the \
         runs (the rest healthy: none read, or the depth within the threshold); `σ`: the \
         depth's mean standard deviation; `interval`: the runs whose 90 % interval of the \
         depth holds the truth (the played loss at its pole, 0 elsewhere), of those that read \
         a magnet.\n\n\
         | case | read | pole right | depth | eccentricity | uniform loss | e_tot mean / worst [%] | verdict FAULT / suspect | σ | interval |\n\
         | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n"
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
        let verdicts = |a: Assessment| row.runs.iter().filter(|r| r.verdict == a).count();
        let stated: Vec<f32> = row
            .runs
            .iter()
            .map(|r| r.std)
            .filter(|s| s.is_finite())
            .collect();
        let sigma = if stated.is_empty() {
            "–".to_string()
        } else {
            format!("{:.3}", stated.iter().sum::<f32>() / stated.len() as f32)
        };
        let covers: Vec<bool> = row
            .runs
            .iter()
            .filter_map(|r| r.covers(row.played()))
            .collect();
        let interval = if covers.is_empty() {
            "–".to_string()
        } else {
            format!(
                "{} of {}",
                covers.iter().filter(|&&c| c).count(),
                covers.len()
            )
        };
        text.push_str(&format!(
            "| {} | {read} of {} | {pole} | {depth} | {:.3} | {:.3} | {:.2} / {:.2} | {} / {} | {sigma} | {interval} |\n",
            row.case.name,
            row.runs.len(),
            mean(&|r| r.eccentricity),
            mean(&|r| r.uniform_loss),
            mean(&|r| r.e_tot),
            worst,
            verdicts(Assessment::Faulty),
            verdicts(Assessment::Suspect),
        ));
    }
    let needed = |rows: &[WeakMagnetRow]| {
        let mut z: Vec<f64> = rows
            .iter()
            .flat_map(|row| {
                row.runs
                    .iter()
                    .filter_map(|r| r.inflation_needed(row.played()))
            })
            .collect();
        z.sort_by(f64::total_cmp);
        let at = ((z.len() as f64 * 0.9).ceil() as usize).saturating_sub(1);
        (z.get(at).copied().unwrap_or(f64::NAN), z.len())
    };
    let split = rows.len().saturating_sub(HELD_OUT);
    let (chosen, n_chosen) = needed(rows.get(..split).unwrap_or_default());
    let (held, n_held) = needed(rows.get(split..).unwrap_or_default());
    text.push_str(&format!(
        "\nThe depth's deviation is its curvature's taken {} times \
         (`shared::uncertainty::DEPTH_INFLATION`) with the search's grid's {:.4} in quadrature. \
         The inflation with which 90 % of the depth's intervals would hold the truth: \
         {chosen:.2} over the {n_chosen} reads of the cases above the held-out ones, \
         {held:.2} over the {n_held} held-out reads.\n",
        shared::uncertainty::DEPTH_INFLATION,
        shared::uncertainty::DEPTH_QUANTIZATION,
    ));
    text
}
