//! `plot`: measured against fitted current, and the GA history, as SVG.

use crate::cli::*;
use crate::commands::identify::load_record;

pub(crate) fn plot_command(
    actuator: &Actuator,
    trace_path: &Path,
    calibration: Option<&Path>,
    seed: u64,
    out: &Path,
) -> Result<()> {
    let trace = actuator.read_trace(trace_path)?;
    if trace.is_flight() {
        return plot_window(actuator, &trace, trace_path, seed, out);
    }
    let (record, _) = load_record(actuator, calibration, trace.test())?;
    let measured = trace.measured(&record.params)?;
    let id = identify_for(&measured, &record, seed, progress_wanted(false))?;
    let k = id.result.faults;
    let title = format!(
        "{}: found k = [{}]",
        trace_path
            .file_name()
            .map_or_else(|| "trace".into(), |n| n.to_string_lossy()),
        k.as_array()
            .iter()
            .map(|x| format!("{x:.3}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    host_sim::fdi::plot::identification_svg(
        out,
        &measured,
        record.params,
        &record.calibration,
        &k,
        &id.history,
        &title,
    )
    .with_context(|| format!("plotting into {}", out.display()))?;
    println!("wrote {}", out.display());
    Ok(())
}

/// `plot` of a window of flight: the window identification and its picture.
fn plot_window(
    actuator: &Actuator,
    trace: &host_sim::files::trace::Trace,
    trace_path: &Path,
    seed: u64,
    out: &Path,
) -> Result<()> {
    use host_sim::fdi::window::{identify_window, window_series};
    use host_sim::studies::flight::{flight_record, window_reason};
    let record = flight_record(&actuator.record);
    let measured = trace.measured(&record.params)?;
    let id = identify_window(
        trace,
        &measured,
        &record,
        shared::window::HeldComponents::NONE,
        seed,
    )?;
    let points = window_series(trace, &measured, &record, &id)?;
    let title = format!(
        "{} (window of flight): {} — k = [{}]",
        trace_path
            .file_name()
            .map_or_else(|| "trace".into(), |n| n.to_string_lossy()),
        window_reason(&id.verdict),
        id.faults
            .as_array()
            .iter()
            .map(|x| format!("{x:.2}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    host_sim::fdi::plot::window_svg(out, &points, &title)
        .with_context(|| format!("plotting into {}", out.display()))?;
    println!("wrote {}", out.display());
    Ok(())
}
