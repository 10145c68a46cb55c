//! The film: per-pixel accumulation of samples in linear float.
//!
//! Each pixel keeps a running mean and the sum of squared deviations
//! (Welford 1962), so the sample variance comes for free; the box filter of
//! S1's downsample is the plain mean. Pixels are written by exactly one
//! thread, in sample order, so results do not depend on the thread count.
//! Wider reconstruction filters ([`filter`]) are applied afterwards from
//! the kept samples ([`Film::reconstruct`]).

pub mod filter;
pub mod memory;

pub use filter::Filter;

/// Linear RGB image, shape (height, width, 3), row 0 at the top: what a
/// film develops into, and what the image readers and writers of
/// [`crate::io::image`] exchange.
pub type LinearImage = Array3<f32>;

use crate::math::Color;
use glam::Vec2;
use ndarray::Array3;
use rayon::prelude::*;

/// One camera sample: where it lies on the film (in pixels, pixel (x, y)
/// covering [x, x+1) × [y, y+1)) and the radiance it carried.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FilmSample {
    pub pos: Vec2,
    pub value: Color,
}

/// Running statistics of one pixel's samples.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelStats {
    pub mean: Color,
    /// Sum of squared deviations from the mean (per channel).
    pub m2: Color,
    pub count: u32,
}

impl PixelStats {
    // ANCHOR: welford
    /// Welford's update.
    #[inline]
    pub fn add(&mut self, x: Color) {
        self.count += 1;
        let delta = x - self.mean;
        self.mean += delta / self.count as f32;
        self.m2 += delta * (x - self.mean);
    }

    /// Unbiased sample variance per channel (zero below two samples).
    pub fn variance(&self) -> Color {
        if self.count < 2 {
            Color::ZERO
        } else {
            self.m2 / (self.count - 1) as f32
        }
    }
    // ANCHOR_END: welford
}

#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    /// Row-major pixels, row 0 at the top.
    pub pixels: Vec<PixelStats>,
    /// The image made by a reconstruction filter wider than the box, when
    /// one was applied; [`Film::image`] returns it.
    pub filtered: Option<LinearImage>,
}

impl Film {
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            pixels: vec![PixelStats::default(); width as usize * height as usize],
            filtered: None,
        }
    }

    pub fn pixel(&self, x: u32, y: u32) -> &PixelStats {
        &self.pixels[y as usize * self.width as usize + x as usize]
    }

    fn to_array(&self, f: impl Fn(&PixelStats) -> Color) -> LinearImage {
        let (w, h) = (self.width as usize, self.height as usize);
        Array3::from_shape_fn((h, w, 3), |(y, x, c)| f(&self.pixels[y * w + x])[c])
    }

    /// The image: the filtered one if [`Film::reconstruct`] made one, else
    /// the box-filtered image (each pixel's sample mean).
    pub fn image(&self) -> LinearImage {
        match &self.filtered {
            Some(img) => img.clone(),
            None => self.box_image(),
        }
    }

    /// The box-filtered image: each pixel's sample mean.
    pub fn box_image(&self) -> LinearImage {
        self.to_array(|p| p.mean)
    }

    /// Reconstruct the image with `filter` from `rows`, each row's samples,
    /// `spp` per pixel, pixel after pixel from the left. Each
    /// output pixel is the weighted mean Σ w·L / Σ w of every sample within
    /// the filter's radius of its centre (the pixel's mean if the weights
    /// cancel, which no filter here does for samples spread over the pixel).
    /// `Filter::Box` clears the filtered image instead.
    pub fn reconstruct(&mut self, filter: Filter, rows: &[Vec<FilmSample>], spp: usize) {
        if filter == Filter::Box {
            self.filtered = None;
            return;
        }
        let (w, h) = (self.width as i64, self.height as i64);
        assert!(
            rows.len() == h as usize && rows.iter().all(|r| r.len() == w as usize * spp),
            "one block of spp samples per pixel"
        );
        let r = filter.radius();
        let mut out = vec![Color::ZERO; (w * h) as usize];
        out.par_chunks_mut(w as usize)
            .enumerate()
            .for_each(|(y, row)| {
                let cy = y as f32 + 0.5;
                let (y0, y1) = (
                    ((cy - r).floor() as i64).max(0),
                    ((cy + r).floor() as i64).min(h - 1),
                );
                for (x, px) in row.iter_mut().enumerate() {
                    let cx = x as f32 + 0.5;
                    let (x0, x1) = (
                        ((cx - r).floor() as i64).max(0),
                        ((cx + r).floor() as i64).min(w - 1),
                    );
                    let (mut sum, mut wsum) = (Color::ZERO, 0.0f32);
                    for qy in y0..=y1 {
                        for qx in x0..=x1 {
                            let start = qx as usize * spp;
                            for s in &rows[qy as usize][start..start + spp] {
                                let wt = filter.weight(s.pos.x - cx, s.pos.y - cy);
                                sum += wt * s.value;
                                wsum += wt;
                            }
                        }
                    }
                    *px = if wsum > 1e-6 {
                        sum / wsum
                    } else {
                        self.pixels[y * w as usize + x].mean
                    };
                }
            });
        let (wu, hu) = (w as usize, h as usize);
        self.filtered = Some(Array3::from_shape_fn((hu, wu, 3), |(y, x, c)| {
            out[y * wu + x][c]
        }));
    }

    /// Each pixel's sample count (rays spent, for the adaptive sampler),
    /// shape (height, width).
    pub fn count_array(&self) -> ndarray::Array2<f64> {
        let (w, h) = (self.width as usize, self.height as usize);
        ndarray::Array2::from_shape_fn((h, w), |(y, x)| f64::from(self.pixels[y * w + x].count))
    }

    /// Mean and largest sample count per pixel.
    pub fn samples_per_pixel(&self) -> (f64, u32) {
        let total: u64 = self.pixels.iter().map(|p| u64::from(p.count)).sum();
        let max = self.pixels.iter().map(|p| p.count).max().unwrap_or(0);
        (total as f64 / self.pixels.len().max(1) as f64, max)
    }

    /// Per-pixel sample variance.
    pub fn variance_image(&self) -> LinearImage {
        self.to_array(PixelStats::variance)
    }

    /// Mean over pixels and channels of the per-pixel sample variance s²
    /// (the spread of single samples).
    pub fn mean_sample_variance(&self) -> f64 {
        self.mean_over_pixels(|p| p.variance())
    }

    /// Mean over pixels and channels of s²/n: the estimated variance of each
    /// pixel's mean, i.e. of the pixel value itself. For independent
    /// samples this predicts the MSE a pixel value has around its
    /// expectation.
    pub fn mean_variance_of_mean(&self) -> f64 {
        self.mean_over_pixels(|p| p.variance() / p.count.max(1) as f32)
    }

    fn mean_over_pixels(&self, f: impl Fn(&PixelStats) -> Color) -> f64 {
        if self.pixels.is_empty() {
            return 0.0;
        }
        let sum: f64 = self
            .pixels
            .iter()
            .map(|p| {
                let c = f(p);
                f64::from(c.x) + f64::from(c.y) + f64::from(c.z)
            })
            .sum();
        sum / (3 * self.pixels.len()) as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn welford_matches_two_pass() {
        let xs = [0.1f32, 0.7, 0.3, 0.9, 0.5];
        let mut p = PixelStats::default();
        for &x in &xs {
            p.add(Color::splat(x));
        }
        let mean = xs.iter().sum::<f32>() / 5.0;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f32>() / 4.0;
        assert!((p.mean.x - mean).abs() < 1e-6);
        assert!((p.variance().x - var).abs() < 1e-6);
    }
}
