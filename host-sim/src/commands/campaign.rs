//! `campaign`: accuracy campaigns over the paper's fault cases.

use crate::cli::*;

pub(crate) fn campaign_command(
    actuator: &Actuator,
    table: CampaignTable,
    runs: u64,
    out: Option<&Path>,
    runs_csv: Option<&Path>,
    plot: Option<&Path>,
) -> Result<()> {
    use host_sim::studies::campaign::{self, HEALTHY, TABLE_2};
    let (title, cases) = match table {
        CampaignTable::One => ("Table I: single faults", TABLE_1.to_vec()),
        CampaignTable::Two => ("Table II: multiple faults, and the healthy actuator", {
            let mut v = TABLE_2.to_vec();
            v.push(HEALTHY);
            v
        }),
        CampaignTable::OneAndTwo => (
            "Tables I and II: the preflight's uncertainty's calibration",
            {
                let mut v = TABLE_1.to_vec();
                v.extend(TABLE_2);
                v.push(HEALTHY);
                v
            },
        ),
        CampaignTable::Random => (
            "Random multi-fault vectors (not tuned on)",
            campaign::untuned_random_cases(8),
        ),
        CampaignTable::Demagnetization => (
            "Demagnetization (k9), its mixes, and what must not read as it",
            campaign::DEMAGNETIZATION.to_vec(),
        ),
    };
    let start = Instant::now();
    let summaries =
        campaign::run_campaign(&cases, runs, actuator, std::io::stderr().is_terminal())?;
    let title = format!(
        "{title} ({}, {} test)",
        actuator.name,
        actuator.record.test.kind_name()
    );
    let title = title.as_str();
    let mut text = campaign::markdown(title, &summaries, runs);
    if matches!(table, CampaignTable::Random) {
        text += "\nVectors:\n\n";
        for c in &summaries {
            text += &format!(
                "- {}: [{}]\n",
                c.case.name,
                c.case
                    .faults
                    .iter()
                    .map(|x| format!("{x:.3}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
    }
    if matches!(table, CampaignTable::Demagnetization) {
        text += &campaign::demagnetization_markdown(&summaries);
    }
    print!("{text}");
    if let Some(path) = runs_csv {
        std::fs::write(path, campaign::runs_csv(&summaries))
            .with_context(|| format!("writing {}", path.display()))?;
    }
    println!(
        "\n({} identifications in {:.1} s wall time)",
        summaries.iter().map(|c| c.runs.len()).sum::<usize>(),
        start.elapsed().as_secs_f64()
    );
    if let Some(path) = out {
        std::fs::write(path, &text).with_context(|| format!("writing {}", path.display()))?;
    }
    if let Some(path) = plot {
        campaign::plot(path, title, &summaries)?;
    }
    Ok(())
}

/// One point of the robustness grid: the day and drive the reference model plays.
struct GridPoint {
    label: String,
    day: Day,
    /// Whether the drive differs from the calibration's (the calibration is redone on it:
    /// dead time is a property of the installed controller, like the harness).
    own_calibration: bool,
    /// Whether the record is told the controller's timing the reference model plays (a
    /// controller whose duty delay the record carries); otherwise it keeps its own.
    declared_timing: bool,
}

/// The robustness grid around the actuator's calibration day: the winding (and gear)
/// temperature −60 … +60 K from it, the bus at 250 and 280 V (scaled for other buses), the
/// two corners (cold and low bus, hot and high bus), and a drive with 1 µs of dead time.
fn grid(actuator: &Actuator) -> Result<Vec<GridPoint>> {
    let r = actuator.reference_settings()?;
    let base = r.conditions.winding_temperature;
    let nominal_bus = f64::from(actuator.params().dc_bus_voltage);
    let bus = |v: f64| v / 270.0 * nominal_bus;
    let point = |label: String, temperature: Option<f64>, bus_voltage: Option<f64>| GridPoint {
        label,
        day: Day {
            temperature,
            bus_voltage,
            ..Day::default()
        },
        own_calibration: false,
        declared_timing: false,
    };
    let mut points: Vec<GridPoint> = [-60.0, -30.0, 0.0, 30.0, 60.0]
        .into_iter()
        .map(|dt: f64| {
            point(
                format!("{:+.0} K ({:.0} °C)", dt, base + dt),
                (dt != 0.0).then_some(base + dt),
                None,
            )
        })
        .collect();
    for v in [250.0, 280.0] {
        points.push(point(format!("bus {:.1} V", bus(v)), None, Some(bus(v))));
    }
    points.push(point(
        format!("−60 K, bus {:.1} V", bus(250.0)),
        Some(base - 60.0),
        Some(bus(250.0)),
    ));
    points.push(point(
        format!("+60 K, bus {:.1} V", bus(280.0)),
        Some(base + 60.0),
        Some(bus(280.0)),
    ));
    let row = |label: &str, day: Day, own_calibration: bool, declared_timing: bool| GridPoint {
        label: label.to_string(),
        day,
        own_calibration,
        declared_timing,
    };
    let dead_time = Day {
        dead_time: Some(1.0e-6),
        ..Day::default()
    };
    points.push(row(
        "dead time 1 µs (calibrated on that drive)",
        dead_time,
        true,
        false,
    ));
    points.push(row(
        "dead time 1 µs, calibrated at the file's (a replaced drive)",
        dead_time,
        false,
        false,
    ));
    // The controller's timing (issue 34): declared in the record and calibrated with it, and
    // one the record does not know.
    for (label, seconds) in [
        ("duty delay 25 µs (declared, calibrated with it)", 2.5e-5),
        ("duty delay 50 µs (declared, calibrated with it)", 5.0e-5),
        ("duty delay 100 µs (declared, calibrated with it)", 1.0e-4),
    ] {
        let day = Day {
            duty_delay: Some(seconds),
            ..Day::default()
        };
        points.push(row(label, day, true, true));
    }
    points.push(row(
        "duty delay 50 µs, undeclared (the record says 0)",
        Day {
            duty_delay: Some(5.0e-5),
            ..Day::default()
        },
        false,
        false,
    ));
    // The gearbox is not the winding: the thermistor reads the winding.
    for (label, winding, gear) in [
        ("gear −40 K from the winding", None, base - 40.0),
        ("gear +40 K from the winding", None, base + 40.0),
        ("winding −40 K, gear −60 K", Some(base - 40.0), base - 60.0),
    ] {
        let day = Day {
            temperature: winding,
            gear_temperature: Some(gear),
            ..Day::default()
        };
        points.push(row(label, day, false, false));
    }
    // The grease as two things (drag ×10 and dry friction ×2.95 at −40 °C), calibrated with
    // `--at` on that grease.
    let grease = |temperature: Option<f64>, gear_temperature: Option<f64>| Day {
        temperature,
        gear_temperature,
        two_part_grease: true,
        ..Day::default()
    };
    points.push(row(
        "two-part grease, +0 K",
        grease(None, None),
        true,
        false,
    ));
    points.push(row(
        "two-part grease, −60 K",
        grease(Some(base - 60.0), None),
        true,
        false,
    ));
    points.push(row(
        "two-part grease, +60 K",
        grease(Some(base + 60.0), None),
        true,
        false,
    ));
    points.push(row(
        "two-part grease, gear −40 K from the winding",
        grease(None, Some(base - 40.0)),
        true,
        false,
    ));
    points.push(row(
        "eccentricity as a per-phase back-EMF gain",
        Day {
            eccentricity: Some(host_sim::plant::reference::EccentricityPhysics::PhaseGain),
            ..Day::default()
        },
        false,
        false,
    ));
    Ok(points)
}

/// `campaign --conditions`: Table I, Table II and the healthy actuator at every point of the
/// robustness grid, one row per point.
/// "n of total", and when some runs are outside, why and which cases: `(grease_out_of_range:
/// backlash k2 = 1.0 ×10)`, or the reason alone when it took every run.
fn outside_cases(
    summaries: &[host_sim::studies::campaign::CaseSummary],
    outside: usize,
    total: usize,
) -> String {
    let mut text = format!("{outside} of {total}");
    if outside == 0 {
        return text;
    }
    let mut by_reason: Vec<(shared::health::DomainCode, Vec<(&str, usize)>)> = Vec::new();
    for c in summaries {
        for r in &c.runs {
            let Some(code) = r.outside else { continue };
            if !by_reason.iter().any(|(k, _)| *k == code) {
                by_reason.push((code, Vec::new()));
            }
            let Some((_, cases)) = by_reason.iter_mut().find(|(k, _)| *k == code) else {
                continue;
            };
            match cases.iter_mut().find(|(name, _)| *name == c.case.name) {
                Some((_, n)) => *n += 1,
                None => cases.push((c.case.name, 1)),
            }
        }
    }
    let parts: Vec<String> = by_reason
        .iter()
        .map(|(code, cases)| {
            let n: usize = cases.iter().map(|(_, n)| n).sum();
            if n == total {
                code.name().to_string()
            } else {
                let list: Vec<String> = cases
                    .iter()
                    .map(|(name, n)| format!("{name} ×{n}"))
                    .collect();
                format!("{}: {}", code.name(), list.join(", "))
            }
        })
        .collect();
    text += &format!(" ({})", parts.join("; "));
    text
}

/// `campaign --wind`: the preflight in wind (`host_sim::studies::wind`).
pub(crate) fn wind_campaign_command(
    actuator: &Actuator,
    runs: u64,
    out: Option<&Path>,
) -> Result<()> {
    use host_sim::studies::wind::{wind_campaign, wind_markdown, WINDS, WIND_CASES};
    let rm = ReferenceModel::new(actuator.reference_settings()?).with_test(actuator.record.test);
    let record = actuator.record_for(&actuator.record.test)?;
    let start = Instant::now();
    let total = WINDS.len() * WIND_CASES.len();
    let mut done = 0;
    let rows = wind_campaign(&rm, &record, runs, |row| {
        done += 1;
        eprintln!(
            "[{done}/{total}] {} in {:?} kt: {} of {} named ({:.0} s)",
            row.case,
            row.wind,
            row.named(),
            row.runs.len(),
            start.elapsed().as_secs_f64()
        );
    })?;
    report_table(&wind_markdown(&rows, &actuator.name), start, out)
}

/// What `campaign --flight` flies: the cases (`--table`, else `FLIGHT_CASES`), the
/// phases (`--phase`, else all three) and the windows per flight (`--flight-windows`, up
/// to `--flight-windows-max`).
pub(crate) struct FlightCampaignRun<'a> {
    pub table: Option<CampaignTable>,
    pub phases: &'a [FlightPhase],
    pub length: shared::fusion::FlightLength,
    /// The windows' GA (`--window-search`; the controller's by default).
    pub search: host_sim::fdi::window::WindowSearch,
}

/// The flight campaign's cases for `table`: Table I, or Table II without its noise case (a
/// window's noise is its turbulence) and the healthy actuator (without the I_ref noise the
/// ground campaign gives it), or the demagnetization table's uniform cases on the
/// calibration's day (a flight's day is its own; one weak magnet is the reference model's
/// form, not a fault vector) and the healthy actuator; none: the healthy actuator, friction
/// 0.2 and Table II medium.
fn flight_cases(table: Option<CampaignTable>) -> Result<Vec<(&'static str, [f32; FAULT_COUNT])>> {
    use host_sim::studies::campaign::{MagnetForm, DEMAGNETIZATION, TABLE_2};
    use host_sim::studies::flight::FLIGHT_CASES;
    let of = |cases: &[host_sim::studies::campaign::Case]| -> Vec<_> {
        cases
            .iter()
            .filter(|c| c.noise == 0.0)
            .map(|c| (c.name, c.faults))
            .collect()
    };
    Ok(match table {
        None => FLIGHT_CASES.to_vec(),
        Some(CampaignTable::One) => of(&TABLE_1),
        Some(CampaignTable::Two) => {
            let mut cases = of(&TABLE_2);
            cases.push(FLIGHT_CASES[0]);
            cases
        }
        Some(CampaignTable::Demagnetization) => {
            let mut cases: Vec<_> = DEMAGNETIZATION
                .iter()
                .filter(|c| c.magnets == MagnetForm::Uniform && c.winding_rise == 0.0)
                .map(|c| (c.name, c.faults))
                .collect();
            cases.push(FLIGHT_CASES[0]);
            cases
        }
        Some(CampaignTable::Random | CampaignTable::OneAndTwo) => anyhow::bail!(
            "--table: the flight campaign flies Table I (1), Table II (2) or \
             demagnetization only"
        ),
    })
}

/// `campaign --flight`: the window identification and the preflight FDI on flight windows
/// (`host_sim::studies::flight`).
pub(crate) fn flight_campaign_command(
    actuator: &Actuator,
    seeds: std::ops::Range<u64>,
    run: &FlightCampaignRun,
    amplitudes: Option<&[f64]>,
    out: Option<&Path>,
    runs_csv: Option<&Path>,
) -> Result<()> {
    let runs = seeds.end - seeds.start;
    if let Some(amplitudes) = amplitudes {
        if runs_csv.is_some() {
            anyhow::bail!("--runs-csv: not written by the --test-amplitudes study");
        }
        if run.table.is_some() || !run.phases.is_empty() {
            anyhow::bail!("--table, --phase: not taken by the --test-amplitudes study (cruise, healthy and friction 0.2)");
        }
        use host_sim::studies::flight::{amplitude_markdown, test_amplitude_study};
        if amplitudes
            .iter()
            .any(|a| !(a.is_finite() && *a > 0.0 && *a <= 50.0))
        {
            anyhow::bail!("--test-amplitudes: each amplitude in (0, 50] mrad");
        }
        let rm = ReferenceModel::new(actuator.reference_settings()?);
        let start = Instant::now();
        let radians: Vec<f32> = amplitudes.iter().map(|a| (a * 1e-3) as f32).collect();
        let total = 4 * radians.len();
        let mut done = 0;
        let study = test_amplitude_study(&rm, &actuator.record, &radians, runs, |a, row| {
            done += 1;
            eprintln!(
                "[{done}/{total}] {:.2} mrad: {} in {:?} turbulence ({:.0} s)",
                1e3 * a,
                row.case,
                row.window.turbulence,
                start.elapsed().as_secs_f64()
            );
        })?;
        return report_table(&amplitude_markdown(&study, &actuator.name), start, out);
    }
    use host_sim::studies::flight::{
        flight_campaign, flight_markdown, flight_runs_csv, ALL_WINDOWS,
    };
    let cases = flight_cases(run.table)?;
    let windows: Vec<FlightWindow> = ALL_WINDOWS
        .iter()
        .filter(|w| run.phases.is_empty() || run.phases.contains(&w.phase))
        .copied()
        .collect();
    let rm = ReferenceModel::new(actuator.reference_settings()?);
    let start = Instant::now();
    let total = windows.len() * cases.len();
    let mut done = 0;
    let rows = flight_campaign(
        &rm,
        &actuator.record,
        seeds,
        run.length,
        run.search,
        &windows,
        &cases,
        |row| {
            done += 1;
            eprintln!(
                "[{done}/{total}] {} in {:?}, {:?} turbulence ({:.0} s)",
                row.case,
                row.window.phase,
                row.window.turbulence,
                start.elapsed().as_secs_f64()
            );
        },
    )?;
    if let Some(path) = runs_csv {
        std::fs::write(path, flight_runs_csv(&rows))
            .with_context(|| format!("writing {}", path.display()))?;
    }
    report_table(&flight_markdown(&rows, &actuator.name), start, out)
}

/// Prints a campaign's Markdown table and its wall time, and writes the table to `out`.
fn report_table(text: &str, start: Instant, out: Option<&Path>) -> Result<()> {
    print!("{text}");
    println!("({:.0} s)", start.elapsed().as_secs_f64());
    if let Some(path) = out {
        std::fs::write(path, text).with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(())
}

pub(crate) fn conditions_campaign_command(
    actuator: &Actuator,
    runs: u64,
    out: Option<&Path>,
) -> Result<()> {
    use host_sim::studies::campaign::{self, HEALTHY, HEALTHY_QUIET, TABLE_2};
    let mut cases = TABLE_1.to_vec();
    cases.extend(TABLE_2);
    cases.push(HEALTHY_QUIET);
    cases.push(HEALTHY);
    let start = Instant::now();
    let mut text = format!(
        "### Robustness: {} ({} test), {runs} runs per case\n\n\
         Calibrated at {:.1} °C (measured) on the file's drive; each row plays another day or \
         drive against that calibration (the dead-time row is calibrated on its own drive). \
         e_tot in % (eq. 4); `healthy`: the largest component any run of the healthy \
         actuator read, and its component-runs read `FAULT` / `suspect` (7 components × runs); \
         then the same readings of the healthy components beside the faults of Table I and II; \
         then the runs the domain check put outside; then the largest disagreement of the \
         injection's winding temperature with the thermistor's over the row's runs (beyond \
         `shared::conditions::MAX_WINDING_DISAGREEMENT` a run is outside); last, the runs that \
         read a weak magnet (no case plays one), of them those whose verdict is `FAULT` (its \
         depth's 90 % interval beyond the threshold), and of those the runs the domain check \
         found `within` (a reading a user would act on).\n\n\
         | conditions | Table I median | Table I worst case (mean) | low | medium | high | medium + noise | healthy: largest | healthy: FAULT / suspect | Table I+II healthy components FAULT / suspect | outside the domain | injection − thermistor, largest [K] | weak magnet read |\n\
         | --- | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n",
        actuator.name,
        actuator.record.test.kind_name(),
        actuator.record.calibration.temperature
    );
    for point in grid(actuator)? {
        let mut played = actuator.clone().with_day(point.day)?;
        if point.declared_timing {
            played.record.calibration.duty_delay =
                played.reference_settings()?.bridge.duty_delay as f32;
        }
        if point.own_calibration {
            // On the played drive and grease, at the calibration's own day.
            let mut settings = played.reference_settings()?;
            settings.conditions = actuator.reference_settings()?.conditions;
            let model = ReferenceModel::new(settings).with_test(played.record.test);
            played.record.calibration = host_sim::fdi::calibration::reference_calibration(
                &model,
                &played.record.calibration,
            )?;
        }
        eprintln!("robustness: {}", point.label);
        let summaries =
            campaign::run_campaign(&cases, runs, &played, std::io::stderr().is_terminal())?;
        let by_name = |name: &str| summaries.iter().find(|c| c.case.name == name);
        let table_1: Vec<&campaign::CaseSummary> = summaries
            .iter()
            .filter(|c| TABLE_1.iter().any(|t| t.name == c.case.name))
            .collect();
        let mut means: Vec<f64> = table_1.iter().map(|c| c.mean()).collect();
        means.sort_by(f64::total_cmp);
        let median = means.get(means.len() / 2).copied().unwrap_or(f64::NAN);
        let worst = table_1
            .iter()
            .max_by(|a, b| a.mean().total_cmp(&b.mean()))
            .map_or("-".to_string(), |c| {
                format!("{:.2} ({})", c.mean(), c.case.name)
            });
        let mean_of =
            |name: &str| by_name(name).map_or("-".to_string(), |c| format!("{:.2}", c.mean()));
        let healthy = by_name(HEALTHY_QUIET.name);
        let largest = healthy.map_or(f64::NAN, |c| {
            c.runs
                .iter()
                .map(|r| r.largest_component)
                .fold(0.0, f64::max)
        });
        let readings = |c: &campaign::CaseSummary| {
            let truth =
                shared::FaultVector::new(c.case.faults).unwrap_or(shared::FaultVector::NOMINAL);
            let nominal = shared::FaultVector::NOMINAL;
            let (mut fault, mut suspect, mut of) = (0usize, 0usize, 0usize);
            for r in &c.runs {
                for i in [0usize, 1, 2, 3, 4, 5, 7] {
                    if truth.as_array()[i] != nominal.as_array()[i] {
                        continue;
                    }
                    of += 1;
                    match r.assessments[i] {
                        shared::uncertainty::Assessment::Faulty => fault += 1,
                        shared::uncertainty::Assessment::Suspect
                        | shared::uncertainty::Assessment::Ambiguous { .. } => suspect += 1,
                        _ => {}
                    }
                }
            }
            (fault, suspect, of)
        };
        let (hf, hs, _) = healthy.map_or((0, 0, 0), readings);
        let (mut f, mut su, mut of) = (0, 0, 0);
        for c in summaries.iter().filter(|c| c.case.name != HEALTHY.name) {
            let (a, b, n) = readings(c);
            f += a;
            su += b;
            of += n;
        }
        let outside: usize = summaries
            .iter()
            .map(|c| c.runs.iter().filter(|r| !r.within).count())
            .sum();
        let total: usize = summaries.iter().map(|c| c.runs.len()).sum();
        let outside_text = outside_cases(&summaries, outside, total);
        let disagreement = summaries
            .iter()
            .flat_map(|c| {
                c.runs
                    .iter()
                    .map(|r| f64::from(r.winding_disagreement).abs())
            })
            .fold(0.0, f64::max);
        let weak: usize = summaries
            .iter()
            .map(|c| c.runs.iter().filter(|r| r.weak_magnet.is_some()).count())
            .sum();
        let weak_faulty = |within_only: bool| -> usize {
            summaries
                .iter()
                .map(|c| {
                    c.runs
                        .iter()
                        .filter(|r| {
                            r.weak_magnet_verdict == Assessment::Faulty
                                && (r.within || !within_only)
                        })
                        .count()
                })
                .sum()
        };
        let (weak_faulty, weak_acted) = (weak_faulty(false), weak_faulty(true));
        text += &format!(
            "| {} | {median:.2} | {worst} | {} | {} | {} | {} | {largest:.3} | {hf} / {hs} | {f} / {su} of {of} | {outside_text} | {disagreement:.1} | {weak} of {total} ({weak_faulty} `FAULT`, {weak_acted} of them `within`) |\n",
            point.label,
            mean_of("low"),
            mean_of("medium"),
            mean_of("high"),
            mean_of("medium + noise 50 %"),
        );
        println!("{}", text.lines().last().unwrap_or(""));
    }
    text += &format!(
        "\n({:.0} s wall time; `host-sim campaign --conditions --runs {runs}{}`)\n",
        start.elapsed().as_secs_f64(),
        if actuator.built_in {
            String::new()
        } else {
            format!(
                " --actuator {}",
                actuator
                    .source
                    .as_ref()
                    .map_or("…".to_string(), |p| p.display().to_string())
            )
        }
    );
    if let Some(path) = out {
        std::fs::write(path, &text).with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared::fault::DEMAGNETIZATION_INDEX;

    #[test]
    fn the_flight_campaigns_demagnetization_table_flies_the_uniform_cases_and_the_healthy() {
        let cases = flight_cases(Some(CampaignTable::Demagnetization)).unwrap();
        let k9: Vec<f32> = cases
            .iter()
            .map(|(_, k)| k[DEMAGNETIZATION_INDEX])
            .collect();
        // Uniform k9 0.1, 0.2, 0.5, 0.2 with a short, the short alone, the healthy actuator.
        assert_eq!(k9, [0.1, 0.2, 0.5, 0.2, 0.0, 0.0]);
        assert!(cases
            .iter()
            .all(|(name, _)| !name.contains("magnet") && !name.contains(" K")));
        assert_eq!(cases.last().map(|c| c.0), Some("healthy"));
        let refused = flight_cases(Some(CampaignTable::Random)).unwrap_err();
        assert!(refused.to_string().contains("demagnetization"), "{refused}");
    }
}
