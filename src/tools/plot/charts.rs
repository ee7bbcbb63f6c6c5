//! The charts of `helmwatch plot`, drawn with plotters on its SVG backend.
//!
//! Ship response `G(j w) = b / (j w (j w + a))`: `|G| = b / (w sqrt(w^2 + a^2))`, `arg G =
//! -pi/2 - atan(w / a)` (continuous in (-pi, -pi/2)). Relay with hysteresis, height `h`,
//! hysteresis `eps`: `N(A) = 4h / (pi A) e^{-i asin(eps/A)}`, so `-1/N(A) = -(pi / 4h)
//! (sqrt(A^2 - eps^2) + i eps)`: a horizontal half-line at `Im = -pi eps / 4h`, `A >= eps`.

use super::recording::{decimate, Trace};
use super::{HistoryPoint, PlotError};
use helmwatch_core::wire::features::ToneFeatures;
use helmwatch_core::wire::Method;
use plotters::coord::Shift;
use plotters::prelude::*;

type Area<'a> = DrawingArea<SVGBackend<'a>, Shift>;
/// A named line series: (legend, points, colour).
type Series<'a> = (&'a str, &'a [(f64, f64)], RGBColor);

fn draw_err<E: std::fmt::Display>(e: E) -> PlotError {
    PlotError::Draw(e.to_string())
}

const FONT: &str = "sans-serif";
const NOMINAL: RGBColor = BLUE;
const ESTIMATED: RGBColor = RED;
const MEASURED: RGBColor = BLACK;
/// Radius of a measured point's circle [px].
const POINT_PX: i32 = 4;

/// A tick label: short, and parsed back exactly by `str::parse::<f64>` (tests read the axes
/// back from the SVG).
pub(super) fn tick(v: &f64) -> String {
    let v = *v;
    // An axis's zero computed as a sum of steps comes out as 1e-16 or so.
    if v.abs() < 1e-12 {
        return "0".into();
    }
    if v.abs() >= 1e5 || v.abs() < 1e-3 {
        return format!("{v:e}");
    }
    let s = format!("{v:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    s.to_string()
}

/// `|G(j w)|` and `arg G(j w)` [rad] of the Nomoto ship `(a, b)`.
fn response(w: f64, (a, b): (f64, f64)) -> (f64, f64) {
    (
        b / (w * (w * w + a * a).sqrt()),
        -std::f64::consts::FRAC_PI_2 - (w / a).atan(),
    )
}

fn db(gain: f64) -> f64 {
    20.0 * gain.log10()
}

/// `n` frequencies spaced evenly on a log scale over `[lo, hi]`.
fn log_grid(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| lo * (hi / lo).powf(i as f64 / (n - 1) as f64))
        .collect()
}

/// Range of `values` padded by `pad` of its span (at least `min_span`).
fn padded(values: impl Iterator<Item = f64>, pad: f64, min_span: f64) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
            (l.min(v), h.max(v))
        });
    if !lo.is_finite() {
        return (-1.0, 1.0);
    }
    let span = (hi - lo).max(min_span);
    let mid = 0.5 * (lo + hi);
    (mid - span * (0.5 + pad), mid + span * (0.5 + pad))
}

fn legend_line(color: RGBColor) -> impl Fn((i32, i32)) -> PathElement<(i32, i32)> {
    move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
}

/// A small square (legends of measured points: circles are kept for the data).
/// Draws a chart's series labels (one style for every chart).
fn legend<'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, SVGBackend<'a>, CT>,
    position: SeriesLabelPosition,
) -> Result<(), PlotError> {
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(position)
        .label_font((FONT, 13))
        .draw()
        .map_err(draw_err)
}

fn legend_square(color: RGBColor) -> impl Fn((i32, i32)) -> Rectangle<(i32, i32)> {
    move |(x, y)| Rectangle::new([(x + 6, y - 3), (x + 12, y + 3)], color.filled())
}

/// CLFRT: the Bode pair.
pub(super) fn bode(
    svg: &mut String,
    size: (u32, u32),
    title: &str,
    tones: &[ToneFeatures],
    nominal: (f64, f64),
    estimated: Option<(f64, f64)>,
) -> Result<(), PlotError> {
    let root = SVGBackend::with_string(svg, size).into_drawing_area();
    root.fill(&WHITE).map_err(draw_err)?;
    let w_min = tones.iter().map(|t| t.omega_rad_s).fold(f64::MAX, f64::min);
    let w_max = tones.iter().map(|t| t.omega_rad_s).fold(0.0, f64::max);
    let (lo, hi) = (w_min / 4.0, w_max * 4.0);
    let grid = log_grid(lo, hi, 200);
    let mut models = vec![("nominal ship", nominal, NOMINAL)];
    if let Some(e) = estimated {
        models.push(("estimated ship", e, ESTIMATED));
    }
    let rel = |t: &ToneFeatures| t.gain_ci90_rel.clamp(0.0, 0.99);
    let gains = models
        .iter()
        .flat_map(|m| grid.iter().map(|&w| db(response(w, m.1).0)))
        .chain(tones.iter().map(|t| db(t.gain * (1.0 + rel(t)))))
        .chain(tones.iter().map(|t| db(t.gain * (1.0 - rel(t)))))
        .collect::<Vec<_>>();
    let phases = models
        .iter()
        .flat_map(|m| grid.iter().map(|&w| response(w, m.1).1.to_degrees()))
        .chain(
            tones
                .iter()
                .map(|t| (t.phase_rad + t.phase_ci90_rad).to_degrees()),
        )
        .chain(
            tones
                .iter()
                .map(|t| (t.phase_rad - t.phase_ci90_rad).to_degrees()),
        )
        .collect::<Vec<_>>();
    let g_range = padded(gains.into_iter(), 0.05, 6.0);
    let p_range = padded(phases.into_iter(), 0.05, 20.0);

    let (upper, lower) = root.split_vertically(size.1 / 2);
    for (panel, area) in [(0, &upper), (1, &lower)] {
        let y_range = if panel == 0 { g_range } else { p_range };
        let mut chart = ChartBuilder::on(area)
            .caption(
                if panel == 0 {
                    title.to_string()
                } else {
                    String::new()
                },
                (FONT, 20),
            )
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d((lo..hi).log_scale(), y_range.0..y_range.1)
            .map_err(draw_err)?;
        chart
            .configure_mesh()
            .x_desc("frequency [rad/s]")
            .y_desc(if panel == 0 {
                "gain [dB]"
            } else {
                "phase [deg]"
            })
            .x_label_formatter(&tick)
            .y_label_formatter(&tick)
            .max_light_lines(4)
            .draw()
            .map_err(draw_err)?;
        let value = |w: f64, ab: (f64, f64)| {
            let (g, p) = response(w, ab);
            if panel == 0 {
                db(g)
            } else {
                p.to_degrees()
            }
        };
        for (name, ab, color) in &models {
            let (name, ab, color) = (*name, *ab, *color);
            chart
                .draw_series(LineSeries::new(
                    grid.iter().map(|&w| (w, value(w, ab))),
                    color.stroke_width(2),
                ))
                .map_err(draw_err)?
                .label(format!(
                    "{name}: a = {:.4} 1/s, b = {:.3e} 1/s^2",
                    ab.0, ab.1
                ))
                .legend(legend_line(color));
        }
        // The tones: a circle at the measured value, a vertical bar over the 90 % interval.
        let measured = |t: &ToneFeatures| -> (f64, f64, f64) {
            if panel == 0 {
                (
                    db(t.gain),
                    db(t.gain * (1.0 - rel(t))),
                    db(t.gain * (1.0 + rel(t))),
                )
            } else {
                (
                    t.phase_rad.to_degrees(),
                    (t.phase_rad - t.phase_ci90_rad).to_degrees(),
                    (t.phase_rad + t.phase_ci90_rad).to_degrees(),
                )
            }
        };
        chart
            .draw_series(tones.iter().map(|t| {
                let (_, l, h) = measured(t);
                PathElement::new(
                    vec![(t.omega_rad_s, l), (t.omega_rad_s, h)],
                    MEASURED.stroke_width(2),
                )
            }))
            .map_err(draw_err)?;
        chart
            .draw_series(
                tones.iter().map(|t| {
                    Circle::new((t.omega_rad_s, measured(t).0), POINT_PX, MEASURED.filled())
                }),
            )
            .map_err(draw_err)?
            .label("measured at the tones, 90 % interval")
            .legend(legend_square(MEASURED));
        legend(&mut chart, SeriesLabelPosition::LowerLeft)?;
    }
    root.present().map_err(draw_err)
}

/// The relay of an HBT test.
#[derive(Debug, Clone, Copy)]
pub(super) struct Relay {
    /// Height h [rad].
    pub height_rad: f64,
    /// Hysteresis eps [rad].
    pub hysteresis_rad: f64,
}

impl Relay {
    /// `-1/N(A)` for a heading amplitude `A >= eps` [rad] (module documentation).
    pub fn minus_inverse_df(&self, amplitude_rad: f64) -> (f64, f64) {
        let k = std::f64::consts::PI / (4.0 * self.height_rad);
        let eps = self.hysteresis_rad;
        (
            -k * (amplitude_rad * amplitude_rad - eps * eps).max(0.0).sqrt(),
            -k * eps,
        )
    }
}

/// What the Nyquist picture of an HBT report shows.
#[derive(Debug, Clone)]
pub(super) struct NyquistInput {
    pub relay: Relay,
    /// The servo (its describing function is in the loop).
    pub servo: helmwatch_core::model::ServoConfig,
    /// Measured limit-cycle frequency [rad/s].
    pub omega_u_rad_s: f64,
    /// Measured first-harmonic heading amplitude [rad].
    pub amplitude_rad: f64,
    /// Measured ship response at omega_u: `(|G|, arg G [rad])`.
    pub response: Option<(f64, f64)>,
    pub nominal: (f64, f64),
    pub estimated: Option<(f64, f64)>,
    /// The describing function's `(omega_u, A)` for the nominal and the estimated ship.
    pub predicted_nominal: Option<(f64, f64)>,
    pub predicted_estimated: Option<(f64, f64)>,
}

/// HBT: the Nyquist plane with the relay's locus.
pub(super) fn nyquist(
    svg: &mut String,
    size: (u32, u32),
    title: &str,
    n: &NyquistInput,
) -> Result<(), PlotError> {
    use helmwatch_core::dsp::relay::servo_describing_function;
    use rustfft::num_complex::Complex64;
    let root = SVGBackend::with_string(svg, size).into_drawing_area();
    root.fill(&WHITE).map_err(draw_err)?;
    let polar = |(g, p): (f64, f64)| (g * p.cos(), g * p.sin());
    // The loop the relay sees: servo (describing function) times ship.
    let looped = |w: f64, ab: (f64, f64)| -> Option<(f64, f64)> {
        let s = servo_describing_function(n.relay.height_rad, w, &n.servo).ok()?;
        let g = Complex64::from_polar(response(w, ab).0, response(w, ab).1) * s;
        Some((g.re, g.im))
    };
    let wu = n.omega_u_rad_s;
    let measured = n.relay.minus_inverse_df(n.amplitude_rad);
    let mut models = vec![("nominal ship", n.nominal, NOMINAL, n.predicted_nominal)];
    if let Some(e) = n.estimated {
        models.push(("estimated ship", e, ESTIMATED, n.predicted_estimated));
    }
    // The frame: the curves near omega_u, the locus up to twice the amplitude, every marker.
    let near = log_grid(wu / 1.6, wu * 1.6, 50);
    let mut frame: Vec<(f64, f64)> = models
        .iter()
        .flat_map(|m| {
            near.iter()
                .flat_map(move |&w| [Some(polar(response(w, m.1))), looped(w, m.1)])
                .flatten()
        })
        .collect();
    frame.push(measured);
    frame.push(n.relay.minus_inverse_df(2.0 * n.amplitude_rad));
    frame.push(n.relay.minus_inverse_df(n.relay.hysteresis_rad));
    frame.extend(n.response.map(polar));
    for m in &models {
        frame.extend(m.3.map(|(_, a)| n.relay.minus_inverse_df(a)));
    }
    let x_range = padded(frame.iter().map(|p| p.0), 0.08, 1e-6);
    let y_range = padded(frame.iter().map(|p| p.1), 0.08, 1e-6);
    let inside = |p: &(f64, f64)| {
        p.0 >= x_range.0 && p.0 <= x_range.1 && p.1 >= y_range.0 && p.1 <= y_range.1
    };
    let mut chart = ChartBuilder::on(&root)
        .caption(title, (FONT, 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(80)
        .build_cartesian_2d(x_range.0..x_range.1, y_range.0..y_range.1)
        .map_err(draw_err)?;
    chart
        .configure_mesh()
        .x_desc("Re")
        .y_desc("Im")
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .max_light_lines(4)
        .draw()
        .map_err(draw_err)?;
    let wide = log_grid(wu / 20.0, wu * 20.0, 600);
    for (name, ab, color, _) in &models {
        let (ab, color) = (*ab, *color);
        chart
            .draw_series(LineSeries::new(
                wide.iter()
                    .filter_map(|&w| looped(w, ab))
                    .filter(|p| inside(p)),
                color.stroke_width(2),
            ))
            .map_err(draw_err)?
            .label(format!("S(w) G(jw): servo and {name}"))
            .legend(legend_line(color));
        chart
            .draw_series(DashedLineSeries::new(
                wide.iter()
                    .map(|&w| polar(response(w, ab)))
                    .filter(|p| inside(p)),
                6,
                4,
                color.stroke_width(1),
            ))
            .map_err(draw_err)?
            .label(format!("G(jw): {name} alone (dashed)"))
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 8, y)], color.stroke_width(1))
            });
    }
    let eps = n.relay.hysteresis_rad;
    let locus: Vec<(f64, f64)> = (0..400)
        .map(|i| {
            n.relay
                .minus_inverse_df(eps + i as f64 * eps.max(1e-4) * 0.25)
        })
        .filter(|p| inside(p))
        .collect();
    chart
        .draw_series(LineSeries::new(locus, GREEN.stroke_width(2)))
        .map_err(draw_err)?
        .label(format!(
            "-1/N(A), relay h = {:.2} deg, eps = {:.2} deg",
            n.relay.height_rad.to_degrees(),
            eps.to_degrees()
        ))
        .legend(legend_line(GREEN));
    for (name, _, color, predicted) in &models {
        if let Some((w, a)) = predicted {
            let color = *color;
            chart
                .draw_series(std::iter::once(TriangleMarker::new(
                    n.relay.minus_inverse_df(*a),
                    7,
                    color.filled(),
                )))
                .map_err(draw_err)?
                .label(format!(
                    "predicted for the {name}: P = {:.0} s, A = {:.2} deg",
                    2.0 * std::f64::consts::PI / w,
                    a.to_degrees()
                ))
                .legend(move |(x, y)| TriangleMarker::new((x + 9, y), 5, color.filled()));
        }
    }
    if let Some(r) = n.response {
        chart
            .draw_series(std::iter::once(Cross::new(
                polar(r),
                6,
                MEASURED.stroke_width(2),
            )))
            .map_err(draw_err)?
            .label(format!(
                "measured response G(jw_u) = {:.3} at {:.1} deg",
                r.0,
                r.1.to_degrees()
            ))
            .legend(|(x, y)| Cross::new((x + 9, y), 4, MEASURED.stroke_width(2)));
    }
    chart
        .draw_series(std::iter::once(Circle::new(
            measured,
            POINT_PX,
            MEASURED.filled(),
        )))
        .map_err(draw_err)?
        .label(format!(
            "measured limit cycle: P = {:.0} s, A = {:.2} deg",
            2.0 * std::f64::consts::PI / wu,
            n.amplitude_rad.to_degrees()
        ))
        .legend(legend_square(MEASURED));
    legend(&mut chart, SeriesLabelPosition::LowerRight)?;
    root.present().map_err(draw_err)
}

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
    let mut top = ChartBuilder::on(&upper)
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
    legend(&mut top, SeriesLabelPosition::UpperLeft)?;

    let mut bottom = ChartBuilder::on(&lower)
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
    legend(&mut bottom, SeriesLabelPosition::UpperLeft)?;
    root.present().map_err(draw_err)
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels_parse_back() {
        for v in [0.0, 1.5, -20.0, 0.0125, 1e-4, 2.5e6, -180.0, 13.82] {
            let s = tick(&v);
            assert_eq!(s.parse::<f64>().unwrap(), v, "{s}");
        }
        assert_eq!(tick(&-20.0), "-20");
        assert_eq!(tick(&-1.1e-16), "0");
    }

    /// The relay's locus against the describing function's definition.
    #[test]
    fn minus_inverse_df_is_minus_one_over_n() {
        let relay = Relay {
            height_rad: 8f64.to_radians(),
            hysteresis_rad: 1f64.to_radians(),
        };
        let a = 3f64.to_radians();
        let (h, eps) = (relay.height_rad, relay.hysteresis_rad);
        let phi = (eps / a).asin();
        let n = (4.0 * h / (std::f64::consts::PI * a), -phi);
        // -1/N = -(1/|N|) e^{+i phi}.
        let want = (-phi.cos() / n.0, -phi.sin() / n.0);
        let got = relay.minus_inverse_df(a);
        assert!((got.0 - want.0).abs() < 1e-12 && (got.1 - want.1).abs() < 1e-12);
    }
}
