//! Prognostics on the ground: simulated degradations (`host-sim degrade`), the trend and RUL
//! report of a history (`host-sim prognose`), its picture, and the ProgPy-style evaluation
//! (`host-sim prognostics`: α-λ accuracy and prognostic horizon).
//!
//! One simulated flight = one reference-model test (≈ 0.05 s) + one onboard identification
//! (≈ 1 s); flights run in parallel. The trend and RUL are `shared::prognosis`, the code the
//! controller runs.

use std::path::Path;

use anyhow::{anyhow, bail, Context, Result};
use plotters::prelude::*;
use rayon::prelude::*;
use shared::domain::DomainLimits;
use shared::fault::{FAULT_COUNT, FAULT_NAMES};
use shared::health::HealthRecord;
use shared::prognosis::{FaultTrend, Growth, HealthTrend, TrendEstimate, TrendSettings};
use shared::{ActuatorParams, Calibration, FaultVector};

use crate::health_file::HistoryRow;
use crate::identify::identify;
use crate::reference::{ReferenceModel, ReferenceSettings, Scenario};

/// How the faults grow from the start vector to the end vector over the flights.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum PathShape {
    /// Uniform growth per flight.
    Linear,
    /// Exponential growth, `(e^{3s} − 1)/(e^3 − 1)` of the way at fraction `s` of the flights
    /// (a fifth of the change in the first half, as wear feeding on itself).
    Accelerating,
}

/// Rate of [`PathShape::Accelerating`] over the whole path.
const ACCELERATION: f64 = 3.0;

/// A degradation path: `flights` preflights from `start` (flight 0) to `end` (the last).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DegradationPath {
    pub start: FaultVector,
    pub end: FaultVector,
    pub flights: u32,
    pub shape: PathShape,
}

impl DegradationPath {
    /// Fraction of the way at `flight` (fractional flights allowed).
    fn progress(&self, flight: f64) -> f64 {
        let s = flight / f64::from(self.flights.saturating_sub(1).max(1));
        match self.shape {
            PathShape::Linear => s,
            PathShape::Accelerating => (ACCELERATION * s).exp_m1() / ACCELERATION.exp_m1(),
        }
    }

    /// The actuator's true fault vector at `flight`.
    pub fn at(&self, flight: u32) -> FaultVector {
        let p = self.progress(f64::from(flight)) as f32;
        let mut k = [0f32; FAULT_COUNT];
        for ((o, a), b) in k
            .iter_mut()
            .zip(self.start.as_array())
            .zip(self.end.as_array())
        {
            *o = a + (b - a) * p;
        }
        FaultVector::saturating(k)
    }

    /// The (fractional) flight at which component `i`'s deviation from nominal reaches
    /// `threshold`, if it does within the path: the true end of life.
    pub fn end_of_life(&self, i: usize, threshold: f32) -> Option<f64> {
        let dev = |v: &FaultVector| v.deviations().get(i).copied().flatten().map(f64::from);
        let (a, b) = (dev(&self.start)?, dev(&self.end)?);
        let t = f64::from(threshold);
        if a >= t || b < t || b <= a {
            return None;
        }
        let q = (t - a) / (b - a);
        let s = match self.shape {
            PathShape::Linear => q,
            PathShape::Accelerating => (q * ACCELERATION.exp_m1()).ln_1p() / ACCELERATION,
        };
        Some(s * f64::from(self.flights.saturating_sub(1).max(1)))
    }
}

/// Seeds of flight `flight` of run `seed`: (reference model, GA).
fn flight_seeds(seed: u64, flight: u32) -> (u64, u64) {
    let rm = seed.wrapping_mul(100_003).wrapping_add(u64::from(flight));
    (rm, rm.wrapping_add(1))
}

/// Simulates the preflight of every flight of `path` (RM trace with I_ref noise `noise`,
/// onboard identification, domain verdict), in parallel; `tick` is called after each flight.
pub fn degrade(
    path: &DegradationPath,
    noise: f64,
    seed: u64,
    tick: &(dyn Fn() + Sync),
) -> Result<Vec<HistoryRow>> {
    let rm = ReferenceModel::new(ReferenceSettings::REFERENCE);
    let params = ActuatorParams::REFERENCE;
    (0..path.flights)
        .into_par_iter()
        .map(|flight| {
            let truth = path.at(flight);
            let (rm_seed, ga_seed) = flight_seeds(seed, flight);
            let trace = rm
                .simulate(&Scenario {
                    faults: truth,
                    current_ref_noise: noise,
                    seed: rm_seed,
                })
                .trace;
            let measured = trace.measured(&params)?;
            let id = identify(&measured, &Calibration::REFERENCE_ACTUATOR, ga_seed, false)?;
            let domain = trace
                .domain_monitor(&params)
                .assess(&DomainLimits::REFERENCE_ACTUATOR, id.result.fitness);
            tick();
            Ok(HistoryRow {
                record: HealthRecord::new(flight, id.result.faults, id.result.fitness, domain)
                    .with_std(
                        id.uncertainty
                            .map_or([f32::NAN; FAULT_COUNT], |(u, _)| u.std),
                    ),
                truth: Some(truth),
            })
        })
        .collect()
}

/// Parses `--threshold`: one number for every fault, or `name=value` pairs (names as in the
/// CSV header) over [`TrendSettings::DEFAULT`]'s.
pub fn parse_thresholds(text: &str) -> Result<[f32; FAULT_COUNT], String> {
    let mut t = TrendSettings::DEFAULT.thresholds;
    let value = |s: &str| -> Result<f32, String> {
        let v: f32 = s
            .trim()
            .parse()
            .map_err(|_| format!("\"{s}\" is not a number"))?;
        if v.is_finite() && v > 0.0 && v <= 1.0 {
            Ok(v)
        } else {
            Err(format!("threshold {v} is outside (0, 1]"))
        }
    };
    if !text.contains('=') {
        let v = value(text)?;
        for (i, o) in t.iter_mut().enumerate() {
            if shared::prognosis::is_trended(i) {
                *o = v;
            }
        }
        return Ok(t);
    }
    for pair in text.split(',') {
        let (name, v) = pair
            .split_once('=')
            .ok_or_else(|| format!("\"{pair}\" is not name=value"))?;
        let i = FAULT_NAMES
            .iter()
            .position(|n| *n == name.trim())
            .filter(|&i| shared::prognosis::is_trended(i))
            .ok_or_else(|| {
                format!(
                    "unknown fault \"{}\" (one of friction, backlash, short_a, short_b, short_c, \
                     eccentricity, gain_drift)",
                    name.trim()
                )
            })?;
        t[i] = value(v)?;
    }
    Ok(t)
}

/// The trend of a history, up to and including flight `until` (all of it when `None`).
pub fn trend_of(rows: &[HistoryRow], until: Option<u32>, settings: &TrendSettings) -> HealthTrend {
    HealthTrend::from_records(
        rows.iter()
            .map(|r| &r.record)
            .filter(|r| until.is_none_or(|u| r.flight <= u)),
        settings,
    )
}

/// A growth shape as reports print it: `linear`, `exp 0.088` (rate per flight), `power 2`.
pub fn growth_name(g: Growth) -> String {
    match g {
        Growth::Linear => "linear".into(),
        Growth::Exponential(r) => format!("exp {r:.3}"),
        Growth::PowerLaw(p) => format!("power {p}"),
    }
}

fn fmt_flights(v: Option<f32>) -> String {
    match v {
        None => "beyond".into(),
        Some(x) => format!("{x:.1}"),
    }
}

/// The per-fault table `prognose` prints.
pub fn report_text(
    estimates: &[Option<TrendEstimate>; FAULT_COUNT],
    settings: &TrendSettings,
) -> String {
    let mut out = format!(
        "{:<13} {:>4} {:>4} {:>7} {:>9} {:>16} {:>7} {:>9} {:>9} {:>19}\n",
        "fault",
        "n",
        "out",
        "level",
        "slope/fl",
        "shape",
        "thresh",
        "scatter",
        "RUL [fl]",
        "90 % interval"
    );
    for (i, e) in estimates.iter().enumerate() {
        let Some(e) = e else { continue };
        let shape = format!("{} {:.0}%", growth_name(e.growth), 100.0 * e.weight);
        let (thr, rul, interval) = match (settings.threshold(i), e.rul) {
            (Some(t), Some(r)) => (
                format!("{t:.3}"),
                fmt_flights(r.rul),
                format!("[{}, {}]", fmt_flights(r.lower), fmt_flights(r.upper)),
            ),
            _ => ("-".into(), "-".into(), "-".into()),
        };
        out += &format!(
            "{:<13} {:>4} {:>4} {:>7.4} {:>9.5} {:>16} {:>7} {:>9.4} {:>9} {:>19}\n",
            FAULT_NAMES[i],
            e.observations,
            e.outliers,
            e.level,
            e.slope,
            shape,
            thr,
            e.scatter,
            rul,
            interval
        );
    }
    out
}

/// The JSON object `prognose --json` prints: per fault its trend and a `rul` entry
/// (`{"flights", "lower", "upper"}`, `null` = beyond the horizon; `rul` itself `null` when the
/// fault has no threshold).
pub fn report_json(
    rows: &[HistoryRow],
    trend: &HealthTrend,
    estimates: &[Option<TrendEstimate>; FAULT_COUNT],
    settings: &TrendSettings,
) -> serde_json::Value {
    let mut faults = serde_json::Map::new();
    for (i, e) in estimates.iter().enumerate() {
        let Some(e) = e else { continue };
        let rul = e
            .rul
            .map(|r| serde_json::json!({"flights": r.rul, "lower": r.lower, "upper": r.upper}));
        faults.insert(
            FAULT_NAMES[i].to_string(),
            serde_json::json!({
                "observations": e.observations,
                "outliers": e.outliers,
                "level": e.level,
                "slope": e.slope,
                "growth": growth_name(e.growth),
                "growth_weight": e.weight,
                "scatter": e.scatter,
                "threshold": settings.threshold(i),
                "rul": rul,
            }),
        );
    }
    serde_json::json!({
        "records": rows.len(),
        "skipped": trend.skipped(),
        "newest_flight": rows.last().map(|r| r.record.flight),
        "horizon": settings.horizon,
        "faults": faults,
    })
}

/// The picture: per fault with a threshold, the identified levels (dots; crosses outside the
/// domain), the truth when known, the fit, the 90 % cone of every plausible growth rate and
/// the threshold with the RUL interval marked on it.
pub fn history_svg(
    out: &Path,
    rows: &[HistoryRow],
    trend: &HealthTrend,
    settings: &TrendSettings,
    title: &str,
) -> Result<()> {
    let estimates = trend.estimates(settings);
    // Faults with a threshold and an estimate; of those, the ones detected or heading for
    // their threshold within the horizon (all of them when none is).
    let candidates: Vec<usize> = (0..FAULT_COUNT)
        .filter(|&i| settings.threshold(i).is_some() && estimates[i].is_some())
        .collect();
    let active: Vec<usize> = candidates
        .iter()
        .copied()
        .filter(|&i| {
            estimates[i].is_some_and(|e| {
                e.level > shared::fault::DETECTION_THRESHOLD
                    || e.rul.is_some_and(|r| r.rul.is_some())
            })
        })
        .collect();
    let shown = if active.is_empty() {
        candidates
    } else {
        active
    };
    if shown.is_empty() {
        bail!("nothing to plot: fewer than 3 trusted records");
    }
    let newest = f64::from(rows.last().map_or(0, |r| r.record.flight));
    let first = f64::from(rows.first().map_or(0, |r| r.record.flight));
    let span = (newest - first).max(1.0);
    let rows_n = shown.len().div_ceil(2);
    let root = SVGBackend::new(out, (1200, 40 + 330 * rows_n as u32)).into_drawing_area();
    let e = |e: DrawingAreaErrorKind<_>| anyhow!("drawing {}: {e:?}", out.display());
    root.fill(&WHITE).map_err(e)?;
    let root = root.titled(title, ("sans-serif", 20)).map_err(e)?;
    let panels = root.split_evenly((rows_n, 2));
    for (panel, &i) in panels.iter().zip(&shown) {
        let threshold = f64::from(settings.threshold(i).unwrap_or(1.0));
        let estimate = estimates[i].ok_or_else(|| anyhow!("no estimate"))?;
        let fault: &FaultTrend = trend.fault(i).ok_or_else(|| anyhow!("no trend"))?;
        // Show the future up to the interval's far end (or half the history again).
        let far = estimate
            .rul
            .and_then(|r| r.upper.or(r.rul))
            .map_or(0.5 * span, f64::from)
            .clamp(0.25 * span, 1.5 * span);
        let x_end = newest + 1.15 * far;
        let obs: Vec<(f64, f64, bool)> = rows
            .iter()
            .filter_map(|r| {
                let d = r.record.faults.deviations()[i]?;
                Some((
                    f64::from(r.record.flight),
                    f64::from(d),
                    r.record.is_trusted(),
                ))
            })
            .collect();
        let steps = 200;
        let grid: Vec<f64> = (0..=steps)
            .map(|s| first + (x_end - first) * f64::from(s) / f64::from(steps))
            .collect();
        let fit: Vec<(f64, f64)> = grid
            .iter()
            .map(|&x| (x, fault.band(x, settings).0))
            .collect();
        let cone: Vec<(f64, (f64, f64))> = grid
            .iter()
            .filter(|&&x| x >= newest)
            .map(|&x| (x, fault.envelope(x, settings)))
            .collect();
        let y_hi = obs
            .iter()
            .map(|o| o.1)
            .fold(threshold * 1.15, f64::max)
            .min(1.0);
        let mut chart = ChartBuilder::on(panel)
            .caption(FAULT_NAMES[i], ("sans-serif", 16))
            .margin(8)
            .x_label_area_size(32)
            .y_label_area_size(50)
            .build_cartesian_2d(first..x_end, 0.0..y_hi)
            .map_err(e)?;
        chart
            .configure_mesh()
            .x_desc("flight")
            .y_desc("deviation from nominal")
            .draw()
            .map_err(e)?;
        let mut upper: Vec<(f64, f64)> = cone.iter().map(|&(x, (_, h))| (x, h.min(y_hi))).collect();
        let lower: Vec<(f64, f64)> = cone.iter().map(|&(x, (l, _))| (x, l.max(0.0))).collect();
        upper.extend(lower.into_iter().rev());
        chart
            .draw_series(std::iter::once(Polygon::new(upper, RED.mix(0.15))))
            .map_err(e)?
            .label("90 % cone (plausible growth rates)")
            .legend(|(x, y)| Rectangle::new([(x, y - 4), (x + 20, y + 4)], RED.mix(0.15).filled()));
        chart
            .draw_series(LineSeries::new(fit, RED.stroke_width(2)))
            .map_err(e)?
            .label("fit")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED));
        if rows.iter().all(|r| r.truth.is_some()) {
            let truth: Vec<(f64, f64)> = rows
                .iter()
                .filter_map(|r| {
                    Some((
                        f64::from(r.record.flight),
                        f64::from(r.truth?.deviations()[i]?),
                    ))
                })
                .collect();
            chart
                .draw_series(LineSeries::new(truth, BLACK.mix(0.6)))
                .map_err(e)?
                .label("truth")
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.mix(0.6)));
        }
        chart
            .draw_series(
                obs.iter()
                    .filter(|o| o.2)
                    .map(|&(x, y, _)| Circle::new((x, y), 3, BLUE.filled())),
            )
            .map_err(e)?
            .label("identified")
            .legend(|(x, y)| Circle::new((x + 10, y), 3, BLUE.filled()));
        chart
            .draw_series(
                obs.iter()
                    .filter(|o| !o.2)
                    .map(|&(x, y, _)| Cross::new((x, y), 4, BLACK)),
            )
            .map_err(e)?;
        chart
            .draw_series(LineSeries::new(
                vec![(first, threshold), (x_end, threshold)],
                GREEN.stroke_width(2),
            ))
            .map_err(e)?
            .label(format!("threshold {threshold:.3}"))
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], GREEN));
        if let Some(r) = estimate.rul {
            let lo = r.lower.map_or(x_end, |v| newest + f64::from(v)).min(x_end);
            let hi = r.upper.map_or(x_end, |v| newest + f64::from(v)).min(x_end);
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [(lo, threshold - 0.01 * y_hi), (hi, threshold + 0.01 * y_hi)],
                    GREEN.mix(0.6).filled(),
                )))
                .map_err(e)?;
            if let Some(m) = r.rul {
                let x = newest + f64::from(m);
                if x <= x_end {
                    chart
                        .draw_series(std::iter::once(TriangleMarker::new(
                            (x, threshold),
                            6,
                            GREEN,
                        )))
                        .map_err(e)?
                        .label(format!("RUL {m:.1} flights"))
                        .legend(|(x, y)| TriangleMarker::new((x + 10, y), 5, GREEN));
                }
            }
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK.mix(0.3))
            .label_font(("sans-serif", 11))
            .draw()
            .map_err(e)?;
    }
    root.present().context("writing the plot")?;
    Ok(())
}

/// One evaluation scenario: a degradation path shape and its start and end vectors.
#[derive(Clone, Copy, Debug)]
pub struct EvalScenario {
    pub name: &'static str,
    pub start: [f32; FAULT_COUNT],
    pub end: [f32; FAULT_COUNT],
    pub shape: PathShape,
}

const H: [f32; FAULT_COUNT] = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5];

const fn with(mut k: [f32; FAULT_COUNT], i: usize, v: f32) -> [f32; FAULT_COUNT] {
    k[i] = v;
    k
}

/// The evaluation set: single faults and pairs growing together, linear and accelerating,
/// each crossing its default threshold at about 80 % of the path (eccentricity is left out:
/// its identification is not yet accurate, issue 4).
pub const EVAL_SCENARIOS: [EvalScenario; 8] = [
    EvalScenario {
        name: "friction, linear",
        start: H,
        end: with(H, 0, 0.6),
        shape: PathShape::Linear,
    },
    EvalScenario {
        name: "friction, accelerating",
        start: H,
        end: with(H, 0, 0.6),
        shape: PathShape::Accelerating,
    },
    EvalScenario {
        name: "short A, linear",
        start: H,
        end: with(H, 2, 0.36),
        shape: PathShape::Linear,
    },
    EvalScenario {
        name: "short A, accelerating",
        start: H,
        end: with(H, 2, 0.36),
        shape: PathShape::Accelerating,
    },
    EvalScenario {
        name: "backlash, accelerating",
        start: H,
        end: with(H, 1, 0.6),
        shape: PathShape::Accelerating,
    },
    EvalScenario {
        name: "gain drift up, linear",
        start: H,
        end: with(H, 7, 0.8),
        shape: PathShape::Linear,
    },
    EvalScenario {
        name: "friction + short B, linear",
        start: H,
        end: with(with(H, 0, 0.6), 3, 0.36),
        shape: PathShape::Linear,
    },
    EvalScenario {
        name: "backlash + gain drift down, accelerating",
        start: H,
        end: with(with(H, 1, 0.6), 7, 0.2),
        shape: PathShape::Accelerating,
    },
];

/// One fault's prognosis along one simulated run.
#[derive(Clone, Debug)]
pub struct Track {
    pub scenario: &'static str,
    pub shape: PathShape,
    pub seed: u64,
    pub fault: usize,
    /// True end of life (fractional flight).
    pub eol: f64,
    /// After each flight: the RUL estimate (`None` before three observations).
    pub predictions: Vec<(u32, Option<shared::prognosis::RulEstimate>)>,
}

/// Runs every scenario for `seeds` seeds over `flights` flights and replays the onboard
/// prognosis flight by flight.
pub fn evaluate(
    scenarios: &[EvalScenario],
    seeds: u64,
    flights: u32,
    noise: f64,
    settings: &TrendSettings,
    tick: &(dyn Fn() + Sync),
) -> Result<Vec<Track>> {
    let mut tracks = Vec::new();
    for sc in scenarios {
        let path = DegradationPath {
            start: FaultVector::new(sc.start).map_err(|e| anyhow!("{}: {e:?}", sc.name))?,
            end: FaultVector::new(sc.end).map_err(|e| anyhow!("{}: {e:?}", sc.name))?,
            flights,
            shape: sc.shape,
        };
        for seed in 0..seeds {
            let rows = degrade(&path, noise, seed, tick)?;
            for i in 0..FAULT_COUNT {
                let Some(threshold) = settings.threshold(i) else {
                    continue;
                };
                let Some(eol) = path.end_of_life(i, threshold) else {
                    continue;
                };
                let mut trend = HealthTrend::new();
                let predictions = rows
                    .iter()
                    .map(|r| {
                        trend.update(&r.record, settings);
                        let e = trend
                            .fault(i)
                            .and_then(|f| f.estimate(Some(threshold), settings));
                        (r.record.flight, e.and_then(|e| e.rul))
                    })
                    .collect();
                tracks.push(Track {
                    scenario: sc.name,
                    shape: sc.shape,
                    seed,
                    fault: i,
                    eol,
                    predictions,
                });
            }
        }
    }
    Ok(tracks)
}

/// ProgPy-style metrics of one track with accuracy bound `alpha` (relative).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrackMetrics {
    /// α-λ at λ = 0.5 and λ = 0.75 (RUL within ±α of the truth at that flight).
    pub alpha_lambda: [bool; 2],
    /// Relative RUL error at λ = 0.5 (`None`: no crossing predicted).
    pub error_half: Option<f64>,
    /// Share of the predictions from half of the life to the end of life within ±α.
    pub share_after_half: f64,
    /// Share of those whose 90 % interval holds the truth.
    pub coverage_after_half: f64,
    /// Prognostic horizon [flights]: end of life minus the first flight from which every
    /// prediction stays within ±α·EOL of the truth (0 when none does).
    pub horizon: f64,
}

fn within(pred: Option<f32>, truth: f64, bound: f64) -> bool {
    pred.is_some_and(|p| (f64::from(p) - truth).abs() <= bound)
}

impl Track {
    fn at(&self, flight: u32) -> Option<shared::prognosis::RulEstimate> {
        self.predictions
            .iter()
            .find(|p| p.0 == flight)
            .and_then(|p| p.1)
    }

    pub fn metrics(&self, alpha: f64) -> TrackMetrics {
        let lambda = |l: f64| {
            let t = (l * self.eol).floor() as u32;
            let truth = self.eol - f64::from(t);
            within(self.at(t).and_then(|r| r.rul), truth, alpha * truth)
        };
        let t_half = (0.5 * self.eol).floor() as u32;
        let error_half = self.at(t_half).and_then(|r| r.rul).map(|p| {
            (f64::from(p) - (self.eol - f64::from(t_half))) / (self.eol - f64::from(t_half))
        });
        let before_eol: Vec<(u32, Option<shared::prognosis::RulEstimate>)> = self
            .predictions
            .iter()
            .copied()
            .filter(|p| f64::from(p.0) < self.eol)
            .collect();
        let late: Vec<_> = before_eol.iter().filter(|p| p.0 >= t_half).collect();
        let share = |ok: &dyn Fn(f64, &shared::prognosis::RulEstimate) -> bool| -> f64 {
            let n = late
                .iter()
                .filter(|p| p.1.is_some_and(|r| ok(self.eol - f64::from(p.0), &r)))
                .count();
            n as f64 / late.len().max(1) as f64
        };
        let share_after_half = share(&|truth, r| within(r.rul, truth, alpha * truth));
        let coverage_after_half = share(&|truth, r| {
            r.lower.is_some_and(|l| f64::from(l) <= truth)
                && r.upper.is_none_or(|u| f64::from(u) >= truth)
        });
        // First flight from which every later prediction stays within ±α·EOL.
        let mut first_good = None;
        for p in before_eol.iter().rev() {
            if within(
                p.1.and_then(|r| r.rul),
                self.eol - f64::from(p.0),
                alpha * self.eol,
            ) {
                first_good = Some(p.0);
            } else {
                break;
            }
        }
        TrackMetrics {
            alpha_lambda: [lambda(0.5), lambda(0.75)],
            error_half,
            share_after_half,
            coverage_after_half,
            horizon: first_good.map_or(0.0, |t| self.eol - f64::from(t)),
        }
    }
}

/// The evaluation report (Markdown): one row per scenario and fault, and the totals.
pub fn eval_markdown(tracks: &[Track], alpha: f64) -> String {
    let mut groups: Vec<(&str, usize, Vec<&Track>)> = Vec::new();
    for t in tracks {
        match groups
            .iter_mut()
            .find(|g| g.0 == t.scenario && g.1 == t.fault)
        {
            Some(g) => g.2.push(t),
            None => groups.push((t.scenario, t.fault, vec![t])),
        }
    }
    let pct = |x: f64| format!("{:.0} %", 100.0 * x);
    let mut out = format!(
        "| scenario | fault | runs | true EOL [flight] | α-λ λ=0.5 | α-λ λ=0.75 | RUL error at λ=0.5 (each run) | within ±{a} after half life | 90 % interval holds truth | prognostic horizon [flights] (PH/EOL) |\n\
         | --- | --- | ---: | ---: | ---: | ---: | --- | ---: | ---: | --- |\n",
        a = pct(alpha)
    );
    let mut all: Vec<TrackMetrics> = Vec::new();
    for (name, fault, ts) in &groups {
        let m: Vec<TrackMetrics> = ts.iter().map(|t| t.metrics(alpha)).collect();
        let n = m.len() as f64;
        let count = |f: &dyn Fn(&TrackMetrics) -> bool| m.iter().filter(|x| f(x)).count();
        let errors: Vec<String> = m
            .iter()
            .map(|x| {
                x.error_half
                    .map_or("none".into(), |e| format!("{:+.0} %", 100.0 * e))
            })
            .collect();
        let mean = |f: &dyn Fn(&TrackMetrics) -> f64| m.iter().map(f).sum::<f64>() / n;
        let eol = ts.iter().map(|t| t.eol).sum::<f64>() / n;
        let ph: Vec<String> = m.iter().map(|x| format!("{:.0}", x.horizon)).collect();
        out += &format!(
            "| {name} | {} | {} | {eol:.1} | {}/{} | {}/{} | {} | {} | {} | {} ({}) |\n",
            FAULT_NAMES[*fault],
            m.len(),
            count(&|x| x.alpha_lambda[0]),
            m.len(),
            count(&|x| x.alpha_lambda[1]),
            m.len(),
            errors.join(", "),
            pct(mean(&|x| x.share_after_half)),
            pct(mean(&|x| x.coverage_after_half)),
            ph.join(", "),
            pct(mean(&|x| x.horizon) / eol),
        );
        all.extend(m);
    }
    let n = all.len();
    let c = |f: &dyn Fn(&TrackMetrics) -> bool| all.iter().filter(|x| f(x)).count();
    let mean = |f: &dyn Fn(&TrackMetrics) -> f64| all.iter().map(f).sum::<f64>() / n.max(1) as f64;
    out += &format!(
        "| **all** | | {n} | | **{}/{n}** | **{}/{n}** | | **{}** | {} | |\n",
        c(&|x| x.alpha_lambda[0]),
        c(&|x| x.alpha_lambda[1]),
        pct(mean(&|x| x.share_after_half)),
        pct(mean(&|x| x.coverage_after_half)),
    );
    out
}

/// The α-λ picture: predicted RUL against flight, both over the true EOL, for every track,
/// with the truth and the ±α cone; one panel per path shape.
pub fn eval_svg(out: &Path, tracks: &[Track], alpha: f64) -> Result<()> {
    let root = SVGBackend::new(out, (1200, 520)).into_drawing_area();
    let e = |e: DrawingAreaErrorKind<_>| anyhow!("drawing {}: {e:?}", out.display());
    root.fill(&WHITE).map_err(e)?;
    let panels = root.split_evenly((1, 2));
    for (panel, shape) in panels
        .iter()
        .zip([PathShape::Linear, PathShape::Accelerating])
    {
        let mut chart = ChartBuilder::on(panel)
            .caption(
                format!("{shape:?} degradations: RUL / EOL against flight / EOL"),
                ("sans-serif", 16),
            )
            .margin(10)
            .x_label_area_size(36)
            .y_label_area_size(50)
            .build_cartesian_2d(0.0..1.0, 0.0..1.2)
            .map_err(e)?;
        chart
            .configure_mesh()
            .x_desc("λ = flight / true EOL")
            .y_desc("RUL / true EOL")
            .draw()
            .map_err(e)?;
        let cone: Vec<(f64, f64)> = [
            (0.0, 1.0 + alpha),
            (1.0, 0.0),
            (1.0, 0.0),
            (0.0, 1.0 - alpha),
        ]
        .into_iter()
        .collect();
        chart
            .draw_series(std::iter::once(Polygon::new(cone, GREEN.mix(0.15))))
            .map_err(e)?
            .label(format!("truth ±{:.0} %", 100.0 * alpha))
            .legend(|(x, y)| {
                Rectangle::new([(x, y - 4), (x + 20, y + 4)], GREEN.mix(0.15).filled())
            });
        chart
            .draw_series(LineSeries::new(
                vec![(0.0, 1.0), (1.0, 0.0)],
                BLACK.stroke_width(2),
            ))
            .map_err(e)?
            .label("true RUL")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK));
        for (n, t) in tracks.iter().filter(|t| t.shape == shape).enumerate() {
            let colour = Palette99::pick(n).mix(0.8);
            let pts: Vec<(f64, f64)> = t
                .predictions
                .iter()
                .filter(|p| f64::from(p.0) < t.eol)
                .filter_map(|p| {
                    let r = p.1?.rul?;
                    Some((f64::from(p.0) / t.eol, (f64::from(r) / t.eol).min(1.2)))
                })
                .collect();
            chart.draw_series(LineSeries::new(pts, colour)).map_err(e)?;
        }
        chart
            .draw_series(LineSeries::new(
                vec![(0.5, 0.0), (0.5, 1.2)],
                BLACK.mix(0.3),
            ))
            .map_err(e)?;
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK.mix(0.3))
            .draw()
            .map_err(e)?;
    }
    root.present().context("writing the plot")?;
    Ok(())
}
