//! Grouped bar charts: for each category along x, one bar per series side
//! by side, on a linear or log y axis. Part of [`crate::analysis::plot`];
//! the frame and legend come from [`super::chart`].

use super::axis::{to_plot, Axis, AxisScale};
use super::chart::{build_chart, draw_legend, place_legend, plot_width, LegendPosition, XTicks};
use super::{
    check_figure, fit_text, plot_err, rgb, save_figure, series_colour, Figure, PlotError,
    CHART_SIZE, TICK_PX,
};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// One series of a [`BarChart`]: a value per category.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BarSeries {
    /// Legend text.
    pub label: String,
    /// `values[i]` is the bar for category `i`; missing or non-finite
    /// values (and values ≤ 0 on a log axis) leave a gap.
    pub values: Vec<f64>,
}

impl BarSeries {
    /// A series with the given label and values.
    pub fn new(label: impl Into<String>, values: Vec<f64>) -> Self {
        Self {
            label: label.into(),
            values,
        }
    }
}

/// Grouped bars: for each category along x, one bar per series side by side.
#[derive(Clone, Debug, PartialEq)]
pub struct BarChart {
    /// Caption above the plot.
    pub title: String,
    /// x axis description.
    pub x_label: String,
    /// y axis description (include the unit).
    pub y_label: String,
    /// Category names along x, in order.
    pub categories: Vec<String>,
    /// The series, coloured in order.
    pub series: Vec<BarSeries>,
    /// y axis scale; on a log axis bars rise from the bottom of the axis.
    pub y_scale: AxisScale,
    /// Legend placement.
    pub legend: LegendPosition,
    /// Canvas size in pixels, [`CHART_SIZE`] by default.
    pub size: (u32, u32),
}

impl BarChart {
    /// An empty chart over the given categories; push series into `series`.
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
        categories: Vec<String>,
    ) -> Self {
        Self {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            categories,
            series: Vec::new(),
            y_scale: AxisScale::Linear,
            legend: LegendPosition::Auto,
            size: CHART_SIZE,
        }
    }

    /// Write `stem.png` and `stem.svg`.
    pub fn save(&self, stem: &Path) -> Result<(), PlotError> {
        save_figure(self, stem).map_err(|e| PlotError::figure("bar chart", &self.title, e))
    }

    /// Draw the chart in memory only: an error where [`Self::save`] would
    /// fail (a title or axis label that does not fit, a log axis without
    /// positive data).
    pub fn check(&self) -> Result<(), PlotError> {
        check_figure(self).map_err(|e| PlotError::figure("bar chart", &self.title, e))
    }
}

impl BarChart {
    /// The bars as plot-space rectangles `(series, x0, x1, top)`; bars
    /// fill 80 % of each category slot, the rest separates the groups.
    fn bars(&self) -> Vec<(usize, f64, f64, f64)> {
        let n_cat = self.categories.len();
        let width = 0.8 / self.series.len().max(1) as f64;
        let mut out = Vec::new();
        for (j, s) in self.series.iter().enumerate() {
            for (i, &v) in s.values.iter().take(n_cat).enumerate() {
                if let Some(top) = to_plot(self.y_scale, v) {
                    let x0 = i as f64 + 0.1 + j as f64 * width;
                    out.push((j, x0, x0 + width, top));
                }
            }
        }
        out
    }
}

impl Figure for BarChart {
    fn size(&self) -> (u32, u32) {
        self.size
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), PlotError> {
        let n_cat = self.categories.len();
        let bars = self.bars();
        let ys: Vec<f64> = bars.iter().map(|b| b.3).collect();
        let any_finite = self
            .series
            .iter()
            .flat_map(|s| s.values.iter().take(n_cat))
            .any(|v| v.is_finite());
        if any_finite && ys.is_empty() {
            return Err(PlotError::Invalid(
                "no bar has a positive value for the log y axis".into(),
            ));
        }
        let y = Axis::fit(self.y_scale, &ys, 0.08, true);
        let x = Axis {
            major: (0..n_cat).map(|i| i as f64 + 0.5).collect(),
            minor: vec![],
            ..Axis::new(AxisScale::Linear, 0.0, n_cat.max(1) as f64)
        };
        let base = match self.y_scale {
            AxisScale::Linear => 0.0f64.clamp(y.lo, y.hi),
            AxisScale::Log10 => y.lo,
        };
        // Where the bars are, sampled on a grid inside each, for the legend.
        let mut occupied = Vec::new();
        for &(_, x0, x1, top) in &bars {
            for a in 0..=8 {
                for b in 0..=16 {
                    let u = x0 + (x1 - x0) * f64::from(a) / 8.0;
                    let v = base + (top - base) * f64::from(b) / 16.0;
                    occupied.push((x.fraction(u), y.fraction(v)));
                }
            }
        }
        let labels: Vec<&str> = self.series.iter().map(|s| s.label.as_str()).collect();
        let (legend, headroom) = place_legend(self.legend, &labels, &occupied, self.size);
        let y = if headroom > 0.0 {
            y.with_headroom(headroom)
        } else {
            y
        };
        let x_fmt = |u: &f64| {
            let i = (u - 0.5).round();
            if i >= 0.0 && (i as usize) < n_cat {
                self.categories[i as usize].clone()
            } else {
                String::new()
            }
        };
        // Category names get the tick size at which the widest fits its
        // slot (an error below the smallest size: relabel it in the manifest).
        let slot = plot_width(self.size.0) / n_cat.max(1) as f64 - 8.0;
        let mut x_tick_px = TICK_PX;
        for c in &self.categories {
            x_tick_px = x_tick_px.min(fit_text("bar label", c, TICK_PX, slot)?);
        }
        let mut chart = build_chart(
            root,
            &self.title,
            &x,
            &y,
            &self.x_label,
            &self.y_label,
            XTicks {
                format: &x_fmt,
                px: x_tick_px,
            },
        )?;
        for (j, s) in self.series.iter().enumerate() {
            let colour = rgb(series_colour(j));
            let rects: Vec<_> = bars
                .iter()
                .filter(|b| b.0 == j)
                .map(|&(_, x0, x1, top)| Rectangle::new([(x0, base), (x1, top)], colour.filled()))
                .collect();
            chart
                .draw_series(rects)
                .map_err(plot_err)?
                .label(s.label.clone())
                .legend(move |(lx, ly)| {
                    Rectangle::new([(lx, ly - 10), (lx + 36, ly + 10)], colour.filled())
                });
        }
        draw_legend(&mut chart, legend)
    }
}
