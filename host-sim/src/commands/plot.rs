//! `plot`: measured against fitted current, and the GA history, as SVG.

use crate::*;

pub(crate) fn plot_command(
    trace_path: &Path,
    calibration: Option<&Path>,
    seed: u64,
    out: &Path,
) -> Result<()> {
    let trace = Trace::read(trace_path)?;
    let measured = trace.measured(&ActuatorParams::REFERENCE)?;
    let (calibration, _) = load_calibration(calibration, measured.test())?;
    let id = identify(&measured, &calibration, seed, progress_wanted(false))?;
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
    host_sim::plot::identification_svg(out, &measured, &calibration, &k, &id.history, &title)
        .with_context(|| format!("plotting into {}", out.display()))?;
    println!("wrote {}", out.display());
    Ok(())
}
