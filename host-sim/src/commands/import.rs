//! `import`: a rig recording → a trace of the actuator's test at the control rate.

use crate::cli::*;
use crate::commands::simulate::format_from_extension;

#[allow(clippy::too_many_arguments)]
pub(crate) fn import_command(
    actuator: &Actuator,
    recording: &Path,
    columns: Option<std::collections::BTreeMap<String, String>>,
    scales: Option<std::collections::BTreeMap<String, f64>>,
    start: Option<f64>,
    flight: bool,
    delimiter: Option<char>,
    anti_alias_hz: Option<f64>,
    out: &Path,
) -> Result<()> {
    // The controller's own current-sense front end, as the actuator file describes it.
    let anti_alias_hz = anti_alias_hz
        .or_else(|| actuator.reference.map(|r| r.anti_alias_hz))
        .unwrap_or(0.0);
    let rig = actuator.rig.clone().unwrap_or_default();
    let delimiter = match delimiter {
        None => None,
        Some(c) if c.is_ascii() => Some(c as u8),
        Some(c) => anyhow::bail!("--delimiter {c:?}: must be one ASCII character"),
    };
    let format = RigFormat {
        columns: columns.unwrap_or(rig.columns),
        scales: scales.unwrap_or(rig.scales),
        delimiter,
        start,
        anti_alias_hz,
    };
    let out_format = format_from_extension(out);
    if flight && start.is_none() {
        anyhow::bail!(
            "--flight: give --start SECONDS, where the superimposed chirp starts in the \
             recording (a flight's command never rests at 0, so the start cannot be found from \
             it)"
        );
    }
    let bytes =
        std::fs::read(recording).with_context(|| format!("reading {}", recording.display()))?;
    // A window of flight carries the actuator's chirp alone (no standstill segment).
    let test = if flight {
        actuator.record.test.chirp_only()
    } else {
        actuator.record.test
    };
    let period = f64::from(actuator.params().control_period);
    let trace = host_sim::files::rig::import(&bytes, &format, &test, period)
        .map_err(anyhow::Error::new)
        .and_then(|t| t.checked().map_err(anyhow::Error::new))
        .with_context(|| format!("recording {} refused", recording.display()))?;
    let trace = if flight { trace.as_flight() } else { trace };
    trace.write(out, out_format)?;
    println!(
        "wrote {} ({} samples of {} at {:.0} Hz, from {})",
        out.display(),
        trace.samples().len(),
        if flight {
            "a window of flight (the chirp alone on the flight's commands)".to_string()
        } else {
            format!("the {} test", test.kind_name())
        },
        1.0 / period,
        recording.display()
    );
    Ok(())
}
