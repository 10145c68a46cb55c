//! The film: per-pixel accumulation of samples in linear float.
//!
//! Each pixel keeps a running mean and the sum of squared deviations
//! (Welford 1962), so the sample variance comes for free; the box filter of
//! S1's downsample is the plain mean. Pixels are written by exactly one
//! thread, in sample order, so results do not depend on the thread count.

use crate::io::image::{write_exr_channels, ChannelData, LinearImage};
use crate::math::Color;
use ndarray::Array3;
use std::path::Path;

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

    /// Write the film as OpenEXR with its statistics: `R`, `G`, `B` = each
    /// pixel's mean, `variance.R`, `variance.G`, `variance.B` = the unbiased
    /// sample variance of its samples (divide by `count` for the variance of
    /// the mean), `count` = its number of samples (32-bit unsigned).
    pub fn write_exr(&self, path: &Path) -> anyhow::Result<()> {
        let channel =
            |f: &dyn Fn(&PixelStats) -> f32| ChannelData::F32(self.pixels.iter().map(f).collect());
        let channels = vec![
            ("R", channel(&|p| p.mean.x)),
            ("G", channel(&|p| p.mean.y)),
            ("B", channel(&|p| p.mean.z)),
            ("variance.R", channel(&|p| p.variance().x)),
            ("variance.G", channel(&|p| p.variance().y)),
            ("variance.B", channel(&|p| p.variance().z)),
            (
                "count",
                ChannelData::U32(self.pixels.iter().map(|p| p.count).collect()),
            ),
        ];
        write_exr_channels(path, self.width as usize, self.height as usize, channels)
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

    /// Every channel comes back as written: f32 and u32 samples are stored
    /// losslessly, so equality is exact; and `image`'s reader (used for
    /// references and `raylab diff`) still finds the mean in R, G, B.
    #[test]
    fn exr_round_trip_of_statistics_channels() {
        let mut film = Film::new(3, 2);
        for (i, p) in film.pixels.iter_mut().enumerate() {
            for k in 0..=i {
                p.add(Color::new(0.1 * k as f32, 0.5, 2.0 + i as f32));
            }
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f.exr");
        film.write_exr(&path).unwrap();
        let exr = crate::io::image::read_exr_channels(&path).unwrap();
        assert_eq!((exr.width, exr.height), (3, 2));
        let get = |name: &str| {
            exr.get(name)
                .unwrap_or_else(|| panic!("no channel {name}"))
                .to_vec()
        };
        let var = film.variance_image();
        for (i, p) in film.pixels.iter().enumerate() {
            let (y, x) = (i / 3, i % 3);
            assert_eq!(get("R")[i], p.mean.x);
            assert_eq!(get("B")[i], p.mean.z);
            assert_eq!(get("variance.R")[i], var[[y, x, 0]]);
            assert_eq!(get("variance.G")[i], var[[y, x, 1]]);
            assert_eq!(get("count")[i], p.count as f32);
        }
        assert!(var[[1, 2, 0]] > 0.0, "the test needs a non-zero variance");
        let back = crate::io::image::read_image(&path).unwrap();
        assert_eq!(back, film.image());
    }
}
