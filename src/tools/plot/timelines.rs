//! The charts against time: a report history (chi2 and the normalised residuals against
//! `t_end`) and a recording (heading, rudder and excitation).

use super::recording::{decimate, Trace};
use super::style::{
    draw_err, legend, legend_line, legend_square, padded, tick, Area, Series, FONT, POINT_PX,
};
use super::{HistoryPoint, PlotError};
use helmwatch_core::wire::Method;
use plotters::prelude::*;

fn method_color(m: Method) -> RGBColor {
    match m {
        Method::Clfrt => BLUE,
        Method::Hbt => RED,
    }
}

/// A report history: chi2 with the threshold above, the normalised residuals below.
pub(super) fn history(
    svg: &mut String,
    size: (u32, u32),
    title: &str,
    points: &[HistoryPoint],
    threshold: f64,
) -> Result<(), PlotError> {
    let root = SVGBackend::with_string(svg, size).into_drawing_area();
    root.fill(&WHITE).map_err(draw_err)?;
    let t_range = padded(points.iter().map(|p| p.t_end), 0.03, 1.0);
    let chi2_max = points
        .iter()
        .filter_map(|p| p.chi2)
        .fold(threshold, f64::max);
    let z_range = padded(
        points
            .iter()
            .flat_map(|p| [p.z_speed, p.z_disp, p.z_rate])
            .flatten()
            .chain([-1.0, 1.0]),
        0.05,
        2.0,
    );
    let (upper, lower) = root.split_vertically(size.1 / 2);
    draw_chi2(&upper, title, points, threshold, t_range, chi2_max)?;
    draw_residuals(&lower, points, t_range, z_range)?;
    root.present().map_err(draw_err)
}

/// The upper panel: each report's chi2 per method (circles) under the single-test limit.
fn draw_chi2(
    upper: &Area,
    title: &str,
    points: &[HistoryPoint],
    threshold: f64,
    t_range: (f64, f64),
    chi2_max: f64,
) -> Result<(), PlotError> {
    let mut top = ChartBuilder::on(upper)
        .caption(title, (FONT, 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(t_range.0..t_range.1, 0.0..chi2_max * 1.15)
        .map_err(draw_err)?;
    top.configure_mesh()
        .x_desc("t_end [s]")
        .y_desc("chi2")
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .max_light_lines(4)
        .draw()
        .map_err(draw_err)?;
    top.draw_series(DashedLineSeries::new(
        [(t_range.0, threshold), (t_range.1, threshold)],
        8,
        5,
        BLACK.stroke_width(1),
    ))
    .map_err(draw_err)?
    .label(format!("single-test limit = {}", tick(&threshold)))
    .legend(legend_line(BLACK));
    for m in [Method::Clfrt, Method::Hbt] {
        let color = method_color(m);
        let series: Vec<(f64, f64)> = points
            .iter()
            .filter(|p| p.method == m)
            .filter_map(|p| p.chi2.map(|c| (p.t_end, c)))
            .collect();
        if series.is_empty() {
            continue;
        }
        top.draw_series(LineSeries::new(series.clone(), color.mix(0.4)))
            .map_err(draw_err)?;
        top.draw_series(
            series
                .iter()
                .map(|&p| Circle::new(p, POINT_PX, color.filled())),
        )
        .map_err(draw_err)?
        .label(format!("chi2, {}", m.name()))
        .legend(legend_square(color));
    }
    legend(&mut top, SeriesLabelPosition::UpperLeft)
}

/// The lower panel: each report's normalised residuals `z_speed`, `z_disp`, `z_rate`.
fn draw_residuals(
    lower: &Area,
    points: &[HistoryPoint],
    t_range: (f64, f64),
    z_range: (f64, f64),
) -> Result<(), PlotError> {
    let mut bottom = ChartBuilder::on(lower)
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(t_range.0..t_range.1, z_range.0..z_range.1)
        .map_err(draw_err)?;
    bottom
        .configure_mesh()
        .x_desc("t_end [s]")
        .y_desc("normalised residual")
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .max_light_lines(4)
        .draw()
        .map_err(draw_err)?;
    let pick = |f: fn(&HistoryPoint) -> Option<f64>| -> Vec<(f64, f64)> {
        points
            .iter()
            .filter_map(|p| f(p).map(|v| (p.t_end, v)))
            .collect()
    };
    let (zs, zd, zr) = (pick(|p| p.z_speed), pick(|p| p.z_disp), pick(|p| p.z_rate));
    let c_speed = RGBColor(0, 140, 0);
    let c_disp = RGBColor(150, 0, 150);
    let c_rate = RGBColor(220, 120, 0);
    bottom
        .draw_series(
            zs.iter()
                .map(|&p| Cross::new(p, 5, c_speed.stroke_width(2))),
        )
        .map_err(draw_err)?
        .label("z_speed")
        .legend(move |(x, y)| Cross::new((x + 9, y), 4, c_speed.stroke_width(2)));
    bottom
        .draw_series(
            zd.iter()
                .map(|&p| TriangleMarker::new(p, 5, c_disp.filled())),
        )
        .map_err(draw_err)?
        .label("z_disp")
        .legend(move |(x, y)| TriangleMarker::new((x + 9, y), 4, c_disp.filled()));
    bottom
        .draw_series(zr.iter().map(|&(t, v)| {
            EmptyElement::at((t, v)) + Rectangle::new([(-3, -3), (3, 3)], c_rate.filled())
        }))
        .map_err(draw_err)?
        .label("z_rate (servo)")
        .legend(legend_square(c_rate));
    legend(&mut bottom, SeriesLabelPosition::UpperLeft)
}

/// A recording: heading above; rudder and excitation below [deg] against time.
pub(super) fn trace(svg: &mut String, size: (u32, u32), tr: &Trace) -> Result<(), PlotError> {
    let root = SVGBackend::with_string(svg, size).into_drawing_area();
    root.fill(&WHITE).map_err(draw_err)?;
    let deg = |v: &[(f64, f64)]| -> Vec<(f64, f64)> {
        decimate(v)
            .into_iter()
            .map(|(t, x)| (t, x.to_degrees()))
            .collect()
    };
    let (heading, rudder, excitation) = (deg(&tr.heading), deg(&tr.rudder), deg(&tr.excitation));
    let t_range = padded(
        heading
            .iter()
            .chain(&rudder)
            .chain(&excitation)
            .map(|p| p.0),
        0.0,
        1.0,
    );
    let h_range = padded(heading.iter().map(|p| p.1), 0.05, 1.0);
    let r_range = padded(rudder.iter().chain(&excitation).map(|p| p.1), 0.05, 1.0);
    let (upper, lower) = root.split_vertically(size.1 / 2);
    let panels: [(&Area, (f64, f64), &str); 2] = [
        (&upper, h_range, "heading [deg]"),
        (&lower, r_range, "rudder [deg]"),
    ];
    for (i, (area, y_range, y_desc)) in panels.into_iter().enumerate() {
        let mut chart = ChartBuilder::on(area)
            .caption(
                if i == 0 {
                    format!("{}: recording", tr.vessel)
                } else {
                    String::new()
                },
                (FONT, 20),
            )
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(t_range.0..t_range.1, y_range.0..y_range.1)
            .map_err(draw_err)?;
        chart
            .configure_mesh()
            .x_desc("t [s]")
            .y_desc(y_desc)
            .x_label_formatter(&tick)
            .y_label_formatter(&tick)
            .max_light_lines(4)
            .draw()
            .map_err(draw_err)?;
        let series: Vec<Series> = if i == 0 {
            vec![("heading (unwrapped)", &heading[..], BLUE)]
        } else {
            vec![
                ("rudder angle", &rudder[..], BLACK),
                ("excitation (0 when none)", &excitation[..], RED),
            ]
        };
        for (name, pts, color) in series {
            if pts.is_empty() {
                continue;
            }
            chart
                .draw_series(LineSeries::new(pts.iter().copied(), color.stroke_width(1)))
                .map_err(draw_err)?
                .label(name)
                .legend(legend_line(color));
        }
        legend(&mut chart, SeriesLabelPosition::UpperRight)?;
    }
    root.present().map_err(draw_err)
}
