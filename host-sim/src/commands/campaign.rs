//! `campaign`: accuracy campaigns over the paper's fault cases.

use crate::*;

pub(crate) fn campaign_command(
    actuator: &Actuator,
    table: CampaignTable,
    runs: u64,
    out: Option<&Path>,
    plot: Option<&Path>,
) -> Result<()> {
    use host_sim::campaign::{self, HEALTHY, TABLE_2};
    let (title, cases) = match table {
        CampaignTable::One => ("Table I: single faults", TABLE_1.to_vec()),
        CampaignTable::Two => ("Table II: multiple faults, and the healthy actuator", {
            let mut v = TABLE_2.to_vec();
            v.push(HEALTHY);
            v
        }),
        CampaignTable::Random => (
            "Random multi-fault vectors (not tuned on)",
            campaign::untuned_random_cases(8),
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
    print!("{text}");
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
