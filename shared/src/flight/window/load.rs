//! A window's load search: the spring's stiffness and moment by golden-section searches
//! and the load's slow trend by fixed-point rounds ([`WindowProblem::fit_load`]), at most
//! [`LOAD_SEARCH_EVALUATIONS`] evaluations; and how the best load moves with a step of the
//! faults ([`LoadResponse`]). O(1) per point besides the evaluations.

use super::*;

impl<'a, const N: usize> WindowProblem<'a, N> {
    /// Fits the load at fault vector `k`: a golden-section search of the stiffness (from a
    /// third to three times `stiffness_guess`) and of the moment (±50 % of the held moment),
    /// `TREND_ROUNDS` fixed-point rounds that move the drift the fit profiled out into the
    /// load (its value at the start into the moment, its change into the trend: the model
    /// then plays the slow hinge moment, backlash crossings where they happen), the stiffness
    /// again near the first, and the trend's rounds again. [`LOAD_SEARCH_EVALUATIONS`]
    /// evaluations. Returns the load found and its error.
    pub fn fit_load(&self, k: &FaultVector, stiffness_guess: f32) -> (WindowLoad, f32) {
        let (load, error, _) = run_to_end(self.fit_load_stepwise(k, stiffness_guess));
        (load, error)
    }

    /// [`fit_load`](Self::fit_load) in steps: each evaluation stepwise
    /// ([`evaluate_stepwise`](Self::evaluate_stepwise)).
    /// Also returns the evaluations it spent (≤ [`LOAD_SEARCH_EVALUATIONS`]: the trend's
    /// rounds stop when one does not lower the error).
    pub async fn fit_load_stepwise(
        &self,
        k: &FaultVector,
        stiffness_guess: f32,
    ) -> (WindowLoad, f32, u32) {
        let held = self.held_moment();
        let mut load = WindowLoad::spring(stiffness_guess, held);
        let at_moment = |load: WindowLoad, m: f32| WindowLoad {
            moment: m,
            stiffness: load.stiffness,
            trend: load.trend,
        };
        // The moment sets where the load reverses, so where the gear crosses its play, and
        // with a wide play the fitness is sharp in it (a basin a few N·m wide per crossing
        // pattern): a fine scan first, at the guessed stiffness.
        // The current holds the moment less what dry friction carries: the span is the
        // friction a fault could reach (three times the healthy breakaway, at the user
        // shaft) and a fifth of the held moment for the estimate's own error.
        let p = self.model.params();
        let span = 3.0 * p.static_friction * p.gear_ratio + 0.2 * abs(held);
        let cell = 2.0 * span / (MOMENT_SCAN - 1) as f32;
        let mut best = (held, f32::INFINITY);
        for j in 0..MOMENT_SCAN {
            let m = held - span + cell * j as f32;
            let e = self.evaluate_stepwise(k, at_moment(load, m)).await.error;
            if e < best.1 {
                best = (m, e);
            }
        }
        load.moment = best.0;
        let ln = crate::base::math::ln;
        let range_k = (ln(stiffness_guess / 3.0), ln(stiffness_guess * 3.0));
        let mut search = GoldenSearch::new(range_k);
        while let Some(x) = search.ask() {
            search.tell(
                self.evaluate_stepwise(k, stiffness_at(load, x).await)
                    .await
                    .error,
            );
        }
        let (log_k, _) = search.best();
        load = stiffness_at(load, log_k).await;
        let mut search = GoldenSearch::new((best.0 - cell, best.0 + cell));
        while let Some(m) = search.ask() {
            search.tell(self.evaluate_stepwise(k, at_moment(load, m)).await.error);
        }
        let (moment, _) = search.best();
        load.moment = moment;
        let (trended, first_rounds) = self.follow_trend(k, load).await;
        load = trended;
        let mut search = GoldenSearch::new((log_k - 0.3, log_k + 0.3));
        while let Some(x) = search.ask() {
            search.tell(
                self.evaluate_stepwise(k, stiffness_at(load, x).await)
                    .await
                    .error,
            );
        }
        let (log_k, _) = search.best();
        let (load, second_rounds) = self.follow_trend(k, stiffness_at(load, log_k).await).await;
        let error = self.evaluate_stepwise(k, load).await.error;
        let runs = MOMENT_SCAN + 3 * GOLDEN_STEPS + 1 + first_rounds + second_rounds;
        (load, error, runs as u32)
    }

    /// [`TREND_ROUNDS`] rounds: the drift the fit profiles out, as a moment (amperes times
    /// the torque constant and the gear ratio), added to the load. O(rounds) evaluations.
    /// Also returns the evaluations spent (two per round).
    pub(super) async fn follow_trend(
        &self,
        k: &FaultVector,
        mut load: WindowLoad,
    ) -> (WindowLoad, usize) {
        let mut runs = 0;
        let per_ampere = self.model.torque_constant() * self.model.params().gear_ratio;
        for _ in 0..TREND_ROUNDS {
            let fit = self.evaluate_stepwise(k, load).await;
            let start: f32 = fit
                .drift
                .iter()
                .zip(&legendre(-1.0))
                .map(|(c, p)| c * p)
                .sum();
            let next = WindowLoad {
                moment: load.moment + per_ampere * start,
                trend: core::array::from_fn(|j| {
                    load.trend.get(j).copied().unwrap_or(0.0)
                        + per_ampere * fit.drift.get(j).copied().unwrap_or(0.0)
                }),
                stiffness: load.stiffness,
            };
            let error = self.evaluate_stepwise(k, next).await.error;
            runs += 2;
            if error <= fit.error {
                load = next;
            } else {
                break;
            }
        }
        (load, runs)
    }
}

/// How the load's best stiffness and moment move with a step of the faults, from a
/// window's curvature: the nuisances' least-squares step given the faults' step `δ` is
/// `Q⁻¹(NᵀWr − C·δ)` (`N` the nuisances' columns, `Q = NᵀWN`, `C = NᵀWJ` their cross terms
/// with the faults; linearised at the curvature's vector); its two load rows are kept.
#[derive(Clone, Copy, Debug)]
pub(super) struct LoadResponse {
    /// The load's step for no fault step: [ln stiffness, moment in N·m] (the curvature's
    /// columns are the current's change per relative stiffness and per N·m).
    pub(super) at_zero: [f64; 2],
    /// Its change per unit of each fault component.
    pub(super) per_fault: [[f64; FAULT_COUNT]; 2],
}

impl LoadResponse {
    pub(super) const NONE: Self = Self {
        at_zero: [0.0; 2],
        per_fault: [[0.0; FAULT_COUNT]; 2],
    };

    /// `load` moved with the faults' step from `from` to `to` (the phase's step taken the
    /// short way round), in steps for a controller's idle time: a pause first, then the
    /// exponential stepwise. O(9).
    pub(super) async fn step_stepwise(
        &self,
        load: WindowLoad,
        from: &FaultVector,
        to: &FaultVector,
    ) -> WindowLoad {
        // What the caller did since its last pause ends its poll here.
        pause().await;
        let [mut ln_k, mut moment] = self.at_zero;
        for (i, (a, b)) in from.as_array().iter().zip(to.as_array()).enumerate() {
            let mut d = b - a;
            if crate::physics::fault::CIRCULAR
                .get(i)
                .copied()
                .unwrap_or(false)
            {
                d -= crate::base::math::floor(d + 0.5);
            }
            let d = f64::from(d);
            ln_k += self.per_fault[0].get(i).copied().unwrap_or(0.0) * d;
            moment += self.per_fault[1].get(i).copied().unwrap_or(0.0) * d;
        }
        pause().await;
        WindowLoad {
            stiffness: load.stiffness * crate::base::math::exp64_stepwise(ln_k).await as f32,
            moment: load.moment + moment as f32,
            trend: load.trend,
        }
    }
}

/// A golden-section search over a range, asked point by point (ask / tell, as the GA):
/// [`GOLDEN_STEPS`] points, then the best point seen and its value. O(1) per point.
#[derive(Clone, Copy, Debug)]
pub(super) struct GoldenSearch {
    pub(super) a: f32,
    pub(super) b: f32,
    pub(super) c: f32,
    pub(super) d: f32,
    pub(super) fc: f32,
    pub(super) fd: f32,
    /// Points told so far.
    pub(super) told: usize,
    /// Whether the point asked next is `d` (else `c`).
    pub(super) at_d: bool,
}

impl GoldenSearch {
    pub(super) const R: f32 = 0.618_034;

    pub(super) fn new((a, b): (f32, f32)) -> Self {
        Self {
            a,
            b,
            c: b - Self::R * (b - a),
            d: a + Self::R * (b - a),
            fc: f32::NAN,
            fd: f32::NAN,
            told: 0,
            at_d: false,
        }
    }

    /// The next point to evaluate; `None` once [`GOLDEN_STEPS`] were told.
    pub(super) fn ask(&self) -> Option<f32> {
        (self.told < GOLDEN_STEPS).then_some(if self.at_d { self.d } else { self.c })
    }

    /// The value at the point last asked.
    pub(super) fn tell(&mut self, value: f32) {
        if self.at_d {
            self.fd = value;
        } else {
            self.fc = value;
        }
        self.told += 1;
        if self.told == 1 {
            self.at_d = true;
        } else if self.told < GOLDEN_STEPS {
            if self.fc <= self.fd {
                self.b = self.d;
                self.d = self.c;
                self.fd = self.fc;
                self.c = self.b - Self::R * (self.b - self.a);
                self.at_d = false;
            } else {
                self.a = self.c;
                self.c = self.d;
                self.fc = self.fd;
                self.d = self.a + Self::R * (self.b - self.a);
                self.at_d = true;
            }
        }
    }

    /// The better of the two inner points and its value.
    pub(super) fn best(&self) -> (f32, f32) {
        if self.fc <= self.fd {
            (self.c, self.fc)
        } else {
            (self.d, self.fd)
        }
    }
}

/// `load` at the stiffness `e^log_k` [N·m/rad], its exponential stepwise
/// ([`exp64_stepwise`](crate::base::math::exp64_stepwise)), with a pause before and after.
async fn stiffness_at(load: WindowLoad, log_k: f32) -> WindowLoad {
    pause().await;
    let stiffness = crate::base::math::exp64_stepwise(f64::from(log_k)).await as f32;
    pause().await;
    WindowLoad {
        stiffness,
        moment: load.moment,
        trend: load.trend,
    }
}
