//! A window's curvature: the Gauss–Newton sums at a fault vector with the drift and the
//! load profiled out ([`WindowProblem::curvature`]), thirteen lockstep model runs in polls of
//! [`CURVATURE_RUNS_PER_POLL`] runs' samples, f32 products summed in blocks of 64 joined in
//! f64.

use super::*;
use crate::base::steps::dot_stepwise;

impl<'a, const N: usize> WindowProblem<'a, N> {
    /// The Gauss–Newton sums at `k` under the problem's load ([`Curvature`]): one base run,
    /// one run per component shifted by [`STEP`] (down where up would leave [0, 1]) and one
    /// per fitted load parameter (the stiffness by 1 %, the moment by 1 % of the spring's
    /// moment at the test's amplitude), stepped in lockstep. The nuisances — the drift's
    /// polynomials and the two load parameters — are profiled out of the residual and of
    /// every fault column (the Schur complement `JᵀWJ − CᵀQ⁻¹C`, `Q` the nuisances' normal
    /// matrix, `C` their cross terms with the faults): an interval then includes what the
    /// window cannot tell from its load (a moment against friction). Twelve model runs, no
    /// storage of residuals; f32 products summed in blocks joined in f64. For the window's
    /// uncertainty and its polish. A held component ([`HeldComponents`]) is varied, but its
    /// row and column leave the sums (its deviation not determined; the polish does not
    /// move it); its cross terms with the free components are the [`HeldCoupling`].
    pub fn curvature(&self, k: &FaultVector) -> Curvature {
        run_to_end(self.curvature_stepwise(k))
    }

    /// [`curvature`](Self::curvature) with how the free components lean on the held ones
    /// there ([`HeldCoupling`]; what [`identify`] hands a flight's reading).
    pub fn curvature_with_coupling(&self, k: &FaultVector) -> (Curvature, HeldCoupling) {
        let (c, _, coupling) = run_to_end(self.curvature_and_load_stepwise(k, self.load));
        (c, coupling)
    }

    /// [`curvature`](Self::curvature) in steps: the future pauses after every
    /// [`CURVATURE_RUNS_PER_POLL`] runs' sample, after each sample's sums and after each row
    /// of a block's flush.
    pub async fn curvature_stepwise(&self, k: &FaultVector) -> Curvature {
        self.curvature_and_load_stepwise(k, self.load).await.0
    }

    /// [`curvature_stepwise`](Self::curvature_stepwise) under `load`, with how the load's
    /// best stiffness and moment move with the faults ([`LoadResponse`]): the polish steps
    /// the load with the faults, as the profiled curvature assumes.
    ///
    /// Two stages, each its own future, so that the runs' state is gone when the profile's
    /// algebra runs: [`lockstep_sums_stepwise`](Self::lockstep_sums_stepwise), then
    /// [`profiled_stepwise`](Self::profiled_stepwise).
    pub(super) async fn curvature_and_load_stepwise(
        &self,
        k: &FaultVector,
        load: WindowLoad,
    ) -> (Curvature, LoadResponse, HeldCoupling) {
        // The totals stay here, lent to both stages (not moved: 1.9 kB).
        let mut totals = WindowTotals::ZERO;
        let fitted = self.lockstep_sums_stepwise(k, load, &mut totals).await;
        self.profiled_stepwise(&mut totals, fitted).await
    }

    /// The curvature's sums at `k` under `load` over the window, added to `totals`:
    /// thirteen lockstep runs, f32 products summed in blocks joined in f64. Returns the
    /// fitted samples' count.
    #[allow(clippy::indexing_slicing, clippy::needless_range_loop)] // indices < FAULT_COUNT, NUISANCES on fixed arrays
    async fn lockstep_sums_stepwise(
        &self,
        k: &FaultVector,
        load: WindowLoad,
        totals: &mut WindowTotals,
    ) -> u32 {
        // What the caller did since its last pause ends its poll here.
        pause().await;
        let k = &self.held.apply(k);
        let start = self.measured.initial_angles();
        let first = self.command.position_at(0);
        let moment_step = LOAD_STEP * load.stiffness * self.model.command().amplitude;
        let moment_step = if moment_step > 0.0 { moment_step } else { 1.0 };
        let mut steps = [0.0f32; FAULT_COUNT];
        // One model for the twelve runs, each run's rigging set before its step.
        let mut model = self.model;
        pause().await;
        // Idle runs first (a constant copied, ≈ 4 kB), each started in the loop below.
        let mut runs = [IDLE_LOCKSTEP_RUN; RUNS];
        pause().await;
        for (j, slot) in runs.iter_mut().enumerate() {
            let mut genes = *k.as_array();
            let (mut stiffness, mut moment) = (load.stiffness, load.moment);
            // Held components are varied too: their columns give how the free
            // components lean on them ([`HeldCoupling`]), then leave the sums.
            if (1..=FAULT_COUNT).contains(&j) {
                let c = j - 1;
                let x = genes[c];
                let shifted = if x + STEP <= 1.0 { x + STEP } else { x - STEP };
                steps[c] = shifted - x;
                genes[c] = shifted;
            } else if j == FAULT_COUNT + 1 {
                stiffness *= 1.0 + LOAD_STEP;
            } else if j == FAULT_COUNT + 2 {
                moment += moment_step;
            }
            let (m, r) = self
                .model
                .with_load_stiffness(stiffness)
                .start_loaded_run_stepwise(&FaultVector::saturating(genes), start, moment, first)
                .await;
            *slot = (m.rigging(), r, LowPassState::default());
            pause().await;
        }
        let filter = self.measured.filter();
        let mut fitted = 0u32;
        let mut previous = 0.0f32;
        let mut block = WindowBlockSums::ZERO;
        let mut in_block = 0u32;
        for (i, &r) in self
            .measured
            .samples()
            .iter()
            .take(self.samples)
            .enumerate()
        {
            let x = axis(i, self.samples);
            let phi = legendre(x);
            let push = -load.trend_at(&phi);
            let command = self.command.position_at(i);
            let mut current = [0.0f32; RUNS];
            for (n, ((rigging, run, state), out)) in
                runs.iter_mut().zip(current.iter_mut()).enumerate()
            {
                model.rig(*rigging);
                if push != 0.0 {
                    run.push_surface(&model, push);
                }
                *out = filter.apply(state, run.next_sample(&model, command).current);
                if (n + 1) % CURVATURE_RUNS_PER_POLL == 0 {
                    pause().await;
                }
            }
            let d = r - previous;
            previous = r;
            if i < SETTLE_SAMPLES {
                continue;
            }
            // f32 products summed in blocks of CURVATURE_BLOCK samples, each block added to
            // the f64 totals (as the preflight's curvature): single precision per sample,
            // the Cortex-M4F's FPU, no soft f64 in the loop.
            let w = weight(d, self.inv_kappa);
            let base = current[0];
            let e = r - base;
            let jac: [f32; FAULT_COUNT] = core::array::from_fn(|c| {
                if steps[c] != 0.0 {
                    (current[c + 1] - base) / steps[c]
                } else {
                    0.0
                }
            });
            // The nuisance columns: the drift's polynomials, then d/d ln K and d/dM.
            let nuisance: [f32; NUISANCES] = core::array::from_fn(|t| {
                if t < DRIFT_TERMS {
                    phi[t]
                } else if t == DRIFT_TERMS {
                    (current[FAULT_COUNT + 1] - base) / LOAD_STEP
                } else {
                    (current[FAULT_COUNT + 2] - base) / moment_step
                }
            });
            let b = &mut block;
            for a in 0..FAULT_COUNT {
                let wa = w * jac[a];
                b.gradient[a] += wa * e;
                for c in a..FAULT_COUNT {
                    b.normal[a][c] += wa * jac[c];
                }
            }
            b.rss += w * e * e;
            for t in 0..NUISANCES {
                let wn = w * nuisance[t];
                b.q_residual[t] += wn * e;
                for c in 0..FAULT_COUNT {
                    b.cross[t][c] += wn * jac[c];
                }
            }
            for (row, &n) in b.q_load.iter_mut().zip(&nuisance[DRIFT_TERMS..]) {
                let wn = w * n;
                for (x, &m) in row.iter_mut().zip(&nuisance) {
                    *x += wn * m;
                }
            }
            fitted += 1;
            in_block += 1;
            pause().await;
            if in_block == CURVATURE_BLOCK {
                block.flush_stepwise(totals).await;
                in_block = 0;
            }
        }
        block.flush_stepwise(totals).await;
        fitted
    }

    /// The nuisances profiled out of `totals` (the Schur complement) and the held
    /// components' entries taken out: the curvature, the load's response and the coupling.
    /// In steps: the nuisances' inverse, each solve's rows and each profiled entry a poll.
    #[allow(clippy::indexing_slicing, clippy::needless_range_loop)] // indices < FAULT_COUNT, NUISANCES on fixed arrays
    async fn profiled_stepwise(
        &self,
        totals: &mut WindowTotals,
        fitted: u32,
    ) -> (Curvature, LoadResponse, HeldCoupling) {
        pause().await;
        let WindowTotals {
            normal,
            gradient,
            rss,
            q_load,
            cross,
            q_residual,
        } = totals;
        for a in 0..FAULT_COUNT {
            for c in 0..a {
                normal[a][c] = normal[c][a];
            }
        }
        pause().await;
        // Profile the nuisances out (a regular Q; a singular one leaves the sums as they are,
        // and the load where it is). Q is built straight into the inverse's own state.
        let mut response = LoadResponse::NONE;
        let q = self.nuisance_normal(q_load);
        if let Some(qi) = invert_stepwise(&q).await {
            pause().await;
            let qr = solve_stepwise(&qi, q_residual).await;
            *rss -= dot_stepwise(&qr, q_residual).await;
            response.at_zero = [qr[DRIFT_TERMS], qr[DRIFT_TERMS + 1]];
            // Rows by iterator, columns by `get`, not by indices the pauses would keep: no
            // bounds check.
            let entry = |t: usize, c: usize| cross.get(t).and_then(|r| r.get(c)).copied();
            for (a, (gradient_a, normal_a)) in
                gradient.iter_mut().zip(normal.iter_mut()).enumerate()
            {
                let column: [f64; NUISANCES] = core::array::from_fn(|u| entry(u, a).unwrap_or(0.0));
                let qa = solve_stepwise(&qi, &column).await;
                for (per_fault, term) in response.per_fault.iter_mut().zip(DRIFT_TERMS..) {
                    if let (Some(slot), Some(&q)) = (per_fault.get_mut(a), qa.get(term)) {
                        *slot = -q;
                    }
                }
                pause().await;
                *gradient_a -= dot_stepwise(&qa, q_residual).await;
                pause().await;
                for (c, n) in normal_a.iter_mut().enumerate() {
                    let column: [f64; NUISANCES] =
                        core::array::from_fn(|t| entry(t, c).unwrap_or(0.0));
                    *n -= dot_stepwise(&qa, &column).await;
                    pause().await;
                }
            }
        }
        pause().await;
        // The held components' entries leave the sums (the polish does not move them, the
        // uncertainty does not read them); what the free ones share with them is kept.
        let mut coupling = HeldCoupling::NONE;
        for h in (0..FAULT_COUNT).filter(|&h| self.held.holds(h)) {
            for a in (0..FAULT_COUNT).filter(|&a| !self.held.holds(a)) {
                coupling.normal[a][h] = normal[a][h];
            }
            for a in 0..FAULT_COUNT {
                normal[a][h] = 0.0;
                normal[h][a] = 0.0;
            }
            gradient[h] = 0.0;
            response.per_fault[0][h] = 0.0;
            response.per_fault[1][h] = 0.0;
        }
        pause().await;
        let curvature = Curvature {
            normal: *normal,
            rss: rss.max(0.0),
            gradient: *gradient,
            fitted,
        };
        (curvature, response, coupling)
    }
}

impl<const N: usize> WindowProblem<'_, N> {
    /// The nuisances' normal matrix `Q`: the drift's Gram matrix and the load columns'
    /// rows `q_load` (mirrored). O(`NUISANCES²`).
    #[allow(clippy::indexing_slicing, clippy::needless_range_loop)] // indices < NUISANCES on fixed arrays
    fn nuisance_normal(
        &self,
        q_load: &[[f64; NUISANCES]; NUISANCES - DRIFT_TERMS],
    ) -> [[f64; NUISANCES]; NUISANCES] {
        let mut q = [[0.0f64; NUISANCES]; NUISANCES];
        for (row, g) in q.iter_mut().zip(&self.gram) {
            row[..DRIFT_TERMS].copy_from_slice(g);
        }
        for (t, row) in q_load.iter().enumerate() {
            let t = DRIFT_TERMS + t;
            q[t] = *row;
            for u in 0..DRIFT_TERMS {
                q[u][t] = row[u];
            }
        }
        q
    }
}

/// A curvature's lockstep run before its start: its rigging, its run and its filter.
const IDLE_LOCKSTEP_RUN: (RunRigging, crate::model::monitor::MonitorRun, LowPassState) = (
    RunRigging {
        load_stiffness: 0.0,
        encoder_offset: 0.0,
    },
    crate::model::monitor::MonitorRun::IDLE,
    LowPassState::ZERO,
);

/// `Q⁻¹·v` from the inverse `qi`, each row's sum stepwise ([`dot_stepwise`]).
#[allow(clippy::indexing_slicing)] // t, u < NUISANCES on fixed arrays
async fn solve_stepwise(
    qi: &[[f64; NUISANCES]; NUISANCES],
    v: &[f64; NUISANCES],
) -> [f64; NUISANCES] {
    let mut out = [0.0f64; NUISANCES];
    // Rows by iterator, not by an index the pauses would keep: no bounds check.
    for (slot, row) in out.iter_mut().zip(qi) {
        *slot = dot_stepwise(row, v).await;
        pause().await;
    }
    out
}

/// Runs of a window curvature's lockstep sample between two pauses of
/// [`WindowProblem::curvature_stepwise`]; the sample's sums are one more poll, a block's
/// flush into the f64 totals one per row (each under 30 % of a 100 µs control period on the
/// Cortex-M4F).
pub const CURVATURE_RUNS_PER_POLL: usize = 5;

/// Fitted samples a window curvature sums in f32 before they join its f64 totals.
pub(super) const CURVATURE_BLOCK: u32 = 64;

/// One block of a window curvature's sums in f32 ([`WindowProblem::curvature`]): the
/// faults' normal matrix (upper triangle) and gradient, the residual's squares, the
/// nuisances' products with the residual and the fault columns, and the load columns'
/// products with every nuisance.
pub(super) struct WindowBlockSums {
    pub(super) normal: [[f32; FAULT_COUNT]; FAULT_COUNT],
    pub(super) gradient: [f32; FAULT_COUNT],
    pub(super) rss: f32,
    pub(super) q_residual: [f32; NUISANCES],
    pub(super) cross: [[f32; FAULT_COUNT]; NUISANCES],
    pub(super) q_load: [[f32; NUISANCES]; NUISANCES - DRIFT_TERMS],
}

impl WindowBlockSums {
    pub(super) const ZERO: Self = Self {
        normal: [[0.0; FAULT_COUNT]; FAULT_COUNT],
        gradient: [0.0; FAULT_COUNT],
        rss: 0.0,
        q_residual: [0.0; NUISANCES],
        cross: [[0.0; FAULT_COUNT]; NUISANCES],
        q_load: [[0.0; NUISANCES]; NUISANCES - DRIFT_TERMS],
    };

    /// Adds the block to `totals` and empties it, pausing after each row (soft f64 on the
    /// Cortex-M4F: a row's adds are one poll).
    pub(super) async fn flush_stepwise(&mut self, totals: &mut WindowTotals) {
        for (total, block) in totals.normal.iter_mut().zip(&self.normal) {
            add(total, block);
            pause().await;
        }
        add(&mut totals.gradient, &self.gradient);
        totals.rss += f64::from(self.rss);
        add(&mut totals.q_residual, &self.q_residual);
        pause().await;
        for (total, block) in totals.cross.iter_mut().zip(&self.cross) {
            add(total, block);
            pause().await;
        }
        for (total, block) in totals.q_load.iter_mut().zip(&self.q_load) {
            add(total, block);
            pause().await;
        }
        *self = Self::ZERO;
    }
}

/// A window curvature's sums in f64, the blocks' totals: the faults' normal matrix (upper
/// triangle) and gradient, the residual's squares, the nuisances' normal matrix's load rows
/// (its drift block is the Gram matrix), their cross terms with the faults and their
/// products with the residual.
pub(super) struct WindowTotals {
    pub(super) normal: [[f64; FAULT_COUNT]; FAULT_COUNT],
    pub(super) gradient: [f64; FAULT_COUNT],
    pub(super) rss: f64,
    pub(super) q_load: [[f64; NUISANCES]; NUISANCES - DRIFT_TERMS],
    pub(super) cross: [[f64; FAULT_COUNT]; NUISANCES],
    pub(super) q_residual: [f64; NUISANCES],
}

impl WindowTotals {
    pub(super) const ZERO: Self = Self {
        normal: [[0.0; FAULT_COUNT]; FAULT_COUNT],
        gradient: [0.0; FAULT_COUNT],
        rss: 0.0,
        q_load: [[0.0; NUISANCES]; NUISANCES - DRIFT_TERMS],
        cross: [[0.0; FAULT_COUNT]; NUISANCES],
        q_residual: [0.0; NUISANCES],
    };
}

/// `total += block`, element by element.
pub(super) fn add<const M: usize>(total: &mut [f64; M], block: &[f32; M]) {
    for (t, &b) in total.iter_mut().zip(block) {
        *t += f64::from(b);
    }
}
