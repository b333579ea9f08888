//! Windows of flight (issue 36). The preflight FDI's monitor model plays the preflight chirp
//! alone, so a window of flight (the flight control computer's corrections, trim and
//! turbulence on the surface) must never be read `within` by it — it is named outside,
//! whatever the phase, the turbulence and the faults. The window identification reads the
//! calm windows it can, right, and names the others; a flight's reading from its windows
//! fused is right where it is `within`; a window keeps its mark in a trace file.

use host_sim::fdi::window::WindowSearch;
use host_sim::plant::reference::{ReferenceModel, ReferenceSettings};
use host_sim::studies::flight::{flight_campaign, ALL_WINDOWS, FLIGHT_CASES};
use shared::actuator::ActuatorRecord;
use shared::domain::Domain;
use shared::fusion::FlightLength;

#[test]
fn no_flight_window_is_read_within() {
    let rm = ReferenceModel::new(ReferenceSettings::REFERENCE);
    // One flight of two windows per row.
    let rows = flight_campaign(
        &rm,
        &ActuatorRecord::REFERENCE,
        0..1,
        FlightLength::fixed(2),
        WindowSearch::ONBOARD,
        &ALL_WINDOWS,
        &FLIGHT_CASES,
        |_| {},
    )
    .expect("the campaign runs");
    assert_eq!(rows.len(), 18);
    for row in &rows {
        assert_eq!((row.runs.len(), row.flights.len()), (2, 1));
        for run in &row.runs {
            let (domain, e_tot) = &run.preflight;
            assert_ne!(
                *domain,
                Domain::Within,
                "{} in {:?}: read within at e_tot {e_tot:.1} %",
                row.case,
                row.window
            );
        }
        // The window identification on the same windows, and the flight's reading from
        // both fused: what they read `within` is right to 6 % e_tot and calls no healthy
        // component `FAULT`; what they cannot read (turbulence that stands in for friction,
        // …) they name.
        let windows = row.runs.iter().map(|r| ("window", r));
        for (reading, run) in windows.chain(row.flights.iter().map(|f| ("flight", f))) {
            if run.window.0.is_ok() {
                assert!(
                    run.window.1 <= 6.0 && run.false_faults == 0,
                    "{} in {:?}: the {reading} within at e_tot {:.1} % with {} false FAULTs",
                    row.case,
                    row.window,
                    run.window.1,
                    run.false_faults
                );
            }
        }
    }
}

/// Friction 0.2 flown in moderate cruise on the reference actuator, seeds `seeds`, each
/// flight `length` long: the campaign's rows.
fn moderate_cruise_friction_flights(
    seeds: std::ops::Range<u64>,
    length: FlightLength,
) -> Vec<host_sim::studies::flight::FlightRow> {
    use host_sim::plant::aero::{FlightPhase, FlightWindow, Turbulence};
    flight_campaign(
        &ReferenceModel::new(ReferenceSettings::REFERENCE),
        &ActuatorRecord::REFERENCE,
        seeds,
        length,
        WindowSearch::ONBOARD,
        &[FlightWindow {
            phase: FlightPhase::Cruise,
            turbulence: Turbulence::Moderate,
        }],
        &FLIGHT_CASES[1..2],
        |_| {},
    )
    .expect("the campaign runs")
}

/// A flight in moderate cruise that eight windows leave out (its fused friction deviation
/// above the limit), flown under the cruise rule (`shared::fusion::CRUISE_LENGTH`: eight,
/// then more while the friction deviation alone keeps it out, up to 24), flies more and is
/// read once the deviation is within: right to 6 % e_tot, its friction within its 90 %
/// interval, no healthy component `FAULT` (friction 0.2, seed 1: read at fourteen windows in
/// `campaign --flight --phase cruise --flight-windows 8 --flight-windows-max 24`).
#[test]
fn a_cruise_flight_flies_windows_until_its_friction_is_read() {
    use shared::fusion::{CRUISE_LENGTH, FLIGHT_MAX_FRICTION_STD};
    let rows = moderate_cruise_friction_flights(1..2, CRUISE_LENGTH);
    let flight = &rows[0].flights[0];
    // More than eight flown: the reading of the first eight was out for its friction only.
    assert!(
        (CRUISE_LENGTH.least + 1..=CRUISE_LENGTH.most).contains(&flight.windows),
        "{} windows flown",
        flight.windows
    );
    assert_eq!(rows[0].runs.len() as u32, flight.windows);
    assert_eq!(flight.window.0, Ok(()), "{:?}", flight.window.0);
    assert!(
        flight.std[0] <= FLIGHT_MAX_FRICTION_STD,
        "σ {}",
        flight.std[0]
    );
    assert!(flight.window.1 <= 6.0, "e_tot {:.2} %", flight.window.1);
    assert!(
        (flight.found.friction() - 0.2).abs() <= shared::uncertainty::Z90 * flight.std[0],
        "friction {} at σ {}",
        flight.found.friction(),
        flight.std[0]
    );
    assert_eq!(flight.false_faults, 0);
}

/// A flight the friction limit alone keeps out, into which a window read with its surface
/// pinned entered, ends on the friction that window held, the preflight's
/// (`shared::fusion::WindowFusion::final_reading`): moderate cruise, friction 0.2, seed 6
/// (of seeds 0–11, 6, 9 and 11 fly a pinned window into such a flight), eight windows (`campaign --flight --flight-windows 8`; `turbulence_too_high` before stop
/// 62, its load-model windows reading the friction to σ above 0.03). Right to 6 % e_tot,
/// every interval holding the truth, no healthy component `FAULT`.
#[test]
fn a_flight_the_turbulence_keeps_out_ends_on_its_pinned_windows_friction() {
    use shared::window::WindowReason;
    let rows = moderate_cruise_friction_flights(6..7, FlightLength::fixed(8));
    let (windows, flight) = (&rows[0].runs, &rows[0].flights[0]);
    // Windows of both models entered: a pinned one and at least one that read the friction.
    let entered = |pinned: u32| {
        windows
            .iter()
            .filter(|w| {
                w.pinned == pinned
                    && matches!(
                        w.window.0,
                        Ok(()) | Err(WindowReason::TurbulenceTooHigh { .. })
                    )
            })
            .count()
    };
    assert!(
        entered(1) >= 1 && entered(0) >= 1,
        "{} pinned, {} load",
        entered(1),
        entered(0)
    );
    assert_eq!(flight.window.0, Ok(()), "{:?}", flight.window.0);
    // The friction is the preflight's, not read in flight.
    assert!(flight.std[0].is_nan(), "σ {}", flight.std[0]);
    assert_eq!(flight.found.friction(), flight.pre_found.friction());
    assert!(flight.window.1 <= 6.0, "e_tot {:.2} %", flight.window.1);
    assert_eq!(flight.false_faults, 0);
    assert!(flight.covered.1 >= 2, "{:?}", flight.covered);
    assert_eq!(flight.covered.0, flight.covered.1, "{:?}", flight.covered);
}

/// The window identification on the calmest windows (approach, light turbulence: the load
/// reverses, the play is crossed): the healthy actuator and friction 0.2 are identified
/// `within`, friction read within 0.05 and e_tot under 3 %; Table II medium (a backlash
/// crossed under turbulence the model does not follow) is named outside, not read.
#[test]
fn approach_windows_are_identified_or_named() {
    use host_sim::fdi::window::identify_window;
    use host_sim::plant::aero::{FlightPhase, FlightWindow, Turbulence};
    use host_sim::plant::reference::Scenario;
    use host_sim::studies::flight::flight_record;
    use shared::metrics::total_error;
    use shared::FaultVector;
    let record = flight_record(&ActuatorRecord::REFERENCE);
    let rm = ReferenceModel::new(ReferenceSettings::REFERENCE)
        .with_test(record.test)
        .with_flight(Some(FlightWindow {
            phase: FlightPhase::Approach,
            turbulence: Turbulence::Light,
        }));
    let read = |faults: [f32; shared::FAULT_COUNT]| {
        let truth = FaultVector::new(faults).expect("a fault vector");
        let sim = rm.simulate(&Scenario::new(truth));
        assert!(
            sim.trace.is_flight(),
            "the window's trace is marked a window of flight"
        );
        let measured = sim.trace.measured(&record.params).expect("conditioned");
        let id = identify_window(
            &sim.trace,
            &measured,
            &record,
            shared::window::HeldComponents::NONE,
            1,
        )
        .expect("identified");
        // The window's picture: every sample, and the fitted series closer to the measured
        // current than the model before the drift (the drift is fitted, it cannot be worse).
        let points = host_sim::fdi::window::window_series(&sim.trace, &measured, &record, &id)
            .expect("the window's series");
        // Every sample up to the last one whose command the controller kept (every
        // COMMAND_STRIDE-th): the window's last few samples past it are not fitted.
        let n = sim.trace.samples().len();
        let stride = shared::window::COMMAND_STRIDE;
        assert_eq!(points.len(), n - (n - 1) % stride);
        let rms = |f: &dyn Fn(&host_sim::fdi::window::WindowPoint) -> f32| {
            (points.iter().skip(200).map(|p| f(p).powi(2)).sum::<f32>() / points.len() as f32)
                .sqrt()
        };
        let (plain, with_drift) = (rms(&|p| p.3 - p.4), rms(&|p| p.3 - p.5));
        assert!(with_drift <= plain + 1e-6, "{with_drift} vs {plain}");
        let svg = std::env::temp_dir().join(format!("ema-fdi-window-{}.svg", std::process::id()));
        host_sim::fdi::plot::window_svg(&svg, &points, "window").expect("plotted");
        let text = std::fs::read_to_string(&svg).expect("written");
        assert!(text.contains("<svg") && text.contains("polyline"));
        let _ = std::fs::remove_file(&svg);
        (
            id.verdict,
            total_error(&id.faults, &truth),
            id.faults.friction(),
        )
    };
    for friction in [0.0f32, 0.2] {
        let mut faults = *FaultVector::NOMINAL.as_array();
        faults[0] = friction;
        let (verdict, e_tot, read_friction) = read(faults);
        assert_eq!(verdict, Ok(()), "friction {friction}");
        assert!(e_tot < 3.0, "friction {friction}: e_tot {e_tot:.2} %");
        assert!(
            (read_friction - friction).abs() < 0.05,
            "friction {friction}: read {read_friction}"
        );
    }
    let (verdict, e_tot, _) = read(host_sim::studies::campaign::MEDIUM);
    assert!(
        verdict.is_err(),
        "Table II medium read within at e_tot {e_tot:.1} %"
    );
}

/// A window of flight keeps its mark through a CSV file (`# test: flight`) and through the
/// binary form (`FLIGHT_MARK` in its header's test code), whose rows read back as written.
#[test]
fn a_flight_trace_keeps_its_mark() {
    use host_sim::files::trace::{Trace, TraceFormat};
    use host_sim::plant::aero::{FlightPhase, FlightWindow, Turbulence};
    use host_sim::plant::reference::Scenario;
    let record = host_sim::studies::flight::flight_record(&ActuatorRecord::REFERENCE);
    let rm = ReferenceModel::new(ReferenceSettings::REFERENCE)
        .with_test(record.test)
        .with_flight(Some(FlightWindow {
            phase: FlightPhase::Cruise,
            turbulence: Turbulence::Moderate,
        }));
    let trace = rm
        .simulate(&Scenario::new(shared::FaultVector::NOMINAL))
        .trace;
    let csv = trace.to_csv();
    assert!(csv.starts_with(b"# test: flight\n"));
    let back = Trace::from_bytes(&csv).expect("read back");
    assert!(back.is_flight());
    assert_eq!(back.samples().len(), trace.samples().len());
    let path = std::env::temp_dir().join(format!("ema-fdi-flight-{}.bin", std::process::id()));
    trace
        .write(&path, TraceFormat::Bin)
        .expect("a window in the binary form");
    let bin = std::fs::read(&path).expect("written");
    assert_eq!(bin[7], shared::trace::FLIGHT_MARK | record.test.kind());
    let back = Trace::from_bytes(&bin).expect("read back");
    assert!(back.is_flight());
    assert_eq!(back.to_bin().expect("encodable"), bin);
    assert!(
        !Trace::from_bytes(b"t,theta_cmd,i_a,i_b,i_c,theta_m,theta_u\n0,0,0,0,0,0,0\n")
            .map(|t| t.is_flight())
            .unwrap_or(false)
    );
}

/// A study's window search (`campaign --flight --window-search`) is the one the windows are
/// read with: a cruise window in light turbulence, friction 0.2, read with the controller's
/// search (two GAs of 300 evaluations of 16) spends at most what it allows (two GAs, two
/// load searches, seven curvatures and the polish's and the verdict's runs) and fewer runs
/// than two GAs of 600 of 32 on the same window, which spend more than 2 × 300 + the rest.
#[test]
fn a_window_search_sets_the_windows_model_runs() {
    use host_sim::plant::aero::{FlightPhase, FlightWindow, Turbulence};
    use shared::window::{CURVATURE_RUNS, LOAD_SEARCH_EVALUATIONS, WINDOW_GA_EVALUATIONS};
    let runs = |search: WindowSearch| {
        let rows = flight_campaign(
            &ReferenceModel::new(ReferenceSettings::REFERENCE),
            &ActuatorRecord::REFERENCE,
            0..1,
            FlightLength::fixed(1),
            search,
            &[FlightWindow {
                phase: FlightPhase::Cruise,
                turbulence: Turbulence::Light,
            }],
            &FLIGHT_CASES[1..2],
            |_| {},
        )
        .expect("the campaign runs");
        rows[0].runs[0].model_runs
    };
    let rest = 2 * LOAD_SEARCH_EVALUATIONS as u32 + 7 * CURVATURE_RUNS + 10;
    let onboard = runs(WindowSearch::ONBOARD);
    let costlier = runs(WindowSearch {
        evaluations: 600,
        population: 32,
    });
    assert_eq!(
        (
            WindowSearch::ONBOARD.evaluations,
            WindowSearch::ONBOARD.population
        ),
        (WINDOW_GA_EVALUATIONS, 16)
    );
    assert!(
        onboard <= 2 * WINDOW_GA_EVALUATIONS + rest,
        "{onboard} runs"
    );
    assert!(costlier > 2 * 300 + rest, "{costlier} runs");
    assert!(onboard < costlier, "{onboard} against {costlier}");
}
