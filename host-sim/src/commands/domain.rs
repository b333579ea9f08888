//! `domain`: the survey behind the monitor model's domain limits; for an actuator file, also
//! the limits it suggests, written into the file with `--write`.

use crate::cli::*;

pub(crate) fn domain_command(
    actuator: &Actuator,
    seeds: u64,
    out: Option<&Path>,
    write: Option<&Path>,
) -> Result<()> {
    let limits = actuator.record.domain;
    let start = Instant::now();
    let rows = host_sim::studies::domain::survey(
        actuator,
        seeds,
        &limits,
        std::io::stderr().is_terminal(),
    )?;
    let mut text = host_sim::studies::domain::markdown(&rows, &limits);
    let suggested = host_sim::studies::domain::suggested_limits(&rows, &limits);
    let keys = [
        ("domain.min_travel", format!("{:?}", suggested.min_travel)),
        (
            "domain.min_phase_ratio",
            format!("{:?}", suggested.min_phase_ratio),
        ),
        (
            "domain.max_tracking",
            format!("{:?}", suggested.max_tracking),
        ),
        ("domain.max_fitness", format!("{:?}", suggested.max_fitness)),
    ];
    text += &format!(
        "\nSuggested from the explained actuators of {} (½ least travel and phase ratio, \
         1.5 × largest tracking, 2 × largest fitness):\n\n```toml\n[domain]\n",
        actuator.name
    );
    for (key, value) in &keys {
        text += &format!("{} = {value}\n", key.trim_start_matches("domain."));
    }
    text += "```\n";
    print!("{text}");
    println!(
        "\n{} tests in {:.0} s",
        rows.len(),
        start.elapsed().as_secs_f64()
    );
    if let Some(path) = out {
        std::fs::write(path, &text).with_context(|| format!("writing {}", path.display()))?;
    }
    if let Some(path) = write {
        let mut file =
            std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
        for (key, value) in &keys {
            file = Actuator::with_key_text(&file, key, value)
                .with_context(|| format!("{} sets no `{key}`", path.display()))?;
        }
        Actuator::parse(&file).context("the rewritten description")?;
        std::fs::write(path, file).with_context(|| format!("writing {}", path.display()))?;
        println!(
            "wrote the suggested [domain] limits into {}",
            path.display()
        );
    }
    Ok(())
}
