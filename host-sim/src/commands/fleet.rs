//! `fleet ingest`, `fleet report` and `fleet bench`: the fleet store and its report.

use crate::cli::*;
use crate::commands::prognostics::TrendArgs;
use host_sim::fleet::{self, FleetStore};

#[derive(clap::Subcommand)]
pub(crate) enum FleetCommand {
    /// Store controllers' health logs (the 84-byte record slots the controller keeps, or an older version's 52, 68 or 76;
    /// `degrade --log` and the firmware's --health write them) in the fleet store, keyed by
    /// actuator serial and flight. Ingesting a log twice adds nothing; a damaged log, one
    /// with an unknown record version, or one that contradicts what is stored is refused
    /// whole and the store keeps what it had. Exit status 1 when any log was refused.
    Ingest {
        /// Health-log files, or folders of them; each file's name without extension is its
        /// actuator's serial (ACT-00042.bin → ACT-00042).
        #[arg(required = true)]
        logs: Vec<PathBuf>,
        /// The fleet store (SQLite file, created when missing).
        #[arg(long)]
        db: PathBuf,
        /// The actuator serial, instead of the file name (one log only).
        #[arg(long)]
        serial: Option<String>,
        /// Store the sound records of a log with damaged slots instead of refusing it.
        #[arg(long)]
        skip_damaged: bool,
    },
    /// Write the fleet report: one static HTML page (no scripts, SVG pictures) ranking every
    /// actuator by the lower bound of its RUL, with each fault's trend and interval for the
    /// first actuators, and the ones tested outside the monitor model's domain flagged.
    Report {
        /// The fleet store.
        #[arg(long)]
        db: PathBuf,
        /// The HTML page to write.
        #[arg(long)]
        out: PathBuf,
        /// Actuators (from the top of the ranking) whose trends are drawn.
        #[arg(long, default_value_t = 20)]
        detail: usize,
        #[command(flatten)]
        trend: TrendArgs,
    },
    /// Benchmark: a synthetic fleet (no reference model: paths and scatter drawn at random)
    /// written as health logs, ingested into a new store and reported, on one thread; prints
    /// the time of each step.
    Bench {
        #[arg(long, default_value_t = 1000)]
        actuators: u32,
        #[arg(long, default_value_t = 500, value_parser = clap::value_parser!(u32).range(2..=100_000))]
        flights: u32,
        /// Folder for the logs, the store and the report (kept); without it a temporary folder
        /// is used and removed.
        #[arg(long)]
        dir: Option<PathBuf>,
    },
}

pub(crate) fn fleet_command(command: FleetCommand) -> Result<ExitCode> {
    match command {
        FleetCommand::Ingest {
            logs,
            db,
            serial,
            skip_damaged,
        } => ingest(&logs, &db, serial.as_deref(), skip_damaged, true),
        FleetCommand::Report {
            db,
            out,
            detail,
            trend,
        } => {
            report(&db, &out, detail, &trend.settings())?;
            Ok(ExitCode::SUCCESS)
        }
        FleetCommand::Bench {
            actuators,
            flights,
            dir,
        } => bench(actuators, flights, dir.as_deref()),
    }
}

/// Ingests `logs`; prints one line per log (refusals on stderr).
fn ingest(
    logs: &[PathBuf],
    db: &Path,
    serial: Option<&str>,
    skip_damaged: bool,
    verbose: bool,
) -> Result<ExitCode> {
    let files = fleet::log_files(logs)?;
    if serial.is_some() && files.len() != 1 {
        anyhow::bail!(
            "--serial names one actuator: give one log ({} given)",
            files.len()
        );
    }
    let mut store = FleetStore::open(db)?;
    let bar = host_sim::progress_bar(
        files.len() as u64,
        "{elapsed_precise} [{bar:40}] {pos}/{len} logs",
        !verbose && std::io::stderr().is_terminal(),
    );
    let (mut refused, mut added, mut seen) = (0usize, 0usize, 0usize);
    for path in &files {
        bar.inc(1);
        let outcome = (|| -> Result<fleet::Ingested> {
            let serial = match serial {
                Some(s) => s.to_string(),
                None => fleet::serial_of(path)?,
            };
            let image =
                std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
            store.ingest(&serial, &image, &path.display().to_string(), skip_damaged)
        })();
        match outcome {
            Ok(i) => {
                added += i.added;
                seen += i.records;
                if verbose {
                    println!(
                        "{}: {} v{} records, {} new{}{}",
                        path.display(),
                        i.records,
                        i.version,
                        i.added,
                        if i.empty > 0 {
                            format!(", {} empty slots", i.empty)
                        } else {
                            String::new()
                        },
                        if i.skipped_damaged > 0 {
                            format!(", {} damaged slots skipped", i.skipped_damaged)
                        } else {
                            String::new()
                        }
                    );
                }
            }
            Err(e) => {
                refused += 1;
                eprintln!("{}: refused: {e:#}", path.display());
            }
        }
    }
    bar.finish_and_clear();
    let (records, actuators) = store.counts()?;
    println!(
        "{} logs: {} ingested ({seen} records, {added} new), {refused} refused; the store holds \
         {records} records of {actuators} actuators",
        files.len(),
        files.len() - refused,
    );
    Ok(if refused > 0 {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    })
}

/// Writes the report page; returns the actuators and records reported.
fn report(
    db: &Path,
    out: &Path,
    detail: usize,
    settings: &TrendSettings,
) -> Result<(usize, usize)> {
    if !db.exists() {
        anyhow::bail!(
            "{}: no such fleet store (create it with fleet ingest)",
            db.display()
        );
    }
    let store = FleetStore::open(db)?;
    let histories = store.histories()?;
    let statuses = fleet::ranked(&histories, settings);
    let html = fleet::report_html(&statuses, &histories, settings, detail);
    std::fs::write(out, html).with_context(|| format!("writing {}", out.display()))?;
    let records = statuses.iter().map(|s| s.records).sum();
    println!(
        "wrote {} ({} actuators, {records} records; {} flagged outside the domain)",
        out.display(),
        statuses.len(),
        statuses.iter().filter(|s| s.flagged()).count()
    );
    Ok((statuses.len(), records))
}

fn bench(actuators: u32, flights: u32, dir: Option<&Path>) -> Result<ExitCode> {
    let temporary = dir.is_none();
    let dir = match dir {
        Some(d) => d.to_path_buf(),
        None => tempfile_dir()?,
    };
    let logs = dir.join("logs");
    let db = dir.join("fleet.sqlite");
    let html = dir.join("report.html");
    if db.exists() {
        std::fs::remove_file(&db)?;
    }
    let t = Instant::now();
    fleet::synthetic_fleet(&logs, actuators, flights, 1)?;
    let made = t.elapsed().as_secs_f64();
    // One thread: the report's trends would otherwise be free to use rayon (they do not).
    let t = Instant::now();
    let status = ingest(std::slice::from_ref(&logs), &db, None, false, false)?;
    let ingest_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    report(&db, &html, 20, &TrendSettings::DEFAULT)?;
    let report_s = t.elapsed().as_secs_f64();
    let again = Instant::now();
    ingest(&[logs], &db, None, false, false)?;
    let again_s = again.elapsed().as_secs_f64();
    println!(
        "fleet of {actuators} actuators × {flights} flights: logs written in {made:.1} s; \
         ingest {ingest_s:.1} s, report {report_s:.1} s, together {:.1} s (one thread); \
         ingesting the same logs again {again_s:.1} s; store {:.1} MB, report {:.1} MB",
        ingest_s + report_s,
        std::fs::metadata(&db)?.len() as f64 / 1e6,
        std::fs::metadata(&html)?.len() as f64 / 1e6,
    );
    if temporary {
        std::fs::remove_dir_all(&dir).with_context(|| format!("removing {}", dir.display()))?;
    }
    Ok(status)
}

/// A new folder under the system's temporary folder.
fn tempfile_dir() -> Result<PathBuf> {
    let d = std::env::temp_dir().join(format!("ema-fdi-fleet-bench-{}", std::process::id()));
    std::fs::create_dir_all(&d)?;
    Ok(d)
}
