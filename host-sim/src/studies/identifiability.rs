//! Identifiability of the fault vector from one preflight test design, before any campaign.
//!
//! For a design and an operating point `k`, the reference model is run on `seeds` noise seeds
//! at `k` and at `k ± h·e_j` for each component `j` (common random numbers: the same seed on
//! both sides). `y` is everything the FDI fits: the conditioned, filtered equivalent current
//! (the excited pair's current during a standstill segment) and, for the applied-voltage
//! design, the conducting pair's filtered mean line voltage that the controller knows from
//! its own switching.
//!
//! * `J = ∂y/∂k` — central differences (one-sided at a bound), averaged over the seeds.
//! * `Σ` — per-sample variance of `y` over the seeds at `k` (diagonal).
//! * `F = Jᵀ Σ⁻¹ J` — its singular values (√ of F's eigenvalues) and condition number.
//! * Predicted one-test standard deviation of each component: `√diag(F⁻¹)`, which assumes
//!   white noise, and the scatter of the linearised estimate `F⁻¹ Jᵀ Σ⁻¹ (y_s − ȳ)` over the
//!   seeds, which keeps the noise's real correlation (filtered ripple, sensor noise).
//!
//! Work: `seeds · (1 + 2·p)` reference-model runs per design and point (p ≤ 8 components;
//! the eccentricity phase is left out where the eccentricity is 0, where it has no effect),
//! in parallel. Units of the standard deviations: the fault vector's [0, 1] range.

use anyhow::{bail, Result};
use rayon::prelude::*;
use shared::conditioning::commutation_signs;
use shared::fault::{FAULT_COUNT, FAULT_NAMES};
use shared::test_design::{Drive, PreflightTest};
use shared::{ActuatorParams, FaultVector, LowPass};

use crate::plant::reference::{ReferenceModel, ReferenceSettings, Scenario, Simulation};
use crate::studies::campaign::TABLE_2;

/// A test design of the study.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Design {
    /// The paper's chirp, phase currents only.
    Paper,
    /// a. Voltage steps on each phase pair at standstill, then the chirp.
    Standstill,
    /// b. The chirp with the applied-voltage channel (mean leg voltages per period).
    Voltage,
    /// c. Moves of ±7 mrad at the user shaft (1.1 motor revolutions), then the chirp.
    Motion,
    /// a + b: the standstill segment and the applied-voltage channel.
    StandstillVoltage,
}

impl Design {
    pub const ALL: [Self; 5] = [
        Self::Paper,
        Self::Standstill,
        Self::Voltage,
        Self::Motion,
        Self::StandstillVoltage,
    ];

    pub fn test(self) -> PreflightTest {
        match self {
            Self::Paper | Self::Voltage => PreflightTest::PAPER,
            Self::Standstill | Self::StandstillVoltage => PreflightTest::STANDSTILL,
            Self::Motion => PreflightTest::MOTION,
        }
    }

    fn voltage_channel(self) -> bool {
        matches!(self, Self::Voltage | Self::StandstillVoltage)
    }

    pub fn label(self) -> &'static str {
        match self {
            Self::Paper => "paper (chirp, currents)",
            Self::Standstill => "a. standstill pair steps + chirp",
            Self::Voltage => "b. chirp + applied-voltage channel",
            Self::Motion => "c. motion (±7 mrad) + chirp",
            Self::StandstillVoltage => "a + b",
        }
    }
}

/// The operating points of the study.
pub fn points() -> [(&'static str, FaultVector); 3] {
    [
        ("healthy", FaultVector::NOMINAL),
        ("Table II low", FaultVector::saturating(TABLE_2[0].faults)),
        (
            "Table II medium",
            FaultVector::saturating(TABLE_2[1].faults),
        ),
    ]
}

/// What the FDI fits, from one reference-model run (module docs).
pub fn measurement(design: Design, sim: &Simulation, params: &ActuatorParams) -> Result<Vec<f64>> {
    let filter = LowPass::for_control_period(params.control_period)
        .map_err(|e| anyhow::anyhow!("conditioning filter: {e:?}"))?;
    let test = design.test();
    let mut state = Default::default();
    let mut voltage_state = Default::default();
    let n = sim.trace.samples().len();
    let mut currents = Vec::with_capacity(n);
    let mut voltages = Vec::with_capacity(n);
    for (i, (s, truth)) in sim.trace.samples().iter().zip(&sim.truth).enumerate() {
        let signs = match test.drive(i, params.control_period) {
            Drive::Pair(d) => d.signs(),
            Drive::Position(_) => commutation_signs(params.pole_pairs * s.motor_angle as f32),
        };
        let signed = |x: [f64; 3]| -> f32 {
            (0.5 * (0..3).map(|j| f64::from(signs[j]) * x[j]).sum::<f64>()) as f32
        };
        currents.push(f64::from(
            filter.apply(&mut state, signed(s.phase_currents)),
        ));
        if design.voltage_channel() {
            voltages.push(f64::from(
                filter.apply(&mut voltage_state, signed(truth.applied_voltages)),
            ));
        }
    }
    currents.extend(voltages);
    Ok(currents)
}

/// The study of one design at one point.
#[derive(Clone, Debug, PartialEq)]
pub struct Study {
    pub design: Design,
    pub point: &'static str,
    /// Components studied (indices into the fault vector).
    pub components: Vec<usize>,
    /// Singular values of Σ^(−½)·J, largest first.
    pub singular_values: Vec<f64>,
    /// Predicted one-test standard deviation per component, white-noise formula.
    pub std_white: [Option<f64>; FAULT_COUNT],
    /// The same from the seeds' scatter of the linearised estimate.
    pub std_seeds: [Option<f64>; FAULT_COUNT],
    /// Largest correlation between two components' estimates (from F⁻¹), with the pair.
    pub worst_correlation: (f64, usize, usize),
    /// Length of `y`.
    pub samples: usize,
}

impl Study {
    pub fn condition(&self) -> f64 {
        match (self.singular_values.first(), self.singular_values.last()) {
            (Some(&hi), Some(&lo)) if lo > 0.0 => hi / lo,
            _ => f64::INFINITY,
        }
    }
}

/// Runs the study of `design` at `k` (module docs). `step` is `h`; `seeds ≥ 3`.
pub fn study(
    design: Design,
    point: &'static str,
    k: &FaultVector,
    seeds: u64,
    step: f32,
    anti_alias_hz: f64,
    current_ref_noise: f64,
) -> Result<Study> {
    if seeds < 3 {
        bail!("need at least 3 seeds, got {seeds}");
    }
    if !(step > 0.0 && step <= 0.2) {
        bail!("the difference step must be in (0, 0.2], got {step}");
    }
    let rm = ReferenceModel::new(ReferenceSettings {
        anti_alias_hz,
        ..ReferenceSettings::REFERENCE
    })
    .with_test(design.test());
    let params = ActuatorParams::REFERENCE;
    let run = |k: &FaultVector, seed: u64| -> Result<Vec<f64>> {
        let sim = rm.simulate(&Scenario {
            faults: *k,
            current_ref_noise,
            seed,
        });
        measurement(design, &sim, &params)
    };
    let components: Vec<usize> = (0..FAULT_COUNT)
        .filter(|&j| j != 6 || k.eccentricity() > 0.0)
        .collect();
    // Jobs: the base point, then each component's two sides, each on every seed.
    let mut jobs: Vec<(Option<(usize, f32)>, u64)> = (0..seeds).map(|s| (None, s)).collect();
    for &j in &components {
        for side in [-1.0f32, 1.0] {
            jobs.extend((0..seeds).map(|s| (Some((j, side)), s)));
        }
    }
    let shifted = |j: usize, side: f32| -> (FaultVector, f32) {
        let mut a = *k.as_array();
        let x = (a[j] + side * step).clamp(0.0, 1.0);
        a[j] = x;
        (FaultVector::saturating(a), x)
    };
    let outputs: Vec<Vec<f64>> = jobs
        .par_iter()
        .map(|&(shift, seed)| match shift {
            None => run(k, seed),
            Some((j, side)) => run(&shifted(j, side).0, seed),
        })
        .collect::<Result<_>>()?;
    let len = outputs.iter().map(Vec::len).min().unwrap_or(0);
    let s = seeds as usize;
    let base = &outputs[..s];
    let mean: Vec<f64> = (0..len)
        .map(|i| base.iter().map(|y| y[i]).sum::<f64>() / s as f64)
        .collect();
    let variance: Vec<f64> = (0..len)
        .map(|i| base.iter().map(|y| (y[i] - mean[i]).powi(2)).sum::<f64>() / (s - 1) as f64)
        .collect();
    let floor = 1e-6 * variance.iter().sum::<f64>() / len.max(1) as f64;
    let weight: Vec<f64> = variance.iter().map(|v| 1.0 / v.max(floor)).collect();

    let p = components.len();
    let mut jacobian = vec![vec![0.0; len]; p];
    for (c, &j) in components.iter().enumerate() {
        let lo = &outputs[s * (1 + 2 * c)..s * (2 + 2 * c)];
        let hi = &outputs[s * (2 + 2 * c)..s * (3 + 2 * c)];
        let span = f64::from(shifted(j, 1.0).1 - shifted(j, -1.0).1);
        if span <= 0.0 {
            bail!("component {j} cannot move at this point");
        }
        for (i, slot) in jacobian[c].iter_mut().enumerate() {
            *slot = (0..s).map(|r| hi[r][i] - lo[r][i]).sum::<f64>() / (s as f64 * span);
        }
    }
    let mut fisher = vec![vec![0.0; p]; p];
    for a in 0..p {
        for b in a..p {
            let v: f64 = (0..len)
                .map(|i| jacobian[a][i] * weight[i] * jacobian[b][i])
                .sum();
            fisher[a][b] = v;
            fisher[b][a] = v;
        }
    }
    let mut eig = symmetric_eigenvalues(&fisher);
    eig.sort_by(|a, b| b.total_cmp(a));
    let singular_values = eig.iter().map(|&x| x.max(0.0).sqrt()).collect();
    let inverse = invert(&fisher).unwrap_or_else(|| vec![vec![f64::INFINITY; p]; p]);

    // Linearised estimate of each seed's deviation from the mean.
    let estimates: Vec<Vec<f64>> = base
        .iter()
        .map(|y| {
            let g: Vec<f64> = (0..p)
                .map(|a| {
                    (0..len)
                        .map(|i| jacobian[a][i] * weight[i] * (y[i] - mean[i]))
                        .sum()
                })
                .collect();
            (0..p)
                .map(|a| (0..p).map(|b| inverse[a][b] * g[b]).sum())
                .collect()
        })
        .collect();
    let mut std_white = [None; FAULT_COUNT];
    let mut std_seeds = [None; FAULT_COUNT];
    for (c, &j) in components.iter().enumerate() {
        std_white[j] = Some(inverse[c][c].max(0.0).sqrt());
        let m = estimates.iter().map(|e| e[c]).sum::<f64>() / s as f64;
        let v = estimates.iter().map(|e| (e[c] - m).powi(2)).sum::<f64>() / (s - 1) as f64;
        std_seeds[j] = Some(v.sqrt());
    }
    let mut worst_correlation = (0.0f64, 0, 0);
    for a in 0..p {
        for b in a + 1..p {
            let r = inverse[a][b] / (inverse[a][a] * inverse[b][b]).sqrt();
            if r.abs() > worst_correlation.0.abs() {
                worst_correlation = (r, components[a], components[b]);
            }
        }
    }
    Ok(Study {
        design,
        point,
        components,
        singular_values,
        std_white,
        std_seeds,
        worst_correlation,
        samples: len,
    })
}

/// The linearised identification error that the monitor model's structural mismatch
/// causes with a test design, at one point.
#[derive(Clone, Debug, PartialEq)]
pub struct MismatchBias {
    pub point: &'static str,
    /// Predicted `k_found − k_true` per component (`None`: not studied at this point).
    pub bias: [Option<f64>; FAULT_COUNT],
    /// Relative RMS of the mismatch against the measured signal [%].
    pub mismatch_rms: f64,
}

impl MismatchBias {
    /// Predicted e_tot [%] (paper eq. (4)) of the bias.
    pub fn e_tot(&self, k: &FaultVector) -> f64 {
        let e: Vec<f64> = self.bias.iter().map(|b| b.unwrap_or(0.0)).collect();
        let mut sum = 0.0;
        for (j, x) in e.iter().enumerate() {
            let w = if j == 6 {
                f64::from(k.eccentricity())
            } else {
                1.0
            };
            sum += w * x * x;
        }
        100.0 * (sum / FAULT_COUNT as f64).sqrt()
    }
}

/// What the FDI would find with `test` if it reached the weighted least-squares optimum of
/// its fitness (the standstill segment weighted by `standstill_weight`), linearised: `δk = (JᵀWJ)⁻¹ JᵀW m`, with `J` the calibrated monitor model's
/// sensitivity (central differences), `W` eq. (3)'s per-sample weights and `m` the
/// mismatch between the conditioned reference-model current and the monitor model's at the
/// true `k` (each from the same measured start), averaged over `seeds`. Work: `seeds`
/// reference-model runs and `seeds · (1 + 2·p)` monitor-model runs.
pub fn mismatch_bias(
    point: &'static str,
    k: &FaultVector,
    test: PreflightTest,
    standstill_weight: f64,
    seeds: u64,
    step: f32,
) -> Result<MismatchBias> {
    mismatch_bias_on(
        point,
        k,
        test,
        standstill_weight,
        seeds,
        step,
        &ReferenceSettings::REFERENCE,
        DayHandling::Ignored,
    )
}

/// What the monitor model knows of the day the reference model plays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DayHandling {
    /// The calibration's day: the FDI ignores what the day changed.
    Ignored,
    /// The day [`shared::conditions::TestConditions::estimate`] reads from each test, as the
    /// flown FDI does.
    Estimated,
}

/// [`mismatch_bias`] with the reference model playing `settings` (another day, bus or
/// drive) against the reference actuator's calibration, the monitor model on the day
/// `day` says.
#[allow(clippy::too_many_arguments)]
pub fn mismatch_bias_on(
    point: &'static str,
    k: &FaultVector,
    test: PreflightTest,
    standstill_weight: f64,
    seeds: u64,
    step: f32,
    settings: &ReferenceSettings,
    day: DayHandling,
) -> Result<MismatchBias> {
    use shared::conditions::TestConditions;
    use shared::Calibration;
    use shared::MonitorModel;
    if seeds < 1 {
        bail!("need at least 1 seed");
    }
    let rm = ReferenceModel::new(*settings).with_test(test);
    let params = ActuatorParams::REFERENCE;
    let calibration = Calibration::reference_actuator(&test);
    let calibrated = MonitorModel::new(params, &calibration).with_test(&test);
    let lead = test.standstill_samples();
    let filter = LowPass::for_control_period(params.control_period)
        .map_err(|e| anyhow::anyhow!("conditioning filter: {e:?}"))?;
    let components: Vec<usize> = (0..FAULT_COUNT)
        .filter(|&j| j != 6 || k.eccentricity() > 0.0)
        .collect();
    let p = components.len();
    // Per seed: mismatch, eq. (3) weights, the monitor model's sensitivity, the measurement.
    type SeedBlock = (Vec<f64>, Vec<f64>, Vec<Vec<f64>>, Vec<f64>);
    let per_seed: Vec<SeedBlock> = (0..seeds)
        .into_par_iter()
        .map(|seed| -> Result<_> {
            let sim = rm.simulate(&Scenario {
                faults: *k,
                current_ref_noise: 0.0,
                seed,
            });
            let measured = sim.trace.measured(&params)?;
            let model =
                match day {
                    DayHandling::Ignored => calibrated,
                    DayHandling::Estimated => calibrated.with_conditions(
                        &TestConditions::estimate(&measured, &params, &calibration),
                    ),
                };
            let reference: Vec<f64> = measured.samples().iter().map(|&x| f64::from(x)).collect();
            let inv_kappa = f64::from(
                measured
                    .inv_kappa()
                    .map_err(|e| anyhow::anyhow!("conditioning: {e:?}"))?,
            );
            // As the fitness weighs them: the standstill segment by its weight, the chirp by
            // eq. (3)'s derivative normalisation.
            let mut previous = 0.0;
            let weight: Vec<f64> = reference
                .iter()
                .enumerate()
                .map(|(i, &r)| {
                    if i < lead {
                        let fitted = test.standstill.is_some_and(|s| s.fitted(i));
                        return if fitted { standstill_weight } else { 0.0 };
                    }
                    let d = r - previous;
                    previous = r;
                    1.0 / (d * d * inv_kappa + 1.0)
                })
                .collect();
            let start = measured.initial_angles();
            let modelled = |k: &FaultVector| -> Vec<f64> {
                let mut state = Default::default();
                let mut out = Vec::with_capacity(reference.len());
                model.run_from(k, start, reference.len(), |s| {
                    out.push(f64::from(filter.apply(&mut state, s.current)));
                });
                out
            };
            let at_truth = modelled(k);
            let mismatch: Vec<f64> = reference
                .iter()
                .zip(&at_truth)
                .map(|(r, m)| r - m)
                .collect();
            let jacobian: Vec<Vec<f64>> = components
                .iter()
                .map(|&j| {
                    let side = |sign: f32| {
                        let mut a = *k.as_array();
                        a[j] = (a[j] + sign * step).clamp(0.0, 1.0);
                        (a[j], modelled(&FaultVector::saturating(a)))
                    };
                    let (lo_k, lo) = side(-1.0);
                    let (hi_k, hi) = side(1.0);
                    let span = f64::from(hi_k - lo_k);
                    hi.iter().zip(&lo).map(|(h, l)| (h - l) / span).collect()
                })
                .collect();
            Ok((mismatch, weight, jacobian, reference))
        })
        .collect::<Result<_>>()?;
    let mut system = NormalEquations::new(p);
    let (mut mismatch_sq, mut signal_sq) = (0.0, 0.0);
    for (mismatch, weight, jacobian, reference) in &per_seed {
        system.add(jacobian, weight, mismatch);
        mismatch_sq += mismatch.iter().map(|x| x * x).sum::<f64>();
        signal_sq += reference.iter().map(|x| x * x).sum::<f64>();
    }
    let delta = system
        .solve()
        .ok_or_else(|| anyhow::anyhow!("singular sensitivity"))?;
    let mut bias = [None; FAULT_COUNT];
    for (&j, d) in components.iter().zip(delta) {
        bias[j] = Some(d);
    }
    Ok(MismatchBias {
        point,
        bias,
        mismatch_rms: 100.0 * (mismatch_sq / signal_sq.max(f64::MIN_POSITIVE)).sqrt(),
    })
}

/// The days the day study plays against the reference actuator's calibration (20 °C, 270 V,
/// 0.5 µs of dead time): the winding and grease ±30 and ±60 K (the file's friction law),
/// the bus at 250 and 280 V, 1 µs of dead time, 50 mΩ more harness per phase, the gear
/// 40 K colder or warmer than the winding (and a cold morning's motor 20 K above its gear),
/// a controller that loads its volts one carrier late without the record knowing.
pub fn day_nuisances() -> Vec<(&'static str, ReferenceSettings)> {
    let base = ReferenceSettings::REFERENCE;
    let at = |delta: f64| {
        let mut s = base;
        s.conditions = s
            .conditions
            .at_temperature(base.conditions.winding_temperature + delta);
        s
    };
    let bus = |v: f64| {
        let mut s = base;
        s.conditions.bus_voltage = Some(v);
        s
    };
    let mut dead = base;
    dead.bridge.dead_time = 1.0e-6;
    let mut harness = base;
    harness.bridge.harness_resistance += 0.05;
    // The gearbox is not the winding: the thermistor reads the winding, the friction law
    // takes its reading (issue 34).
    let gap = |winding: f64, gear: f64| {
        let mut s = at(winding);
        s.conditions.gear_temperature = base.conditions.gear_temperature + gear;
        s
    };
    let mut late = base;
    late.bridge.duty_delay = 5.0e-5;
    vec![
        ("calibration day", base),
        ("−60 K", at(-60.0)),
        ("−30 K", at(-30.0)),
        ("+30 K", at(30.0)),
        ("+60 K", at(60.0)),
        ("bus 250 V", bus(250.0)),
        ("bus 280 V", bus(280.0)),
        ("dead time 1 µs", dead),
        ("harness +50 mΩ", harness),
        ("gear −40 K from the winding", gap(0.0, -40.0)),
        ("gear +40 K from the winding", gap(0.0, 40.0)),
        ("winding −40 K, gear −60 K", gap(-40.0, -60.0)),
        ("duty delay 50 µs, undeclared", late),
    ]
}

/// One row of the day study: what a nuisance does to the signal, and the identification
/// error it causes with the day ignored and with the day estimated.
#[derive(Clone, Debug, PartialEq)]
pub struct DayBias {
    pub nuisance: &'static str,
    pub point: &'static str,
    pub ignored: MismatchBias,
    pub estimated: MismatchBias,
}

/// The day study of `test` at `points`: per nuisance of [`day_nuisances`], the linearised
/// identification error ([`mismatch_bias_on`]) with the day ignored and estimated. Work:
/// `2 · nuisances · points · seeds` reference-model runs.
pub fn day_study(
    test: PreflightTest,
    points: &[(&'static str, FaultVector)],
    seeds: u64,
    step: f32,
    mut progress: impl FnMut(&str),
) -> Result<Vec<DayBias>> {
    let weight = f64::from(shared::fitness::STANDSTILL_WEIGHT);
    let mut rows = Vec::new();
    for (nuisance, settings) in day_nuisances() {
        for &(point, k) in points {
            progress(&format!("{nuisance} @ {point}"));
            let bias = |day| mismatch_bias_on(point, &k, test, weight, seeds, step, &settings, day);
            rows.push(DayBias {
                nuisance,
                point,
                ignored: bias(DayHandling::Ignored)?,
                estimated: bias(DayHandling::Estimated)?,
            });
        }
    }
    Ok(rows)
}

/// The day study's table (Markdown).
pub fn day_markdown(
    rows: &[DayBias],
    points: &[(&'static str, FaultVector)],
    seeds: u64,
) -> String {
    use std::fmt::Write;
    let mut text = format!(
        "The injection test on the real bridge, the reference actuator's calibration (20 °C, \
         270 V, 0.5 µs), {seeds} seeds: what each nuisance of the day does to the fitted \
         signal (mismatch RMS against the monitor model at the truth, % of the signal) and the \
         linearised identification error it causes (predicted e_tot, %; the largest component \
         error, % of the range) with the day ignored and with the day estimated per test.\n\n\
         | nuisance | point | mismatch ignored (%) | e_tot ignored (%) | largest ignored | \
         mismatch estimated (%) | e_tot estimated (%) | largest estimated |\n\
         | --- | --- | ---: | ---: | --- | ---: | ---: | --- |\n"
    );
    let largest = |b: &MismatchBias| {
        b.bias
            .iter()
            .enumerate()
            .filter_map(|(j, x)| x.map(|v| (j, v)))
            .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
            .map_or("—".to_string(), |(j, v)| {
                format!("{} {:+.2}", FAULT_NAMES[j], 100.0 * v)
            })
    };
    for r in rows {
        let k = points
            .iter()
            .find(|(p, _)| *p == r.point)
            .map_or(FaultVector::NOMINAL, |(_, k)| *k);
        let _ = writeln!(
            text,
            "| {} | {} | {:.3} | {:.2} | {} | {:.3} | {:.2} | {} |",
            r.nuisance,
            r.point,
            r.ignored.mismatch_rms,
            r.ignored.e_tot(&k),
            largest(&r.ignored),
            r.estimated.mismatch_rms,
            r.estimated.e_tot(&k),
            largest(&r.estimated),
        );
    }
    text
}

/// Weighted linear least squares `min Σ_i w_i (r_i − Σ_a J_a,i δ_a)²`, accumulated block by
/// block: `JᵀWJ` and `JᵀWr`. O(p²) per sample.
#[derive(Clone, Debug, PartialEq)]
pub struct NormalEquations {
    matrix: Vec<Vec<f64>>,
    rhs: Vec<f64>,
}

impl NormalEquations {
    pub fn new(p: usize) -> Self {
        Self {
            matrix: vec![vec![0.0; p]; p],
            rhs: vec![0.0; p],
        }
    }

    /// Adds samples: `jacobian[a][i]`, `weight[i]`, `residual[i]`.
    #[allow(clippy::needless_range_loop)] // index notation as in the formula
    pub fn add(&mut self, jacobian: &[Vec<f64>], weight: &[f64], residual: &[f64]) {
        let p = self.rhs.len();
        for i in 0..residual.len().min(weight.len()) {
            for a in 0..p {
                let ja = jacobian[a][i] * weight[i];
                self.rhs[a] += ja * residual[i];
                for b in 0..p {
                    self.matrix[a][b] += ja * jacobian[b][i];
                }
            }
        }
    }

    /// The least-squares `δ`; `None` if `JᵀWJ` is singular.
    pub fn solve(&self) -> Option<Vec<f64>> {
        let inverse = invert(&self.matrix)?;
        Some(
            inverse
                .iter()
                .map(|row| row.iter().zip(&self.rhs).map(|(m, r)| m * r).sum())
                .collect(),
        )
    }
}

/// Eigenvalues of a symmetric matrix (cyclic Jacobi). O(n³) per sweep, ≤ 50 sweeps.
#[allow(clippy::needless_range_loop)] // index notation as in the rotation formulas
pub fn symmetric_eigenvalues(m: &[Vec<f64>]) -> Vec<f64> {
    let n = m.len();
    let mut a: Vec<Vec<f64>> = m.to_vec();
    for _ in 0..50 {
        let off: f64 = (0..n)
            .flat_map(|i| (0..n).filter(move |&j| j != i).map(move |j| (i, j)))
            .map(|(i, j)| a[i][j] * a[i][j])
            .sum();
        let scale: f64 = (0..n).map(|i| a[i][i] * a[i][i]).sum();
        if off <= 1e-30 * scale.max(f64::MIN_POSITIVE) {
            break;
        }
        for p in 0..n {
            for q in p + 1..n {
                if a[p][q] == 0.0 {
                    continue;
                }
                let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for r in 0..n {
                    let (arp, arq) = (a[r][p], a[r][q]);
                    a[r][p] = c * arp - s * arq;
                    a[r][q] = s * arp + c * arq;
                }
                for r in 0..n {
                    let (apr, aqr) = (a[p][r], a[q][r]);
                    a[p][r] = c * apr - s * aqr;
                    a[q][r] = s * apr + c * aqr;
                }
            }
        }
    }
    (0..n).map(|i| a[i][i]).collect()
}

/// Inverse of a symmetric positive-definite matrix (Gauss–Jordan with partial pivoting);
/// `None` if singular.
#[allow(clippy::needless_range_loop)] // index notation as in the elimination
pub fn invert(m: &[Vec<f64>]) -> Option<Vec<Vec<f64>>> {
    let n = m.len();
    let mut a: Vec<Vec<f64>> = m
        .iter()
        .enumerate()
        .map(|(i, row)| {
            let mut r = row.clone();
            r.extend((0..n).map(|j| if i == j { 1.0 } else { 0.0 }));
            r
        })
        .collect();
    for col in 0..n {
        let pivot = (col..n).max_by(|&x, &y| a[x][col].abs().total_cmp(&a[y][col].abs()))?;
        if a[pivot][col].abs() < 1e-300 {
            return None;
        }
        a.swap(col, pivot);
        let d = a[col][col];
        for v in a[col].iter_mut() {
            *v /= d;
        }
        for r in 0..n {
            if r != col {
                let f = a[r][col];
                if f != 0.0 {
                    for c in 0..2 * n {
                        a[r][c] -= f * a[col][c];
                    }
                }
            }
        }
    }
    Some(a.into_iter().map(|r| r[n..].to_vec()).collect())
}

/// Markdown: one table per design (points as rows), then the summary.
pub fn markdown(
    studies: &[Study],
    seeds: u64,
    step: f32,
    anti_alias_hz: f64,
    current_ref_noise: f64,
) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let pct = |x: Option<f64>| x.map_or("—".to_string(), |v| format!("{:.2}", 100.0 * v));
    let _ = writeln!(
        out,
        "Reference model (current anti-alias filter {anti_alias_hz} Hz, I_ref noise \
         {current_ref_noise} of the nominal RMS), {seeds} noise seeds per point, difference \
         step h = {step}. \
         Standard deviations in % of the component's [0, 1] range: `white` = √diag(F⁻¹), \
         `seeds` = scatter of the linearised estimate over the seeds. \
         Components: {}.\n",
        FAULT_NAMES
            .iter()
            .enumerate()
            .map(|(i, n)| format!("k{} {n}", i + 1))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let mut designs: Vec<Design> = studies.iter().map(|s| s.design).collect();
    designs.dedup();
    for design in designs {
        let _ = writeln!(out, "### {}\n", design.label());
        let _ = writeln!(
            out,
            "| point | samples | singular values | condition | k1 | k2 | k3 | k4 | k5 | k6 | k7 | k8 | most correlated |"
        );
        let _ = writeln!(
            out,
            "| --- | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- |"
        );
        for st in studies.iter().filter(|s| s.design == design) {
            let sv = st
                .singular_values
                .iter()
                .map(|x| format!("{x:.3e}"))
                .collect::<Vec<_>>()
                .join(", ");
            let cells: Vec<String> = (0..FAULT_COUNT)
                .map(|j| format!("{} / {}", pct(st.std_white[j]), pct(st.std_seeds[j])))
                .collect();
            let (r, a, b) = st.worst_correlation;
            let _ = writeln!(
                out,
                "| {} | {} | {sv} | {:.3e} | {} | k{}–k{} {r:+.3} |",
                st.point,
                st.samples,
                st.condition(),
                cells.join(" | "),
                a + 1,
                b + 1
            );
        }
        let _ = writeln!(out);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    #[allow(clippy::needless_range_loop)]
    fn eigenvalues_and_inverse_of_a_known_matrix() {
        // Eigenvalues 1, 2, 4 in a rotated basis.
        let m = vec![
            vec![2.0, 1.0, 0.0],
            vec![1.0, 2.0, 0.0],
            vec![0.0, 0.0, 4.0],
        ];
        let mut e = symmetric_eigenvalues(&m);
        e.sort_by(f64::total_cmp);
        for (got, want) in e.iter().zip([1.0, 3.0, 4.0]) {
            assert!((got - want).abs() < 1e-12, "{e:?}");
        }
        let inv = invert(&m).unwrap();
        for i in 0..3 {
            for j in 0..3 {
                let product: f64 = (0..3).map(|k| m[i][k] * inv[k][j]).sum();
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((product - want).abs() < 1e-12);
            }
        }
        assert!(invert(&[vec![1.0, 2.0], vec![2.0, 4.0]]).is_none());
    }

    #[test]
    fn normal_equations_recover_a_known_shift_through_noise_free_data() {
        let n = 200;
        let jacobian: Vec<Vec<f64>> = (0..3)
            .map(|a| (0..n).map(|i| ((i * (a + 1)) as f64 * 0.1).sin()).collect())
            .collect();
        let delta = [0.3, -0.02, 0.7];
        let residual: Vec<f64> = (0..n)
            .map(|i| (0..3).map(|a| jacobian[a][i] * delta[a]).sum())
            .collect();
        let weight: Vec<f64> = (0..n).map(|i| 1.0 + (i % 7) as f64).collect();
        let mut system = NormalEquations::new(3);
        // In two blocks, as the seeds are added.
        let (j1, j2): (Vec<Vec<f64>>, Vec<Vec<f64>>) = jacobian
            .iter()
            .map(|c| (c[..80].to_vec(), c[80..].to_vec()))
            .unzip();
        system.add(&j1, &weight[..80], &residual[..80]);
        system.add(&j2, &weight[80..], &residual[80..]);
        let got = system.solve().unwrap();
        for (g, w) in got.iter().zip(delta) {
            assert!((g - w).abs() < 1e-10, "{got:?}");
        }
    }
}
