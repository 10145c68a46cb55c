//! Image-comparison metrics: how far a rendered image is from a reference.
//!
//! This sits at the end of the data flow, after the film has written its
//! images: `raylab diff test.exr reference.exr` reads two files and reports
//! the mean squared error (MSE), the relative MSE of Rousselle et al., the
//! peak signal-to-noise ratio (PSNR), the largest absolute error and the
//! statistics of NVIDIA's ꟻLIP perceptual error map, which it can also write
//! as a magma-coloured PNG.
//!
//! MSE, relMSE, PSNR and the maximum error are computed on the linear RGB
//! values exactly as stored (no tone mapping, no clamping). ꟻLIP is the
//! reference C++ implementation (through the `nv-flip` crate) in its LDR
//! form: both images are first clamped to [0, 1] and encoded to 8-bit sRGB
//! with [`to_srgb8`], so ꟻLIP sees what an sRGB display would show, and
//! differences above 1 (in HDR renders) are invisible to it.

use crate::Error;
use ndarray::Array2;
use raylab::io::image::{read_image, to_srgb8, LinearImage};
use raylab::io::write_atomically;
use serde::Serialize;
use std::fmt;
use std::path::Path;

/// The ε in the denominator of the relative MSE, from Rousselle, Knaus and
/// Zwicker, "Adaptive Sampling and Reconstruction using Greedy Error
/// Minimization" (SIGGRAPH Asia 2011): it keeps near-black reference pixels
/// from dominating the mean.
pub const REL_MSE_EPSILON: f64 = 1e-2;

/// ꟻLIP's viewing condition: pixels per degree of visual angle. 67 is the
/// reference tool's default (a 0.7 m wide 4K monitor seen from 0.7 m).
pub const FLIP_PIXELS_PER_DEGREE: f32 = nv_flip::DEFAULT_PIXELS_PER_DEGREE;

/// Why two images cannot be compared.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum MetricsError {
    /// The images have different sizes; sizes are width × height.
    #[error("image sizes differ: test is {}×{}, reference is {}×{}", test.0, test.1, reference.0, reference.1)]
    SizeMismatch {
        /// (width, height) of the test image.
        test: (usize, usize),
        /// (width, height) of the reference image.
        reference: (usize, usize),
    },
    /// An image is not (height, width, 3) RGB.
    #[error("{which} image has {channels} channels, expected 3 (RGB)")]
    NotRgb {
        /// "test" or "reference".
        which: &'static str,
        /// The channel count found.
        channels: usize,
    },
    /// An image has no pixels.
    #[error("{which} image is empty (0 pixels)")]
    Empty {
        /// "test" or "reference".
        which: &'static str,
    },
}

/// Statistics of a ꟻLIP error map, as NVIDIA's reference `flip` tool prints
/// them. Every value is in [0, 1].
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct FlipStats {
    /// Mean of the per-pixel ꟻLIP errors; the single number the ꟻLIP
    /// authors recommend reporting.
    pub mean: f64,
    /// Error-weighted median: the smallest per-pixel error `e` such that the
    /// pixels with error ≤ `e` carry more than half of the total error
    /// (sum of all errors). It answers "at what error level does the bulk of
    /// the visible error sit?", and is not the ordinary median.
    pub weighted_median: f64,
    /// First error-weighted quartile: as `weighted_median` with 25 % of the
    /// total error.
    pub q1: f64,
    /// Third error-weighted quartile: as `weighted_median` with 75 % of the
    /// total error.
    pub q3: f64,
    /// Smallest per-pixel error.
    pub min: f64,
    /// Largest per-pixel error.
    pub max: f64,
}

/// Every metric of one test image against its reference.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ImageMetrics {
    /// Mean squared error over pixels and channels (linear values).
    pub mse: f64,
    /// Relative MSE, see [`rel_mse`].
    pub rel_mse: f64,
    /// PSNR in dB for a peak of 1.0; `f64::INFINITY` for identical images
    /// (serde_json writes infinity as `null`).
    pub psnr: f64,
    /// Largest absolute difference over pixels and channels.
    pub max_abs_error: f64,
    /// ꟻLIP statistics (LDR, see the module documentation).
    pub flip: FlipStats,
}

/// True when `a` and `b` have the same shape; the scalar metrics return NaN
/// otherwise rather than panicking.
fn same_shape(a: &LinearImage, b: &LinearImage) -> bool {
    a.dim() == b.dim()
}

/// Mean over pixels and channels of `(a − b)²`. NaN when the shapes differ
/// or the images are empty (use [`compare`] for a checked comparison).
pub fn mse(a: &LinearImage, b: &LinearImage) -> f64 {
    if !same_shape(a, b) {
        return f64::NAN;
    }
    let sum: f64 = a
        .iter()
        .zip(b.iter())
        .map(|(&x, &y)| {
            let d = f64::from(x) - f64::from(y);
            d * d
        })
        .sum();
    sum / a.len() as f64
}

/// Relative MSE (also called MRSE): the mean over pixels and channels of
/// `(a − r)² / (r² + ε)` where `r` is the reference `reference` and
/// ε = [`REL_MSE_EPSILON`] = 0.01 (Rousselle et al. 2011). Dividing by the
/// reference makes an error in a dark region count as much as a
/// proportionally equal error in a bright one. Not symmetric: the second
/// argument must be the reference. NaN when the shapes differ or the images
/// are empty.
pub fn rel_mse(a: &LinearImage, reference: &LinearImage) -> f64 {
    if !same_shape(a, reference) {
        return f64::NAN;
    }
    let sum: f64 = a
        .iter()
        .zip(reference.iter())
        .map(|(&x, &r)| {
            let (x, r) = (f64::from(x), f64::from(r));
            (x - r) * (x - r) / (r * r + REL_MSE_EPSILON)
        })
        .sum();
    sum / a.len() as f64
}

/// Peak signal-to-noise ratio in dB: `10 · log10(peak² / MSE)`. Identical
/// images give `f64::INFINITY`. Computed on linear values; `peak` is the
/// largest value the signal is meant to reach (1.0 for display-referred
/// images). NaN when the shapes differ or the images are empty.
pub fn psnr(a: &LinearImage, b: &LinearImage, peak: f64) -> f64 {
    let e = mse(a, b);
    if e == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (peak * peak / e).log10()
    }
}

/// Largest absolute difference over pixels and channels. NaN when the
/// shapes differ or any difference is NaN (as the MSE then is: `f64::max`
/// would skip it); 0 for empty images.
pub fn max_abs_error(a: &LinearImage, b: &LinearImage) -> f64 {
    if !same_shape(a, b) {
        return f64::NAN;
    }
    a.iter()
        .zip(b.iter())
        .map(|(&x, &y)| (f64::from(x) - f64::from(y)).abs())
        .fold(0.0, |m: f64, e| {
            if m.is_nan() || e.is_nan() {
                f64::NAN
            } else {
                m.max(e)
            }
        })
}

/// Check that two images can be compared: both RGB, non-empty, same size.
fn check_comparable(test: &LinearImage, reference: &LinearImage) -> Result<(), MetricsError> {
    for (which, img) in [("test", test), ("reference", reference)] {
        let (h, w, c) = img.dim();
        if c != 3 {
            return Err(MetricsError::NotRgb { which, channels: c });
        }
        if w == 0 || h == 0 {
            return Err(MetricsError::Empty { which });
        }
    }
    let (th, tw, _) = test.dim();
    let (rh, rw, _) = reference.dim();
    if (th, tw) != (rh, rw) {
        return Err(MetricsError::SizeMismatch {
            test: (tw, th),
            reference: (rw, rh),
        });
    }
    Ok(())
}

/// Wrap a linear image as the 8-bit sRGB image ꟻLIP's LDR pipeline expects
/// (values clamped to [0, 1] by [`to_srgb8`]).
fn flip_input(img: &LinearImage) -> nv_flip::FlipImageRgb8 {
    let (h, w, _) = img.dim();
    nv_flip::FlipImageRgb8::with_data(w as u32, h as u32, &to_srgb8(img))
}

/// The per-pixel ꟻLIP error map of `test` against `reference`, shape
/// (height, width), values in [0, 1]; computed by NVIDIA's reference
/// implementation on the 8-bit sRGB versions of both images at
/// [`FLIP_PIXELS_PER_DEGREE`].
pub fn flip_error_map(
    test: &LinearImage,
    reference: &LinearImage,
) -> Result<Array2<f32>, MetricsError> {
    check_comparable(test, reference)?;
    let (h, w, _) = test.dim();
    let map = nv_flip::flip(
        flip_input(reference),
        flip_input(test),
        FLIP_PIXELS_PER_DEGREE,
    );
    // nv-flip returns exactly width·height values, row-major from the top
    // left, so the reshape cannot fail; the error path is only defensive.
    Array2::from_shape_vec((h, w), map.to_vec()).map_err(|_| MetricsError::SizeMismatch {
        test: (w, h),
        reference: (map.width() as usize, map.height() as usize),
    })
}

/// Pool a ꟻLIP error map into the statistics the reference tool prints.
///
/// Mean and the weighted percentiles come from ꟻLIP's own pool
/// (`nv_flip::FlipPool`, the C++ `pooling` class): the mean is the sum of
/// the errors over the pixel count, and the weighted p-percentile is
/// `getPercentile(p, weighted = true)`: sort the errors, accumulate them, and
/// return the first error at which the running sum exceeds p times the total
/// (the tool's "weighted median" is p = 0.5, its quartiles p = 0.25 and
/// 0.75). Min and max are taken from the map directly, because the pool
/// starts its maximum at the smallest positive float, not at 0. An empty
/// map gives all zeros.
pub fn flip_stats(map: &Array2<f32>) -> FlipStats {
    let (h, w) = map.dim();
    if map.is_empty() {
        return FlipStats {
            mean: 0.0,
            weighted_median: 0.0,
            q1: 0.0,
            q3: 0.0,
            min: 0.0,
            max: 0.0,
        };
    }
    let data: Vec<f32> = map.iter().copied().collect();
    let image = nv_flip::FlipImageFloat::with_data(w as u32, h as u32, &data);
    let mut pool = nv_flip::FlipPool::from_image(&image);
    let (min, max) = data
        .iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    FlipStats {
        mean: f64::from(pool.mean()),
        weighted_median: f64::from(pool.get_percentile(0.5, true)),
        q1: f64::from(pool.get_percentile(0.25, true)),
        q3: f64::from(pool.get_percentile(0.75, true)),
        min: f64::from(min),
        max: f64::from(max),
    }
}

/// Write a ꟻLIP error map as an 8-bit PNG coloured with ꟻLIP's magma
/// palette (black = no error, light yellow = 1), atomically.
pub fn write_flip_map(path: &Path, map: &Array2<f32>) -> Result<(), Error> {
    check_png_name(path)?;
    let (h, w) = map.dim();
    let data: Vec<f32> = map.iter().copied().collect();
    let values = nv_flip::FlipImageFloat::with_data(w as u32, h as u32, &data);
    let coloured = values.apply_color_lut(&nv_flip::magma_lut());
    write_atomically(path, |tmp| {
        let buf = image::RgbImage::from_raw(w as u32, h as u32, coloured.to_vec())
            .ok_or_else(|| Error::Internal("error map buffer size mismatch".into()))?;
        buf.save_with_format(tmp, image::ImageFormat::Png)
            .map_err(|error| Error::Encode {
                path: path.to_path_buf(),
                what: "error map",
                error,
            })
    })
}

/// The ꟻLIP error map is written as PNG: an [`Error::Argument`] for any
/// other name.
fn check_png_name(path: &Path) -> Result<(), Error> {
    let is_png = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("png"));
    if is_png {
        Ok(())
    } else {
        Err(Error::Argument(format!(
            "{}: the error map is written as PNG; use a .png name",
            path.display()
        )))
    }
}

/// All metrics of `test` against `reference`. Fails when the sizes differ
/// (the error names both sizes), when an image is empty or not RGB.
pub fn compare(test: &LinearImage, reference: &LinearImage) -> Result<ImageMetrics, MetricsError> {
    let map = flip_error_map(test, reference)?;
    Ok(metrics_with_map(test, reference, &map))
}

/// The metrics once the comparison has been checked and the map computed.
fn metrics_with_map(
    test: &LinearImage,
    reference: &LinearImage,
    map: &Array2<f32>,
) -> ImageMetrics {
    ImageMetrics {
        mse: mse(test, reference),
        rel_mse: rel_mse(test, reference),
        psnr: psnr(test, reference, 1.0),
        max_abs_error: max_abs_error(test, reference),
        flip: flip_stats(map),
    }
}

/// The bytes a pixel of two images compared by [`diff_files`] takes at the
/// peak: both linear images, ꟻLIP's inputs, its colour pipeline and error
/// map, and the map's statistics. Measured: `raylab diff` of two PNGs
/// grows by 97 to 103 bytes per pixel beyond the process (crates/cli/tests/
/// memory.rs checks this bound within 10 %).
pub const DIFF_BYTES_PER_PIXEL: u128 = 104;

/// Compare the image file `test` against the image file `reference` (PNG or
/// EXR, read as linear RGB) and, when `error_map` is given, write the ꟻLIP
/// error map there as a magma PNG. Nothing is written when any step fails.
pub fn diff_files(
    test: &Path,
    reference: &Path,
    error_map: Option<&Path>,
) -> Result<ImageMetrics, Error> {
    if let Some(out) = error_map {
        // Checked before the work so a wrong name fails fast.
        check_png_name(out)?;
        raylab::io::check_outputs(
            &[("TEST", test), ("REFERENCE", reference)],
            &[("--out", out)],
        )?;
    }
    let (w, h) = raylab::io::image::dimensions(test)?;
    raylab::film::memory::check(
        || format!("comparing two {w}×{h} images"),
        u128::from(w) * u128::from(h) * DIFF_BYTES_PER_PIXEL,
    )?;
    let a = read_image(test)?;
    let b = read_image(reference)?;
    let map = flip_error_map(&a, &b).map_err(|error| Error::Compare {
        test: Some(test.to_path_buf()),
        reference: reference.to_path_buf(),
        error,
    })?;
    let metrics = metrics_with_map(&a, &b, &map);
    if let Some(out) = error_map {
        write_flip_map(out, &map)?;
    }
    Ok(metrics)
}

impl fmt::Display for ImageMetrics {
    /// A two-column table, one metric per line.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let psnr = if self.psnr.is_infinite() && self.psnr > 0.0 {
            "∞ (identical)".to_string()
        } else {
            format!("{:.2} dB", self.psnr)
        };
        let rows = [
            ("MSE", format!("{:.6e}", self.mse)),
            ("relMSE (ε = 0.01)", format!("{:.6e}", self.rel_mse)),
            ("PSNR (peak 1)", psnr),
            ("max |error|", format!("{:.6}", self.max_abs_error)),
            ("FLIP mean", format!("{:.6}", self.flip.mean)),
            (
                "FLIP weighted median",
                format!("{:.6}", self.flip.weighted_median),
            ),
            ("FLIP 1st weighted quartile", format!("{:.6}", self.flip.q1)),
            ("FLIP 3rd weighted quartile", format!("{:.6}", self.flip.q3)),
            ("FLIP min", format!("{:.6}", self.flip.min)),
            ("FLIP max", format!("{:.6}", self.flip.max)),
        ];
        let width = rows
            .iter()
            .map(|(name, _)| name.chars().count())
            .max()
            .unwrap_or(0);
        for (name, value) in rows {
            let pad = width - name.chars().count();
            writeln!(f, "{name}{:pad$}  {value}", "")?;
        }
        Ok(())
    }
}
