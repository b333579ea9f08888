//! Where the preflight's error under the paper's I_ref noise comes from: the noise's effect on
//! the actuator's motion (a physics the monitor model does not play), or the noise the
//! measured current carries (what any model fitted to one 0.5 s test must live with).
//!
//! Per case and seed the reference actuator's preflight is simulated twice, with the I_ref
//! noise and without it (the same seed: the same sensor noise), and identified four ways:
//!
//! * `iref` — the test with I_ref noise, as `preflight --noise` plays it;
//! * `quiet` — the test without it;
//! * `transplant` — the quiet test's angles (its motion) with the noisy test's current: the
//!   equivalent-current difference of the two runs added sample by sample to the quiet run's
//!   conducting phases, from the chirp's first sample on. It carries the noise's current but
//!   not what the noise did to the motion;
//! * `white` — the quiet test plus independent white Gaussian noise on its equivalent current,
//!   of the same RMS as that difference (the loop's shaping of the noise taken away);
//!
//! Every reading has its eccentricity's free-phase bias taken off, as the FDI reports it
//! (`√(Z² − 2σ²)`, σ its own white-noise deviation: `shared::uncertainty::free_phase_corrected`).
//!
//! For each way: per component the mean error (found − true) and its scatter over the seeds,
//! e_tot, and how many runs end at a fitness below the truth's (the data prefer the vector
//! found: the search is not what is short).
//!
//! `cargo run --release -p host-sim --example noise_source [SEEDS [NOISE]]` (16 seeds and the
//! paper's 0.5 by default; ≈ 1.4 s per seed and case on one core). It stops with an error if a
//! transplant's equivalent current over the chirp is not the noisy test's.

use anyhow::Result;
use host_sim::fdi::identify::identify_for;
use host_sim::files::actuator::Actuator;
use host_sim::files::trace::Trace;
use host_sim::plant::noise::Gaussian;
use host_sim::plant::reference::{ReferenceModel, Scenario};
use shared::conditioning::commutation_signs;

mod noise_cases;
use noise_cases::{equivalent, CASES};
use shared::metrics::total_error;
use shared::{ActuatorParams, FaultVector};

const WAYS: [&str; 4] = ["iref", "quiet", "transplant", "white"];

/// `quiet` with `added[n]` on sample `n`'s equivalent current, through its conducting phases.
fn with_current(quiet: &Trace, added: &[f64], pole_pairs: f32) -> Trace {
    let mut out = Trace::with_capacity(quiet.samples().len()).with_test(*quiet.test());
    for (s, &a) in quiet.samples().iter().zip(added) {
        let signs = commutation_signs(s.motor_angle as f32 * pole_pairs);
        let mut s = *s;
        for (i, sign) in s.phase_currents.iter_mut().zip(signs) {
            *i += f64::from(sign) * a;
        }
        out.push(s);
    }
    out
}

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let seeds: u64 = args.next().map_or(Ok(16), |a| a.parse())?;
    let noise: f64 = args.next().map_or(Ok(0.5), |a| a.parse())?;
    anyhow::ensure!(
        seeds >= 2,
        "SEEDS must be at least 2 (a scatter needs two runs)"
    );
    anyhow::ensure!(
        (0.0..=1.0).contains(&noise),
        "NOISE is a fraction of the nominal I_ref RMS, 0 … 1"
    );
    let actuator = Actuator::reference();
    let record = actuator.record;
    let params: ActuatorParams = record.params;
    let pole_pairs = params.pole_pairs;
    let rm = ReferenceModel::new(actuator.reference_settings()?).with_test(record.test);
    let lead = record.test.lead_samples();
    println!("I_ref noise {noise}, {seeds} seeds per case, the reference actuator's preflight");
    for (name, k) in CASES {
        let truth = FaultVector::new(k).map_err(|e| anyhow::anyhow!("{e:?}"))?;
        // errors[way][seed][component], e_tot[way][seed], below[way]
        let mut errors = vec![Vec::new(); WAYS.len()];
        let mut e_tot = vec![Vec::new(); WAYS.len()];
        let mut below = [0usize; WAYS.len()];
        let mut difference_rms = 0.0;
        for seed in 0..seeds {
            let scenario = Scenario {
                faults: truth,
                current_ref_noise: noise,
                seed,
            };
            let noisy = rm.simulate(&scenario).trace;
            let quiet = rm
                .simulate(&Scenario {
                    current_ref_noise: 0.0,
                    ..scenario
                })
                .trace;
            let added: Vec<f64> = noisy
                .samples()
                .iter()
                .zip(quiet.samples())
                .enumerate()
                .map(|(n, (a, b))| {
                    if n < lead {
                        0.0
                    } else {
                        equivalent(a, pole_pairs) - equivalent(b, pole_pairs)
                    }
                })
                .collect();
            let chirp = &added[lead.min(added.len())..];
            let rms = (chirp.iter().map(|a| a * a).sum::<f64>() / chirp.len().max(1) as f64).sqrt();
            difference_rms += rms / seeds as f64;
            let mut g = Gaussian::new(seed ^ 0x00C0_FFEE);
            let white: Vec<f64> = (0..added.len())
                .map(|n| if n < lead { 0.0 } else { rms * g.next() })
                .collect();
            let transplant = with_current(&quiet, &added, pole_pairs);
            // The transplant's equivalent current is the noisy test's, sample by sample over
            // the chirp (before it, at standstill, it is the quiet test's).
            let worst = transplant
                .chirp_samples()
                .iter()
                .zip(noisy.chirp_samples())
                .map(|(a, b)| (equivalent(a, pole_pairs) - equivalent(b, pole_pairs)).abs())
                .fold(0.0, f64::max);
            anyhow::ensure!(
                worst < 1e-9,
                "seed {seed}: the transplant's current departs from the noisy test's by {worst} A"
            );
            let traces = [
                noisy,
                quiet.clone(),
                transplant,
                with_current(&quiet, &white, pole_pairs),
            ];
            for (w, trace) in traces.iter().enumerate() {
                let measured = trace.measured(&params)?;
                let id = identify_for(&measured, &record, 1 + seed, false)?;
                let problem = shared::FitnessProblem::new(&measured, params, &record.calibration)
                    .map_err(|e| anyhow::anyhow!("fitness: {e:?}"))?;
                let found = id.result.faults;
                if id.result.fitness < problem.error(&truth) {
                    below[w] += 1;
                }
                let d: Vec<f64> = found
                    .as_array()
                    .iter()
                    .zip(truth.as_array())
                    .map(|(f, t)| f64::from(f - t))
                    .collect();
                errors[w].push(d);
                e_tot[w].push(f64::from(total_error(&found, &truth)));
            }
        }
        println!();
        println!(
            "## {name} (the noisy run's equivalent current departs from the quiet run's by {difference_rms:.3} A RMS over the chirp)"
        );
        println!();
        println!(
            "| way | friction | backlash | short A | eccentricity | gain drift | mean e_tot [%] | fitness below the truth's |"
        );
        println!("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |");
        for (w, way) in WAYS.iter().enumerate() {
            let cell = |i: usize| {
                let v: Vec<f64> = errors[w].iter().map(|d| d[i]).collect();
                let n = v.len() as f64;
                let mean = v.iter().sum::<f64>() / n;
                let sd = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
                format!("{mean:+.3} ± {sd:.3}")
            };
            let mean_e = e_tot[w].iter().sum::<f64>() / e_tot[w].len() as f64;
            println!(
                "| {way} | {} | {} | {} | {} | {} | {mean_e:.2} | {} of {seeds} |",
                cell(0),
                cell(1),
                cell(2),
                cell(5),
                cell(7),
                below[w]
            );
        }
    }
    Ok(())
}
