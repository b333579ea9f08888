//! `calibrate`: fits the monitor model to a healthy trace and writes the calibration.

use crate::*;

pub(crate) fn calibrate_command(trace_path: &Path, out: &Path) -> Result<()> {
    let trace = Trace::read(trace_path)?;
    let measured = trace.measured(&ActuatorParams::REFERENCE)?;
    let file = calibrate(&measured, ActuatorParams::REFERENCE)?;
    file.write(out)?;
    println!(
        "calibration of the monitor model against {}",
        trace_path.display()
    );
    println!("resistance scale    {:.5}", file.resistance_scale);
    println!("inductance scale    {:.5}", file.inductance_scale);
    println!("back-EMF scale      {:.5}", file.back_emf_scale);
    println!("nominal residual    {:.4e} A²·s", file.nominal_residual);
    println!(
        "mismatch (relative RMS of the filtered equivalent current): {:.2} % before, {:.2} % after",
        100.0 * file.mismatch_before,
        100.0 * file.mismatch_after
    );
    println!(
        "({} monitor-model runs) wrote {}",
        file.evaluations,
        out.display()
    );
    Ok(())
}
