//! The FDI on windows of flight (issue 36): the reference model flies the surface
//! ([`crate::plant::aero::FlightWindow`]: the flight control computer's corrections with the
//! test's chirp superimposed, the hinge moment of trim and turbulence), and each window is
//! read twice:
//! * by the flown preflight identification and domain checks, as if it were a preflight (the
//!   monitor model plays the chirp alone, so no window should come out `within`);
//! * by the window identification ([`crate::fdi::window`]: the recorded command, the
//!   window's load fitted, the window's own verdicts).
//!
//! ≈ 0.8 s per run on one core.

use anyhow::Result;
use rayon::prelude::*;
use shared::actuator::ActuatorRecord;
use shared::domain::Domain;
use shared::metrics::total_error;
use shared::{Calibration, FaultVector};

use crate::fdi::identify::identify_for;
use crate::fdi::window::{held_from, identify_window_with, WindowModel, WindowSearch};
use crate::plant::aero::{FlightPhase, FlightWindow, Turbulence};
use crate::plant::reference::{ReferenceModel, Scenario};
use shared::fusion::{FlightLength, FlightProgress, WindowFusion, FLIGHT_MAX_FRICTION_STD};
use shared::uncertainty::{Assessment, Uncertainty};
use shared::window::WindowReason;

/// The cases: the healthy actuator, friction 0.2 and Table II medium.
pub const FLIGHT_CASES: [(&str, [f32; shared::FAULT_COUNT]); 3] = [
    ("healthy", *FaultVector::NOMINAL.as_array()),
    (
        "friction k1 = 0.2",
        [0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0],
    ),
    ("Table II medium", crate::studies::campaign::MEDIUM),
];

/// One seed of one case in one window.
#[derive(Clone, Debug)]
pub struct FlightRun {
    /// The run's seed (the window's noise, turbulence and corrections).
    pub seed: u64,
    /// The preflight identification's verdict on the window and its e_tot [%].
    pub preflight: (Domain, f64),
    /// The window identification's verdict (`Err`: outside) and e_tot [%].
    pub window: (Result<(), WindowReason>, f64),
    /// The window identification's largest component where the truth is nominal.
    pub healthy_max: f32,
    /// Components the window identification calls `FAULT` (its 90 % interval beyond the
    /// threshold) where the truth is nominal.
    pub false_faults: usize,
    /// Components whose 90 % interval holds the truth, and components with an interval.
    pub covered: (usize, usize),
    /// The window's load beyond its spring over the spring's moment at the test's amplitude
    /// (`WindowIdentified::turbulence`), and the share of the current its fit leaves
    /// unexplained (`WindowIdentified::misfit`).
    pub turbulence: f32,
    pub misfit: f32,
    /// The window identification's vector and its standard deviations (NaN: undetermined).
    pub found: FaultVector,
    pub std: [f32; shared::FAULT_COUNT],
    /// The part of `std` the held preflight values' error adds, shared by a flight's
    /// windows (`shared::window::HeldComponents::shared_std`; zero where none).
    pub shared_std: [f32; shared::FAULT_COUNT],
    /// Components whose window interval meets the same flight's preflight interval, and
    /// components compared (both determined; none when the preflight was not `within`).
    pub agreement: (usize, usize),
    /// Windows flown: 1 for a window, the flight's count for a flight's reading.
    pub windows: u32,
    /// Monitor-model runs the window identification with its load fitted spent (what the
    /// controller spends; a curvature counts thirteen); a flight's reading: its windows'
    /// sum.
    pub model_runs: u32,
    /// Windows read with the surface pinned (`shared::pinned`): 0 or 1 for a window, the
    /// count entered for a flight's reading; and a window's pinned misfit when one was
    /// tried (NaN otherwise, and for a flight).
    pub pinned: u32,
    pub pinned_misfit: f32,
    /// The surface sensor's share of that misfit (NaN where not tried).
    pub pinned_floor: f32,
    /// The same flight's preflight reading and its deviations (NaN: undetermined, or the
    /// preflight not `within`): what `agreement` compares with.
    pub pre_found: FaultVector,
    pub pre_std: [f32; shared::FAULT_COUNT],
}

/// The preflight's seed offset from the window's (its own noise).
const GROUND_SEED: u64 = 1_000;

/// Components where two readings' 90 % intervals meet (their distance within the sum of
/// their half-widths), and components where both are determined; the eccentricity's phase
/// is left out.
pub fn agreement(a: &Uncertainty, b: &Uncertainty) -> (usize, usize) {
    let mut out = (0, 0);
    for j in 0..shared::FAULT_COUNT {
        if j == ECCENTRICITY_PHASE || a.std[j].is_nan() || b.std[j].is_nan() {
            continue;
        }
        out.1 += 1;
        if a.lower[j] <= b.upper[j] && b.lower[j] <= a.upper[j] {
            out.0 += 1;
        }
    }
    out
}

/// One case in one window, every seed's run.
#[derive(Clone, Debug)]
pub struct FlightRow {
    pub case: &'static str,
    pub truth: FaultVector,
    pub window: FlightWindow,
    /// Every window's run: `windows per flight` per seed.
    pub runs: Vec<FlightRun>,
    /// Each flight's reading from its windows fused ([`shared::fusion`]), one per seed;
    /// empty at one window per flight.
    pub flights: Vec<FlightRun>,
}

/// The test a flight window carries (the record's chirp alone) and the record the FDI reads
/// it with (that test; the built-in actuator's calibration of the chirp-only test when the
/// record is the built-in one).
pub fn flight_record(record: &ActuatorRecord) -> ActuatorRecord {
    let test = record.test.chirp_only();
    let calibration = if *record == ActuatorRecord::REFERENCE {
        Calibration::reference_actuator(&test)
    } else {
        record.calibration
    };
    ActuatorRecord {
        test,
        calibration,
        ..*record
    }
}

/// Every phase in both turbulences.
pub const ALL_WINDOWS: [FlightWindow; 6] = [
    window(FlightPhase::Climb, Turbulence::Light),
    window(FlightPhase::Climb, Turbulence::Moderate),
    window(FlightPhase::Cruise, Turbulence::Light),
    window(FlightPhase::Cruise, Turbulence::Moderate),
    window(FlightPhase::Approach, Turbulence::Light),
    window(FlightPhase::Approach, Turbulence::Moderate),
];

const fn window(phase: FlightPhase, turbulence: Turbulence) -> FlightWindow {
    FlightWindow { phase, turbulence }
}

/// Every case of `cases` ([`FLIGHT_CASES`] by default) in every phase and turbulence of
/// `windows` ([`ALL_WINDOWS`] by default), one flight per seed of `seeds` flying `length`'s
/// windows (fused into the flight's reading when more than one), each window read with the
/// GA of `search` (the controller's: [`WindowSearch::ONBOARD`]).
#[allow(clippy::too_many_arguments)]
pub fn flight_campaign(
    rm: &ReferenceModel,
    record: &ActuatorRecord,
    seeds: std::ops::Range<u64>,
    length: FlightLength,
    search: WindowSearch,
    windows: &[FlightWindow],
    cases: &[(&'static str, [f32; shared::FAULT_COUNT])],
    progress: impl FnMut(&FlightRow),
) -> Result<Vec<FlightRow>> {
    fly_windows(
        rm,
        record,
        &flight_record(record),
        seeds,
        (length, search),
        windows,
        cases,
        progress,
    )
}

/// The test amplitudes [rad] the superimposed-test study tries, in cruise.
pub const TEST_AMPLITUDES: [f32; 4] = [1.25e-3, 2.5e-3, 5.0e-3, 10.0e-3];

/// The superimposed test's amplitude (docs/in-flight.md): in cruise, light and moderate
/// turbulence, the healthy actuator and friction 0.2, `runs` seeds, the window's chirp at
/// each of `amplitudes` [rad] (the preflight beside it keeps its own test). One set of rows
/// per amplitude.
pub fn test_amplitude_study(
    rm: &ReferenceModel,
    record: &ActuatorRecord,
    amplitudes: &[f32],
    runs: u64,
    mut progress: impl FnMut(f32, &FlightRow),
) -> Result<Vec<(f32, Vec<FlightRow>)>> {
    let windows = [
        window(FlightPhase::Cruise, Turbulence::Light),
        window(FlightPhase::Cruise, Turbulence::Moderate),
    ];
    let cases = [FLIGHT_CASES[0], FLIGHT_CASES[1]];
    amplitudes
        .iter()
        .map(|&a| {
            let mut window_record = flight_record(record);
            window_record.test.chirp.amplitude = a;
            let rows = fly_windows(
                rm,
                record,
                &window_record,
                0..runs,
                (FlightLength::fixed(1), WindowSearch::ONBOARD),
                &windows,
                &cases,
                |row| progress(a, row),
            )?;
            Ok((a, rows))
        })
        .collect()
}

/// The seed of window `j` of the flight of seed `seed`: window 0 is the flight's seed (one
/// window per flight plays what it always played), the others a stride apart (clear of
/// the preflight's [`GROUND_SEED`] offset).
fn window_seed(seed: u64, j: u32) -> u64 {
    seed + u64::from(j) * 100_000
}

/// What a reading (a window's or a flight's) says against the truth: its largest component
/// where the truth is nominal (the eccentricity's phase left out), the components it calls
/// `FAULT` where the truth is nominal, and its 90 % intervals that hold the truth.
fn against_truth(
    truth: &FaultVector,
    faults: &FaultVector,
    assessments: &[Assessment; shared::FAULT_COUNT],
    uncertainty: Option<&Uncertainty>,
) -> (f32, usize, (usize, usize)) {
    let nominal = FaultVector::NOMINAL;
    let healthy_max = truth
        .as_array()
        .iter()
        .zip(nominal.as_array())
        .zip(faults.as_array())
        .enumerate()
        .filter(|&(j, ((t, n), _))| t == n && j != ECCENTRICITY_PHASE)
        .map(|(_, ((_, n), f))| (f - n).abs())
        .fold(0.0f32, f32::max);
    let false_faults = assessments
        .iter()
        .zip(truth.as_array().iter().zip(nominal.as_array()))
        .filter(|(a, (t, n))| t == n && matches!(a, Assessment::Faulty))
        .count();
    let covered = uncertainty.map_or((0, 0), |u| {
        let c = u.covers(truth);
        (
            c.iter().filter(|x| **x == Some(true)).count(),
            c.iter().filter(|x| x.is_some()).count(),
        )
    });
    (healthy_max, false_faults, covered)
}

/// `cases` in `windows`, one flight per seed of `seeds` flying windows as `length` says
/// (`FlightLength::after`): every window played with `record`'s test and identified with
/// it by the GA of `search`, the flight's windows fused into its reading (when more than
/// one), and the same flight's preflight with `ground_record`.
#[allow(clippy::too_many_arguments)]
fn fly_windows(
    rm: &ReferenceModel,
    ground_record: &ActuatorRecord,
    record: &ActuatorRecord,
    seeds: std::ops::Range<u64>,
    (length, search): (FlightLength, WindowSearch),
    windows: &[FlightWindow],
    cases: &[(&'static str, [f32; shared::FAULT_COUNT])],
    mut progress: impl FnMut(&FlightRow),
) -> Result<Vec<FlightRow>> {
    let ground_record = *ground_record;
    let ground = rm.with_test(ground_record.test);
    let record = *record;
    let rm = rm.with_test(record.test);
    let threshold = shared::fault::DETECTION_THRESHOLD;
    let mut rows = Vec::new();
    for &window in windows {
        for &(case, faults) in cases {
            let truth = FaultVector::new(faults).map_err(|e| anyhow::anyhow!("{e:?}"))?;
            let flying = rm.with_flight(Some(window));
            let flights = seeds
                .clone()
                .into_par_iter()
                .map(|seed| -> Result<(Vec<FlightRun>, Option<FlightRun>)> {
                    // The same flight's preflight: the same actuator and day on the ground,
                    // its own noise.
                    let before = ground.simulate(&Scenario {
                        seed: seed + GROUND_SEED,
                        ..Scenario::new(truth)
                    });
                    let measured = before.trace.measured(&ground_record.params)?;
                    let pre = identify_for(&measured, &ground_record, 1 + seed, false)?;
                    let pre_within = pre.domain(
                        &before.trace.domain_monitor(&ground_record.params),
                        &ground_record.domain,
                    ) == Domain::Within;
                    // The window holds the shorts at the same flight's preflight reading
                    // (a window cannot tell them from an eccentricity), when it is `within`.
                    let held = held_from(&pre, pre_within);
                    let agree = |u: Option<&Uncertainty>| match (u, &pre.uncertainty, pre_within) {
                        (Some(a), Some((b, _)), true) => agreement(a, b),
                        _ => (0, 0),
                    };
                    let pre_found = pre.result.faults;
                    let pre_std = match &pre.uncertainty {
                        Some((u, _)) if pre_within => u.std,
                        _ => [f32::NAN; shared::FAULT_COUNT],
                    };
                    let mut runs = Vec::new();
                    let mut fusion = WindowFusion::EMPTY;
                    let mut first_reason = None;
                    let mut pinned_entered = 0u32;
                    for j in 0..length.most {
                        let seed = window_seed(seed, j);
                        let sim = flying.simulate(&Scenario {
                            seed,
                            ..Scenario::new(truth)
                        });
                        let measured = sim.trace.measured(&record.params)?;
                        let id = identify_for(&measured, &record, 1 + seed, false)?;
                        let domain =
                            id.domain(&sim.trace.domain_monitor(&record.params), &record.domain);
                        let w = identify_window_with(
                            &sim.trace,
                            &measured,
                            &record,
                            held,
                            1 + seed,
                            search,
                        )?;
                        let entered = w.enter(&mut fusion);
                        pinned_entered += u32::from(entered && w.model == WindowModel::Pinned);
                        first_reason.get_or_insert(w.verdict);
                        let u = w.uncertainty.as_ref().map(|(u, _)| u);
                        let (healthy_max, false_faults, covered) =
                            against_truth(&truth, &w.faults, &w.assessments(), u);
                        runs.push(FlightRun {
                            seed,
                            turbulence: w.turbulence,
                            misfit: w.misfit,
                            found: w.faults,
                            std: u.map_or([f32::NAN; shared::FAULT_COUNT], |u| u.std),
                            shared_std: w.shared_std,
                            agreement: agree(u),
                            preflight: (domain, f64::from(total_error(&id.result.faults, &truth))),
                            window: (w.verdict, f64::from(total_error(&w.faults, &truth))),
                            healthy_max,
                            false_faults,
                            covered,
                            windows: 1,
                            model_runs: w.load_model_runs,
                            pinned: u32::from(w.model == WindowModel::Pinned),
                            pinned_misfit: w.pinned_misfit.unwrap_or(f32::NAN),
                            pinned_floor: w.pinned_sensor_floor.unwrap_or(f32::NAN),
                            pre_found,
                            pre_std,
                        });
                        let reading = fusion.reading(FLIGHT_MAX_FRICTION_STD).ok();
                        if let FlightProgress::Done(_) =
                            length.after(j + 1, reading.as_ref(), FLIGHT_MAX_FRICTION_STD)
                        {
                            break;
                        }
                    }
                    if length.most < 2 {
                        return Ok((runs, None));
                    }
                    let mean = |f: fn(&FlightRun) -> f32| {
                        runs.iter().map(f).sum::<f32>() / runs.len().max(1) as f32
                    };
                    let (turbulence, misfit) = (mean(|r| r.turbulence), mean(|r| r.misfit));
                    let model_runs = runs.iter().map(|r| r.model_runs).sum();
                    // The flown preflight FDI's verdict on the flight's first window.
                    let preflight = runs
                        .first()
                        .map_or((Domain::Within, f64::NAN), |r| r.preflight);
                    let flight = match fusion.final_reading(FLIGHT_MAX_FRICTION_STD) {
                        Ok(f) => {
                            let (u, corr) = &f.uncertainty;
                            let (healthy_max, false_faults, covered) = against_truth(
                                &truth,
                                &f.faults,
                                &u.assess_at(&f.faults, corr, threshold),
                                Some(u),
                            );
                            FlightRun {
                                seed,
                                turbulence,
                                misfit,
                                found: f.faults,
                                std: u.std,
                                shared_std: f.shared_std,
                                agreement: agree(Some(u)),
                                preflight,
                                window: (f.verdict, f64::from(total_error(&f.faults, &truth))),
                                healthy_max,
                                false_faults,
                                covered,
                                windows: runs.len() as u32,
                                model_runs,
                                pinned: pinned_entered,
                                pinned_misfit: f32::NAN,
                                pinned_floor: f32::NAN,
                                pre_found,
                                pre_std,
                            }
                        }
                        // No window of the flight could be fused: the flight is named by
                        // its first window's reason (`unconfirmed` if that one was read).
                        Err(_) => FlightRun {
                            seed,
                            turbulence,
                            misfit,
                            found: FaultVector::NOMINAL,
                            std: [f32::NAN; shared::FAULT_COUNT],
                            shared_std: [0.0; shared::FAULT_COUNT],
                            agreement: (0, 0),
                            preflight,
                            window: (
                                first_reason.filter(|v| v.is_err()).unwrap_or(Err(
                                    WindowReason::Unconfirmed {
                                        windows: fusion.windows(),
                                        disagreement: f32::NAN,
                                    },
                                )),
                                f64::NAN,
                            ),
                            healthy_max: 0.0,
                            false_faults: 0,
                            covered: (0, 0),
                            windows: runs.len() as u32,
                            model_runs,
                            pinned: 0,
                            pinned_misfit: f32::NAN,
                            pinned_floor: f32::NAN,
                            pre_found,
                            pre_std,
                        },
                    };
                    Ok((runs, Some(flight)))
                })
                .collect::<Result<Vec<_>>>()?;
            let mut row = FlightRow {
                case,
                truth,
                window,
                runs: Vec::new(),
                flights: Vec::new(),
            };
            for (runs, flight) in flights {
                row.runs.extend(runs);
                row.flights.extend(flight);
            }
            progress(&row);
            rows.push(row);
        }
    }
    Ok(rows)
}

/// Index of the eccentricity's phase in a fault vector.
const ECCENTRICITY_PHASE: usize = 6;

/// The reason of a preflight verdict, in the health log's words.
fn reason(d: &Domain) -> &'static str {
    shared::health::DomainCode::from(*d).name()
}

/// The name of a window's verdict.
pub fn window_reason(v: &Result<(), WindowReason>) -> &'static str {
    // The health log's words: one naming for the report and the record.
    shared::health::DomainCode::from(*v).name()
}

/// `names` counted, in order of first appearance: "a 3, b 1".
fn tally<'a>(names: impl Iterator<Item = &'a str>) -> String {
    let mut counts: Vec<(&str, usize)> = Vec::new();
    for name in names {
        match counts.iter_mut().find(|(n, _)| *n == name) {
            Some((_, c)) => *c += 1,
            None => counts.push((name, 1)),
        }
    }
    counts
        .iter()
        .map(|(n, c)| format!("{n} {c}"))
        .collect::<Vec<_>>()
        .join(", ")
}

fn median(mut x: Vec<f64>) -> Option<f64> {
    x.sort_by(f64::total_cmp);
    let n = x.len();
    match n {
        0 => None,
        _ if n % 2 == 1 => Some(x[n / 2]),
        _ => Some(0.5 * (x[n / 2 - 1] + x[n / 2])),
    }
}

/// The campaign as Markdown: per window and case, the window identification's verdicts and
/// accuracy, the flights' fused readings (when a flight has several windows), then the
/// preflight identification's verdicts on the same windows.
pub fn flight_markdown(rows: &[FlightRow], actuator: &str) -> String {
    let runs = rows.first().map_or(0, |r| r.runs.len());
    let mut text = format!(
        "### The window identification on flight windows: {actuator}, {runs} runs per row\n\n\
         The window: the test's chirp alone on the flight control computer's corrections, \
         the hinge moment of trim and Dryden turbulence at the phase's dynamic pressure \
         (docs/in-flight.md). The monitor model follows the recorded command from an \
         equilibrium under the fitted hinge moment, with the fitted stiffness and trend \
         (docs/in-flight.md). Verdicts by reason; e_tot [%] of the windows left \
         `within`; on the healthy components of the `within` windows, the largest reading \
         and the false `FAULT` verdicts (a 90 % interval beyond the threshold); the 90 % \
         intervals that hold the truth.\n\n"
    );
    text.push_str(&readings_table(rows, |r| &r.runs, "windows"));
    let mut model_runs: Vec<u32> = rows
        .iter()
        .flat_map(|r| r.runs.iter().map(|w| w.model_runs))
        .collect();
    model_runs.sort_unstable();
    if let Some(&most) = model_runs.last() {
        text.push_str(&format!(
            "Monitor-model runs per window identification with its load fitted, what the \
             controller spends (a curvature counts 13; a window read pinned on the host adds \
             its own): median {}, most {most}.\n\n",
            model_runs[model_runs.len() / 2]
        ));
    }
    let flights = rows.first().map_or(0, |r| r.flights.len());
    if flights > 0 {
        let counts: Vec<u32> = rows
            .iter()
            .flat_map(|r| r.flights.iter().map(|f| f.windows))
            .collect();
        let (least, most) = (
            counts.iter().copied().min().unwrap_or(0),
            counts.iter().copied().max().unwrap_or(0),
        );
        let per_flight = if least == most {
            format!("{least} windows each")
        } else {
            format!(
                "{least}–{most} windows each (a flight flies more while only its friction \
                 deviation keeps it out and more can bring it within, `shared::fusion::\
                 FlightLength`; {:.1} on average)",
                counts.iter().sum::<u32>() as f64 / counts.len().max(1) as f64
            )
        };
        text.push_str(&format!(
            "### A flight's reading from its windows: {actuator}, {flights} flights per row, \
             {per_flight}\n\n\
             Each flight's windows that are `within` or named `turbulence_too_high` fused \
             (`shared::fusion`: their fits' quadratics added, minimised in the fault box); \
             the flight named `unconfirmed` with fewer than two such windows or when they \
             disagree beyond their deviations, `turbulence_too_high` when its fused \
             friction deviation is above {FLIGHT_MAX_FRICTION_STD}, and by its first window's reason when no \
             window could be fused. Columns as above, per flight.\n\n",
        ));
        text.push_str(&readings_table(rows, |r| &r.flights, "flights"));
    }
    text.push_str(&format!(
        "### The preflight identification on the same windows: {actuator}\n\n\
         The flown preflight FDI reads the window as a preflight: its monitor model plays \
         the chirp alone. Verdicts by reason; e_tot [%] of any run left `within`.\n\n\
         | phase | turbulence | case | verdicts | within: e_tot |\n\
         | --- | --- | --- | --- | ---: |\n"
    ));
    let (mut within_total, mut total) = (0, 0);
    for row in rows {
        let verdicts = tally(row.runs.iter().map(|r| reason(&r.preflight.0)));
        let within: Vec<String> = row
            .runs
            .iter()
            .filter(|r| r.preflight.0 == Domain::Within)
            .map(|r| format!("{:.1}", r.preflight.1))
            .collect();
        within_total += within.len();
        total += row.runs.len();
        text.push_str(&format!(
            "| {:?} | {:?} | {} | {verdicts} | {} |\n",
            row.window.phase,
            row.window.turbulence,
            row.case,
            if within.is_empty() {
                "–".to_string()
            } else {
                within.join(", ")
            }
        ));
    }
    text.push_str(&format!(
        "\n{within_total} of {total} windows left `within`.\n"
    ));
    text
}

/// The readings (a row's windows or flights, `select`) per row: verdicts, accuracy of the
/// identified, healthy components, intervals, agreement; then the totals and the
/// intervals' calibration per component.
fn readings_table(
    rows: &[FlightRow],
    select: fn(&FlightRow) -> &[FlightRun],
    noun: &str,
) -> String {
    let mut text = String::from(
        "| phase | turbulence | case | verdicts | within: median e_tot | max e_tot | \
         healthy components: max | false FAULT | intervals holding the truth | \
         agreeing with the preflight |\n\
         | --- | --- | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |\n",
    );
    let (mut within_total, mut total, mut wrong) = (0, 0, 0);
    let (mut false_total, mut held, mut intervals) = (0, 0, 0);
    let (mut agreed, mut agreed_of) = (0, 0);
    for row in rows {
        let verdicts = tally(select(row).iter().map(|r| window_reason(&r.window.0)));
        let within: Vec<&FlightRun> = select(row).iter().filter(|r| r.window.0.is_ok()).collect();
        let e: Vec<f64> = within.iter().map(|r| r.window.1).collect();
        within_total += within.len();
        wrong += e.iter().filter(|&&x| x > 6.0).count();
        total += select(row).len();
        let healthy = within
            .iter()
            .map(|r| r.healthy_max)
            .fold(None, |m: Option<f32>, x| Some(m.map_or(x, |m| m.max(x))));
        let false_faults: usize = within.iter().map(|r| r.false_faults).sum();
        let (h, n) = within
            .iter()
            .fold((0, 0), |(h, n), r| (h + r.covered.0, n + r.covered.1));
        let (ag, compared) = within
            .iter()
            .fold((0, 0), |(a, n), r| (a + r.agreement.0, n + r.agreement.1));
        agreed += ag;
        agreed_of += compared;
        false_total += false_faults;
        held += h;
        intervals += n;
        text.push_str(&format!(
            "| {:?} | {:?} | {} | {verdicts} | {} | {} | {} | {false_faults} | {h} of {n} | \
             {ag} of {compared} |\n",
            row.window.phase,
            row.window.turbulence,
            row.case,
            median(e.clone()).map_or("–".into(), |m| format!("{m:.1}")),
            e.iter()
                .copied()
                .reduce(f64::max)
                .map_or("–".into(), |m| format!("{m:.1}")),
            healthy.map_or("–".into(), |m| format!("{m:.3}")),
        ));
    }
    text.push_str(&format!(
        "\n{within_total} of {total} {noun} identified (`within`); {wrong} of them with \
         e_tot above 6 %; {false_total} false `FAULT` verdicts on healthy components; the \
         90 % intervals hold the truth in {held} of {intervals} component-readings and \
         meet the same flight's preflight interval in {agreed} of {agreed_of}.\n\n"
    ));
    let flights = if noun == "flights" {
        ", then `shared::fusion::flight_inflation` (`FLIGHT_INFLATION`, the eccentricity's held beyond eight windows),"
    } else {
        ""
    };
    text.push_str(&format!(
        "Per component (the eccentricity's phase left out), the 90 % intervals of the \
             identified {noun} that hold the truth, and the factor on their deviations that \
             would make 90 % of them hold it (1.0 or less: calibrated or wide; \
             `shared::window::WINDOW_INFLATION`{flights} is already applied):"
    ));
    for (j, (held, n, factor)) in interval_calibration(rows, select).iter().enumerate() {
        if *n == 0 {
            continue;
        }
        text.push_str(&format!(
            " k{} {held}/{n} ({});",
            j + 1,
            factor.map_or("–".into(), |f| format!("×{f:.2}"))
        ));
    }
    text.pop();
    text.push_str(".\n\n");
    text
}

/// Per component, over the identified windows of `rows`: the 90 % intervals that hold the
/// truth, the intervals, and the factor on the stated deviations that would make them hold
/// it in 90 % (the 90th percentile of |error| / σ over [`shared::uncertainty::Z90`]; `None`
/// under ten intervals). How `shared::window::WINDOW_INFLATION` is chosen, and checked.
pub fn interval_calibration(
    rows: &[FlightRow],
    select: fn(&FlightRow) -> &[FlightRun],
) -> [(usize, usize, Option<f32>); shared::FAULT_COUNT] {
    core::array::from_fn(|j| {
        let mut z: Vec<f32> = rows
            .iter()
            .flat_map(|row| {
                select(row)
                    .iter()
                    .filter(|r| r.window.0.is_ok() && !r.std[j].is_nan() && j != ECCENTRICITY_PHASE)
                    .map(move |r| {
                        (r.found.as_array()[j] - row.truth.as_array()[j]).abs() / r.std[j]
                    })
            })
            .collect();
        z.sort_by(f32::total_cmp);
        let n = z.len();
        let held = z.iter().filter(|&&x| x <= shared::uncertainty::Z90).count();
        let factor = (n >= 10).then(|| z[(9 * n).div_ceil(10) - 1] / shared::uncertainty::Z90);
        (held, n, factor)
    })
}

/// Every window of the campaign as a CSV row, then every flight's fused reading (when a
/// flight has several windows): phase, turbulence, case, seed, `window` or `flight`, the
/// verdict, e_tot [%], its false `FAULT`s and largest healthy component, the turbulence
/// level and misfit (a flight's: its windows' mean), the preflight FDI's verdict on the
/// (first) window, the vector found, its deviations and the part of them the held preflight
/// values' error adds (shared by a flight's windows), the windows flown (1 for a window),
/// the windows read pinned and a window's pinned misfit (NaN: not tried), then the same
/// flight's preflight reading and its deviations (NaN where not `within`).
pub fn flight_runs_csv(rows: &[FlightRow]) -> String {
    let mut text = String::from(
        "phase,turbulence,case,seed,reading,verdict,e_tot_pct,false_faults,healthy_max,\
         turbulence_level,misfit,preflight_verdict",
    );
    for j in 1..=shared::FAULT_COUNT {
        text.push_str(&format!(",k{j}"));
    }
    for j in 1..=shared::FAULT_COUNT {
        text.push_str(&format!(",std_k{j}"));
    }
    for j in 1..=shared::FAULT_COUNT {
        text.push_str(&format!(",shared_k{j}"));
    }
    text.push_str(",windows,model_runs,pinned,pinned_misfit,pinned_floor");
    for j in 1..=shared::FAULT_COUNT {
        text.push_str(&format!(",pre_k{j}"));
    }
    for j in 1..=shared::FAULT_COUNT {
        text.push_str(&format!(",pre_std_k{j}"));
    }
    text.push('\n');
    for (reading, select) in [
        (
            "window",
            (|r: &FlightRow| r.runs.as_slice()) as fn(&FlightRow) -> &[FlightRun],
        ),
        ("flight", |r: &FlightRow| r.flights.as_slice()),
    ] {
        for row in rows {
            for r in select(row) {
                text.push_str(&format!(
                    "{:?},{:?},{},{},{reading},{},{:.3},{},{:.4},{:.4},{:.5},{}",
                    row.window.phase,
                    row.window.turbulence,
                    row.case,
                    r.seed,
                    window_reason(&r.window.0),
                    r.window.1,
                    r.false_faults,
                    r.healthy_max,
                    r.turbulence,
                    r.misfit,
                    reason(&r.preflight.0),
                ));
                for x in r.found.as_array().iter().chain(&r.std).chain(&r.shared_std) {
                    text.push_str(&format!(",{x:.5}"));
                }
                text.push_str(&format!(
                    ",{},{},{},{:.5},{:.5}",
                    r.windows, r.model_runs, r.pinned, r.pinned_misfit, r.pinned_floor
                ));
                for x in r.pre_found.as_array().iter().chain(&r.pre_std) {
                    text.push_str(&format!(",{x:.5}"));
                }
                text.push('\n');
            }
        }
    }
    text
}

/// The superimposed-test study as Markdown: per amplitude, window and case, the windows
/// identified, their median and worst e_tot, the false `FAULT` verdicts.
pub fn amplitude_markdown(study: &[(f32, Vec<FlightRow>)], actuator: &str) -> String {
    let runs = study
        .first()
        .and_then(|(_, rows)| rows.first())
        .map_or(0, |r| r.runs.len());
    let mut text = format!(
        "### The superimposed test's amplitude in cruise: {actuator}, {runs} runs per row\n\n\
         The window's chirp (0 → 15 Hz in 0.5 s) at each amplitude on the flight control \
         computer's corrections; the window identification. Identified: windows `within`; \
         e_tot [%] over them; false `FAULT`: verdicts on healthy components.\n\n\
         | amplitude [mrad] | turbulence | case | verdicts | identified | median e_tot | \
         max e_tot | false FAULT |\n\
         | ---: | --- | --- | --- | ---: | ---: | ---: | ---: |\n"
    );
    for (a, rows) in study {
        for row in rows {
            let within: Vec<&FlightRun> = row.runs.iter().filter(|r| r.window.0.is_ok()).collect();
            let e: Vec<f64> = within.iter().map(|r| r.window.1).collect();
            text.push_str(&format!(
                "| {:.2} | {:?} | {} | {} | {} of {} | {} | {} | {} |\n",
                1e3 * a,
                row.window.turbulence,
                row.case,
                tally(row.runs.iter().map(|r| window_reason(&r.window.0))),
                within.len(),
                row.runs.len(),
                median(e.clone()).map_or("–".into(), |m| format!("{m:.1}")),
                e.iter()
                    .copied()
                    .reduce(f64::max)
                    .map_or("–".into(), |m| format!("{m:.1}")),
                within.iter().map(|r| r.false_faults).sum::<usize>(),
            ));
        }
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plant::aero::{FlightPhase, FlightWindow, Turbulence};

    /// A within window whose friction reads `friction` with deviation `std`.
    fn run(seed: u64, friction: f32, std: f32) -> FlightRun {
        let mut genes = *FaultVector::NOMINAL.as_array();
        genes[0] = friction;
        let mut stds = [0.1; shared::FAULT_COUNT];
        stds[0] = std;
        FlightRun {
            seed,
            preflight: (Domain::Within, 0.0),
            window: (Ok(()), 1.0),
            healthy_max: 0.0,
            false_faults: 0,
            covered: (0, 0),
            turbulence: 0.05,
            misfit: 0.003,
            found: FaultVector::saturating(genes),
            std: stds,
            shared_std: [0.0; shared::FAULT_COUNT],
            agreement: (0, 0),
            windows: 1,
            model_runs: 0,
            pinned: 0,
            pinned_misfit: f32::NAN,
            pinned_floor: f32::NAN,
            pre_found: FaultVector::NOMINAL,
            pre_std: [0.02; shared::FAULT_COUNT],
        }
    }

    #[test]
    fn the_interval_factor_is_the_ninetieth_percentile_of_the_errors_over_z90() {
        // Friction errors of 0.01 … 0.20 at σ 0.01 (z = 1 … 20): 20 windows, the 18th
        // largest |z| is 18.
        let mut runs: Vec<FlightRun> = (1..=20).map(|i| run(i, i as f32 * 0.01, 0.01)).collect();
        // A window named outside counts nowhere.
        let mut outside = run(99, 0.9, 0.01);
        outside.window.0 = Err(WindowReason::PlayUnseen { contrast: 0.1 });
        runs.push(outside);
        let rows = [FlightRow {
            case: "healthy",
            truth: FaultVector::NOMINAL,
            window: FlightWindow {
                phase: FlightPhase::Cruise,
                turbulence: Turbulence::Light,
            },
            runs,
            flights: vec![run(7, 0.02, 0.01)],
        }];
        let calibration = interval_calibration(&rows, |r| &r.runs);
        let (held, n, factor) = calibration[0];
        assert_eq!((held, n), (1, 20));
        let factor = factor.expect("20 intervals");
        assert!(
            (factor - 18.0 / shared::uncertainty::Z90).abs() < 1e-3,
            "{factor}"
        );
        // Exact components: every interval holds, the factor is zero; the phase is skipped.
        assert_eq!(calibration[1].0, 20);
        assert_eq!(calibration[1].2, Some(0.0));
        assert_eq!(calibration[ECCENTRICITY_PHASE].1, 0);
        // The flights' readings are counted apart.
        assert_eq!(interval_calibration(&rows, |r| &r.flights)[0].1, 1);
        // The runs' CSV: a header, one line per window, then one per flight, 12 + 3 × 9 + 5
        // + 2 × 9 fields each (the windows flown, their model runs, those read pinned, the
        // pinned misfit and its sensor's share, then the preflight's reading and
        // deviations).
        let csv = flight_runs_csv(&rows);
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines.len(), 23);
        assert!(lines.iter().all(|l| l.split(',').count() == 62), "{csv}");
        assert!(lines[0].contains(",std_k9,shared_k1,"));
        assert!(lines[0].contains(",windows,model_runs,pinned,pinned_misfit,pinned_floor,pre_k1,"));
        assert!(lines[0].ends_with(",pre_std_k9"));
        assert!(
            lines[22].ends_with(",1,0,0,NaN,NaN,0.00000,0.00000,0.00000,0.00000,0.00000,0.00000,0.50000,0.50000,0.00000,0.02000,0.02000,0.02000,0.02000,0.02000,0.02000,0.02000,0.02000,0.02000"),
            "{}",
            lines[22]
        );
        assert!(lines[21].contains(",window,play_unseen,"));
        assert!(lines[22].contains(",7,flight,within,"));
    }
}
