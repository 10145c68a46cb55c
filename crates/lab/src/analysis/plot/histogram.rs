//! Histograms: a sample binned into equal-width bins, drawn as touching
//! bars on a linear or log count axis, and [`bin_counts`], the binning on
//! its own. Part of [`crate::analysis::plot`]; the frame comes from
//! [`super::chart`].

use super::axis::{to_plot, Axis, AxisScale};
use super::chart::{build_chart, XTicks};
use super::{plot_err, rgb, save_figure, Figure, PlotError, CHART_SIZE, OKABE_ITO, TICK_PX};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// Counts of `values` in `bins` equal-width bins over `range` = (lo, hi).
/// The last bin includes `hi`; values outside the range and non-finite
/// values are not counted. Returns an empty vector when `bins` is 0 or the
/// range is empty or not finite.
pub fn bin_counts(values: &[f64], bins: usize, range: (f64, f64)) -> Vec<u64> {
    let (lo, hi) = range;
    if bins == 0 || !(lo.is_finite() && hi.is_finite() && hi > lo) {
        return Vec::new();
    }
    let mut counts = vec![0u64; bins];
    for &v in values {
        if v.is_finite() && v >= lo && v <= hi {
            let i = (((v - lo) / (hi - lo)) * bins as f64) as usize;
            counts[i.min(bins - 1)] += 1;
        }
    }
    counts
}

/// A histogram of a sample: equal-width bins drawn as touching bars.
#[derive(Clone, Debug, PartialEq)]
pub struct Histogram {
    /// Caption above the plot.
    pub title: String,
    /// x axis description (what was measured, with unit).
    pub x_label: String,
    /// y axis description ("pixels", "runs", …).
    pub y_label: String,
    /// The sample; non-finite values are ignored.
    pub values: Vec<f64>,
    /// Number of bins (at least 1).
    pub bins: usize,
    /// Binning range; `None` means from the sample's minimum to maximum.
    pub range: Option<(f64, f64)>,
    /// y axis scale; `Log10` suits long-tailed data, empty bins are skipped.
    pub y_scale: AxisScale,
    /// Canvas size in pixels, [`CHART_SIZE`] by default.
    pub size: (u32, u32),
}

impl Histogram {
    /// A histogram of `values` in `bins` bins over the data range.
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        values: Vec<f64>,
        bins: usize,
    ) -> Self {
        Self {
            title: title.into(),
            x_label: x_label.into(),
            y_label: "count".into(),
            values,
            bins,
            range: None,
            y_scale: AxisScale::Linear,
            size: CHART_SIZE,
        }
    }

    /// The binning range actually used: `range`, or the data's extent
    /// (widened by ±0.5 when all values are equal). None without data.
    pub fn bin_range(&self) -> Option<(f64, f64)> {
        if let Some(r) = self.range {
            return Some(r);
        }
        let finite = self.values.iter().copied().filter(|v| v.is_finite());
        let lo = finite.clone().fold(f64::INFINITY, f64::min);
        let hi = finite.fold(f64::NEG_INFINITY, f64::max);
        if !lo.is_finite() {
            None
        } else if hi > lo {
            Some((lo, hi))
        } else {
            Some((lo - 0.5, hi + 0.5))
        }
    }

    /// Write `stem.png` and `stem.svg`.
    pub fn save(&self, stem: &Path) -> Result<(), PlotError> {
        save_figure(self, stem).map_err(|e| PlotError::figure("histogram", &self.title, e))
    }
}

impl Figure for Histogram {
    fn size(&self) -> (u32, u32) {
        self.size
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), PlotError> {
        if self.bins < 1 {
            return Err(PlotError::Invalid(
                "a histogram needs at least one bin".into(),
            ));
        }
        let (lo, hi) = self.bin_range().unwrap_or((0.0, 1.0));
        if !(lo.is_finite() && hi.is_finite() && hi > lo) {
            return Err(PlotError::Invalid(format!(
                "histogram range ({lo}, {hi}) is empty or not finite"
            )));
        }
        let counts = bin_counts(&self.values, self.bins, (lo, hi));
        let ys: Vec<f64> = counts
            .iter()
            .filter_map(|&c| to_plot(self.y_scale, c as f64))
            .collect();
        let x = Axis::fit(AxisScale::Linear, &[lo, hi], 0.0, false);
        let y = Axis::fit(self.y_scale, &ys, 0.08, true);
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
        let base = match self.y_scale {
            AxisScale::Linear => 0.0,
            AxisScale::Log10 => y.lo,
        };
        let step = (hi - lo) / self.bins as f64;
        let colour = rgb(OKABE_ITO[0]);
        let bars = counts.iter().enumerate().filter_map(|(i, &c)| {
            let top = to_plot(self.y_scale, c as f64)?;
            let x0 = lo + i as f64 * step;
            Some(Rectangle::new(
                [(x0, base), (x0 + step, top)],
                colour.filled(),
            ))
        });
        chart.draw_series(bars).map_err(plot_err)?;
        let outlines = counts.iter().enumerate().filter_map(|(i, &c)| {
            let top = to_plot(self.y_scale, c as f64)?;
            let x0 = lo + i as f64 * step;
            Some(Rectangle::new(
                [(x0, base), (x0 + step, top)],
                WHITE.stroke_width(1),
            ))
        });
        chart.draw_series(outlines).map_err(plot_err)?;
        Ok(())
    }
}
