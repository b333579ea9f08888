//! What the board's drive and sensors cost a window of flight. The board's flight drive
//! (`firmware::flight::FlightCommand` through `BridgeDrive` and its position loop) flies the
//! reference model on the host, without the emulator: its duties act from the next control
//! period, as TIM1's preloaded compare registers make them act on the board, and it reads the
//! encoder and the surface transducer at a chosen resolution. The window it flew (the
//! frames it read, the command it followed, as `feed::window_trace` writes the board's) is
//! read by the onboard FDI's code with the flight's preflight held (the same faults and seed
//! under the actuator's own controller), as the board reads it.
//!
//! Per row: one flight of [`FLIGHT_PERIODS`] control periods on the reference model and one
//! window identification (≈ 1 s on the host in release). Angles in rad, currents in A.

use anyhow::{Context, Result};
use firmware::acquisition::SensorScaling;
use firmware::bridge::{BridgeDrive, BridgeTiming, LatchedLegs};
use firmware::flight::FlightCommand;
use firmware::position_loop::{Feedback, Sensing};
use host_sim::files::actuator::Actuator;
use host_sim::files::trace::{Trace, TraceSample, SAMPLE_RATE_HZ};
use host_sim::plant::aero::{FlightPhase, FlightWindow, Turbulence};
use host_sim::plant::reference::{AnalogSensors, ExternalDrive, ReferenceModel, Scenario};
use shared::actuator::ActuatorRecord;
use shared::FaultVector;

/// Control periods flown: the window begins at [`WINDOW_FROM`] and its chirp (5 000 frames on
/// the reference actuator) ends before the flight does.
pub const FLIGHT_PERIODS: usize = 12_000;
/// The frame at which the window's chirp begins (after the demand filter and the loop settled).
pub const WINDOW_FROM: usize = 6_000;

/// How finely the drive reads its shafts: `None` is the reference model's own sensor (20 bits).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Resolution {
    /// Encoder counts per motor revolution.
    pub encoder_counts: Option<u32>,
    /// Surface transducer's step [rad].
    pub transducer_step: Option<f32>,
}

impl Resolution {
    /// The board: TIM3's quadrature count of a 2 048-line encoder and a 12-bit ADC over the
    /// transducer's ±0.5 rad (`SensorScaling::REFERENCE_BOARD`).
    pub const BOARD: Self = Self {
        encoder_counts: Some(8_192),
        transducer_step: Some(SensorScaling::REFERENCE_BOARD.transducer_rad_per_count),
    };
    /// The actuator's own sensors as the reference model reads them (20-bit absolute encoder,
    /// 20-bit transducer).
    pub const ACTUATOR: Self = Self {
        encoder_counts: None,
        transducer_step: None,
    };
}

/// One drive and its sensors, a row of the study.
#[derive(Clone, Copy, Debug)]
pub struct DriveCase {
    pub name: &'static str,
    pub sensing: Sensing,
    pub resolution: Resolution,
    /// The duties act from the next control period (TIM1's preload); `false`: at once.
    pub late_duties: bool,
}

/// The study's rows: the board as built, each of its two coarse sensors alone, the board's
/// loop on the actuator's sensors, and the monitor model's own controller (duties at once,
/// the sensors as they come).
pub const CASES: [DriveCase; 5] = [
    DriveCase {
        name: "the board: 2 048-line encoder, 12-bit transducer",
        sensing: Sensing::BOARD,
        resolution: Resolution::BOARD,
        late_duties: true,
    },
    DriveCase {
        name: "the board's loop, 20-bit encoder, 12-bit transducer",
        sensing: Sensing::BOARD,
        resolution: Resolution {
            encoder_counts: None,
            ..Resolution::BOARD
        },
        late_duties: true,
    },
    DriveCase {
        name: "the board's loop, 2 048-line encoder, 20-bit transducer",
        sensing: Sensing::BOARD,
        resolution: Resolution {
            transducer_step: None,
            ..Resolution::BOARD
        },
        late_duties: true,
    },
    DriveCase {
        name: "the board's loop on the actuator's 20-bit sensors",
        sensing: Sensing::BOARD,
        resolution: Resolution::ACTUATOR,
        late_duties: true,
    },
    DriveCase {
        name: "the monitor model's controller: duties at once, 20-bit sensors",
        sensing: Sensing::DIRECT,
        resolution: Resolution::ACTUATOR,
        late_duties: false,
    },
];

/// A window read from one case's flight.
#[derive(Clone, Copy, Debug)]
pub struct WindowRow {
    /// The share of the window's current the fit leaves unexplained (the verdict's misfit).
    pub misfit: f32,
    pub verdict: Result<(), shared::window::WindowReason>,
    /// The window's reading of the friction (k1).
    pub friction: f32,
    /// RMS of the command less the surface as the drive read it over the window [rad].
    pub tracking: f32,
}

/// The board's flight drive on the reference model's pins: one period per call.
struct FlightDrive<'a> {
    drive: BridgeDrive<&'a mut LatchedLegs>,
    command: FlightCommand,
    record: ActuatorRecord,
    case: DriveCase,
    counts: f32,
    motor_zero: Option<f64>,
    frames: usize,
    /// The duties written last period: with late duties, what acts in this one.
    acting: [Option<f64>; 3],
    window: Trace,
    tracking: (f64, usize),
}

impl FlightDrive<'_> {
    fn feedback(&mut self, s: &AnalogSensors) -> Feedback {
        let r = self.case.resolution;
        let zero = *self.motor_zero.get_or_insert(s.motor_angle);
        let step = |x: f64, lsb: Option<f32>| match lsb {
            Some(lsb) => ((x as f32) / lsb).round() * lsb,
            None => x as f32,
        };
        let amps = SensorScaling::REFERENCE_BOARD.amps_per_count;
        Feedback {
            phase_currents: s.phase_currents.map(|i| step(i, Some(amps))),
            motor_angle: step(
                s.motor_angle - zero,
                r.encoder_counts.map(|n| core::f32::consts::TAU / n as f32),
            ),
            user_angle: step(s.user_angle, r.transducer_step),
            bus_voltage: s.bus_voltage as f32,
        }
    }
}

impl ExternalDrive for FlightDrive<'_> {
    fn period(&mut self, s: &AnalogSensors) -> Option<[Option<f64>; 3]> {
        let feedback = self.feedback(s);
        self.drive.measured(feedback);
        let demand = s.demand? as f32;
        let test = self.record.test;
        let period = self.record.params.control_period;
        if self.frames == WINDOW_FROM {
            self.command.begin_window(test, period);
        }
        let acting = self.command.tick(demand, &mut self.drive);
        let k = self.frames.wrapping_sub(WINDOW_FROM);
        if self.frames >= WINDOW_FROM && self.command.in_window() {
            self.window.push(TraceSample {
                time: k as f64 / f64::from(SAMPLE_RATE_HZ),
                command: f64::from(shared::trace::command_as_traced(acting)),
                phase_currents: feedback.phase_currents.map(f64::from),
                motor_angle: f64::from(feedback.motor_angle),
                user_angle: f64::from(feedback.user_angle),
                bus_voltage: Some(s.bus_voltage),
                temperature: Some(s.temperature),
            });
            let e = f64::from(acting - feedback.user_angle);
            self.tracking = (self.tracking.0 + e * e, self.tracking.1 + 1);
        }
        self.frames += 1;
        let counts = self.counts;
        let now = self
            .drive
            .legs_mut()
            .0
            .map(|l| l.map(|d| f64::from(d) / f64::from(counts)));
        Some(if self.case.late_duties {
            core::mem::replace(&mut self.acting, now)
        } else {
            now
        })
    }
}

/// `case` flown through `phase` (light turbulence) on `actuator` with `faults` and reference-
/// model seed `seed`; its window read with the same seed's preflight held (GA seed 1).
pub fn fly_case(
    actuator: &Actuator,
    case: DriveCase,
    phase: FlightPhase,
    faults: FaultVector,
    seed: u64,
) -> Result<WindowRow> {
    let full = actuator.record_for(&actuator.record.test)?;
    let p = full.params;
    let settings = actuator.reference_settings()?;
    let ground = ReferenceModel::new(settings).with_test(full.test);
    let scenario = Scenario {
        seed,
        ..Scenario::new(faults)
    };
    // The flight's preflight, under the actuator's own controller.
    let pre = ground.simulate(&scenario).trace;
    let measured = pre.measured(&p)?;
    let host_pre = host_sim::fdi::identify::identify_for(&measured, &full, 1, false)?;
    let within =
        host_pre.domain(&pre.domain_monitor(&p), &full.domain) == shared::domain::Domain::Within;
    let held = host_sim::fdi::window::held_from(&host_pre, within);

    // The window's record, as the board reads a window: its test's chirp alone.
    let record = ActuatorRecord {
        test: full.test.chirp_only(),
        ..full
    };
    let drive_settings = actuator.record.drive;
    let timing = BridgeTiming::new(&drive_settings, 168_000_000, p.control_period)
        .map_err(|e| anyhow::anyhow!("the board's timer: {e:?}"))?;
    let mut latched = LatchedLegs::default();
    let mut flight = FlightDrive {
        drive: BridgeDrive::new(&mut latched, timing, drive_settings, &p, case.sensing),
        command: FlightCommand::follow(p.control_period),
        record,
        case,
        counts: f32::from(timing.counts),
        motor_zero: None,
        frames: 0,
        acting: [None; 3],
        window: Trace::with_capacity(5_000)
            .with_test(record.test)
            .as_flight(),
        tracking: (0.0, 0),
    };
    let model = ground
        .with_test(record.test)
        .with_flight(Some(FlightWindow {
            phase,
            turbulence: Turbulence::Light,
        }))
        .with_flight_periods(Some(FLIGHT_PERIODS));
    model.simulate_driven(&scenario, &mut flight);
    let window = &flight.window;
    let w_measured = window
        .measured(&p)
        .with_context(|| format!("{}: the window flown", case.name))?;
    let read = host_sim::fdi::window::identify_window(window, &w_measured, &record, held, 1)?;
    let (sum, n) = flight.tracking;
    Ok(WindowRow {
        misfit: read.misfit,
        verdict: read.verdict,
        friction: read.faults.as_array()[0],
        tracking: (sum / n.max(1) as f64).sqrt() as f32,
    })
}

/// Every case of [`CASES`] through each of `phases`, on reference-model seeds `seeds`, as a
/// Markdown table: per case and phase, each seed's share of the current unexplained, how many
/// windows are under the limit, how many are read, and the friction they read.
pub fn table(
    actuator: &Actuator,
    phases: &[FlightPhase],
    faults: FaultVector,
    seeds: core::ops::Range<u64>,
    mut progress: impl FnMut(&str),
) -> Result<String> {
    let limit = shared::window::WindowLimits::REFERENCE.max_misfit;
    let mut out = format!(
        "### What the board's drive and sensors cost a window ({}, faults {}, seeds {}–{})\n\n\
         The board's flight drive flies the reference model in light turbulence with its \
         duties a control period late (TIM1's preload), reading its shafts as each row says; \
         the window it flew is read by the onboard FDI's code with the same seed's preflight \
         held. A window is read only if the fit leaves at most {:.0} % of its current \
         unexplained; under it, a window may still be named for its turbulence or an unseen \
         play.\n\n\
         | drive and sensors | phase | unexplained [%], each seed | under {:.0} % | read | friction read (mean) | tracking [mrad RMS] |\n\
         | --- | --- | --- | ---: | ---: | ---: | ---: |\n",
        actuator.name,
        faults
            .as_array()
            .iter()
            .map(|k| format!("{k}"))
            .collect::<Vec<_>>()
            .join(","),
        seeds.start,
        seeds.end.saturating_sub(1),
        100.0 * limit,
        100.0 * limit,
    );
    for case in CASES {
        for &phase in phases {
            progress(&format!("{} — {phase:?}", case.name));
            let rows = seeds
                .clone()
                .map(|seed| fly_case(actuator, case, phase, faults, seed))
                .collect::<Result<Vec<_>>>()?;
            let n = rows.len().max(1) as f32;
            let misfits: Vec<String> = rows
                .iter()
                .map(|r| format!("{:.2}", 100.0 * r.misfit))
                .collect();
            out.push_str(&format!(
                "| {} | {phase:?} | {} | {}/{} | {}/{} | {:.3} | {:.3} |\n",
                case.name,
                misfits.join(" / "),
                rows.iter().filter(|r| r.misfit <= limit).count(),
                rows.len(),
                rows.iter().filter(|r| r.verdict.is_ok()).count(),
                rows.len(),
                rows.iter().map(|r| r.friction).sum::<f32>() / n,
                1e3 * rows.iter().map(|r| r.tracking).fold(0.0, f32::max),
            ));
        }
    }
    Ok(out)
}
