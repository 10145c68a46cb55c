//! Per-parameter images of a derivative estimate, and the per-pixel sums
//! they are made from.
//!
//! A [`Planes`] holds, per parameter, the per-pixel estimate (RGB
//! interleaved, row-major), its per-channel spread, and the spread of its
//! channel mean (the grey value, for standard errors of the image mean).
//! [`PixelMoments`] accumulates one pixel's samples' partials with the one
//! [`Moments`] accumulator.

use crate::math::Moments;

/// Per parameter: per pixel and channel the estimate and its spread, and
/// per pixel the spread of the channel mean. What "spread" is depends on
/// the term: the gradient render's samples' variance (divide by the count
/// for the variance of the pixel's estimate), or directly the variance of
/// the estimate (the boundary and rim terms); each holder says which.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Planes {
    pub mean: Vec<Vec<f32>>,
    pub variance: Vec<Vec<f32>>,
    pub variance_grey: Vec<Vec<f32>>,
}

/// Which spread a pixel's moments are turned into.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Spread {
    /// The samples' unbiased variance.
    Samples,
    /// The variance of the mean over the samples.
    Mean,
}

impl Planes {
    /// Zero for `n` parameters over a `width` × `height` image.
    pub fn zeros(n: usize, width: u32, height: u32) -> Self {
        let pixels = width as usize * height as usize;
        Self {
            mean: vec![vec![0.0; 3 * pixels]; n],
            variance: vec![vec![0.0; 3 * pixels]; n],
            variance_grey: vec![vec![0.0; pixels]; n],
        }
    }

    /// How many parameters.
    pub fn len(&self) -> usize {
        self.mean.len()
    }

    pub fn is_empty(&self) -> bool {
        self.mean.is_empty()
    }

    /// Pixel `pixel`'s estimate over `samples` samples (those that did not
    /// land here counting as zeros) from its moments, for the first `n`
    /// parameters, added to what the planes hold.
    pub fn add_pixel<const K: usize>(
        &mut self,
        pixel: usize,
        n: usize,
        m: &PixelMoments<K>,
        samples: f64,
        spread: Spread,
    ) {
        self.add_pixel_scaled(pixel, n, m, samples, spread, 1.0);
    }

    /// [`Self::add_pixel`] with the spreads times `spread_scale` (as
    /// [`Self::add_scaled`] scales another term's).
    pub fn add_pixel_scaled<const K: usize>(
        &mut self,
        pixel: usize,
        n: usize,
        m: &PixelMoments<K>,
        samples: f64,
        spread: Spread,
        spread_scale: f32,
    ) {
        let var = |s: &Moments| {
            spread_scale
                * match spread {
                    Spread::Samples => s.variance(samples),
                    Spread::Mean => s.variance_of_mean(samples),
                } as f32
        };
        for k in 0..n {
            for c in 0..3 {
                self.mean[k][3 * pixel + c] += m.rgb[k][c].mean(samples) as f32;
                self.variance[k][3 * pixel + c] += var(&m.rgb[k][c]);
            }
            self.variance_grey[k][pixel] += var(&m.grey[k]);
        }
    }

    /// `scale` × another term's planes for the same parameters added in
    /// (`scale` turns one kind of spread into another: the count m makes a
    /// variance of the mean a samples' variance).
    pub fn add_scaled(&mut self, o: &Planes, spread_scale: f32) {
        let pairs = [
            (&mut self.mean, &o.mean, 1.0),
            (&mut self.variance, &o.variance, spread_scale),
            (&mut self.variance_grey, &o.variance_grey, spread_scale),
        ];
        for (mine, theirs, s) in pairs {
            for (a, b) in mine.iter_mut().zip(theirs) {
                for (x, y) in a.iter_mut().zip(b) {
                    *x += s * y;
                }
            }
        }
    }

    /// Another pass's parameters after these.
    pub fn extend(&mut self, o: Planes) {
        self.mean.extend(o.mean);
        self.variance.extend(o.variance);
        self.variance_grey.extend(o.variance_grey);
    }
}

/// One pixel's running sums of its samples' partials for K parameters:
/// per parameter and channel, and of the channel mean.
#[derive(Clone, Copy, Debug)]
pub struct PixelMoments<const K: usize> {
    pub rgb: [[Moments; 3]; K],
    pub grey: [Moments; K],
}

impl<const K: usize> Default for PixelMoments<K> {
    fn default() -> Self {
        Self {
            rgb: [[Moments::default(); 3]; K],
            grey: [Moments::default(); K],
        }
    }
}

impl<const K: usize> PixelMoments<K> {
    /// A sample whose partial k has the value `values[k]` per channel.
    #[inline]
    pub fn add(&mut self, values: &[[f64; 3]]) {
        for (k, v) in values.iter().enumerate() {
            for (c, &x) in v.iter().enumerate() {
                self.rgb[k][c].add(x);
            }
            self.grey[k].add((v[0] + v[1] + v[2]) / 3.0);
        }
    }

    /// Another's samples added in.
    pub fn merge(&mut self, o: &Self) {
        for k in 0..K {
            for c in 0..3 {
                self.rgb[k][c].merge(&o.rgb[k][c]);
            }
            self.grey[k].merge(&o.grey[k]);
        }
    }
}
