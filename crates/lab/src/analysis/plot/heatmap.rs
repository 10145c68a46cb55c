//! Heatmaps: a scalar field (per-pixel costs, a periodogram, an error map)
//! drawn as colours of a [`Palette`](super::Palette), with labelled axes and
//! a colour bar, linear or log. Part of [`crate::analysis::plot`].

use super::axis::{to_plot, Axis, AxisScale};
use super::{
    draw_bitmap, fit_text, font, plot_err, save_figure, Figure, Palette, PlotError, AXIS_DESC_PX,
    TICK_PX, TITLE_PX,
};
use ndarray::Array2;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;

/// Colour of cells whose value cannot be shown (NaN, or ≤ 0 on a log scale).
const NO_DATA: [u8; 3] = [160, 160, 160];

/// A scalar field shown as colours, with a labelled colour bar; used for
/// per-pixel cost maps (rows are image rows, row 0 at the top).
#[derive(Clone, Debug, PartialEq)]
pub struct Heatmap {
    /// Caption above the map.
    pub title: String,
    /// The values, shape (rows, columns).
    pub data: Array2<f64>,
    /// Map colours by log10 of the value (for costs spanning decades);
    /// values ≤ 0 are then drawn grey, like NaN.
    pub log_scale: bool,
    /// Colour map.
    pub palette: Palette,
    /// What the colours mean, written beside the colour bar.
    pub value_label: String,
    /// x axis description ("pixel x" by default).
    pub x_label: String,
    /// y axis description ("pixel y" by default).
    pub y_label: String,
    /// Axis values at the map's edges, [left, right, bottom, top] (e.g.
    /// frequencies for a spectrum); `None` numbers cells from 0 at the
    /// left and top edges.
    pub extent: Option<[f64; 4]>,
    /// The values the colour bar spans (before a log scale), when not the
    /// data's own range: values beyond it take the end colours (a robust
    /// range that fireflies do not wash out).
    pub range: Option<(f64, f64)>,
}

impl Heatmap {
    /// A heatmap of `data` with a linear viridis scale.
    pub fn new(title: impl Into<String>, data: Array2<f64>) -> Self {
        Self {
            title: title.into(),
            data,
            log_scale: false,
            palette: Palette::Viridis,
            value_label: String::new(),
            x_label: "pixel x".into(),
            y_label: "pixel y".into(),
            extent: None,
            range: None,
        }
    }

    /// A signed per-pixel field (`values` row-major, `width` × `height`,
    /// row 0 at the top) on the [`Palette::Diverging`] scale, symmetric about
    /// 0 and spanning the 99.5th percentile of |value|: the few pixels
    /// beyond it (Monte Carlo fireflies) take the end colours rather than
    /// washing the rest out.
    pub fn signed(title: impl Into<String>, values: &[f32], width: u32, height: u32) -> Self {
        let data = Array2::from_shape_fn((height as usize, width as usize), |(y, x)| {
            f64::from(values[y * width as usize + x])
        });
        let mut abs: Vec<f64> = values
            .iter()
            .map(|&v| f64::from(v).abs())
            .filter(|v| v.is_finite())
            .collect();
        let m = raylab::math::percentiles(&mut abs, &[99.5])[0];
        let mut map = Self::new(title, data);
        map.palette = Palette::Diverging;
        if m.is_finite() && m > 0.0 {
            map.range = Some((-m, m));
        }
        map
    }

    /// Write `stem.png` and `stem.svg`. Fails when the data is empty, or
    /// when `log_scale` is set and no value is positive.
    pub fn save(&self, stem: &Path) -> Result<(), PlotError> {
        save_figure(self, stem).map_err(|e| PlotError::figure("heatmap", &self.title, e))
    }

    fn scale(&self) -> AxisScale {
        if self.log_scale {
            AxisScale::Log10
        } else {
            AxisScale::Linear
        }
    }

    /// Pixel size of the map area: fit 1000×800, keep square cells.
    fn map_pixels(&self) -> (u32, u32) {
        let (rows, cols) = self.data.dim();
        let (rows, cols) = (rows.max(1) as f64, cols.max(1) as f64);
        let s = (1000.0 / cols).min(800.0 / rows);
        (
            ((cols * s).round() as u32).max(1),
            ((rows * s).round() as u32).max(1),
        )
    }
}

// Layout of a heatmap figure around the map, in pixels.
const HM_LEFT: u32 = 150;
/// Air left of the y axis label, which plotters sets at the very edge of
/// its label area.
const HM_PAD_LEFT: u32 = 20;
const HM_TOP: u32 = 90;
const HM_BOTTOM: u32 = 100;
const HM_BAR_AREA: u32 = 300;
/// Room right of the colour bar for tick labels and the value label.
const HM_BAR_LABELS: u32 = 200;
const HM_MARGIN: u32 = 20;

impl Figure for Heatmap {
    fn size(&self) -> (u32, u32) {
        let (w, h) = self.map_pixels();
        (
            HM_PAD_LEFT + HM_LEFT + w + HM_BAR_AREA + HM_MARGIN,
            HM_TOP + h + HM_BOTTOM,
        )
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), PlotError> {
        let (rows, cols) = self.data.dim();
        if rows == 0 || cols == 0 {
            return Err(PlotError::Invalid(format!(
                "heatmap data is empty ({rows}×{cols})"
            )));
        }
        let scale = self.scale();
        let us: Vec<f64> = self
            .data
            .iter()
            .filter_map(|&v| to_plot(scale, v))
            .collect();
        if us.is_empty() {
            return Err(PlotError::Invalid(format!(
                "no value can be shown{}",
                if self.log_scale {
                    " on a log scale (none is positive); use a linear scale"
                } else {
                    " (all are NaN or infinite)"
                }
            )));
        }
        let mut vmin = us.iter().copied().fold(f64::INFINITY, f64::min);
        let mut vmax = us.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if let Some((lo, hi)) = self.range {
            if let (Some(lo), Some(hi)) = (to_plot(scale, lo), to_plot(scale, hi)) {
                (vmin, vmax) = (lo, hi);
            }
        }
        if self.palette == Palette::Diverging && !self.log_scale {
            // Symmetric about 0, so that white is 0 (an all-zero field
            // gets [−1, 1]).
            let m = vmin.abs().max(vmax.abs());
            let m = if m > 0.0 { m } else { 1.0 };
            (vmin, vmax) = (-m, m);
        }
        // The colour bar spans exactly the data (full contrast); a constant
        // field gets a unit-wide window around its value.
        let bar_axis = Axis::fit(scale, &[vmin, vmax], 0.0, false);
        let (lo, hi) = (bar_axis.lo, bar_axis.hi);

        let (map_w, _) = self.map_pixels();
        // The title is centred over the map; it may reach as far to either
        // side as the nearer canvas edge allows.
        let (total_w, _) = root.dim_in_pixel();
        let centre = HM_PAD_LEFT + HM_LEFT + map_w / 2;
        let room = 2.0 * f64::from(centre.min(total_w.saturating_sub(centre))) - 24.0;
        let title_px = fit_text("title", &self.title, TITLE_PX, room)?;
        root.draw_text(
            &self.title,
            &font(title_px).pos(Pos::new(HPos::Center, VPos::Top)),
            (centre as i32, 20),
        )
        .map_err(plot_err)?;

        // The map: axes in cell units, the cells drawn as one bitmap.
        let (map_area, bar_area) = root.split_horizontally(HM_PAD_LEFT + HM_LEFT + map_w);
        let map_area = map_area.margin(HM_TOP, 0, HM_PAD_LEFT, 0);
        // Row 0 at the top: by default the y axis runs from `rows` (bottom)
        // to 0 (top).
        let [left, right, bottom, top] =
            self.extent.unwrap_or([0.0, cols as f64, rows as f64, 0.0]);
        let x = Axis::fit(AxisScale::Linear, &[left, right], 0.0, false);
        let mut y = Axis::fit(AxisScale::Linear, &[bottom, top], 0.0, false);
        if bottom > top {
            std::mem::swap(&mut y.lo, &mut y.hi);
        }
        let mut chart = ChartBuilder::on(&map_area)
            .x_label_area_size(HM_BOTTOM)
            .y_label_area_size(HM_LEFT)
            .build_cartesian_2d(x.coord(), y.coord())
            .map_err(plot_err)?;
        let x_fmt = |u: &f64| x.label(*u);
        let y_fmt = |u: &f64| y.label(*u);
        let (plot_w, plot_h) = chart.plotting_area().dim_in_pixel();
        let desc_px = fit_text(
            "x axis label",
            &self.x_label,
            AXIS_DESC_PX,
            f64::from(plot_w),
        )?
        .min(fit_text(
            "y axis label",
            &self.y_label,
            AXIS_DESC_PX,
            f64::from(plot_h),
        )?);
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc(&self.x_label)
            .y_desc(&self.y_label)
            .label_style(font(TICK_PX))
            .axis_desc_style(font(desc_px))
            .x_label_formatter(&x_fmt)
            .y_label_formatter(&y_fmt)
            .axis_style(BLACK.stroke_width(2))
            .set_all_tick_mark_size(8)
            .draw()
            .map_err(plot_err)?;
        let (pw, ph) = chart.plotting_area().dim_in_pixel();
        let mut buf = Vec::with_capacity(pw as usize * ph as usize * 3);
        for py in 0..ph as usize {
            let r = (py * rows / ph.max(1) as usize).min(rows - 1);
            for px in 0..pw as usize {
                let c = (px * cols / pw.max(1) as usize).min(cols - 1);
                let colour = match to_plot(scale, self.data[[r, c]]) {
                    Some(u) => self.palette.colour((u - lo) / (hi - lo)),
                    None => NO_DATA,
                };
                buf.extend_from_slice(&colour);
            }
        }
        let base = chart.plotting_area().get_base_pixel();
        draw_bitmap(root, base, (pw, ph), buf)?;

        // The colour bar: a narrow chart whose y axis is the value scale.
        let bar_area = bar_area.margin(HM_TOP, HM_BOTTOM, 60, 0);
        let bar_x = Axis::new(AxisScale::Linear, 0.0, 1.0);
        let mut bar = ChartBuilder::on(&bar_area)
            .right_y_label_area_size(HM_BAR_LABELS)
            .build_cartesian_2d(bar_x.coord(), bar_axis.coord())
            .map_err(plot_err)?;
        let bar_fmt = |u: &f64| bar_axis.label(*u);
        let no_fmt = |_: &f64| String::new();
        bar.configure_mesh()
            .disable_mesh()
            .disable_x_axis()
            .label_style(font(TICK_PX))
            .axis_desc_style(font(AXIS_DESC_PX))
            .x_label_formatter(&no_fmt)
            .y_label_formatter(&bar_fmt)
            .axis_style(BLACK.stroke_width(2))
            .set_all_tick_mark_size(8)
            .draw()
            .map_err(plot_err)?;
        let (bw, bh) = bar.plotting_area().dim_in_pixel();
        let mut bbuf = Vec::with_capacity(bw as usize * bh as usize * 3);
        for py in 0..bh {
            // Top of the bar is the highest value.
            let t = 1.0 - (f64::from(py) + 0.5) / f64::from(bh.max(1));
            let colour = self.palette.colour(t);
            for _ in 0..bw {
                bbuf.extend_from_slice(&colour);
            }
        }
        let bbase = bar.plotting_area().get_base_pixel();
        draw_bitmap(root, bbase, (bw, bh), bbuf)?;
        bar.plotting_area()
            .draw(&Rectangle::new(
                [(0.0, lo), (1.0, hi)],
                BLACK.stroke_width(2),
            ))
            .map_err(plot_err)?;
        // The value label, rotated along the bar beyond its tick labels.
        // (plotters' own y_desc lands outside the canvas in a right-hand
        // label area.)
        if !self.value_label.is_empty() {
            let x = bbase.0 + bw as i32 + HM_BAR_LABELS as i32 - 30;
            let y = bbase.1 + bh as i32 / 2;
            let px = fit_text(
                "colour bar label",
                &self.value_label,
                AXIS_DESC_PX,
                f64::from(bh),
            )?;
            root.draw_text(
                &self.value_label,
                &font(px)
                    .transform(FontTransform::Rotate270)
                    .pos(Pos::new(HPos::Center, VPos::Center)),
                (x, y),
            )
            .map_err(plot_err)?;
        }
        Ok(())
    }
}
