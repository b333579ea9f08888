//! The identification picture: measured vs best-fit monitor-model current, and the fitness
//! history of the GA. SVG through `plotters`.

use std::path::Path;

use anyhow::{anyhow, Result};
use plotters::prelude::*;
use shared::fdi::OnboardMeasured;
use shared::{ActuatorParams, Calibration, FaultVector};

use crate::fdi::calibration::filtered_model_current;

/// Draws the two panels into `out`.
pub fn identification_svg(
    out: &Path,
    measured: &OnboardMeasured,
    params: ActuatorParams,
    calibration: &Calibration,
    found: &FaultVector,
    history: &[(u32, f32)],
    title: &str,
) -> Result<()> {
    let dt = f64::from(params.control_period);
    let fitted = filtered_model_current(measured, params, calibration, found);
    let series = |v: &[f32]| -> Vec<(f64, f64)> {
        v.iter()
            .enumerate()
            .map(|(i, &x)| (i as f64 * dt, f64::from(x)))
            .collect()
    };
    let measured_pts = series(measured.samples());
    let fitted_pts = series(&fitted);
    let (lo, hi) = measured_pts
        .iter()
        .chain(&fitted_pts)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p.1), hi.max(p.1))
        });
    let pad = 0.05 * (hi - lo).max(1e-3);
    let t_end = measured_pts.len() as f64 * dt;

    let root = SVGBackend::new(out, (1100, 800)).into_drawing_area();
    let e = |e: DrawingAreaErrorKind<_>| anyhow!("drawing {}: {e:?}", out.display());
    root.fill(&WHITE).map_err(e)?;
    let (upper, lower) = root.split_vertically(480);

    let mut chart = ChartBuilder::on(&upper)
        .caption(title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..t_end, (lo - pad)..(hi + pad))
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc("t [s]")
        .y_desc("filtered equivalent current [A]")
        .draw()
        .map_err(e)?;
    chart
        .draw_series(LineSeries::new(measured_pts, &BLUE))
        .map_err(e)?
        .label("measured (reference model / actuator)")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLUE));
    chart
        .draw_series(LineSeries::new(fitted_pts, &RED))
        .map_err(e)?
        .label("monitor model at the identified faults")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED));
    draw_legend(&mut chart, out, SeriesLabelPosition::UpperLeft)?;

    // Fitness history: eq. (3) error plus the residual (the raw, positive error) on a log axis.
    let residual = f64::from(calibration.nominal_residual);
    let hist: Vec<(f64, f64)> = history
        .iter()
        .map(|&(n, f)| (f64::from(n), (f64::from(f) + residual).max(1e-12)))
        .collect();
    let max_n = hist.last().map_or(1.0, |p| p.0.max(1.0));
    let (flo, fhi) = hist
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p.1), hi.max(p.1))
        });
    let (flo, fhi) = if flo.is_finite() && fhi.is_finite() {
        (flo / 1.5, fhi * 1.5)
    } else {
        (1e-6, 1.0)
    };
    let mut chart = ChartBuilder::on(&lower)
        .caption(
            "GA: best eq. (3) error (residual not subtracted)",
            ("sans-serif", 16),
        )
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..max_n, (flo..fhi).log_scale())
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc("monitor-model evaluations")
        .y_desc("error [A²·s]")
        .y_labels(12)
        .y_label_formatter(&|v| format!("{v:.1e}"))
        .draw()
        .map_err(e)?;
    chart
        .draw_series(LineSeries::new(hist, &BLACK))
        .map_err(e)?;
    root.present().map_err(e)?;
    Ok(())
}

/// A window of flight as identified: the command and the surface's angle [mrad] above, the
/// filtered measured current, the model's at the identified faults and the model's with the
/// profiled drift [A] below.
pub fn window_svg(
    out: &Path,
    points: &[crate::fdi::window::WindowPoint],
    title: &str,
) -> Result<()> {
    let e = |e: DrawingAreaErrorKind<_>| anyhow!("drawing {}: {e:?}", out.display());
    let t_end = points.last().map_or(1.0, |p| f64::from(p.0)).max(1e-3);
    let range = |values: &mut dyn Iterator<Item = f64>| {
        let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
        let (lo, hi) = if lo.is_finite() {
            (lo, hi)
        } else {
            (-1.0, 1.0)
        };
        let pad = 0.05 * (hi - lo).max(1e-3);
        (lo - pad)..(hi + pad)
    };
    let root = SVGBackend::new(out, (1100, 800)).into_drawing_area();
    root.fill(&WHITE).map_err(e)?;
    let (upper, lower) = root.split_vertically(330);
    let angles = range(
        &mut points
            .iter()
            .flat_map(|p| [p.1, p.2])
            .map(|x| 1e3 * f64::from(x)),
    );
    let mut chart = ChartBuilder::on(&upper)
        .caption(title, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(36)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..t_end, angles)
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc("t [s]")
        .y_desc("angle [mrad]")
        .draw()
        .map_err(e)?;
    for (pick, colour, label) in [
        (1usize, BLACK, "command (flight control computer + test)"),
        (2, GREEN, "surface (measured)"),
    ] {
        let series = points.iter().map(move |p| {
            let v = if pick == 1 { p.1 } else { p.2 };
            (f64::from(p.0), 1e3 * f64::from(v))
        });
        chart
            .draw_series(LineSeries::new(series, &colour))
            .map_err(e)?
            .label(label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour));
    }
    draw_legend(&mut chart, out, SeriesLabelPosition::UpperLeft)?;
    let currents = range(&mut points.iter().flat_map(|p| [p.3, p.4, p.5]).map(f64::from));
    let mut chart = ChartBuilder::on(&lower)
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..t_end, currents)
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc("t [s]")
        .y_desc("filtered equivalent current [A]")
        .draw()
        .map_err(e)?;
    for (pick, colour, label) in [
        (3usize, BLUE, "measured"),
        (
            4,
            RGBColor(255, 160, 160),
            "monitor model (fitted load, identified faults)",
        ),
        (5, RED, "monitor model + profiled drift"),
    ] {
        let series = points.iter().map(move |p| {
            let v = match pick {
                3 => p.3,
                4 => p.4,
                _ => p.5,
            };
            (f64::from(p.0), f64::from(v))
        });
        chart
            .draw_series(LineSeries::new(series, &colour))
            .map_err(e)?
            .label(label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour));
    }
    draw_legend(&mut chart, out, SeriesLabelPosition::UpperLeft)?;
    root.present().map_err(e)?;
    Ok(())
}

/// The series legend every plot of this crate draws: at `position`, on a translucent white
/// box.
pub(crate) fn draw_legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    out: &Path,
    position: SeriesLabelPosition,
) -> Result<()> {
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(position)
        .draw()
        .map_err(|e| anyhow!("drawing {}: {e:?}", out.display()))
}

/// Median best-so-far e_tot against evaluations, one line per optimiser, log–log, with the
/// target as a dashed line.
pub fn optimisers_svg(
    out: &Path,
    curves: &[(&str, Vec<f64>)],
    target: f64,
    title: &str,
) -> Result<()> {
    let e = |e: DrawingAreaErrorKind<_>| anyhow!("drawing {}: {e:?}", out.display());
    let root = SVGBackend::new(out, (1000, 650)).into_drawing_area();
    root.fill(&WHITE).map_err(e)?;
    let max_n = curves.iter().map(|c| c.1.len()).max().unwrap_or(1).max(2) as f64;
    let finite = curves
        .iter()
        .flat_map(|c| c.1.iter().copied())
        .filter(|v| v.is_finite() && *v > 0.0);
    let (lo, hi) = finite.fold((target, target), |(lo, hi), v| (lo.min(v), hi.max(v)));
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(
            (1.0..max_n).log_scale(),
            ((lo / 1.5)..(hi * 1.5)).log_scale(),
        )
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc("monitor-model evaluations")
        .y_desc("median e_tot of the best so far [%]")
        .y_label_formatter(&|v| {
            if *v >= 0.01 {
                format!("{v:.2}")
            } else {
                format!("{v:.0e}")
            }
        })
        .x_label_formatter(&|v| format!("{v:.0}"))
        .draw()
        .map_err(e)?;
    let colours = [RED, BLUE, GREEN, MAGENTA];
    for (i, (name, curve)) in curves.iter().enumerate() {
        let colour = colours[i % colours.len()];
        // Thin out long curves: every point up to 1 000, then every 1 %.
        let points: Vec<(f64, f64)> = curve
            .iter()
            .enumerate()
            .filter(|(n, v)| v.is_finite() && (*n < 1000 || n % (curve.len() / 100).max(1) == 0))
            .map(|(n, &v)| ((n + 1) as f64, v))
            .collect();
        chart
            .draw_series(LineSeries::new(points, colour.stroke_width(2)))
            .map_err(e)?
            .label(*name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour));
    }
    chart
        .draw_series(DashedLineSeries::new(
            vec![(1.0, target), (max_n, target)],
            6,
            4,
            BLACK.into(),
        ))
        .map_err(e)?
        .label(format!("target e_tot = {target} %"))
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK));
    draw_legend(&mut chart, out, SeriesLabelPosition::UpperRight)?;
    root.present().map_err(e)?;
    Ok(())
}
