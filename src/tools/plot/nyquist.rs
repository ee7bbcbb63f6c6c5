//! The Nyquist plane of an HBT report: the loop the relay sees (servo describing function
//! times ship), the ship alone, the relay's `-1/N(A)` locus, the measured limit cycle and
//! response, the describing function's predictions.
//!
//! Relay with hysteresis, height `h`, hysteresis `eps`: `N(A) = 4h / (pi A) e^{-i
//! asin(eps/A)}`, so `-1/N(A) = -(pi / 4h) (sqrt(A^2 - eps^2) + i eps)`: a horizontal
//! half-line at `Im = -pi eps / 4h`, `A >= eps`.

use super::bode::response;
use super::style::{
    draw_err, legend, legend_line, legend_square, log_grid, padded, tick, Estimated, CALIBRATED,
    ESTIMATED, FONT, MEASURED, NOMINAL, POINT_PX,
};
use super::PlotError;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

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
    pub estimated: Estimated,
}

/// A ship drawn: (legend, `(a, b)`, colour, the describing function's `(omega_u, A)`).
type Model = (&'static str, (f64, f64), RGBColor, Option<(f64, f64)>);

/// The plane's chart.
type Plane<'a> = ChartContext<'a, SVGBackend<'a>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// A point of the plane from `(|G|, arg G)`.
fn polar((g, p): (f64, f64)) -> (f64, f64) {
    (g * p.cos(), g * p.sin())
}

/// The loop the relay sees: servo (describing function) times ship, at `w` for the ship
/// `ab` (`None` where the servo's describing function is undefined).
fn looped(n: &NyquistInput, w: f64, ab: (f64, f64)) -> Option<(f64, f64)> {
    use helmwatch_core::dsp::relay::servo_describing_function;
    use rustfft::num_complex::Complex64;
    let s = servo_describing_function(n.relay.height_rad, w, &n.servo).ok()?;
    let g = Complex64::from_polar(response(w, ab).0, response(w, ab).1) * s;
    Some((g.re, g.im))
}

/// HBT: the Nyquist plane with the relay's locus.
pub(super) fn nyquist(
    svg: &mut String,
    size: (u32, u32),
    title: &str,
    n: &NyquistInput,
) -> Result<(), PlotError> {
    let root = SVGBackend::with_string(svg, size).into_drawing_area();
    root.fill(&WHITE).map_err(draw_err)?;
    let measured = n.relay.minus_inverse_df(n.amplitude_rad);
    // Each ship with the describing function's `(omega_u, A)` for it.
    let predict = |ab: (f64, f64)| {
        helmwatch_core::dsp::relay::limit_cycle_describing_function(
            ab.0,
            ab.1,
            n.relay.height_rad,
            n.relay.hysteresis_rad,
            &n.servo,
        )
        .ok()
    };
    let mut models = vec![("nominal ship", n.nominal, NOMINAL, predict(n.nominal))];
    if let Some(e) = n.estimated.raw {
        models.push(("networks' estimate (raw)", e, ESTIMATED, predict(e)));
    }
    if let Some(e) = n.estimated.calibrated {
        models.push(("calibrated to the vessel", e, CALIBRATED, predict(e)));
    }
    let frame = frame(n, &models, measured);
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
    draw_ships(&mut chart, n, &models, &inside)?;
    draw_locus(&mut chart, n, &inside)?;
    draw_measured(&mut chart, n, &models, measured)?;
    legend(&mut chart, SeriesLabelPosition::LowerRight)?;
    root.present().map_err(draw_err)
}

/// The points the frame must hold: the curves near omega_u, the locus up to twice the
/// amplitude, every marker.
fn frame(n: &NyquistInput, models: &[Model], measured: (f64, f64)) -> Vec<(f64, f64)> {
    let wu = n.omega_u_rad_s;
    let near = log_grid(wu / 1.6, wu * 1.6, 50);
    let mut frame: Vec<(f64, f64)> = models
        .iter()
        .flat_map(|m| {
            near.iter()
                .flat_map(move |&w| [Some(polar(response(w, m.1))), looped(n, w, m.1)])
                .flatten()
        })
        .collect();
    frame.push(measured);
    frame.push(n.relay.minus_inverse_df(2.0 * n.amplitude_rad));
    frame.push(n.relay.minus_inverse_df(n.relay.hysteresis_rad));
    frame.extend(n.response.map(polar));
    for m in models {
        frame.extend(m.3.map(|(_, a)| n.relay.minus_inverse_df(a)));
    }
    frame
}

/// Each ship's loop (solid) and the ship alone (dashed), inside the frame.
fn draw_ships(
    chart: &mut Plane,
    n: &NyquistInput,
    models: &[Model],
    inside: &impl Fn(&(f64, f64)) -> bool,
) -> Result<(), PlotError> {
    let wu = n.omega_u_rad_s;
    let wide = log_grid(wu / 20.0, wu * 20.0, 600);
    for (name, ab, color, _) in models {
        let (ab, color) = (*ab, *color);
        chart
            .draw_series(LineSeries::new(
                wide.iter()
                    .filter_map(|&w| looped(n, w, ab))
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
    Ok(())
}

/// The relay's `-1/N(A)` locus, inside the frame.
fn draw_locus(
    chart: &mut Plane,
    n: &NyquistInput,
    inside: &impl Fn(&(f64, f64)) -> bool,
) -> Result<(), PlotError> {
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
    Ok(())
}

/// The markers: each ship's predicted limit cycle (triangles), the measured response (a
/// cross) and the measured limit cycle on the locus (a circle).
fn draw_measured(
    chart: &mut Plane,
    n: &NyquistInput,
    models: &[Model],
    measured: (f64, f64),
) -> Result<(), PlotError> {
    for (name, _, color, predicted) in models {
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
            2.0 * std::f64::consts::PI / n.omega_u_rad_s,
            n.amplitude_rad.to_degrees()
        ))
        .legend(legend_square(MEASURED));
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

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
