//! `domain`: the survey behind the monitor model's domain limits.

use crate::*;

pub(crate) fn domain_command(seeds: u64, out: Option<&Path>) -> Result<()> {
    let limits = shared::domain::DomainLimits::REFERENCE_ACTUATOR;
    let start = Instant::now();
    let rows = host_sim::domain::survey(seeds, &limits, std::io::stderr().is_terminal())?;
    let text = host_sim::domain::markdown(&rows, &limits);
    print!("{text}");
    println!(
        "\n{} tests in {:.0} s",
        rows.len(),
        start.elapsed().as_secs_f64()
    );
    if let Some(path) = out {
        std::fs::write(path, &text).with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(())
}
