//! The film: per-pixel accumulation of samples in linear float.
//!
//! Each pixel keeps a running mean and the sum of squared deviations
//! (Welford 1962), so the sample variance comes for free; the box filter of
//! S1's downsample is the plain mean. Pixels are written by exactly one
//! thread, in sample order, so results do not depend on the thread count.

use crate::io::image::LinearImage;
use crate::math::Color;
use ndarray::Array3;

/// Running statistics of one pixel's samples.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelStats {
    pub mean: Color,
    /// Sum of squared deviations from the mean (per channel).
    pub m2: Color,
    pub count: u32,
}

impl PixelStats {
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
}

#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    /// Row-major pixels, row 0 at the top.
    pub pixels: Vec<PixelStats>,
}

impl Film {
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            pixels: vec![PixelStats::default(); width as usize * height as usize],
        }
    }

    pub fn pixel(&self, x: u32, y: u32) -> &PixelStats {
        &self.pixels[y as usize * self.width as usize + x as usize]
    }

    fn to_array(&self, f: impl Fn(&PixelStats) -> Color) -> LinearImage {
        let (w, h) = (self.width as usize, self.height as usize);
        Array3::from_shape_fn((h, w, 3), |(y, x, c)| f(&self.pixels[y * w + x])[c])
    }

    /// The box-filtered image: each pixel's sample mean.
    pub fn image(&self) -> LinearImage {
        self.to_array(|p| p.mean)
    }

    /// Per-pixel sample variance.
    pub fn variance_image(&self) -> LinearImage {
        self.to_array(PixelStats::variance)
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
