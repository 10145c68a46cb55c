//! The frame shared by the x–y charts ([`super::LineChart`],
//! [`super::BarChart`], [`super::Histogram`]): caption, axes, ticks and grid
//! ([`build_chart`]), the marker shapes and series styles, and the legend
//! with its automatic placement in a corner free of data
//! ([`place_legend`]). Part of [`crate::analysis::plot`].

use super::axis::{Axis, AxisCoord};
use super::{
    fit_text, font, plot_err, PlotError, AXIS_DESC_PX, LEGEND_PX, LINE_WIDTH, MARKER_RADIUS,
    TICK_PX, TITLE_PX,
};
use plotters::coord::Shift;
use plotters::prelude::*;

/// Marker shapes, assigned per series in this order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Marker {
    Circle,
    Square,
    TriangleUp,
    Diamond,
    TriangleDown,
}

/// The markers in the order the series get them (cycling).
pub(super) const MARKERS: [Marker; 5] = [
    Marker::Circle,
    Marker::Square,
    Marker::TriangleUp,
    Marker::Diamond,
    Marker::TriangleDown,
];

/// Vertices of a marker centred on (0, 0), in pixels (y down). Every shape
/// is a polygon so all markers share one element type.
pub(super) fn marker_polygon(m: Marker, r: i32) -> Vec<(i32, i32)> {
    let rf = f64::from(r);
    let ring = |n: usize, start_deg: f64, scale: f64| -> Vec<(i32, i32)> {
        (0..n)
            .map(|i| {
                let a = (start_deg + 360.0 * i as f64 / n as f64).to_radians();
                (
                    (scale * rf * a.cos()).round() as i32,
                    (scale * rf * a.sin()).round() as i32,
                )
            })
            .collect()
    };
    match m {
        Marker::Circle => ring(20, 0.0, 1.0),
        Marker::Square => vec![
            (-r + 1, -r + 1),
            (r - 1, -r + 1),
            (r - 1, r - 1),
            (-r + 1, r - 1),
        ],
        Marker::TriangleUp => ring(3, -90.0, 1.2),
        Marker::TriangleDown => ring(3, 90.0, 1.2),
        Marker::Diamond => ring(4, -90.0, 1.15),
    }
}

/// How a series is drawn.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SeriesStyle {
    /// A solid line through the points.
    Line,
    /// Markers only (scatter).
    Points,
    /// A solid line with a marker at each point.
    #[default]
    LinePoints,
    /// A dashed line without markers, for reference or theoretical data
    /// (an O(n log n) curve, a published result).
    Dashed,
}

/// The parts of a series' legend glyph, in pixels relative to the legend
/// entry: three line segments (contiguous for a solid line, with gaps for a
/// dashed one) and the marker polygon. Invisible parts get a transparent
/// style, so every style builds the same element type.
pub(super) struct LegendGlyph {
    pub(super) segments: [Vec<(i32, i32)>; 3],
    pub(super) line: ShapeStyle,
    pub(super) marker: Vec<(i32, i32)>,
    pub(super) marker_style: ShapeStyle,
}

impl LegendGlyph {
    pub(super) fn new(style: SeriesStyle, marker: Marker, colour: RGBColor) -> Self {
        let seg = |a: i32, b: i32| vec![(a, 0), (b, 0)];
        let segments = match style {
            SeriesStyle::Dashed => [seg(0, 11), seg(17, 28), seg(34, 44)],
            _ => [seg(0, 15), seg(15, 30), seg(30, 44)],
        };
        let line = match style {
            SeriesStyle::Points => TRANSPARENT.stroke_width(1),
            _ => colour.stroke_width(LINE_WIDTH),
        };
        let (marker, marker_style) = match style {
            SeriesStyle::Points | SeriesStyle::LinePoints => {
                (marker_polygon(marker, MARKER_RADIUS), colour.filled())
            }
            _ => (vec![(0, 0), (1, 0), (0, 1)], TRANSPARENT.filled()),
        };
        let marker = marker.into_iter().map(|(x, y)| (x + 22, y)).collect();
        Self {
            segments,
            line,
            marker,
            marker_style,
        }
    }
}

/// Where the legend box goes inside the plot (named in kebab case in
/// experiment manifests and their `meta.json`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum LegendPosition {
    /// The first corner (upper right, upper left, lower right, lower left)
    /// where the box covers no data; if every corner has data, the y axis
    /// is extended upwards to make room in the upper right.
    #[default]
    Auto,
    /// Top left corner of the plot area.
    UpperLeft,
    /// Top right corner of the plot area.
    UpperRight,
    /// Bottom left corner of the plot area.
    LowerLeft,
    /// Bottom right corner of the plot area.
    LowerRight,
    /// No legend.
    Hidden,
}

/// Draw the legend box of `chart` at `position` (nothing when hidden).
pub(super) fn draw_legend<'a, DB: DrawingBackend + 'a>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<AxisCoord, AxisCoord>>,
    position: LegendPosition,
) -> Result<(), PlotError> {
    let pos = match position {
        LegendPosition::UpperLeft => SeriesLabelPosition::UpperLeft,
        LegendPosition::UpperRight => SeriesLabelPosition::UpperRight,
        LegendPosition::LowerLeft => SeriesLabelPosition::LowerLeft,
        LegendPosition::LowerRight => SeriesLabelPosition::LowerRight,
        // `place_legend` resolves Auto before drawing.
        LegendPosition::Hidden | LegendPosition::Auto => return Ok(()),
    };
    chart
        .configure_series_labels()
        .position(pos)
        .margin(16)
        .legend_area_size(56)
        .label_font(font(LEGEND_PX))
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(120, 120, 120))
        .draw()
        .map_err(plot_err)
}

/// A plotters chart on our axes.
pub(super) type Chart2d<'a, DB> = ChartContext<'a, DB, Cartesian2d<AxisCoord, AxisCoord>>;

/// The x axis's tick labels: their text and size.
pub(super) struct XTicks<'f> {
    /// The label of a tick at a plot-space x.
    pub format: &'f dyn Fn(&f64) -> String,
    /// Text size in pixels.
    pub px: f64,
}

/// Margin around a chart and the room of its axis labels, in pixels.
const MARGIN: u32 = 28;
const X_LABEL_AREA: u32 = 96;
const Y_LABEL_AREA: u32 = 150;

/// Width in pixels of the plot area [`build_chart`] leaves on a canvas
/// `width` wide.
pub(super) fn plot_width(width: u32) -> f64 {
    (f64::from(width) - f64::from(2 * MARGIN + Y_LABEL_AREA)).max(1.0)
}

/// The common frame of every x–y chart: caption, axes, ticks, grid.
pub(super) fn build_chart<'a, DB: DrawingBackend>(
    root: &'a DrawingArea<DB, Shift>,
    title: &str,
    x: &Axis,
    y: &Axis,
    x_label: &str,
    y_label: &str,
    x_ticks: XTicks<'_>,
) -> Result<Chart2d<'a, DB>, PlotError> {
    let (width, _) = root.dim_in_pixel();
    let title_px = fit_text(
        "title",
        title,
        TITLE_PX,
        f64::from(width.saturating_sub(2 * MARGIN)),
    )?;
    let mut chart = ChartBuilder::on(root)
        .caption(title, font(title_px))
        .margin(MARGIN)
        .x_label_area_size(X_LABEL_AREA)
        .y_label_area_size(Y_LABEL_AREA)
        .build_cartesian_2d(x.coord(), y.coord())
        .map_err(plot_err)?;
    // Axis labels run along the plot area (the y label turned upright);
    // both get the size the longer one needs, so they match.
    let (plot_w, plot_h) = chart.plotting_area().dim_in_pixel();
    let desc_px = fit_text("x axis label", x_label, AXIS_DESC_PX, f64::from(plot_w))?.min(
        fit_text("y axis label", y_label, AXIS_DESC_PX, f64::from(plot_h))?,
    );
    let y_fmt = |u: &f64| y.label(*u);
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(y_label)
        .label_style(font(TICK_PX))
        .x_label_style(font(x_ticks.px))
        .axis_desc_style(font(desc_px))
        .x_label_formatter(x_ticks.format)
        .y_label_formatter(&y_fmt)
        .bold_line_style(RGBColor(205, 205, 205).stroke_width(1))
        .light_line_style(RGBColor(238, 238, 238).stroke_width(1))
        .axis_style(BLACK.stroke_width(2))
        .set_all_tick_mark_size(8)
        .draw()
        .map_err(plot_err)?;
    Ok(chart)
}

/// Choose the legend corner for `LegendPosition::Auto`.
///
/// `occupied` holds samples of where the data is drawn, as fractions of the
/// plot area (x right, y up). The legend box size is estimated from the
/// labels (DejaVu Sans averages about 0.6 em per character). Returns the
/// corner and, when no corner is free, the fraction of the plot height to
/// add above the data for the legend (0 otherwise).
pub(super) fn place_legend(
    requested: LegendPosition,
    labels: &[&str],
    occupied: &[(f64, f64)],
    size: (u32, u32),
) -> (LegendPosition, f64) {
    if labels.is_empty() {
        return (LegendPosition::Hidden, 0.0);
    }
    if requested != LegendPosition::Auto {
        return (requested, 0.0);
    }
    // Plot area of `build_chart`: canvas less margins, label areas, caption.
    let plot_w = plot_width(size.0);
    let plot_h =
        (f64::from(size.1) - f64::from(2 * MARGIN + X_LABEL_AREA) - 1.5 * TITLE_PX).max(1.0);
    let chars = labels.iter().map(|l| l.chars().count()).max().unwrap_or(0) as f64;
    // Box plus its 16 px margin from the plot edge, plus 12 px of air.
    let box_w = (56.0 + 0.6 * LEGEND_PX * chars + 40.0 + 28.0) / plot_w;
    let box_h = (labels.len() as f64 * (LEGEND_PX + 8.0) + 30.0 + 28.0) / plot_h;
    let corners = [
        (
            LegendPosition::UpperRight,
            (1.0 - box_w, 1.0),
            (1.0 - box_h, 1.0),
        ),
        (LegendPosition::UpperLeft, (0.0, box_w), (1.0 - box_h, 1.0)),
        (LegendPosition::LowerRight, (1.0 - box_w, 1.0), (0.0, box_h)),
        (LegendPosition::LowerLeft, (0.0, box_w), (0.0, box_h)),
    ];
    for (pos, (x0, x1), (y0, y1)) in corners {
        let hit = occupied
            .iter()
            .any(|&(x, y)| x >= x0 && x <= x1 && y >= y0 && y <= y1);
        if !hit {
            return (pos, 0.0);
        }
    }
    // No free corner: make one, unless the legend is taller than half the
    // plot (then extending the axis would squash the data; overlap instead).
    if box_h < 0.5 {
        (LegendPosition::UpperRight, box_h)
    } else {
        (LegendPosition::UpperRight, 0.0)
    }
}

/// Samples along a polyline (plot space) as plot-area fractions, for
/// [`place_legend`].
pub(super) fn sample_polyline(x: &Axis, y: &Axis, pts: &[(f64, f64)], out: &mut Vec<(f64, f64)>) {
    let frac = |p: (f64, f64)| (x.fraction(p.0), y.fraction(p.1));
    if let [only] = pts {
        out.push(frac(*only));
    }
    for w in pts.windows(2) {
        let (a, b) = (frac(w[0]), frac(w[1]));
        // 32 samples per segment: finer than any legend box is narrow.
        for i in 0..=32 {
            let t = f64::from(i) / 32.0;
            out.push((a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1)));
        }
    }
}
