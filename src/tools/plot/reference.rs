//! The vessel's learned reference over speed (`helmwatch plot` of a vessel's state file,
//! `<state-dir>/vessels/<v>.json`): per method, the learned tests' raw residuals `e_u` [m/s]
//! and `e_D` [%] against their speed log (circles, one per learned test), the reference's
//! predicted offset over speed at the learned tests' mean declared displacement (a line) and
//! its band of two standard deviations of a test about it (dashed: the prediction's own
//! error, the scatter at the learned tests' mean sea and the floors;
//! `helmwatch_core::fdi::reference::MethodReference::curve`).

use super::style::{draw_err, tick};
use super::{data, PlotError};
use helmwatch_core::fdi::reference::{MethodReference, Settings};
use helmwatch_core::wire::Method;
use plotters::prelude::*;

/// Speeds on the curve.
const GRID: usize = 60;

/// Draws both methods' references (`learned[0]` CLFRT, `learned[1]` HBT).
pub(super) fn reference(
    svg: &mut String,
    size: (u32, u32),
    title: &str,
    learned: &[MethodReference; 2],
    s: &Settings,
) -> Result<(), PlotError> {
    if learned.iter().all(|c| c.samples.is_empty()) {
        return Err(data(
            "no learned test in the state (commissioning has not begun)",
        ));
    }
    let root = SVGBackend::with_string(svg, size).into_drawing_area();
    root.fill(&WHITE).map_err(draw_err)?;
    let root = root.titled(title, ("sans-serif", 20)).map_err(draw_err)?;
    let speeds: Vec<f64> = learned
        .iter()
        .flat_map(|c| c.samples.iter().map(|x| x.speed_mps))
        .collect();
    let lo = speeds.iter().copied().fold(f64::INFINITY, f64::min) - 1.5;
    let hi = speeds.iter().copied().fold(f64::NEG_INFINITY, f64::max) + 1.5;
    let grid: Vec<f64> = (0..=GRID)
        .map(|i| lo + (hi - lo) * i as f64 / GRID as f64)
        .collect();
    let panels = root.split_evenly((2, 2));
    for (row, (m, c)) in [Method::Clfrt, Method::Hbt].iter().zip(learned).enumerate() {
        let n = c.samples.len().max(1) as f64;
        let d = (c.samples.iter().map(|x| x.displacement_t.ln()).sum::<f64>() / n).exp();
        let curve = c.curve(s, &grid, d);
        for col in 0..2 {
            let scale = if col == 0 { 1.0 } else { 100.0 };
            let points: Vec<(f64, f64)> = c
                .samples
                .iter()
                .map(|x| (x.speed_mps, x.e[col] * scale))
                .collect();
            let line: Vec<(f64, f64)> =
                curve.iter().map(|(u, o, _)| (*u, o[col] * scale)).collect();
            let band = |sign: f64| -> Vec<(f64, f64)> {
                curve
                    .iter()
                    .map(|(u, o, sd)| (*u, (o[col] + sign * 2.0 * sd[col]) * scale))
                    .collect()
            };
            let (upper, lower) = (band(1.0), band(-1.0));
            let ys = points.iter().chain(&line).map(|p| p.1).chain(
                upper
                    .iter()
                    .chain(&lower)
                    .map(|p| p.1)
                    .filter(|v| v.is_finite()),
            );
            let (ymin, ymax) = ys.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(v), b.max(v))
            });
            let pad = ((ymax - ymin) * 0.08).max(1e-3);
            let (ymin, ymax) = if ymin.is_finite() {
                (ymin - pad, ymax + pad)
            } else {
                (-1.0, 1.0)
            };
            let what = if col == 0 { "e_u [m/s]" } else { "e_D [%]" };
            let mut chart = ChartBuilder::on(&panels[row * 2 + col])
                .caption(
                    format!("{} {what}: {}", m.name().to_uppercase(), c.describe(s)),
                    ("sans-serif", 13),
                )
                .margin(10)
                .x_label_area_size(36)
                .y_label_area_size(60)
                .build_cartesian_2d(lo..hi, ymin..ymax)
                .map_err(draw_err)?;
            chart
                .configure_mesh()
                .x_desc("speed log [m/s]")
                .y_desc(what)
                .x_label_formatter(&tick)
                .y_label_formatter(&tick)
                .max_light_lines(4)
                .draw()
                .map_err(draw_err)?;
            let color = if *m == Method::Clfrt { BLUE } else { RED };
            if !line.is_empty() {
                chart
                    .draw_series(LineSeries::new(line, color.stroke_width(2)))
                    .map_err(draw_err)?;
                for b in [upper, lower] {
                    chart
                        .draw_series(DashedLineSeries::new(
                            b,
                            6,
                            4,
                            color.mix(0.6).stroke_width(1),
                        ))
                        .map_err(draw_err)?;
                }
            }
            chart
                .draw_series(points.iter().map(|&p| Circle::new(p, 4, BLACK.filled())))
                .map_err(draw_err)?;
        }
    }
    root.present().map_err(draw_err)
}
