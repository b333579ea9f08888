//! Can one preflight test tell two fault vectors apart at all? A model-free check on the
//! reference model alone: the deterministic signature that separates vectors A and B in the
//! measured (filtered equivalent) current, against the scatter of one test.
//!
//! Each vector is simulated with `seeds` sensor/process-noise seeds; per-seed traces are
//! averaged. The signature distance is the relative RMS difference of the mean traces of A and
//! B (B on other seeds), with the part the finite average leaves (the difference of two means
//! of A on disjoint seeds) removed in quadrature. The test scatter is the relative RMS
//! difference of one test from A's mean. All distances are relative to the RMS of A's mean
//! trace. Work: 3 × `seeds` reference-model runs (≈ 0.05 s each), in parallel.

use anyhow::{anyhow, Result};
use rayon::prelude::*;
use shared::{ActuatorParams, FaultVector};

use crate::plant::reference::{ReferenceModel, ReferenceSettings, Scenario};

/// What [`separability`] measured, in % of the signal RMS.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Separability {
    /// Deterministic difference between A and B.
    pub signature: f64,
    /// Scatter of one test around its mean (sensor noise, ripple aliasing).
    pub test_scatter: f64,
    /// Residual noise of the mean-vs-mean comparison (removed from `signature`).
    pub mean_noise: f64,
}

/// Compares vectors `a` and `b` with `seeds` seeds each (≥ 2), noise-free I_ref.
pub fn separability(a: &FaultVector, b: &FaultVector, seeds: u64) -> Result<Separability> {
    if seeds < 2 {
        return Err(anyhow!("need at least 2 seeds, got {seeds}"));
    }
    let rm = ReferenceModel::new(ReferenceSettings::REFERENCE);
    let params = ActuatorParams::REFERENCE;
    let trace = |k: &FaultVector, seed: u64| -> Result<Vec<f64>> {
        let sim = rm.simulate(&Scenario {
            faults: *k,
            current_ref_noise: 0.0,
            seed,
        });
        let measured = sim.trace.measured(&params)?;
        Ok(measured.samples().iter().map(|&x| f64::from(x)).collect())
    };
    let batch = |k: &FaultVector, first: u64| -> Result<Vec<Vec<f64>>> {
        (first..first + seeds)
            .into_par_iter()
            .map(|s| trace(k, s))
            .collect()
    };
    let a1 = batch(a, 0)?;
    let a2 = batch(a, seeds)?;
    let b3 = batch(b, 2 * seeds)?;
    let mean = |runs: &[Vec<f64>]| -> Vec<f64> {
        let n = runs.len() as f64;
        let len = runs.iter().map(Vec::len).min().unwrap_or(0);
        (0..len)
            .map(|i| runs.iter().map(|r| r[i]).sum::<f64>() / n)
            .collect()
    };
    let (ma1, ma2, mb) = (mean(&a1), mean(&a2), mean(&b3));
    let scale = (ma1.iter().map(|x| x * x).sum::<f64>() / ma1.len().max(1) as f64).sqrt();
    if scale <= 0.0 {
        return Err(anyhow!("vector A gives a flat current: nothing to compare"));
    }
    let rms_diff = |x: &[f64], y: &[f64]| {
        let n = x.len().min(y.len()).max(1) as f64;
        (x.iter().zip(y).map(|(p, q)| (p - q).powi(2)).sum::<f64>() / n).sqrt() / scale * 100.0
    };
    let mean_noise = rms_diff(&ma1, &ma2);
    let raw = rms_diff(&ma1, &mb);
    // Each run is part of the mean it is compared with: n − 1 corrects for that.
    let test_scatter = (a1.iter().map(|r| rms_diff(r, &ma1).powi(2)).sum::<f64>()
        / (a1.len() as f64 - 1.0))
        .sqrt();
    Ok(Separability {
        signature: (raw * raw - mean_noise * mean_noise).max(0.0).sqrt(),
        test_scatter,
        mean_noise,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_vector_is_not_separable_from_itself_but_a_gain_drift_is() {
        let a = FaultVector::NOMINAL;
        let same = separability(&a, &a, 4).unwrap();
        let mut k = *a.as_array();
        k[7] = 0.7;
        let drift = separability(&a, &FaultVector::new(k).unwrap(), 4).unwrap();
        // Same vector: what is left is the finite-average noise, well under one test's scatter.
        assert!(same.signature < 0.5 * same.test_scatter, "{same:?}");
        // A 20 % gain drift stands far above one test's scatter.
        assert!(drift.signature > 2.0 * drift.test_scatter, "{drift:?}");
    }
}
