//! The grease study (issue 34, item 3): can one preflight chirp tell the grease's viscous
//! drag from its dry friction, from what the controller measures alone, so that the drag can
//! stand as a thermometer of the grease and wear (k1) stay apart from a cold gearbox?
//!
//! Per test, the flight code's own fit of the motor's torque balance over the chirp
//! (`shared::grease`, fed by the trace's frames as the controller conditions them). Its
//! viscous term lumps every viscous torque the motor sees — the grease's drag on the motor
//! shaft and the user shaft's damping reflected through the gear: only its change from the
//! calibration day is the grease's. The study's only cost is the reference model's runs.

use anyhow::{bail, Result};
use rayon::prelude::*;
use shared::grease::GreaseReading;
use shared::test_design::PreflightTest;
use shared::FaultVector;

use crate::plant::reference::{ReferenceModel, ReferenceSettings, Scenario};

/// One row of the study: what the reference model played and what the chirp's fit read,
/// as ratios to the healthy actuator at the calibration day (mean and spread over seeds).
#[derive(Clone, Debug, PartialEq)]
pub struct GreaseRow {
    pub grease: &'static str,
    pub winding: f64,
    pub gear: f64,
    pub case: &'static str,
    /// The reference model's grease drag at the gear's temperature over the calibration
    /// day's (1 where the grease has none).
    pub true_drag: f64,
    /// Its dry friction (grease law × the fault's 1 + 2·k1) over the calibration day's.
    pub true_coulomb: f64,
    /// Fitted viscous / the calibration day's: mean, standard deviation over seeds.
    pub viscous: (f64, f64),
    /// Fitted dry friction / the calibration day's.
    pub coulomb: (f64, f64),
    /// Wear read with the healthy dry friction taken from the fitted drag through the
    /// healthy law (`k1 = (c/c₀(b) − 1)/2`), and with it taken from the winding thermistor's
    /// temperature (today's friction law).
    pub wear_by_drag: f64,
    pub wear_by_thermistor: f64,
    pub true_wear: f64,
}

fn mean_sd(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let m = x.iter().sum::<f64>() / n;
    let v = x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    (m, v.sqrt())
}

/// The actuator and test the study plays (the built-in reference actuator, or a file's).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bench {
    pub settings: ReferenceSettings,
    pub test: PreflightTest,
}

impl Bench {
    /// The built-in reference actuator and its injection test.
    pub const REFERENCE: Self = Self {
        settings: ReferenceSettings::REFERENCE,
        test: PreflightTest::INJECTION,
    };

    /// The calibration day's winding temperature [°C].
    pub fn day(&self) -> f64 {
        self.settings.conditions.winding_temperature
    }
}

/// The bench's actuator with its grease (one factor on dry friction) or the two-part grease,
/// at winding and gear temperatures `winding`, `gear` [°C].
pub fn settings(bench: &Bench, two_part: bool, winding: f64, gear: f64) -> ReferenceSettings {
    let mut s = bench.settings;
    if two_part {
        s.thermal = s.thermal.with_two_part_grease(&s.params);
    }
    s.conditions = s.conditions.at_temperature(winding);
    s.conditions.gear_temperature = gear;
    s
}

/// Fits `seeds` reference-model runs of `k` under `settings` (the injection test; seeds
/// 0 … seeds − 1).
pub fn fits(
    bench: &Bench,
    settings: ReferenceSettings,
    k: FaultVector,
    seeds: u64,
) -> Result<Vec<GreaseReading>> {
    let test = bench.test;
    (0..seeds)
        .into_par_iter()
        .map(|seed| {
            let mut scenario = Scenario::new(k);
            scenario.seed = seed;
            let sim = ReferenceModel::new(settings)
                .with_test(test)
                .simulate(&scenario);
            sim.trace
                .measured(&settings.params)?
                .grease()
                .map_err(|e| anyhow::anyhow!("the chirp's torque balance: {e:?}"))
        })
        .collect()
}

/// The healthy actuator's chirp fits at the climatic chamber's temperatures (winding = gear,
/// as `calibrate --at` plays them) and at the calibration day: what the wear is read against.
#[derive(Clone, Debug, PartialEq)]
pub struct HealthyGreaseLaw {
    /// (°C, viscous, dry friction), the calibration day's included.
    points: Vec<(f64, f64, f64)>,
    /// The calibration day's viscous and dry friction.
    day: (f64, f64),
}

impl HealthyGreaseLaw {
    /// Fits `seeds` healthy runs at −45, −25, 0 and +75 °C and at the calibration day.
    pub fn measure(bench: &Bench, two_part: bool, seeds: u64) -> Result<Self> {
        let base = bench.day();
        let healthy = FaultVector::saturating([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0]);
        let mut points = Vec::new();
        for t in [-45.0, -25.0, 0.0, base, 75.0] {
            let f = fits(bench, settings(bench, two_part, t, t), healthy, seeds)?;
            let v = mean_sd(&f.iter().map(|x| f64::from(x.viscous)).collect::<Vec<_>>()).0;
            let c = mean_sd(&f.iter().map(|x| f64::from(x.coulomb)).collect::<Vec<_>>()).0;
            points.push((t, v, c));
        }
        let day = (points[3].1, points[3].2);
        Ok(Self { points, day })
    }

    /// The fit's viscous drag and dry friction over the calibration day's.
    pub fn ratios(&self, fit: &GreaseReading) -> (f64, f64) {
        (
            f64::from(fit.viscous) / self.day.0,
            f64::from(fit.coulomb) / self.day.1,
        )
    }

    /// Wear `k1 = (c / c₀ − 1) / 2` with the healthy dry friction c₀ taken from the fitted
    /// drag through the healthy points (piecewise linear, clamped at the ends).
    pub fn wear_by_drag(&self, viscous_ratio: f64, coulomb_ratio: f64) -> f64 {
        let points = self
            .points
            .iter()
            .map(|p| (p.1 / self.day.0, p.2 / self.day.1));
        (coulomb_ratio / interpolate(points.collect(), viscous_ratio) - 1.0) / 2.0
    }

    /// The same with c₀ taken from a temperature [°C] (today's friction law, which reads the
    /// winding thermistor).
    pub fn wear_by_temperature(&self, celsius: f64, coulomb_ratio: f64) -> f64 {
        let points = self.points.iter().map(|p| (p.0, p.2 / self.day.1));
        (coulomb_ratio / interpolate(points.collect(), celsius) - 1.0) / 2.0
    }
}

/// Piecewise linear in `points` (sorted here by x), clamped at the ends.
fn interpolate(mut points: Vec<(f64, f64)>, x: f64) -> f64 {
    points.sort_by(|a, b| a.0.total_cmp(&b.0));
    let i = points
        .partition_point(|p| p.0 < x)
        .clamp(1, points.len() - 1);
    let (a, b) = (points[i - 1], points[i]);
    let t = ((x - a.0) / (b.0 - a.0)).clamp(0.0, 1.0);
    a.1 + t * (b.1 - a.1)
}

/// The grease study: for each grease (one factor, two-part), winding and gear temperature
/// and case, the chirp's fit against the truth. `progress` is told each row.
pub fn grease_study(
    bench: &Bench,
    seeds: u64,
    mut progress: impl FnMut(&str),
) -> Result<Vec<GreaseRow>> {
    if seeds < 2 {
        bail!("the study needs at least 2 seeds");
    }
    let base = bench.day();
    let cases: [(&'static str, [f32; 9]); 5] = [
        ("healthy", [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0]),
        (
            "friction k1 = 0.2",
            [0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0],
        ),
        (
            "friction k1 = 0.4",
            [0.4, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0],
        ),
        (
            "backlash k2 = 0.4",
            [0.0, 0.4, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0],
        ),
        (
            "short A k3 = 0.2",
            [0.0, 0.0, 0.2, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0],
        ),
    ];
    let days: [(f64, f64); 6] = [
        (base, base),
        (base - 60.0, base - 60.0),
        (base + 60.0, base + 60.0),
        (base, base - 40.0),
        (base, base + 40.0),
        (base - 40.0, base - 60.0),
    ];
    let mut rows = Vec::new();
    for (grease, two_part) in [("one factor", false), ("two-part", true)] {
        progress(&format!("{grease}: the healthy law"));
        let law = HealthyGreaseLaw::measure(bench, two_part, seeds)?;
        let truth = settings(bench, two_part, base, base);
        let drag0 = truth.thermal.drag(base);
        let coulomb0 = truth.thermal.friction_scale(base);
        for &(winding, gear) in &days {
            for &(case, k) in &cases {
                progress(&format!(
                    "{grease}: winding {winding:.0} °C, gear {gear:.0} °C, {case}"
                ));
                let s = settings(bench, two_part, winding, gear);
                let f = fits(bench, s, FaultVector::saturating(k), seeds)?;
                let ratios: Vec<(f64, f64)> = f.iter().map(|x| law.ratios(x)).collect();
                let viscous: Vec<f64> = ratios.iter().map(|r| r.0).collect();
                let coulomb: Vec<f64> = ratios.iter().map(|r| r.1).collect();
                let (vm, cm) = (mean_sd(&viscous).0, mean_sd(&coulomb).0);
                rows.push(GreaseRow {
                    grease,
                    winding,
                    gear,
                    case,
                    true_drag: if drag0 > 0.0 {
                        s.thermal.drag(gear) / drag0
                    } else {
                        1.0
                    },
                    true_coulomb: s.thermal.friction_scale(gear) / coulomb0
                        * (1.0 + 2.0 * f64::from(k[0])),
                    viscous: mean_sd(&viscous),
                    coulomb: mean_sd(&coulomb),
                    // The thermistor reads the winding (its 2 K bias left out here).
                    wear_by_drag: law.wear_by_drag(vm, cm),
                    wear_by_thermistor: law.wear_by_temperature(winding, cm),
                    true_wear: f64::from(k[0]),
                });
            }
        }
    }
    Ok(rows)
}

/// The study's table (Markdown).
pub fn grease_markdown(name: &str, rows: &[GreaseRow], seeds: u64) -> String {
    use std::fmt::Write;
    let mut text = format!(
        "### {name}\n\nInjection test, {seeds} seeds per row: the chirp's torque-balance \
         fit (`shared::grease`) against what the reference model played, both \
         as ratios to the healthy actuator at the calibration day; then the wear k1 read with \
         the healthy dry friction taken from the fitted drag, and from the winding's \
         temperature (today's law).\n\n\
         | grease | winding °C | gear °C | case | drag played | viscous fitted (sd) | dry played | dry fitted (sd) | k1 | k1 by drag | k1 by thermistor |\n\
         | --- | ---: | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n"
    );
    for r in rows {
        let _ = writeln!(
            text,
            "| {} | {:.0} | {:.0} | {} | {:.2} | {:.2} ({:.2}) | {:.2} | {:.2} ({:.2}) | {:.1} | {:+.3} | {:+.3} |",
            r.grease,
            r.winding,
            r.gear,
            r.case,
            r.true_drag,
            r.viscous.0,
            r.viscous.1,
            r.true_coulomb,
            r.coulomb.0,
            r.coulomb.1,
            r.true_wear,
            r.wear_by_drag,
            r.wear_by_thermistor,
        );
    }
    text
}
