//! `degrade`, `prognose` and `prognostics`: degradation histories, trends and RUL.

use crate::cli::*;
use host_sim::files::health as health_file;

/// The trend's thresholds and horizon on the command line (`prognose`, `fleet report`).
#[derive(clap::Args)]
pub(crate) struct TrendArgs {
    /// Maintenance threshold on the deviation from nominal: one value for every fault, or
    /// name=value pairs (friction, backlash, short_a, short_b, short_c, eccentricity,
    /// gain_drift, demagnetization, weak_magnet: one magnet's depth) over the defaults 0.5,
    /// 0.5, 0.3, 0.3, 0.3, 0.5, 0.25, 0.3, 0.5.
    #[arg(long, value_parser = prognostics::parse_thresholds)]
    threshold: Option<[f32; shared::prognosis::TREND_COUNT]>,
    /// Flights searched ahead for the threshold crossing.
    #[arg(long, default_value_t = 500, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    horizon: u32,
}

impl TrendArgs {
    /// The controller's settings with these thresholds and this horizon.
    pub(crate) fn settings(&self) -> TrendSettings {
        let mut settings = TrendSettings::DEFAULT;
        if let Some(t) = self.threshold {
            settings.thresholds = t;
        }
        settings.horizon = self.horizon;
        settings
    }
}

pub(crate) fn degrade_command(
    path: &DegradationPath,
    noise: f64,
    seed: u64,
    intrusions: f64,
    windows: u8,
    out: &Path,
    log: Option<&Path>,
) -> Result<()> {
    let start = Instant::now();
    let bar = host_sim::progress_bar(
        u64::from(path.flights),
        "{elapsed_precise} [{bar:40}] {pos}/{len} flights (ETA {eta})",
        std::io::stderr().is_terminal(),
    );
    let rows = prognostics::degrade(path, noise, seed, intrusions, windows, 1, &|| bar.inc(1))?;
    bar.finish_and_clear();
    std::fs::write(out, health_file::history_csv(&rows))
        .with_context(|| format!("writing {}", out.display()))?;
    if let Some(log_path) = log {
        let mut store = health_file::FileStore::open(log_path, ONBOARD_RECORDS)?;
        let (mut log, _) = HealthLog::<ONBOARD_RECORDS>::load(&mut store)?;
        // The controller's log keeps preflights and flights' readings: each window's own
        // entry stays in the CSV.
        for r in rows.iter().filter(|r| !r.record.is_window()) {
            log.append(&mut store, r.record)
                .map_err(|e| anyhow::anyhow!("appending flight {}: {e:?}", r.record.flight))?;
        }
    }
    let preflights: Vec<&health_file::HistoryRow> =
        rows.iter().filter(|r| r.record.window == 0).collect();
    let flown: Vec<&health_file::HistoryRow> =
        rows.iter().filter(|r| r.record.is_window()).collect();
    let read: Vec<&health_file::HistoryRow> = rows
        .iter()
        .filter(|r| r.record.window == FLIGHT_READING)
        .collect();
    let outside = preflights.iter().filter(|r| !r.record.is_trusted()).count();
    let in_flight = if flown.is_empty() {
        String::new()
    } else {
        format!(
            "; {} windows of flight, {} identified, the others outside; {} flights' readings \
             from their windows, {} within{}",
            flown.len(),
            flown.iter().filter(|r| r.record.is_trusted()).count(),
            read.len(),
            read.iter().filter(|r| r.record.is_trusted()).count(),
            if log.is_some() {
                " (the windows' own entries in the CSV only: the controller's log keeps \
                 preflights and flights' readings)"
            } else {
                ""
            }
        )
    };
    println!(
        "wrote {} ({} flights, {outside} outside the monitor model's domain{in_flight}; {:.0} s)",
        out.display(),
        preflights.len(),
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

pub(crate) fn prognose_command(
    history: &Path,
    settings: &TrendSettings,
    at: Option<u32>,
    plot_out: Option<&Path>,
    json: bool,
) -> Result<()> {
    let mut rows = health_file::read_history(history)?;
    if let Some(at) = at {
        rows.retain(|r| r.record.flight <= at);
        if rows.is_empty() {
            anyhow::bail!("no flight at or before {at} in {}", history.display());
        }
    }
    let trend = prognostics::trend_of(&rows, None, settings);
    let estimates = trend.estimates(settings);
    if json {
        println!(
            "{}",
            prognostics::report_json(&rows, &trend, &estimates, settings)
        );
    } else {
        let windows = rows.iter().filter(|r| r.record.is_window()).count();
        println!(
            "{}: {} records, newest flight {}, {} outside the domain (not used){}",
            history.display(),
            rows.len(),
            rows.last().map_or(0, |r| r.record.flight),
            trend.skipped(),
            if windows > 0 {
                format!(
                    ", {windows} windows' own entries (not trended: their flights' readings \
                     carry them)"
                )
            } else {
                String::new()
            }
        );
        print!("{}", prognostics::report_text(&estimates, settings));
        if let Some(seen) = prognostics::weak_magnet_seen(&rows) {
            print!("{}", prognostics::weak_magnet_text(&seen));
        }
        println!(
            "RUL in flights after the newest; \"beyond\" = no crossing within {} flights.",
            settings.horizon
        );
    }
    if let Some(out) = plot_out {
        let title = format!(
            "{} up to flight {}",
            history.display(),
            rows.last().map_or(0, |r| r.record.flight)
        );
        prognostics::history_svg(out, &rows, &trend, settings, &title)?;
        if !json {
            println!("wrote {}", out.display());
        }
    }
    Ok(())
}

/// What `host-sim prognostics` evaluates.
pub(crate) struct EvalRun {
    pub seeds: u64,
    pub first_seed: u64,
    pub flights: u32,
    pub noises: Vec<f64>,
    pub intrusions: f64,
    pub windows: u8,
    /// The most tests per preflight; as many as the noise calls for are played.
    pub repeat: u8,
    /// Whose readings the trend takes; more than one: a sweep (each from the same kept
    /// histories, one table row each).
    pub readings: Vec<prognostics::Readings>,
    pub settings: TrendSettings,
    pub histories: Option<PathBuf>,
    pub alpha: f64,
    /// The weak magnet's scenarios instead of the fault families'.
    pub weak_magnet: bool,
}

impl EvalRun {
    /// The scenarios evaluated: the fault families', or the weak magnet's.
    fn scenarios(&self) -> Vec<prognostics::EvalScenario> {
        if self.weak_magnet {
            prognostics::weak_magnet_scenarios(&self.noises)
        } else {
            prognostics::eval_scenarios(&self.noises)
        }
    }

    /// The runs to evaluate from `readings`.
    fn runs(&self, readings: prognostics::Readings) -> prognostics::EvalRuns {
        prognostics::EvalRuns {
            seeds: self.first_seed..self.first_seed + self.seeds,
            flights: self.flights,
            intrusions: self.intrusions,
            windows: self.windows,
            repeat: self.repeat,
            readings,
        }
    }
}

pub(crate) fn prognostics_command(
    run: &EvalRun,
    out: Option<&Path>,
    plot_out: Option<&Path>,
) -> Result<()> {
    if let [readings] = run.readings[..] {
        return evaluation_command(run, readings, out, plot_out);
    }
    let Some(dir) = &run.histories else {
        anyhow::bail!(
            "a sweep of --ideal-readings evaluates the same runs once per value: give \
             --histories DIR (the runs are simulated into it once, or read from it)"
        );
    };
    let start = Instant::now();
    let scenarios = run.scenarios();
    let runs = scenarios.len() as u64 * run.seeds;
    let bar = host_sim::progress_bar(
        runs * u64::from(run.flights) * run.readings.len() as u64,
        "{elapsed_precise} [{bar:40}] {pos}/{len} flights (ETA {eta})",
        std::io::stderr().is_terminal(),
    );
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut rows = Vec::new();
    let mut simulated = 0;
    for &readings in &run.readings {
        let eval = prognostics::evaluate(
            &scenarios,
            &run.runs(readings),
            &run.settings,
            Some(dir),
            &|n| bar.inc(n),
        )?;
        simulated += eval.simulated;
        rows.push(prognostics::SweepRow {
            readings,
            totals: prognostics::Totals::of(
                &eval.tracks,
                run.alpha,
                prognostics::PredictionStart::Detection,
            ),
        });
    }
    bar.finish_and_clear();
    let mut text = format!(
        "The same {runs} runs × {} flights (seeds {}–{}; {simulated} simulated, the rest read \
         from {}) evaluated from each kind of readings; every prediction from detection. \
         Ideal readings: each preflight without an intrusion reads its true fault vector plus \
         seeded Gaussian noise of σ and states σ (the trend's noise floor, {}, still applies).\n\n",
        run.flights,
        run.first_seed,
        run.first_seed + run.seeds - 1,
        dir.display(),
        run.settings.noise_floor
    );
    text += &prognostics::sweep_markdown(&rows, run.alpha);
    text += &format!("\n{:.0} s.\n", start.elapsed().as_secs_f64());
    print!("{text}");
    if let Some(path) = out {
        std::fs::write(path, &text).with_context(|| format!("writing {}", path.display()))?;
    }
    if let Some(path) = plot_out {
        prognostics::sweep_svg(path, &rows)?;
    }
    Ok(())
}

/// One evaluation from one kind of readings: every table.
fn evaluation_command(
    run: &EvalRun,
    readings: prognostics::Readings,
    out: Option<&Path>,
    plot_out: Option<&Path>,
) -> Result<()> {
    let start = Instant::now();
    let scenarios = run.scenarios();
    let total = scenarios.len() as u64 * run.seeds * u64::from(run.flights);
    let bar = host_sim::progress_bar(
        total,
        "{elapsed_precise} [{bar:40}] {pos}/{len} flights (ETA {eta})",
        std::io::stderr().is_terminal(),
    );
    if let Some(dir) = &run.histories {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let eval = prognostics::evaluate(
        &scenarios,
        &run.runs(readings),
        &run.settings,
        run.histories.as_deref(),
        &|n| bar.inc(n),
    )?;
    bar.finish_and_clear();
    let mut text = String::new();
    match readings {
        prognostics::Readings::Fdi => {}
        prognostics::Readings::Ideal(sigma) => {
            text += &format!(
                "**Ideal readings, not the FDI's:** every preflight without an intrusion reads its \
                 true fault vector plus Gaussian noise of standard deviation {sigma} and states \
                 {sigma} (the trend's noise floor still applies); the flights with an intrusion \
                 keep the FDI's records.\n\n"
            );
        }
        prognostics::Readings::LeanRemoved => {
            text += "**The FDI's readings with their lean taken off (an oracle):** each run's \
                     mean error per component, over its trusted preflights at least 0.05 from \
                     nominal, subtracted from every preflight.\n\n";
        }
    }
    text += &prognostics::eval_markdown(&eval, run.alpha);
    let t = &run.settings.thresholds;
    let thresholds = if run.weak_magnet {
        format!(
            "{} one weak magnet's depth",
            t[shared::prognosis::WEAK_MAGNET_TREND]
        )
    } else {
        format!(
            "{} friction and backlash, {} shorts, {} eccentricity, {} gain drift",
            t[0], t[2], t[5], t[7]
        )
    };
    text += &format!(
        "\n{} runs × {} flights (seeds {}–{}; {} simulated, {} read from the history folder); thresholds \
         {thresholds}; systematic error \
         {}; noise floor {}; a flight's reading's σ counted {} times; {} windows of flight per flight; {} test(s) per preflight; {:.0} s.\n",
        scenarios.len() as u64 * run.seeds,
        run.flights,
        run.first_seed,
        run.first_seed + run.seeds - 1,
        eval.simulated,
        eval.cached,
        run.settings.systematic,
        run.settings.noise_floor,
        run.settings.flight_scale,
        run.windows,
        run.repeat,
        start.elapsed().as_secs_f64()
    );
    print!("{text}");
    if let Some(path) = out {
        std::fs::write(path, &text).with_context(|| format!("writing {}", path.display()))?;
    }
    if let Some(path) = plot_out {
        prognostics::eval_svg(path, &eval.tracks, run.alpha)?;
    }
    Ok(())
}
