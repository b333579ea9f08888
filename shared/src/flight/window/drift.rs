//! The drift a window profiles out of its residual: the Legendre basis over the window,
//! evaluated per block of [`DRIFT_BLOCK`] samples by a Taylor step, and the model currents
//! the fit walks sample by sample ([`SampleCurrent`]), with eq. (3)'s weight. O(1) per
//! sample, O(`DRIFT_TERMS`) per block.

use super::*;

/// Bonnet's recurrence `(n + 1)·P(n+1) = (2n + 1)·x·P(n) − n·P(n−1)` as the two factors of
/// each step from `P(n−1)`, `P(n)` to `P(n+1)`, n = 1 … `DRIFT_TERMS − 2`: `(2n + 1)/(n + 1)`
/// and `n/(n + 1)`, rounded once here rather than divided at every sample.
#[allow(clippy::indexing_slicing)] // n − 1 < DRIFT_TERMS − 2, evaluated at compile time
pub(super) const BONNET: [(f32, f32); DRIFT_TERMS - 2] = {
    let mut t = [(0.0f32, 0.0f32); DRIFT_TERMS - 2];
    let mut n = 1;
    while n <= DRIFT_TERMS - 2 {
        let (a, b) = (
            (2 * n + 1) as f64 / (n + 1) as f64,
            n as f64 / (n + 1) as f64,
        );
        t[n - 1] = (a as f32, b as f32);
        n += 1;
    }
    t
};

/// The first [`DRIFT_TERMS`] Legendre polynomials at `x` ∈ [−1, 1] (Bonnet's recurrence,
/// [`BONNET`]): three multiplies per term, no division; indexed, so that the size-optimised
/// build keeps it a plain loop. Per window, per block of samples and per curvature sample.
#[inline(always)]
#[allow(clippy::indexing_slicing)] // n < DRIFT_TERMS on fixed arrays
pub(super) fn legendre(x: f32) -> [f32; DRIFT_TERMS] {
    let mut p = [0.0f32; DRIFT_TERMS];
    p[0] = 1.0;
    p[1] = x;
    let mut n = 2;
    while n < DRIFT_TERMS {
        let (a, b) = BONNET[n - 2];
        p[n] = a * x * p[n - 1] - b * p[n - 2];
        n += 1;
    }
    p
}

/// Where sample `i` of a window of `n` sits on the drift's axis [−1, 1].
#[inline(always)]
pub(super) fn axis(i: usize, n: usize) -> f32 {
    let span = n.saturating_sub(SETTLE_SAMPLES + 1).max(1) as f32;
    2.0 * (i.saturating_sub(SETTLE_SAMPLES)) as f32 / span - 1.0
}

/// The distance between two samples on the drift's axis (see [`axis`]).
#[inline(always)]
pub(super) fn axis_step(n: usize) -> f32 {
    2.0 / n.saturating_sub(SETTLE_SAMPLES + 1).max(1) as f32
}

/// Fitted samples per block of the drift's expansion (`TaylorBlock`).
pub const DRIFT_BLOCK: usize = 16;

/// `Σ a·b` over the drift's terms.
#[inline(always)]
#[allow(clippy::indexing_slicing)] // n < DRIFT_TERMS on fixed arrays
pub(super) fn dot(a: &[f32; DRIFT_TERMS], b: &[f32; DRIFT_TERMS]) -> f32 {
    // `Iterator::sum`'s fold from −0.0, in the same order: the same bits, in the caller's
    // loop rather than a call.
    let mut sum = -0.0f32;
    let mut n = 0;
    while n < DRIFT_TERMS {
        sum += a[n] * b[n];
        n += 1;
    }
    sum
}

/// The drift's polynomials, their first and second derivatives at a block's centre: over
/// the block, `P(x_c + u) ≈ P + u·P′ + ½u²·P″`. O(`DRIFT_TERMS`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct TaylorBlock {
    pub(super) value: [f32; DRIFT_TERMS],
    pub(super) slope: [f32; DRIFT_TERMS],
    pub(super) bend: [f32; DRIFT_TERMS],
}

impl TaylorBlock {
    pub(super) const ZERO: Self = Self {
        value: [0.0; DRIFT_TERMS],
        slope: [0.0; DRIFT_TERMS],
        bend: [0.0; DRIFT_TERMS],
    };

    /// The block at `x`, as a window's sums open it ([`ResidualSums::next_block`]: Bonnet's
    /// recurrence for the values, `P′(n+1) = P′(n−1) + (2n+1)·P(n)` and the same for `P″`
    /// from `P′`).
    #[cfg(test)]
    pub(super) fn at(x: f32) -> Self {
        let mut sums = ResidualSums::new(&[0.0; DRIFT_TERMS]);
        sums.next_block((0.0, 0.0, 0.0), x, &[0.0; DRIFT_TERMS]);
        sums.block
    }

    /// Adds a block's sums `(Σ w·e, Σ w·e·u, Σ w·e·u²)` to the projections `Σ w·e·P`.
    pub(super) fn add_to(&self, projections: &mut [f32; DRIFT_TERMS], sums: (f32, f32, f32)) {
        for (((p, v), s), c) in projections
            .iter_mut()
            .zip(&self.value)
            .zip(&self.slope)
            .zip(&self.bend)
        {
            *p += v * sums.0 + s * sums.1 + 0.5 * c * sums.2;
        }
    }
}

/// Eq. (3)'s sums over a window's samples, taken in order and resumable
/// ([`advance`](Self::advance) any number of samples at a time, the same bits): the modelled
/// current against the measured after [`SETTLE_SAMPLES`], weighted by the measured current's
/// steps, and its projections on the drift's polynomials.
///
/// The drift's polynomials are not evaluated per sample: over each block of [`DRIFT_BLOCK`]
/// fitted samples they are expanded to second order about the block's centre
/// ([`TaylorBlock`]), so a sample adds three weighted powers of its distance from the centre
/// and the trend's moment is three multiply-adds. The expansion's error is the third
/// derivative's term: below 10⁻⁴ of the polynomials' range for degree 9.
#[derive(Clone)]
pub(super) struct ResidualSums {
    /// The next sample's index.
    next: usize,
    /// The trend's value at the window's start (its moments are relative to it).
    pub(super) at_start: f32,
    pub(super) block: TaylorBlock,
    /// The trend's expansion over the block: value, slope, half the bend.
    moment: (f32, f32, f32),
    /// Σ w·e, Σ w·e·u, Σ w·e·u² over the block, u the distance from its centre.
    sums: (f32, f32, f32),
    pub(super) projections: [f32; DRIFT_TERMS],
    previous: f32,
    squares: f32,
    in_block: usize,
}

impl ResidualSums {
    pub(super) fn new(trend: &[f32; DRIFT_TERMS]) -> Self {
        Self {
            next: 0,
            at_start: dot(trend, &legendre(-1.0)),
            block: TaylorBlock::ZERO,
            moment: (0.0, 0.0, 0.0),
            sums: (0.0, 0.0, 0.0),
            projections: [0.0; DRIFT_TERMS],
            previous: 0.0,
            squares: 0.0,
            in_block: 0,
        }
    }

    /// Steps `modelled` over at most `count` more of `problem`'s samples (`trend` the load's,
    /// as at [`new`](Self::new)) and sums them. Returns whether the window is done. One
    /// loop over the settle and the fitted samples, the model stepped inline
    /// ([`SampleCurrent`]); the running sums are locals within a call. O(`count`).
    #[inline(always)]
    pub(super) fn advance<const N: usize>(
        &mut self,
        problem: &WindowProblem<'_, N>,
        trend: &[f32; DRIFT_TERMS],
        modelled: &mut impl SampleCurrent,
        count: usize,
    ) -> bool {
        let total = problem.samples;
        let reference = problem.measured.samples();
        let reference = reference.get(..total).unwrap_or(reference);
        let total = reference.len();
        let start = self.next.min(total);
        let end = start.saturating_add(count).min(total);
        let mut previous = self.previous;
        let step = axis_step(total);
        let half = 0.5 * (DRIFT_BLOCK - 1) as f32;
        let mut moment = self.moment;
        let mut sums = self.sums;
        let mut squares = self.squares;
        let mut in_block = self.in_block;
        for (i, &r) in (start..).zip(reference.get(start..end).unwrap_or(&[])) {
            if i < SETTLE_SAMPLES {
                modelled.next(i, 0.0);
                previous = r;
                continue;
            }
            if in_block == 0 {
                moment = self.next_block(sums, axis(i, total) + half * step, trend);
                sums = (0.0, 0.0, 0.0);
            }
            let u = (in_block as f32 - half) * step;
            in_block = if in_block + 1 == DRIFT_BLOCK {
                0
            } else {
                in_block + 1
            };
            let h = moment.0 + u * (moment.1 + u * moment.2);
            let m = modelled.next(i, h);
            let d = r - previous;
            previous = r;
            let w = weight(d, problem.inv_kappa);
            let e = r - m;
            let we = w * e;
            squares += we * e;
            let weu = we * u;
            sums.0 += we;
            sums.1 += weu;
            sums.2 += weu * u;
        }
        self.previous = previous;
        self.moment = moment;
        self.sums = sums;
        self.squares = squares;
        self.in_block = in_block;
        self.next = end;
        end == total
    }

    /// Closes the block whose sums are `sums` into the projections and opens the next, centred
    /// at `x` on the drift's axis: the trend's moment over it (value, slope, half the bend).
    /// One pass over the terms does what [`TaylorBlock::add_to`], the polynomials' recurrences
    /// ([`legendre`] and its derivatives') and three [`dot`]s do, each sum in their order (the
    /// same bits). Out of line: once per
    /// [`DRIFT_BLOCK`] samples, its registers not the sample loop's. O(`DRIFT_TERMS`).
    #[inline(never)]
    #[allow(clippy::indexing_slicing)] // n < DRIFT_TERMS on fixed arrays
    pub(super) fn next_block(
        &mut self,
        sums: (f32, f32, f32),
        x: f32,
        trend: &[f32; DRIFT_TERMS],
    ) -> (f32, f32, f32) {
        let b = &mut self.block;
        let mut moment = (-0.0f32, -0.0f32, -0.0f32);
        let mut n = 0;
        while n < DRIFT_TERMS {
            // The old block's term n into its projection.
            self.projections[n] +=
                b.value[n] * sums.0 + b.slope[n] * sums.1 + 0.5 * b.bend[n] * sums.2;
            // The new block's term n from its terms n − 1 and n − 2, already new.
            let (value, slope, bend) = if n >= 2 {
                let (p, q) = BONNET[n - 2];
                let f = (2 * n - 1) as f32;
                (
                    p * x * b.value[n - 1] - q * b.value[n - 2],
                    b.slope[n - 2] + f * b.value[n - 1],
                    b.bend[n - 2] + f * b.slope[n - 1],
                )
            } else if n == 1 {
                (x, 1.0, 0.0)
            } else {
                (1.0, 0.0, 0.0)
            };
            b.value[n] = value;
            b.slope[n] = slope;
            b.bend[n] = bend;
            moment.0 += trend[n] * value;
            moment.1 += trend[n] * slope;
            moment.2 += trend[n] * bend;
            n += 1;
        }
        (moment.0 - self.at_start, moment.1, 0.5 * moment.2)
    }

    /// [`advance`](Self::advance) in a function of its own, for a stepwise evaluation: its
    /// loop keeps the sums in registers behind its own `&mut` arguments, not in the
    /// evaluation's future (inlined there, a sample costs ≈ 25 % more on the Cortex-M4F).
    #[inline(never)]
    pub(super) fn advance_slice<const N: usize>(
        &mut self,
        problem: &WindowProblem<'_, N>,
        trend: &[f32; DRIFT_TERMS],
        modelled: &mut LoadedRunCurrent<'_, '_>,
        count: usize,
    ) -> bool {
        modelled.stepping(|current| self.advance(problem, trend, current, count))
    }

    /// Eq. (3) with the drift profiled out, and the drift, of the samples summed so far.
    /// O(`DRIFT_TERMS²`).
    pub(super) fn fit<const N: usize>(mut self, problem: &WindowProblem<'_, N>) -> WindowFit {
        self.block.add_to(&mut self.projections, self.sums);
        let projections = &self.projections;
        let mut drift = [0.0f32; DRIFT_TERMS];
        for (c, row) in drift.iter_mut().zip(&problem.drift_inverse) {
            *c = row.iter().zip(projections).map(|(a, b)| a * b).sum();
        }
        let explained: f32 = drift.iter().zip(projections).map(|(c, b)| c * b).sum();
        let dt = problem.model.params().control_period;
        let error = (self.squares - explained).max(0.0) * dt;
        WindowFit {
            error: if error.is_finite() {
                error
            } else {
                f32::INFINITY
            },
            drift,
        }
    }
}

/// The modelled current of a window's samples, in order: `next(i, h)` steps the model to
/// sample `i` with `h` [N·m] pushed on the surface and gives its filtered current [A]. O(1),
/// inlined into [`WindowProblem::residual_fit`]'s loops.
pub(super) trait SampleCurrent {
    fn next(&mut self, i: usize, h: f32) -> f32;
}

/// No model: the measured current's own energy.
pub(super) struct NoCurrent;

impl SampleCurrent for NoCurrent {
    #[inline(always)]
    fn next(&mut self, _: usize, _: f32) -> f32 {
        0.0
    }
}

/// A monitor-model run under a window's load, driven by the recorded command and seen
/// through the measurement's filter: stepped through [`stepping`](Self::stepping).
pub(super) struct LoadedRunCurrent<'a, 'c> {
    pub(super) model: &'a MonitorModel,
    pub(super) run: &'a mut MonitorRun,
    pub(super) command: &'a RecordedCommand<'c>,
    pub(super) filter: &'a LowPass,
    pub(super) state: LowPassState,
    /// The load's trend is not zero: its moment is pushed on the surface each step.
    pub(super) trending: bool,
}

impl<'c> LoadedRunCurrent<'_, 'c> {
    /// `body` with the run's current as a [`SampleCurrent`], the run's state and the
    /// filter's held by value in the caller's frame ([`MonitorRun::steps`]): a loop in
    /// `body` keeps them in registers (≈ 15 % fewer instructions a sample on the
    /// Cortex-M4F than through the run's reference). Written back when `body` returns.
    #[inline(always)]
    pub(super) fn stepping<R>(
        &mut self,
        body: impl FnOnce(&mut SteppedCurrent<'_, '_, 'c>) -> R,
    ) -> R {
        let Self {
            model,
            run,
            command,
            filter,
            state,
            trending,
            ..
        } = self;
        run.steps(|steps| {
            let mut current = SteppedCurrent {
                model,
                steps,
                command,
                filter,
                state: *state,
                trending: *trending,
            };
            let out = body(&mut current);
            *state = current.state;
            out
        })
    }
}

/// A [`LoadedRunCurrent`] being stepped ([`LoadedRunCurrent::stepping`]).
pub(super) struct SteppedCurrent<'a, 'r, 'c> {
    model: &'a MonitorModel,
    steps: &'a mut RunSteps<'r>,
    command: &'a RecordedCommand<'c>,
    filter: &'a LowPass,
    state: LowPassState,
    trending: bool,
}

impl SteppedCurrent<'_, '_, '_> {
    /// The run's next sample at the command of sample `i`. O(1).
    #[inline(always)]
    fn sample(&mut self, i: usize) -> crate::model::monitor::MonitorSample {
        let command = self.command.position_at(i);
        self.steps.next_motion_sample(self.model, command)
    }
}

impl SampleCurrent for SteppedCurrent<'_, '_, '_> {
    #[inline(always)]
    fn next(&mut self, i: usize, h: f32) -> f32 {
        if self.trending {
            self.steps.push_surface(self.model, -h);
        }
        let sample = self.sample(i);
        self.filter.apply(&mut self.state, sample.current)
    }
}

/// A run's current pushed by a moment per sample from outside the problem
/// ([`WindowProblem::evaluate_with_moment_samples`]) instead of the load's trend.
pub(super) struct MomentSamples<'m, C: SampleCurrent> {
    pub(super) current: &'m mut C,
    pub(super) moments: &'m [f32],
}

impl<C: SampleCurrent> SampleCurrent for MomentSamples<'_, C> {
    #[inline(always)]
    fn next(&mut self, i: usize, _trend: f32) -> f32 {
        let h = self.moments.get(i).copied().unwrap_or(0.0);
        self.current.next(i, h)
    }
}

/// A run whose surface follows its sensor ([`WindowProblem::evaluate_with_surface_samples`]),
/// summing the squared difference of its motor angle from the measured.
pub(super) struct PinnedSurface<'m, 'a, 'r, 'c> {
    pub(super) current: &'m mut SteppedCurrent<'a, 'r, 'c>,
    pub(super) surface: &'m SurfaceSamples<'m>,
    pub(super) motor_error: f64,
    pub(super) motor_sum: f64,
    pub(super) counted: u32,
    pub(super) trajectory: &'m mut [f32],
}

/// What the sensors read of a window's shafts, per sample: the surface's angle \[rad\] and
/// speed [rad/s], the motor's unwrapped angle \[rad\].
#[derive(Clone, Copy, Debug)]
pub struct SurfaceSamples<'m> {
    pub angles: &'m [f32],
    pub speeds: &'m [f32],
    pub motor: &'m [f32],
}

impl SampleCurrent for PinnedSurface<'_, '_, '_, '_> {
    #[inline(always)]
    fn next(&mut self, i: usize, _trend: f32) -> f32 {
        let c = &mut *self.current;
        if let (Some(&angle), Some(&speed)) =
            (self.surface.angles.get(i), self.surface.speeds.get(i))
        {
            c.steps.pin_surface(angle, speed);
        }
        let sample = c.sample(i);
        if let Some(&motor) = self.surface.motor.get(i) {
            let e = f64::from(sample.motor_angle - motor);
            self.motor_error += e * e;
            self.motor_sum += e;
            self.counted += 1;
        }
        if let Some(t) = self.trajectory.get_mut(i) {
            *t = sample.motor_angle;
        }
        c.filter.apply(&mut c.state, sample.current)
    }
}

/// The eq. (3) weight of each fitted sample: `1 / ((ΔI_r)²/κ + 1)`.
#[inline(always)]
pub(super) fn weight(delta: f32, inv_kappa: f32) -> f32 {
    1.0 / (delta * delta * inv_kappa + 1.0)
}
