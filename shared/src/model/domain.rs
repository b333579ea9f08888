//! Is the measured actuator inside the monitor model's domain? The monitor model explains
//! friction, backlash, partial stator shorts, eccentricity and gain drift of an actuator that
//! follows the preflight chirp. A jammed actuator, an open phase or a test run with another
//! command lies outside it: the GA would still return its best vector, a confident wrong
//! answer. These checks turn that into the verdict [`Domain::Outside`]. So does a faulty
//! sensor (a stuck or glitching encoder, a current sense's offset or gain drift, a surface
//! transducer that disagrees with the encoder through the gear): named, never identified.
//!
//! [`DomainMonitor::push`] takes each ADC frame of the test (O(1): one chirp sample, a few
//! compares and sums; ≈ 110 bytes of state); [`DomainMonitor::assess`] judges the statistics
//! and the identification's best fitness against [`DomainLimits`] (O(1)).

use crate::model::conditions::{TestConditions, WindingEstimate, MAX_WINDING_DISAGREEMENT};
use crate::test::command::ChirpCommand;
use crate::test::conditioning::{commutation_signs, i16f16_to_f32, i4f28_to_f32, AdcFrame};

/// Why a test lies outside the monitor model's domain.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum OutsideReason {
    /// The user shaft hardly moved [rad of travel]: jammed (or not driven).
    NoMotion { travel: f32 },
    /// Phase `phase` (0 = A) carried far less current than the others while it was
    /// commutated in: open (disconnected winding, failed leg). `ratio` is its mean current
    /// over the largest phase's.
    OpenPhase { phase: u8, ratio: f32 },
    /// The user shaft did not follow the preflight chirp: the test ran another command.
    /// `tracking` is Σ(θ_u − θ_cmd)² / Σθ_cmd² over the test (offsets removed).
    CommandMismatch { tracking: f32 },
    /// Even the best fault vector leaves this much unexplained [A²·s]: the actuator does
    /// something the monitor model cannot.
    FitnessFloor { fitness: f32 },
    /// The standstill injection's pair `pair` (0 = A→B) carried less current than its
    /// design must produce ([`crate::model::conditions::MIN_PAIR_CURRENT`]), or no physical R and L:
    /// the drive did not apply the test (a bridge that could not, an open leg).
    SegmentCarriedNothing { pair: u8 },
    /// The DC bus the controller measured over the test \[V\] lies outside
    /// [`DomainLimits::bus_voltage`]: a drive the calibration and the campaigns never saw.
    BusOutOfRange { volts: f32 },
    /// The temperature the controller measured over the test [°C] lies outside
    /// [`DomainLimits::temperature`]: beyond where the friction law and the winding's
    /// correction were measured.
    TemperatureOutOfRange { celsius: f32 },
    /// A sensor, not the actuator: the motor encoder read the same count for `samples`
    /// control periods in a row while the chirp drove the motor (stuck).
    EncoderStuck { samples: u32 },
    /// A sensor: the motor encoder jumped `step` rad between two control periods, beyond what
    /// the motor can turn in one at its speed limit (a glitch).
    EncoderGlitch { step: f32 },
    /// A sensor: the three phase currents summed to `amps` on average — a star winding's
    /// sum is 0 — so a current sense has an offset.
    CurrentSenseOffset { amps: f32 },
    /// A sensor: the phase currents' sum varied by `amps` RMS about its mean, beyond the
    /// ADC's noise: one current sense's gain has drifted from the others'.
    CurrentSenseGain { amps: f32 },
    /// A sensor: the surface transducer and the motor encoder (through the gear ratio)
    /// disagreed over `spread` rad, more than the largest play and compliance the fault
    /// vector can explain.
    TransducerDisagrees { spread: f32 },
    /// The installation is not the one calibrated: the injection's winding temperature
    /// disagreed with the thermistor's by `kelvin` (beyond
    /// [`crate::model::conditions::MAX_WINDING_DISAGREEMENT`]), or (`kelvin` NaN) a pair answered
    /// the tone as no R–L circuit of this winding does
    /// ([`crate::model::conditions::WindingEstimate::PairNotPhysical`] says which). Another dead
    /// time, switch, harness or controller timing: recalibrate, do not identify.
    InstallationChanged { kelvin: f32 },
    /// The calibration has a friction law by drag (a grease with a drag of its own) and the
    /// chirp's drag, `drag` times the calibration day's, lies beyond the drags the law was
    /// measured at by more than [`crate::model::conditions::DRAG_MARGIN`] (NaN: the chirp gave no
    /// drag to read). A gearbox colder or warmer than any calibrated point, or a grease that
    /// is not the calibrated one (aged, contaminated, another grade): the healthy friction
    /// is not known, so wear cannot be told from the grease. Test within the calibrated
    /// range, or calibrate the new grease.
    GreaseOutOfRange { drag: f32 },
    /// The load moved during the chirp: the monitor model left a mean current of `offset`
    /// times the measured RMS unexplained ([`LoadSigns::offset`], beyond
    /// [`MAX_LOAD_OFFSET`]) — a moment on the surface other than its hinge spring (wind on
    /// the parked aircraft, a gust, a hand) that the position loop held. No fault does that.
    /// Re-run the test when the surface is quiet.
    LoadMoved { offset: f32 },
    /// The load moved the rotor while the position loop was suspended (the standstill
    /// segment): it turned `travel` times the chirp's amplitude at the motor
    /// ([`LoadSigns::standstill`], beyond [`MAX_STANDSTILL_TRAVEL`]). Re-run the test when the
    /// surface is quiet.
    LoadMovedAtRest { travel: f32 },
}

/// What a test shows of a moment on its surface beyond the hinge spring: both dimensionless.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LoadSigns {
    /// The unexplained current's mean over the chirp against the measured RMS
    /// ([`CurvatureRun::load_offset`](crate::solver::fitness::CurvatureRun::load_offset)); NaN without a chirp.
    pub offset: f32,
    /// The motor's travel over the standstill segment against the chirp's amplitude at the
    /// motor (gear ratio × amplitude); 0 without a segment.
    pub standstill: f32,
}

/// Largest [`LoadSigns::offset`] of a test whose surface carried only its hinge spring.
/// Still air, Table I and II and noise, 3 seeds each, both example actuators: at most 0.0023
/// (reference) and 0.0054 (light); a 5–30 kt wind gives up to 0.24 (docs/in-flight.md,
/// `host-sim campaign --wind`).
pub const MAX_LOAD_OFFSET: f32 = 0.0075;

/// Largest [`LoadSigns::standstill`] of a test on a quiet surface: in still air at most
/// 0.0022 (reference) and 0.0048 (light, the rotor settling in the gear's play).
pub const MAX_STANDSTILL_TRAVEL: f32 = 0.0075;

/// The verdict on the whole test.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Domain {
    /// Inside the monitor model's domain: the fault vector can be trusted as far as the
    /// model goes.
    Within,
    /// Outside: the fault vector explains nothing, do not act on it.
    Outside(OutsideReason),
}

impl Domain {
    /// The verdict with the test's day checked first: an injection segment that carried
    /// nothing, a changed installation, a measured bus or temperature outside `limits`'
    /// ranges (inclusive; a test without the reading is not judged on it), or a chirp's drag
    /// beyond the friction law by drag, puts the test outside, whatever the rest says. O(1).
    pub fn with_day(self, limits: &DomainLimits, day: &TestConditions) -> Self {
        let outside = |v: Option<f32>, [lo, hi]: [f32; 2]| v.filter(|v| !(lo..=hi).contains(v));
        let disagreement = day.winding_disagreement;
        if let WindingEstimate::PairCarriedNothing { pair } = day.winding {
            Self::Outside(OutsideReason::SegmentCarriedNothing { pair })
        } else if let WindingEstimate::PairNotPhysical { .. } = day.winding {
            Self::Outside(OutsideReason::InstallationChanged { kelvin: f32::NAN })
        } else if disagreement.abs() > MAX_WINDING_DISAGREEMENT {
            Self::Outside(OutsideReason::InstallationChanged {
                kelvin: disagreement,
            })
        } else if let Some(volts) = outside(day.bus_voltage, limits.bus_voltage) {
            Self::Outside(OutsideReason::BusOutOfRange { volts })
        } else if let Some(celsius) = outside(day.measured_temperature, limits.temperature) {
            Self::Outside(OutsideReason::TemperatureOutOfRange { celsius })
        } else if let Some(drag) = day.drag_outside_law {
            Self::Outside(OutsideReason::GreaseOutOfRange { drag })
        } else {
            self
        }
    }
}

impl Domain {
    /// The verdict with the load checked: a rotor that turned beyond
    /// [`MAX_STANDSTILL_TRAVEL`] while the loop was suspended (named first: it also spoils
    /// the chirp's start), or a chirp whose unexplained current has a mean beyond
    /// [`MAX_LOAD_OFFSET`] of its RMS, names the moved load in place
    /// of what a moved load also spoils (the fit's floor, the injection's winding, the chirp's
    /// drag) or of `Within`; a sensor, an open phase, a test that did not move or ran another
    /// command, a pair that answered as no R–L circuit keep their reason. NaN is not judged.
    /// O(1).
    pub fn with_load(self, signs: LoadSigns) -> Self {
        let LoadSigns { offset, standstill } = signs;
        let reason = if standstill > MAX_STANDSTILL_TRAVEL {
            OutsideReason::LoadMovedAtRest { travel: standstill }
        } else if offset.abs() > MAX_LOAD_OFFSET {
            OutsideReason::LoadMoved { offset }
        } else {
            return self;
        };
        match self {
            // A pair that answered as no R–L circuit (kelvin NaN) is the drive's, not a
            // load's: a replaced bridge also shakes the rotor at rest.
            Self::Outside(OutsideReason::InstallationChanged { kelvin }) if kelvin.is_nan() => self,
            Self::Within
            | Self::Outside(
                OutsideReason::FitnessFloor { .. }
                | OutsideReason::InstallationChanged { .. }
                | OutsideReason::GreaseOutOfRange { .. },
            ) => Self::Outside(reason),
            other => other,
        }
    }
}

/// Where the domain ends: plain data, set from campaigns (see the constants' docs).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DomainLimits {
    /// Least user-shaft travel of a test that moved \[rad\].
    pub min_travel: f32,
    /// Least ratio of a phase's mean commutated current to the largest phase's.
    pub min_phase_ratio: f32,
    /// Commutated samples each phase needs before the phase check is made.
    pub min_phase_samples: u32,
    /// The phase check needs the largest phase's mean commutated current at least this
    /// high \[A\] (with no current at all there is nothing to compare).
    pub min_phase_current: f32,
    /// Largest tracking ratio of a test that ran the preflight chirp.
    pub max_tracking: f32,
    /// Largest best fitness of an actuator the monitor model explains [A²·s].
    pub max_fitness: f32,
    /// The measured DC bus \[V\] the actuator was calibrated and verified over, `[low, high]`.
    pub bus_voltage: [f32; 2],
    /// The measured temperature [°C] the actuator was calibrated and verified over,
    /// `[low, high]`.
    pub temperature: [f32; 2],
}

impl DomainLimits {
    /// Limits for this project's reference actuator and the preflight chirp
    /// (±5 mrad, 0.5 s). Measured by `host-sim domain` over the Table I and II cases, the
    /// healthy actuator, noise levels 0–10 % and seeds, against jammed, open-phase and
    /// other-command tests; each limit sits between the two groups (BENCHMARKS.md).
    pub const REFERENCE_ACTUATOR: Self = Self {
        min_travel: 2.0e-3,
        min_phase_ratio: 0.25,
        min_phase_samples: 200,
        min_phase_current: 0.2,
        max_tracking: 0.33,
        max_fitness: 0.12,
        // The robustness grid (docs/robustness.md): bus 250–280 V, winding −40 … +80 °C,
        // widened by the bus divider's 0.5 % and the thermistor's 2 K.
        bus_voltage: [245.0, 285.0],
        temperature: [-45.0, 85.0],
    };

    /// What a record of version 1 or 2 (before the ranges) reads as: any bus, any day.
    pub const ANY_DAY: ([f32; 2], [f32; 2]) = (
        [f32::NEG_INFINITY, f32::INFINITY],
        [f32::NEG_INFINITY, f32::INFINITY],
    );
}

/// Running statistics of one test (the settings are the command and the pole pairs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DomainMonitor {
    command: ChirpCommand,
    control_period: f32,
    pole_pairs: f32,
    samples: u32,
    first_user: f32,
    user_min: f32,
    user_max: f32,
    tracking_error: f32,
    command_energy: f32,
    phase_current: [f32; 3],
    phase_samples: [u32; 3],
    sensors: SensorStats,
}

/// The sensors' plausibility statistics of one test (the chirp's frames): O(1) per frame.
#[derive(Clone, Copy, Debug, PartialEq)]
struct SensorStats {
    /// 1 / gear ratio, and the rigging's encoder offset [rad], to see the motor through the
    /// gear.
    inv_gear_ratio: f32,
    encoder_offset: f32,
    /// The largest play the fault vector expresses [rad] and the speed limit [rad/s].
    max_play: f32,
    max_speed: f32,
    /// Encoder bits of the previous frame, the current run of equal readings, the longest.
    previous_motor: i32,
    run: u32,
    longest_run: u32,
    /// Largest |Δθ_m| between consecutive frames [encoder bits, 2⁻¹⁶ rad], and the equal
    /// readings before it.
    largest_step: u32,
    hold_before_step: u32,
    /// Σ and Σ² of i_a + i_b + i_c [A, A²].
    sum: f32,
    sum_square: f32,
    /// Extremes of θ_u − (θ_m − offset)/N [rad].
    disagreement_min: f32,
    disagreement_max: f32,
}

/// Sensor limits, from the actuator's parameters and the controller's ADC. The encoder: a
/// step over twice the speed limit's reach in one period is a glitch, or, after at least
/// [`ENCODER_HOLD_LIMIT`] equal readings, a stuck encoder catching up (a motor held by its
/// friction at a reversal reads equal counts for up to ≈ 11 ms on the campaigns, then moves
/// on smoothly: never more than 0.022 rad a period). Equal readings alone prove nothing — a
/// jammed surface or an open phase holds the motor still too — so an encoder frozen to the
/// end of the test shows as the transducer's disagreement instead. The phase currents' mean
/// sum over 0.08 A or its RMS about the mean over 0.06 A ([`CURRENT_SUM_LIMITS`]: the 12-bit ±20 A ADC's noise sums to ≈ 0.018 A
/// RMS). A transducer disagreement over 1.5 × the largest play the fault vector expresses
/// (100 × the nominal backlash) plus 0.5 mrad ([`TRANSDUCER_MARGIN`]).
pub const ENCODER_HOLD_LIMIT: u32 = 10;
/// Mean and RMS limits of the phase currents' sum \[A\] (see [`ENCODER_HOLD_LIMIT`]).
pub const CURRENT_SUM_LIMITS: [f32; 2] = [0.08, 0.06];
/// Margin of the transducer check \[rad\] (see [`ENCODER_HOLD_LIMIT`]).
pub const TRANSDUCER_MARGIN: f32 = 5.0e-4;

impl DomainMonitor {
    pub fn new(command: ChirpCommand, params: &crate::physics::params::ActuatorParams) -> Self {
        Self {
            command,
            control_period: params.control_period,
            pole_pairs: params.pole_pairs,
            samples: 0,
            first_user: 0.0,
            user_min: f32::INFINITY,
            user_max: f32::NEG_INFINITY,
            tracking_error: 0.0,
            command_energy: 0.0,
            phase_current: [0.0; 3],
            phase_samples: [0; 3],
            sensors: SensorStats {
                inv_gear_ratio: 1.0 / params.gear_ratio,
                encoder_offset: params.encoder_offset,
                max_play: params.nominal_backlash * crate::physics::fault::BACKLASH_SCALE_MAX,
                max_speed: params.max_speed,
                previous_motor: 0,
                run: 0,
                longest_run: 0,
                largest_step: 0,
                hold_before_step: 0,
                sum: 0.0,
                sum_square: 0.0,
                disagreement_min: f32::INFINITY,
                disagreement_max: f32::NEG_INFINITY,
            },
        }
    }

    /// Takes the next frame of the test. O(1).
    pub fn push(&mut self, frame: &AdcFrame) {
        let user = i4f28_to_f32(frame.user_angle);
        if self.samples == 0 {
            self.first_user = user;
        }
        let t = self.samples as f32 * self.control_period;
        let commanded = self.command.position(t);
        let followed = user - self.first_user;
        let e = followed - commanded;
        self.tracking_error += e * e;
        self.command_energy += commanded * commanded;
        self.user_min = self.user_min.min(user);
        self.user_max = self.user_max.max(user);
        let motor = i16f16_to_f32(frame.motor_angle);
        let z = &mut self.sensors;
        let bits = frame.motor_angle.to_bits();
        if self.samples > 0 {
            // The step in encoder bits (I16F16): exact, no float work per frame.
            let step = bits.wrapping_sub(z.previous_motor).unsigned_abs();
            if step > z.largest_step {
                z.largest_step = step;
                z.hold_before_step = z.run + 1;
            }
            z.run = if step == 0 {
                z.run.saturating_add(1)
            } else {
                0
            };
            z.longest_run = z.longest_run.max(z.run);
        }
        z.previous_motor = bits;
        let [a, b, c] = frame.phase_currents.map(i16f16_to_f32);
        let sum = a + b + c;
        z.sum += sum;
        z.sum_square += sum * sum;
        let d = user - (motor - z.encoder_offset) * z.inv_gear_ratio;
        z.disagreement_min = z.disagreement_min.min(d);
        z.disagreement_max = z.disagreement_max.max(d);
        let theta_e = self.pole_pairs * motor;
        let signs = commutation_signs(theta_e);
        for ((sum, count), (sign, current)) in self
            .phase_current
            .iter_mut()
            .zip(self.phase_samples.iter_mut())
            .zip(signs.iter().zip(frame.phase_currents))
        {
            if *sign != 0 {
                let i = i16f16_to_f32(current);
                *sum += if i < 0.0 { -i } else { i };
                *count = count.saturating_add(1);
            }
        }
        self.samples = self.samples.saturating_add(1);
    }

    /// User-shaft travel so far \[rad\].
    pub fn travel(&self) -> f32 {
        if self.samples == 0 {
            0.0
        } else {
            self.user_max - self.user_min
        }
    }

    /// Σ(θ_u − θ_cmd)² / Σθ_cmd² so far (`+∞` before the command moved).
    pub fn tracking(&self) -> f32 {
        if self.command_energy > 0.0 {
            self.tracking_error / self.command_energy
        } else {
            f32::INFINITY
        }
    }

    /// Mean |current| of each phase over the samples it was commutated in \[A\] (`None` for a
    /// phase with fewer than `min_samples`).
    pub fn phase_means(&self, min_samples: u32) -> [Option<f32>; 3] {
        let mut out = [None; 3];
        for ((slot, sum), count) in out
            .iter_mut()
            .zip(self.phase_current)
            .zip(self.phase_samples)
        {
            if count >= min_samples.max(1) {
                *slot = Some(sum / count as f32);
            }
        }
        out
    }

    /// Largest phase's mean commutated current \[A\] (0 before any phase has `min_samples`).
    pub fn largest_phase_mean(&self, min_samples: u32) -> f32 {
        self.phase_means(min_samples)
            .iter()
            .flatten()
            .fold(0.0f32, |a, &b| a.max(b))
    }

    /// Each phase's mean commutated current over the largest phase's (`None` for a phase
    /// with fewer than `min_samples`, or when no phase carries current).
    pub fn phase_ratios(&self, min_samples: u32) -> [Option<f32>; 3] {
        let largest = self.largest_phase_mean(min_samples);
        self.phase_means(min_samples)
            .map(|mean| mean.filter(|_| largest > 0.0).map(|m| m / largest))
    }

    /// The verdict, checks in order of how directly they see the failure: phases (while
    /// current flows), the test's day (an injection that carried nothing), motion, command,
    /// then the identification's best `fitness`.
    pub fn assess(&self, limits: &DomainLimits, fitness: f32, day: &TestConditions) -> Domain {
        let test = self.assess_test(limits, fitness);
        // An open phase starves its pairs' injection too: name the phase, the more direct
        // reason; otherwise a segment that carried nothing comes before the rest.
        if let Domain::Outside(OutsideReason::OpenPhase { .. }) = test {
            return test;
        }
        match Domain::Within.with_day(limits, day) {
            Domain::Within => test,
            outside => outside,
        }
    }

    /// The phase currents' sum over the frames: its mean [A] and its variance about the mean
    /// [A²] (NaN before any frame).
    fn current_sum_moments(&self) -> (f32, f32) {
        let z = &self.sensors;
        let n = self.samples as f32;
        let mean = z.sum / n;
        (mean, z.sum_square / n - mean * mean)
    }

    /// The largest encoder step between two frames [rad].
    fn largest_encoder_step(&self) -> f32 {
        self.sensors.largest_step as f32 * (1.0 / 65_536.0)
    }

    /// The sensors' statistics so far: the longest run of equal encoder readings (frames),
    /// the largest encoder step \[rad\], the phase currents' mean sum and its RMS about the
    /// mean \[A\], the transducer's disagreement with the encoder through the gear \[rad\].
    pub fn sensor_statistics(&self) -> (u32, f32, f32, f32, f32) {
        let z = &self.sensors;
        let (mean, variance) = self.current_sum_moments();
        let rms = if variance > 0.0 {
            crate::base::math::sqrt(variance)
        } else {
            0.0
        };
        let identical = if self.samples > 0 {
            z.longest_run + 1
        } else {
            0
        };
        (
            identical,
            self.largest_encoder_step(),
            mean,
            rms,
            z.disagreement_max - z.disagreement_min,
        )
    }

    /// The sensors' verdict alone (`None`: plausible, or fewer than two frames). O(1).
    // `!(x <= limit)`: a NaN statistic is outside too.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    #[inline(never)]
    pub fn sensor_fault(&self) -> Option<OutsideReason> {
        if self.samples < 2 {
            return None;
        }
        let z = &self.sensors;
        // The sum's mean and variance, compared squared (no root unless named).
        let (mean, variance) = self.current_sum_moments();
        let [mean_limit, rms_limit] = CURRENT_SUM_LIMITS;
        let disagreement = z.disagreement_max - z.disagreement_min;
        let step = self.largest_encoder_step();
        let jump = step > 2.0 * z.max_speed * self.control_period;
        if jump && z.hold_before_step >= ENCODER_HOLD_LIMIT {
            Some(OutsideReason::EncoderStuck {
                samples: z.hold_before_step,
            })
        } else if jump {
            Some(OutsideReason::EncoderGlitch { step })
        } else if !(mean * mean <= mean_limit * mean_limit) {
            Some(OutsideReason::CurrentSenseOffset { amps: mean })
        } else if !(variance <= rms_limit * rms_limit) {
            Some(OutsideReason::CurrentSenseGain {
                amps: crate::base::math::sqrt(variance),
            })
        } else if !(disagreement <= 1.5 * z.max_play + TRANSDUCER_MARGIN) {
            Some(OutsideReason::TransducerDisagrees {
                spread: disagreement,
            })
        } else {
            None
        }
    }

    /// The checks of the test's frames and fitness, without the day's.
    fn assess_test(&self, limits: &DomainLimits, fitness: f32) -> Domain {
        // A sensor fault first: it would otherwise read as an actuator fault or another
        // reason.
        if let Some(reason) = self.sensor_fault() {
            return Domain::Outside(reason);
        }
        if self.largest_phase_mean(limits.min_phase_samples) >= limits.min_phase_current {
            let ratios = self.phase_ratios(limits.min_phase_samples);
            for (phase, ratio) in (0u8..).zip(ratios) {
                if let Some(ratio) = ratio.filter(|r| *r < limits.min_phase_ratio) {
                    return Domain::Outside(OutsideReason::OpenPhase { phase, ratio });
                }
            }
        }
        let travel = self.travel();
        if travel < limits.min_travel {
            return Domain::Outside(OutsideReason::NoMotion { travel });
        }
        let tracking = self.tracking();
        // NaN counts as outside.
        if tracking.is_nan() || tracking > limits.max_tracking {
            return Domain::Outside(OutsideReason::CommandMismatch { tracking });
        }
        if fitness.is_nan() || fitness > limits.max_fitness {
            return Domain::Outside(OutsideReason::FitnessFloor { fitness });
        }
        Domain::Within
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const QUIET: LoadSigns = LoadSigns {
        offset: 0.001,
        standstill: 0.002,
    };

    #[test]
    fn a_quiet_surface_keeps_the_verdict() {
        let floor = Domain::Outside(OutsideReason::FitnessFloor { fitness: 1.0 });
        assert_eq!(Domain::Within.with_load(QUIET), Domain::Within);
        assert_eq!(floor.with_load(QUIET), floor);
        // NaN (no chirp, no sums) is not judged.
        let unknown = LoadSigns {
            offset: f32::NAN,
            ..QUIET
        };
        assert_eq!(Domain::Within.with_load(unknown), Domain::Within);
    }

    #[test]
    fn a_moved_load_is_named_over_what_it_spoils_but_not_over_a_sensor() {
        let chirp = LoadSigns {
            offset: -2.0 * MAX_LOAD_OFFSET,
            ..QUIET
        };
        let rest = LoadSigns {
            standstill: 2.0 * MAX_STANDSTILL_TRAVEL,
            ..chirp
        };
        assert_eq!(
            Domain::Within.with_load(chirp),
            Domain::Outside(OutsideReason::LoadMoved {
                offset: chirp.offset
            })
        );
        // The rotor moved at rest: named first (it spoils the chirp's start too).
        assert_eq!(
            Domain::Within.with_load(rest),
            Domain::Outside(OutsideReason::LoadMovedAtRest {
                travel: rest.standstill
            })
        );
        for spoiled in [
            OutsideReason::FitnessFloor { fitness: 1.0 },
            OutsideReason::InstallationChanged { kelvin: -40.0 },
            OutsideReason::GreaseOutOfRange { drag: 3.0 },
        ] {
            assert!(matches!(
                Domain::Outside(spoiled).with_load(chirp),
                Domain::Outside(OutsideReason::LoadMoved { .. })
            ));
        }
        // A pair that answered as no R–L circuit: the drive's, kept (NaN: no `==`).
        assert!(matches!(
            Domain::Outside(OutsideReason::InstallationChanged { kelvin: f32::NAN }).with_load(rest),
            Domain::Outside(OutsideReason::InstallationChanged { kelvin }) if kelvin.is_nan()
        ));
        for kept in [
            OutsideReason::CurrentSenseOffset { amps: 0.2 },
            OutsideReason::OpenPhase {
                phase: 1,
                ratio: 0.1,
            },
            OutsideReason::NoMotion { travel: 0.0 },
            OutsideReason::CommandMismatch { tracking: 1.0 },
        ] {
            assert_eq!(Domain::Outside(kept).with_load(rest), Domain::Outside(kept));
        }
    }
}
