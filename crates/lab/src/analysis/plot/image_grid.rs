//! Image grids: linear-RGB images side by side with a caption under each
//! (renders at several sample counts, render / reference / ꟻLIP map),
//! shown as 8-bit sRGB. Part of [`crate::analysis::plot`].

use super::{
    draw_bitmap, fit_text, font, plot_err, save_figure, text_width, Figure, PlotError, CAPTION_PX,
    TITLE_PX,
};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use raylab::io::image::LinearImage;
use raylab::math::srgb_encode;
use std::path::Path;

/// Images side by side with a caption under each, e.g. the same scene at
/// 1, 4 and 16 samples per pixel, or render / reference / ꟻLIP map.
#[derive(Clone, Debug, PartialEq)]
pub struct ImageGrid {
    /// Caption above the grid.
    pub title: String,
    /// Images per row (at least 1).
    pub columns: usize,
    /// The images (linear RGB, shown as 8-bit sRGB with values clamped to
    /// [0, 1]) and their captions, filled row by row.
    pub cells: Vec<(LinearImage, String)>,
}

// Layout of an image grid, in pixels.
const GRID_PAD: u32 = 24;
const GRID_TITLE: u32 = 80;
const GRID_CAPTION: u32 = 52;

impl ImageGrid {
    /// An empty grid; push `(image, caption)` pairs into `cells`.
    pub fn new(title: impl Into<String>, columns: usize) -> Self {
        Self {
            title: title.into(),
            columns,
            cells: Vec::new(),
        }
    }

    /// Write `stem.png` and `stem.svg` (the SVG embeds the images as PNG).
    /// Fails when there is no cell, an image is empty or not RGB, or
    /// `columns` is 0.
    pub fn save(&self, stem: &Path) -> Result<(), PlotError> {
        if self.columns < 1 {
            return Err(PlotError::Invalid(format!(
                "image grid \"{}\": columns must be at least 1",
                self.title
            )));
        }
        if self.cells.is_empty() {
            return Err(PlotError::Invalid(format!(
                "image grid \"{}\" has no images",
                self.title
            )));
        }
        for (i, (img, caption)) in self.cells.iter().enumerate() {
            let (h, w, c) = img.dim();
            if !(h > 0 && w > 0 && c == 3) {
                return Err(PlotError::Invalid(format!(
                    "image grid \"{}\": image {i} (\"{caption}\") is {w}×{h} with {c} channels; \
                     expected a non-empty RGB image",
                    self.title
                )));
            }
        }
        save_figure(self, stem).map_err(|e| PlotError::figure("image grid", &self.title, e))
    }

    /// The box every image is fitted into: the largest image, scaled by an
    /// integer factor (nearest neighbour, so pixels stay visible) when it is
    /// small, or shrunk when it is wider than 600 px.
    fn cell_box(&self) -> (u32, u32, f64) {
        let max_w = self
            .cells
            .iter()
            .map(|c| c.0.dim().1)
            .max()
            .unwrap_or(1)
            .max(1) as f64;
        let max_h = self
            .cells
            .iter()
            .map(|c| c.0.dim().0)
            .max()
            .unwrap_or(1)
            .max(1) as f64;
        let s = if max_w < 300.0 {
            (300.0 / max_w).floor().max(1.0)
        } else {
            (600.0 / max_w).min(1.0)
        };
        (
            ((max_w * s).round() as u32).max(1),
            ((max_h * s).round() as u32).max(1),
            s,
        )
    }

    fn rows(&self) -> usize {
        self.cells.len().div_ceil(self.columns.max(1))
    }
}

impl Figure for ImageGrid {
    fn size(&self) -> (u32, u32) {
        let (bw, bh, _) = self.cell_box();
        let cols = self.columns.clamp(1, self.cells.len().max(1)) as u32;
        let rows = self.rows() as u32;
        let w = GRID_PAD + cols * (bw + GRID_PAD);
        // Room for the title even when the grid is narrow.
        let title_w = text_width(&self.title, TITLE_PX)
            .unwrap_or(self.title.chars().count() as f64 * TITLE_PX * 0.6)
            .ceil() as u32
            + 2 * GRID_PAD;
        (
            w.max(title_w).max(400),
            GRID_TITLE + rows * (bh + GRID_CAPTION + GRID_PAD),
        )
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), PlotError> {
        let (total_w, _) = self.size();
        let (bw, bh, s) = self.cell_box();
        let cols = self.columns.clamp(1, self.cells.len().max(1)) as u32;
        let grid_w = GRID_PAD + cols * (bw + GRID_PAD);
        let x_off = (total_w.saturating_sub(grid_w)) / 2;
        // `size` made the canvas wide enough for the title.
        let title_px = fit_text("title", &self.title, TITLE_PX, f64::from(total_w))?;
        root.draw_text(
            &self.title,
            &font(title_px).pos(Pos::new(HPos::Center, VPos::Top)),
            ((total_w / 2) as i32, 20),
        )
        .map_err(plot_err)?;
        for (i, (img, caption)) in self.cells.iter().enumerate() {
            let (col, row) = ((i % cols as usize) as u32, (i / cols as usize) as u32);
            let (h, w, _) = img.dim();
            let iw = ((w as f64 * s).round() as u32).clamp(1, bw);
            let ih = ((h as f64 * s).round() as u32).clamp(1, bh);
            let cell_x = x_off + GRID_PAD + col * (bw + GRID_PAD);
            let cell_y = GRID_TITLE + row * (bh + GRID_CAPTION + GRID_PAD);
            // Centre the image horizontally; sit it on its caption.
            let ix = cell_x + (bw - iw) / 2;
            let iy = cell_y + (bh - ih);
            draw_bitmap(
                root,
                (ix as i32, iy as i32),
                (iw, ih),
                resample_srgb8(img, iw, ih),
            )?;
            root.draw(&Rectangle::new(
                [
                    (ix as i32 - 1, iy as i32 - 1),
                    ((ix + iw) as i32, (iy + ih) as i32),
                ],
                RGBColor(120, 120, 120).stroke_width(1),
            ))
            .map_err(plot_err)?;
            let caption_px = fit_text(
                "image caption",
                caption,
                CAPTION_PX,
                f64::from(bw + GRID_PAD),
            )?;
            root.draw_text(
                caption,
                &font(caption_px).pos(Pos::new(HPos::Center, VPos::Top)),
                ((cell_x + bw / 2) as i32, (cell_y + bh + 12) as i32),
            )
            .map_err(plot_err)?;
        }
        Ok(())
    }
}

/// Resize a linear image to `w`×`h` and encode it as 8-bit sRGB. Each output
/// pixel averages (in linear light, where averaging is physically right)
/// the input pixels its footprint covers, which is a box filter when
/// shrinking and nearest neighbour when enlarging.
fn resample_srgb8(img: &LinearImage, w: u32, h: u32) -> Vec<u8> {
    let (ih, iw, _) = img.dim();
    let (w, h) = (w as usize, h as usize);
    let mut out = Vec::with_capacity(w * h * 3);
    for y in 0..h {
        let y0 = y * ih / h;
        let y1 = ((y + 1) * ih).div_ceil(h).clamp(y0 + 1, ih);
        for x in 0..w {
            let x0 = x * iw / w;
            let x1 = ((x + 1) * iw).div_ceil(w).clamp(x0 + 1, iw);
            let n = ((y1 - y0) * (x1 - x0)) as f32;
            for c in 0..3 {
                let mut sum = 0.0f32;
                for sy in y0..y1 {
                    for sx in x0..x1 {
                        let v = img[[sy, sx, c]];
                        sum += if v.is_finite() { v } else { 0.0 };
                    }
                }
                let v = srgb_encode((sum / n).clamp(0.0, 1.0));
                out.push((v * 255.0 + 0.5).floor() as u8);
            }
        }
    }
    out
}
