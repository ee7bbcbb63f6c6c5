//! The Bode pair of a CLFRT report: the measured gain [dB] and phase [deg] at the tones with
//! their 90 % intervals, over the nominal ship's response and the ships at the networks' raw estimate and at the
//! estimate calibrated to the vessel.
//!
//! Ship response `G(j w) = b / (j w (j w + a))`: `|G| = b / (w sqrt(w^2 + a^2))`, `arg G =
//! -pi/2 - atan(w / a)` (continuous in (-pi, -pi/2)).

use super::style::{
    draw_err, legend, legend_line, legend_square, log_grid, padded, tick, Area, Estimated,
    CALIBRATED, ESTIMATED, FONT, MEASURED, NOMINAL, POINT_PX,
};
use super::PlotError;
use helmwatch_core::wire::features::ToneFeatures;
use plotters::prelude::*;

/// `|G(j w)|` and `arg G(j w)` [rad] of the Nomoto ship `(a, b)`.
pub(super) fn response(w: f64, (a, b): (f64, f64)) -> (f64, f64) {
    (
        b / (w * (w * w + a * a).sqrt()),
        -std::f64::consts::FRAC_PI_2 - (w / a).atan(),
    )
}

fn db(gain: f64) -> f64 {
    20.0 * gain.log10()
}

/// A ship drawn as a line: (legend, `(a, b)`, colour).
type Model = (&'static str, (f64, f64), RGBColor);

/// What both panels of the pair draw.
struct Bode<'a> {
    /// The frequency axis [rad/s].
    lo: f64,
    hi: f64,
    /// Frequencies of the ships' lines.
    grid: Vec<f64>,
    models: Vec<Model>,
    tones: &'a [ToneFeatures],
}

/// A tone's relative 90 % interval of the gain, as drawn.
fn rel(t: &ToneFeatures) -> f64 {
    t.gain_ci90_rel.clamp(0.0, 0.99)
}

/// CLFRT: the Bode pair.
pub(super) fn bode(
    svg: &mut String,
    size: (u32, u32),
    title: &str,
    tones: &[ToneFeatures],
    nominal: (f64, f64),
    estimated: &Estimated,
) -> Result<(), PlotError> {
    let root = SVGBackend::with_string(svg, size).into_drawing_area();
    root.fill(&WHITE).map_err(draw_err)?;
    let w_min = tones.iter().map(|t| t.omega_rad_s).fold(f64::MAX, f64::min);
    let w_max = tones.iter().map(|t| t.omega_rad_s).fold(0.0, f64::max);
    let (lo, hi) = (w_min / 4.0, w_max * 4.0);
    let grid = log_grid(lo, hi, 200);
    let mut models = vec![("nominal ship", nominal, NOMINAL)];
    if let Some(e) = estimated.raw {
        models.push(("networks' estimate (raw)", e, ESTIMATED));
    }
    if let Some(e) = estimated.calibrated {
        models.push(("calibrated to the vessel", e, CALIBRATED));
    }
    let b = Bode {
        lo,
        hi,
        grid,
        models,
        tones,
    };
    let (g_range, p_range) = ranges(&b);
    let (upper, lower) = root.split_vertically(size.1 / 2);
    draw_panel(&upper, 0, title, g_range, &b)?;
    draw_panel(&lower, 1, title, p_range, &b)?;
    root.present().map_err(draw_err)
}

/// The gain [dB] and phase [deg] axes: every line and every interval, padded.
fn ranges(b: &Bode) -> ((f64, f64), (f64, f64)) {
    let (grid, models, tones) = (&b.grid, &b.models, b.tones);
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
    (g_range, p_range)
}

/// One panel: 0 the gain (with the title), 1 the phase.
fn draw_panel(
    area: &Area,
    panel: usize,
    title: &str,
    y_range: (f64, f64),
    b: &Bode,
) -> Result<(), PlotError> {
    let (lo, hi) = (b.lo, b.hi);
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
    for (name, ab, color) in &b.models {
        let (name, ab, color) = (*name, *ab, *color);
        chart
            .draw_series(LineSeries::new(
                b.grid.iter().map(|&w| (w, value(w, ab))),
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
    let measured = |t: &ToneFeatures| measured(t, panel);
    chart
        .draw_series(b.tones.iter().map(|t| {
            let (_, l, h) = measured(t);
            PathElement::new(
                vec![(t.omega_rad_s, l), (t.omega_rad_s, h)],
                MEASURED.stroke_width(2),
            )
        }))
        .map_err(draw_err)?;
    chart
        .draw_series(
            b.tones
                .iter()
                .map(|t| Circle::new((t.omega_rad_s, measured(t).0), POINT_PX, MEASURED.filled())),
        )
        .map_err(draw_err)?
        .label("measured at the tones, 90 % interval")
        .legend(legend_square(MEASURED));
    legend(&mut chart, SeriesLabelPosition::LowerLeft)
}

/// A tone's measured value and its 90 % interval `(value, low, high)` in panel `panel`'s
/// unit (0: gain [dB], 1: phase [deg]).
fn measured(t: &ToneFeatures, panel: usize) -> (f64, f64, f64) {
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
}
