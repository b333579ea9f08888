//! A window's problem: the monitor model run over the window under its load, and eq. (3)
//! with the drift profiled out ([`WindowProblem::evaluate`]). One evaluation is one model
//! run over the window, O(N), and O(`DRIFT_TERMS²`); [`WindowProblem::fitted`] two runs.

use super::*;

impl<'a, const N: usize> WindowProblem<'a, N> {
    /// The window problem of `measured` (a finished buffer of the window's frames) driven by
    /// `command` (one commanded angle per frame), with `model` on the window's day (the
    /// chirp-only test's) and the load at `load`.
    pub fn new(
        measured: &'a MeasuredCurrent<N>,
        command: RecordedCommand<'a>,
        model: MonitorModel,
        load: WindowLoad,
    ) -> Result<Self, WindowError> {
        let mut slot = None;
        run_to_end(Self::build_stepwise(
            &mut slot, measured, command, model, load,
        ))?;
        // A build that returns `Ok` has filled the slot.
        slot.ok_or(WindowError::Singular)
    }

    /// [`new`](Self::new) in steps, for a controller's idle time, built into `slot` (the
    /// caller's: the problem, ≈ 1.9 kB, is not moved through futures): a pause first, after
    /// each half row of a sample's Gram products (five soft-f64 multiply-adds), in the Gram
    /// matrix's inverse ([`invert_stepwise`]) and after every [`SCAN_PER_POLL`] samples of
    /// the window's scans (its peak, its command's range, its energy). `Ok`: the slot holds
    /// the same problem as `new`'s.
    pub async fn build_stepwise(
        slot: &mut Option<Self>,
        measured: &'a MeasuredCurrent<N>,
        command: RecordedCommand<'a>,
        model: MonitorModel,
        load: WindowLoad,
    ) -> Result<(), WindowError> {
        pause().await;
        if model.lead_samples() != 0 {
            return Err(WindowError::Standstill);
        }
        let reference = measured.samples();
        let samples = reference.len().min(command.len());
        if samples < SETTLE_SAMPLES + 10 * DRIFT_TERMS {
            return Err(WindowError::TooShort);
        }
        let inv_kappa = measured.inv_kappa().map_err(|_| WindowError::Flat)?;
        let mut gram = [[0.0f64; DRIFT_TERMS]; DRIFT_TERMS];
        let mut previous = 0.0f32;
        for (i, &r) in reference.iter().take(samples).enumerate() {
            let d = r - previous;
            previous = r;
            if i < SETTLE_SAMPLES {
                if (i + 1) % SCAN_PER_POLL == 0 {
                    pause().await;
                }
                continue;
            }
            if i == SETTLE_SAMPLES {
                pause().await;
            }
            let w = f64::from(weight(d, inv_kappa));
            let phi = legendre(axis(i, samples));
            for (row, &a) in gram.iter_mut().zip(&phi) {
                for (c, (x, &b)) in row.iter_mut().zip(&phi).enumerate() {
                    *x += w * f64::from(a) * f64::from(b);
                    if c + 1 == DRIFT_TERMS / 2 {
                        pause().await;
                    }
                }
                pause().await;
            }
        }
        let inverse = invert_stepwise(&gram).await.ok_or(WindowError::Singular)?;
        pause().await;
        let mut drift_inverse = [[0.0f32; DRIFT_TERMS]; DRIFT_TERMS];
        for (to, from) in drift_inverse.iter_mut().zip(&inverse) {
            *to = from.map(|x| x as f32);
            pause().await;
        }
        // The kept samples within the window (the line between two never leaves them).
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        for (j, &x) in command
            .kept()
            .iter()
            .take((samples - 1) / command.stride + 1)
            .enumerate()
        {
            (lo, hi) = (lo.min(x), hi.max(x));
            if (j + 1) % SCAN_PER_POLL == 0 {
                pause().await;
            }
        }
        let mut peak_current = 0.0f32;
        for (i, &x) in reference.iter().take(samples).enumerate() {
            peak_current = peak_current.max(abs(x));
            if (i + 1) % SCAN_PER_POLL == 0 {
                pause().await;
            }
        }
        let problem = slot.insert(Self {
            measured,
            command,
            model,
            load,
            inv_kappa,
            drift_inverse,
            gram,
            samples,
            energy: 0.0,
            peak_current,
            command_range: hi - lo,
            held: HeldComponents::NONE,
            evaluation_slice: EVALUATION_SLICE,
        });
        pause().await;
        let mut energy = ResidualSums::new(&[0.0; DRIFT_TERMS]);
        while !energy.advance(problem, &[0.0; DRIFT_TERMS], &mut NoCurrent, SCAN_PER_POLL) {
            pause().await;
        }
        problem.energy = energy.fit(problem).error;
        Ok(())
    }

    pub fn load(&self) -> WindowLoad {
        self.load
    }

    /// The window's samples (the measured and the commanded, the shorter).
    pub fn samples(&self) -> usize {
        self.samples
    }

    /// The samples eq. (3) sums over (the window's after [`SETTLE_SAMPLES`]).
    pub fn fitted_samples(&self) -> usize {
        self.samples.saturating_sub(SETTLE_SAMPLES)
    }

    /// The error of a model that gives no current [A²·s]: what
    /// [`misfit`](Self::misfit) divides by.
    pub fn energy(&self) -> f32 {
        self.energy
    }

    pub fn model(&self) -> &MonitorModel {
        &self.model
    }

    /// The window problem of an actuator `record`'s window: `measured` (its finished frames,
    /// the window's test) driven by `kept` (the command kept every [`COMMAND_STRIDE`]
    /// frames), the model on the day the FDI estimates from the window
    /// ([`TestConditions::estimate`](crate::model::conditions::TestConditions::estimate)), the load at `load`, and that day. The host's and the
    /// controller's windows both start here. O(N) (the day's estimate).
    pub fn of_record(
        measured: &'a MeasuredCurrent<N>,
        kept: &'a [f32],
        record: &crate::preflight::actuator::ActuatorRecord,
        load: WindowLoad,
    ) -> Result<(Self, crate::model::conditions::TestConditions), WindowError> {
        let mut slot = None;
        let conditions = run_to_end(Self::of_record_into_stepwise(
            &mut slot, measured, kept, record, load,
        ))?;
        // A build that returns `Ok` has filled the slot.
        Ok((slot.ok_or(WindowError::Singular)?, conditions))
    }

    /// [`of_record`](Self::of_record) in steps, built into `slot` (the caller's): the day's
    /// estimate, the model, then [`build_stepwise`](Self::build_stepwise), each in polls of
    /// their own. `Ok`: the day, the slot holding the problem.
    pub async fn of_record_into_stepwise(
        slot: &mut Option<Self>,
        measured: &'a MeasuredCurrent<N>,
        kept: &'a [f32],
        record: &crate::preflight::actuator::ActuatorRecord,
        load: WindowLoad,
    ) -> Result<crate::model::conditions::TestConditions, WindowError> {
        let conditions = crate::model::conditions::TestConditions::estimate_stepwise(
            measured,
            &record.params,
            &record.calibration,
        )
        .await;
        pause().await;
        let model = MonitorModel::new(record.params, &record.calibration)
            .with_test(measured.test())
            .with_conditions(&conditions);
        let command = RecordedCommand::kept_every(COMMAND_STRIDE, kept);
        pause().await;
        Self::build_stepwise(slot, measured, command, model, load).await?;
        Ok(conditions)
    }

    /// The same problem with its stepwise evaluations in polls of `samples` samples (at
    /// least one; `usize::MAX`: a model run in one poll). The same bits for every slice.
    pub fn with_evaluation_slice(mut self, samples: usize) -> Self {
        self.evaluation_slice = samples.max(1);
        self
    }

    /// The same problem with `held` components held ([`HeldComponents`]), its model playing
    /// their weak magnet.
    pub fn with_held(mut self, held: HeldComponents) -> Self {
        self.hold(held);
        self
    }

    /// Holds `held` components ([`HeldComponents`]), in place, its model playing their weak
    /// magnet.
    pub fn hold(&mut self, held: HeldComponents) {
        self.held = held;
        self.model = self.model.with_magnets(held.magnets());
    }

    /// The components held at values from outside the window.
    pub fn held(&self) -> &HeldComponents {
        &self.held
    }

    /// The same problem under another load.
    pub fn with_load(mut self, load: WindowLoad) -> Self {
        self.load = load;
        self
    }

    /// Puts the problem under another load, in place.
    pub fn set_load(&mut self, load: WindowLoad) {
        self.load = load;
    }

    /// The moment [N·m] the measured current holds at the window's start, at the model's
    /// torque constant: the mean over the 10 ms after the settle, times the gear ratio. The
    /// load search's start.
    pub fn held_moment(&self) -> f32 {
        let span = self
            .measured
            .samples()
            .iter()
            .skip(SETTLE_SAMPLES / 2)
            .take(SETTLE_SAMPLES / 2);
        let (sum, n) = span.fold((0.0f32, 0u32), |(s, n), &x| (s + x, n + 1));
        let mean = if n > 0 { sum / n as f32 } else { 0.0 };
        mean * self.model.torque_constant() * self.model.params().gear_ratio
    }

    /// The error and drift of fault vector `k` under the problem's load. One model run.
    pub fn evaluate(&self, k: &FaultVector) -> WindowFit {
        self.evaluate_under(k, self.load)
    }

    /// As [`evaluate`](Self::evaluate) under `load`.
    pub fn evaluate_under(&self, k: &FaultVector, load: WindowLoad) -> WindowFit {
        let (model, mut run) = self.loaded_start(k, load);
        let trending = load.trend != [0.0; DRIFT_TERMS];
        let mut current = self.loaded_current(&model, &mut run, trending);
        current.stepping(|current| self.residual_fit(&load.trend, current))
    }

    /// [`evaluate_under`](Self::evaluate_under) in steps, for a controller's idle time: a
    /// pause first, the run's start stepwise ([`MonitorModel::start_loaded_run_stepwise`]), then a pause
    /// after every slice of samples ([`with_evaluation_slice`](Self::with_evaluation_slice))
    /// and once at the end. The same bits.
    pub async fn evaluate_stepwise(&self, k: &FaultVector, load: WindowLoad) -> WindowFit {
        // What the caller did since the last pause (a previous run's fit, a search's step)
        // ends its poll here.
        pause().await;
        let (model, mut run) = self.loaded_start_stepwise(k, load).await;
        pause().await;
        let trending = load.trend != [0.0; DRIFT_TERMS];
        let mut state = LowPassState::default();
        let mut sums = ResidualSums::new(&load.trend);
        loop {
            let mut current = self.loaded_current(&model, &mut run, trending);
            current.state = state;
            let done = sums.advance_slice(self, &load.trend, &mut current, self.evaluation_slice);
            state = current.state;
            if done {
                break;
            }
            pause().await;
        }
        pause().await;
        sums.fit(self)
    }

    /// As [`evaluate_under`](Self::evaluate_under) with the load's trend replaced by a
    /// moment per sample from outside the problem, `moments[i]` [N·m] the hinge moment the
    /// motor must hold at sample `i` beyond the spring's, relative to the window's start
    /// (0 past the slice's end). For studies of what the window's load must follow
    /// (host-sim's example `window_moment`, docs/in-flight.md); not flown. O(samples).
    pub fn evaluate_with_moment_samples(
        &self,
        k: &FaultVector,
        load: WindowLoad,
        moments: &[f32],
    ) -> WindowFit {
        let (model, mut run) = self.loaded_start(k, load);
        let mut current = self.loaded_current(&model, &mut run, true);
        current.stepping(|current| {
            self.residual_fit(&[0.0; DRIFT_TERMS], &mut MomentSamples { current, moments })
        })
    }

    /// As [`evaluate_with_moment_samples`](Self::evaluate_with_moment_samples) with no
    /// moment at all: the surface is put, each sample, where its sensor read it, so the gear
    /// carries whatever moved it; `load` sets where the run starts in the play. Also returns
    /// the mean and the mean square of the run's motor angle against the measured [rad,
    /// rad²] over the window's samples; the run's motor angle \[rad\]
    /// goes to `trajectory`, as far as it reaches. For studies (host-sim's example
    /// `window_pinned`, docs/in-flight.md); not flown. O(samples).
    pub fn evaluate_with_surface_samples(
        &self,
        k: &FaultVector,
        load: WindowLoad,
        surface: &SurfaceSamples<'_>,
        trajectory: &mut [f32],
    ) -> (WindowFit, f64, f64) {
        let (model, mut run) = self.loaded_start(k, load);
        let mut current = self.loaded_current(&model, &mut run, false);
        current.stepping(|current| {
            let mut pinned = PinnedSurface {
                current,
                surface,
                motor_error: 0.0,
                motor_sum: 0.0,
                counted: 0,
                trajectory,
            };
            let fit = self.residual_fit(&[0.0; DRIFT_TERMS], &mut pinned);
            let n = f64::from(pinned.counted.max(1));
            (fit, pinned.motor_sum / n, pinned.motor_error / n)
        })
    }

    /// The model under `load`'s stiffness and its run started in equilibrium under its
    /// moment, at the held components' values of `k`.
    #[inline(always)]
    pub(super) fn loaded_start(
        &self,
        k: &FaultVector,
        load: WindowLoad,
    ) -> (MonitorModel, MonitorRun) {
        run_to_end(self.loaded_start_stepwise(k, load))
    }

    /// [`loaded_start`](Self::loaded_start) in steps
    /// ([`MonitorModel::start_loaded_run_stepwise`]).
    pub(super) async fn loaded_start_stepwise(
        &self,
        k: &FaultVector,
        load: WindowLoad,
    ) -> (MonitorModel, MonitorRun) {
        let k = &self.held.apply(k);
        let model = self.model.with_load_stiffness(load.stiffness);
        let start = self.measured.initial_angles();
        let first = self.command.position_at(0);
        model
            .start_loaded_run_stepwise(k, start, load.moment, first)
            .await
    }

    /// The run's current through the measurement's filter, pushing a moment each step
    /// when `trending`.
    #[inline(always)]
    pub(super) fn loaded_current<'s>(
        &'s self,
        model: &'s MonitorModel,
        run: &'s mut MonitorRun,
        trending: bool,
    ) -> LoadedRunCurrent<'s, 'a> {
        LoadedRunCurrent {
            model,
            run,
            command: &self.command,
            filter: self.measured.filter(),
            state: LowPassState::default(),
            trending,
        }
    }

    /// Eq. (3) of the modelled current `modelled.next(i, h)` (filtered; called once per
    /// sample, in order, with `h` the moment [N·m] of `trend` there, relative to the window's
    /// start) against the measured, after the settle, with the drift profiled out
    /// ([`ResidualSums`] over the whole window in one call).
    #[inline(always)]
    pub(super) fn residual_fit(
        &self,
        trend: &[f32; DRIFT_TERMS],
        modelled: &mut impl SampleCurrent,
    ) -> WindowFit {
        let mut sums = ResidualSums::new(trend);
        sums.advance(self, trend, modelled, usize::MAX);
        sums.fit(self)
    }

    /// The window as fitted at `k` under the problem's load: for every sample, the time
    /// \[s\], the measured current, the model's and the model's with the profiled drift \[A\]
    /// (all filtered alike), handed to `sink`. Two model runs (the drift, then the trace).
    pub fn fitted(&self, k: &FaultVector, mut sink: impl FnMut(f32, f32, f32, f32)) {
        let k = &self.held.apply(k);
        let load = self.load;
        let drift = self.evaluate_under(k, load).drift;
        let model = self.model.with_load_stiffness(load.stiffness);
        let start = self.measured.initial_angles();
        let first = self.command.position_at(0);
        let (model, mut run) = model.start_loaded_run(k, start, load.moment, first);
        let filter = self.measured.filter();
        let mut state = LowPassState::default();
        let dt = self.model.params().control_period;
        for (i, &r) in self
            .measured
            .samples()
            .iter()
            .take(self.samples)
            .enumerate()
        {
            let phi = legendre(axis(i, self.samples));
            run.push_surface(&model, -load.trend_at(&phi));
            let sample = run.next_sample(&model, self.command.position_at(i));
            let modelled = filter.apply(&mut state, sample.current);
            let d: f32 = drift.iter().zip(&phi).map(|(c, p)| c * p).sum();
            sink(i as f32 * dt, r, modelled, modelled + d);
        }
    }
}
