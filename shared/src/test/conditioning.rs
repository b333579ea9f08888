//! Signal conditioning: three phase currents + rotor angle → one filtered equivalent current.
//!
//! Units: amperes, radians (motor shaft; electrical angle θ_e = P·θ_m), hertz. One sample per
//! control period (10 kHz). Every call here is O(1) per sample; [`MeasuredCurrent::finish`] is
//! one O(N) pass.
//!
//! **Commutation convention** (shared by the monitor model and any model of the real drive):
//! 120° trapezoidal commutation in six 60° sectors, sector `j` covering
//! `θ_e ∈ ((2j−1)·30°, (2j+1)·30°)` modulo 360°. In each sector one phase floats and the other
//! two carry the same current in opposite directions; [`COMMUTATION_SIGNS`] gives, per sector,
//! the sign with which each phase (A, B, C) carries a positive-torque current. The floating
//! phase in sectors 0 and 3 is A, in 1 and 4 it is B, in 2 and 5 it is C — the sector layout of
//! the paper's short-circuit shape function, eq. (1).
//!
//! **Equivalent current**: `i_eq = ½ · Σ_x s_x(θ_e) · i_x`, the current of the two conducting
//! phases, signed so that positive means motoring torque in the positive direction. It is
//! continuous in sign through motion reversals (unlike |i| envelopes) and ignores the floating
//! phase (counting a commutating phase doubled the model mismatch in prototyping).

use fixed::types::{I16F16, I4F28};
use heapless::Vec;

use crate::base::math::{floor, tan};
use crate::physics::grease::{ChirpTorqueFit, GreaseError, GreaseReading};
use crate::test::test_design::PreflightTest;

/// Positive-torque current sign of phases A, B, C in each 60° commutation sector.
pub const COMMUTATION_SIGNS: [[i8; 3]; 6] = [
    [0, 1, -1],
    [1, 0, -1],
    [1, -1, 0],
    [0, -1, 1],
    [-1, 0, 1],
    [-1, 1, 0],
];

/// Commutation sector `0..6` of an electrical angle \[rad\] (any value; NaN maps to sector 0).
#[inline]
pub fn commutation_sector(theta_e: f32) -> usize {
    // Sector boundaries sit at odd multiples of 30°: shift by half a sector, then divide.
    let x = theta_e * (3.0 / core::f32::consts::PI) + 0.5;
    // `as i32` saturates and maps NaN to 0: no panic for any input.
    (floor(x) as i32).rem_euclid(6) as usize
}

/// Signs of the three phases in the sector of `theta_e`.
#[inline]
pub fn commutation_signs(theta_e: f32) -> [i8; 3] {
    match COMMUTATION_SIGNS.get(commutation_sector(theta_e)) {
        Some(s) => *s,
        None => [0; 3], // unreachable: the sector is reduced modulo 6
    }
}

/// One acquisition, in fixed point as the controller holds it: the three phase currents \[A\]
/// and the motor-shaft angle \[rad\], each `I16F16` (±32 768, resolution 15 µA / 15 µrad), and
/// the user-shaft angle \[rad\] from the position transducer, `I4F28` (±8, resolution 3.7 nrad).
/// An `I16F16` reading (a phase current \[A\], the motor-shaft angle \[rad\]) as `f32`: the bits
/// rounded to nearest by the integer conversion, then the exact power-of-two scale — the value
/// `fixed`'s `to_num::<f32>()` gives, without its generic helper in the firmware's flash.
pub fn i16f16_to_f32(x: I16F16) -> f32 {
    x.to_bits() as f32 * (1.0 / 65_536.0)
}

/// An `I4F28` reading (the user-shaft angle \[rad\]) as `f32`, as [`i16f16_to_f32`].
pub fn i4f28_to_f32(x: I4F28) -> f32 {
    x.to_bits() as f32 * (1.0 / 268_435_456.0)
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
// No defmt derive: `fixed` numbers do not implement `defmt::Format`.
pub struct AdcFrame {
    pub phase_currents: [I16F16; 3],
    pub motor_angle: I16F16,
    pub user_angle: I4F28,
    /// The bus and temperature readings latched with the frame, where the controller has
    /// them (a trace of version 3, the board's channels).
    pub conditions: Option<ConditionReading>,
}

/// The bus voltage and temperature the controller measured at one sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct ConditionReading {
    /// DC bus voltage \[V\].
    pub bus_voltage: I16F16,
    /// Temperature [°C].
    pub temperature: I16F16,
}

impl ConditionReading {
    /// Converts, saturating (NaN becomes 0, as [`AdcFrame::from_f32`] does).
    pub fn from_f64(bus_voltage: f64, temperature: f64) -> Self {
        let nan_to_zero = |x: f64| if x.is_nan() { 0.0 } else { x };
        Self {
            bus_voltage: I16F16::saturating_from_num(nan_to_zero(bus_voltage)),
            temperature: I16F16::saturating_from_num(nan_to_zero(temperature)),
        }
    }
}

impl AdcFrame {
    /// Builds a frame from floating-point values, saturating at the fixed-point range
    /// (NaN becomes 0 rather than a panic).
    pub fn from_f32(phase_currents: [f32; 3], motor_angle: f32, user_angle: f32) -> Self {
        let finite = |x: f32| if x.is_nan() { 0.0 } else { x };
        let convert = |x: f32| I16F16::saturating_from_num(finite(x));
        Self {
            phase_currents: phase_currents.map(convert),
            motor_angle: convert(motor_angle),
            user_angle: I4F28::saturating_from_num(finite(user_angle)),
            conditions: None,
        }
    }
}

/// The angles of the two shafts \[rad\] as the controller measures them: the motor shaft
/// (encoder) and the user shaft (position transducer, offset included). The monitor model
/// starts each test from the first sample's: where the rotor sits sets commutation and the
/// shape functions, and where the gear sits inside its play sets the first backlash crossing.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ShaftAngles {
    pub motor: f32,
    pub user: f32,
    /// Phase currents where a standstill segment's first fitted step starts, past its settle
    /// \[A\]: the first pair's filtered current as A = +i, B = −i (what the hold before the
    /// test and the rotor's motion during the settle left in the windings).
    pub currents: [f32; 3],
}

impl ShaftAngles {
    /// Both shafts at zero, no current (the monitor model's own traces start here).
    pub const ZERO: Self = Self {
        motor: 0.0,
        user: 0.0,
        currents: [0.0; 3],
    };
}

/// Sign-preserving equivalent current \[A\] of one sample (module docs).
#[inline]
pub fn equivalent_current(phase_currents: [f32; 3], theta_e: f32) -> f32 {
    let s = commutation_signs(theta_e);
    0.5 * (f32::from(s[0]) * phase_currents[0]
        + f32::from(s[1]) * phase_currents[1]
        + f32::from(s[2]) * phase_currents[2])
}

/// Why conditioning refused its input.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ConditioningError {
    /// Cutoff not inside `(0, sample_rate / 2)`, or a rate that is not finite and positive.
    InvalidCutoff,
    /// Fewer samples than the fitness needs.
    TooFewSamples { have: u32, need: u32 },
    /// A sample that is NaN or infinite (at this index).
    NotFinite { index: u32 },
    /// The buffer was used before [`MeasuredCurrent::finish`].
    NotFinished,
}

/// Second-order Butterworth low-pass (bilinear transform), the settings half.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LowPass {
    b0: f32,
    b1: f32,
    b2: f32,
    a1: f32,
    a2: f32,
}

/// Running state of a [`LowPass`] (transposed direct form II).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LowPassState {
    z1: f32,
    z2: f32,
}

impl LowPassState {
    /// At rest.
    pub const ZERO: Self = Self { z1: 0.0, z2: 0.0 };
}

impl LowPass {
    /// Every coefficient zero (the output is 0): the placeholder of a buffer built in static
    /// storage ([`MeasuredCurrent::ZEROED`]) until its filter is set.
    pub const ZERO: Self = Self {
        b0: 0.0,
        b1: 0.0,
        b2: 0.0,
        a1: 0.0,
        a2: 0.0,
    };

    /// Default cutoff of the equivalent-current filter \[Hz\]: well above the chirp and the
    /// electrical-angle signatures of the faults (≤ ~300 Hz during the test), well below the
    /// switching ripple.
    pub const DEFAULT_CUTOFF_HZ: f32 = 1000.0;

    /// Butterworth low-pass with the given cutoff and sample rate.
    pub fn butterworth(cutoff_hz: f32, sample_rate_hz: f32) -> Result<Self, ConditioningError> {
        let valid = sample_rate_hz.is_finite()
            && sample_rate_hz > 0.0
            && cutoff_hz.is_finite()
            && cutoff_hz > 0.0
            && cutoff_hz < 0.5 * sample_rate_hz;
        if !valid {
            return Err(ConditioningError::InvalidCutoff);
        }
        let k = tan(core::f32::consts::PI * cutoff_hz / sample_rate_hz);
        let sqrt2 = core::f32::consts::SQRT_2;
        let norm = 1.0 / (1.0 + sqrt2 * k + k * k);
        let b0 = k * k * norm;
        Ok(Self {
            b0,
            b1: 2.0 * b0,
            b2: b0,
            a1: 2.0 * (k * k - 1.0) * norm,
            a2: (1.0 - sqrt2 * k + k * k) * norm,
        })
    }

    /// The default filter at the control rate of `control_period` seconds.
    pub fn for_control_period(control_period: f32) -> Result<Self, ConditioningError> {
        Self::butterworth(Self::DEFAULT_CUTOFF_HZ, 1.0 / control_period)
    }

    /// Filters one sample (O(1)).
    #[inline(always)]
    pub fn apply(&self, state: &mut LowPassState, x: f32) -> f32 {
        let y = self.b0 * x + state.z1;
        state.z1 = self.b1 * x - self.a1 * y + state.z2;
        state.z2 = self.b2 * x - self.a2 * y;
        y
    }
}

/// Running sums of the controller's bus and temperature readings: exact (fixed-point bits
/// summed as integers), so the means have the same bits on every target. 20 bytes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ConditionSums {
    bus_bits: i64,
    temperature_bits: i64,
    count: u32,
}

impl ConditionSums {
    pub const ZERO: Self = Self {
        bus_bits: 0,
        temperature_bits: 0,
        count: 0,
    };

    /// Adds one reading (`I16F16` bits of the bus \[V\] and temperature [°C]). O(1).
    pub fn push(&mut self, bus_bits: i32, temperature_bits: i32) {
        self.bus_bits = self.bus_bits.saturating_add(i64::from(bus_bits));
        self.temperature_bits = self
            .temperature_bits
            .saturating_add(i64::from(temperature_bits));
        self.count = self.count.saturating_add(1);
    }

    fn mean(&self, bits: i64) -> Option<f32> {
        // In f32 (no 64-bit division on the controller): the same bits on every target.
        (self.count > 0).then(|| bits as f32 / (65_536.0 * self.count as f32))
    }

    /// Mean bus voltage over the test \[V\], if the test carried it.
    pub fn bus_voltage(&self) -> Option<f32> {
        self.mean(self.bus_bits)
    }

    /// Mean measured temperature over the test [°C], if the test carried it.
    pub fn temperature(&self) -> Option<f32> {
        self.mean(self.temperature_bits)
    }
}

/// Samples of each scan of [`MeasuredCurrent::finish_stepwise`] between two pauses (a few
/// instructions each).
pub const FINISH_SAMPLES_PER_POLL: usize = 64;

/// The conditioned measured current of one test, ready for the fitness: at most `N` filtered
/// equivalent-current samples \[A\] plus the derivative normalisation of eq. (3).
///
/// Filled sample by sample (`push_*` hands the sample back when full), then sealed with
/// [`finish`](Self::finish). Memory: `4·N` bytes plus a few words; no allocation.
#[derive(Clone, Debug)]
pub struct MeasuredCurrent<const N: usize> {
    filter: LowPass,
    filter_state: LowPassState,
    samples: Vec<f32, N>,
    /// Shaft angles at the first frame ([`ShaftAngles::ZERO`] when fed by
    /// [`push_equivalent`](Self::push_equivalent) only).
    initial_angles: ShaftAngles,
    /// The test the samples come from: during its standstill segment a frame's current is
    /// the driven pair's, not the commutated pair's.
    test: PreflightTest,
    /// `1 / κ`, κ = mean of the squared sample-to-sample difference; `None` until finished.
    inv_kappa: Option<f32>,
    /// The bus and temperature readings the frames carried.
    conditions: ConditionSums,
    /// The chirp's torque balance, fed its frames (the grease's drag and dry friction).
    torque_fit: ChirpTorqueFit,
    /// Lowest and highest motor-encoder reading over the standstill segment [I16F16 bits]:
    /// how far the rotor moved while the position loop was suspended.
    standstill_motor: [i32; 2],
}

impl<const N: usize> MeasuredCurrent<N> {
    /// Shortest trace the fitness accepts: 0.1 s at 10 kHz.
    pub const MIN_SAMPLES: usize = 1000;

    /// An empty buffer whose every byte is zero (filter [`LowPass::ZERO`], a zero-length
    /// test), so that a `static` holding it lives in `.bss` and is never built on the stack
    /// (22 kB): give it its filter and test with [`set_filter`](Self::set_filter) and
    /// [`clear_for`](Self::clear_for) before use.
    pub const ZEROED: Self = Self::for_test(
        LowPass::ZERO,
        PreflightTest {
            standstill: None,
            motion: None,
            chirp: crate::test::command::ChirpCommand {
                amplitude: 0.0,
                end_frequency: 0.0,
                duration: 0.0,
            },
        },
    );

    /// An empty buffer that conditions with `filter` the paper's test (the chirp alone).
    pub const fn new(filter: LowPass) -> Self {
        Self::for_test(filter, PreflightTest::PAPER)
    }

    /// An empty buffer that conditions with `filter` the frames of `test`.
    pub const fn for_test(filter: LowPass, test: PreflightTest) -> Self {
        Self {
            filter,
            filter_state: LowPassState { z1: 0.0, z2: 0.0 },
            samples: Vec::new(),
            initial_angles: ShaftAngles::ZERO,
            test,
            inv_kappa: None,
            conditions: ConditionSums::ZERO,
            torque_fit: ChirpTorqueFit::ZERO,
            standstill_motor: [0, 0],
        }
    }

    /// How far the motor turned over the standstill segment \[rad\] (0 without one): with the
    /// position loop suspended only a moment on the surface (or the rotor settling in the
    /// gear's play) moves it.
    pub fn standstill_travel(&self) -> f32 {
        let [lo, hi] = self.standstill_motor;
        hi.wrapping_sub(lo) as u32 as f32 * (1.0 / 65_536.0)
    }

    /// Sums of the bus and temperature readings the frames carried.
    pub fn conditions(&self) -> &ConditionSums {
        &self.conditions
    }

    /// What the chirp's torque balance read of the grease (`grease` module).
    pub fn grease(&self) -> Result<GreaseReading, GreaseError> {
        self.torque_fit.reading()
    }

    /// [`grease`](Self::grease) in steps ([`ChirpTorqueFit::reading_stepwise`]).
    pub async fn grease_stepwise(&self) -> Result<GreaseReading, GreaseError> {
        self.torque_fit.reading_stepwise().await
    }

    /// The test the buffer conditions.
    pub fn test(&self) -> &PreflightTest {
        &self.test
    }

    /// Samples of the test's standstill segment (they come first; 0 without one).
    pub fn lead_samples(&self) -> usize {
        self.test.standstill_samples()
    }

    /// Conditions and stores one ADC frame; hands it back when the buffer is full. The first
    /// frame also sets the [`initial_angles`](Self::initial_angles). During a standstill
    /// segment the current is the driven pair's, `½·Σ s_x·i_x` with the pair's signs.
    pub fn push_frame(&mut self, frame: AdcFrame, pole_pairs: f32) -> Result<(), AdcFrame> {
        if self.samples.is_full() {
            return Err(frame);
        }
        if let Some(c) = frame.conditions {
            self.conditions
                .push(c.bus_voltage.to_bits(), c.temperature.to_bits());
        }
        let [a, b, c] = frame.phase_currents.map(i16f16_to_f32);
        let theta_e = pole_pairs * i16f16_to_f32(frame.motor_angle);
        let index = self.samples.len();
        let pair = self
            .test
            .standstill
            .and_then(|segment| segment.at(self.samples.len()));
        let current = match pair {
            Some(drive) => {
                let s = drive.signs();
                0.5 * (f32::from(s[0]) * a + f32::from(s[1]) * b + f32::from(s[2]) * c)
            }
            None => equivalent_current([a, b, c], theta_e),
        };
        match self.push_equivalent(current) {
            Ok(()) => {
                // Where the fitted part of a standstill segment starts (past its settle,
                // whose rotor motion the model does not play): the first pair's current, as
                // filtered (half the ADC noise of one raw frame; the current moves slowly
                // there), put as phase currents A = +i, B = −i. Without a segment, the phase
                // currents of the first frame. The shaft angles where the chirp starts.
                let fitted_start = self.test.standstill.map(|s| usize::from(s.settle_samples));
                if fitted_start == Some(index) {
                    let i = self.samples.last().copied().unwrap_or(current);
                    self.initial_angles.currents = [i, -i, 0.0];
                } else if fitted_start.is_none() && index == 0 {
                    self.initial_angles.currents = [a, b, c];
                }
                let motor = i16f16_to_f32(frame.motor_angle);
                let user = i4f28_to_f32(frame.user_angle);
                if index == self.lead_samples() {
                    self.initial_angles.motor = motor;
                    self.initial_angles.user = user;
                }
                if index >= self.lead_samples() {
                    self.torque_fit.push(current, motor, user);
                } else {
                    // Every byte zero when empty (`ZEROED`): the first frame sets both.
                    let bits = frame.motor_angle.to_bits();
                    let [lo, hi] = &mut self.standstill_motor;
                    if index == 0 {
                        (*lo, *hi) = (bits, bits);
                    }
                    *lo = (*lo).min(bits);
                    *hi = (*hi).max(bits);
                }
                Ok(())
            }
            Err(_) => Err(frame),
        }
    }

    /// Filters and stores one equivalent-current sample \[A\]; hands it back when full.
    pub fn push_equivalent(&mut self, current: f32) -> Result<(), f32> {
        if self.samples.is_full() {
            return Err(current);
        }
        let y = self.filter.apply(&mut self.filter_state, current);
        self.inv_kappa = None;
        self.samples.push(y)
    }

    /// Seals the buffer: checks it and computes the eq. (3) normalisation. O(N).
    pub fn finish(&mut self) -> Result<(), ConditioningError> {
        crate::base::steps::run_to_end(self.finish_stepwise())
    }

    /// [`finish`](Self::finish) in steps, for a controller's idle time: a pause after every
    /// [`FINISH_SAMPLES_PER_POLL`] samples of each of its two scans. The same result.
    pub async fn finish_stepwise(&mut self) -> Result<(), ConditioningError> {
        use crate::base::steps::pause;
        let need = Self::MIN_SAMPLES.min(N);
        if self.samples.len() < need {
            return Err(ConditioningError::TooFewSamples {
                have: self.samples.len() as u32,
                need: need as u32,
            });
        }
        for (index, x) in self.samples.iter().enumerate() {
            if !x.is_finite() {
                return Err(ConditioningError::NotFinite {
                    index: index as u32,
                });
            }
            if (index + 1) % FINISH_SAMPLES_PER_POLL == 0 {
                pause().await;
            }
        }
        // κ over the chirp: the standstill segment has its own weight in the fitness.
        let lead = self.lead_samples().min(self.samples.len());
        let chirp = self.samples.get(lead..).unwrap_or(&[]);
        let mut sum_sq = 0.0f32;
        let mut previous = 0.0f32;
        for (i, &x) in chirp.iter().enumerate() {
            let d = x - previous;
            sum_sq += d * d;
            previous = x;
            if (i + 1) % FINISH_SAMPLES_PER_POLL == 0 {
                pause().await;
            }
        }
        let kappa = sum_sq / chirp.len().max(1) as f32;
        // A flat trace has no derivative to normalise: every weight is then 1.
        self.inv_kappa = Some(if kappa > f32::MIN_POSITIVE {
            1.0 / kappa
        } else {
            0.0
        });
        Ok(())
    }

    /// The filtered samples \[A\].
    pub fn samples(&self) -> &[f32] {
        &self.samples
    }

    /// Where the monitor model starts: the shaft angles at the chirp's first sample, the
    /// phase currents at the standstill segment's first fitted sample.
    pub fn initial_angles(&self) -> ShaftAngles {
        self.initial_angles
    }

    /// `1/κ` of eq. (3) in units of 1/A² per sample step, once finished.
    pub fn inv_kappa(&self) -> Result<f32, ConditioningError> {
        self.inv_kappa.ok_or(ConditioningError::NotFinished)
    }

    /// The filter this buffer conditions with (the monitor model's output must go through the
    /// same one).
    pub fn filter(&self) -> &LowPass {
        &self.filter
    }

    /// Empties the buffer for a new test of design `test`, keeping the filter.
    pub fn clear_for(&mut self, test: PreflightTest) {
        self.clear();
        self.test = test;
    }

    /// Empties the buffer and conditions the next test with `filter`.
    pub fn set_filter(&mut self, filter: LowPass) {
        self.filter = filter;
        self.clear();
    }

    /// Empties the buffer for a new test, keeping the filter.
    pub fn clear(&mut self) {
        self.samples.clear();
        self.initial_angles = ShaftAngles::ZERO;
        self.filter_state = LowPassState::default();
        self.inv_kappa = None;
        self.conditions = ConditionSums::ZERO;
        self.torque_fit = ChirpTorqueFit::ZERO;
        self.standstill_motor = [0, 0];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_standstill_travel_is_the_rotors_range_there_and_nothing_after() {
        let test = PreflightTest::INJECTION;
        let lead = test.lead_samples();
        let filter = LowPass::for_control_period(1.0e-4).expect("the 10 kHz filter");
        let mut m: MeasuredCurrent<6000> = MeasuredCurrent::for_test(filter, test);
        assert_eq!(m.standstill_travel(), 0.0);
        let frame = |motor: f64| AdcFrame {
            phase_currents: [0.1, -0.1, 0.0].map(I16F16::saturating_from_num),
            motor_angle: I16F16::saturating_from_num(motor),
            user_angle: I4F28::ZERO,
            conditions: None,
        };
        for i in 0..lead {
            // The rotor creeps from 10.0 to 10.02 rad and back over the segment.
            let x = i as f64 / lead as f64;
            let motor = 10.0 + 0.04 * if x < 0.5 { x } else { 1.0 - x };
            m.push_frame(frame(motor), 4.0).expect("room");
        }
        let travel = m.standstill_travel();
        assert!((travel - 0.02).abs() < 1e-3, "{travel}");
        // The chirp's motion is not the standstill's.
        for _ in 0..100 {
            m.push_frame(frame(12.0), 4.0).expect("room");
        }
        assert_eq!(m.standstill_travel(), travel);
        m.clear();
        assert_eq!(m.standstill_travel(), 0.0);
    }

    #[test]
    fn sums_give_exact_means_and_none_without_readings() {
        let mut s = ConditionSums::ZERO;
        assert_eq!(s.bus_voltage(), None);
        for (bus, t) in [(270.0f32, -40.0f32), (271.0, -39.0)] {
            s.push((bus * 65_536.0) as i32, (t * 65_536.0) as i32);
        }
        assert_eq!(s.bus_voltage(), Some(270.5));
        assert_eq!(s.temperature(), Some(-39.5));
    }

    #[test]
    fn sectors_follow_the_table() {
        let deg = core::f32::consts::PI / 180.0;
        assert_eq!(commutation_sector(0.0), 0);
        assert_eq!(commutation_sector(29.0 * deg), 0);
        assert_eq!(commutation_sector(31.0 * deg), 1);
        assert_eq!(commutation_sector(100.0 * deg), 2);
        assert_eq!(commutation_sector(180.0 * deg), 3);
        assert_eq!(commutation_sector(-29.0 * deg), 0);
        assert_eq!(commutation_sector(-31.0 * deg), 5);
        assert_eq!(commutation_sector(720.0 * deg + 100.0 * deg), 2);
        assert_eq!(commutation_sector(f32::NAN), 0);
        assert!(commutation_sector(f32::INFINITY) < 6);
        assert!(commutation_sector(-1e30) < 6);
    }

    #[test]
    fn each_sector_has_one_floating_phase_and_balanced_currents() {
        for s in COMMUTATION_SIGNS {
            assert_eq!(s.iter().filter(|&&x| x == 0).count(), 1);
            assert_eq!(s.iter().map(|&x| x as i32).sum::<i32>(), 0);
        }
        // Paper eq. (1): floating phase A, B, C in sectors (0,3), (1,4), (2,5).
        for (j, s) in COMMUTATION_SIGNS.iter().enumerate() {
            assert_eq!(s[j % 3], 0, "sector {j}");
        }
    }

    #[test]
    fn equivalent_current_recovers_the_conducting_current_with_its_sign() {
        for j in 0..36 {
            let theta_e = (j as f32 + 0.5) * 10.0 * core::f32::consts::PI / 180.0;
            let s = commutation_signs(theta_e);
            for current in [3.5f32, -2.0] {
                let phases = s.map(|x| f32::from(x) * current);
                assert_eq!(equivalent_current(phases, theta_e), current);
            }
        }
    }

    #[test]
    fn low_pass_has_unit_dc_gain_and_attenuates_above_cutoff() {
        let lp = LowPass::butterworth(1000.0, 10_000.0).unwrap();
        let mut st = LowPassState::default();
        let mut y = 0.0;
        for _ in 0..2000 {
            y = lp.apply(&mut st, 1.0);
        }
        assert!((y - 1.0).abs() < 1e-5);
        // A 4 kHz tone is attenuated by more than 20 dB.
        let mut st = LowPassState::default();
        let mut peak = 0.0f32;
        for i in 0..4000 {
            let x = (core::f32::consts::TAU * 4000.0 * i as f32 / 10_000.0).sin();
            let y = lp.apply(&mut st, x);
            if i > 2000 {
                peak = peak.max(y.abs());
            }
        }
        assert!(peak < 0.1, "peak {peak}");
        assert_eq!(
            LowPass::butterworth(5000.0, 10_000.0),
            Err(ConditioningError::InvalidCutoff)
        );
        assert_eq!(
            LowPass::butterworth(0.0, 10_000.0),
            Err(ConditioningError::InvalidCutoff)
        );
        assert_eq!(
            LowPass::butterworth(f32::NAN, 10_000.0),
            Err(ConditioningError::InvalidCutoff)
        );
    }

    #[test]
    fn the_first_frame_sets_the_initial_angles_and_clear_resets_them() {
        let lp = LowPass::butterworth(1000.0, 10_000.0).unwrap();
        let mut m = MeasuredCurrent::<10>::new(lp);
        assert_eq!(m.initial_angles(), ShaftAngles::ZERO);
        m.push_frame(AdcFrame::from_f32([1.0, -1.0, 0.0], 0.25, -3.0e-5), 4.0)
            .unwrap();
        m.push_frame(AdcFrame::from_f32([1.0, -1.0, 0.0], 0.5, 7.0e-5), 4.0)
            .unwrap();
        let a = m.initial_angles();
        assert_eq!(a.motor, 0.25);
        // I4F28 holds the user angle to 3.7 nrad.
        assert!((a.user + 3.0e-5).abs() < 4.0e-9, "{a:?}");
        m.clear();
        assert_eq!(m.initial_angles(), ShaftAngles::ZERO);
    }

    #[test]
    fn measured_buffer_hands_back_when_full_and_checks_length() {
        let lp = LowPass::butterworth(1000.0, 10_000.0).unwrap();
        let mut m = MeasuredCurrent::<1200>::new(lp);
        assert_eq!(m.inv_kappa(), Err(ConditioningError::NotFinished));
        for i in 0..999 {
            m.push_equivalent(i as f32).unwrap();
        }
        assert_eq!(
            m.finish(),
            Err(ConditioningError::TooFewSamples {
                have: 999,
                need: 1000
            })
        );
        for i in 999..1200 {
            m.push_equivalent(i as f32).unwrap();
        }
        assert_eq!(m.push_equivalent(7.0), Err(7.0));
        let frame = AdcFrame::from_f32([1.0, -1.0, 0.0], 0.3, 0.0);
        assert_eq!(m.push_frame(frame, 4.0), Err(frame));
        m.finish().unwrap();
        assert!(m.inv_kappa().unwrap() > 0.0);
        m.clear();
        assert!(m.samples().is_empty());
    }

    #[test]
    fn measured_buffer_rejects_non_finite_samples() {
        let lp = LowPass::butterworth(1000.0, 10_000.0).unwrap();
        let mut m = MeasuredCurrent::<1000>::new(lp);
        for i in 0..1000 {
            m.push_equivalent(if i == 10 { f32::INFINITY } else { 0.0 })
                .unwrap();
        }
        // The filter spreads the infinity (as NaN/inf) from index 10 on.
        assert_eq!(m.finish(), Err(ConditioningError::NotFinite { index: 10 }));
    }

    #[test]
    fn fixed_readings_convert_as_the_fixed_crate_does() {
        let mut rng = crate::base::random::Xoshiro128PlusPlus::seed_from_u64(7);
        let edges = [
            0,
            1,
            -1,
            i32::MAX,
            i32::MIN,
            16_777_217,
            -16_777_217,
            33_554_435,
        ];
        let bits = edges
            .into_iter()
            .chain((0..100_000).map(|_| rng.next_u32() as i32 >> (rng.next_u32() % 32)));
        for b in bits {
            let (x, y) = (I16F16::from_bits(b), I4F28::from_bits(b));
            assert_eq!(
                i16f16_to_f32(x).to_bits(),
                x.to_num::<f32>().to_bits(),
                "{b}"
            );
            assert_eq!(
                i4f28_to_f32(y).to_bits(),
                y.to_num::<f32>().to_bits(),
                "{b}"
            );
        }
    }
}
