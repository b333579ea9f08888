//! The monitor model (MM): the fast, single-phase-equivalent model the GA runs thousands of
//! times (paper Fig. 4, SPEC §4).
//!
//! Fixed step = the control period (100 µs, 10 kHz); f32; O(1) work and no allocation per
//! step; one [`MonitorModel::run`] of `n` samples is `n` steps. Time is the step index times
//! the period, never read from a clock.
//!
//! Structure, per step:
//! 1. **ACE controller** — PID position loop on the user-shaft angle (its proportional gain
//!    carries the gain-drift fault) → motor speed reference (saturated) → PI speed loop with
//!    conditional-integration anti-windup → current reference I_ref (saturated).
//! 2. **Single-phase equivalent drive** — no PWM and no phase switching: the drive applies the
//!    voltage that would bring the current to I_ref within one period, limited to ±V_dc
//!    (an ideal hysteresis controller seen at the control rate), on an R–L–back-EMF branch of
//!    two phases in series. Electrical faults enter through the paper's shape functions:
//!    short circuit, eq. (1), scales resistance and torque/back-EMF gain by the mean healthy
//!    fraction of the two phases conducting in the current 60° sector; eccentricity, eq. (2),
//!    modulates torque/back-EMF gain with rotor angle; demagnetization scales it in every
//!    bin (the magnets' flux), apart from the day's reversible flux; one weak magnet
//!    ([`MonitorModel::with_magnets`]) scales it over the mechanical angle (two phase
//!    shares a step when there is one, a test of its depth when there is none).
//! 3. **Mechanics** — motor inertia (with lumped stick-slip dry friction: a velocity-level
//!    friction impulse that can stop, but never reverse, the motor within one step) coupled to
//!    the user inertia by a compliant gear train whose play is a dead zone (a contact that
//!    closes within a step damps over its share of the step only); the user shaft carries
//!    the aerodynamic spring load. Semi-implicit Euler.
//!
//! The recorded signal is the equivalent current at the start of each step, i.e. what the ADC
//! samples at `t = i·dt` before the control update.
//!
//! A run starts at rest from the shaft angles measured at the test's first sample, the gear
//! relaxed inside its play ([`MonitorModel::run_from`]); the model's own traces start at zero.

use core::ops::ControlFlow;

use crate::base::math::{abs, clamp, cos, exp64, floor, TAU};
use crate::base::steps::{pause, run_to_end};
use crate::model::calibration::Calibration;
use crate::model::conditions::TestConditions;
use crate::physics::fault::FaultEffects;
use crate::physics::fault::FaultVector;
use crate::physics::magnets::WeakMagnet;
use crate::physics::params::ActuatorParams;
use crate::test::command::{ChirpCommand, ChirpSampler, CommandSource};
use crate::test::conditioning::ShaftAngles;
use crate::test::test_design::{PairDrive, PreflightTest, StandstillSegment, PAIR_SIGNS};

/// What the monitor model exposes at each sample: the state at `time`, before the step's
/// update, plus the controller's output for the coming period.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MonitorSample {
    /// Time of the sample \[s\].
    pub time: f32,
    /// Commanded user-shaft angle \[rad\].
    pub command: f32,
    /// Equivalent (two conducting phases) motor current \[A\].
    pub current: f32,
    /// Reference current from the controller for the coming period \[A\].
    pub current_ref: f32,
    /// Motor-shaft angle at the sample \[rad\].
    pub motor_angle: f32,
    /// User-shaft angle at the sample \[rad\].
    pub user_angle: f32,
}

/// What a run hands each sample to ([`MonitorModel::run_with`]): any
/// `FnMut(&MonitorSample) -> ControlFlow<()>`, or a type whose `take` the compiler inlines into
/// both of the run's loops (the fitness's sum: a closure called from two places stays a call
/// when optimising for size, and its captures stay in memory).
pub trait SampleSink {
    /// Takes one sample; `Break` ends the run. O(1).
    fn take(&mut self, sample: &MonitorSample) -> ControlFlow<()>;
}

impl<F: FnMut(&MonitorSample) -> ControlFlow<()>> SampleSink for F {
    #[inline(always)]
    fn take(&mut self, sample: &MonitorSample) -> ControlFlow<()> {
        self(sample)
    }
}

/// Running state of one simulation. Plain data, a few dozen bytes.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MonitorState {
    pub motor_angle: f32,
    /// Motor angle one period earlier (what the shape functions see).
    pub previous_motor_angle: f32,
    pub motor_speed: f32,
    /// True user-shaft angle \[rad\] (the aerodynamic load's zero is 0).
    pub user_angle: f32,
    pub user_speed: f32,
    /// Position-transducer offset \[rad\], constant over a run: the controller and the
    /// recorded samples see `user_angle + user_offset`.
    pub user_offset: f32,
    pub current: f32,
    pub position_integral: f32,
    pub previous_error: f32,
    pub speed_integral: f32,
    /// Phase currents measured at the standstill segment's first fitted frame \[A\] (its first
    /// step starts there; the model holds them through the settle).
    pub start_currents: [f32; 3],
}

impl MonitorState {
    /// At rest, with the shafts where the measured test began. The gear starts relaxed: the
    /// surface as near its load's rest (0) as the play allows, which splits the measured
    /// user angle into a true angle and the transducer's offset. O(1).
    fn at_rest(
        start: ShaftAngles,
        f: &FaultedConstants,
        inv_gear_ratio: f32,
        encoder_offset: f32,
    ) -> Self {
        let motor_at_user = (start.motor - encoder_offset) * inv_gear_ratio;
        let user_angle = clamp(
            0.0,
            motor_at_user - f.half_backlash,
            motor_at_user + f.half_backlash,
        );
        Self {
            motor_angle: start.motor,
            previous_motor_angle: start.motor,
            user_angle,
            user_offset: start.user - user_angle,
            // The command starts at 0: no derivative kick on the first step.
            previous_error: -start.user,
            start_currents: start.currents,
            ..Self::default()
        }
    }
}

/// Quantities that depend on the fault vector, computed once per run.
#[derive(Clone, Copy, Debug)]
struct FaultedConstants {
    kp: f32,
    static_friction_impulse: f32,
    dynamic_friction_impulse: f32,
    half_backlash: f32,
    /// Calibrated two-phase resistance [Ω] per commutation sector: the resistance shape of
    /// eq. (1) (mean healthy fraction of the two conducting phases) times the nominal value.
    sector_resistance: [f32; 6],
    /// Calibrated torque/back-EMF constant [N·m/A] over one electrical turn in
    /// [`GAIN_BINS`] bins (eight per sector, bin 0 starting at θ_e = −30°): the nominal value
    /// times the mean over the two conducting phases of healthy fraction × air-gap coupling
    /// factor ([`torque_gain_bins`]).
    bin_torque_constant: [f32; GAIN_BINS],
    /// Standstill pair circuits A→B, B→C, C→A: `i ← decay·i + gain·V` per period (the
    /// exact step response of R_pair, L_pair).
    pair_decay: [f32; 3],
    pair_gain: [f32; 3],
}

/// The monitor model's settings: parameters, calibration and test command, with the
/// per-step constants derived once.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MonitorModel {
    params: ActuatorParams,
    command: ChirpCommand,
    dt: f32,
    inv_dt: f32,
    resistance: f32,
    l_over_dt: f32,
    dt_over_l: f32,
    torque_constant: f32,
    inv_gear_ratio: f32,
    dt_over_motor_inertia: f32,
    dt_over_user_inertia: f32,
    friction_scale: f32,
    user_damping: f32,
    /// The motor speed kept over one step against the grease's drag above the calibration
    /// day's (`1 − dt·D/J_m`; exactly 1 without one, so the model plays the same bits).
    motor_drag_keep: f32,
    /// One healthy phase's R [Ω] and L [H] in the standstill segment's pair circuits: the
    /// calibrated installed circuit, R at the test's winding temperature.
    pair_phase_resistance: f32,
    pair_phase_inductance: f32,
    /// The standstill segment played before the chirp, if the test has one.
    standstill: Option<StandstillSegment>,
    /// The controller's duty delay as a share of the period ([`Calibration::delay_share`]).
    delay_share: f32,
    /// The lowest healthy friction the solver may read, against the day's estimate
    /// ([`Self::with_friction_floor`]; 1: none below it).
    friction_floor: f32,
    /// One weak magnet on the rotor beside the fault vector's uniform loss
    /// ([`Self::with_magnets`]; [`WeakMagnet::NONE`]: even magnets).
    magnets: WeakMagnet,
}

impl MonitorModel {
    /// A monitor model of `params` corrected by `calibration` (electrical scales, friction
    /// scale, user-shaft damping), driven by the preflight chirp.
    pub fn new(params: ActuatorParams, calibration: &Calibration) -> Self {
        let dt = params.control_period;
        let inductance = 2.0 * params.phase_inductance * calibration.inductance_scale;
        Self {
            params,
            command: ChirpCommand::PREFLIGHT,
            dt,
            inv_dt: 1.0 / dt,
            resistance: 2.0 * params.phase_resistance * calibration.resistance_scale,
            l_over_dt: inductance / dt,
            dt_over_l: dt / inductance,
            torque_constant: params.torque_constant() * calibration.back_emf_scale,
            inv_gear_ratio: 1.0 / params.gear_ratio,
            dt_over_motor_inertia: dt / params.motor_inertia,
            dt_over_user_inertia: dt / params.user_inertia,
            friction_scale: calibration.friction_scale,
            user_damping: calibration.damping,
            motor_drag_keep: 1.0,
            pair_phase_resistance: params.phase_resistance * calibration.pair_resistance_scale,
            pair_phase_inductance: params.phase_inductance * calibration.pair_inductance_scale,
            standstill: None,
            delay_share: calibration.delay_share(params.control_period),
            friction_floor: 1.0,
            magnets: WeakMagnet::NONE,
        }
    }

    /// The same model on the day `conditions` describes: copper resistance (chirp and pair
    /// circuits) at the estimated winding temperature, torque constant at its flux, healthy
    /// friction at the measured temperature or the grease's state, and the grease's drag on
    /// the motor shaft above the calibration day's. The calibration's own day changes
    /// nothing.
    pub fn with_conditions(mut self, conditions: &TestConditions) -> Self {
        self.resistance *= conditions.copper_scale;
        self.pair_phase_resistance *= conditions.pair_resistance_ratio;
        self.torque_constant *= conditions.flux_scale;
        self.friction_scale *= conditions.friction_scale;
        if conditions.drag_rise != 0.0 {
            // The chirp's drag in equivalent current per radian of a block's travel, as a
            // torque per motor speed [N·m·s/rad].
            let drag = self.torque_constant
                * conditions.drag_rise
                * crate::physics::grease::BLOCK as f32
                * self.dt;
            self.motor_drag_keep = clamp(1.0 - self.dt_over_motor_inertia * drag, 0.0, 2.0);
        }
        self
    }

    /// The same model with one weak magnet on its rotor ([`WeakMagnet`]; the fault vector's
    /// uniform loss still scales every pole): each step's gain times the conducting pair's
    /// share at the previous sample's mechanical angle. With [`WeakMagnet::NONE`] the model
    /// plays the same bits as without. O(1); a weak magnet costs each step two phase shares.
    #[must_use]
    pub fn with_magnets(mut self, magnets: WeakMagnet) -> Self {
        self.magnets = magnets;
        self
    }

    /// The weak magnet this model plays ([`WeakMagnet::NONE`]: even magnets).
    pub fn magnets(&self) -> WeakMagnet {
        self.magnets
    }

    /// The same model on a drive that slews to each step of its current reference at the
    /// bus's voltage (hysteresis current control), under reference steps of mean square
    /// `power` [A² per control period]: a step `Δ` is reached after `L·|Δ|/(V ∓ E)`, later
    /// against the back-EMF `E` than with it, so the period's mean current falls short of the
    /// new reference by `Δ·t_s/(2T)` and, over zero-mean steps, by
    /// `(L/2T)·power·E/(V² − E²)` in the direction of motion. To first order in `E/V` that
    /// is a viscous drag `k_t²·(L/2T)·power/V²` on the motor, played as the grease's drag is
    /// (no work per step; `power` 0 plays the same bits). What a noisy current reference
    /// does to the current the loops must draw (docs/prognostics.md, "What the lean is");
    /// a study's option: the identification does not set it. O(1).
    #[must_use]
    pub fn with_reference_steps(mut self, power: f32) -> Self {
        let v = self.params.dc_bus_voltage;
        // No bus to slew against (a record that gives none): no shortfall, no NaN drag.
        if power > 0.0 && v > 0.0 {
            let drag = self.torque_constant * self.torque_constant * 0.5 * self.l_over_dt * power
                / (v * v);
            self.motor_drag_keep = clamp(
                self.motor_drag_keep - self.dt_over_motor_inertia * drag,
                0.0,
                2.0,
            );
        }
        self
    }

    /// The same model with the day's healthy friction a nuisance the solver estimates with
    /// the faults, down to `floor` (0.05 … 1) times the day's estimate: the solver's first
    /// component then spans the friction torque `floor … 3` times the day's healthy one
    /// (`floor + (3 − floor)·k1'`), the healthy point at `k1' = (1 − floor)/(3 − floor)`;
    /// [`Self::reading`] says what a solver's vector reads as. A floor of 1 is the fault
    /// vector itself, bit for bit. O(1).
    #[must_use]
    pub fn with_friction_floor(mut self, floor: f32) -> Self {
        self.friction_floor = if floor.is_finite() {
            clamp(floor, 0.05, 1.0)
        } else {
            1.0
        };
        self
    }

    /// [`Self::with_friction_floor`]'s floor.
    pub fn friction_floor(&self) -> f32 {
        self.friction_floor
    }

    /// The fault vector the solver's vector `k` reads as: its friction torque's excess over
    /// the day's healthy friction as k1 (`max(0, (floor + (3 − floor)·k1' − 1)/2)`), the rest
    /// as it is. The identity without a floor. O(1).
    pub fn reading(&self, k: &FaultVector) -> FaultVector {
        if self.friction_floor == 1.0 {
            return *k;
        }
        let mut a = *k.as_array();
        let l = self.friction_floor;
        a[0] = (0.5 * (l + (3.0 - l) * k.friction() - 1.0)).max(0.0);
        FaultVector::saturating(a)
    }

    /// The solver's vector that reads as `k` ([`Self::reading`]'s inverse where k1 > 0; a
    /// healthy friction at the day's estimate). O(1).
    pub fn solver_vector(&self, k: &FaultVector) -> FaultVector {
        if self.friction_floor == 1.0 {
            return *k;
        }
        let mut a = *k.as_array();
        let l = self.friction_floor;
        a[0] = (1.0 + 2.0 * k.friction() - l) / (3.0 - l);
        FaultVector::saturating(a)
    }

    /// The healthy friction the solver's vector `k` reads, against the day's estimate: 1
    /// where it reads a friction fault or none below the estimate. O(1).
    pub fn healthy_friction_read(&self, k: &FaultVector) -> f32 {
        let l = self.friction_floor;
        (l + (3.0 - l) * k.friction()).min(1.0)
    }

    /// How much a solver's k1' moves the reading's k1 (`(3 − floor)/2`; 1 without a floor).
    pub fn reading_scale(&self) -> f32 {
        0.5 * (3.0 - self.friction_floor)
    }

    /// The same model driven by another command.
    pub fn with_command(mut self, command: ChirpCommand) -> Self {
        self.command = command;
        self
    }

    /// The same model playing a whole test design: its standstill segment, if any, then its
    /// chirp. (The motion segment of the identifiability study is not played.)
    pub fn with_test(mut self, test: &PreflightTest) -> Self {
        self.command = test.chirp;
        self.standstill = test.standstill;
        self
    }

    /// The test this model plays.
    pub fn test(&self) -> PreflightTest {
        PreflightTest {
            standstill: self.standstill,
            motion: None,
            chirp: self.command,
        }
    }

    /// Samples of the standstill segment before the chirp (0 without one).
    pub fn lead_samples(&self) -> usize {
        self.standstill.map_or(0, |s| s.samples())
    }

    pub fn params(&self) -> &ActuatorParams {
        &self.params
    }

    pub fn command(&self) -> &ChirpCommand {
        &self.command
    }

    /// The chirp at this model's control period, as the model plays it. O(1).
    pub fn sampler(&self) -> ChirpSampler {
        self.command.sampler(self.dt)
    }

    /// Number of samples in the whole test: the standstill segment and the chirp.
    pub fn test_samples(&self) -> usize {
        let n = self.command.duration * self.inv_dt + 0.5;
        let chirp = if n.is_finite() && n > 0.0 {
            n as usize
        } else {
            0
        };
        self.lead_samples() + chirp
    }

    fn faulted(&self, k: &FaultVector) -> FaultedConstants {
        let fx = self.fault_effects(k);
        let mut pairs = [(0.0, 0.0); 3];
        if self.standstill.is_some() {
            for (j, slot) in pairs.iter_mut().enumerate() {
                *slot = self.pair_constants(&fx, j);
            }
        }
        let mut gains = [1.0f32; GAIN_BINS];
        torque_gain_bins(&self.params, &fx, &mut gains, 0..GAIN_BINS);
        self.faulted_from(&fx, &pairs, &gains)
    }

    /// [`faulted`](Self::faulted) in steps, the same pieces: the future pauses after each
    /// standstill pair's constants (a soft-f64 exponential each on the Cortex-M4F) and after
    /// every [`GAIN_BINS_PER_POLL`] bins of the torque table. The same bits.
    async fn faulted_stepwise(&self, k: &FaultVector) -> FaultedConstants {
        let fx = self.fault_effects(k);
        // A test without a standstill segment (a window's) never drives a pair: its
        // constants stay zero (three soft-f64 exponentials saved per run start).
        let mut pairs = [(0.0, 0.0); 3];
        if self.standstill.is_some() {
            for (j, slot) in pairs.iter_mut().enumerate() {
                *slot = self.pair_constants(&fx, j);
                pause().await;
            }
        }
        let mut gains = [1.0f32; GAIN_BINS];
        let mut first = 0;
        while first < GAIN_BINS {
            let end = (first + GAIN_BINS_PER_POLL).min(GAIN_BINS);
            torque_gain_bins(&self.params, &fx, &mut gains, first..end);
            pause().await;
            first = end;
        }
        self.faulted_from(&fx, &pairs, &gains)
    }

    /// What fault vector `k` does to the model: its effects, with the friction floor.
    fn fault_effects(&self, k: &FaultVector) -> FaultEffects {
        let mut fx = k.effects();
        if self.friction_floor != 1.0 {
            fx.friction_scale = self.friction_floor + (3.0 - self.friction_floor) * k.friction();
        }
        fx
    }

    /// Standstill pair `j`'s decay and gain per step under the healthy turns of `fx`.
    #[inline(never)]
    fn pair_constants(&self, fx: &FaultEffects, j: usize) -> (f32, f32) {
        // Standstill pair y → z: R = R_ph·(N_y + N_z), L = L_ph·(N_y² + N_z²).
        let signs = PAIR_SIGNS.get(j).copied().unwrap_or([0; 3]);
        let (mut n1, mut n2) = (0.0f32, 0.0f32);
        for (&sign, &n) in signs.iter().zip(&fx.healthy_turns) {
            if sign != 0 {
                n1 += n;
                n2 += n * n;
            }
        }
        let r = f64::from(self.pair_phase_resistance * n1);
        let l = f64::from(self.pair_phase_inductance * n2);
        let decay = exp64(-f64::from(self.dt) * r / l);
        (decay as f32, ((1.0 - decay) / r) as f32)
    }

    /// The run's constants from the effects `fx`, the standstill pairs' `pairs` and the
    /// torque table's relative `gains`.
    #[inline(never)]
    fn faulted_from(
        &self,
        fx: &FaultEffects,
        pairs: &[(f32, f32); 3],
        gains: &[f32; GAIN_BINS],
    ) -> FaultedConstants {
        let p = &self.params;
        let [na, nb, nc] = fx.healthy_turns;
        FaultedConstants {
            kp: p.position_kp * fx.kp_scale,
            static_friction_impulse: self.dt_over_motor_inertia
                * p.static_friction
                * self.friction_scale
                * fx.friction_scale,
            dynamic_friction_impulse: self.dt_over_motor_inertia
                * p.dynamic_friction
                * self.friction_scale
                * fx.friction_scale,
            half_backlash: 0.5 * p.nominal_backlash * fx.backlash_scale,
            // Sector j (mod 3) has phase j floating: the other two conduct.
            sector_resistance: [nb + nc, nc + na, na + nb, nb + nc, nc + na, na + nb]
                .map(|n| self.resistance * (0.5 * n)),
            // The magnets' irreversible flux loss scales the torque constant (and the back-EMF)
            // in every bin; the standstill pairs above do not see it: a short scales L by N²,
            // a weak magnet does not.
            bin_torque_constant: gains.map(|g| self.torque_constant * fx.flux_scale * g),
            pair_decay: pairs.map(|(d, _)| d),
            pair_gain: pairs.map(|(_, g)| g),
        }
    }

    /// Simulates `samples` steps from rest for fault vector `k`, handing each sample to `sink`.
    /// O(`samples`) work, no allocation.
    pub fn run(&self, k: &FaultVector, samples: usize, sink: impl FnMut(&MonitorSample)) {
        self.run_from(k, ShaftAngles::ZERO, samples, sink);
    }

    /// As [`run`](Self::run), from rest with the shafts at `start` (the measured angles at
    /// the first sample): the controller's integrators empty, the drive unpowered.
    pub fn run_from(
        &self,
        k: &FaultVector,
        start: ShaftAngles,
        samples: usize,
        mut sink: impl FnMut(&MonitorSample),
    ) {
        self.run_with(k, start, samples, &self.sampler(), |s: &MonitorSample| {
            sink(s);
            ControlFlow::Continue(())
        });
    }

    /// The general run: at most `samples` steps from rest at `start`, reading the command
    /// from `command` (the model's own chirp, or a [`CommandTable`](crate::test::command::CommandTable)
    /// of it for the same bits with less work), until `sink` breaks. Returns the number of
    /// steps simulated. O(`samples`) work, no allocation.
    pub fn run_with(
        &self,
        k: &FaultVector,
        start: ShaftAngles,
        samples: usize,
        command: &impl CommandSource,
        mut sink: impl SampleSink,
    ) -> usize {
        let f = self.faulted(k);
        let mut state =
            MonitorState::at_rest(start, &f, self.inv_gear_ratio, self.params.encoder_offset);
        let lead = match self.standstill {
            Some(segment) => match self.run_standstill(&f, &segment, &state, samples, &mut sink) {
                ControlFlow::Break(done) => return done,
                ControlFlow::Continue(lead) => lead,
            },
            None => 0,
        };
        for i in 0..samples.saturating_sub(lead) {
            let time = i as f32 * self.dt;
            let sample = self.step(&f, &mut state, time, command.position_at(i));
            if sink.take(&sample).is_break() {
                return lead + i + 1;
            }
        }
        samples
    }

    /// A run advanced one sample at a time ([`MonitorRun::next_sample`]), for callers that
    /// step several runs in lockstep (the identification's uncertainty). The same bits as
    /// [`run_with`](Self::run_with) from the same start. O(1) to create.
    pub fn start_run(&self, k: &FaultVector, start: ShaftAngles) -> MonitorRun {
        let f = self.faulted(k);
        let state =
            MonitorState::at_rest(start, &f, self.inv_gear_ratio, self.params.encoder_offset);
        let pair_current = pair_current_after_switch(state.start_currents, 0);
        MonitorRun {
            f,
            state,
            index: 0,
            pair: 0,
            pair_current,
        }
    }

    /// The same model with the surface's load a spring of `stiffness` [N·m/rad] (a window of
    /// flight: the actuator's spring plus the hinge moment's stiffness at the window's
    /// dynamic pressure, estimated by [`crate::flight::window`]).
    pub fn with_load_stiffness(mut self, stiffness: f32) -> Self {
        self.params.aero_stiffness = stiffness;
        self
    }

    /// The surface's spring and the rigging offset this model steps with: what
    /// [`start_loaded_run`](Self::start_loaded_run) sets for its run. O(1).
    pub fn rigging(&self) -> RunRigging {
        RunRigging {
            load_stiffness: self.params.aero_stiffness,
            encoder_offset: self.params.encoder_offset,
        }
    }

    /// Sets the model's rigging: runs stepped in lockstep share one model and set each
    /// run's rigging before its step (a few bytes per run instead of a model). O(1).
    pub fn rig(&mut self, rigging: RunRigging) {
        self.params.aero_stiffness = rigging.load_stiffness;
        self.params.encoder_offset = rigging.encoder_offset;
    }

    /// The calibrated torque constant on the test's day [N·m/A] (the healthy motor's).
    pub fn torque_constant(&self) -> f32 {
        self.torque_constant
    }

    /// A run that starts in equilibrium under a moment `moment` [N·m] on the surface, with
    /// the shafts at `start` and the first command `command` \[rad\]: the surface where the
    /// spring gives the moment, the gear pressed against the flank that carries it and
    /// deflected by it, the motor current that holds it in the speed loop's integrator, the
    /// position loop's integrator where it asks no speed. The model this run must be stepped
    /// with is returned beside it: its rigging offset is moved so that the measured motor
    /// angle sits at that gear deflection (the fault vector's backlash sets the flank), which
    /// keeps the measured rotor angle for the drive's shape functions. A window of flight
    /// starts so ([`crate::flight::window`]); the preflight starts at rest ([`start_run`]). O(1).
    ///
    /// [`start_run`]: Self::start_run
    pub fn start_loaded_run(
        &self,
        k: &FaultVector,
        start: ShaftAngles,
        moment: f32,
        command: f32,
    ) -> (MonitorModel, MonitorRun) {
        run_to_end(self.start_loaded_run_stepwise(k, start, moment, command))
    }

    /// [`start_loaded_run`](Self::start_loaded_run) in steps: the fault's constants
    /// stepwise, then the start in one poll (O(1)). The same bits.
    pub async fn start_loaded_run_stepwise(
        &self,
        k: &FaultVector,
        start: ShaftAngles,
        moment: f32,
        command: f32,
    ) -> (MonitorModel, MonitorRun) {
        let f = self.faulted_stepwise(k).await;
        let p = &self.params;
        let surface = if p.aero_stiffness > 0.0 {
            moment / p.aero_stiffness
        } else {
            0.0
        };
        let flank = if moment > 0.0 {
            f.half_backlash
        } else if moment < 0.0 {
            -f.half_backlash
        } else {
            0.0
        };
        let deflection = flank
            + if p.gear_stiffness > 0.0 {
                moment / p.gear_stiffness
            } else {
                0.0
            };
        let mut model = *self;
        model.params.encoder_offset = start.motor - p.gear_ratio * (surface + deflection);
        let kt = f
            .bin_torque_constant
            .get(gain_bin(p.pole_pairs * start.motor))
            .copied()
            .unwrap_or(self.torque_constant);
        let current = if kt != 0.0 {
            moment * self.inv_gear_ratio / kt
        } else {
            0.0
        };
        let error = command - start.user;
        let state = MonitorState {
            motor_angle: start.motor,
            previous_motor_angle: start.motor,
            user_angle: surface,
            user_offset: start.user - surface,
            current,
            previous_error: error,
            position_integral: if p.position_ki != 0.0 {
                -f.kp * error / p.position_ki
            } else {
                0.0
            },
            speed_integral: if p.speed_ki != 0.0 {
                current / p.speed_ki
            } else {
                0.0
            },
            ..MonitorState::default()
        };
        let run = MonitorRun {
            f,
            state,
            index: 0,
            pair: 0,
            pair_current: 0.0,
        };
        (model, run)
    }

    /// [`start_run`](Self::start_run) into an existing run, in place. O(1).
    #[inline(never)]
    pub fn restart_run(&self, run: &mut MonitorRun, k: &FaultVector, start: ShaftAngles) {
        run.f = self.faulted(k);
        run.state = MonitorState::at_rest(
            start,
            &run.f,
            self.inv_gear_ratio,
            self.params.encoder_offset,
        );
        run.index = 0;
        run.pair = 0;
        run.pair_current = pair_current_after_switch(run.state.start_currents, 0);
    }

    /// The standstill segment: each pair an R–L circuit driven by the segment's voltage, the
    /// shaft held by breakaway friction (the segment's torque stays below it), the position
    /// loop suspended. When the driven pair changes, the phase left open drops its current
    /// through its diodes and the other two share what it carried. At most `samples` steps,
    /// O(1) each; breaks with the number of samples produced, or continues with the
    /// segment's length.
    fn run_standstill(
        &self,
        f: &FaultedConstants,
        segment: &StandstillSegment,
        state: &MonitorState,
        samples: usize,
        sink: &mut impl SampleSink,
    ) -> ControlFlow<usize, usize> {
        let lead = segment.samples();
        let mut pair = 0usize;
        let mut current = pair_current_after_switch(state.start_currents, pair);
        // The previous period's volts, which hold for `delay_share` of each period.
        let mut commanded = 0.0f32;
        // Every sample the drives give is inside the segment: fitted is past the settle.
        let settle = usize::from(segment.settle_samples);
        let mut drives = segment.drives();
        for i in 0..lead.min(samples) {
            let Some(drive) = drives.next() else {
                break;
            };
            let fitted = i >= settle;
            if drive.pair != pair {
                let signs = PAIR_SIGNS.get(pair).copied().unwrap_or([0; 3]);
                current =
                    pair_current_after_switch(signs.map(|s| f32::from(s) * current), drive.pair);
                pair = drive.pair;
            }
            let sample = MonitorSample {
                time: (i as f32 - lead as f32) * self.dt,
                command: 0.0,
                current,
                current_ref: 0.0,
                motor_angle: state.motor_angle,
                user_angle: state.user_angle + state.user_offset,
            };
            if sink.take(&sample).is_break() {
                return ControlFlow::Break(i + 1);
            }
            // Held through the settle (not fitted: the rotor may still move, and its
            // back-EMF drives the shorted pair), then from the measured current on.
            let volts = drive.voltage(self.dt);
            if fitted {
                let decay = f.pair_decay.get(pair).copied().unwrap_or(0.0);
                let gain = f.pair_gain.get(pair).copied().unwrap_or(0.0);
                current = decay * current + gain * (volts + self.delay_share * (commanded - volts));
            }
            commanded = volts;
        }
        if samples <= lead {
            return ControlFlow::Break(samples);
        }
        ControlFlow::Continue(lead)
    }

    /// Simulates `out.len()` samples and writes the equivalent current \[A\] into `out`.
    pub fn simulate(&self, k: &FaultVector, out: &mut [f32]) {
        let mut slots = out.iter_mut();
        self.run(k, slots.len(), |s| {
            if let Some(slot) = slots.next() {
                *slot = s.current;
            }
        });
    }

    /// One control period. O(1).
    #[inline(always)]
    fn step(
        &self,
        f: &FaultedConstants,
        s: &mut MonitorState,
        time: f32,
        command: f32,
    ) -> MonitorSample {
        let p = &self.params;
        let dt = self.dt;

        // 1. ACE controller.
        let error = command - (s.user_angle + s.user_offset);
        s.position_integral += error * dt;
        let error_rate = (error - s.previous_error) * self.inv_dt;
        s.previous_error = error;
        let speed_ref =
            f.kp * error + p.position_ki * s.position_integral + p.position_kd * error_rate;
        let speed_ref = clamp(speed_ref, -p.max_speed, p.max_speed);
        let speed_error = speed_ref - s.motor_speed;
        let integral = s.speed_integral + speed_error * dt;
        let unsaturated = p.speed_kp * speed_error + p.speed_ki * integral;
        let current_ref = clamp(unsaturated, -p.max_current, p.max_current);
        // Conditional integration: hold the integrator while it would push further into
        // saturation.
        if unsaturated == current_ref || (unsaturated > current_ref) != (speed_error > 0.0) {
            s.speed_integral = integral;
        }

        // 2. Single-phase equivalent drive with the electrical shape functions, evaluated at
        //    the rotor angle of the previous sample: the drive commutates from the last
        //    position it sampled.
        //    One angle reduction serves both: the bin, and its sector (eight bins each).
        let bin = gain_bin(p.pole_pairs * s.previous_motor_angle);
        let r = f
            .sector_resistance
            .get(bin / BINS_PER_SECTOR)
            .copied()
            .unwrap_or(self.resistance);
        let kt = f
            .bin_torque_constant
            .get(bin)
            .copied()
            .unwrap_or(self.torque_constant);
        // One weak magnet: the pair's share over the mechanical angle (even magnets: none,
        // the same bits).
        let kt = if self.magnets.is_none() {
            kt
        } else {
            kt * self
                .magnets
                .pair_factor(p, s.previous_motor_angle, (bin / BINS_PER_SECTOR) % 3)
        };
        let back_emf = kt * s.motor_speed;
        let sampled = (s.current, s.motor_angle, s.user_angle + s.user_offset);
        let voltage = r * s.current + back_emf + self.l_over_dt * (current_ref - s.current);
        let voltage = clamp(voltage, -p.dc_bus_voltage, p.dc_bus_voltage);
        s.current += self.dt_over_l * (voltage - r * s.current - back_emf);
        let motor_torque = kt * s.current;

        // 3. Mechanics: dead-zone compliant gear train, stick-slip friction, aero load.
        // The gear sees the motor angle from the surface's zero (the rigging offset).
        let deflection = (s.motor_angle - p.encoder_offset) * self.inv_gear_ratio - s.user_angle;
        let engaged = deflection - clamp(deflection, -f.half_backlash, f.half_backlash);
        // A contact pushes, never pulls: damping cannot reverse the spring's torque. A contact
        // that closed during this step damps only over its share of the step (its
        // penetration over the rate it closes at): the impulse grows from 0 with the
        // penetration instead of a whole step's `c·v` at the first touch, so the test's
        // currents move smoothly with the play, as the continuous gear's do.
        let relative_speed = s.motor_speed * self.inv_gear_ratio - s.user_speed;
        let closing = abs(relative_speed);
        let penetration_rate = abs(engaged) * self.inv_dt;
        let share = if penetration_rate >= closing {
            1.0
        } else {
            penetration_rate / closing
        };
        let contact = p.gear_stiffness * engaged + p.gear_damping * relative_speed * share;
        let gear_torque = if engaged > 0.0 && contact > 0.0 || engaged < 0.0 && contact < 0.0 {
            contact
        } else {
            0.0
        };
        let free_speed = s.motor_speed * self.motor_drag_keep
            + self.dt_over_motor_inertia * (motor_torque - gear_torque * self.inv_gear_ratio);
        let friction_impulse = if abs(s.motor_speed) < p.stick_speed {
            f.static_friction_impulse
        } else {
            f.dynamic_friction_impulse
        };
        s.motor_speed = if abs(free_speed) <= friction_impulse {
            0.0
        } else if free_speed > 0.0 {
            free_speed - friction_impulse
        } else {
            free_speed + friction_impulse
        };
        s.previous_motor_angle = s.motor_angle;
        s.motor_angle += s.motor_speed * dt;
        s.user_speed += self.dt_over_user_inertia
            * (gear_torque - p.aero_stiffness * s.user_angle - self.user_damping * s.user_speed);
        s.user_angle += s.user_speed * dt;

        MonitorSample {
            time,
            command,
            current: sampled.0,
            current_ref,
            motor_angle: sampled.1,
            user_angle: sampled.2,
        }
    }
}

/// What a loaded start ([`MonitorModel::start_loaded_run`]) changes in the model its run is
/// stepped with: the surface's spring [N·m/rad] and the rigging offset \[rad\].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunRigging {
    pub load_stiffness: f32,
    pub encoder_offset: f32,
}

/// One monitor-model run in progress (see [`MonitorModel::start_run`]): its fault-dependent
/// constants and state, ≈ 0.3 kB; the model's settings are passed to each step.
#[derive(Clone, Debug)]
pub struct MonitorRun {
    f: FaultedConstants,
    state: MonitorState,
    /// Samples produced so far.
    index: usize,
    /// Standstill pair driven at the previous sample, and its current [A].
    pair: usize,
    pair_current: f32,
}

impl MonitorRun {
    /// A run with every field zero, to be restarted ([`MonitorModel::restart_run`]) before
    /// use: a `static` holding it lives in `.bss`, built in place. Stepping it unrestarted
    /// gives zeros, not a panic.
    pub const IDLE: Self = Self {
        f: FaultedConstants {
            kp: 0.0,
            static_friction_impulse: 0.0,
            dynamic_friction_impulse: 0.0,
            half_backlash: 0.0,
            sector_resistance: [0.0; 6],
            bin_torque_constant: [0.0; GAIN_BINS],
            pair_decay: [0.0; 3],
            pair_gain: [0.0; 3],
        },
        state: MonitorState {
            motor_angle: 0.0,
            previous_motor_angle: 0.0,
            motor_speed: 0.0,
            user_angle: 0.0,
            user_speed: 0.0,
            user_offset: 0.0,
            current: 0.0,
            position_integral: 0.0,
            previous_error: 0.0,
            speed_integral: 0.0,
            start_currents: [0.0; 3],
        },
        index: 0,
        pair: 0,
        pair_current: 0.0,
    };

    /// Index of the next sample and, during the chirp, the index into the command (`None`
    /// during the standstill segment): what the caller reads the command at.
    pub fn next_command_index(&self, m: &MonitorModel) -> Option<usize> {
        self.index.checked_sub(m.lead_samples())
    }

    /// Applies a moment `moment` [N·m] on the surface (positive along the positive angle)
    /// for the coming step of model `m`: a load the model's spring does not play (a window
    /// of flight's slow hinge-moment change). O(1).
    pub fn push_surface(&mut self, m: &MonitorModel, moment: f32) {
        self.state.user_speed += m.dt_over_user_inertia * moment;
    }

    /// This run's steps without a standstill segment (a window's: `m.lead_samples()` is
    /// 0), its state held by value in `body`'s [`RunSteps`] — a caller's loop keeps it in
    /// registers, not behind this run's reference — and written back when `body` returns.
    /// O(1) beyond `body`.
    #[inline(always)]
    pub fn steps<R>(&mut self, body: impl FnOnce(&mut RunSteps<'_>) -> R) -> R {
        let mut steps = RunSteps {
            f: &self.f,
            state: self.state,
            index: self.index,
        };
        let out = body(&mut steps);
        let (state, index) = (steps.state, steps.index);
        self.state = state;
        self.index = index;
        out
    }

    /// The next sample of the test of model `m` (the one that started this run): the
    /// standstill segment's, then the chirp's with the commanded user angle `command` \[rad\]
    /// (ignored during the segment). O(1).
    pub fn next_sample(&mut self, m: &MonitorModel, command: f32) -> MonitorSample {
        let lead = m.lead_samples();
        let i = self.index;
        self.index = self.index.saturating_add(1);
        if let (Some(segment), true) = (m.standstill, i < lead) {
            let drive = segment.at(i).unwrap_or(PairDrive {
                pair: self.pair,
                volts: 0.0,
                frequency: 0.0,
                on_index: 0,
            });
            if drive.pair != self.pair {
                let signs = PAIR_SIGNS.get(self.pair).copied().unwrap_or([0; 3]);
                self.pair_current = pair_current_after_switch(
                    signs.map(|s| f32::from(s) * self.pair_current),
                    drive.pair,
                );
                self.pair = drive.pair;
            }
            let sample = MonitorSample {
                time: (i as f32 - lead as f32) * m.dt,
                command: 0.0,
                current: self.pair_current,
                current_ref: 0.0,
                motor_angle: self.state.motor_angle,
                user_angle: self.state.user_angle + self.state.user_offset,
            };
            // Held through the settle, as in `run_standstill`.
            if segment.fitted(i) {
                let decay = self.f.pair_decay.get(self.pair).copied().unwrap_or(0.0);
                let gain = self.f.pair_gain.get(self.pair).copied().unwrap_or(0.0);
                self.pair_current = decay * self.pair_current + gain * drive.voltage(m.dt);
            }
            return sample;
        }
        let j = i.saturating_sub(lead);
        let time = j as f32 * m.dt;
        m.step(&self.f, &mut self.state, time, command)
    }
}

/// A run's steps without a standstill segment, its state by value ([`MonitorRun::steps`]):
/// what a window's evaluation steps in its loop.
pub struct RunSteps<'r> {
    f: &'r FaultedConstants,
    state: MonitorState,
    index: usize,
}

impl RunSteps<'_> {
    /// The next sample, inlined into its caller's loop: the same bits as
    /// [`MonitorRun::next_sample`] on a run without a standstill segment. O(1).
    #[inline(always)]
    pub fn next_motion_sample(&mut self, m: &MonitorModel, command: f32) -> MonitorSample {
        let time = self.index as f32 * m.dt;
        self.index = self.index.saturating_add(1);
        m.step(self.f, &mut self.state, time, command)
    }

    /// As [`MonitorRun::push_surface`]. O(1).
    #[inline(always)]
    pub fn push_surface(&mut self, m: &MonitorModel, moment: f32) {
        self.state.user_speed += m.dt_over_user_inertia * moment;
    }

    /// Puts the surface where its sensor read it for the coming step: `measured` \[rad\] as
    /// the sensor reads it (the run's transducer offset taken off), moving at `speed`
    /// [rad/s]. The gear then carries what the motor's side and the measured surface make
    /// of it, whatever moment moved the surface. O(1).
    pub fn pin_surface(&mut self, measured: f32, speed: f32) {
        self.state.user_angle = measured - self.state.user_offset;
        self.state.user_speed = speed;
    }
}

/// The current of standstill pair `to` just after the drive switches to it with phase
/// currents `phases` [A]: the phase `to` leaves open drops to zero through its diodes and the
/// other two share what it carried (the three currents sum to zero). O(1).
fn pair_current_after_switch(mut phases: [f32; 3], to: usize) -> f32 {
    let Some(new) = PAIR_SIGNS.get(to) else {
        return 0.0;
    };
    let open = new.iter().position(|&s| s == 0).unwrap_or(0);
    let dropped = phases.get(open).copied().unwrap_or(0.0);
    for (x, slot) in phases.iter_mut().enumerate() {
        *slot = if x == open {
            0.0
        } else {
            *slot + 0.5 * dropped
        };
    }
    0.5 * new
        .iter()
        .zip(&phases)
        .map(|(&s, &i)| f32::from(s) * i)
        .sum::<f32>()
}

/// Bins of the torque-gain table a poll of [`MonitorModel::start_loaded_run_stepwise`]
/// fills (four cosines each).
pub const GAIN_BINS_PER_POLL: usize = 4;

/// Bins of the torque-gain table over one electrical turn (7.5° each).
pub const GAIN_BINS: usize = 48;
const BINS_PER_SECTOR: usize = GAIN_BINS / 6;

/// Bin `0..GAIN_BINS` of an electrical angle [rad] (any value; NaN maps to bin 0). Bin `b`
/// covers `θ_e ∈ (−30° + 7.5°·b, −30° + 7.5°·(b+1))` mod 360°, so that sector `j` is bins
/// `8j … 8j+7`, as in [`commutation_sector`](crate::test::conditioning::commutation_sector).
#[inline(always)]
fn gain_bin(theta_e: f32) -> usize {
    let x = theta_e * (GAIN_BINS as f32 / TAU) + 0.5 * BINS_PER_SECTOR as f32;
    // Branch-free floor: truncate, then step down where truncation rounded up (x < 0). `as
    // i32` saturates and maps NaN to 0: no panic for any input. The same value as
    // `floor(x) as i32` for every x.
    let t = x as i32;
    let floor = t.saturating_sub(i32::from(x < t as f32));
    floor.rem_euclid(GAIN_BINS as i32) as usize
}

/// The torque/back-EMF gain of the two conducting phases over one electrical turn.
///
/// Short circuit: a phase's coupling scales with its healthy turns N (eq. (1) extended to
/// the torque gain). Static eccentricity: the air gap at stator angle ψ is
/// g₀·(1 − Z·cos(ψ − ψ_min)), ψ_min at φ from the centre of phase A's coils; a phase's
/// coupling scales with the mean permeance 1/(1 − Z·cos(ψ − ψ_min)) at the two magnet
/// edges under its coils (two full-pitch coils side by side per phase, edges one pole pitch
/// apart), evaluated at each bin's centre. The edges under a coil repeat every pole pitch,
/// so one electrical turn holds the whole shape. Without eccentricity each bin is the
/// conducting pair's mean healthy fraction, eq. (1). O(GAIN_BINS) work per fault vector;
/// this call fills the table's `bins` (its other entries untouched).
#[inline(never)]
fn torque_gain_bins(
    p: &ActuatorParams,
    fx: &FaultEffects,
    table: &mut [f32; GAIN_BINS],
    bins: core::ops::Range<usize>,
) {
    let z = fx.eccentricity_z;
    let psi_min = p.winding_group_angle[0] + fx.eccentricity_phase;
    let pole_pairs = if p.pole_pairs >= 1.0 {
        p.pole_pairs
    } else {
        1.0
    };
    let pitch = core::f32::consts::PI / pole_pairs;
    let permeance = |psi: f32| {
        let d = 1.0 - z * cos(psi - psi_min);
        if d > 0.0 {
            1.0 / d
        } else {
            1.0
        }
    };
    let coupling = |phase: usize, theta_m: f32| -> f32 {
        let turns = fx.healthy_turns.get(phase).copied().unwrap_or(1.0);
        if z == 0.0 {
            return turns;
        }
        let group = p.winding_group_angle.get(phase).copied().unwrap_or(0.0);
        // First coil spans [group − pitch, group); the edge inside it, then the next one.
        let start = group - pitch;
        let offset = theta_m + 0.5 * pitch - start;
        let u = offset - pitch * floor(offset / pitch);
        let e1 = start + u;
        turns * 0.5 * (permeance(e1) + permeance(e1 + pitch))
    };
    for (b, slot) in table.iter_mut().enumerate().take(bins.end).skip(bins.start) {
        let theta_e = -TAU / 12.0 + (b as f32 + 0.5) * (TAU / GAIN_BINS as f32);
        let theta_m = theta_e / pole_pairs;
        let floating = (b / BINS_PER_SECTOR) % 3;
        let (y, z_phase) = ((floating + 1) % 3, (floating + 2) % 3);
        *slot = 0.5 * (coupling(y, theta_m) + coupling(z_phase, theta_m));
    }
}
