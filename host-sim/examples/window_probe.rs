use host_sim::fdi::window::identify_window;
use host_sim::plant::aero::{FlightPhase, FlightWindow, Turbulence};
use host_sim::plant::reference::{ReferenceModel, Scenario};
use host_sim::studies::flight::flight_record;
use shared::actuator::ActuatorRecord;
use shared::metrics::total_error;
use shared::FaultVector;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let phase = match args.get(1).map(|s| s.as_str()) { Some("climb") => FlightPhase::Climb, Some("approach") => FlightPhase::Approach, _ => FlightPhase::Cruise };
    let turb = match args.get(2).map(|s| s.as_str()) { Some("moderate") => Turbulence::Moderate, _ => Turbulence::Light };
    let record = flight_record(&ActuatorRecord::REFERENCE);
    let rm = ReferenceModel::new(Default::default()).with_test(record.test).with_flight(if std::env::var("GROUND").is_ok() { None } else { Some(FlightWindow { phase, turbulence: turb }) });
    let mut cases: Vec<(&str, [f32; 9])> = vec![
        ("healthy", *FaultVector::NOMINAL.as_array()),
        ("friction 0.2", [0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0]),
        ("medium", host_sim::studies::campaign::MEDIUM),
    ];
    if let Ok(v) = std::env::var("CASE") {
        let a: Vec<f32> = v.split(',').map(|x| x.parse().unwrap()).collect();
        cases = vec![("custom", a.try_into().unwrap())];
    }
    let seeds: u64 = std::env::var("SEEDS").ok().and_then(|s| s.parse().ok()).unwrap_or(3);
    for (name, f) in cases {
        let truth = FaultVector::new(f).unwrap();
        for seed in 0..seeds {
            let sim = rm.simulate(&Scenario { seed, ..Scenario::new(truth) });
            let measured = sim.trace.measured(&record.params)?;
            let t = std::time::Instant::now();
            let id = identify_window(&sim.trace, &measured, &record, 1 + seed)?;
            let truth_fit = {
                use shared::window::*;
                let command = host_sim::fdi::window::recorded_command(&sim.trace);
                let conditions = shared::conditions::TestConditions::estimate(&measured, &record.params, &record.calibration);
                let model = shared::MonitorModel::new(record.params, &record.calibration).with_test(measured.test()).with_conditions(&conditions);
                let p = WindowProblem::new(&measured, RecordedCommand::new(&command), model, WindowLoad::spring(5e4, 0.0)).unwrap();
                if std::env::var("GROUND").is_ok() {
                    for m in [-20.0f32, 0.0, 20.0] {
                        let f = p.evaluate_under(&truth, WindowLoad::spring(5e4, m));
                        println!("   ground M {m}: fit {:.3e} drift {:?}", f.error, f.drift);
                    }
                    let fp = shared::FitnessProblem::new(&measured, record.params, &record.calibration).unwrap();
                    println!("   preflight fitness raw {:.3e}", fp.raw_error(&truth));
                }
                let (load, e) = p.fit_load(&truth, 5e4);
                if std::env::var("DUMP").is_ok() {
                    let mut out = String::new();
                    p.clone().with_load(load).fitted(&truth, |t, r, m, md| out.push_str(&format!("{t},{r},{m},{md}\n")));
                    std::fs::write(format!("/tmp/dump{seed}.csv"), out).unwrap();
                }
                println!("   truth: fit {e:.3e} K {:.0} M {:.1} drift {:?}", load.stiffness, load.moment, p.clone().with_load(load).evaluate(&truth).drift);
                0.0
            };
            let _ = truth_fit;
            println!("{name} seed {seed}: {:?} misfit {:.4} e_tot {:.2} % fit {:.3e} load K {:.0} M {:.1} drift {:?} {:?} ({:.2} s)\n   found {:?}",
                id.verdict, id.misfit, total_error(&id.faults, &truth), id.fitness, id.load.stiffness, id.load.moment, id.drift.map(|x| (x*1000.0).round()/1000.0), id.evaluations, t.elapsed().as_secs_f64(),
                id.faults.as_array().map(|x| (x*100.0).round()/100.0));
        }
    }
    Ok(())
}
#[allow(dead_code)]
fn unused() {}
