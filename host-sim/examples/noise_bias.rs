//! Is the preflight's lean under I_ref noise the bias of a nonlinear least-squares fit?
//!
//! A fit of a nonlinear model to data with zero-mean noise is biased at second order in the
//! noise (Box 1971): `b ≈ −½ (JᵀWJ)⁻¹ JᵀW v`, `v_i = tr(H_i C)`, with `J` the model's
//! Jacobian, `H_i` sample i's Hessian and `C` the estimate's covariance. With `C = L Lᵀ`,
//! `tr(H_i C) = Σ_k l_kᵀ H_i l_k`, which the model gives as second differences along the
//! columns `l_k` of `L`: `m_i(k̂ + l_k) − 2 m_i(k̂) + m_i(k̂ − l_k)` (a step of one standard
//! deviation, which also carries what is not smooth at that scale).
//!
//! Per case and seed the reference actuator's preflight under I_ref noise is identified as
//! the FDI does (GA, polish, weak-magnet search, reading), and the same test is simulated
//! without the noise (the same seed: the same sensor noise). Printed per case, over the
//! components away from their bounds (more than 3 of the reading's own white-noise σ; the
//! eccentricity's phase held), mean ± scatter over the seeds:
//!
//! * `as read` — the error (found − true) as the FDI reports it;
//! * Box's bias taken off, `C` the reading's own (`s²·share·(JᵀWJ)⁻¹`, the residual's
//!   variance times its noise share, as the free-phase correction takes it: what a
//!   controller could do), or `C` the found vectors' covariance over the seeds (an oracle);
//! * the noise's current alone: the least-squares move `(JᵀWJ)⁻¹JᵀW (r_noisy − r_quiet)`
//!   that the difference of the two tests' filtered currents makes at the found vector. A
//!   zero-mean noise moves it by nothing on average; a mean away from zero is a part of the
//!   noisy test's current the monitor model does not play;
//! * the same with the periods where the bridge put the bus's full voltage across two legs
//!   (the current loop saturated; `applied_voltages` of the reference model's truth) and the
//!   two after each given no weight.
//!
//! * a hysteresis drive's slew shortfall, in closed form from the reference model's truth:
//!   each period's step `Δ` of the current reference is reached after `L·|Δ|/(V ∓ E)`, the
//!   period's mean current falls short of it by `Δ·t_s/(2T)`, and the loops are taken to make
//!   that up in full with sampled current (the noisy test's shortfall less the quiet test's,
//!   filtered); its least-squares move.
//!
//! `NOISE_BIAS_MODEL=measured` identifies with the monitor model playing that shortfall
//! (`MonitorModel::with_reference_steps`) at the step power read from the test itself (the
//! unfiltered equivalent current's mean square step over the chirp); `=truth` at the
//! reference model's own (the noisy reference's less the quiet one's).
//!
//! Studies of the mechanism, not results: `NOISE_BIAS_BUS=V` plays another bus voltage,
//! `NOISE_BIAS_BRIDGE=ideal` an ideal bridge, `NOISE_BIAS_BAND=A` another hysteresis band
//! (all off the calibration's: their `as read` rows carry that mismatch).
//! `NOISE_BIAS_ACTUATOR=FILE.toml` runs another actuator's description.
//!
//! `cargo run --release -p host-sim --example noise_bias [SEEDS [NOISE]]` (12 seeds and the
//! paper's 0.5 by default; ≈ 0.4 s per seed and case on one core).

// Small dense matrices read best indexed.
#![allow(clippy::needless_range_loop)]

use std::ops::ControlFlow;

use anyhow::Result;
use host_sim::fdi::identify::{command_table, onboard_identification, SLICE};
use host_sim::files::actuator::Actuator;
use host_sim::plant::reference::{ReferenceModel, Scenario};
use shared::fault::{ECCENTRICITY_PHASE_INDEX, FAULT_COUNT};
use shared::fitness::{CurvatureRun, STANDSTILL_WEIGHT};
use shared::monitor::MonitorSample;
use shared::{FaultVector, Status};

mod noise_cases;
use noise_cases::{equivalent, CASES};

/// The components printed: friction, backlash, short A, eccentricity, gain drift.
const SHOWN: [(usize, &str); 5] = [
    (0, "friction"),
    (1, "backlash"),
    (2, "short A"),
    (5, "eccentricity"),
    (7, "gain drift"),
];

/// Filtered model currents of `k` over the measured samples, as the fitness sees them.
fn currents(
    problem: &shared::FitnessProblem<'_, { shared::fdi::TEST_SAMPLES }>,
    measured: &shared::fdi::OnboardMeasured,
    k: &[f32; FAULT_COUNT],
) -> Vec<f64> {
    let model = problem.model();
    let filter = measured.filter();
    let mut state = shared::conditioning::LowPassState::default();
    let mut out = Vec::with_capacity(measured.samples().len());
    model.run_with(
        &FaultVector::saturating(*k),
        measured.initial_angles(),
        measured.samples().len(),
        &model.sampler(),
        |s: &MonitorSample| {
            out.push(f64::from(filter.apply(&mut state, s.current)));
            ControlFlow::Continue(())
        },
    );
    out
}

/// Eq. (3)'s weight of each measured sample (0 where it is not fitted).
fn weights(measured: &shared::fdi::OnboardMeasured) -> Result<Vec<f64>> {
    let r = measured.samples();
    let lead = measured.lead_samples();
    let inv_kappa = measured
        .inv_kappa()
        .map_err(|e| anyhow::anyhow!("κ: {e:?}"))?;
    let standstill = measured.test().standstill;
    let mut previous = 0.0f32;
    Ok(r.iter()
        .enumerate()
        .map(|(i, &x)| {
            if i < lead {
                if standstill.is_some_and(|s| s.fitted(i)) {
                    f64::from(STANDSTILL_WEIGHT)
                } else {
                    0.0
                }
            } else {
                let d = x - previous;
                previous = x;
                f64::from(1.0 / (d * d * inv_kappa + 1.0))
            }
        })
        .collect())
}

/// Lower Cholesky factor of a symmetric positive definite matrix; `None` if it is not.
fn cholesky(a: &[Vec<f64>]) -> Option<Vec<Vec<f64>>> {
    let n = a.len();
    let mut l = vec![vec![0.0; n]; n];
    for i in 0..n {
        for j in 0..=i {
            let s: f64 = (0..j).map(|k| l[i][k] * l[j][k]).sum();
            if i == j {
                let d = a[i][i] - s;
                if d <= 0.0 {
                    return None;
                }
                l[i][i] = d.sqrt();
            } else {
                l[i][j] = (a[i][j] - s) / l[j][j];
            }
        }
    }
    Some(l)
}

/// `a⁻¹` of a symmetric positive definite matrix.
fn inverse(a: &[Vec<f64>]) -> Option<Vec<Vec<f64>>> {
    let n = a.len();
    let l = cholesky(a)?;
    let mut inv = vec![vec![0.0; n]; n];
    for c in 0..n {
        // Solve L y = e_c, then Lᵀ x = y.
        let mut y = vec![0.0; n];
        for i in 0..n {
            let e = if i == c { 1.0 } else { 0.0 };
            y[i] = (e - (0..i).map(|k| l[i][k] * y[k]).sum::<f64>()) / l[i][i];
        }
        for i in (0..n).rev() {
            let s: f64 = (i + 1..n).map(|k| l[k][i] * inv[k][c]).sum();
            inv[i][c] = (y[i] - s) / l[i][i];
        }
    }
    Some(inv)
}

/// `JᵀWJ` of the Jacobian's rows (one per component) under weights `w`.
fn normal(jacobian: &[Vec<f64>], w: &[f64]) -> Vec<Vec<f64>> {
    jacobian
        .iter()
        .map(|ja| {
            jacobian
                .iter()
                .map(|jb| ja.iter().zip(jb).zip(w).map(|((a, b), w)| a * b * w).sum())
                .collect()
        })
        .collect()
}

/// The least-squares move `(JᵀWJ)⁻¹JᵀW d` that data `d` make, per free component, on the
/// reading's scale (`None` if `JᵀWJ` is not positive definite).
fn first_order(run: &Run, w: &[f64], d: &[f64]) -> Option<[f64; FAULT_COUNT]> {
    let inv = inverse(&normal(&run.jacobian, w))?;
    let jwd: Vec<f64> = run
        .jacobian
        .iter()
        .map(|ja| ja.iter().zip(w).zip(d).map(|((j, w), d)| j * w * d).sum())
        .collect();
    let mut out = [0.0; FAULT_COUNT];
    for (a, &ia) in run.free.iter().enumerate() {
        out[ia] =
            inv[a].iter().zip(&jwd).map(|(x, y)| x * y).sum::<f64>() * f64::from(run.scale[ia]);
    }
    Some(out)
}

/// One seed's identification and what the bias needs of it.
struct Run {
    /// The solver's vector and its reading (free-phase corrected, as reported).
    solver: [f32; FAULT_COUNT],
    read: [f32; FAULT_COUNT],
    /// d reading / d solver per component (the friction's reading scale; 1 elsewhere).
    scale: [f32; FAULT_COUNT],
    /// Components away from their bounds, the model's Jacobian over them per sample, the
    /// found vector's currents, eq. (3)'s weights.
    free: Vec<usize>,
    jacobian: Vec<Vec<f64>>,
    base: Vec<f64>,
    weights: Vec<f64>,
    /// The reading's own noise variance per sample: s²·share.
    noise_variance: f64,
    /// The noisy test's filtered current less the quiet test's, sample by sample.
    noise_current: Vec<f64>,
    /// A hysteresis drive's predicted slew shortfall, noisy less quiet, filtered.
    predicted: Vec<f64>,
    /// The periods at the bus's full voltage across two legs.
    saturated: Vec<bool>,
    measured: Box<shared::fdi::OnboardMeasured>,
    seed: u64,
    model_noise: f32,
}

/// Box's bias at the run's vector for covariance `c` over its free components, on the
/// reading's scale (`None` if `c` or `JᵀWJ` is not positive definite).
fn bias(
    run: &Run,
    problem: &shared::FitnessProblem<'_, { shared::fdi::TEST_SAMPLES }>,
    c: &[Vec<f64>],
) -> Option<[f64; FAULT_COUNT]> {
    let l = cholesky(c)?;
    let mut v = vec![0.0; run.base.len()];
    for k in 0..run.free.len() {
        let mut up = run.solver;
        let mut down = run.solver;
        for (a, &ia) in run.free.iter().enumerate() {
            up[ia] += l[a][k] as f32;
            down[ia] -= l[a][k] as f32;
        }
        let mu = currents(problem, &run.measured, &up);
        let md = currents(problem, &run.measured, &down);
        for (i, x) in v.iter_mut().enumerate() {
            *x += mu[i] - 2.0 * run.base[i] + md[i];
        }
    }
    first_order(run, &run.weights, &v).map(|b| b.map(|x| -0.5 * x))
}

/// Simulates and identifies one seed of `truth` as the FDI does, and takes what the bias
/// and the noise's current need.
fn identify_seed(
    rm: &ReferenceModel,
    record: &shared::actuator::ActuatorRecord,
    bus: f64,
    truth: FaultVector,
    noise: f64,
    seed: u64,
) -> Result<Run> {
    let params = record.params;
    let sim = rm.simulate(&Scenario {
        faults: truth,
        current_ref_noise: noise,
        seed,
    });
    let measured = sim.trace.measured(&params)?;
    anyhow::ensure!(
        sim.truth.len() == measured.samples().len(),
        "the truth and the trace differ in length"
    );
    let saturated = sim
        .truth
        .iter()
        .map(|t| {
            let v = t.applied_voltages;
            let hi = v.iter().copied().fold(f64::MIN, f64::max);
            let lo = v.iter().copied().fold(f64::MAX, f64::min);
            hi - lo >= 0.98 * bus
        })
        .collect();
    let quiet_sim = rm.simulate(&Scenario {
        faults: truth,
        current_ref_noise: 0.0,
        seed,
    });
    let quiet = quiet_sim.trace.measured(&params)?;
    // What a hysteresis drive's slew predicts: each period's step of the reference is
    // reached after `L·|Δ|/(V ∓ E)` (slower against the back-EMF), the period's mean current
    // falls short of the new reference by `Δ·t_s/(2T)`, and the loops make that torque up
    // with sampled current. The noisy test's shortfall less the quiet test's, through the
    // conditioning's filter, from the chirp's first sample.
    let lead = measured.lead_samples();
    let shortfall = |truth: &[host_sim::plant::reference::TruthSample]| -> Vec<f64> {
        let l = 2.0 * f64::from(params.phase_inductance);
        let period = f64::from(params.control_period);
        let kt = f64::from(params.torque_constant());
        let mut previous = 0.0;
        truth
            .iter()
            .enumerate()
            .map(|(n, t)| {
                let step = t.current_ref - previous;
                previous = t.current_ref;
                if n < lead {
                    return 0.0;
                }
                let emf = kt * t.motor_speed;
                let available = (bus - step.signum() * emf).max(1.0);
                let slew = (l * step.abs() / available).min(period);
                step * slew / (2.0 * period)
            })
            .collect()
    };
    let predicted = {
        let filter = measured.filter();
        let mut state = shared::conditioning::LowPassState::default();
        shortfall(&sim.truth)
            .iter()
            .zip(shortfall(&quiet_sim.truth))
            .map(|(a, b)| f64::from(filter.apply(&mut state, (a - b) as f32)))
            .collect()
    };
    let step_variance = |truth: &[host_sim::plant::reference::TruthSample]| -> f64 {
        let steps: Vec<f64> = truth[lead..]
            .windows(2)
            .map(|w| w[1].current_ref - w[0].current_ref)
            .collect();
        steps.iter().map(|d| d * d).sum::<f64>() / steps.len() as f64
    };
    // The measured equivalent current's mean square step over the chirp, unfiltered.
    let pole_pairs = params.pole_pairs;
    let raw: Vec<f64> = sim
        .trace
        .samples()
        .iter()
        .map(|t| equivalent(t, pole_pairs))
        .collect();
    let measured_steps = raw[lead..]
        .windows(2)
        .map(|w| (w[1] - w[0]).powi(2))
        .sum::<f64>()
        / (raw.len() - lead - 1) as f64;
    let model_noise = match std::env::var("NOISE_BIAS_MODEL").as_deref() {
        Ok("truth") => {
            (step_variance(&sim.truth) - step_variance(&quiet_sim.truth)).max(0.0) as f32
        }
        Ok("measured") => measured_steps as f32,
        Ok(other) => anyhow::bail!("NOISE_BIAS_MODEL takes `truth` or `measured`, not `{other}`"),
        Err(_) => 0.0,
    };
    let table = command_table(&measured, record);
    let mut id = onboard_identification(&measured, record, record.ga, 1 + seed, &table)?
        .with_reference_steps(model_noise);
    while !matches!(id.step(SLICE), Status::Done(_)) {}
    let mut cr = Box::new(CurvatureRun::IDLE);
    let polished = id.polished(record.polish, &mut cr);
    let result = id.with_weak_magnet(polished, record.polish, &mut cr);
    let curvature = id.problem().curvature_in(&mut cr, &result.faults);
    let (read, _) = id.read(result, &curvature, &record.systematic);
    let problem = id.problem();
    let solver = *result.faults.as_array();
    let mut scale = [1.0f32; FAULT_COUNT];
    scale[0] = problem.model().reading_scale();
    let base = currents(problem, &measured, &solver);
    // Forward differences of 0.01 (down where up would leave [0, 1]); the phase held.
    let all: Vec<usize> = (0..FAULT_COUNT)
        .filter(|&i| i != ECCENTRICITY_PHASE_INDEX)
        .collect();
    let jacobian_all: Vec<Vec<f64>> = all
        .iter()
        .map(|&i| {
            let mut g = solver;
            let h = if g[i] + 0.01 <= 1.0 { 0.01 } else { -0.01 };
            g[i] += h;
            currents(problem, &measured, &g)
                .iter()
                .zip(&base)
                .map(|(a, b)| (a - b) / f64::from(h))
                .collect()
        })
        .collect();
    let weights = weights(&measured)?;
    let excess = f64::from(result.fitness.max(0.0));
    let share = excess / (excess + f64::from(problem.nominal_residual().max(0.0)));
    let dof = (f64::from(curvature.fitted) - FAULT_COUNT as f64).max(1.0);
    let noise_variance = curvature.rss / dof * share;
    let inv_all = inverse(&normal(&jacobian_all, &weights))
        .ok_or_else(|| anyhow::anyhow!("seed {seed}: JᵀWJ not positive definite"))?;
    // Away from the bounds by 3 of the reading's own white-noise deviations.
    let keep: Vec<usize> = (0..all.len())
        .filter(|&a| {
            let s = (inv_all[a][a] * noise_variance).sqrt() as f32;
            let x = solver[all[a]];
            x > 3.0 * s && x < 1.0 - 3.0 * s
        })
        .collect();
    let noise_current = measured
        .samples()
        .iter()
        .zip(quiet.samples())
        .map(|(a, b)| f64::from(a - b))
        .collect();
    Ok(Run {
        solver,
        read: *read.faults.as_array(),
        scale,
        free: keep.iter().map(|&a| all[a]).collect(),
        jacobian: keep.iter().map(|&a| jacobian_all[a].clone()).collect(),
        base,
        weights,
        noise_variance,
        noise_current,
        predicted,
        saturated,
        measured,
        seed,
        model_noise,
    })
}

const WAYS: [&str; 6] = [
    "as read",
    "Box's bias off, C the reading's own",
    "Box's bias off, C over the seeds (oracle)",
    "the noise's current alone: its least-squares move",
    "the same, the saturated periods and the two after each unweighted",
    "a hysteresis drive's slew shortfall (closed form): its least-squares move",
];

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let seeds: u64 = args.next().map_or(Ok(12), |a| a.parse())?;
    let noise: f64 = args.next().map_or(Ok(0.5), |a| a.parse())?;
    anyhow::ensure!(
        seeds >= 3,
        "SEEDS must be at least 3 (a covariance over seeds)"
    );
    anyhow::ensure!(
        (0.0..=1.0).contains(&noise),
        "NOISE is a fraction of the nominal I_ref RMS, 0 … 1"
    );
    let actuator = match std::env::var("NOISE_BIAS_ACTUATOR") {
        Ok(path) => Actuator::load(std::path::Path::new(&path))?,
        Err(_) => Actuator::reference(),
    };
    let record = actuator.record;
    let mut settings = actuator.reference_settings()?;
    if let Ok(v) = std::env::var("NOISE_BIAS_BRIDGE") {
        anyhow::ensure!(v == "ideal", "NOISE_BIAS_BRIDGE takes `ideal`");
        settings.bridge = host_sim::plant::bridge::BridgeSettings::IDEAL;
    }
    if let Ok(v) = std::env::var("NOISE_BIAS_BUS") {
        settings.conditions.bus_voltage = Some(v.parse()?);
    }
    if let Ok(v) = std::env::var("NOISE_BIAS_BAND") {
        settings.hysteresis_band = v.parse()?;
    }
    let bus = settings
        .conditions
        .bus_voltage
        .unwrap_or(f64::from(record.params.dc_bus_voltage));
    let rm = ReferenceModel::new(settings).with_test(record.test);
    if let Ok(v) = std::env::var("NOISE_BIAS_MODEL") {
        println!(
            "the monitor model plays the drive's slew shortfall (`with_reference_steps`) at the \
             reference's step power from the {v} currents"
        );
    }
    println!(
        "I_ref noise {noise}, {seeds} seeds per case, {}'s preflight, bus {bus} V{}",
        actuator.name,
        if settings.bridge == host_sim::plant::bridge::BridgeSettings::IDEAL {
            ", an ideal bridge"
        } else {
            ""
        }
    );
    for (name, k) in CASES {
        let truth = FaultVector::new(k).map_err(|e| anyhow::anyhow!("{e:?}"))?;
        let runs = (0..seeds)
            .map(|seed| identify_seed(&rm, &record, bus, truth, noise, seed))
            .collect::<Result<Vec<_>>>()?;
        // The oracle's covariance over the seeds, on the solver's scale.
        let n = runs.len() as f64;
        let mean: Vec<f64> = (0..FAULT_COUNT)
            .map(|i| runs.iter().map(|r| f64::from(r.solver[i])).sum::<f64>() / n)
            .collect();
        let cov = |a: usize, b: usize| {
            runs.iter()
                .map(|r| (f64::from(r.solver[a]) - mean[a]) * (f64::from(r.solver[b]) - mean[b]))
                .sum::<f64>()
                / (n - 1.0)
        };
        let mut rows: Vec<[[f64; FAULT_COUNT]; WAYS.len()]> = Vec::new();
        let mut saturated_share = 0.0;
        for run in &runs {
            // The problem again (the same: a fresh identification's), for the sigma points.
            let table = command_table(&run.measured, &record);
            let id =
                onboard_identification(&run.measured, &record, record.ga, 1 + run.seed, &table)?
                    .with_reference_steps(run.model_noise);
            let problem = id.problem();
            let nope = || anyhow::anyhow!("seed {}: a matrix not positive definite", run.seed);
            let own_inv = inverse(&normal(&run.jacobian, &run.weights)).ok_or_else(nope)?;
            let own: Vec<Vec<f64>> = own_inv
                .iter()
                .map(|row| row.iter().map(|x| x * run.noise_variance).collect())
                .collect();
            let over_seeds: Vec<Vec<f64>> = run
                .free
                .iter()
                .map(|&a| run.free.iter().map(|&b| cov(a, b)).collect())
                .collect();
            let error = |b: &[f64; FAULT_COUNT]| -> [f64; FAULT_COUNT] {
                core::array::from_fn(|i| f64::from(run.read[i]) - b[i] - f64::from(k[i]))
            };
            let lead = run.measured.lead_samples();
            let unsaturated: Vec<f64> = (0..run.weights.len())
                .map(|i| {
                    if (i.saturating_sub(2)..=i).any(|j| run.saturated[j]) {
                        0.0
                    } else {
                        run.weights[i]
                    }
                })
                .collect();
            saturated_share += run.saturated.iter().skip(lead).filter(|&&x| x).count() as f64
                / (run.saturated.len() - lead) as f64
                / n;
            rows.push([
                error(&[0.0; FAULT_COUNT]),
                error(&bias(run, problem, &own).ok_or_else(nope)?),
                error(&bias(run, problem, &over_seeds).ok_or_else(nope)?),
                first_order(run, &run.weights, &run.noise_current).ok_or_else(nope)?,
                first_order(run, &unsaturated, &run.noise_current).ok_or_else(nope)?,
                first_order(run, &run.weights, &run.predicted).ok_or_else(nope)?,
            ]);
        }
        println!();
        println!(
            "## {name} (the bus's full voltage across two legs in {:.2} % of the chirp's periods)",
            100.0 * saturated_share
        );
        println!();
        println!("| way | {} |", SHOWN.map(|(_, n)| n).join(" | "));
        println!("| --- |{}", " ---: |".repeat(SHOWN.len()));
        for (w, way) in WAYS.iter().enumerate() {
            let cells: Vec<String> = SHOWN
                .iter()
                .map(|&(i, _)| {
                    let v: Vec<f64> = rows.iter().map(|r| r[w][i]).collect();
                    let m = v.iter().sum::<f64>() / n;
                    let sd = (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
                    format!("{m:+.4} ± {sd:.4}")
                })
                .collect();
            println!("| {way} | {} |", cells.join(" | "));
        }
    }
    Ok(())
}
