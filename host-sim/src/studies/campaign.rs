//! Accuracy campaigns: the paper's fault cases (SPEC §7) simulated by the reference model and
//! identified by the onboard FDI, `runs` seeds per case, in parallel (rayon) over all runs.
//!
//! Run `r` of a case uses reference-model seed `r` (sensor and process noise) and GA seed
//! `1 + r`. One run = one RM simulation (≈ 0.05 s) + one identification (≈ 1.5 s).

use std::fmt::Write as _;
use std::path::Path;

use anyhow::{anyhow, Result};
use rayon::prelude::*;
use shared::actuator::ActuatorRecord;
use shared::fault::{
    CIRCULAR, DEMAGNETIZATION_INDEX, DEMAGNETIZATION_LOSS_MAX, DETECTION_THRESHOLD,
};
use shared::fault::{FAULT_COUNT, PAPER_FAULT_COUNT};
use shared::metrics::{total_error, total_error_all};
use shared::uncertainty::{
    preflight_systematic, reads_play, Assessment, SystematicError, Uncertainty,
};
use shared::FaultVector;

use crate::fdi::identify::identify_for;
use crate::files::actuator::Actuator;
use crate::plant::reference::{Demagnetization, ReferenceModel, Scenario};
use shared::magnets::WeakMagnet;

/// What the paper reports for a case.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PaperValue {
    /// Mean e_tot [%] from the paper's Table I.
    Mean(f64),
    /// Table II is garbled in the paper; the text gives a range [%].
    About(&'static str),
    /// No paper value (our own rows).
    None,
}

/// One case of a campaign.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Case {
    pub name: &'static str,
    pub faults: [f32; FAULT_COUNT],
    /// I_ref noise, fraction of the nominal I_ref RMS.
    pub noise: f64,
    pub paper: PaperValue,
    /// Our target for the mean e_tot [%] (`None` for the healthy row).
    pub target: Option<f64>,
    /// The healthy row reports the largest identified fault component instead of e_tot.
    pub healthy: bool,
    /// How the reference model plays the case's demagnetization k9.
    pub magnets: MagnetForm,
    /// The whole actuator this far from the calibration's temperature [K] (the day's
    /// reversible flux and copper; the record and its calibration are unchanged).
    pub winding_rise: f64,
}

/// How the reference model plays a case's demagnetization k9 (the truth the FDI is scored
/// against is k9 itself: the mean flux lost).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MagnetForm {
    /// Every pole lost the same share (thermal).
    Uniform,
    /// One magnet (pole 0) lost all of it: `2P·0.5·k9` of its flux, its back-EMF dipping once
    /// per mechanical revolution. One magnet cannot lose more than itself: k9 ≤ 1/P.
    OneMagnet,
}

const fn single(index: usize, value: f32) -> [f32; FAULT_COUNT] {
    let mut k = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0];
    k[index] = value;
    k
}

const fn case(name: &'static str, faults: [f32; FAULT_COUNT], paper: f64, target: f64) -> Case {
    Case {
        name,
        faults,
        noise: 0.0,
        paper: PaperValue::Mean(paper),
        target: Some(target),
        healthy: false,
        magnets: MagnetForm::Uniform,
        winding_rise: 0.0,
    }
}

/// Eccentricity cases are at φ = 0 (k7 = 0.5).
pub const TABLE_1: [Case; 16] = [
    case("friction k1 = 0.1", single(0, 0.1), 1.16, 1.16),
    case("friction k1 = 0.4", single(0, 0.4), 1.13, 1.13),
    case("friction k1 = 1.0", single(0, 1.0), 4.54, 4.54),
    case("backlash k2 = 0.1", single(1, 0.1), 0.61, 0.61),
    case("backlash k2 = 0.4", single(1, 0.4), 1.72, 1.72),
    case("backlash k2 = 1.0", single(1, 1.0), 1.04, 1.04),
    case("short A k3 = 0.1", single(2, 0.1), 0.88, 0.88),
    case("short A k3 = 0.2", single(2, 0.2), 1.30, 1.30),
    case("short A k3 = 0.5", single(2, 0.5), 1.53, 1.53),
    case("eccentricity k6 = 0.1", single(5, 0.1), 1.39, 1.39),
    case("eccentricity k6 = 0.2", single(5, 0.2), 8.33, 2.0),
    case("eccentricity k6 = 0.5", single(5, 0.5), 3.43, 3.43),
    case("gain drift k8 = 0.4", single(7, 0.4), 0.72, 0.72),
    case("gain drift k8 = 0.6", single(7, 0.6), 1.80, 1.80),
    case("gain drift k8 = 0.0", single(7, 0.0), 3.90, 3.90),
    case("gain drift k8 = 1.0", single(7, 1.0), 1.44, 1.44),
];

/// Table II's medium case.
pub const MEDIUM: [f32; FAULT_COUNT] = [0.4, 0.4, 0.2, 0.1, 0.05, 0.2, 0.75, 0.6, 0.0];

pub const TABLE_2: [Case; 4] = [
    Case {
        name: "low",
        faults: [0.1, 0.1, 0.1, 0.05, 0.0, 0.1, 0.25, 0.4, 0.0],
        noise: 0.0,
        paper: PaperValue::About("≈ 1–2"),
        target: Some(2.0),
        healthy: false,
        magnets: MagnetForm::Uniform,
        winding_rise: 0.0,
    },
    Case {
        name: "medium",
        faults: MEDIUM,
        noise: 0.0,
        paper: PaperValue::About("≈ 1–2"),
        target: Some(2.0),
        healthy: false,
        magnets: MagnetForm::Uniform,
        winding_rise: 0.0,
    },
    Case {
        name: "high",
        faults: [1.0, 1.0, 0.5, 0.3, 0.1, 0.5, 0.1, 0.0, 0.0],
        noise: 0.0,
        paper: PaperValue::About("≈ 7"),
        target: Some(5.0),
        healthy: false,
        magnets: MagnetForm::Uniform,
        winding_rise: 0.0,
    },
    Case {
        name: "medium + noise 50 %",
        faults: MEDIUM,
        noise: 0.5,
        paper: PaperValue::About("≈ 2"),
        target: Some(3.0),
        healthy: false,
        magnets: MagnetForm::Uniform,
        winding_rise: 0.0,
    },
];

/// The healthy actuator with I_ref noise: no component may exceed 0.03.
pub const HEALTHY: Case = Case {
    name: "healthy + noise 50 %",
    faults: [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0],
    noise: 0.5,
    paper: PaperValue::None,
    target: Some(3.0),
    healthy: true,
    magnets: MagnetForm::Uniform,
    winding_rise: 0.0,
};

/// The healthy actuator without process noise: the false-alarm row of the robustness grid.
pub const HEALTHY_QUIET: Case = Case {
    name: "healthy",
    noise: 0.0,
    ..HEALTHY
};

/// Largest allowed identified component on a healthy actuator.
pub const FALSE_ALARM_LIMIT: f64 = 0.03;

const fn demagnetized(
    name: &'static str,
    faults: [f32; FAULT_COUNT],
    magnets: MagnetForm,
    winding_rise: f64,
) -> Case {
    Case {
        name,
        faults,
        noise: 0.0,
        paper: PaperValue::None,
        target: Some(2.0),
        healthy: false,
        magnets,
        winding_rise,
    }
}

const fn healthy_at(name: &'static str, winding_rise: f64) -> Case {
    Case {
        name,
        noise: 0.0,
        winding_rise,
        ..HEALTHY
    }
}

/// k9 with short A at k3.
const fn with_short(k9: f32, k3: f32) -> [f32; FAULT_COUNT] {
    let mut k = single(DEMAGNETIZATION_INDEX, k9);
    k[2] = k3;
    k
}

/// The ninth fault (issue 35): demagnetization in both forms, mixed with a short, on the
/// robustness grid's days (−60 … +60 K from the calibration's), and the rows that must not
/// read as it (a short, the day).
pub const DEMAGNETIZATION: [Case; 17] = [
    demagnetized(
        "uniform k9 = 0.1",
        single(DEMAGNETIZATION_INDEX, 0.1),
        MagnetForm::Uniform,
        0.0,
    ),
    demagnetized(
        "uniform k9 = 0.2",
        single(DEMAGNETIZATION_INDEX, 0.2),
        MagnetForm::Uniform,
        0.0,
    ),
    demagnetized(
        "uniform k9 = 0.5",
        single(DEMAGNETIZATION_INDEX, 0.5),
        MagnetForm::Uniform,
        0.0,
    ),
    demagnetized(
        "one magnet k9 = 0.1",
        single(DEMAGNETIZATION_INDEX, 0.1),
        MagnetForm::OneMagnet,
        0.0,
    ),
    demagnetized(
        "one magnet k9 = 0.2",
        single(DEMAGNETIZATION_INDEX, 0.2),
        MagnetForm::OneMagnet,
        0.0,
    ),
    demagnetized(
        "uniform k9 = 0.2 + short A k3 = 0.2",
        with_short(0.2, 0.2),
        MagnetForm::Uniform,
        0.0,
    ),
    demagnetized(
        "uniform k9 = 0.2 at +60 K",
        single(DEMAGNETIZATION_INDEX, 0.2),
        MagnetForm::Uniform,
        60.0,
    ),
    demagnetized(
        "uniform k9 = 0.1 at −60 K",
        single(DEMAGNETIZATION_INDEX, 0.1),
        MagnetForm::Uniform,
        -60.0,
    ),
    demagnetized(
        "uniform k9 = 0.1 at −30 K",
        single(DEMAGNETIZATION_INDEX, 0.1),
        MagnetForm::Uniform,
        -30.0,
    ),
    demagnetized(
        "uniform k9 = 0.1 at +30 K",
        single(DEMAGNETIZATION_INDEX, 0.1),
        MagnetForm::Uniform,
        30.0,
    ),
    demagnetized("short A k3 = 0.2", single(2, 0.2), MagnetForm::Uniform, 0.0),
    demagnetized(
        "short A k3 = 0.2 at +60 K",
        single(2, 0.2),
        MagnetForm::Uniform,
        60.0,
    ),
    demagnetized(
        "short A k3 = 0.2 at −60 K",
        single(2, 0.2),
        MagnetForm::Uniform,
        -60.0,
    ),
    healthy_at("healthy at +60 K", 60.0),
    healthy_at("healthy at +30 K", 30.0),
    healthy_at("healthy at −30 K", -30.0),
    healthy_at("healthy at −60 K", -60.0),
];

/// Random multi-fault vectors: every component uniform in its range, drawn from a fixed
/// seed (xoshiro256++ seed 2026). Target as Table II medium (2 %). The first six served
/// the identifiability study's diagnostics; campaigns use [`untuned_random_cases`].
pub fn random_cases(n: usize) -> Vec<Case> {
    random_cases_from(2026, RANDOM_NAMES, n)
}

/// Random multi-fault vectors that no design, weight or setting was chosen on (seed 2027).
pub fn untuned_random_cases(n: usize) -> Vec<Case> {
    random_cases_from(2027, UNTUNED_NAMES, n)
}

const RANDOM_NAMES: [&str; 8] = [
    "random 1", "random 2", "random 3", "random 4", "random 5", "random 6", "random 7", "random 8",
];
const UNTUNED_NAMES: [&str; 8] = [
    "untuned 1",
    "untuned 2",
    "untuned 3",
    "untuned 4",
    "untuned 5",
    "untuned 6",
    "untuned 7",
    "untuned 8",
];

fn random_cases_from(seed: u64, names: [&'static str; 8], n: usize) -> Vec<Case> {
    use rand_core::{RngCore, SeedableRng};
    let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed);
    (0..n.min(names.len()))
        .map(|j| {
            // The paper's eight components, drawn as before the ninth fault (no
            // demagnetization: `--table demagnetization` has its own cases).
            let mut k = [0.0f32; FAULT_COUNT];
            for (i, slot) in k.iter_mut().enumerate().take(PAPER_FAULT_COUNT) {
                let u = (rng.next_u32() >> 8) as f32 / (1u32 << 24) as f32;
                // Faults up to medium level (0.5, shorts 0.25); phase and drift over their range.
                *slot = match i {
                    2..=4 => 0.25 * u,
                    6 | 7 => u,
                    _ => 0.5 * u,
                };
            }
            Case {
                name: names[j],
                faults: k,
                noise: 0.0,
                paper: PaperValue::None,
                target: Some(2.0),
                healthy: false,
                magnets: MagnetForm::Uniform,
                winding_rise: 0.0,
            }
        })
        .collect()
}

/// One identification of one case.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunResult {
    pub found: FaultVector,
    /// e_tot [%] (eq. 4).
    pub e_tot: f64,
    /// The same root mean square over all nine components (demagnetization included) [%].
    pub e_tot_all: f64,
    /// Largest |k_i − nominal_i| over the fault components (not the phase) [-].
    pub largest_component: f64,
    pub fitness: f32,
    /// Eq. (3) at the true vector (residual subtracted): below `fitness` means the optimiser
    /// missed; above means the model prefers a wrong vector.
    pub fitness_at_truth: f32,
    pub evaluations: u32,
    /// Gauss–Newton sums of the polish (nine monitor-model runs each).
    pub curvatures: u32,
    pub seconds: f64,
    /// The identification's uncertainty (`None` if this test determines no component).
    pub uncertainty: Option<Uncertainty>,
    /// Per component, |found − true| / std without the inflation and the systematic error
    /// (`shared::uncertainty::preflight_systematic`: the raw Gauss–Newton std); `None` where
    /// undetermined or for the phase without an eccentricity.
    pub z_raw: [Option<f64>; FAULT_COUNT],
    /// Per component, the stated deviation without the actuator's systematic error (the
    /// inflated curvature's; NaN where undetermined): what the survey of that error reads.
    pub own_std: [f64; FAULT_COUNT],
    /// Verdicts with the uncertainty (`Faulty` only when the 90 % interval clears the
    /// detection threshold).
    pub assessments: [Assessment; FAULT_COUNT],
    /// Whether the domain check found the test inside the monitor model's domain.
    pub within: bool,
    /// Why it did not (the reason's health code), when it did not.
    pub outside: Option<shared::health::DomainCode>,
    /// The weak magnet read and the pole nearest its centre (`None`: none read).
    pub weak_magnet: Option<(WeakMagnet, u32)>,
    /// The weak magnet's verdict (`shared::uncertainty::assess_magnet`; `Healthy` when none
    /// is read).
    pub weak_magnet_verdict: Assessment,
    /// The rotor's whole mean flux lost as k9 (the uniform loss and a weak magnet's mean):
    /// what a one-magnet case's truth k9 is scored against.
    pub k9_mean: f32,
    /// The injection's winding temperature minus the thermistor's [K]
    /// (`shared::conditions::TestConditions::winding_disagreement`).
    pub winding_disagreement: f32,
}

impl RunResult {
    /// Whether every truly faulty component (beyond the detection threshold) reads `Faulty`;
    /// `None` for a healthy truth.
    pub fn detected(&self, truth: &FaultVector) -> Option<bool> {
        let faulty: Vec<usize> = truth
            .deviations()
            .iter()
            .enumerate()
            .filter(|(_, d)| d.is_some_and(|d| d > DETECTION_THRESHOLD))
            .map(|(i, _)| i)
            .collect();
        (!faulty.is_empty()).then(|| {
            faulty
                .iter()
                .all(|&i| self.assessments[i] == Assessment::Faulty)
        })
    }

    /// Whether a truly healthy component reads `Faulty`, or a weak magnet reads `Faulty` on
    /// a rotor whose magnets are alike (`weak_played`: the case plays one).
    pub fn false_alarm(&self, truth: &FaultVector, weak_played: bool) -> bool {
        let component = truth.deviations().iter().enumerate().any(|(i, d)| {
            d.is_some_and(|d| d <= DETECTION_THRESHOLD) && self.assessments[i] == Assessment::Faulty
        });
        component || (self.weak_magnet_verdict == Assessment::Faulty && !weak_played)
    }

    /// (inside, determined) component counts of the 90 % intervals against the truth.
    pub fn coverage(&self, truth: &FaultVector) -> (usize, usize) {
        let Some(u) = &self.uncertainty else {
            return (0, 0);
        };
        let c = u.covers(truth);
        // The phase counts only with an eccentricity (e_tot weighs it by k6).
        let counted = c.iter().enumerate().filter_map(|(i, x)| {
            if i == 6 && truth.eccentricity() == 0.0 {
                None
            } else {
                *x
            }
        });
        counted.fold((0, 0), |(inside, n), x| (inside + usize::from(x), n + 1))
    }
}

/// Statistics of one case.
#[derive(Clone, Debug, PartialEq)]
pub struct CaseSummary {
    pub case: Case,
    pub runs: Vec<RunResult>,
}

/// Every run of `summaries` as CSV: `case,run,e_tot,e_tot_all,fitness,fitness_at_truth,
/// evaluations,curvatures,within,k1…k9,std_k1…std_k9` (the run index is its seed offset;
/// `e_tot` over the paper's eight components, `e_tot_all` over all nine; the standard
/// deviations with the inflation, NaN where undetermined).
pub fn runs_csv(summaries: &[CaseSummary]) -> String {
    let mut out = String::from(
        "case,run,e_tot,e_tot_all,fitness,fitness_at_truth,evaluations,curvatures,within",
    );
    for n in shared::fault::FAULT_NAMES {
        out += &format!(",{n}");
    }
    for n in shared::fault::FAULT_NAMES {
        out += &format!(",std_{n}");
    }
    out.push('\n');
    for s in summaries {
        for (i, r) in s.runs.iter().enumerate() {
            out += &format!(
                "{},{i},{},{},{},{},{},{},{}",
                s.case.name,
                r.e_tot,
                r.e_tot_all,
                r.fitness,
                r.fitness_at_truth,
                r.evaluations,
                r.curvatures,
                r.within
            );
            for k in r.found.as_array() {
                out += &format!(",{k}");
            }
            let std = r.uncertainty.map_or([f32::NAN; FAULT_COUNT], |u| u.std);
            for s in std {
                out += &format!(",{s}");
            }
            out.push('\n');
        }
    }
    out
}

/// The ninth fault's own table: per case the demagnetization played and found (the rotor's
/// whole mean flux lost as k9, a weak magnet's mean included; mean and range over the
/// runs), the runs it reads `FAULT` (the uniform loss), the runs that read a weak magnet
/// (at the played pole 0) and its mean depth, e_tot over the paper's eight and over all nine, and the largest other component's deviation from nominal (what else the case
/// was read as). Targets (issue 35): k9 within ±0.03 at 0.1, no more than 0.05 where none is
/// played, never `FAULT` on a healthy day.
pub fn demagnetization_markdown(summaries: &[CaseSummary]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "\n| case | k9 played | k9 found: mean [min, max] | runs reading it `FAULT` | weak magnet read (at pole 0), mean depth | e_tot of the eight (mean) | e_tot of all nine (mean) | largest other component (worst run) |"
    );
    let _ = writeln!(s, "| --- | --- | --- | --- | --- | --- | --- | --- |");
    for c in summaries {
        let k9: Vec<f64> = c.runs.iter().map(|r| f64::from(r.k9_mean)).collect();
        let weak: Vec<&(WeakMagnet, u32)> = c
            .runs
            .iter()
            .filter_map(|r| r.weak_magnet.as_ref())
            .collect();
        let weak_text = if weak.is_empty() {
            format!("0/{}", c.runs.len())
        } else {
            format!(
                "{}/{} ({}), {:.2}",
                weak.len(),
                c.runs.len(),
                weak.iter().filter(|(_, pole)| *pole == 0).count(),
                weak.iter().map(|(m, _)| f64::from(m.depth)).sum::<f64>() / weak.len() as f64
            )
        };
        let n = k9.len().max(1) as f64;
        let (lo, hi) = k9
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
                (a.min(x), b.max(x))
            });
        let faulty = c
            .runs
            .iter()
            .filter(|r| r.assessments.get(DEMAGNETIZATION_INDEX) == Some(&Assessment::Faulty))
            .count();
        let mean = |f: fn(&RunResult) -> f64| c.runs.iter().map(f).sum::<f64>() / n;
        // |found − played| of every other fault component (not the phase: a location).
        let truth = FaultVector::saturating(c.case.faults);
        let (other, name) = c
            .runs
            .iter()
            .flat_map(|r| {
                shared::metrics::component_errors(&r.found, &truth)
                    .into_iter()
                    .enumerate()
                    .filter(|&(i, _)| !CIRCULAR[i] && i != DEMAGNETIZATION_INDEX)
                    .map(|(i, e)| (f64::from(e) / 100.0, i))
            })
            .fold((0.0, 0), |best, x| if x.0 > best.0 { x } else { best });
        let _ = writeln!(
            s,
            "| {} | {:.2} | {:.3} [{:.3}, {:.3}] | {faulty}/{} | {weak_text} | {:.2} | {:.2} | {:.3} ({}) |",
            c.case.name,
            c.case.faults[DEMAGNETIZATION_INDEX],
            k9.iter().sum::<f64>() / n,
            lo,
            hi,
            c.runs.len(),
            mean(|r| r.e_tot),
            mean(|r| r.e_tot_all),
            other,
            shared::fault::FAULT_NAMES[name],
        );
    }
    s
}

impl CaseSummary {
    fn values(&self) -> Vec<f64> {
        self.runs
            .iter()
            .map(|r| {
                if self.case.healthy {
                    100.0 * r.largest_component
                } else {
                    r.e_tot
                }
            })
            .collect()
    }
    /// Mean of e_tot (healthy row: of the largest component, in %).
    pub fn mean(&self) -> f64 {
        let v = self.values();
        v.iter().sum::<f64>() / v.len().max(1) as f64
    }
    pub fn variance(&self) -> f64 {
        let v = self.values();
        let m = self.mean();
        v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len().max(1) as f64
    }
    pub fn worst(&self) -> f64 {
        self.values().into_iter().fold(0.0, f64::max)
    }
    pub fn mean_evaluations(&self) -> f64 {
        self.runs
            .iter()
            .map(|r| f64::from(r.evaluations))
            .sum::<f64>()
            / self.runs.len().max(1) as f64
    }
    pub fn mean_seconds(&self) -> f64 {
        self.runs.iter().map(|r| r.seconds).sum::<f64>() / self.runs.len().max(1) as f64
    }
    /// The components' truth the readings are scored against: the case's vector, its k9 none
    /// where one magnet plays it (the reading carries that magnet apart from the uniform
    /// loss).
    fn component_truth(&self) -> FaultVector {
        let mut k = self.case.faults;
        if self.case.magnets == MagnetForm::OneMagnet {
            k[DEMAGNETIZATION_INDEX] = 0.0;
        }
        FaultVector::saturating(k)
    }

    /// (inside, determined) component-runs of the 90 % intervals.
    pub fn coverage(&self) -> (usize, usize) {
        let truth = self.component_truth();
        self.runs.iter().fold((0, 0), |(a, b), r| {
            let (x, y) = r.coverage(&truth);
            (a + x, b + y)
        })
    }

    /// (runs detecting every true fault, runs with a fault to detect, runs with a false
    /// alarm).
    pub fn detection(&self) -> (usize, usize, usize) {
        let truth = FaultVector::saturating(self.case.faults);
        let weak = self.case.magnets == MagnetForm::OneMagnet;
        // A one-magnet case's k9 is that magnet: detected when a weak magnet reads `FAULT`
        // (and every other true fault does).
        let uniform = self.component_truth();
        let magnet = |r: &RunResult| r.weak_magnet_verdict == Assessment::Faulty;
        let detected = |r: &RunResult| match r.detected(&uniform) {
            Some(hit) => Some(hit && (!weak || magnet(r))),
            None if weak => Some(magnet(r)),
            None => None,
        };
        self.runs
            .iter()
            .fold((0, 0, 0), |(d, n, f), r| match detected(r) {
                Some(hit) => (
                    d + usize::from(hit),
                    n + 1,
                    f + usize::from(r.false_alarm(&truth, weak)),
                ),
                None => (d, n, f + usize::from(r.false_alarm(&truth, weak))),
            })
    }

    /// Runs whose best fitness is above the fitness at the true vector (the optimiser stopped
    /// short of a better-known point).
    pub fn optimiser_misses(&self) -> usize {
        self.runs
            .iter()
            .filter(|r| r.fitness > r.fitness_at_truth)
            .count()
    }
    /// Meets every target that applies: mean ≤ target (and ≤ paper), worst ≤ 3 × mean; the
    /// healthy row: every run's largest component ≤ 0.03.
    pub fn passes(&self) -> bool {
        if self.case.healthy {
            return self.worst() <= 100.0 * FALSE_ALARM_LIMIT;
        }
        let mean = self.mean();
        let target_ok = self.case.target.is_none_or(|t| mean <= t);
        target_ok && self.worst() <= 3.0 * mean.max(0.1)
    }
}

/// The reference model of `case` (its day, its magnets) and the fault vector it plays for
/// `truth`: a one-magnet case plays k9 as that magnet's loss and no uniform loss.
fn case_model(
    rm: &ReferenceModel,
    case: &Case,
    truth: &FaultVector,
) -> Result<(ReferenceModel, FaultVector)> {
    let mut model = *rm;
    if case.winding_rise != 0.0 {
        let mut settings = *rm.settings();
        let day = settings.conditions.winding_temperature + case.winding_rise;
        settings.conditions = settings.conditions.at_temperature(day);
        model = model.with_settings(settings);
    }
    match case.magnets {
        MagnetForm::Uniform => Ok((model, *truth)),
        MagnetForm::OneMagnet => {
            let poles = 2.0 * f64::from(rm.settings().params.pole_pairs);
            // f32's k9 in f64: round to what the case means (0.2 · 0.5 · 10 = 1, not 1 + 1e-8).
            let loss =
                (f64::from(truth.demagnetization() * DEMAGNETIZATION_LOSS_MAX) * poles * 1e6)
                    .round()
                    / 1e6;
            if loss > 1.0 {
                anyhow::bail!(
                    "case {}: one magnet cannot lose {loss:.2} of its flux (k9 ≤ 1/P)",
                    case.name
                );
            }
            let mut k = *truth.as_array();
            k[DEMAGNETIZATION_INDEX] = 0.0;
            Ok((
                model.with_demagnetization(Demagnetization::Partial { loss, pole: 0 }),
                FaultVector::saturating(k),
            ))
        }
    }
}

/// Runs one case once.
pub fn run_once(
    rm: &ReferenceModel,
    record: &ActuatorRecord,
    case: &Case,
    run: u64,
) -> Result<RunResult> {
    let calibration = &record.calibration;
    let truth = FaultVector::new(case.faults).map_err(|e| anyhow!("case {}: {e:?}", case.name))?;
    let (rm, played) = case_model(rm, case, &truth)?;
    let sim = rm.simulate(&Scenario {
        faults: played,
        current_ref_noise: case.noise,
        seed: run,
    });
    let params = record.params;
    let measured = sim.trace.measured(&params)?;
    let id = identify_for(&measured, record, 1 + run, false)?;
    let problem = shared::FitnessProblem::new(&measured, params, calibration)
        .map_err(|e| anyhow!("fitness: {e:?}"))?;
    let found = id.result.faults;
    let largest_component = f64::from(found.largest_deviation());
    let assessments = id.assessments();
    let uncertainty = id.uncertainty.map(|(u, _)| u);
    let mut z_raw = [None; FAULT_COUNT];
    let mut own_std = [f64::NAN; FAULT_COUNT];
    if let Some(u) = &uncertainty {
        for (i, z) in z_raw.iter_mut().enumerate() {
            own_std[i] = without_systematic(
                u,
                &found,
                &record.systematic.on_day(id.conditions.friction_slope),
                i,
            );
            let raw = own_std[i] / f64::from(shared::uncertainty::INFLATION);
            let skip = i == 6 && truth.eccentricity() == 0.0;
            if raw.is_finite() && raw > 0.0 && !skip {
                let mut e = f64::from(found.as_array()[i] - truth.as_array()[i]).abs();
                if i == 6 {
                    e = e.min(1.0 - e);
                }
                *z = Some(e / raw);
            }
        }
    }
    let domain = id.domain(&sim.trace.domain_monitor(&params), &record.domain);
    // A weak magnet scored as the mean flux it took, as the case's k9 means it.
    let magnets = id.result.magnets;
    let mean = shared::weak_magnet::with_depth(&found, magnets.depth, 0.0, params.pole_pairs);
    Ok(RunResult {
        found,
        e_tot: f64::from(total_error(&found, &truth)),
        e_tot_all: f64::from(total_error_all(&mean, &truth)),
        weak_magnet: (!magnets.is_none()).then(|| (magnets, magnets.pole(&params))),
        weak_magnet_verdict: id.magnet_assessment_at(shared::fault::DETECTION_THRESHOLD),
        k9_mean: mean.demagnetization(),
        largest_component,
        fitness: id.result.fitness,
        fitness_at_truth: problem.error(&truth),
        evaluations: id.result.evaluations,
        curvatures: id.result.curvatures,
        seconds: id.seconds,
        uncertainty,
        z_raw,
        own_std,
        assessments,
        winding_disagreement: id.conditions.winding_disagreement,
        within: domain == shared::domain::Domain::Within,
        outside: (domain != shared::domain::Domain::Within)
            .then(|| shared::health::DomainCode::from(domain)),
    })
}

/// Runs every case `runs` times, in parallel, with a progress bar when `progress`.
pub fn run_campaign(
    cases: &[Case],
    runs: u64,
    actuator: &Actuator,
    progress: bool,
) -> Result<Vec<CaseSummary>> {
    let record = actuator.record;
    actuator.calibration_for(&record.test)?;
    let rm = ReferenceModel::new(actuator.reference_settings()?).with_test(record.test);
    let jobs: Vec<(usize, u64)> = (0..cases.len())
        .flat_map(|c| (0..runs).map(move |r| (c, r)))
        .collect();
    let bar = crate::progress_bar(
        jobs.len() as u64,
        "campaign {bar:40} {pos}/{len} identifications, {elapsed} elapsed, ~{eta} left",
        progress,
    );
    let results: Vec<Result<(usize, RunResult)>> = jobs
        .par_iter()
        .map(|&(c, r)| {
            let out = run_once(&rm, &record, &cases[c], r).map(|x| (c, x));
            bar.inc(1);
            out
        })
        .collect();
    bar.finish_and_clear();
    let mut summaries: Vec<CaseSummary> = cases
        .iter()
        .map(|&case| CaseSummary {
            case,
            runs: Vec::new(),
        })
        .collect();
    for r in results {
        let (c, run) = r?;
        summaries[c].runs.push(run);
    }
    Ok(summaries)
}

/// The campaign as a Markdown table.
pub fn markdown(title: &str, summaries: &[CaseSummary], runs: u64) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "### {title}\n");
    let _ = writeln!(
        s,
        "{runs} runs per case (RM seed r, GA seed 1 + r). e_tot in % (eq. 4); for the healthy row, the largest identified fault component in % of its range (false-alarm limit 3 %).\n"
    );
    let _ = writeln!(
        s,
        "| case | paper mean | our mean | variance | worst | target | meets | mean evaluations | mean seconds | optimiser short of truth | 90 % intervals holding the truth | runs detecting every fault | runs with a false alarm |"
    );
    let _ = writeln!(
        s,
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"
    );
    for c in summaries {
        let paper = match c.case.paper {
            PaperValue::Mean(v) => format!("{v:.2}"),
            PaperValue::About(t) => t.to_string(),
            PaperValue::None => "–".into(),
        };
        let target = if c.case.healthy {
            "all runs ≤ 3".to_string()
        } else {
            c.case.target.map_or("–".into(), |t| format!("≤ {t:.2}"))
        };
        let _ = writeln!(
            s,
            "| {} | {paper} | {:.2} | {:.3} | {:.2} | {target} | {} | {:.0} | {:.2} | {}/{} | {}/{} | {} | {}/{} |",
            c.case.name,
            c.mean(),
            c.variance(),
            c.worst(),
            if c.passes() { "yes" } else { "**no**" },
            c.mean_evaluations(),
            c.mean_seconds(),
            c.optimiser_misses(),
            c.runs.len(),
            c.coverage().0,
            c.coverage().1,
            {
                let (d, n, _) = c.detection();
                if n > 0 {
                    format!("{d}/{n}")
                } else {
                    "–".into()
                }
            },
            c.detection().2,
            c.runs.len()
        );
    }
    let (inside, all) = summaries
        .iter()
        .map(CaseSummary::coverage)
        .fold((0, 0), |(a, b), (x, y)| (a + x, b + y));
    let mut z: Vec<f64> = summaries
        .iter()
        .flat_map(|c| {
            c.runs
                .iter()
                .flat_map(|r| r.z_raw.iter().flatten().copied())
        })
        .collect();
    z.sort_by(f64::total_cmp);
    let needed = z
        .get(((z.len() as f64 * 0.9).ceil() as usize).saturating_sub(1))
        .map_or(f64::NAN, |q| q / f64::from(shared::uncertainty::Z90));
    let _ = writeln!(
        s,
        "\n90 % intervals (inflation {}): the truth inside {inside} of {all} component-runs \
         ({:.1} %); the inflation that would make it 90 % here: {needed:.2}.",
        shared::uncertainty::INFLATION,
        100.0 * inside as f64 / all.max(1) as f64
    );
    // For calibrating the inflation across campaigns: inside counts at other values.
    let grid: Vec<String> = [4.0, 6.0, 8.0, 10.0, 12.0, 14.0, 16.0, 20.0, 25.0]
        .iter()
        .map(|&c: &f64| {
            let n = z
                .iter()
                .filter(|&&x| x <= c * f64::from(shared::uncertainty::Z90))
                .count();
            format!("{c}: {n}/{}", z.len())
        })
        .collect();
    let _ = writeln!(
        s,
        "Inside at other inflations (without the systematic error): {}.",
        grid.join(", ")
    );
    // Per component: what a flight's windows take of a preflight's deviation when they
    // hold its value (`shared::window::HELD_ERROR_SCALE`).
    let per: Vec<String> = (0..FAULT_COUNT)
        .filter(|&i| i != shared::fault::ECCENTRICITY_PHASE_INDEX)
        .map(|i| {
            let mut z: Vec<f64> = summaries
                .iter()
                .flat_map(|c| c.runs.iter().filter_map(move |r| r.z_raw[i]))
                .collect();
            z.sort_by(f64::total_cmp);
            let needed = z
                .get(((z.len() as f64 * 0.9).ceil() as usize).saturating_sub(1))
                .map_or(f64::NAN, |q| q / f64::from(shared::uncertainty::Z90));
            format!(
                "{} {needed:.2} ({})",
                shared::fault::FAULT_NAMES[i],
                z.len()
            )
        })
        .collect();
    let _ = writeln!(
        s,
        "Per component, the inflation that would make 90 % of its intervals hold the truth \
         (component-runs): {}.",
        per.join(", ")
    );
    let _ = writeln!(
        s,
        "Per component, the least systematic error (steps of 0.001; the gain drift's is the \
         actuator file's `[uncertainty] gain_drift_systematic`) with which 90 % of its \
         intervals at inflation {} hold the truth: {}.",
        shared::uncertainty::INFLATION,
        least_systematic(summaries, |_| true).join(", ")
    );
    let _ = writeln!(
        s,
        "The same over the runs that read a gear play (backlash ≥ {}; the gain drift's is \
         `[uncertainty] play_gain_drift_systematic`): {}; over those that do not: {}.",
        shared::fault::DETECTION_THRESHOLD,
        least_systematic(summaries, reads_play).join(", "),
        least_systematic(summaries, |k| !reads_play(k)).join(", ")
    );
    s
}

/// Component `i`'s stated deviation in `u` (a preflight that read `found`) without the
/// systematic error (`shared::uncertainty::preflight_systematic`, added in quadrature) of
/// the actuator whose record carries `systematic`: the inflated curvature's.
fn without_systematic(
    u: &Uncertainty,
    found: &FaultVector,
    systematic: &SystematicError,
    i: usize,
) -> f64 {
    let std = f64::from(u.std[i]);
    let systematic = f64::from(preflight_systematic(found, systematic)[i]);
    (std * std - systematic * systematic).max(0.0).sqrt()
}

/// Per component (not the phase): the least systematic error in steps of 0.001 (up to 0.1)
/// which, added in quadrature to each run's inflated deviation, makes 90 % of the
/// component's intervals hold the truth (the rule of `shared::uncertainty::SYSTEMATIC`), over
/// the runs whose found vector passes `runs`.
fn least_systematic(summaries: &[CaseSummary], runs: impl Fn(&FaultVector) -> bool) -> Vec<String> {
    let z90 = f64::from(shared::uncertainty::Z90);
    (0..FAULT_COUNT)
        .filter(|&i| i != shared::fault::ECCENTRICITY_PHASE_INDEX)
        .map(|i| {
            // (|error|, the inflated deviation without the systematic error) per run.
            let runs: Vec<(f64, f64)> = summaries
                .iter()
                .flat_map(|c| c.runs.iter().map(move |r| (c.case.faults, r)))
                .filter(|(_, r)| runs(&r.found))
                .filter_map(|(truth, r)| {
                    let own = r.own_std[i];
                    let e = f64::from(r.found.as_array()[i] - truth[i]).abs();
                    own.is_finite().then_some((e, own))
                })
                .collect();
            let enough = (runs.len() as f64 * 0.9).ceil() as usize;
            let least = (0..=100).map(|m| f64::from(m) * 0.001).find(|&e| {
                runs.iter()
                    .filter(|(x, own)| *x <= z90 * (own * own + e * e).sqrt())
                    .count()
                    >= enough
            });
            format!(
                "{} {}",
                shared::fault::FAULT_NAMES[i],
                least.map_or("> 0.1".into(), |e| format!("{e:.3}"))
            )
        })
        .collect()
}

/// Per-case e_tot, ours (mean with min–max bar) against the paper, as an SVG.
pub fn plot(out: &Path, title: &str, summaries: &[CaseSummary]) -> Result<()> {
    use plotters::prelude::*;
    let n = summaries.len();
    let top = summaries
        .iter()
        .map(|c| {
            let paper = match c.case.paper {
                PaperValue::Mean(v) => v,
                _ => 0.0,
            };
            c.worst().max(paper)
        })
        .fold(1.0, f64::max)
        * 1.15;
    let root = SVGBackend::new(out, (1100, 600)).into_drawing_area();
    let e = |e: DrawingAreaErrorKind<_>| anyhow!("drawing {}: {e:?}", out.display());
    root.fill(&WHITE).map_err(e)?;
    let labels: Vec<String> = summaries.iter().map(|c| c.case.name.to_string()).collect();
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(150)
        .y_label_area_size(60)
        .build_cartesian_2d(-0.5..(n as f64 - 0.5), 0.0..top)
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_labels(n)
        .x_label_formatter(&|x| {
            let i = x.round();
            if (x - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < labels.len() {
                labels[i as usize].clone()
            } else {
                String::new()
            }
        })
        .x_label_style(
            ("sans-serif", 12)
                .into_font()
                .transform(FontTransform::Rotate270),
        )
        .y_desc("e_tot [%]")
        .draw()
        .map_err(e)?;
    let ours: Vec<(f64, f64)> = summaries
        .iter()
        .enumerate()
        .map(|(i, c)| (i as f64, c.mean()))
        .collect();
    chart
        .draw_series(
            ours.iter()
                .map(|&(x, y)| Circle::new((x, y), 5, BLUE.filled())),
        )
        .map_err(e)?
        .label("ours: mean over runs (bar: min – max)")
        .legend(|(x, y)| Circle::new((x + 10, y), 5, BLUE.filled()));
    chart
        .draw_series(summaries.iter().enumerate().map(|(i, c)| {
            let v = c.values();
            let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = v.iter().copied().fold(0.0, f64::max);
            PathElement::new(vec![(i as f64, lo), (i as f64, hi)], BLUE)
        }))
        .map_err(e)?;
    let paper: Vec<(f64, f64)> = summaries
        .iter()
        .enumerate()
        .filter_map(|(i, c)| match c.case.paper {
            PaperValue::Mean(v) => Some((i as f64 + 0.15, v)),
            _ => None,
        })
        .collect();
    if !paper.is_empty() {
        chart
            .draw_series(
                paper
                    .iter()
                    .map(|&(x, y)| TriangleMarker::new((x, y), 7, RED.filled())),
            )
            .map_err(e)?
            .label("paper (Table I mean)")
            .legend(|(x, y)| TriangleMarker::new((x + 10, y), 7, RED.filled()));
    }
    chart
        .draw_series(summaries.iter().enumerate().filter_map(|(i, c)| {
            c.case.target.filter(|_| !c.case.healthy).map(|t| {
                PathElement::new(
                    vec![(i as f64 - 0.3, t), (i as f64 + 0.3, t)],
                    BLACK.stroke_width(2),
                )
            })
        }))
        .map_err(e)?
        .label("our target")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.stroke_width(2)));
    crate::fdi::plot::draw_legend(&mut chart, out, SeriesLabelPosition::UpperLeft)?;
    root.present().map_err(e)?;
    Ok(())
}
