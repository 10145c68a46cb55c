//! Line charts: one or more named series of (x, y) points on linear or log
//! axes, drawn as lines, markers, both, or dashed reference curves. Part of
//! [`crate::analysis::plot`]; the frame and legend come from [`super::chart`].

use super::axis::{to_plot, Axis, AxisScale};
use super::chart::{
    build_chart, draw_legend, marker_polygon, place_legend, sample_polyline, LegendGlyph,
    LegendPosition, SeriesStyle, XTicks, MARKERS,
};
use super::{
    check_figure, plot_err, rgb, save_figure, series_colour, Figure, PlotError, CHART_SIZE,
    LINE_WIDTH, MARKER_RADIUS, TICK_PX,
};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// One named curve of a [`LineChart`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Series {
    /// Legend text.
    pub label: String,
    /// (x, y) points, drawn in the given order; non-finite points (and
    /// points ≤ 0 on a log axis) are skipped.
    pub points: Vec<(f64, f64)>,
    /// Line, markers, both, or dashed.
    pub style: SeriesStyle,
    /// Error bars: (low, high) y values per point, in the order of
    /// `points`; empty for none. A bar whose ends cannot be drawn (NaN, ≤ 0
    /// on a log axis) or whose ends are equal is left out.
    pub errors: Vec<(f64, f64)>,
}

impl Series {
    /// A series with the given label, points and style.
    pub fn new(label: impl Into<String>, points: Vec<(f64, f64)>, style: SeriesStyle) -> Self {
        Self {
            label: label.into(),
            points,
            style,
            errors: Vec::new(),
        }
    }

    /// The same series with error bars, (low, high) per point.
    pub fn with_errors(mut self, errors: Vec<(f64, f64)>) -> Self {
        self.errors = errors;
        self
    }
}

/// An x–y chart of one or more series, on linear or log axes.
#[derive(Clone, Debug, PartialEq)]
pub struct LineChart {
    /// Caption above the plot.
    pub title: String,
    /// x axis description (include the unit).
    pub x_label: String,
    /// y axis description (include the unit).
    pub y_label: String,
    /// x axis scale.
    pub x_scale: AxisScale,
    /// y axis scale.
    pub y_scale: AxisScale,
    /// The curves, coloured and marked in order.
    pub series: Vec<Series>,
    /// Legend placement.
    pub legend: LegendPosition,
    /// Canvas size in pixels, [`CHART_SIZE`] by default.
    pub size: (u32, u32),
    /// The legend entry of the error bars (shown when any series has a
    /// bar of non-zero length), e.g. "bars: min to max of 5 repeats".
    pub error_label: String,
}

impl LineChart {
    /// An empty chart with linear axes; push series into `series`.
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
    ) -> Self {
        Self {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            x_scale: AxisScale::Linear,
            y_scale: AxisScale::Linear,
            series: Vec::new(),
            legend: LegendPosition::Auto,
            size: CHART_SIZE,
            error_label: "error bars".to_string(),
        }
    }

    /// Write `stem.png` and `stem.svg`. Fails (writing nothing) when a log
    /// axis has data but none of it is positive.
    pub fn save(&self, stem: &Path) -> Result<(), PlotError> {
        save_figure(self, stem).map_err(|e| PlotError::figure("line chart", &self.title, e))
    }

    /// Draw the chart in memory only: an error where [`Self::save`] would
    /// fail (a title or axis label that does not fit, a log axis without
    /// positive data).
    pub fn check(&self) -> Result<(), PlotError> {
        check_figure(self).map_err(|e| PlotError::figure("line chart", &self.title, e))
    }

    /// The drawable points of each series in plot space, split into runs:
    /// a point that cannot be drawn (NaN, infinite, ≤ 0 on a log axis) is
    /// missing data, so the line breaks there instead of bridging the gap.
    fn plot_runs(&self) -> Vec<Vec<Vec<(f64, f64)>>> {
        self.series
            .iter()
            .map(|s| {
                let mut runs = vec![Vec::new()];
                for &(x, y) in &s.points {
                    match (to_plot(self.x_scale, x), to_plot(self.y_scale, y)) {
                        (Some(u), Some(v)) => runs.last_mut().map_or((), |r| r.push((u, v))),
                        _ => runs.push(Vec::new()),
                    }
                }
                runs.retain(|r| !r.is_empty());
                runs
            })
            .collect()
    }

    /// The drawable error bars of series `i` in plot space: (x, low, high)
    /// with low < high.
    fn plot_bars(&self, i: usize) -> Vec<(f64, f64, f64)> {
        let s = &self.series[i];
        s.points
            .iter()
            .zip(&s.errors)
            .filter_map(|(&(x, _), &(lo, hi))| {
                let u = to_plot(self.x_scale, x)?;
                let (a, b) = (to_plot(self.y_scale, lo)?, to_plot(self.y_scale, hi)?);
                (a < b).then_some((u, a, b))
            })
            .collect()
    }

    fn axes(&self, runs: &[Vec<Vec<(f64, f64)>>]) -> Result<(Axis, Axis), PlotError> {
        let all = || runs.iter().flatten().flatten();
        let xs: Vec<f64> = all().map(|p| p.0).collect();
        let mut ys: Vec<f64> = all().map(|p| p.1).collect();
        for i in 0..self.series.len() {
            ys.extend(self.plot_bars(i).iter().flat_map(|b| [b.1, b.2]));
        }
        let any_finite = self
            .series
            .iter()
            .flat_map(|s| &s.points)
            .any(|(x, y)| x.is_finite() && y.is_finite());
        if any_finite && xs.is_empty() {
            let which: Vec<&str> = [("x", self.x_scale), ("y", self.y_scale)]
                .iter()
                .filter(|(_, s)| *s == AxisScale::Log10)
                .map(|(n, _)| *n)
                .collect();
            return Err(PlotError::Invalid(format!(
                "no point has a positive value on the log {} axis; \
                 use a linear scale for data that is all zero or negative",
                which.join(" and ")
            )));
        }
        Ok((
            Axis::fit(self.x_scale, &xs, 0.03, false),
            Axis::fit(self.y_scale, &ys, 0.06, false),
        ))
    }
}

impl Figure for LineChart {
    fn size(&self) -> (u32, u32) {
        self.size
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), PlotError> {
        let runs = self.plot_runs();
        let (x, y) = self.axes(&runs)?;
        let shown: Vec<usize> = (0..self.series.len())
            .filter(|&i| !runs[i].is_empty())
            .collect();
        let bars: Vec<Vec<(f64, f64, f64)>> =
            (0..self.series.len()).map(|i| self.plot_bars(i)).collect();
        let any_bars = shown.iter().any(|&i| !bars[i].is_empty());
        let mut labels: Vec<&str> = shown
            .iter()
            .map(|&i| self.series[i].label.as_str())
            .collect();
        if any_bars {
            labels.push(&self.error_label);
        }
        let mut occupied = Vec::new();
        for &i in &shown {
            for run in &runs[i] {
                sample_polyline(&x, &y, run, &mut occupied);
            }
            for &(u, lo, hi) in &bars[i] {
                sample_polyline(&x, &y, &[(u, lo), (u, hi)], &mut occupied);
            }
        }
        let (legend, headroom) = place_legend(self.legend, &labels, &occupied, self.size);
        let y = if headroom > 0.0 {
            y.with_headroom(headroom)
        } else {
            y
        };
        let x_fmt = |u: &f64| x.label(*u);
        let mut chart = build_chart(
            root,
            &self.title,
            &x,
            &y,
            &self.x_label,
            &self.y_label,
            XTicks {
                format: &x_fmt,
                px: TICK_PX,
            },
        )?;
        for &i in &shown {
            let s = &self.series[i];
            let colour = rgb(series_colour(i));
            let marker = MARKERS[i % MARKERS.len()];
            let line = colour.stroke_width(LINE_WIDTH);
            let style = s.style;
            // An empty series carries the legend entry; the runs follow.
            chart
                .draw_series(Vec::<PathElement<(f64, f64)>>::new())
                .map_err(plot_err)?
                .label(s.label.clone())
                .legend(move |at| {
                    let g = LegendGlyph::new(style, marker, colour);
                    let [a, b, c] = g.segments;
                    EmptyElement::at(at)
                        + PathElement::new(a, g.line)
                        + PathElement::new(b, g.line)
                        + PathElement::new(c, g.line)
                        + Polygon::new(g.marker, g.marker_style)
                });
            // Error bars first, so the markers sit on top of them.
            let thin = colour.stroke_width(2);
            for &(u, lo, hi) in &bars[i] {
                let cap = || PathElement::new(vec![(-ERROR_CAP, 0), (ERROR_CAP, 0)], thin);
                chart
                    .draw_series([
                        EmptyElement::at((u, lo)) + cap(),
                        EmptyElement::at((u, hi)) + cap(),
                    ])
                    .map_err(plot_err)?;
                chart
                    .draw_series(std::iter::once(PathElement::new(
                        vec![(u, lo), (u, hi)],
                        thin,
                    )))
                    .map_err(plot_err)?;
            }
            for run in &runs[i] {
                match style {
                    SeriesStyle::Line | SeriesStyle::LinePoints => {
                        chart
                            .draw_series(LineSeries::new(run.iter().copied(), line))
                            .map_err(plot_err)?;
                    }
                    SeriesStyle::Dashed => {
                        chart
                            .draw_series(DashedLineSeries::new(run.iter().copied(), 14, 8, line))
                            .map_err(plot_err)?;
                    }
                    SeriesStyle::Points => {}
                }
                if matches!(style, SeriesStyle::Points | SeriesStyle::LinePoints) {
                    chart
                        .draw_series(run.iter().map(|&c| {
                            EmptyElement::at(c)
                                + Polygon::new(
                                    marker_polygon(marker, MARKER_RADIUS),
                                    colour.filled(),
                                )
                        }))
                        .map_err(plot_err)?;
                }
            }
        }
        if any_bars {
            // The legend entry that says what the bars are: a grey bar.
            let grey = RGBColor(90, 90, 90).stroke_width(2);
            chart
                .draw_series(Vec::<PathElement<(f64, f64)>>::new())
                .map_err(plot_err)?
                .label(self.error_label.clone())
                .legend(move |at| {
                    let (c, h, w) = (22, 12, ERROR_CAP);
                    EmptyElement::at(at)
                        + PathElement::new(vec![(c, -h), (c, h)], grey)
                        + PathElement::new(vec![(c - w, -h), (c + w, -h)], grey)
                        + PathElement::new(vec![(c - w, h), (c + w, h)], grey)
                });
        }
        draw_legend(&mut chart, legend)
    }
}

/// Half the width of an error bar's end caps, in pixels.
const ERROR_CAP: i32 = 7;
