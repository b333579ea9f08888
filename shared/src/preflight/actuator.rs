//! The actuator record: everything the onboard FDI knows about one actuator — its physical
//! parameters, the preflight test it commands, the monitor model's calibration, the GA
//! settings, the domain limits, the detection threshold and the preflight's systematic error
//! on this actuator — as versioned, CRC-32-checked bytes beside one verified executable
//! (DO-178C's parameter data items).
//!
//! Layout (little endian): `"EMAA"`, version `u16`, body length `u16`, the body as 32-bit
//! words in the order of [`ActuatorRecord::encode`], CRC-32 of everything before it.
//! [`RECORD_BYTES`] in all. Encoding and decoding are O(1) (a fixed 492 bytes), allocate
//! nothing and never panic; a decoded record is range-checked ([`ActuatorRecord::validate`])
//! before it is handed out.

use crate::base::capacity::{POPULATION, TEST_SAMPLES};
use crate::model::calibration::{Calibration, FRICTION_POINTS};
use crate::model::domain::DomainLimits;
use crate::physics::drive::DriveSettings;
use crate::physics::fault::{FaultVector, DETECTION_THRESHOLD, FAULT_COUNT, PAPER_FAULT_COUNT};
use crate::physics::params::{ActuatorParams, PARAM_WORDS};
use crate::solver::ga::{GaSettings, GENES};
use crate::solver::polish::{PolishSettings, ProbeStart, MAX_PROBES};
use crate::solver::uncertainty::SystematicError;
use crate::test::command::ChirpCommand;
use crate::test::test_design::{MotionSegment, PreflightTest, StandstillSegment};
use crate::test::trace::Crc32;

/// First bytes of every actuator record.
pub const RECORD_MAGIC: [u8; 4] = *b"EMAA";
/// The version this code writes (it reads versions 1 to 4 too: version 1 has steps at
/// standstill and the calibration without the day's terms, versions 1 and 2 have no domain
/// bus and temperature ranges, which read as [`DomainLimits::ANY_DAY`], none before 4
/// has the polish's settings, which read as [`PolishSettings::FDI`], and none before 5 has
/// the drive, which reads as [`DriveSettings::TYPICAL`]; none before 6 has the
/// calibration's duty delay, which reads as 0: the controller of those records applied
/// each period's volts at its sample; none before 7 has the grease's drag law, which reads
/// as none: friction follows the measured temperature; none before 8 has the GA's initial
/// guess of the ninth component, demagnetization, which reads as 0: no flux lost; none
/// before 9 has the preflight's systematic error, which reads as
/// [`SystematicError::REFERENCE_ACTUATOR`], the values those records were used with; none
/// before 10 has the gearbox's spread from the thermistor, which reads as 0: the gearbox at
/// the thermistor's temperature; none before 11 has the most tests a preflight plays, which
/// reads as 1: one test).
pub const RECORD_VERSION: u16 = 11;
/// 32-bit words in the body of version 1.
const BODY_WORDS_V1: usize = 72;
/// Words version 2 adds at the end of [`run_words`]: the injection's frequency, the pair
/// circuits' scales, the calibration's temperature, the friction law and the magnets.
const DAY_WORDS: usize = 5 + 2 * FRICTION_POINTS;
/// 32-bit words in the body of version 2.
const BODY_WORDS_V2: usize = BODY_WORDS_V1 + DAY_WORDS;
/// Words version 3 adds after the detection threshold: the domain's bus and temperature
/// ranges.
const RANGE_WORDS: usize = 4;
/// 32-bit words in the body of version 3.
const BODY_WORDS_V3: usize = BODY_WORDS_V2 + RANGE_WORDS;
/// Words version 4 adds at the end: the polish's steps, probe count and damping, then per
/// probe its component (bit 8: from nominal; bit 9: from the scan's minima) and level.
const POLISH_WORDS: usize = 4 + 2 * MAX_PROBES;
/// 32-bit words in the body of version 4.
const BODY_WORDS_V4: usize = BODY_WORDS_V3 + POLISH_WORDS;
/// Words version 5 adds at the end: the drive's carrier, dead time, compensation (0 or 1)
/// and compensation threshold.
const DRIVE_WORDS: usize = 4;
/// 32-bit words in the body of version 5.
const BODY_WORDS_V5: usize = BODY_WORDS_V4 + DRIVE_WORDS;
/// Words version 6 adds at the end: the calibration's duty delay.
const TIMING_WORDS: usize = 1;
/// 32-bit words in the body of version 6.
const BODY_WORDS_V6: usize = BODY_WORDS_V5 + TIMING_WORDS;
/// Words version 7 adds at the end: the calibration's viscous drag and each friction
/// point's drag.
const GREASE_WORDS: usize = 1 + FRICTION_POINTS;
/// 32-bit words in the body of version 7.
const BODY_WORDS_V7: usize = BODY_WORDS_V6 + GREASE_WORDS;
/// Words version 8 adds at the end: the initial guess's components past the paper's eight
/// (demagnetization). The body's guess before it keeps the paper's eight.
const NINTH_WORDS: usize = GENES - PAPER_FAULT_COUNT;
/// 32-bit words in the body of version 8.
const BODY_WORDS_V8: usize = BODY_WORDS_V7 + NINTH_WORDS;
/// Words version 9 adds at the end: the preflight's systematic error in the gain drift,
/// without and with a gear play ([`SystematicError`]).
const SYSTEMATIC_WORDS: usize = 2;
/// 32-bit words in the body of version 9.
const BODY_WORDS_V9: usize = BODY_WORDS_V8 + SYSTEMATIC_WORDS;
/// Words version 10 adds at the end: the gearbox's spread from the thermistor
/// ([`SystematicError::gear_temperature_spread`]).
const SPREAD_WORDS: usize = 1;
/// 32-bit words in the body of version 10.
const BODY_WORDS_V10: usize = BODY_WORDS_V9 + SPREAD_WORDS;
/// Words version 11 adds at the end: the most tests one preflight plays
/// ([`ActuatorRecord::max_tests`]).
const TESTS_WORDS: usize = 1;
/// 32-bit words in the body.
const BODY_WORDS: usize = BODY_WORDS_V10 + TESTS_WORDS;
/// The body's 32-bit words by version, from 1 (bytes, not a `match`: 36 B less flash).
#[allow(clippy::indexing_slicing)] // evaluated when compiling: an index out of range fails the build
const BODY_WORDS_OF_VERSION: [u8; RECORD_VERSION as usize] = {
    let words = [
        BODY_WORDS_V1,
        BODY_WORDS_V2,
        BODY_WORDS_V3,
        BODY_WORDS_V4,
        BODY_WORDS_V5,
        BODY_WORDS_V6,
        BODY_WORDS_V7,
        BODY_WORDS_V8,
        BODY_WORDS_V9,
        BODY_WORDS_V10,
        BODY_WORDS,
    ];
    let mut out = [0u8; RECORD_VERSION as usize];
    let mut i = 0;
    while i < out.len() {
        assert!(words[i] <= u8::MAX as usize);
        out[i] = words[i] as u8;
        i += 1;
    }
    out
};
/// Bytes of one record: magic, version, length, body, CRC-32.
pub const RECORD_BYTES: usize = 8 + 4 * BODY_WORDS + 4;
/// Bytes of a version 1 record.
pub const RECORD_BYTES_V1: usize = 8 + 4 * BODY_WORDS_V1 + 4;
/// Bytes of a version 2 record.
pub const RECORD_BYTES_V2: usize = 8 + 4 * BODY_WORDS_V2 + 4;
/// Bytes of a version 3 record.
pub const RECORD_BYTES_V3: usize = 8 + 4 * BODY_WORDS_V3 + 4;
/// Bytes of a version 4 record.
pub const RECORD_BYTES_V4: usize = 8 + 4 * BODY_WORDS_V4 + 4;
/// Bytes of a version 5 record.
pub const RECORD_BYTES_V5: usize = 8 + 4 * BODY_WORDS_V5 + 4;
/// Bytes of a version 6 record.
pub const RECORD_BYTES_V6: usize = 8 + 4 * BODY_WORDS_V6 + 4;
/// Bytes of a version 7 record.
pub const RECORD_BYTES_V7: usize = 8 + 4 * BODY_WORDS_V7 + 4;
/// Bytes of a version 8 record.
pub const RECORD_BYTES_V8: usize = 8 + 4 * BODY_WORDS_V8 + 4;
/// Bytes of a version 9 record.
pub const RECORD_BYTES_V9: usize = 8 + 4 * BODY_WORDS_V9 + 4;
/// Bytes of a version 10 record.
pub const RECORD_BYTES_V10: usize = 8 + 4 * BODY_WORDS_V10 + 4;

/// The most tests one preflight may play ([`ActuatorRecord::max_tests`]).
pub const MAX_TESTS: u32 = 8;

/// Why a record was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ActuatorRecordError {
    /// Fewer bytes than one record.
    TooShort { found: usize },
    /// Not an actuator record.
    BadMagic,
    /// Written by another version of this format.
    UnsupportedVersion { found: u16 },
    /// The length field disagrees with the version's layout.
    BadLength { found: u16 },
    /// The bytes are damaged.
    BadChecksum,
    /// A value outside its physical or working range; names the field as the actuator
    /// description file does (`section.key`).
    OutOfRange { field: RecordField },
}

/// The fields [`ActuatorRecord::validate`] can refuse, named on the host as the actuator
/// description file names them ([`RecordField::key`]). An enum rather than the key's text so
/// that the firmware's flash holds no names: defmt prints the variant from the host's table.
macro_rules! record_fields {
    ($($variant:ident => $key:literal,)*) => {
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        #[cfg_attr(feature = "defmt", derive(defmt::Format))]
        pub enum RecordField {
            $($variant,)*
        }

        impl RecordField {
            /// Every field, in declaration order.
            pub const ALL: &'static [RecordField] = &[$(RecordField::$variant,)*];

            /// `section.key` in the actuator description file (`ga`: the GA settings as a
            /// whole; `test`: a segment's sample count beyond 65 535).
            pub const fn key(self) -> &'static str {
                match self {
                    $(RecordField::$variant => $key,)*
                }
            }
        }
    };
}

record_fields! {
    TestDesign => "test.design",
    TestInjectionFrequency => "test.injection_frequency",
    MotorDcBusVoltage => "motor.dc_bus_voltage",
    MotorPhaseResistance => "motor.phase_resistance",
    MotorPhaseInductance => "motor.phase_inductance",
    MotorBackEmfConstant => "motor.back_emf_constant",
    MotorMaxCurrent => "motor.max_current",
    MechanicsMotorInertia => "mechanics.motor_inertia",
    MechanicsUserInertia => "mechanics.user_inertia",
    MechanicsGearRatio => "mechanics.gear_ratio",
    MechanicsGearStiffness => "mechanics.gear_stiffness",
    MechanicsNominalBacklash => "mechanics.nominal_backlash",
    MechanicsStaticFriction => "mechanics.static_friction",
    MechanicsDynamicFriction => "mechanics.dynamic_friction",
    MechanicsStickSpeed => "mechanics.stick_speed",
    ControllerPositionKp => "controller.position_kp",
    ControllerMaxSpeed => "controller.max_speed",
    ControllerSpeedKp => "controller.speed_kp",
    ControllerControlPeriod => "controller.control_period",
    TestChirpAmplitude => "test.chirp_amplitude",
    TestChirpEndFrequency => "test.chirp_end_frequency",
    TestChirpDuration => "test.chirp_duration",
    CalibrationResistanceScale => "calibration.resistance_scale",
    CalibrationPairResistanceScale => "calibration.pair_resistance_scale",
    CalibrationPairInductanceScale => "calibration.pair_inductance_scale",
    CalibrationInductanceScale => "calibration.inductance_scale",
    CalibrationBackEmfScale => "calibration.back_emf_scale",
    CalibrationFrictionScale => "calibration.friction_scale",
    MechanicsGearDamping => "mechanics.gear_damping",
    MechanicsAeroStiffness => "mechanics.aero_stiffness",
    ControllerPositionKi => "controller.position_ki",
    ControllerPositionKd => "controller.position_kd",
    ControllerSpeedKi => "controller.speed_ki",
    CalibrationDamping => "calibration.damping",
    CalibrationNominalResidual => "calibration.nominal_residual",
    DomainMinTravel => "domain.min_travel",
    DomainMinPhaseRatio => "domain.min_phase_ratio",
    DomainMinPhaseCurrent => "domain.min_phase_current",
    DomainMaxTracking => "domain.max_tracking",
    CalibrationTemperature => "calibration.temperature",
    CalibrationFrictionPoints => "calibration.friction_points",
    CalibrationMagnetCoefficient => "calibration.magnet_coefficient",
    CalibrationDutyDelay => "calibration.duty_delay",
    MotorPolePairs => "motor.pole_pairs",
    MotorWindingGroupAngleDeg => "motor.winding_group_angle_deg",
    InstallationEncoderOffset => "installation.encoder_offset",
    TestStandstillVolts => "test.standstill_volts",
    TestMotionAmplitude => "test.motion_amplitude",
    DomainMaxFitness => "domain.max_fitness",
    DomainBusVoltage => "domain.bus_voltage",
    DomainTemperature => "domain.temperature",
    Polish => "polish",
    DriveCarrierHz => "drive.carrier_hz",
    DriveDeadTime => "drive.dead_time",
    DriveCompensationThreshold => "drive.compensation_threshold",
    DetectionThreshold => "detection.threshold",
    Ga => "ga",
    GaTournamentSize => "ga.tournament_size",
    TestSegmentSamples => "test",
    CalibrationViscous => "calibration.viscous",
    CalibrationDragPoints => "calibration.drag_points",
    UncertaintyGainDriftSystematic => "uncertainty.gain_drift_systematic",
    UncertaintyPlayGainDriftSystematic => "uncertainty.play_gain_drift_systematic",
    UncertaintyGearTemperatureSpread => "uncertainty.gear_temperature_spread",
    TestMaxTests => "test.max_tests",
}

/// One actuator, as the FDI needs it. Plain data.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ActuatorRecord {
    pub params: ActuatorParams,
    /// The preflight test this actuator's controller commands.
    pub test: PreflightTest,
    /// The monitor model fitted to this actuator (`host-sim calibrate`).
    pub calibration: Calibration,
    pub ga: GaSettings,
    /// The Gauss–Newton polish after the GA: its steps and probe starts.
    pub polish: PolishSettings,
    pub domain: DomainLimits,
    /// The bridge the controller drives the test through (the board's PWM timer).
    pub drive: DriveSettings,
    /// Deviation from nominal above which a component reads as a fault.
    pub detection_threshold: f32,
    /// The preflight's systematic error on this actuator, surveyed on its own campaign
    /// (`crate::solver::uncertainty::SystematicError`).
    pub systematic: SystematicError,
    /// The most tests one preflight plays where the current's noise calls for them
    /// ([`Self::tests_called_for`]), 1 … [`MAX_TESTS`]: the drive time the maker allows.
    pub max_tests: u32,
}

impl ActuatorRecord {
    /// This project's reference actuator with the default test.
    pub const REFERENCE: Self = Self {
        params: ActuatorParams::REFERENCE,
        test: PreflightTest::INJECTION,
        calibration: Calibration::REFERENCE_ACTUATOR,
        ga: GaSettings::FDI,
        polish: PolishSettings::FDI,
        domain: DomainLimits::REFERENCE_ACTUATOR,
        drive: DriveSettings::TYPICAL,
        detection_threshold: DETECTION_THRESHOLD,
        systematic: SystematicError::REFERENCE_ACTUATOR,
        max_tests: 1,
    };

    /// The tests the noise in a trusted reading of fitness `fitness` [A²·s] calls for:
    /// `⌈fitness / nominal⌉` against the calibration's healthy mismatch (its
    /// `nominal_residual`, which the reported fitness has already taken off), at least 1 and
    /// at most [`Self::max_tests`] (taken within 1 … [`MAX_TESTS`]).
    ///
    /// Why: `n` tests, each with the noise drawn anew, average one test's scatter by `√n`
    /// and bring the noise's share of the mean's residual, `fitness / n`, down to the
    /// model's own mismatch at that `n`; beyond it the mean's error is the model's, which
    /// more tests do not reduce. A fitness at or below the mismatch calls for one test, a
    /// calibration without a mismatch (0) for the most; NaN for one. O(1).
    pub fn tests_called_for(&self, fitness: f32) -> u32 {
        let max = self.max_tests.clamp(1, MAX_TESTS);
        let nominal = self.calibration.nominal_residual;
        if fitness.is_nan() || fitness <= nominal.max(0.0) {
            return 1;
        }
        if nominal <= 0.0 || fitness >= max as f32 * nominal {
            return max;
        }
        // 1 < fitness / nominal < max here: the ratio rounded up.
        let ratio = fitness / nominal;
        let whole = ratio as u32;
        whole + u32::from((whole as f32) < ratio)
    }

    /// The record's bytes. Validate first: encoding does not check ranges.
    pub fn encode(&self) -> [u8; RECORD_BYTES] {
        let mut w = Writer {
            out: [0; RECORD_BYTES],
            at: 0,
        };
        w.bytes(&RECORD_MAGIC);
        w.bytes(&RECORD_VERSION.to_le_bytes());
        w.bytes(&((4 * BODY_WORDS) as u16).to_le_bytes());
        run_words(
            &self.params,
            &self.test,
            &self.calibration,
            &self.ga,
            |word| w.u32(word),
        );
        let d = &self.domain;
        for v in [d.min_travel, d.min_phase_ratio] {
            w.f32(v);
        }
        w.u32(d.min_phase_samples);
        for v in [
            d.min_phase_current,
            d.max_tracking,
            d.max_fitness,
            self.detection_threshold,
            d.bus_voltage[0],
            d.bus_voltage[1],
            d.temperature[0],
            d.temperature[1],
        ] {
            w.f32(v);
        }
        let p = &self.polish;
        for v in [p.iterations, p.probe_iterations, p.probe_count] {
            w.u32(u32::from(v));
        }
        w.f32(p.damping);
        for probe in &p.probes {
            let start = match probe.start {
                ProbeStart::Best => 0,
                ProbeStart::Nominal => 0x100,
                ProbeStart::ScanMinimum => 0x200,
            };
            w.u32(u32::from(probe.component) | start);
            w.f32(probe.level);
        }
        let v = &self.drive;
        w.f32(v.carrier_hz);
        w.f32(v.dead_time);
        w.u32(u32::from(v.compensation));
        w.f32(v.compensation_threshold);
        w.f32(self.calibration.duty_delay);
        w.f32(self.calibration.viscous);
        for v in self.calibration.drag_points {
            w.f32(v);
        }
        let guess = self.ga.initial_guess.unwrap_or([0.0; GENES]);
        for &v in guess.get(PAPER_FAULT_COUNT..).unwrap_or(&[]) {
            w.f32(v);
        }
        w.f32(self.systematic.gain_drift);
        w.f32(self.systematic.play_gain_drift);
        w.f32(self.systematic.gear_temperature_spread);
        w.u32(self.max_tests);
        let mut crc = Crc32::new();
        crc.update(w.out.get(..RECORD_BYTES - 4).unwrap_or(&[]));
        w.bytes(&crc.finish().to_le_bytes());
        w.out
    }

    /// The record in `bytes` (at least one record of its version: [`RECORD_BYTES`], or
    /// [`RECORD_BYTES_V1`]; any more are ignored), checked for damage, version and ranges.
    /// Out of line: inlined into the firmware's start-up it costs 0.6 kB of flash (measured).
    #[inline(never)]
    pub fn decode(bytes: &[u8]) -> Result<Self, ActuatorRecordError> {
        let too_short = ActuatorRecordError::TooShort { found: bytes.len() };
        let Some(head) = bytes.get(..8) else {
            return Err(too_short);
        };
        let mut r = Reader { bytes: head, at: 0 };
        if r.word() != RECORD_MAGIC {
            return Err(ActuatorRecordError::BadMagic);
        }
        let [v0, v1, l0, l1] = r.word();
        let version = u16::from_le_bytes([v0, v1]);
        let Some(&body_words) = usize::from(version)
            .checked_sub(1)
            .and_then(|v| BODY_WORDS_OF_VERSION.get(v))
        else {
            return Err(ActuatorRecordError::UnsupportedVersion { found: version });
        };
        let body_words = usize::from(body_words);
        // Magic, version, length, body, CRC-32 (as `RECORD_BYTES_V*`).
        let total = 8 + 4 * body_words + 4;
        let Some(bytes) = bytes.get(..total) else {
            return Err(too_short);
        };
        let mut r = Reader { bytes, at: 8 };
        let length = u16::from_le_bytes([l0, l1]);
        if usize::from(length) != 4 * body_words {
            return Err(ActuatorRecordError::BadLength { found: length });
        }
        let mut crc = Crc32::new();
        crc.update(bytes.get(..total - 4).unwrap_or(&[]));
        let stored = bytes
            .get(total - 4..)
            .and_then(|b| <[u8; 4]>::try_from(b).ok())
            .map(u32::from_le_bytes);
        if stored != Some(crc.finish()) {
            return Err(ActuatorRecordError::BadChecksum);
        }
        let out_of_range = |field| ActuatorRecordError::OutOfRange { field };
        let params = ActuatorParams::from_words(r.f32s::<PARAM_WORDS>());
        let kind = r.u32();
        let volts = r.f32();
        let [settle, on, off] = [r.u16()?, r.u16()?, r.u16()?];
        let amplitude = r.f32();
        let [ramp, hold] = [r.u16()?, r.u16()?];
        let [chirp_amplitude, end_frequency, duration] = r.f32s::<3>();
        if kind > 7 || (version == 1 && kind > 3) {
            return Err(out_of_range(RecordField::TestDesign));
        }
        let mut test = PreflightTest {
            standstill: (kind & 1 != 0).then_some(StandstillSegment {
                volts,
                frequency: 0.0,
                settle_samples: settle,
                on_samples: on,
                off_samples: off,
            }),
            motion: (kind & 2 != 0).then_some(MotionSegment {
                amplitude,
                ramp_samples: ramp,
                hold_samples: hold,
            }),
            chirp: ChirpCommand {
                amplitude: chirp_amplitude,
                end_frequency,
                duration,
            },
        };
        let [resistance_scale, inductance_scale, back_emf_scale, friction_scale, damping, nominal_residual] =
            r.f32s::<6>();
        let mut calibration = Calibration {
            resistance_scale,
            inductance_scale,
            back_emf_scale,
            friction_scale,
            damping,
            nominal_residual,
            ..Calibration::IDENTITY
        };
        let [max_evaluations, max_generations, stall_generations] = [r.u32(), r.u32(), r.u32()];
        let tournament_size =
            u8::try_from(r.u32()).map_err(|_| out_of_range(RecordField::GaTournamentSize))?;
        let [tolerance, crossover_alpha, mutation_probability, mutation_scale, mutation_floor, differential_probability, differential_scale] =
            r.f32s::<7>();
        let circular_mask = r.u32();
        let mut circular = [false; GENES];
        for (i, c) in circular.iter_mut().enumerate() {
            *c = circular_mask & (1 << i) != 0;
        }
        let has_guess = r.u32();
        // The paper's eight here; the rest at the end (version 8), else nominal.
        let mut guess = *FaultVector::NOMINAL.as_array();
        for g in guess.iter_mut().take(PAPER_FAULT_COUNT) {
            *g = r.f32();
        }
        if version >= 2 {
            let [frequency, pair_r, pair_l, temperature, magnet] = r.f32s::<5>();
            for point in &mut calibration.friction_points {
                *point = r.f32s::<2>();
            }
            if let Some(s) = &mut test.standstill {
                s.frequency = frequency;
            }
            if (kind & 4 != 0) != test.standstill.is_some_and(|s| s.frequency > 0.0) {
                return Err(out_of_range(RecordField::TestInjectionFrequency));
            }
            calibration.pair_resistance_scale = pair_r;
            calibration.pair_inductance_scale = pair_l;
            calibration.temperature = temperature;
            calibration.magnet_coefficient = magnet;
        }
        let [min_travel, min_phase_ratio] = r.f32s::<2>();
        let min_phase_samples = r.u32();
        let [min_phase_current, max_tracking, max_fitness, detection_threshold] = r.f32s::<4>();
        let (bus_voltage, temperature) = if version >= 3 {
            let [bus_low, bus_high, low, high] = r.f32s::<4>();
            ([bus_low, bus_high], [low, high])
        } else {
            DomainLimits::ANY_DAY
        };
        let polish = if version >= 4 {
            let small = |v: u32| u8::try_from(v).map_err(|_| out_of_range(RecordField::Polish));
            let mut p = PolishSettings {
                iterations: small(r.u32())?,
                probe_iterations: small(r.u32())?,
                probe_count: small(r.u32())?,
                damping: r.f32(),
                ..PolishSettings::NONE
            };
            for probe in &mut p.probes {
                let word = r.u32();
                probe.component = (word & 0xFF) as u8;
                probe.start = match word & 0x300 {
                    0 => ProbeStart::Best,
                    0x100 => ProbeStart::Nominal,
                    0x200 => ProbeStart::ScanMinimum,
                    _ => return Err(out_of_range(RecordField::Polish)),
                };
                probe.level = r.f32();
            }
            p
        } else {
            PolishSettings::FDI
        };
        let drive = if version >= 5 {
            let [carrier_hz, dead_time, compensation, compensation_threshold] = r.f32s::<4>();
            DriveSettings {
                carrier_hz,
                dead_time,
                compensation: match compensation.to_bits() {
                    0 => false,
                    1 => true,
                    _ => return Err(out_of_range(RecordField::DriveCompensationThreshold)),
                },
                compensation_threshold,
            }
        } else {
            DriveSettings::TYPICAL
        };
        if version >= 6 {
            calibration.duty_delay = r.f32();
        }
        if version >= 7 {
            calibration.viscous = r.f32();
            for d in &mut calibration.drag_points {
                *d = r.f32();
            }
        }
        if version >= 8 {
            for g in guess.iter_mut().skip(PAPER_FAULT_COUNT) {
                *g = r.f32();
            }
        }
        let mut systematic = SystematicError::REFERENCE_ACTUATOR;
        if version >= 9 {
            systematic.gain_drift = r.f32();
            systematic.play_gain_drift = r.f32();
        }
        if version >= 10 {
            systematic.gear_temperature_spread = r.f32();
        }
        let max_tests = if version >= 11 { r.u32() } else { 1 };
        let ga = GaSettings {
            max_evaluations,
            max_generations,
            stall_generations,
            tolerance,
            tournament_size,
            crossover_alpha,
            mutation_probability,
            mutation_scale,
            mutation_floor,
            differential_probability,
            differential_scale,
            circular,
            initial_guess: (has_guess != 0).then_some(guess),
        };
        let record = Self {
            params,
            test,
            calibration,
            ga,
            polish,
            drive,
            domain: DomainLimits {
                min_travel,
                min_phase_ratio,
                min_phase_samples,
                min_phase_current,
                max_tracking,
                max_fitness,
                bus_voltage,
                temperature,
            },
            detection_threshold,
            systematic,
            max_tests,
        };
        record.validate()?;
        Ok(record)
    }

    /// Refuses values outside their physical or working range, naming the first one as
    /// `section.key` of the actuator description file. O(1); written as loops over tables
    /// so that it stays small in flash.
    pub fn validate(&self) -> Result<(), ActuatorRecordError> {
        let p = &self.params;
        let c = &self.calibration;
        let d = &self.domain;
        let t = &self.test;
        let fail = |field| Err(ActuatorRecordError::OutOfRange { field });
        let positive: [(f32, RecordField); 26] = [
            (p.dc_bus_voltage, RecordField::MotorDcBusVoltage),
            (p.phase_resistance, RecordField::MotorPhaseResistance),
            (p.phase_inductance, RecordField::MotorPhaseInductance),
            (p.back_emf_constant, RecordField::MotorBackEmfConstant),
            (p.max_current, RecordField::MotorMaxCurrent),
            (p.motor_inertia, RecordField::MechanicsMotorInertia),
            (p.user_inertia, RecordField::MechanicsUserInertia),
            (p.gear_ratio, RecordField::MechanicsGearRatio),
            (p.gear_stiffness, RecordField::MechanicsGearStiffness),
            (p.nominal_backlash, RecordField::MechanicsNominalBacklash),
            (p.static_friction, RecordField::MechanicsStaticFriction),
            (p.dynamic_friction, RecordField::MechanicsDynamicFriction),
            (p.stick_speed, RecordField::MechanicsStickSpeed),
            (p.position_kp, RecordField::ControllerPositionKp),
            (p.max_speed, RecordField::ControllerMaxSpeed),
            (p.speed_kp, RecordField::ControllerSpeedKp),
            (p.control_period, RecordField::ControllerControlPeriod),
            (t.chirp.amplitude, RecordField::TestChirpAmplitude),
            (t.chirp.end_frequency, RecordField::TestChirpEndFrequency),
            (t.chirp.duration, RecordField::TestChirpDuration),
            (c.resistance_scale, RecordField::CalibrationResistanceScale),
            (
                c.pair_resistance_scale,
                RecordField::CalibrationPairResistanceScale,
            ),
            (
                c.pair_inductance_scale,
                RecordField::CalibrationPairInductanceScale,
            ),
            (c.inductance_scale, RecordField::CalibrationInductanceScale),
            (c.back_emf_scale, RecordField::CalibrationBackEmfScale),
            (c.friction_scale, RecordField::CalibrationFrictionScale),
        ];
        if let Some(field) = first_outside(&positive, false) {
            return fail(field);
        }
        let non_negative: [(f32, RecordField); 16] = [
            (p.gear_damping, RecordField::MechanicsGearDamping),
            (p.aero_stiffness, RecordField::MechanicsAeroStiffness),
            (p.position_ki, RecordField::ControllerPositionKi),
            (p.position_kd, RecordField::ControllerPositionKd),
            (p.speed_ki, RecordField::ControllerSpeedKi),
            (c.damping, RecordField::CalibrationDamping),
            (c.nominal_residual, RecordField::CalibrationNominalResidual),
            (c.viscous, RecordField::CalibrationViscous),
            (d.min_travel, RecordField::DomainMinTravel),
            (d.min_phase_ratio, RecordField::DomainMinPhaseRatio),
            (d.min_phase_current, RecordField::DomainMinPhaseCurrent),
            (d.max_tracking, RecordField::DomainMaxTracking),
            (
                self.drive.compensation_threshold,
                RecordField::DriveCompensationThreshold,
            ),
            (
                self.systematic.gain_drift,
                RecordField::UncertaintyGainDriftSystematic,
            ),
            (
                self.systematic.play_gain_drift,
                RecordField::UncertaintyPlayGainDriftSystematic,
            ),
            (
                self.systematic.gear_temperature_spread,
                RecordField::UncertaintyGearTemperatureSpread,
            ),
        ];
        if let Some(field) = first_outside(&non_negative, true) {
            return fail(field);
        }
        let whole_pole_pairs = p.pole_pairs >= 1.0 && p.pole_pairs <= 64.0 && {
            let n = p.pole_pairs as u32;
            n as f32 == p.pole_pairs
        };
        let v = &self.drive;
        let others: [(bool, RecordField); 23] = [
            (
                (1..=MAX_TESTS).contains(&self.max_tests),
                RecordField::TestMaxTests,
            ),
            (
                t.standstill.is_none_or(|s| {
                    s.frequency.is_finite()
                        && s.frequency >= 0.0
                        && s.frequency * p.control_period <= 0.125
                }),
                RecordField::TestInjectionFrequency,
            ),
            (
                c.temperature.is_finite() && (-80.0..=200.0).contains(&c.temperature),
                RecordField::CalibrationTemperature,
            ),
            (
                // Rising in temperature, unused points (factor 0) last.
                c.friction_points.windows(2).all(|w| match w {
                    [[t0, f0], [t1, f1]] => *f1 == 0.0 || (*f0 > 0.0 && t1 > t0),
                    _ => true,
                }) && c.friction_points.iter().all(|[t, f]| {
                    t.is_finite()
                        && (-80.0..=200.0).contains(t)
                        && f.is_finite()
                        && (0.0..=20.0).contains(f)
                }),
                RecordField::CalibrationFrictionPoints,
            ),
            (
                c.magnet_coefficient.is_finite() && c.magnet_coefficient.abs() <= 0.01,
                RecordField::CalibrationMagnetCoefficient,
            ),
            (
                c.duty_delay >= 0.0 && c.duty_delay <= p.control_period,
                RecordField::CalibrationDutyDelay,
            ),
            (drag_points_fall(c), RecordField::CalibrationDragPoints),
            (whole_pole_pairs, RecordField::MotorPolePairs),
            (
                p.winding_group_angle
                    .iter()
                    .all(|a| a.is_finite() && a.abs() <= 7.0),
                RecordField::MotorWindingGroupAngleDeg,
            ),
            (
                p.dynamic_friction <= p.static_friction,
                RecordField::MechanicsDynamicFriction,
            ),
            (
                p.encoder_offset.is_finite() && p.encoder_offset.abs() <= 1.0e4,
                RecordField::InstallationEncoderOffset,
            ),
            (
                p.control_period <= 1.0e-2,
                RecordField::ControllerControlPeriod,
            ),
            (
                t.standstill.is_none_or(|s| {
                    s.volts.is_finite()
                        && s.volts > 0.0
                        && s.volts <= p.dc_bus_voltage
                        && s.on_samples > 0
                }),
                RecordField::TestStandstillVolts,
            ),
            (
                t.motion.is_none_or(|m| {
                    m.amplitude.is_finite() && m.amplitude > 0.0 && m.ramp_samples > 0
                }),
                RecordField::TestMotionAmplitude,
            ),
            (
                t.chirp.end_frequency * p.control_period < 0.1,
                RecordField::TestChirpEndFrequency,
            ),
            (
                t.samples(p.control_period) <= TEST_SAMPLES,
                RecordField::TestChirpDuration,
            ),
            (
                d.max_fitness.is_finite() && d.max_fitness > 0.0,
                RecordField::DomainMaxFitness,
            ),
            (
                d.bus_voltage[0] <= d.bus_voltage[1],
                RecordField::DomainBusVoltage,
            ),
            (self.polish.check(), RecordField::Polish),
            (v.carrier_valid(), RecordField::DriveCarrierHz),
            (v.dead_time_valid(), RecordField::DriveDeadTime),
            (
                d.temperature[0] <= d.temperature[1],
                RecordField::DomainTemperature,
            ),
            (
                self.detection_threshold > 0.0 && self.detection_threshold < 1.0,
                RecordField::DetectionThreshold,
            ),
        ];
        for (ok, field) in others {
            if !ok {
                return fail(field);
            }
        }
        if self.ga.check(POPULATION).is_err() {
            return fail(RecordField::Ga);
        }
        Ok(())
    }
}

/// The words of what defines one identification run — parameters, test, calibration, GA
/// settings — in record order (f32 as their bits). One list for the record's body and the
/// checkpoint fingerprint ([`crate::preflight::fdi::Identification::fingerprint`]). O(1).
pub(crate) fn run_words(
    params: &ActuatorParams,
    test: &PreflightTest,
    calibration: &Calibration,
    ga: &GaSettings,
    mut word: impl FnMut(u32),
) {
    let f32s = |values: &[f32], word: &mut dyn FnMut(u32)| {
        for v in values {
            word(v.to_bits());
        }
    };
    f32s(&params.to_words(), &mut word);
    let t = test;
    word(u32::from(t.kind()));
    let s = t.standstill.unwrap_or(StandstillSegment::DEFAULT);
    word(s.volts.to_bits());
    for v in [s.settle_samples, s.on_samples, s.off_samples] {
        word(u32::from(v));
    }
    let m = t.motion.unwrap_or(MotionSegment::DEFAULT);
    word(m.amplitude.to_bits());
    word(u32::from(m.ramp_samples));
    word(u32::from(m.hold_samples));
    let c = calibration;
    f32s(
        &[
            t.chirp.amplitude,
            t.chirp.end_frequency,
            t.chirp.duration,
            c.resistance_scale,
            c.inductance_scale,
            c.back_emf_scale,
            c.friction_scale,
            c.damping,
            c.nominal_residual,
        ],
        &mut word,
    );
    let g = ga;
    for v in [g.max_evaluations, g.max_generations, g.stall_generations] {
        word(v);
    }
    word(u32::from(g.tournament_size));
    f32s(
        &[
            g.tolerance,
            g.crossover_alpha,
            g.mutation_probability,
            g.mutation_scale,
            g.mutation_floor,
            g.differential_probability,
            g.differential_scale,
        ],
        &mut word,
    );
    word(
        g.circular
            .iter()
            .enumerate()
            .fold(0u32, |m, (i, &c)| m | (u32::from(c) << i)),
    );
    word(u32::from(g.initial_guess.is_some()));
    // The paper's eight components of the guess (the ninth ends the record, version 8).
    let guess = g.initial_guess.unwrap_or([0.0; GENES]);
    f32s(guess.get(..PAPER_FAULT_COUNT).unwrap_or(&[]), &mut word);
    // Version 2: the day's words.
    f32s(
        &[
            s.frequency,
            c.pair_resistance_scale,
            c.pair_inductance_scale,
            c.temperature,
            c.magnet_coefficient,
        ],
        &mut word,
    );
    for point in &c.friction_points {
        f32s(point, &mut word);
    }
}

impl Default for ActuatorRecord {
    fn default() -> Self {
        Self::REFERENCE
    }
}

const _: () = assert!(FAULT_COUNT == GENES);

/// Whether the calibration's drag points are each in 0 … 100 and, with a friction law by drag
/// (`viscous` above 0), above 0 and falling as the used friction points' temperatures rise
/// (`shared::conditions::friction_factor_by_drag` reads them in reverse).
fn drag_points_fall(c: &Calibration) -> bool {
    let mut above = f32::INFINITY;
    let mut ok = true;
    for (point, &drag) in c.friction_points.iter().zip(&c.drag_points) {
        ok &= (0.0..=100.0).contains(&drag);
        if c.viscous > 0.0 && point[1] > 0.0 {
            ok &= drag > 0.0 && drag < above;
            above = drag;
        }
    }
    ok
}

/// The first value that is not finite and positive (or zero, with `zero_allowed`). Kept out
/// of line so that the checks stay a loop in flash, not 35 unrolled copies.
#[inline(never)]
fn first_outside(values: &[(f32, RecordField)], zero_allowed: bool) -> Option<RecordField> {
    values
        .iter()
        .find(|(v, _)| !(v.is_finite() && (*v > 0.0 || zero_allowed && *v == 0.0)))
        .map(|&(_, field)| field)
}

struct Writer {
    out: [u8; RECORD_BYTES],
    at: usize,
}

impl Writer {
    fn bytes(&mut self, b: &[u8]) {
        if let Some(dst) = self.out.get_mut(self.at..self.at + b.len()) {
            dst.copy_from_slice(b);
        }
        self.at += b.len();
    }
    fn f32(&mut self, v: f32) {
        self.bytes(&v.to_bits().to_le_bytes());
    }
    fn u32(&mut self, v: u32) {
        self.bytes(&v.to_le_bytes());
    }
}

/// Reads words in order; past the end it reads zeros (the length was checked before).
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn word(&mut self) -> [u8; 4] {
        let w = self
            .bytes
            .get(self.at..self.at + 4)
            .and_then(|b| <[u8; 4]>::try_from(b).ok())
            .unwrap_or([0; 4]);
        self.at += 4;
        w
    }
    /// Out of line: a record reads 85 words, and one copy keeps decoding small in flash.
    #[inline(never)]
    fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.word())
    }
    fn u16(&mut self) -> Result<u16, ActuatorRecordError> {
        u16::try_from(self.u32()).map_err(|_| ActuatorRecordError::OutOfRange {
            field: RecordField::TestSegmentSamples,
        })
    }
    fn f32(&mut self) -> f32 {
        f32::from_bits(self.u32())
    }
    fn f32s<const K: usize>(&mut self) -> [f32; K] {
        let mut out = [0.0; K];
        self.fill(&mut out);
        out
    }
    /// Not generic, so that one copy serves every length (flash).
    #[inline(never)]
    fn fill(&mut self, out: &mut [f32]) {
        for v in out {
            *v = self.f32();
        }
    }
}

#[cfg(test)]
mod tests;
