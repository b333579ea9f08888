//! What the reference model plays beyond the calibrated installation (SPEC §9): a controller
//! that loads its volts late, a grease whose drag and dry friction follow their own
//! temperature laws, a second eccentricity physics; and what the FDI makes of a changed
//! installation: a declared controller timing calibrates and identifies, an undeclared one or
//! another dead time is named `InstallationChanged`, never identified.

use host_sim::fdi::calibration::{calibrate, least_duty_delay};
use host_sim::plant::bridge::ThermalLaws;
use host_sim::plant::reference::{
    EccentricityPhysics, ReferenceModel, ReferenceSettings, Scenario, Simulation,
};
use shared::conditions::TestConditions;
use shared::domain::{Domain, DomainLimits, OutsideReason};
use shared::{ActuatorParams, Calibration, FaultVector};

const HEALTHY: [f32; 9] = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0];
const SHORT_A: [f32; 9] = [0.0, 0.0, 0.2, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0];

fn simulate(settings: ReferenceSettings, k: [f32; 9]) -> Simulation {
    ReferenceModel::new(settings).simulate(&Scenario::new(FaultVector::new(k).expect("valid")))
}

fn with_delay(seconds: f64) -> ReferenceSettings {
    let mut s = ReferenceSettings::REFERENCE;
    s.bridge.duty_delay = seconds;
    s
}

/// The day and the domain verdict of the reference actuator's FDI with `calibration` on `sim`.
fn verdict(sim: &Simulation, calibration: &Calibration) -> (TestConditions, Domain) {
    let params = ActuatorParams::REFERENCE;
    let measured = sim.trace.measured(&params).expect("conditions");
    let day = TestConditions::estimate(&measured, &params, calibration);
    (
        day,
        Domain::Within.with_day(&DomainLimits::REFERENCE_ACTUATOR, &day),
    )
}

#[test]
fn a_late_controller_applies_each_period_the_previous_volts_for_its_delay() {
    // Half a control period (one 20 kHz carrier): each period's mean leg voltage is half the
    // previous period's command and half its own.
    // On a bridge without dead time (which the controller compensates by a current sign it
    // measured before the volts take effect: physics of its own, tested by the campaigns).
    let mut bridge = ReferenceSettings::REFERENCE;
    bridge.bridge.dead_time = 0.0;
    let on_time = simulate(bridge, HEALTHY);
    bridge.bridge.duty_delay = 5.0e-5;
    let late = simulate(bridge, HEALTHY);
    let segment = shared::test_design::PreflightTest::INJECTION
        .standstill
        .expect("the injection");
    let (mut blended, mut unshifted) = (Vec::new(), Vec::new());
    let mut swing = 0.0f64;
    for k in 1..segment.samples() {
        // The two driven legs, while the same pair's tone plays through both periods.
        let (Some(before), Some(now)) = (segment.at(k - 1), segment.at(k)) else {
            continue;
        };
        if before.pair != now.pair || before.volts == 0.0 || now.volts == 0.0 {
            continue;
        }
        for (leg, sign) in now.signs().iter().enumerate() {
            if *sign == 0 {
                continue;
            }
            let expected = 0.5
                * (on_time.truth[k - 1].applied_voltages[leg]
                    + on_time.truth[k].applied_voltages[leg]);
            let applied = late.truth[k].applied_voltages[leg];
            blended.push(applied - expected);
            unshifted.push(applied - on_time.truth[k].applied_voltages[leg]);
            swing = swing.max(on_time.truth[k].applied_voltages[leg].abs());
        }
    }
    let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt();
    println!(
        "late against blended: RMS {:.3} V, against on time {:.3} V, of {swing:.1} V",
        rms(&blended),
        rms(&unshifted)
    );
    assert!(swing > 5.0, "{swing}");
    // What is left is the switches' drops at slightly different currents and the bus
    // ripple: millivolts, against the volt the on-time controller's period differs by.
    assert!(rms(&blended) < 0.05, "{}", rms(&blended));
    assert!(rms(&unshifted) > 20.0 * rms(&blended));
}

#[test]
fn a_two_part_grease_drags_tenfold_in_the_cold_and_the_energy_balance_holds() {
    let mut warm = ReferenceSettings::REFERENCE;
    warm.thermal = ThermalLaws::NDFEB_GREASED.with_two_part_grease(&ActuatorParams::REFERENCE);
    let mut cold = warm;
    cold.conditions.gear_temperature = -40.0;
    let [w, c] = [warm, cold].map(|s| simulate(s, HEALTHY).energy);
    for e in [w, c] {
        let mechanical = e.mechanical_loss + e.mechanical_stored + e.contact_release;
        let rel = (e.shaft_work - mechanical).abs() / e.shaft_work;
        assert!(rel < 0.02, "mechanical side off by {rel}: {e:?}");
    }
    // The cold grease takes several times the warm one's losses (drag ×10, dry ×2.95).
    println!(
        "mechanical loss warm {:.4} J, cold {:.4} J",
        w.mechanical_loss, c.mechanical_loss
    );
    assert!(c.mechanical_loss > 2.0 * w.mechanical_loss);
    // The one-factor grease of the same actuator has no drag at all.
    assert_eq!(ThermalLaws::NDFEB_GREASED.drag(-40.0), 0.0);
}

#[test]
fn phase_gain_eccentricity_scales_each_phase_by_its_own_constant() {
    let mut settings = ReferenceSettings::REFERENCE;
    settings.eccentricity = EccentricityPhysics::PhaseGain;
    let rm = ReferenceModel::new(settings);
    // k7 = 0.5: the minimum gap faces phase A's coil group.
    let k = FaultVector::new([0.0, 0.0, 0.0, 0.0, 0.0, 0.6, 0.5, 0.5, 0.0]).expect("valid");
    let z = f64::from(k.effects().eccentricity_z);
    let faulty = rm.coupling_shapes(&k);
    let healthy = rm.coupling_shapes(&FaultVector::NOMINAL);
    let centre = settings.winding_group_angle;
    for phase in 0..3 {
        let gain = 1.0 + z * (centre[phase] - centre[0]).cos();
        let worst = faulty[phase]
            .iter()
            .zip(healthy[phase].iter())
            .map(|(f, h)| (f - gain * h).abs())
            .fold(0.0, f64::max);
        assert!(worst < 1e-12, "phase {phase}: {worst}");
    }
    // The permeance physics of the same vector changes the shape, not only its scale.
    let permeance = ReferenceModel::new(ReferenceSettings::REFERENCE).coupling_shapes(&k);
    let ratio: Vec<f64> = permeance[0]
        .iter()
        .zip(healthy[0].iter())
        .filter(|(_, h)| h.abs() > 0.5)
        .map(|(p, h)| p / h)
        .collect();
    let (lo, hi) = ratio
        .iter()
        .fold((f64::MAX, f64::MIN), |(l, h), &r| (l.min(r), h.max(r)));
    assert!(hi - lo > 0.01, "{lo} … {hi}");
}

#[test]
fn a_declared_controller_delay_calibrates_and_an_undeclared_one_is_named() {
    let params = ActuatorParams::REFERENCE;
    for delay in [2.5e-5, 5.0e-5, 1.0e-4] {
        let sim = simulate(with_delay(delay), HEALTHY);
        // Undeclared: the injection cannot be a physical circuit, or it reads the winding
        // tens of kelvin off the thermistor. Named, never identified.
        let (day, domain) = verdict(&sim, &Calibration::REFERENCE_ACTUATOR);
        assert!(
            matches!(
                domain,
                Domain::Outside(OutsideReason::InstallationChanged { .. })
            ),
            "{delay}: {domain:?} {day:?}"
        );
        // Declared, and calibrated on that controller: a later test on it reads its day.
        let measured = sim.trace.measured(&params).expect("conditions");
        let prior = Calibration {
            duty_delay: delay as f32,
            ..Calibration::REFERENCE_ACTUATOR
        };
        let file = calibrate(&measured, params, &prior).expect("calibrates");
        assert_eq!(file.duty_delay, delay as f32);
        let calibrated = file.calibration();
        let mut cold = with_delay(delay);
        cold.conditions = cold.conditions.at_temperature(-20.0);
        let (day, domain) = verdict(&simulate(cold, HEALTHY), &calibrated);
        assert_eq!(domain, Domain::Within, "{delay}: {day:?}");
        assert!((day.winding_rise + 42.0).abs() < 10.0, "{delay}: {day:?}");
        // With a short, the late controller's dead-time compensation (by a current sign
        // that is half a period old near each zero crossing) moves the injection's
        // temperature: named as a changed installation, or read right — never a wrong day.
        let (day, domain) = verdict(&simulate(cold, SHORT_A), &calibrated);
        let named = matches!(
            domain,
            Domain::Outside(OutsideReason::InstallationChanged { .. })
        );
        assert!(
            named || (domain == Domain::Within && (day.winding_rise + 42.0).abs() < 10.0),
            "{delay}: {domain:?} {day:?}"
        );
        // The calibration of the on-time controller does not describe the late one.
        let (_, domain) = verdict(&sim, &Calibration::REFERENCE_ACTUATOR);
        assert!(matches!(
            domain,
            Domain::Outside(OutsideReason::InstallationChanged { .. })
        ));
        // `calibrate` without the delay refuses, and says what delay would fit.
        let refused = calibrate(&measured, params, &Calibration::REFERENCE_ACTUATOR)
            .expect_err("an undeclared delay is refused");
        let text = format!("{refused:#}");
        assert!(text.contains("duty_delay"), "{text}");
        let least = least_duty_delay(&measured, params.control_period, 1.2).expect("a delay");
        assert!(least > 0.3 * delay && least <= delay, "{delay}: {least}");
    }
}

#[test]
fn another_dead_time_is_named_as_a_changed_installation() {
    // The reference actuator calibrated on its 0.5 µs drive, played on a 2 µs one (a
    // replaced drive with slower switches).
    let mut settings = ReferenceSettings::REFERENCE;
    settings.bridge.dead_time = 2.0e-6;
    for k in [HEALTHY, SHORT_A] {
        let sim = simulate(settings, k);
        let (day, domain) = verdict(&sim, &Calibration::REFERENCE_ACTUATOR);
        let Domain::Outside(OutsideReason::InstallationChanged { kelvin }) = domain else {
            panic!("{k:?}: {domain:?} {day:?}")
        };
        println!(
            "{k:?}: injection − thermistor {kelvin:+.1} K, {:?}",
            day.winding
        );
    }
    // The calibrated drive itself stays within, its shorts too.
    for k in [
        HEALTHY,
        SHORT_A,
        [0.0, 0.0, 0.5, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0],
    ] {
        let sim = simulate(ReferenceSettings::REFERENCE, k);
        let (day, domain) = verdict(&sim, &Calibration::REFERENCE_ACTUATOR);
        assert_eq!(domain, Domain::Within, "{k:?}: {day:?}");
    }
}

#[test]
fn at_one_frequency_a_delay_reads_as_resistance_so_the_record_carries_it() {
    // The identifiability behind `[drive] duty_delay` (docs/identifiability.md, timing): the
    // tone's current phase carries both the pair's R and the controller's delay. Read with
    // an assumed delay, the injection's R moves by Ω per period of assumed delay; the right
    // delay gives the same R as an on-time controller.
    use host_sim::fdi::calibration::pair_resistances_at;
    let params = ActuatorParams::REFERENCE;
    let dt = params.control_period;
    let mean = |r: [f64; 3]| r.iter().sum::<f64>() / 3.0;
    // Without dead time: on the real bridge the late controller also compensates the dead
    // time by a current sign measured before its volts apply, which reads as ≈ 0.37 Ω more
    // (the calibration absorbs it for the healthy current; see the declared-delay test).
    let mut bridge = ReferenceSettings::REFERENCE;
    bridge.bridge.dead_time = 0.0;
    let on_time = simulate(bridge, HEALTHY);
    let on_time = on_time.trace.measured(&params).expect("conditions");
    bridge.bridge.duty_delay = 5.0e-5;
    let late = simulate(bridge, HEALTHY);
    let late = late.trace.measured(&params).expect("conditions");
    let r0 = mean(pair_resistances_at(&on_time, dt, 0.0));
    let slope = mean(pair_resistances_at(&on_time, dt, 1.0)) - r0;
    let r_late = mean(pair_resistances_at(&late, dt, 0.5));
    let r_late_unknown = mean(pair_resistances_at(&late, dt, 0.0));
    println!(
        "pair R {r0:.3} Ω on time; {slope:.2} Ω per period of assumed delay \
         ({:.2} % of R per µs); late read with its delay {r_late:.3} Ω, without \
         {r_late_unknown:.3} Ω",
        100.0 * slope / (1e6 * f64::from(dt)) / r0
    );
    assert!(slope > 3.0, "{slope}");
    // Within the period-mean blend's approximation of a circuit whose time constant is ≈ 40
    // periods (1.2 % measured; the calibration absorbs it).
    assert!((r_late - r0).abs() < 0.02 * r0, "{r_late} against {r0}");
    assert!(r_late_unknown < 0.0, "{r_late_unknown}");
}

/// Issue 34, item 3: the chirp spans speeds, so its torque balance tells a two-part grease's
/// drag from its dry friction. With the gearbox 40 K colder than the winding, wear read
/// against the healthy dry friction the fitted drag points to is right; read against the
/// winding's temperature (today's friction law) it is not. On a one-factor grease the drag
/// does not move with temperature, so it cannot stand as a thermometer.
#[test]
fn the_chirp_tells_a_cold_grease_from_wear_by_its_drag() {
    use host_sim::studies::grease::{fits, settings, Bench, HealthyGreaseLaw};
    let bench = Bench::REFERENCE;
    let base = bench.day();
    let law = HealthyGreaseLaw::measure(&bench, true, 2).unwrap();
    let worn = FaultVector::saturating([0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0]);
    let fit = fits(&bench, settings(&bench, true, base, base - 40.0), worn, 2).unwrap();
    for f in &fit {
        let (viscous, coulomb) = law.ratios(f);
        // Played: drag ×4.11, dry friction ×1.94 × (1 + 2·0.2).
        assert!(viscous > 2.5, "drag ratio {viscous}");
        assert!(
            (coulomb / (1.94 * 1.4) - 1.0).abs() < 0.08,
            "dry ratio {coulomb}"
        );
        let by_drag = law.wear_by_drag(viscous, coulomb);
        let by_thermistor = law.wear_by_temperature(base, coulomb);
        assert!((by_drag - 0.2).abs() < 0.06, "k1 by drag {by_drag}");
        assert!(by_thermistor > 0.5, "k1 by thermistor {by_thermistor}");
    }
    let one_factor = HealthyGreaseLaw::measure(&bench, false, 2).unwrap();
    let cold = fits(&bench, settings(&bench, false, -40.0, -40.0), worn, 2).unwrap();
    for f in &cold {
        let (viscous, coulomb) = one_factor.ratios(f);
        assert!(
            (viscous - 1.0).abs() < 0.25,
            "one-factor drag ratio {viscous}"
        );
        assert!(coulomb > 3.5, "one-factor dry ratio {coulomb}");
    }
}

/// Issue 34, item 3, end to end: a two-part grease calibrated with `--at`'s temperatures gets
/// a friction law by drag; a healthy actuator whose gearbox is 40 K colder than its winding
/// then reads healthy, where the thermistor-indexed law (the same calibration without it)
/// reads the cold grease as wear. A one-factor grease gets no law by drag.
#[test]
fn a_cold_gearbox_with_a_draggy_grease_reads_healthy_by_its_drag() {
    use host_sim::fdi::calibration::reference_calibration;
    use host_sim::fdi::identify::identify;
    let mut settings = ReferenceSettings::REFERENCE;
    settings.thermal = ThermalLaws::NDFEB_GREASED.with_two_part_grease(&settings.params);
    let test = shared::test_design::PreflightTest::INJECTION;
    let model = ReferenceModel::new(settings).with_test(test);
    let with_law = reference_calibration(&model, &Calibration::REFERENCE_ACTUATOR).unwrap();
    assert!(with_law.viscous > 0.0, "{with_law:?}");
    // Drags falling with temperature, ×5 or more at −45 °C.
    assert!(with_law.drag_points[0] > 5.0, "{:?}", with_law.drag_points);
    let thermistor_only = Calibration {
        viscous: 0.0,
        drag_points: [0.0; 4],
        ..with_law
    };
    let mut cold = settings;
    cold.conditions.gear_temperature -= 40.0;
    let params = ActuatorParams::REFERENCE;
    let mut scenario = Scenario::new(FaultVector::new(HEALTHY).unwrap());
    scenario.seed = 3;
    let sim = ReferenceModel::new(cold)
        .with_test(test)
        .simulate(&scenario);
    let measured = sim.trace.measured(&params).unwrap();
    let by_drag = identify(&measured, &with_law, 1, false).unwrap();
    let by_thermistor = identify(&measured, &thermistor_only, 1, false).unwrap();
    let friction = |i: &host_sim::fdi::identify::Identified| i.result.faults.as_array()[0];
    assert!(friction(&by_drag) < 0.05, "{:?}", by_drag.result.faults);
    assert!(
        friction(&by_thermistor) > 0.3,
        "{:?}",
        by_thermistor.result.faults
    );
    // Within the drags the law was measured at: inside the domain.
    let (_, domain) = verdict(&sim, &with_law);
    assert_eq!(domain, Domain::Within);
    // A gearbox colder than any calibrated point (−65 °C under a winding at 20 °C, which the
    // thermistor reads in range): its drag lies beyond the law, named, never identified.
    let mut colder = settings;
    colder.conditions.gear_temperature -= 85.0;
    let sim = ReferenceModel::new(colder)
        .with_test(test)
        .simulate(&scenario);
    let (day, domain) = verdict(&sim, &with_law);
    let Domain::Outside(OutsideReason::GreaseOutOfRange { drag }) = domain else {
        panic!("{domain:?} {day:?}");
    };
    assert!(
        drag > with_law.drag_points[0] * shared::conditions::DRAG_MARGIN,
        "{drag} {:?}",
        with_law.drag_points
    );
    // The one-factor grease's drag does not move: no law by drag.
    let one_factor = reference_calibration(
        &ReferenceModel::new(ReferenceSettings::REFERENCE).with_test(test),
        &Calibration::REFERENCE_ACTUATOR,
    )
    .unwrap();
    assert_eq!(one_factor.viscous, 0.0);
}
