//! What every chart of `helmwatch plot` shares: the font, the colours, the tick labels, the
//! axes' ranges and the legends.

use super::PlotError;
use plotters::coord::Shift;
use plotters::prelude::*;

/// A drawing area of an SVG.
pub(super) type Area<'a> = DrawingArea<SVGBackend<'a>, Shift>;
/// A named line series: (legend, points, colour).
pub(super) type Series<'a> = (&'a str, &'a [(f64, f64)], RGBColor);

/// A plotters error as the plot's.
pub(super) fn draw_err<E: std::fmt::Display>(e: E) -> PlotError {
    PlotError::Draw(e.to_string())
}

pub(super) const FONT: &str = "sans-serif";
pub(super) const NOMINAL: RGBColor = BLUE;
/// The ships drawn beside the nominal one, as Nomoto `(a, b)`: at the networks' raw estimate
/// (the report's `estimate`) and at the estimate calibrated to the vessel
/// (`calibrated_estimate`).
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Estimated {
    pub raw: Option<(f64, f64)>,
    pub calibrated: Option<(f64, f64)>,
}

/// The networks' raw estimate.
pub(super) const ESTIMATED: RGBColor = RED;
/// The estimate calibrated to the vessel (green, darker than plotters' GREEN to read on white).
pub(super) const CALIBRATED: RGBColor = RGBColor(0, 150, 0);
pub(super) const MEASURED: RGBColor = BLACK;
/// Radius of a measured point's circle [px].
pub(super) const POINT_PX: i32 = 4;

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

/// `n` frequencies spaced evenly on a log scale over `[lo, hi]`.
pub(super) fn log_grid(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| lo * (hi / lo).powf(i as f64 / (n - 1) as f64))
        .collect()
}

/// Range of `values` padded by `pad` of its span (at least `min_span`).
pub(super) fn padded(values: impl Iterator<Item = f64>, pad: f64, min_span: f64) -> (f64, f64) {
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

/// A short line (legends of line series).
pub(super) fn legend_line(color: RGBColor) -> impl Fn((i32, i32)) -> PathElement<(i32, i32)> {
    move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
}

/// Draws a chart's series labels (one style for every chart).
pub(super) fn legend<'a, CT: CoordTranslate>(
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

/// A small square (legends of measured points: circles are kept for the data).
pub(super) fn legend_square(color: RGBColor) -> impl Fn((i32, i32)) -> Rectangle<(i32, i32)> {
    move |(x, y)| Rectangle::new([(x + 6, y - 3), (x + 12, y + 3)], color.filled())
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
}
