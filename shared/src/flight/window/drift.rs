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
pub(super) fn dot(a: &[f32; DRIFT_TERMS], b: &[f32; DRIFT_TERMS]) -> f32 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
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

    /// At `x`: Bonnet's recurrence for the values, `P′(n+1) = P′(n−1) + (2n+1)·P(n)` and
    /// the same for `P″` from `P′`.
    #[allow(clippy::indexing_slicing)] // n < DRIFT_TERMS on fixed arrays
    pub(super) fn at(x: f32) -> Self {
        let mut b = Self::ZERO;
        b.value = legendre(x);
        b.slope[1] = 1.0;
        let mut n = 1;
        while n + 1 < DRIFT_TERMS {
            let f = (2 * n + 1) as f32;
            b.slope[n + 1] = b.slope[n - 1] + f * b.value[n];
            b.bend[n + 1] = b.bend[n - 1] + f * b.slope[n];
            n += 1;
        }
        b
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
/// through the measurement's filter.
pub(super) struct LoadedRunCurrent<'a, 'c> {
    pub(super) model: &'a MonitorModel,
    pub(super) run: &'a mut MonitorRun,
    pub(super) command: &'a RecordedCommand<'c>,
    pub(super) filter: &'a LowPass,
    pub(super) state: LowPassState,
    /// The load's trend is not zero: its moment is pushed on the surface each step.
    pub(super) trending: bool,
    /// No standstill segment: the model steps inline.
    pub(super) motion_only: bool,
}

impl SampleCurrent for LoadedRunCurrent<'_, '_> {
    #[inline(always)]
    fn next(&mut self, i: usize, h: f32) -> f32 {
        if self.trending {
            self.run.push_surface(self.model, -h);
        }
        let command = self.command.position_at(i);
        let sample = if self.motion_only {
            self.run.next_motion_sample(self.model, command)
        } else {
            self.run.next_sample(self.model, command)
        };
        self.filter.apply(&mut self.state, sample.current)
    }
}

/// A run's current pushed by a moment per sample from outside the problem
/// ([`WindowProblem::evaluate_with_moment_samples`]) instead of the load's trend.
pub(super) struct MomentSamples<'m, C: SampleCurrent> {
    pub(super) current: C,
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
pub(super) struct PinnedSurface<'m, 'a, 'c> {
    pub(super) current: LoadedRunCurrent<'a, 'c>,
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

impl SampleCurrent for PinnedSurface<'_, '_, '_> {
    #[inline(always)]
    fn next(&mut self, i: usize, _trend: f32) -> f32 {
        let c = &mut self.current;
        if let (Some(&angle), Some(&speed)) =
            (self.surface.angles.get(i), self.surface.speeds.get(i))
        {
            c.run.pin_surface(angle, speed);
        }
        let command = c.command.position_at(i);
        let sample = if c.motion_only {
            c.run.next_motion_sample(c.model, command)
        } else {
            c.run.next_sample(c.model, command)
        };
        let moving = i >= c.model.lead_samples();
        if let (Some(&motor), true) = (self.surface.motor.get(i), moving) {
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
