//! The actuator description file (TOML, human-edited) and the actuator record it becomes.
//!
//! One file describes one actuator: motor, mechanics, controller, installation (the
//! rigging's encoder offset), the preflight test, GA settings, detection threshold, domain
//! limits, optionally its calibration, the sensors and extra physics the reference model
//! plays, and how a rig recording names its columns. Commented examples:
//! `actuators/reference.toml` (this project's reference actuator, bit for bit the built-in
//! one) and `actuators/light-28v.toml`. Units are SI, angles in the file are in degrees
//! where the key says `_deg`.
//!
//! Every command of `host-sim` takes `--actuator FILE`: a description (`.toml`) or a record
//! (`host-sim actuator FILE.toml --out unit.rec`, what the firmware loads), told apart by the
//! record's magic bytes. A bad file is refused with the key and its line; values outside
//! their range are refused by the record's own check ([`ActuatorRecord::validate`]), so the
//! file and the flashed record accept exactly the same actuators.

use std::collections::BTreeMap;
use std::f64::consts::PI;
use std::path::Path;

use anyhow::{anyhow, bail, Context, Result};
use serde::Deserialize;
use shared::actuator::{ActuatorRecord, ActuatorRecordError, RECORD_MAGIC};
use shared::command::ChirpCommand;
use shared::domain::DomainLimits;
use shared::polish::{PolishSettings, Probe, ProbeStart, MAX_PROBES};
use shared::test_design::{PreflightTest, StandstillSegment};
use shared::uncertainty::SystematicError;
use shared::{ActuatorParams, Calibration, GaSettings};

use crate::plant::aero::SurfaceAerodynamics;
use crate::plant::bridge::{
    BridgeSettings, ConditionSensors, OperatingConditions, ThermalLaws, ViscosityLaw,
};
use crate::plant::reference::{EccentricityPhysics, ReferenceSettings};

/// One actuator as the ground tools use it: the record the firmware would load, what the
/// reference model needs beyond it, and the rig's column names.
#[derive(Clone, Debug, PartialEq)]
pub struct Actuator {
    /// What the file calls it (`name`), or the record's file name.
    pub name: String,
    pub record: ActuatorRecord,
    /// Whether the record holds a calibration (`[calibration]` or `host-sim calibrate`);
    /// without one the FDI cannot run.
    pub calibrated: bool,
    /// The reference model's settings when it plays this actuator (its `params` are the
    /// record's); `None` for a record, which holds only what the FDI needs.
    pub reference: Option<ReferenceSettings>,
    /// How a rig recording of this actuator names its columns (`[rig]`), if the file says.
    pub rig: Option<RigColumns>,
    /// Whether this is the built-in reference actuator (no `--actuator`).
    pub built_in: bool,
    /// The file it was loaded from.
    pub source: Option<std::path::PathBuf>,
    /// Whether the preflight's systematic error is this actuator's own: the description
    /// states both `[uncertainty]` values, or this is a record (it carries its values) or
    /// the built-in actuator. False: the reference actuator's values stand in for one or
    /// both, which fit only an actuator like it (README step 4 surveys its own).
    pub systematic_stated: bool,
}

/// A rig recording's column names and unit scales (value in SI = recorded value × scale).
#[derive(Clone, Debug, PartialEq, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RigColumns {
    /// Our column (`t`, `theta_cmd`, `i_a`, `i_b`, `i_c`, `theta_m`, `theta_u`) → the rig's.
    #[serde(default)]
    pub columns: BTreeMap<String, String>,
    /// Our column → multiplier to SI units (e.g. `t = 1e-3` for milliseconds).
    #[serde(default)]
    pub scales: BTreeMap<String, f64>,
}

impl Actuator {
    /// This project's reference actuator with the default test (what no `--actuator` means).
    pub fn reference() -> Self {
        Self {
            name: "built-in reference actuator".to_string(),
            record: ActuatorRecord::REFERENCE,
            calibrated: true,
            reference: Some(ReferenceSettings::REFERENCE),
            rig: None,
            built_in: true,
            source: None,
            systematic_stated: true,
        }
    }

    /// `--actuator`: the built-in reference actuator for `None`, else the file.
    pub fn from_option(path: Option<&Path>) -> Result<Self> {
        match path {
            None => Ok(Self::reference()),
            Some(p) => Self::load(p),
        }
    }

    /// A description (TOML) or a record (binary), by content.
    pub fn load(path: &Path) -> Result<Self> {
        let bytes = std::fs::read(path)
            .with_context(|| format!("cannot read actuator file {}", path.display()))?;
        if bytes.starts_with(&RECORD_MAGIC) {
            let record = ActuatorRecord::decode(&bytes).map_err(|e| {
                anyhow!(
                    "{}: actuator record refused: {}",
                    path.display(),
                    describe(e)
                )
            })?;
            return Ok(Self {
                name: path.file_stem().map_or_else(
                    || "record".to_string(),
                    |s| s.to_string_lossy().into_owned(),
                ),
                record,
                calibrated: record.calibration != Calibration::IDENTITY,
                reference: None,
                rig: None,
                built_in: false,
                source: Some(path.to_path_buf()),
                systematic_stated: true,
            });
        }
        let text = String::from_utf8(bytes).map_err(|_| {
            anyhow!(
                "{}: neither an actuator record nor UTF-8 text",
                path.display()
            )
        })?;
        let mut actuator = Self::parse(&text)
            .with_context(|| format!("actuator description {}", path.display()))?;
        actuator.source = Some(path.to_path_buf());
        Ok(actuator)
    }

    /// A description's text.
    pub fn parse(text: &str) -> Result<Self> {
        let d: Description = toml::from_str(text).map_err(|e| anyhow!("{e}"))?;
        let actuator = d.build();
        if let Some(field) = actuator.reference.as_ref().and_then(check_day) {
            let at = line_of(text, field).map_or(String::new(), |l| format!(" (line {l})"));
            bail!("`{field}`{at}: {}", range_text(field));
        }
        if let Err(e) = actuator.record.validate() {
            let ActuatorRecordError::OutOfRange { field } = e else {
                bail!("{}", describe(e));
            };
            let field = field.key();
            let at = line_of(text, field).map_or(String::new(), |l| format!(" (line {l})"));
            bail!("`{field}`{at}: {}", range_text(field));
        }
        if let Some(rig) = &actuator.rig {
            for key in rig.columns.keys().chain(rig.scales.keys()) {
                let ours = |h: &[&str]| h.contains(&key.as_str());
                if !ours(&crate::files::trace::CSV_HEADER)
                    && !ours(&crate::files::trace::CONDITION_HEADER)
                {
                    let at =
                        line_of_key(text, key).map_or(String::new(), |l| format!(" (line {l})"));
                    bail!(
                        "`rig`{at}: unknown column `{key}` (ours are {})",
                        crate::files::trace::CSV_HEADER.join(", ")
                    );
                }
            }
        }
        Ok(actuator)
    }

    /// The record's bytes (what `host-sim actuator --out` writes and the firmware loads).
    pub fn record_bytes(&self) -> [u8; shared::actuator::RECORD_BYTES] {
        self.record.encode()
    }

    /// The test a trace of this actuator was recorded with: the record's, if the trace's
    /// kind (which segments it has) is the record's; the built-in actuator follows the trace.
    pub fn test_for(&self, trace_test: &PreflightTest) -> Result<PreflightTest> {
        if self.built_in {
            return Ok(*trace_test);
        }
        if trace_test.kind() != self.record.test.kind() {
            return Err(ActuatorRefused(format!(
                "the trace played the {} test, the actuator {} commands the {} test",
                trace_test.kind_name(),
                self.name,
                self.record.test.kind_name()
            ))
            .into());
        }
        Ok(self.record.test)
    }

    /// The calibration the FDI uses for `test`; an error for an uncalibrated actuator.
    pub fn calibration_for(&self, test: &PreflightTest) -> Result<Calibration> {
        if self.built_in {
            return Ok(Calibration::reference_actuator(test));
        }
        if !self.calibrated {
            return Err(ActuatorRefused(format!(
                "the actuator {} has no calibration: run `host-sim calibrate HEALTHY_TRACE \
                 --actuator FILE --out unit.rec` (or add a [calibration] section)",
                self.name
            ))
            .into());
        }
        Ok(self.record.calibration)
    }

    /// This actuator with its test replaced by the built-in design `test` (`--test`); only
    /// the built-in actuator can switch, a file's test is its own.
    pub fn with_test_choice(mut self, test: Option<PreflightTest>) -> Result<Self> {
        let Some(test) = test else {
            return Ok(self);
        };
        if self.built_in {
            self.record.test = test;
            self.record.calibration = Calibration::reference_actuator(&test);
            Ok(self)
        } else if test.kind() == self.record.test.kind() {
            Ok(self)
        } else {
            Err(ActuatorRefused(format!(
                "--test {} disagrees with the actuator file, whose test is {} (edit its [test])",
                test.kind_name(),
                self.record.test.kind_name()
            ))
            .into())
        }
    }

    pub fn params(&self) -> ActuatorParams {
        self.record.params
    }

    /// The reference model's settings for this actuator; a record has none (it holds what
    /// the FDI needs, not the simulated sensors and physics).
    pub fn reference_settings(&self) -> Result<ReferenceSettings> {
        self.reference.ok_or_else(|| {
            ActuatorRefused(format!(
                "{} is an actuator record: the reference model needs the description (TOML); \
                 put the calibration into it with `host-sim calibrate HEALTHY --actuator \
                 FILE.toml --out CALIBRATED.toml`",
                self.name
            ))
            .into()
        })
    }

    /// The description `text` with its `[calibration]` section replaced by `calibration`
    /// (appended when it has none); every other line, comments included, is kept.
    pub fn with_calibration_text(text: &str, calibration: &Calibration) -> String {
        let mut out = String::new();
        let mut skipping = false;
        for line in text.lines() {
            let t = line.trim();
            if t.starts_with('[') {
                skipping = t == "[calibration]";
            }
            if !skipping {
                out += line;
                out.push('\n');
            }
        }
        let mut out = out.trim_end().to_string();
        out.push('\n');
        let c = calibration;
        out += &format!(
            "\n[calibration]\n# Written by `host-sim calibrate`.\nresistance_scale = {:?}\ninductance_scale = {:?}\nback_emf_scale = {:?}\nfriction_scale = {:?}\ndamping = {:?}\nnominal_residual = {:?}\npair_resistance_scale = {:?}\npair_inductance_scale = {:?}\ntemperature = {:?}              # °C, measured during the healthy trace\nmagnet_coefficient = {:?}       # 1/K, flux against temperature (the magnets' data sheet)\n# [°C, factor]: the healthy friction at other temperatures (`calibrate --at`).\nfriction_points = [{}]\n",
            c.resistance_scale,
            c.inductance_scale,
            c.back_emf_scale,
            c.friction_scale,
            c.damping,
            c.nominal_residual,
            c.pair_resistance_scale,
            c.pair_inductance_scale,
            c.temperature,
            c.magnet_coefficient,
            c.friction_points
                .iter()
                .filter(|p| p[1] > 0.0)
                .map(|p| format!("[{:?}, {:?}]", p[0], p[1]))
                .collect::<Vec<_>>()
                .join(", ")
        );
        if c.viscous > 0.0 {
            out += &format!(
                "# The grease's drag (`calibrate --at`): the chirp's viscous drag on the healthy \
                 trace, and at each friction point against it.\nviscous = {:?}\ndrag_points = [{}]\n",
                c.viscous,
                c.friction_points
                    .iter()
                    .zip(&c.drag_points)
                    .filter(|(p, _)| p[1] > 0.0)
                    .map(|(_, d)| format!("{d:?}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
        out
    }

    /// The description `text` with `section.key` set to `value` (the line replaced, its
    /// comment dropped); `None` when the file does not set that key.
    pub fn with_key_text(text: &str, field: &str, value: &str) -> Option<String> {
        let line = line_of(text, field)?;
        let key = field.split_once('.').map_or(field, |(_, k)| k);
        Some(
            text.lines()
                .enumerate()
                .map(|(n, l)| {
                    if n + 1 == line {
                        format!("{key} = {value}\n")
                    } else {
                        format!("{l}\n")
                    }
                })
                .collect(),
        )
    }

    /// The trace at `path`, its test resolved against this actuator ([`Self::test_for`]); a
    /// window of flight carries the actuator's chirp alone, whatever its preflight test.
    pub fn read_trace(&self, path: &Path) -> Result<crate::files::trace::Trace> {
        let trace = crate::files::trace::Trace::read(path)?;
        let test = if trace.is_flight() {
            self.flight_test(trace.test())
        } else {
            self.test_for(trace.test())?
        };
        Ok(trace.with_test(test))
    }

    /// The test a window of flight of this actuator carries: the record's chirp alone (the
    /// built-in actuator follows the trace).
    fn flight_test(&self, trace_test: &PreflightTest) -> PreflightTest {
        if self.built_in {
            *trace_test
        } else {
            self.record.test.chirp_only()
        }
    }

    /// The record with the calibration for `test` (the built-in actuator has one per test).
    pub fn record_for(&self, test: &PreflightTest) -> Result<ActuatorRecord> {
        Ok(ActuatorRecord {
            calibration: self.calibration_for(test)?,
            test: *test,
            ..self.record
        })
    }

    /// The installation rigged at `offset` [rad, motor side] (`--encoder-offset`): the
    /// reference model plays it and the record carries it, as measured at rigging.
    pub fn with_encoder_offset(mut self, offset: Option<f64>) -> Self {
        if let Some(x) = offset {
            self.record.params.encoder_offset = x as f32;
            if let Some(r) = &mut self.reference {
                r.params.encoder_offset = x as f32;
                r.encoder_offset = x;
            }
        }
        self
    }

    /// The simulated actuator on another day or drive (`--temperature`, `--bus-voltage`,
    /// …): the reference model plays it; the FDI's record is unchanged. Refused for a
    /// record (it has no reference model) and for values out of their range.
    pub fn with_day(mut self, day: Day) -> Result<Self> {
        if day == Day::default() {
            return Ok(self);
        }
        let mut r = self.reference_settings()?;
        if let Some(t) = day.temperature {
            r.conditions.winding_temperature = t;
            r.conditions.gear_temperature = t;
        }
        if let Some(t) = day.gear_temperature {
            r.conditions.gear_temperature = t;
        }
        if let Some(v) = day.bus_voltage {
            r.conditions.bus_voltage = Some(v);
        }
        if let Some(d) = day.dead_time {
            r.bridge.dead_time = d;
        }
        if let Some(d) = day.duty_delay {
            r.bridge.duty_delay = d;
        }
        if let Some(e) = day.eccentricity {
            r.eccentricity = e;
        }
        if day.two_part_grease && r.thermal.grease_drag == 0.0 {
            r.thermal = r.thermal.with_two_part_grease(&r.params);
        }
        if let Some(field) = check_day(&r) {
            bail!("{field}: {}", range_text(field));
        }
        self.reference = Some(r);
        Ok(self)
    }

    /// Refuses a command that runs on the built-in reference actuator only.
    pub fn built_in_only(&self, command: &str) -> Result<()> {
        if self.built_in {
            Ok(())
        } else {
            Err(ActuatorRefused(format!(
                "`{command}` runs on the built-in reference actuator only (its cases and \
                 settings are tuned to it); drop --actuator"
            ))
            .into())
        }
    }
}

/// Overrides of the day and drive a simulation plays (`None`: the actuator file's).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Day {
    /// Winding and gear temperature [°C].
    pub temperature: Option<f64>,
    /// Gear temperature alone [°C].
    pub gear_temperature: Option<f64>,
    /// Mean bus voltage [V].
    pub bus_voltage: Option<f64>,
    /// Bridge dead time [s].
    pub dead_time: Option<f64>,
    /// The controller's duty delay [s] (`[drive] duty_delay`).
    pub duty_delay: Option<f64>,
    /// The eccentricity physics the reference model plays.
    pub eccentricity: Option<EccentricityPhysics>,
    /// A two-part grease ([`ThermalLaws::with_two_part_grease`]) where the file's grease
    /// is one factor.
    pub two_part_grease: bool,
}

/// The first `[drive]`, `[conditions]` or thermal value of `r` out of its range, named as
/// the file names it.
fn check_day(r: &ReferenceSettings) -> Option<&'static str> {
    let b = &r.bridge;
    let c = &r.conditions;
    let t = &r.thermal;
    let period = 1.0 / b.carrier_hz;
    let control_period = f64::from(r.params.control_period);
    let a = &r.surface;
    let checks: [(bool, &'static str); 21] = [
        (
            b.carrier_hz >= 1.0e3 && b.carrier_hz <= 2.0e5,
            "drive.carrier_hz",
        ),
        (
            b.timer_hz == 0.0 || b.timer_hz >= 2.0 * b.carrier_hz,
            "drive.timer_hz",
        ),
        (
            b.dead_time >= 0.0 && b.dead_time < 0.1 * period,
            "drive.dead_time",
        ),
        (
            b.compensation_threshold >= 0.0,
            "drive.compensation_threshold",
        ),
        (
            (0.0..1.0).contains(&b.switch_resistance),
            "drive.switch_resistance",
        ),
        ((0.0..5.0).contains(&b.diode_drop), "drive.diode_drop"),
        (
            (0.0..1.0).contains(&b.harness_resistance),
            "drive.harness_resistance",
        ),
        ((0.0..0.2).contains(&b.ripple), "drive.bus_ripple"),
        (b.ripple_hz >= 0.0, "drive.bus_ripple_hz"),
        (
            b.duty_delay >= 0.0 && b.duty_delay <= control_period * (1.0 + 1e-6),
            "drive.duty_delay",
        ),
        (
            (-80.0..=200.0).contains(&c.winding_temperature),
            "conditions.temperature",
        ),
        (
            (-80.0..=200.0).contains(&c.gear_temperature),
            "conditions.gear_temperature",
        ),
        (
            c.bus_voltage.is_none_or(|v| v > 0.0 && v < 2000.0),
            "conditions.bus_voltage",
        ),
        (
            (0.0..1.0).contains(&t.friction_viscous_share)
                && (0.0..10_000.0).contains(&t.friction_activation),
            "reference_model.friction_viscous_share",
        ),
        (
            t.copper.abs() < 0.02 && t.magnet.abs() < 0.02,
            "reference_model.copper_coefficient",
        ),
        (
            (0.0..0.1).contains(&t.grease_drag),
            "reference_model.grease_drag",
        ),
        (
            (0.0..=1.0).contains(&t.coulomb_exponent),
            "reference_model.coulomb_exponent",
        ),
        (a.area > 0.0 && a.area < 1.0e3, "surface.area"),
        (a.chord > 0.0 && a.chord < 100.0, "surface.chord"),
        (
            a.air_density > 0.0 && a.air_density < 10.0,
            "surface.air_density",
        ),
        (
            [a.ch0, a.ch_alpha, a.ch_delta, a.parked_incidence]
                .iter()
                .all(|c| c.abs() < 10.0),
            "surface.ch0",
        ),
    ];
    checks
        .into_iter()
        .find(|(ok, _)| !ok)
        .map(|(_, field)| field)
}

/// The actuator and what it is asked to do disagree (another test kind, no calibration):
/// `host-sim` exits with status 7, as for a refused file.
#[derive(Debug)]
pub struct ActuatorRefused(pub String);

impl std::fmt::Display for ActuatorRefused {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for ActuatorRefused {}

/// A record error in words.
pub fn describe(e: ActuatorRecordError) -> String {
    match e {
        ActuatorRecordError::TooShort { found } => format!(
            "{found} bytes, a record has {}",
            shared::actuator::RECORD_BYTES
        ),
        ActuatorRecordError::BadMagic => "not an actuator record".to_string(),
        ActuatorRecordError::UnsupportedVersion { found } => format!(
            "version {found}, this build reads version {}",
            shared::actuator::RECORD_VERSION
        ),
        ActuatorRecordError::BadLength { found } => {
            format!("body length {found} does not match its version")
        }
        ActuatorRecordError::BadChecksum => "damaged (CRC-32 mismatch)".to_string(),
        ActuatorRecordError::OutOfRange { field } => {
            format!("`{}`: {}", field.key(), range_text(field.key()))
        }
    }
}

fn range_text(field: &str) -> &'static str {
    match field {
        "motor.pole_pairs" => "must be a whole number from 1 to 64",
        "mechanics.dynamic_friction" => "must be positive and at most the static friction",
        "controller.control_period" => "must be positive and at most 10 ms",
        "test.standstill_volts" => "must be positive, at most the DC bus, with on_samples > 0",
        "test.chirp_end_frequency" => "must be positive and below a tenth of the control rate",
        "test.chirp_duration" => {
            "must be positive, and the whole test must fit the onboard buffer (5520 samples)"
        }
        "installation.encoder_offset" => "must be finite (|offset| ≤ 10⁴ rad)",
        "test.max_tests" => "must be a whole number from 1 to 8",
        "ga" => "GA settings the flown solver cannot run (rates in [0, 1], sizes ≥ 1)",
        "detection.threshold" => "must be in (0, 1)",
        "domain.bus_voltage" | "domain.temperature" => "must be [low, high] with low ≤ high",
        "polish" => {
            "at most 64 steps per leg and 6 probes, each a fault component other than ecc_phase \
             (friction, backlash, short_a, short_b, short_c, eccentricity, gain_drift) at a level \
             in [0, 1] from \"best\" or \"nominal\"; damping positive"
        }
        "drive.carrier_hz" => "must be from 1 kHz to 200 kHz",
        "drive.timer_hz" => "must be 0 (continuous duty) or at least twice the carrier",
        "drive.dead_time" => "must be at least 0 and below a tenth of the carrier period",
        "drive.switch_resistance" | "drive.harness_resistance" => "must be in [0, 1) Ω",
        "drive.diode_drop" => "must be in [0, 5) V",
        "drive.bus_ripple" => "must be in [0, 0.2) of the bus",
        "drive.duty_delay" => "must be from 0 to one control period ([controller] control_period)",
        "reference_model.grease_drag" => "must be in [0, 0.1) N·m·s/rad (0: the one-factor grease)",
        "reference_model.coulomb_exponent" => "must be in [0, 1]: a power of the oil's viscosity",
        "conditions.temperature" | "conditions.gear_temperature" => "must be from −80 °C to 200 °C",
        "conditions.bus_voltage" => "must be positive and below 2 000 V",
        "reference_model.friction_viscous_share" => {
            "share must be in [0, 1) and the activation temperature in [0, 10 000) K"
        }
        "reference_model.copper_coefficient" => "coefficients must be below 0.02 /K in size",
        "surface.area" => "must be in (0, 1 000) m²",
        "surface.chord" => "must be in (0, 100) m",
        "surface.air_density" => "must be in (0, 10) kg/m³",
        "surface.ch0" => {
            "the hinge-moment coefficients (per rad) and the parked incidence (rad) must be finite \
             and below 10 in size"
        }
        f if f.ends_with("_ki")
            || f.ends_with("_kd")
            || f.ends_with("damping")
            || f.ends_with("aero_stiffness")
            || f.ends_with("nominal_residual")
            || f.starts_with("uncertainty.")
            || (f.starts_with("domain.") && f != "domain.max_fitness") =>
        {
            "must be finite and not negative"
        }
        _ => "must be finite and positive",
    }
}

/// The 1-based line of `section.key` in `text` (the section header's for a bare section).
fn line_of(text: &str, field: &str) -> Option<usize> {
    let (section, key) = field.split_once('.').unwrap_or((field, ""));
    let mut in_section = false;
    for (n, line) in text.lines().enumerate() {
        let t = line.trim();
        if t.starts_with('[') {
            in_section = t.trim_matches(|c| c == '[' || c == ']').trim() == section;
            if in_section && key.is_empty() {
                return Some(n + 1);
            }
            continue;
        }
        if in_section && !key.is_empty() {
            if let Some((k, _)) = t.split_once('=') {
                if k.trim() == key {
                    return Some(n + 1);
                }
            }
        }
    }
    None
}

/// The 1-based line where `key` is set anywhere in `text`.
fn line_of_key(text: &str, key: &str) -> Option<usize> {
    text.lines()
        .position(|l| {
            l.trim()
                .split_once('=')
                .is_some_and(|(k, _)| k.trim() == key || k.trim().ends_with(&format!(".{key}")))
                || l.contains(&format!(" {key} ="))
                || l.contains(&format!("{{{key} ="))
        })
        .map(|n| n + 1)
}

// ---- the file's shape (serde) ----

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Description {
    name: String,
    motor: Motor,
    mechanics: Mechanics,
    controller: Controller,
    #[serde(default)]
    installation: Installation,
    test: Test,
    #[serde(default)]
    ga: Ga,
    #[serde(default)]
    polish: PolishSection,
    detection: Detection,
    #[serde(default)]
    uncertainty: UncertaintySection,
    domain: Domain,
    calibration: Option<Cal>,
    #[serde(default)]
    sensors: Sensors,
    #[serde(default)]
    reference_model: ReferenceModelExtra,
    #[serde(default)]
    drive: Drive,
    #[serde(default)]
    conditions: Conditions,
    #[serde(default)]
    surface: Surface,
    rig: Option<RigColumns>,
}

/// The control surface's aerodynamics the reference model plays in wind and flight
/// (`crate::plant::aero::SurfaceAerodynamics`); the FDI never reads them.
#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct Surface {
    area: Option<f64>,
    chord: Option<f64>,
    ch0: Option<f64>,
    ch_alpha: Option<f64>,
    ch_delta: Option<f64>,
    air_density: Option<f64>,
    parked_incidence_deg: Option<f64>,
}

/// The power bridge the reference model plays (`crate::plant::bridge::BridgeSettings`).
#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct Drive {
    carrier_hz: Option<f64>,
    timer_hz: Option<f64>,
    dead_time: Option<f64>,
    dead_time_compensation: Option<bool>,
    compensation_threshold: Option<f64>,
    switch_resistance: Option<f64>,
    diode_drop: Option<f64>,
    harness_resistance: Option<f64>,
    bus_ripple: Option<f64>,
    bus_ripple_hz: Option<f64>,
    /// The controller's timing [s]: when a period's duties take effect after its sample.
    duty_delay: Option<f64>,
}

/// The day the reference model plays (`crate::plant::bridge::OperatingConditions`).
#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct Conditions {
    /// Winding temperature [°C].
    temperature: Option<f64>,
    /// Gear temperature [°C] (default: the winding's).
    gear_temperature: Option<f64>,
    /// Mean bus voltage [V] (default: `[motor] dc_bus_voltage`).
    bus_voltage: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Motor {
    dc_bus_voltage: f32,
    pole_pairs: f32,
    phase_resistance: f32,
    phase_inductance: f32,
    back_emf_constant: f32,
    max_current: f32,
    winding_group_angle_deg: [f64; 3],
    /// Magnet flux coefficient [1/K] from the magnets' data sheet (−0.0011 NdFeB,
    /// −0.00035 SmCo): the FDI's flux at the estimated winding temperature.
    #[serde(default)]
    magnet_coefficient: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Mechanics {
    motor_inertia: f32,
    user_inertia: f32,
    gear_ratio: f32,
    gear_stiffness: f32,
    gear_damping: f32,
    nominal_backlash: f32,
    static_friction: f32,
    dynamic_friction: f32,
    stick_speed: f32,
    aero_stiffness: f32,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Controller {
    position_kp: f32,
    position_ki: f32,
    position_kd: f32,
    max_speed: f32,
    speed_kp: f32,
    speed_ki: f32,
    control_period: f32,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct Installation {
    /// Motor encoder reading with the surface at zero [rad, motor side].
    #[serde(default)]
    encoder_offset: f32,
}

#[derive(Deserialize, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
enum Design {
    Injection,
    Standstill,
    Paper,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Test {
    design: Design,
    #[serde(default)]
    standstill_volts: Option<f32>,
    /// The injection's tone [Hz] (`design = "injection"`).
    #[serde(default)]
    injection_frequency: Option<f32>,
    #[serde(default)]
    settle_samples: Option<u16>,
    #[serde(default)]
    on_samples: Option<u16>,
    #[serde(default)]
    off_samples: Option<u16>,
    chirp_amplitude: f32,
    chirp_end_frequency: f32,
    chirp_duration: f32,
    /// The most tests one preflight plays where the current's noise calls for them
    /// (`ActuatorRecord::tests_called_for`); absent: 1, one test.
    #[serde(default)]
    max_tests: Option<u32>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct Ga {
    max_evaluations: Option<u32>,
    max_generations: Option<u32>,
    stall_generations: Option<u32>,
    stall_tolerance: Option<f32>,
    tournament_size: Option<u8>,
    crossover_alpha: Option<f32>,
    mutation_probability: Option<f32>,
    mutation_scale: Option<f32>,
    mutation_floor: Option<f32>,
    differential_probability: Option<f32>,
    differential_scale: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Detection {
    threshold: f32,
}

/// The preflight's systematic error on this actuator (`shared::uncertainty::SystematicError`),
/// surveyed by `host-sim campaign --table 1+2 --runs 10 --actuator FILE`; absent: the
/// reference actuator's.
#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct UncertaintySection {
    gain_drift_systematic: Option<f32>,
    play_gain_drift_systematic: Option<f32>,
    /// How far the gearbox may run from the thermistor [K, one standard deviation]; absent:
    /// 0, the gearbox at the thermistor's temperature.
    gear_temperature_spread: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Domain {
    min_travel: f32,
    min_phase_ratio: f32,
    min_phase_samples: u32,
    min_phase_current: f32,
    max_tracking: f32,
    max_fitness: f32,
    /// `[low, high]` V of the measured bus; absent: any bus.
    bus_voltage: Option<[f32; 2]>,
    /// `[low, high]` °C of the measured temperature; absent: any temperature.
    temperature: Option<[f32; 2]>,
}

/// `[polish]`: the Gauss–Newton polish after the GA (a key left out keeps the flown
/// default, `PolishSettings::FDI`).
#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct PolishSection {
    iterations: Option<u8>,
    probe_iterations: Option<u8>,
    damping: Option<f32>,
    /// Probe starts, e.g. `{ component = "backlash", level = 0.5, from = "nominal" }`
    /// (`from`: "best", the GA's best with the component moved; "nominal"; or "scan", the
    /// GA's best with the component at the next lowest minimum of a scan in steps of
    /// `level`).
    probes: Option<Vec<ProbeEntry>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ProbeEntry {
    component: String,
    level: f32,
    from: String,
}

impl PolishSection {
    /// The settings; an unknown component or `from`, or more probes than fit, become values
    /// `ActuatorRecord::validate` refuses as `polish`.
    fn settings(&self) -> PolishSettings {
        let f = PolishSettings::FDI;
        let mut p = PolishSettings {
            iterations: self.iterations.unwrap_or(f.iterations),
            probe_iterations: self.probe_iterations.unwrap_or(f.probe_iterations),
            damping: self.damping.unwrap_or(f.damping),
            ..f
        };
        if let Some(probes) = &self.probes {
            p.probe_count = u8::try_from(probes.len()).unwrap_or(u8::MAX);
            p.probes = [Probe::backlash(0.0, ProbeStart::Nominal); MAX_PROBES];
            for (slot, e) in p.probes.iter_mut().zip(probes) {
                let component = shared::fault::FAULT_NAMES
                    .iter()
                    .position(|n| *n == e.component);
                let start = match e.from.as_str() {
                    "nominal" => Some(ProbeStart::Nominal),
                    "best" => Some(ProbeStart::Best),
                    "scan" => Some(ProbeStart::ScanMinimum),
                    _ => None,
                };
                *slot = match (component, start) {
                    (Some(c), Some(start)) => Probe {
                        component: c as u8,
                        level: e.level,
                        start,
                    },
                    _ => Probe {
                        component: u8::MAX,
                        level: e.level,
                        start: ProbeStart::Best,
                    },
                };
            }
        }
        p
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Cal {
    resistance_scale: f32,
    inductance_scale: f32,
    back_emf_scale: f32,
    friction_scale: f32,
    damping: f32,
    nominal_residual: f32,
    pair_resistance_scale: Option<f32>,
    pair_inductance_scale: Option<f32>,
    temperature: Option<f32>,
    /// `[[°C, factor], …]`: the healthy friction measured at other temperatures.
    friction_points: Option<Vec<[f32; 2]>>,
    magnet_coefficient: Option<f32>,
    /// The chirp's viscous drag on the healthy trace, and each friction point's against it
    /// (a grease with a drag of its own; absent: friction follows the thermistor).
    viscous: Option<f32>,
    drag_points: Option<Vec<f32>>,
}

/// What the simulator's sensors do (the FDI reads only their output).
#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct Sensors {
    current_full_scale: Option<f64>,
    current_bits: Option<u32>,
    current_noise: Option<f64>,
    anti_alias_hz: Option<f64>,
    encoder_bits: Option<u32>,
    user_full_scale: Option<f64>,
    user_bits: Option<u32>,
    user_offset: Option<f64>,
    user_noise: Option<f64>,
    bus_gain_error: Option<f64>,
    bus_noise: Option<f64>,
    bus_lsb: Option<f64>,
    temperature_bias: Option<f64>,
    temperature_noise: Option<f64>,
    temperature_lsb: Option<f64>,
}

/// Physics the reference model plays and the monitor model does not know.
#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct ReferenceModelExtra {
    step: Option<f64>,
    hysteresis_band: Option<f64>,
    magnet_fringe_deg: Option<f64>,
    aero_damping: Option<f64>,
    end_stop_angle: Option<f64>,
    end_stop_stiffness: Option<f64>,
    end_stop_damping: Option<f64>,
    stick_band: Option<f64>,
    pre_roll: Option<f64>,
    /// The installation's true rigging offset the simulator plays [rad, motor side]
    /// (default: what `[installation]` says the FDI believes).
    encoder_offset: Option<f64>,
    /// Temperature the data sheet's R, k_e and friction are given at [°C].
    reference_temperature: Option<f64>,
    /// Copper resistance and magnet flux coefficients [1/K].
    copper_coefficient: Option<f64>,
    magnet_coefficient: Option<f64>,
    /// Grease drag's share of dry friction at the reference temperature, and the grease's
    /// activation temperature [K] (`crate::plant::bridge::ThermalLaws`).
    friction_viscous_share: Option<f64>,
    friction_activation: Option<f64>,
    /// The grease as two things: its viscous drag on the motor shaft at the reference
    /// temperature [N·m·s/rad] (absent or 0: one factor on dry friction) and the power of the
    /// oil's viscosity the dry friction follows.
    grease_drag: Option<f64>,
    coulomb_exponent: Option<f64>,
    /// `arrhenius` (default) or `walther`: the form of the base oil's viscosity law.
    viscosity_law: Option<ViscosityLaw>,
    /// `permeance` (default) or `phase-gain`: how eccentricity changes the back-EMF.
    eccentricity: Option<EccentricityPhysics>,
}

impl Drive {
    /// The file's bridge, each key left out taken from `default`.
    fn settings(&self, default: BridgeSettings) -> BridgeSettings {
        let d = default;
        BridgeSettings {
            carrier_hz: self.carrier_hz.unwrap_or(d.carrier_hz),
            timer_hz: self.timer_hz.unwrap_or(d.timer_hz),
            dead_time: self.dead_time.unwrap_or(d.dead_time),
            compensation: self.dead_time_compensation.unwrap_or(d.compensation),
            compensation_threshold: self
                .compensation_threshold
                .unwrap_or(d.compensation_threshold),
            switch_resistance: self.switch_resistance.unwrap_or(d.switch_resistance),
            diode_drop: self.diode_drop.unwrap_or(d.diode_drop),
            harness_resistance: self.harness_resistance.unwrap_or(d.harness_resistance),
            ripple: self.bus_ripple.unwrap_or(d.ripple),
            ripple_hz: self.bus_ripple_hz.unwrap_or(d.ripple_hz),
            duty_delay: self.duty_delay.unwrap_or(d.duty_delay),
        }
    }
}

impl Description {
    fn build(self) -> Actuator {
        let systematic_stated = self.uncertainty.gain_drift_systematic.is_some()
            && self.uncertainty.play_gain_drift_systematic.is_some();
        let m = &self.motor;
        let k = &self.mechanics;
        let c = &self.controller;
        let params = ActuatorParams {
            dc_bus_voltage: m.dc_bus_voltage,
            pole_pairs: m.pole_pairs,
            phase_resistance: m.phase_resistance,
            phase_inductance: m.phase_inductance,
            back_emf_constant: m.back_emf_constant,
            max_current: m.max_current,
            // In f32 as the built-in constant is written, so that the reference file is
            // bit for bit the built-in actuator.
            winding_group_angle: m
                .winding_group_angle_deg
                .map(|d| d as f32 * core::f32::consts::PI / 180.0),
            motor_inertia: k.motor_inertia,
            user_inertia: k.user_inertia,
            gear_ratio: k.gear_ratio,
            gear_stiffness: k.gear_stiffness,
            gear_damping: k.gear_damping,
            nominal_backlash: k.nominal_backlash,
            static_friction: k.static_friction,
            dynamic_friction: k.dynamic_friction,
            stick_speed: k.stick_speed,
            aero_stiffness: k.aero_stiffness,
            encoder_offset: self.installation.encoder_offset,
            position_kp: c.position_kp,
            position_ki: c.position_ki,
            position_kd: c.position_kd,
            max_speed: c.max_speed,
            speed_kp: c.speed_kp,
            speed_ki: c.speed_ki,
            control_period: c.control_period,
        };
        let t = &self.test;
        let d = match t.design {
            Design::Injection => StandstillSegment::INJECTION,
            _ => StandstillSegment::DEFAULT,
        };
        let test = PreflightTest {
            standstill: (t.design != Design::Paper).then(|| StandstillSegment {
                volts: t.standstill_volts.unwrap_or(f32::NAN),
                frequency: match t.design {
                    Design::Injection => t.injection_frequency.unwrap_or(f32::NAN),
                    _ => 0.0,
                },
                settle_samples: t.settle_samples.unwrap_or(d.settle_samples),
                on_samples: t.on_samples.unwrap_or(d.on_samples),
                off_samples: t.off_samples.unwrap_or(d.off_samples),
            }),
            motion: None,
            chirp: ChirpCommand {
                amplitude: t.chirp_amplitude,
                end_frequency: t.chirp_end_frequency,
                duration: t.chirp_duration,
            },
        };
        let polish = self.polish.settings();
        let f = GaSettings::FDI;
        let g = &self.ga;
        let ga = GaSettings {
            max_evaluations: g.max_evaluations.unwrap_or(f.max_evaluations),
            max_generations: g.max_generations.unwrap_or(f.max_generations),
            stall_generations: g.stall_generations.unwrap_or(f.stall_generations),
            tolerance: g.stall_tolerance.unwrap_or(f.tolerance),
            tournament_size: g.tournament_size.unwrap_or(f.tournament_size),
            crossover_alpha: g.crossover_alpha.unwrap_or(f.crossover_alpha),
            mutation_probability: g.mutation_probability.unwrap_or(f.mutation_probability),
            mutation_scale: g.mutation_scale.unwrap_or(f.mutation_scale),
            mutation_floor: g.mutation_floor.unwrap_or(f.mutation_floor),
            differential_probability: g
                .differential_probability
                .unwrap_or(f.differential_probability),
            differential_scale: g.differential_scale.unwrap_or(f.differential_scale),
            ..f
        };
        let o = &self.domain;
        let domain = DomainLimits {
            min_travel: o.min_travel,
            min_phase_ratio: o.min_phase_ratio,
            min_phase_samples: o.min_phase_samples,
            min_phase_current: o.min_phase_current,
            max_tracking: o.max_tracking,
            max_fitness: o.max_fitness,
            bus_voltage: o.bus_voltage.unwrap_or(DomainLimits::ANY_DAY.0),
            temperature: o.temperature.unwrap_or(DomainLimits::ANY_DAY.1),
        };
        let calibration = self.calibration.as_ref().map(|c| {
            let i = Calibration::IDENTITY;
            Calibration {
                resistance_scale: c.resistance_scale,
                inductance_scale: c.inductance_scale,
                back_emf_scale: c.back_emf_scale,
                friction_scale: c.friction_scale,
                damping: c.damping,
                nominal_residual: c.nominal_residual,
                pair_resistance_scale: c.pair_resistance_scale.unwrap_or(i.pair_resistance_scale),
                pair_inductance_scale: c.pair_inductance_scale.unwrap_or(i.pair_inductance_scale),
                temperature: c.temperature.unwrap_or(i.temperature),
                friction_points: core::array::from_fn(|j| {
                    c.friction_points
                        .as_ref()
                        .and_then(|p| p.get(j).copied())
                        .unwrap_or([0.0, 0.0])
                }),
                magnet_coefficient: c.magnet_coefficient.unwrap_or(i.magnet_coefficient),
                duty_delay: i.duty_delay,
                viscous: c.viscous.unwrap_or(i.viscous),
                drag_points: core::array::from_fn(|j| {
                    c.drag_points
                        .as_ref()
                        .and_then(|p| p.get(j).copied())
                        .unwrap_or(0.0)
                }),
            }
        });
        let r = ReferenceSettings::REFERENCE;
        let s = &self.sensors;
        let x = &self.reference_model;
        let reference = ReferenceSettings {
            params,
            step: x.step.unwrap_or(r.step),
            hysteresis_band: x.hysteresis_band.unwrap_or(r.hysteresis_band),
            magnet_fringe: x
                .magnet_fringe_deg
                .map_or(r.magnet_fringe, |d| d * PI / 180.0),
            winding_group_angle: m.winding_group_angle_deg.map(|d| d * PI / 180.0),
            aero_damping: x.aero_damping.unwrap_or(r.aero_damping),
            end_stop_angle: x.end_stop_angle.unwrap_or(r.end_stop_angle),
            end_stop_stiffness: x.end_stop_stiffness.unwrap_or(r.end_stop_stiffness),
            end_stop_damping: x.end_stop_damping.unwrap_or(r.end_stop_damping),
            stick_band: x.stick_band.unwrap_or(r.stick_band),
            current_full_scale: s.current_full_scale.unwrap_or(r.current_full_scale),
            current_bits: s.current_bits.unwrap_or(r.current_bits),
            current_noise: s.current_noise.unwrap_or(r.current_noise),
            anti_alias_hz: s.anti_alias_hz.unwrap_or(r.anti_alias_hz),
            encoder_bits: s.encoder_bits.unwrap_or(r.encoder_bits),
            user_full_scale: s.user_full_scale.unwrap_or(r.user_full_scale),
            user_bits: s.user_bits.unwrap_or(r.user_bits),
            user_offset: s.user_offset.unwrap_or(r.user_offset),
            user_noise: s.user_noise.unwrap_or(r.user_noise),
            encoder_offset: x
                .encoder_offset
                .unwrap_or(f64::from(self.installation.encoder_offset)),
            pre_roll: x.pre_roll.unwrap_or(r.pre_roll),
            bridge: self.drive.settings(r.bridge),
            thermal: ThermalLaws {
                reference_temperature: x
                    .reference_temperature
                    .unwrap_or(r.thermal.reference_temperature),
                copper: x.copper_coefficient.unwrap_or(r.thermal.copper),
                magnet: x.magnet_coefficient.unwrap_or(r.thermal.magnet),
                friction_viscous_share: x
                    .friction_viscous_share
                    .unwrap_or(r.thermal.friction_viscous_share),
                friction_activation: x
                    .friction_activation
                    .unwrap_or(r.thermal.friction_activation),
                grease_drag: x.grease_drag.unwrap_or(r.thermal.grease_drag),
                coulomb_exponent: x.coulomb_exponent.unwrap_or(r.thermal.coulomb_exponent),
                viscosity_law: x.viscosity_law.unwrap_or(r.thermal.viscosity_law),
            },
            conditions: {
                let winding = self
                    .conditions
                    .temperature
                    .unwrap_or(r.conditions.winding_temperature);
                OperatingConditions {
                    winding_temperature: winding,
                    gear_temperature: self.conditions.gear_temperature.unwrap_or(winding),
                    bus_voltage: self.conditions.bus_voltage,
                }
            },
            eccentricity: x.eccentricity.unwrap_or(r.eccentricity),
            surface: {
                let a = &self.surface;
                let d = r.surface;
                SurfaceAerodynamics {
                    area: a.area.unwrap_or(d.area),
                    chord: a.chord.unwrap_or(d.chord),
                    ch0: a.ch0.unwrap_or(d.ch0),
                    ch_alpha: a.ch_alpha.unwrap_or(d.ch_alpha),
                    ch_delta: a.ch_delta.unwrap_or(d.ch_delta),
                    air_density: a.air_density.unwrap_or(d.air_density),
                    parked_incidence: a
                        .parked_incidence_deg
                        .map_or(d.parked_incidence, |x| x * PI / 180.0),
                }
            },
            condition_sensors: {
                let c = r.condition_sensors;
                ConditionSensors {
                    bus_gain_error: s.bus_gain_error.unwrap_or(c.bus_gain_error),
                    bus_noise: s.bus_noise.unwrap_or(c.bus_noise),
                    bus_lsb: s.bus_lsb.unwrap_or(c.bus_lsb),
                    temperature_bias: s.temperature_bias.unwrap_or(c.temperature_bias),
                    temperature_noise: s.temperature_noise.unwrap_or(c.temperature_noise),
                    temperature_lsb: s.temperature_lsb.unwrap_or(c.temperature_lsb),
                }
            },
        };
        Actuator {
            name: self.name,
            record: ActuatorRecord {
                params,
                test,
                calibration: Calibration {
                    magnet_coefficient: m
                        .magnet_coefficient
                        .unwrap_or(calibration.map_or(0.0, |c| c.magnet_coefficient)),
                    // The controller's timing is the drive's (`[drive] duty_delay`).
                    duty_delay: reference.bridge.duty_delay as f32,
                    ..calibration.unwrap_or(Calibration::IDENTITY)
                },
                ga,
                polish,
                domain,
                drive: reference.bridge.drive(),
                detection_threshold: self.detection.threshold,
                max_tests: self.test.max_tests.unwrap_or(1),
                systematic: {
                    let (u, r) = (&self.uncertainty, SystematicError::REFERENCE_ACTUATOR);
                    SystematicError {
                        gain_drift: u.gain_drift_systematic.unwrap_or(r.gain_drift),
                        play_gain_drift: u.play_gain_drift_systematic.unwrap_or(r.play_gain_drift),
                        gear_temperature_spread: u.gear_temperature_spread.unwrap_or(0.0),
                        healthy_friction: 0.0,
                    }
                },
            },
            calibrated: calibration.is_some(),
            reference: Some(reference),
            rig: self.rig,
            built_in: false,
            source: None,
            systematic_stated,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reference_text() -> String {
        std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../actuators/reference.toml"
        ))
        .unwrap()
    }

    #[test]
    fn the_reference_file_is_the_built_in_actuator_bit_for_bit() {
        let a = Actuator::parse(&reference_text()).unwrap();
        let built_in = Actuator::reference();
        assert_eq!(a.record, built_in.record);
        assert_eq!(a.record.encode(), built_in.record.encode());
        assert_eq!(a.reference, built_in.reference);
        assert!(a.calibrated);
        // Rewriting the calibration keeps everything else and round-trips its bits.
        // (The magnets' coefficient is the file's [motor] one.)
        let c = Calibration {
            damping: 1.25,
            magnet_coefficient: built_in.record.calibration.magnet_coefficient,
            ..Calibration::REFERENCE_ACTUATOR_PAPER
        };
        let again =
            Actuator::parse(&Actuator::with_calibration_text(&reference_text(), &c)).unwrap();
        assert_eq!(again.record.calibration, c);
        let once = Actuator::with_calibration_text(&reference_text(), &c);
        assert_eq!(
            Actuator::with_calibration_text(&once, &c),
            once,
            "idempotent"
        );
        assert_eq!(again.record.params, a.record.params);
        assert_eq!(again.reference, a.reference);
    }

    #[test]
    fn the_light_actuator_file_loads() {
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../actuators/light-28v.toml"
        ))
        .unwrap();
        let a = Actuator::parse(&text).unwrap();
        assert_eq!(a.record.params.pole_pairs, 5.0);
        assert!(a.record.params.dc_bus_voltage < 30.0);
        // Its own survey's systematic error, not the reference actuator's.
        assert_eq!(
            a.record.systematic,
            SystematicError {
                gain_drift: 0.009,
                play_gain_drift: 0.018,
                gear_temperature_spread: 0.0,
                healthy_friction: 0.0,
            }
        );
    }

    #[test]
    fn the_systematic_error_is_the_files_or_the_reference_actuators() {
        let text = reference_text();
        let start = text.find("[uncertainty]").unwrap();
        let end = start + text[start..].find("\n[").unwrap() + 1;
        let without = format!("{}{}", &text[..start], &text[end..]);
        assert!(!without.contains("gain_drift_systematic"));
        let a = Actuator::parse(&without).unwrap();
        assert_eq!(a.record.systematic, SystematicError::REFERENCE_ACTUATOR);
        assert!(!a.systematic_stated, "the reference's values stand in");
        assert!(Actuator::parse(&text).unwrap().systematic_stated);
        let one = text.replace("play_gain_drift_systematic = 0.011", "");
        let a = Actuator::parse(&one.replace(
            "gain_drift_systematic = 0.006",
            "gain_drift_systematic = 0.02",
        ))
        .unwrap();
        assert_eq!(
            a.record.systematic,
            SystematicError {
                gain_drift: 0.02,
                play_gain_drift: shared::uncertainty::PLAY_GAIN_DRIFT_SYSTEMATIC,
                gear_temperature_spread: 0.0,
                healthy_friction: 0.0,
            }
        );
        assert!(!a.systematic_stated, "one value of two is the reference's");
        let bad = text.replace(
            "play_gain_drift_systematic = 0.011",
            "play_gain_drift_systematic = -0.011",
        );
        let line = bad
            .lines()
            .position(|l| l.starts_with("play_gain_drift_systematic"))
            .unwrap()
            + 1;
        let e = refusal(&bad);
        assert!(
            e.contains("uncertainty.play_gain_drift_systematic")
                && e.contains("not negative")
                && e.contains(&format!("line {line}")),
            "{e}"
        );
    }

    fn refusal(text: &str) -> String {
        format!("{:#}", Actuator::parse(text).unwrap_err())
    }

    #[test]
    fn out_of_range_values_are_refused_with_key_and_line() {
        let text = reference_text().replace("gear_ratio = 500.0", "gear_ratio = 0.0");
        let line = text
            .lines()
            .position(|l| l.starts_with("gear_ratio"))
            .unwrap()
            + 1;
        let e = refusal(&text);
        assert!(
            e.contains("mechanics.gear_ratio") && e.contains(&format!("line {line}")),
            "{e}"
        );
        let e =
            refusal(&reference_text().replace("motor_inertia = 1.0e-4", "motor_inertia = -1.0e-4"));
        assert!(e.contains("mechanics.motor_inertia"), "{e}");
        let e = refusal(&reference_text().replace("pole_pairs = 4", "pole_pairs = 4.5"));
        assert!(e.contains("motor.pole_pairs"), "{e}");
        // The most tests a preflight plays: 1 … 8, absent 1.
        let with =
            |n: &str| reference_text().replace("# max_tests = 4", &format!("max_tests = {n}"));
        let e = refusal(&with("9"));
        assert!(
            e.contains("test.max_tests") && e.contains("from 1 to 8"),
            "{e}"
        );
        let four = Actuator::parse(&with("4")).unwrap();
        assert_eq!(four.record.max_tests, 4);
        assert_eq!(Actuator::reference().record.max_tests, 1);
    }

    #[test]
    fn syntax_unknown_and_missing_keys_are_refused_with_their_line() {
        let e = refusal(&reference_text().replace("gear_ratio = 500.0", "gear_ratio = fast"));
        assert!(e.contains("line") && e.contains("gear_ratio"), "{e}");
        let e = refusal(&reference_text().replace("gear_ratio = 500.0", "gear_ration = 500.0"));
        assert!(e.contains("gear_ration") && e.contains("line"), "{e}");
        let without: String = reference_text()
            .lines()
            .filter(|l| !l.starts_with("gear_ratio"))
            .map(|l| format!("{l}\n"))
            .collect();
        let e = refusal(&without);
        assert!(e.contains("missing field `gear_ratio`"), "{e}");
        let e = refusal(&reference_text().replace("design = \"injection\"", "design = \"wobble\""));
        assert!(e.contains("wobble") && e.contains("line"), "{e}");
    }

    #[test]
    fn an_unknown_rig_column_is_refused() {
        let text = format!(
            "{}\n[rig]\ncolumns = {{ t = \"Time\", i_d = \"Id\" }}\n",
            reference_text()
        );
        let e = refusal(&text);
        assert!(e.contains("i_d"), "{e}");
    }

    #[test]
    fn the_polish_comes_from_the_file_and_a_bad_probe_is_refused() {
        let a = Actuator::parse(&reference_text()).unwrap();
        assert_eq!(a.record.polish, PolishSettings::FDI);
        let text = reference_text().replace(
            "{ component = \"backlash\", level = 1.0, from = \"nominal\" },",
            "{ component = \"eccentricity\", level = 0.3, from = \"nominal\" },",
        );
        let p = Actuator::parse(&text).unwrap().record.polish;
        assert_eq!(
            p.probes[5],
            Probe {
                component: 5,
                level: 0.3,
                start: ProbeStart::Nominal
            }
        );
        for (from, to) in [
            (
                "component = \"backlash\", level = 0.05, from = \"scan\"",
                "component = \"ecc_phase\", level = 0.05, from = \"scan\"",
            ),
            (
                "component = \"backlash\", level = 0.05, from = \"scan\"",
                "component = \"backlash\", level = 0.05, from = \"worst\"",
            ),
            ("iterations = 8", "iterations = 200"),
        ] {
            let e = refusal(&reference_text().replacen(from, to, 1));
            assert!(e.contains("`polish`"), "{e}");
        }
    }

    #[test]
    fn a_file_of_another_test_kind_refuses_a_trace_of_the_other() {
        let a = Actuator::parse(&reference_text()).unwrap();
        assert!(a.test_for(&PreflightTest::PAPER).is_err());
        assert!(a.test_for(&PreflightTest::STANDSTILL).is_err());
        assert_eq!(
            a.test_for(&PreflightTest::INJECTION).unwrap(),
            a.record.test
        );
    }
}
