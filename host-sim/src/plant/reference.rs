//! The reference model (RM): the high-fidelity "real actuator" every test and campaign
//! identifies (SPEC §4, paper Fig. 3). It is deliberately a different and richer model than
//! the monitor model in `shared`.
//!
//! f64; fixed step [`ReferenceSettings::step`] = 1 µs (100 steps per 100 µs control period);
//! O(1) work per step, one 0.5 s test = 500 000 steps. Time is the step index times the step,
//! never read from a clock; every random number comes from generators seeded by the caller.
//!
//! What it models:
//! * **ACE controller** at 10 kHz, on *sensed* signals: PID position loop on the user-shaft
//!   transducer (its K_p carries the gain-drift fault) → saturated speed reference → PI speed
//!   loop on the speed estimated from encoder differences, with anti-windup → saturated I_ref,
//!   plus optional band-limited white process noise on I_ref (held over each control period).
//! * **Inverter**: three legs on a DC bus, 120° trapezoidal commutation from the rotor angle
//!   at every step, per-phase hysteresis current control of the two conducting phases, the
//!   third leg open with its current freewheeling through the diodes until it reaches zero;
//!   floating neutral (the three currents always sum to zero).
//! * **BLDC motor**: per-phase R, L and trapezoidal back-EMF from a permeance model: P = 4
//!   pole pairs with trapezoidal magnetisation (60° electrical fringing), each phase wound as
//!   two full-pitch coils side by side in its own third of the stator (a modular,
//!   fault-tolerant winding). A partial short circuit of `N` healthy turns scales that phase's
//!   R by `N`, L by `N²` and coupling by `N`. Static eccentricity makes the air gap at stator
//!   angle ψ `g(ψ) = g₀·(1 − Z·cos(ψ − ψ_min))`; each coil's flux linkage is integrated over
//!   the gap permeance, so each phase's coupling changes with rotor angle as the magnet edges
//!   cross its coils. `ψ_min` is φ away from the centre of phase A's coils (mechanical angle).
//! * **Mechanics**: two degrees of freedom. Motor inertia with Karnopp stick-slip dry friction
//!   and a Stribeck drop from static to dynamic level; a compliant gear train with backlash
//!   (dead zone), contact damping and no sticking contact; user inertia with the aerodynamic
//!   hinge moment (spring + damping) and end-of-travel stops.
//! * **Sensors**: phase currents through a 12-bit ADC (±20 A) with white electrical noise,
//!   latched at the carrier's centre (every leg low); a 20-bit absolute motor encoder; a
//!   20-bit user-shaft transducer over ±0.5 rad with an offset and noise; the bus voltage
//!   and a winding thermistor with their errors ([`ConditionSensors`]). The trace holds what
//!   these sensors read at each control period.
//! * **The bridge and the day** (`bridge.rs`): PWM in whole timer counts with dead time and
//!   its compensation, switch and diode drops, harness, bus ripple for every segment that
//!   commands a voltage, the same switches under the hysteresis control; copper, magnets and
//!   grease at the day's temperatures.

use shared::conditioning::COMMUTATION_SIGNS;
use shared::fault::{DEMAGNETIZATION_INDEX, DEMAGNETIZATION_LOSS_MAX};
use shared::test_design::{Drive, PairDrive, PreflightTest};
use shared::{ActuatorParams, ChirpCommand, FaultVector};

use crate::files::trace::{Trace, TraceSample};
use crate::plant::aero::{FlightWindow, GroundWind, SurfaceAerodynamics};
use crate::plant::bridge::{
    to_lsb, BridgeSettings, ConditionSensors, OperatingConditions, ThermalLaws,
};
use crate::plant::noise::Gaussian;

use std::f64::consts::{FRAC_PI_2, PI, SQRT_2, TAU};

/// Mechanical angle of the centre of each phase's coil group (A, B, C) of the reference
/// actuator [rad]. The groups sit 120° apart in the order A, C, B, which for P = 4 puts phase
/// B 120° electrical behind A.
const GROUP_CENTRE: [f64; 3] = [67.5 * PI / 180.0, 307.5 * PI / 180.0, 187.5 * PI / 180.0];
/// Least closed-loop hold before a test in wind [s]: the loop takes the mean hinge moment
/// (its bandwidth ≈ 200 rad/s settles in ≈ 25 ms).
pub const WIND_SETTLE: f64 = 0.1;
/// Points per mechanical revolution of the back-EMF shape tables.
const SHAPE_POINTS: usize = 8192;

/// Everything about the RM that is not in [`ActuatorParams`]: drive, sensors, extra physics.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReferenceSettings {
    /// Physical parameters shared with the monitor model (the actuator's data sheet).
    pub params: ActuatorParams,
    /// Integration step [s].
    pub step: f64,
    /// Half-width of the hysteresis current band [A].
    pub hysteresis_band: f64,
    /// Width of the magnet-edge transition (fringing) [rad electrical].
    pub magnet_fringe: f64,
    /// Mechanical angle of the centre of each phase's coil group (A, B, C) [rad], in f64
    /// (the parameters' f32 copy is what the monitor model knows). The two coils of a group
    /// sit one pole pitch (π / P) apart.
    pub winding_group_angle: [f64; 3],
    /// Aerodynamic damping on the user shaft [N·m·s/rad].
    pub aero_damping: f64,
    /// End-of-travel stop angle of the user shaft [rad] (symmetric).
    pub end_stop_angle: f64,
    /// Stiffness and damping of the end stops [N·m/rad], [N·m·s/rad].
    pub end_stop_stiffness: f64,
    pub end_stop_damping: f64,
    /// Motor speed below which the Karnopp model treats the motor as stuck [rad/s].
    pub stick_band: f64,
    /// Full scale (±) and bits of the current ADC [A], [-].
    pub current_full_scale: f64,
    pub current_bits: u32,
    /// RMS of the white electrical noise on each current line [A].
    pub current_noise: f64,
    /// Cutoff of the analogue anti-alias filter of each current-sense channel before its
    /// ADC: second-order Butterworth [Hz]; 0 = none (the ADC samples the raw hysteresis
    /// ripple). [`Self::ANTI_ALIAS_HZ`] is the study's value; the reference actuator keeps
    /// 0 until the calibration and accuracy tables are regenerated with it.
    pub anti_alias_hz: f64,
    /// Bits per revolution of the motor encoder.
    pub encoder_bits: u32,
    /// Full scale (±) [rad] and bits of the user-shaft transducer.
    pub user_full_scale: f64,
    pub user_bits: u32,
    /// Offset and RMS noise of the user-shaft transducer [rad].
    pub user_offset: f64,
    pub user_noise: f64,
    /// The installation's rigging: what the motor encoder reads with the surface at zero and
    /// the gear relaxed [rad, motor side]. The encoder stays aligned to the magnets (the
    /// commutation is unaffected); the gear sees `θ_m − encoder_offset`. What the FDI
    /// believes is `params.encoder_offset` (from the actuator record).
    pub encoder_offset: f64,
    /// Closed-loop hold at zero command before the chirp starts [s]: the test begins from
    /// a regulated actuator (which sits at minus the transducer offset), as on the aircraft.
    pub pre_roll: f64,
    /// The power bridge between the controller and the motor (`[drive]`).
    pub bridge: BridgeSettings,
    /// How R, flux and friction move with temperature (`[reference_model]`).
    pub thermal: ThermalLaws,
    /// The day the test runs on (`[conditions]`, `--temperature`, `--bus-voltage`).
    pub conditions: OperatingConditions,
    /// What the controller measures of its bus and temperature (`[sensors]`).
    pub condition_sensors: ConditionSensors,
    /// How static eccentricity changes each phase's back-EMF (`[reference_model]
    /// eccentricity`).
    pub eccentricity: EccentricityPhysics,
    /// The control surface's aerodynamics (`[surface]`): the hinge moment the wind puts on
    /// it ([`ReferenceModel::with_wind`]).
    pub surface: SurfaceAerodynamics,
}

/// How the reference model plays static eccentricity: the same fault vector's amplitude Z
/// and phase φ, two physics.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum EccentricityPhysics {
    /// The air gap `g(ψ) = g₀·(1 − Z·cos(ψ − ψ_min))` and each coil's flux linkage
    /// integrated over its permeance: every phase's coupling changes with rotor angle as the
    /// magnet edges cross its coils (this project's reference actuator).
    #[default]
    Permeance,
    /// A plain per-phase back-EMF gain: phase x's coupling is `1 + Z·cos(ψ_x − ψ_min)` times
    /// the healthy one, `ψ_x` the centre of its coil group, constant over a revolution (the
    /// first-order effect of a shorter gap over that phase's coils).
    PhaseGain,
}

impl ReferenceSettings {
    /// The reference actuator of this project.
    pub const REFERENCE: Self = Self {
        params: ActuatorParams::REFERENCE,
        step: 1.0e-6,
        hysteresis_band: 0.1,
        magnet_fringe: 60.0 * PI / 180.0,
        winding_group_angle: GROUP_CENTRE,
        aero_damping: 10.0,
        end_stop_angle: 0.35,
        end_stop_stiffness: 1.0e8,
        end_stop_damping: 1.0e5,
        stick_band: 0.02,
        current_full_scale: 20.0,
        current_bits: 12,
        current_noise: 0.01,
        anti_alias_hz: 0.0,
        encoder_bits: 20,
        user_full_scale: 0.5,
        user_bits: 20,
        user_offset: 2.0e-5,
        user_noise: 5.0e-7,
        encoder_offset: 0.0,
        pre_roll: 0.01,
        bridge: BridgeSettings::TYPICAL,
        thermal: ThermalLaws::NDFEB_GREASED,
        conditions: OperatingConditions::REFERENCE,
        condition_sensors: ConditionSensors::TYPICAL,
        eccentricity: EccentricityPhysics::Permeance,
        surface: SurfaceAerodynamics::REFERENCE,
    };

    /// The reference actuator on an ideal drive with exact bus and temperature readings:
    /// what the earlier designs (voltage steps, the paper's chirp) were calibrated and
    /// measured on. For studies of what the bridge does, never a result's plant.
    pub const IDEAL_DRIVE: Self = Self {
        bridge: BridgeSettings::IDEAL,
        condition_sensors: ConditionSensors::EXACT,
        ..Self::REFERENCE
    };
}

impl ReferenceSettings {
    /// A 3 kHz second-order anti-alias stage (0.6 × the 5 kHz Nyquist frequency): the
    /// 20–50 kHz hysteresis ripple is attenuated 40–280 times, the signal delayed ≈ 75 µs.
    pub const ANTI_ALIAS_HZ: f64 = 3000.0;
}

impl Default for ReferenceSettings {
    fn default() -> Self {
        Self::REFERENCE
    }
}

/// What one simulation is asked to do.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scenario {
    pub faults: FaultVector,
    /// RMS of the band-limited noise on I_ref, as a fraction of the nominal I_ref RMS.
    pub current_ref_noise: f64,
    /// Seed of every random draw of the run.
    pub seed: u64,
}

impl Scenario {
    pub fn new(faults: FaultVector) -> Self {
        Self {
            faults,
            current_ref_noise: 0.0,
            seed: 0,
        }
    }
}

/// What the RM knows at the start of each control period and the sensors do not show (with
/// the I_ref the controller computed for that period): for tests and plots.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct TruthSample {
    pub current_ref: f64,
    pub phase_currents: [f64; 3],
    pub motor_angle: f64,
    pub motor_speed: f64,
    pub user_angle: f64,
    pub motor_torque: f64,
    /// Mean voltage of each inverter leg over the coming control period, from the DC bus's
    /// midpoint [V]: what the controller knows of its own switching (the open leg's diode
    /// voltage included).
    pub applied_voltages: [f64; 3],
}

/// Energy bookkeeping over a run [J]: what the inverter delivered and where it went.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct EnergyLedger {
    /// Σ v·i into the three phases.
    pub electrical_input: f64,
    /// Σ R·i² in the windings.
    pub copper_loss: f64,
    /// Magnetic energy Σ ½·L·i² at the end.
    pub magnetic: f64,
    /// ∫ Σ e·i: electrical power converted by the back-EMF.
    pub converted: f64,
    /// ∫ T_m·ω_m: the work the motor torque does on the rotor, as the mechanics sees it.
    pub shaft_work: f64,
    /// Dry friction, gear contact damping, aero damping and end-stop damping losses.
    pub mechanical_loss: f64,
    /// Kinetic + gear spring + aero spring + end-stop spring energy at the end.
    pub mechanical_stored: f64,
    /// Spring energy dropped when a gear contact opens while compressed (no sticking contact).
    pub contact_release: f64,
}

/// One RM run: the sensed trace and the hidden truth, one entry per control period.
#[derive(Clone, Debug, PartialEq)]
pub struct Simulation {
    pub trace: Trace,
    pub truth: Vec<TruthSample>,
    pub energy: EnergyLedger,
    /// What a rig's data logger recorded at [`ReferenceModel::with_recording`]'s rate,
    /// from the start of the pre-roll (time 0) to the end of the test: the same sensor
    /// signals (at a control instant exactly what the controller's ADC latched, in between
    /// with their own noise draws; the trace's bits are the same with or without it).
    /// Empty unless asked for.
    pub recording: Vec<TraceSample>,
}

/// One control period's output as the drive applies it: the pair driven at standstill (the
/// position loop suspended), its legs' duties, and the current reference of the hysteresis
/// control.
type Output = (Option<PairDrive>, Option<[f64; 3]>, f64);

/// What a controller's sensors see at a control instant, before its converters: the phase
/// currents through the anti-alias filters with their noise [A], the motor shaft's angle
/// [rad] (its encoder counts it), the surface's angle with its transducer's offset and noise
/// [rad], the bus [V] and the winding's temperature [°C] with their sensors' gain, bias and
/// noise.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AnalogSensors {
    pub phase_currents: [f64; 3],
    pub motor_angle: f64,
    pub user_angle: f64,
    pub bus_voltage: f64,
    pub temperature: f64,
    /// The flight control computer's position demand [rad]: `None` on the ground (its
    /// output off).
    pub demand: Option<f64>,
}

/// A controller outside the reference model driving its bridge (a board image under
/// emulation): each control period it sees the sensors and gives each leg's duty — the high
/// switch's share of the carrier, centred in it, with the bridge's dead time — or `None` for
/// both switches off. `None` in all: the run ends there.
pub trait ExternalDrive {
    fn period(&mut self, sensed: &AnalogSensors) -> Option<[Option<f64>; 3]>;
}

/// Per-phase electrical constants of one run.
#[derive(Clone, Copy, Debug)]
struct Phase {
    resistance: f64,
    inductance: f64,
    coupling: f64,
}

/// A failure outside the fault vector, which the monitor model cannot represent: what the
/// FDI must report as "outside the monitor model's domain" rather than fit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Anomaly {
    /// The user shaft is jammed where it starts (a seized ball screw or hinge): it does not
    /// move whatever the gear transmits.
    Jammed,
    /// One motor phase (0 = A) is disconnected: it carries no current, and the other two can
    /// only carry current in series.
    OpenPhase(usize),
}

/// A fault of the controller's sensors, not of the actuator: the reference model plays it on
/// what the controller reads, so its control loops act on the faulty reading too. Times are
/// from the start of the test's chirp [s]; phase 0 is A.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SensorFault {
    /// The motor encoder holds its reading for `seconds` from `at`.
    EncoderStuck { at: f64, seconds: f64 },
    /// The motor encoder reads `rad` more for one control period at `at`.
    EncoderGlitch { at: f64, rad: f64 },
    /// A phase's current sense reads `amps` more, the whole test.
    CurrentOffset { phase: usize, amps: f64 },
    /// A phase's current sense reads `gain` times the current, the whole test.
    CurrentGain { phase: usize, gain: f64 },
    /// The surface transducer slips: from `at` on it reads `rad` more.
    TransducerSlip { at: f64, rad: f64 },
}

impl SensorFault {
    /// Where the time-bound faults happen by default: mid-chirp, the motor moving fast.
    pub const AT: f64 = 0.25;

    /// `KIND[:SIZE]`: `encoder-stuck[:SECONDS]` (0.01), `encoder-glitch[:RAD]` (1.0),
    /// `current-offset[:AMPS]` (0.2, phase A), `current-gain[:GAIN]` (1.1, phase A),
    /// `transducer-slip[:RAD]` (0.005).
    pub fn parse(text: &str) -> Result<Self, String> {
        let (kind, size) = match text.split_once(':') {
            Some((k, v)) => {
                let v: f64 = v
                    .trim()
                    .parse()
                    .map_err(|_| format!("size {v:?} of {k} is not a number"))?;
                if !v.is_finite() {
                    return Err(format!("size of {k} must be finite"));
                }
                (k.trim(), Some(v))
            }
            None => (text.trim(), None),
        };
        let at = Self::AT;
        Ok(match kind {
            "encoder-stuck" => Self::EncoderStuck {
                at,
                seconds: size.unwrap_or(0.01).max(0.0),
            },
            "encoder-glitch" => Self::EncoderGlitch {
                at,
                rad: size.unwrap_or(1.0),
            },
            "current-offset" => Self::CurrentOffset {
                phase: 0,
                amps: size.unwrap_or(0.2),
            },
            "current-gain" => Self::CurrentGain {
                phase: 0,
                gain: size.unwrap_or(1.1),
            },
            "transducer-slip" => Self::TransducerSlip {
                at,
                rad: size.unwrap_or(0.005),
            },
            other => {
                return Err(format!(
                    "unknown sensor fault {other:?}: encoder-stuck, encoder-glitch, \
                     current-offset, current-gain or transducer-slip[:SIZE]"
                ))
            }
        })
    }

    /// What the controller reads at chirp time `t` (`None` before the chirp; control period
    /// `dt`) of the true readings; `held` keeps a stuck encoder's reading.
    fn apply(
        &self,
        t: Option<f64>,
        dt: f64,
        currents: &mut [f64; 3],
        encoder: &mut f64,
        held: &mut Option<f64>,
        user: &mut f64,
    ) {
        // Periods whose sample instant falls in [at, at + len), half a period of rounding
        // allowed either side.
        let within =
            |at: f64, len: f64| t.is_some_and(|t| t >= at - 0.5 * dt && t < at + len - 0.5 * dt);
        match *self {
            Self::EncoderStuck { at, seconds } => {
                if within(at, seconds) {
                    *encoder = *held.get_or_insert(*encoder);
                }
            }
            Self::EncoderGlitch { at, rad } => {
                if within(at, dt) {
                    *encoder += rad;
                }
            }
            Self::CurrentOffset { phase, amps } => {
                if let Some(i) = currents.get_mut(phase) {
                    *i += amps;
                }
            }
            Self::CurrentGain { phase, gain } => {
                if let Some(i) = currents.get_mut(phase) {
                    *i *= gain;
                }
            }
            Self::TransducerSlip { at, rad } => {
                if within(at, f64::INFINITY) {
                    *user += rad;
                }
            }
        }
    }
}

/// The reference model: settings plus the command.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReferenceModel {
    settings: ReferenceSettings,
    test: PreflightTest,
    anomaly: Option<Anomaly>,
    sensor_fault: Option<SensorFault>,
    recording_hz: Option<f64>,
    demagnetization: Demagnetization,
    wind: Option<GroundWind>,
    flight: Option<FlightWindow>,
    flight_periods: Option<usize>,
}

/// Irreversible loss of the rotor magnets' flux (SPEC §10, issue 35): after over-temperature
/// (a stalled or jammed actuator, a hot bay), a strong reverse field (a phase short's
/// circulating current) or ageing. Kept apart from the magnets' reversible temperature
/// coefficient, which the day plays ([`ThermalLaws::flux_scale`]): the RM's flux is the day's
/// times what is left of each pole. The fault vector's ninth component (k9) is a uniform loss
/// of its own; this setting plays the physical forms on top of it (a uniform loss up to the
/// whole flux, or one magnet), and [`Demagnetization::truth`] says what k9 they amount to.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum Demagnetization {
    #[default]
    None,
    /// Every pole lost `loss` (0 … 1) of its flux (thermal): the back-EMF and the torque
    /// constant fall alike, the shape stays.
    Uniform { loss: f64 },
    /// One magnet lost `loss` of its flux: pole `pole` (0 … 2P − 1), whose centre sits
    /// `pole · π/P` mechanical ahead of the rotor's zero (the encoder's zero at rigging 0).
    /// Each phase's back-EMF then dips once per mechanical revolution, as that pole passes
    /// its coils.
    Partial { loss: f64, pole: u32 },
}

impl Demagnetization {
    /// `uniform:LOSS` or `partial:LOSS[@POLE]` (LOSS the share of flux lost, 0 … 1; POLE
    /// 0 … 2P − 1, default 0), as the command line writes it.
    pub fn parse(text: &str) -> Result<Self, String> {
        let (kind, rest) = text
            .split_once(':')
            .ok_or_else(|| format!("{text:?}: expected uniform:LOSS or partial:LOSS[@POLE]"))?;
        let (loss, pole) = match rest.split_once('@') {
            Some((l, p)) => (l, Some(p)),
            None => (rest, None),
        };
        let loss: f64 = loss
            .trim()
            .parse()
            .map_err(|_| format!("loss {loss:?} is not a number"))?;
        if !(0.0..=1.0).contains(&loss) {
            return Err(format!("loss {loss} is not a share of the flux (0 … 1)"));
        }
        let pole = pole
            .map(|p| {
                p.trim()
                    .parse::<u32>()
                    .map_err(|_| format!("pole {p:?} is not a pole number"))
            })
            .transpose()?;
        match (kind.trim(), pole) {
            ("uniform", None) => Ok(Self::Uniform { loss }),
            ("uniform", Some(_)) => Err("uniform demagnetization has no pole".to_string()),
            ("partial", pole) => Ok(Self::Partial {
                loss,
                pole: pole.unwrap_or(0),
            }),
            (other, _) => Err(format!("{other:?}: expected uniform or partial")),
        }
    }

    /// What is left of pole `k`'s flux (any integer: poles repeat every `poles`).
    fn pole_amplitude(self, k: i64, poles: i64) -> f64 {
        match self {
            Self::None => 1.0,
            Self::Uniform { loss } => 1.0 - loss,
            Self::Partial { loss, pole } if k.rem_euclid(poles) == i64::from(pole) % poles => {
                1.0 - loss
            }
            Self::Partial { .. } => 1.0,
        }
    }

    /// `faults` with its demagnetization k9 the mean flux this actuator has lost, k9's own
    /// uniform loss and this setting's together (clamped to [0, 1]): the truth an FDI that
    /// reads one flux scale is scored against.
    pub fn truth(self, faults: &FaultVector, pole_pairs: u32) -> FaultVector {
        if self == Self::None {
            return *faults;
        }
        let left = f64::from(faults.effects().flux_scale) * self.flux_left(pole_pairs);
        let mut k = *faults.as_array();
        if let Some(k9) = k.get_mut(DEMAGNETIZATION_INDEX) {
            *k9 = ((1.0 - left) / f64::from(DEMAGNETIZATION_LOSS_MAX)) as f32;
        }
        FaultVector::saturating(k)
    }

    /// The share of the rotor's flux that is left (the mean over the poles).
    pub fn flux_left(self, pole_pairs: u32) -> f64 {
        let poles = 2 * i64::from(pole_pairs.max(1));
        (0..poles)
            .map(|k| self.pole_amplitude(k, poles))
            .sum::<f64>()
            / poles as f64
    }
}

impl ReferenceModel {
    pub fn new(settings: ReferenceSettings) -> Self {
        Self {
            settings,
            test: PreflightTest::INJECTION,
            anomaly: None,
            sensor_fault: None,
            recording_hz: None,
            demagnetization: Demagnetization::None,
            wind: None,
            flight: None,
            flight_periods: None,
        }
    }

    /// In flight, a run of `periods` control periods after the hold instead of the test's:
    /// a flight that goes on past the test (its command zero after its last sample), for a
    /// controller outside the model that plays its own windows on the demand
    /// ([`AnalogSensors::demand`], [`simulate_driven`](Self::simulate_driven)). `None`: the
    /// test's length.
    pub fn with_flight_periods(mut self, periods: Option<usize>) -> Self {
        self.flight_periods = periods;
        self
    }

    /// The same actuator in flight (issue 36): the flight control computer's command added to
    /// the test's position command, and the hinge moment of [`ReferenceSettings::surface`] at
    /// the phase's dynamic pressure, trim incidence and turbulence (in place of any ground
    /// wind). The test should be one the position loop flies (the chirp alone): a standstill
    /// segment would suspend the loop in flight.
    pub fn with_flight(mut self, flight: Option<FlightWindow>) -> Self {
        self.flight = flight;
        self
    }

    /// The flight window this model plays.
    pub fn flight(&self) -> Option<FlightWindow> {
        self.flight
    }

    /// The same actuator parked in a wind: the hinge moment of [`ReferenceSettings::surface`]
    /// at the wind's speed, every control period, from the hold before the test to its end
    /// (the hold lasts at least [`WIND_SETTLE`] so the loop holds the mean moment when the
    /// test starts, as on the apron).
    pub fn with_wind(mut self, wind: Option<GroundWind>) -> Self {
        self.wind = wind;
        self
    }

    /// The wind this model plays on the parked surface.
    pub fn wind(&self) -> Option<GroundWind> {
        self.wind
    }

    /// The same actuator with demagnetized magnets.
    pub fn with_demagnetization(mut self, demagnetization: Demagnetization) -> Self {
        self.demagnetization = demagnetization;
        self
    }

    /// The same actuator on other settings (another day, another drive), everything else
    /// it plays kept.
    pub fn with_settings(mut self, settings: ReferenceSettings) -> Self {
        self.settings = settings;
        self
    }

    /// The magnets' demagnetization this model plays beside the fault vector's k9.
    pub fn demagnetization(&self) -> Demagnetization {
        self.demagnetization
    }

    /// The same actuator read through a faulty sensor.
    pub fn with_sensor_fault(mut self, fault: Option<SensorFault>) -> Self {
        self.sensor_fault = fault;
        self
    }

    /// Also records the sensors at `rate_hz` (a multiple-step period of the fine step, at or
    /// above the control rate) into [`Simulation::recording`], as a rig's data logger would.
    pub fn with_recording(mut self, rate_hz: f64) -> Self {
        self.recording_hz = Some(rate_hz);
        self
    }

    /// The same actuator driven by another chirp (the test's other segments unchanged).
    pub fn with_command(mut self, command: ChirpCommand) -> Self {
        self.test.chirp = command;
        self
    }

    /// The same actuator driven by another test design.
    pub fn with_test(mut self, test: PreflightTest) -> Self {
        self.test = test;
        self
    }

    pub fn test(&self) -> &PreflightTest {
        &self.test
    }

    /// The same actuator with a failure outside the fault vector.
    pub fn with_anomaly(mut self, anomaly: Anomaly) -> Self {
        self.anomaly = Some(anomaly);
        self
    }

    pub fn settings(&self) -> &ReferenceSettings {
        &self.settings
    }

    /// Control periods in the test.
    pub fn test_samples(&self) -> usize {
        self.test.samples(self.settings.params.control_period)
    }

    /// RMS of I_ref of the healthy actuator without process noise [A]: the reference level of
    /// [`Scenario::current_ref_noise`].
    pub fn nominal_current_ref_rms(&self) -> f64 {
        let sim = self.simulate(&Scenario::new(FaultVector::NOMINAL));
        // Over the chirp: the segments before it do not use the current loop alike.
        let lead = self.test.lead_samples();
        rms(sim.truth.iter().skip(lead).map(|t| t.current_ref))
    }

    /// Back-EMF shape of each phase over one mechanical revolution: the coupling of phase x
    /// at rotor angle θ_m is `k_e · N_x · shape[x][θ_m]` [V·s/rad = N·m/A]. Healthy flat top
    /// = 1. Exposed for tests and plots.
    pub fn coupling_shapes(&self, faults: &FaultVector) -> Box<[[f64; SHAPE_POINTS]; 3]> {
        let fx = faults.effects();
        let centre = self.settings.winding_group_angle;
        let psi_min = centre[0] + f64::from(fx.eccentricity_phase);
        let (z, phase_gain) = match self.settings.eccentricity {
            EccentricityPhysics::Permeance => (f64::from(fx.eccentricity_z), [1.0; 3]),
            EccentricityPhysics::PhaseGain => {
                let z = f64::from(fx.eccentricity_z);
                (0.0, centre.map(|c| 1.0 + z * (c - psi_min).cos()))
            }
        };
        let p = f64::from(self.settings.params.pole_pairs);
        let coil_pitch = PI / p;
        let w = self.settings.magnet_fringe;
        let permeance = |psi: f64| 1.0 / (1.0 - z * (psi - psi_min).cos());
        let poles = 2 * (p.round() as i64).max(1);
        let demagnetization = self.demagnetization;
        let flux_left = f64::from(fx.flux_scale);
        let amplitude = |k: i64| demagnetization.pole_amplitude(k, poles) * flux_left;
        let mut shapes = Box::new([[0.0; SHAPE_POINTS]; 3]);
        for (phase, table) in shapes.iter_mut().enumerate() {
            let coils = [
                (centre[phase] - 0.5 * coil_pitch, 1.0),
                (centre[phase] + 0.5 * coil_pitch, -1.0),
            ];
            for (j, slot) in table.iter_mut().enumerate() {
                let theta = TAU * j as f64 / SHAPE_POINTS as f64;
                let mut sum = 0.0;
                for (axis, polarity) in coils {
                    // dλ/dθ_m of a full-pitch coil = −polarity · ∫ M'(u) h(θ + u/P) du over
                    // the coil's electrical window u = P(ψ − θ), M' = ∓2/w on the two
                    // magnet-edge ramps (module docs).
                    let u0 = p * (axis - 0.5 * PI / p - theta);
                    sum -= polarity * edge_integral(u0, w, amplitude, |u| permeance(theta + u / p));
                }
                *slot = phase_gain[phase] * sum / 4.0;
            }
        }
        shapes
    }

    /// Simulates the whole test command. O(test duration / step).
    pub fn simulate(&self, scenario: &Scenario) -> Simulation {
        self.simulate_with(scenario, None)
    }

    /// [`simulate`](Self::simulate) with the bridge driven by `external` instead of the
    /// actuator's own controller: each control period `external` sees the sensors
    /// ([`AnalogSensors`]) and sets the legs' duties, from the period's first fine step; a
    /// leg it leaves off conducts through its diodes. The run ends with the test or when
    /// `external` returns `None`. The trace and truth are the reference model's own sensors'.
    pub fn simulate_driven(
        &self,
        scenario: &Scenario,
        external: &mut dyn ExternalDrive,
    ) -> Simulation {
        self.simulate_with(scenario, Some(external))
    }

    fn simulate_with(
        &self,
        scenario: &Scenario,
        mut external: Option<&mut dyn ExternalDrive>,
    ) -> Simulation {
        let s = &self.settings;
        let p = &s.params;
        let fx = scenario.faults.effects();
        let dt = s.step;
        let ts = f64::from(p.control_period);
        let steps_per_tick = (ts / dt).round().max(1.0) as usize;
        let test_samples = self.test_samples();
        let samples = match (self.flight, self.flight_periods) {
            (Some(_), Some(periods)) => periods,
            _ => test_samples,
        };
        let hold = if self.wind.is_some() || self.flight.is_some() {
            s.pre_roll.max(WIND_SETTLE)
        } else {
            s.pre_roll
        };
        let pre_roll = (hold / ts).round().max(0.0) as usize;
        // q·S·c and the incidence of each control period (none: still air on the ground),
        // and the flight control computer's command (in flight).
        let (load_scale, flight_command): (Vec<(f64, f64)>, Vec<f64>) =
            match (&self.flight, &self.wind) {
                (Some(f), _) => {
                    let scale = f.phase.dynamic_pressure() * s.surface.area * s.surface.chord;
                    f.samples(pre_roll + samples, ts, scenario.seed)
                        .into_iter()
                        .map(|x| ((scale, x.incidence), x.command))
                        .unzip()
                }
                (None, Some(w)) => (
                    w.speeds(pre_roll + samples, ts, scenario.seed)
                        .into_iter()
                        .map(|v| (s.surface.moment_scale(v), s.surface.parked_incidence))
                        .collect(),
                    Vec::new(),
                ),
                (None, None) => (Vec::new(), Vec::new()),
            };

        // The day: copper and magnets at the winding's temperature, grease at the gear's.
        let day = &s.conditions;
        let bridge = &s.bridge;
        let copper = s.thermal.copper_scale(day.winding_temperature);
        let flux = s.thermal.flux_scale(day.winding_temperature);
        let grease = s.thermal.friction_scale(day.gear_temperature);
        let drag = s.thermal.drag(day.gear_temperature);
        // Faulted constants; the harness is in series with each phase's copper.
        let phases: [Phase; 3] = core::array::from_fn(|x| {
            let n = f64::from(fx.healthy_turns[x]);
            Phase {
                resistance: f64::from(p.phase_resistance) * n * copper + bridge.harness_resistance,
                inductance: f64::from(p.phase_inductance) * n * n,
                coupling: f64::from(p.back_emf_constant) * n * flux,
            }
        });
        let shapes = self.coupling_shapes(&scenario.faults);
        let kp = f64::from(p.position_kp) * f64::from(fx.kp_scale);
        let static_friction = f64::from(p.static_friction) * f64::from(fx.friction_scale) * grease;
        let dynamic_friction =
            f64::from(p.dynamic_friction) * f64::from(fx.friction_scale) * grease;
        let stribeck = f64::from(p.stick_speed);
        let half_backlash = 0.5 * f64::from(p.nominal_backlash) * f64::from(fx.backlash_scale);
        let gear = f64::from(p.gear_ratio);
        let stiffness = f64::from(p.gear_stiffness);
        let damping = f64::from(p.gear_damping);
        let jm = f64::from(p.motor_inertia);
        let ju = f64::from(p.user_inertia);
        let aero = f64::from(p.aero_stiffness);
        let bus_mean = day.bus_voltage.unwrap_or(f64::from(p.dc_bus_voltage));
        let carrier = bridge.period(ts);
        let pole_pairs = f64::from(p.pole_pairs);
        let jammed = self.anomaly == Some(Anomaly::Jammed);
        let open_phase = match self.anomaly {
            Some(Anomaly::OpenPhase(x)) => Some(x % 3),
            _ => None,
        };

        // Random streams: sensors and process noise, independent, both from the seed.
        let mut sensor_rng = Gaussian::new(scenario.seed ^ 0x5E45_0125_u64);
        // The bus and temperature readings draw from their own stream.
        let mut condition_rng = Gaussian::new(scenario.seed ^ 0x0000_7E3B_u64);
        let cs = &s.condition_sensors;
        let current_ref_noise = if scenario.current_ref_noise > 0.0 {
            let level = scenario.current_ref_noise * self.nominal_current_ref_rms();
            band_limited_noise(pre_roll + samples, level, scenario.seed ^ 0x0000_1F5E_u64)
        } else {
            vec![0.0; pre_roll + samples]
        };

        let current_lsb = 2.0 * s.current_full_scale / 2f64.powi(s.current_bits as i32);
        let encoder_lsb = TAU / 2f64.powi(s.encoder_bits as i32);
        let user_lsb = 2.0 * s.user_full_scale / 2f64.powi(s.user_bits as i32);

        // State.
        let mut i = [0.0f64; 3];
        let mut legs = [0i8; 3];
        // The rotor starts where the rigging put it: at the encoder offset, surface at 0.
        let rigging = s.encoder_offset;
        let (mut theta_m, mut omega_m, mut theta_u, mut omega_u) = (rigging, 0.0, 0.0, 0.0);
        let (mut position_integral, mut previous_error, mut speed_integral) = (0.0f64, 0.0, 0.0);
        let mut previous_encoder: Option<f64> = None;
        let mut held_encoder: Option<f64> = None;
        let lead = self.test.lead_samples();
        let mut ledger = EnergyLedger::default();
        // Anti-alias filter of each current-sense channel: output and its derivative.
        let aa_omega = TAU * s.anti_alias_hz;
        let mut sensed_filter = [[0.0f64; 2]; 3];
        // The controller's timing: each period's output (pair drive, duties, current
        // reference) takes effect `delay_steps` fine steps after its sample; until then the
        // previous period's holds (at the start: the drive off, no current asked).
        let delay_steps = (bridge.duty_delay / dt)
            .round()
            .clamp(0.0, steps_per_tick as f64) as usize;
        let mut held_output: Output = (None, None, 0.0);

        // The trace declares the design by its code, as files do: the segments, with the
        // preflight chirp the FDI expects (a test of another chirp is an anomaly it must
        // find, not be told).
        let declared = PreflightTest {
            chirp: ChirpCommand::PREFLIGHT,
            ..self.test
        };
        let mut trace = Trace::with_capacity(samples).with_test(declared);
        if self.flight.is_some() {
            trace = trace.as_flight();
        }
        let mut truth = Vec::with_capacity(samples);
        // The rig's logger: its own noise stream, every `record_every` fine steps.
        let record_every = self
            .recording_hz
            .map(|hz| ((1.0 / (hz * dt)).round() as usize).clamp(1, steps_per_tick));
        let mut recording = Vec::new();
        let mut rig_rng = Gaussian::new(scenario.seed ^ 0x0000_4A61_u64);

        for (n, &process_noise) in current_ref_noise.iter().enumerate() {
            // `tick` is `None` during the pre-roll: zero command, nothing recorded.
            let tick = n.checked_sub(pre_roll);

            // ---- sensors (what the ADC latches at this instant) ----
            let mut analogue = if s.anti_alias_hz > 0.0 {
                sensed_filter.map(|[x, _]| x)
            } else {
                i
            };
            let mut encoder = quantise_angle(theta_m, encoder_lsb);
            // A faulty sensor between the actuator and the controller (none: no change).
            let mut user_slip = 0.0;
            if let Some(fault) = &self.sensor_fault {
                let chirp_time = tick
                    .and_then(|k| k.checked_sub(lead))
                    .map(|j| j as f64 * f64::from(p.control_period));
                fault.apply(
                    chirp_time,
                    f64::from(p.control_period),
                    &mut analogue,
                    &mut encoder,
                    &mut held_encoder,
                    &mut user_slip,
                );
            }
            // The same draws, in the same order, as quantising each phase in turn.
            let current_noise: [f64; 3] =
                core::array::from_fn(|_| s.current_noise * sensor_rng.next());
            let sensed_currents: [f64; 3] = core::array::from_fn(|x| {
                quantise(
                    analogue[x] + current_noise[x],
                    current_lsb,
                    s.current_full_scale,
                )
            });
            let now = (n * steps_per_tick) as f64 * dt;
            let bus_sensed = bridge.bus(bus_mean, now) * (1.0 + cs.bus_gain_error)
                + cs.bus_noise * condition_rng.next();
            let measured_bus = to_lsb(bus_sensed, cs.bus_lsb);
            let temperature_sensed = day.winding_temperature
                + cs.temperature_bias
                + cs.temperature_noise * condition_rng.next();
            let measured_temperature = to_lsb(temperature_sensed, cs.temperature_lsb);
            let user_analogue =
                theta_u + s.user_offset + s.user_noise * sensor_rng.next() + user_slip;
            let user_sensed = quantise(user_analogue, user_lsb, s.user_full_scale);
            // The command samples are the monitor model's, bit for bit (same f32 time).
            let drive = tick
                .filter(|&k| k < test_samples)
                .map_or(Drive::Position(0.0), |k| {
                    self.test.drive(k, p.control_period)
                });
            let (command, pair_drive) = match drive {
                Drive::Position(x) => (
                    f64::from(x) + flight_command.get(n).copied().unwrap_or(0.0),
                    None,
                ),
                Drive::Pair(d) => (0.0, Some(d)),
            };
            if let Some(k) = tick {
                trace.push(TraceSample {
                    time: k as f64 / f64::from(crate::files::trace::SAMPLE_RATE_HZ),
                    command,
                    phase_currents: sensed_currents,
                    motor_angle: encoder,
                    user_angle: user_sensed,
                    bus_voltage: Some(measured_bus),
                    temperature: Some(measured_temperature),
                });
            }

            // ---- ACE controller ----
            let error = command - user_sensed;
            position_integral += error * ts;
            let error_rate = (error - previous_error) / ts;
            previous_error = error;
            let speed_ref = (kp * error
                + f64::from(p.position_ki) * position_integral
                + f64::from(p.position_kd) * error_rate)
                .clamp(-f64::from(p.max_speed), f64::from(p.max_speed));
            let speed_estimate = match previous_encoder {
                Some(prev) => (encoder - prev) / ts,
                None => 0.0,
            };
            previous_encoder = Some(encoder);
            let speed_error = speed_ref - speed_estimate;
            let integral = speed_integral + speed_error * ts;
            let unsaturated =
                f64::from(p.speed_kp) * speed_error + f64::from(p.speed_ki) * integral;
            let max_current = f64::from(p.max_current);
            let saturated = unsaturated.clamp(-max_current, max_current);
            if unsaturated == saturated || (unsaturated > saturated) != (speed_error > 0.0) {
                speed_integral = integral;
            }
            let mut current_ref = (saturated + process_noise).clamp(-max_current, max_current);
            if pair_drive.is_some() {
                // Position loop suspended: the loops restart empty when it closes again.
                position_integral = 0.0;
                speed_integral = 0.0;
                current_ref = 0.0;
            }

            let shape = lookup(&shapes, theta_m);
            if tick.is_some() {
                truth.push(TruthSample {
                    current_ref,
                    phase_currents: i,
                    motor_angle: theta_m,
                    motor_speed: omega_m,
                    user_angle: theta_u,
                    motor_torque: (0..3).map(|x| phases[x].coupling * shape[x] * i[x]).sum(),
                    applied_voltages: [0.0; 3],
                });
            }
            let mut applied = [0.0f64; 3];
            // Centre-aligned PWM of the standstill segment: leg x is commanded high for the
            // middle `duty_x` of each carrier period, duty = ½ ± V/(2·V_bus,measured), plus
            // the dead time by the measured current's sign, in whole counts.
            let pwm_duty = pair_drive.map(|d| {
                let signs = d.signs();
                core::array::from_fn::<f64, 3, _>(|x| {
                    let leg = f64::from(signs[x]) * f64::from(d.voltage(p.control_period)) * 0.5;
                    bridge.duty(leg, measured_bus, sensed_currents[x])
                })
            });
            let mut output: Output = (pair_drive, pwm_duty, current_ref);
            // An external controller's legs replace the actuator's own drive, from the
            // period's first step (its converters and timer pace it).
            let mut driven = [true; 3];
            if let Some(ext) = external.as_deref_mut() {
                let sensed = AnalogSensors {
                    phase_currents: core::array::from_fn(|x| analogue[x] + current_noise[x]),
                    motor_angle: theta_m,
                    user_angle: user_analogue,
                    bus_voltage: bus_sensed,
                    temperature: temperature_sensed,
                    demand: self.flight.and(flight_command.get(n).copied()),
                };
                let Some(legs) = ext.period(&sensed) else {
                    break;
                };
                driven = legs.map(|l| l.is_some());
                output = (None, Some(legs.map(|l| l.unwrap_or(0.0))), 0.0);
                held_output = output;
            }
            let previous_output = core::mem::replace(&mut held_output, output);

            // ---- power stage, motor and mechanics, `steps_per_tick` fine steps ----
            for fine in 0..steps_per_tick {
                let (pair_drive, pwm_duty, current_ref) = if fine < delay_steps {
                    previous_output
                } else {
                    output
                };
                if let Some(every) = record_every {
                    let step = n * steps_per_tick + fine;
                    if step % every == 0 {
                        let analogue = if s.anti_alias_hz > 0.0 {
                            sensed_filter.map(|[x, _]| x)
                        } else {
                            i
                        };
                        // At a control instant the logger reads the very signal the
                        // controller's ADC latched (same noise); in between, fresh noise.
                        let (phase_currents, user_angle) = if fine == 0 {
                            (sensed_currents, user_sensed)
                        } else {
                            (
                                analogue.map(|x| {
                                    quantise(
                                        x + s.current_noise * rig_rng.next(),
                                        current_lsb,
                                        s.current_full_scale,
                                    )
                                }),
                                quantise(
                                    theta_u + s.user_offset + s.user_noise * rig_rng.next(),
                                    user_lsb,
                                    s.user_full_scale,
                                ),
                            )
                        };
                        recording.push(TraceSample {
                            time: step as f64 * dt,
                            command,
                            phase_currents,
                            motor_angle: quantise_angle(theta_m, encoder_lsb),
                            user_angle,
                            bus_voltage: Some(measured_bus),
                            temperature: Some(measured_temperature),
                        });
                    }
                }
                let theta_e = pole_pairs * theta_m;
                let sector = ((theta_e * 3.0 / PI + 0.5).floor() as i64).rem_euclid(6) as usize;
                let (signs, floating) = match pair_drive {
                    Some(d) => {
                        let signs = d.signs();
                        (signs, signs.iter().position(|&x| x == 0).unwrap_or(2))
                    }
                    None if external.is_some() => (
                        COMMUTATION_SIGNS[sector],
                        driven.iter().position(|&d| !d).unwrap_or(sector % 3),
                    ),
                    None => (COMMUTATION_SIGNS[sector], sector % 3),
                };

                let shape = lookup(&shapes, theta_m);
                let coupling: [f64; 3] = core::array::from_fn(|x| phases[x].coupling * shape[x]);
                let emf = coupling.map(|k| k * omega_m);

                // Leg voltages: hysteresis on the conducting phases, diodes on the open one,
                // through the bridge's switches, dead time and bus ripple.
                let vdc = bridge.bus(bus_mean, (n * steps_per_tick + fine) as f64 * dt);
                let mut v = [0.0f64; 3];
                for x in 0..3 {
                    if x == floating || !driven[x] {
                        legs[x] = 0;
                        v[x] = bridge.diode_leg(vdc, i[x]);
                    } else if let Some(duty) = pwm_duty {
                        legs[x] = 0;
                        let t0 = fine as f64 * dt;
                        v[x] = bridge.leg_voltage(duty[x], carrier, t0, dt, vdc, i[x]);
                    } else {
                        let reference = f64::from(signs[x]) * current_ref;
                        if i[x] < reference - s.hysteresis_band {
                            legs[x] = 1;
                        } else if i[x] > reference + s.hysteresis_band {
                            legs[x] = -1;
                        } else if legs[x] == 0 {
                            legs[x] = if i[x] < reference { 1 } else { -1 };
                        }
                        v[x] = bridge.switched_leg(legs[x], vdc, i[x]);
                    }
                }

                // Current derivatives with a floating neutral.
                let mut di = [0.0f64; 3];
                let (y, z) = ((floating + 1) % 3, (floating + 2) % 3);
                let blocked_off =
                    driven == [false; 3] && i == [0.0; 3] && (emf[y] - emf[z]).abs() < vdc;
                if blocked_off {
                    // Every switch off, no current, the motor's line voltage below the bus:
                    // the diodes block.
                } else if let Some(x) = open_phase {
                    // Only the other two phases form a circuit, in series; none if one of
                    // them is the floating leg with its diodes blocking.
                    let (y, z) = ((x + 1) % 3, (x + 2) % 3);
                    let blocked = (y == floating || z == floating) && i[floating] == 0.0;
                    if !blocked {
                        let r = phases[y].resistance + phases[z].resistance;
                        let l = phases[y].inductance + phases[z].inductance;
                        let d = (v[y] - v[z] - r * i[y] - emf[y] + emf[z]) / l;
                        di[y] = d;
                        di[z] = -d;
                    }
                } else if i[floating] == 0.0 {
                    // The open phase carries nothing: the other two are in series.
                    let (y, z) = ((floating + 1) % 3, (floating + 2) % 3);
                    let r = phases[y].resistance + phases[z].resistance;
                    let l = phases[y].inductance + phases[z].inductance;
                    let d = (v[y] - v[z] - r * i[y] - emf[y] + emf[z]) / l;
                    di[y] = d;
                    di[z] = -d;
                } else {
                    let mut num = 0.0;
                    let mut den = 0.0;
                    for x in 0..3 {
                        num += (v[x] - phases[x].resistance * i[x] - emf[x]) / phases[x].inductance;
                        den += 1.0 / phases[x].inductance;
                    }
                    let neutral = num / den;
                    for x in 0..3 {
                        di[x] = (v[x] - phases[x].resistance * i[x] - emf[x] - neutral)
                            / phases[x].inductance;
                    }
                }

                let motor_torque: f64 = (0..3).map(|x| coupling[x] * i[x]).sum();

                let previous = i;
                for x in 0..3 {
                    i[x] += di[x] * dt;
                    applied[x] += v[x] / steps_per_tick as f64;
                }
                // Energy booked at the step's mid-point current: with explicit Euler that makes
                // Σ v·i = Σ R·i·i_mid + Δ(½Li²) + Σ e·i_mid hold step by step (booking at the
                // old current would miss ½·L·Δi² per step of switching ripple).
                for x in 0..3 {
                    let mid = 0.5 * (previous[x] + i[x]);
                    ledger.electrical_input += v[x] * mid * dt;
                    ledger.copper_loss += phases[x].resistance * previous[x] * mid * dt;
                    ledger.converted += emf[x] * mid * dt;
                }
                ledger.shaft_work += motor_torque * omega_m * dt;
                let previous_floating = previous[floating];
                // The diode of the open leg blocks once its current reaches zero.
                if previous_floating != 0.0
                    && (i[floating] == 0.0 || i[floating].signum() != previous_floating.signum())
                {
                    i[floating] = 0.0;
                    let (y, z) = ((floating + 1) % 3, (floating + 2) % 3);
                    let residual = 0.5 * (i[y] + i[z]);
                    i[y] -= residual;
                    i[z] -= residual;
                }
                if let Some(x) = open_phase {
                    // The series constraint again after the diode rule above.
                    let (y, z) = ((x + 1) % 3, (x + 2) % 3);
                    let blocked = (y == floating || z == floating) && i[floating] == 0.0;
                    let m = if blocked { 0.0 } else { 0.5 * (i[y] - i[z]) };
                    i[x] = 0.0;
                    i[y] = m;
                    i[z] = -m;
                }

                // Gear train: dead zone, compliant contact with damping, never pulling.
                let deflection = (theta_m - rigging) / gear - theta_u;
                let engaged = deflection - deflection.clamp(-half_backlash, half_backlash);
                let relative_speed = omega_m / gear - omega_u;
                let mut gear_torque = 0.0;
                if engaged != 0.0 {
                    let t = stiffness * engaged + damping * relative_speed;
                    if t.signum() == engaged.signum() {
                        gear_torque = t;
                        ledger.mechanical_loss += damping * relative_speed * relative_speed * dt;
                    } else {
                        // The contact opens while compressed: the spring energy it gives up
                        // does no work.
                        ledger.contact_release -= stiffness * engaged * relative_speed * dt;
                    }
                }

                // Motor: Karnopp stick-slip with a Stribeck drop.
                let drive = motor_torque - gear_torque / gear;
                let friction = if omega_m.abs() < s.stick_band {
                    drive.clamp(-static_friction, static_friction)
                } else {
                    omega_m.signum()
                        * (dynamic_friction
                            + (static_friction - dynamic_friction)
                                * (-(omega_m / stribeck).powi(2)).exp())
                };
                let stuck = omega_m.abs() < s.stick_band && drive.abs() <= static_friction;
                let new_omega_m = if stuck {
                    0.0
                } else {
                    let w = omega_m + dt * (drive - friction - drag * omega_m) / jm;
                    // Sliding friction stops the motor, it never reverses it.
                    if omega_m != 0.0 && w.signum() != omega_m.signum() {
                        0.0
                    } else {
                        w
                    }
                };
                ledger.mechanical_loss +=
                    (friction * omega_m).abs() * dt + drag * omega_m * omega_m * dt;

                // User shaft: aero hinge moment and end stops.
                let mut load = -aero * theta_u - s.aero_damping * omega_u;
                if let Some(&(scale, incidence)) = load_scale.get(n) {
                    load += s.surface.hinge_moment(scale, incidence, theta_u);
                }
                ledger.mechanical_loss += s.aero_damping * omega_u * omega_u * dt;
                let beyond = theta_u - theta_u.clamp(-s.end_stop_angle, s.end_stop_angle);
                if beyond != 0.0 {
                    load += -s.end_stop_stiffness * beyond - s.end_stop_damping * omega_u;
                    ledger.mechanical_loss += s.end_stop_damping * omega_u * omega_u * dt;
                }
                let new_omega_u = if jammed {
                    0.0
                } else {
                    omega_u + dt * (gear_torque + load) / ju
                };

                omega_m = new_omega_m;
                omega_u = new_omega_u;
                theta_m += omega_m * dt;
                theta_u += omega_u * dt;

                // Anti-alias filters (semi-implicit Euler; ω·dt ≈ 0.02).
                for (state, &current) in sensed_filter.iter_mut().zip(&i) {
                    let [y, dy] = *state;
                    let ddy = aa_omega * aa_omega * (current - y) - SQRT_2 * aa_omega * dy;
                    let dy = dy + ddy * dt;
                    *state = [y + dy * dt, dy];
                }
            }
            if let (Some(_), Some(last)) = (tick, truth.last_mut()) {
                last.applied_voltages = applied;
            }
        }

        let deflection = (theta_m - rigging) / gear - theta_u;
        let engaged = deflection - deflection.clamp(-half_backlash, half_backlash);
        let beyond = theta_u - theta_u.clamp(-s.end_stop_angle, s.end_stop_angle);
        ledger.magnetic = (0..3)
            .map(|x| 0.5 * phases[x].inductance * i[x] * i[x])
            .sum();
        ledger.mechanical_stored = 0.5 * jm * omega_m * omega_m
            + 0.5 * ju * omega_u * omega_u
            + 0.5 * stiffness * engaged * engaged
            + 0.5 * aero * theta_u * theta_u
            + 0.5 * s.end_stop_stiffness * beyond * beyond;

        Simulation {
            trace,
            truth,
            energy: ledger,
            recording,
        }
    }
}

/// ∫ M'(u)·h(u) du over the coil window `[u0, u0 + π]` (4-point Gauss–Legendre per piece).
/// Pole `k` spans `u ∈ (kπ − π/2, kπ + π/2)` with magnetisation `(−1)^k · a(k)`; between
/// poles `n` and `n + 1` the ramp centred at `π/2 + nπ` has slope `(M_{n+1} − M_n)/w`:
/// `∓(a(n) + a(n+1))/w`, −2/w and +2/w alternately for whole magnets.
fn edge_integral(u0: f64, w: f64, a: impl Fn(i64) -> f64, h: impl Fn(f64) -> f64) -> f64 {
    const NODES: [f64; 4] = [
        -0.861_136_311_594_052_6,
        -0.339_981_043_584_856_3,
        0.339_981_043_584_856_3,
        0.861_136_311_594_052_6,
    ];
    const WEIGHTS: [f64; 4] = [
        0.347_854_845_137_453_9,
        0.652_145_154_862_546_1,
        0.652_145_154_862_546_1,
        0.347_854_845_137_453_9,
    ];
    let lo = u0;
    let hi = u0 + PI;
    let mut total = 0.0;
    let first = ((lo - w - FRAC_PI_2) / PI).floor() as i64;
    let last = ((hi + w - FRAC_PI_2) / PI).ceil() as i64;
    for n in first..=last {
        // Ramps alternate: centre π/2 + nπ, falling for even n, rising for odd n.
        let centre = FRAC_PI_2 + n as f64 * PI;
        let step = a(n) + a(n + 1);
        let slope = if n.rem_euclid(2) == 0 {
            -step / w
        } else {
            step / w
        };
        let a = lo.max(centre - 0.5 * w);
        let b = hi.min(centre + 0.5 * w);
        if b <= a {
            continue;
        }
        let half = 0.5 * (b - a);
        let mid = 0.5 * (a + b);
        let integral: f64 = NODES
            .iter()
            .zip(WEIGHTS)
            .map(|(x, wt)| wt * h(mid + half * x))
            .sum();
        total += slope * half * integral;
    }
    total
}

/// Linear interpolation of the three shape tables at mechanical angle `theta_m`.
fn lookup(shapes: &[[f64; SHAPE_POINTS]; 3], theta_m: f64) -> [f64; 3] {
    let x = theta_m.rem_euclid(TAU) * (SHAPE_POINTS as f64 / TAU);
    let j = (x.floor() as usize) % SHAPE_POINTS;
    let frac = x - x.floor();
    let next = (j + 1) % SHAPE_POINTS;
    core::array::from_fn(|p| shapes[p][j] + frac * (shapes[p][next] - shapes[p][j]))
}

/// Quantises to the nearest ADC code within ±`full_scale`.
fn quantise(x: f64, lsb: f64, full_scale: f64) -> f64 {
    ((x / lsb).round() * lsb).clamp(-full_scale, full_scale - lsb)
}

/// An absolute encoder reading, unwrapped (multi-turn counter).
fn quantise_angle(theta: f64, lsb: f64) -> f64 {
    (theta / lsb).floor() * lsb
}

fn rms(values: impl Iterator<Item = f64>) -> f64 {
    let (sum, n) = values.fold((0.0, 0usize), |(s, n), x| (s + x * x, n + 1));
    if n == 0 {
        0.0
    } else {
        (sum / n as f64).sqrt()
    }
}

/// `n` samples of band-limited white noise in the sense of Simulink's block of that name:
/// independent Gaussian values held over one control period each (white up to the 5 kHz
/// Nyquist frequency of the 10 kHz hold), scaled to RMS `level` exactly.
fn band_limited_noise(n: usize, level: f64, seed: u64) -> Vec<f64> {
    let mut g = Gaussian::new(seed);
    let mut out: Vec<f64> = (0..n).map(|_| g.next()).collect();
    let r = rms(out.iter().copied());
    if r > 0.0 {
        for y in &mut out {
            *y *= level / r;
        }
    }
    out
}
