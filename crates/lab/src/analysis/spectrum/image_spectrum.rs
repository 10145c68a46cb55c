//! Image power spectra: |DFT|² of a 2D field (typically a luminance error
//! image against a converged reference) via `rustfft` (its scalar planner:
//! see the crate's Cargo.toml), shifted so DC is in the middle, and its
//! radial profile in cycles per pixel. Part of [`crate::analysis::spectrum`].

use ndarray::Array2;
use rustfft::num_complex::Complex64;
use rustfft::FftPlannerScalar;

/// The power spectrum |DFT(image)|² / (rows·columns) of a 2D field (rows
/// are image rows), shifted so the DC term sits at (rows/2, columns/2)
/// (integer division, numpy's `fftshift`): entry (r, c) is the frequency
/// ((c − W/2)/W, (r − H/2)/H) in cycles per pixel. With this scaling the
/// entries sum to the sum of squares of the image (Parseval), so white
/// noise of variance σ² has an expected flat spectrum σ².
pub fn power_spectrum(image: &Array2<f64>) -> Array2<f64> {
    let (h, w) = image.dim();
    if h == 0 || w == 0 {
        return Array2::zeros((h, w));
    }
    let mut planner = FftPlannerScalar::<f64>::new();
    let mut data: Vec<Complex64> = image.iter().map(|&v| Complex64::new(v, 0.0)).collect();
    // Rows (contiguous in the standard layout), then columns via a buffer.
    planner.plan_fft_forward(w).process(&mut data);
    let col_fft = planner.plan_fft_forward(h);
    let mut col = vec![Complex64::new(0.0, 0.0); h];
    for c in 0..w {
        for r in 0..h {
            col[r] = data[r * w + c];
        }
        col_fft.process(&mut col);
        for r in 0..h {
            data[r * w + c] = col[r];
        }
    }
    let scale = 1.0 / (h * w) as f64;
    Array2::from_shape_fn((h, w), |(r, c)| {
        // Shifted (r, c) holds unshifted ((r + H − H/2) mod H, …).
        let (ur, uc) = ((r + h - h / 2) % h, (c + w - w / 2) % w);
        data[ur * w + uc].norm_sqr() * scale
    })
}

/// The radial profile of a shifted power spectrum (as [`power_spectrum`]
/// returns): mean power in rings of width Δ = 1/min(H, W) cycles per
/// pixel, ring b holding the frequencies with |f|/Δ rounding to b, for
/// b = 1 … up to 0.5 cycles per pixel (Nyquist, the largest complete
/// ring). DC (the squared mean, i.e. bias) is left out. Returns
/// (ring centre b·Δ in cycles per pixel, mean power) pairs.
pub fn radial_profile(spectrum: &Array2<f64>) -> Vec<(f64, f64)> {
    let (h, w) = spectrum.dim();
    if h == 0 || w == 0 {
        return Vec::new();
    }
    let delta = 1.0 / h.min(w) as f64;
    let bins = (0.5 / delta).floor() as usize;
    let mut sum = vec![0.0; bins];
    let mut count = vec![0usize; bins];
    for ((r, c), &p) in spectrum.indexed_iter() {
        let fy = (r as f64 - (h / 2) as f64) / h as f64;
        let fx = (c as f64 - (w / 2) as f64) / w as f64;
        let b = (fx.hypot(fy) / delta).round() as usize;
        if (1..=bins).contains(&b) {
            sum[b - 1] += p;
            count[b - 1] += 1;
        }
    }
    (0..bins)
        .filter(|&i| count[i] > 0)
        .map(|i| ((i + 1) as f64 * delta, sum[i] / count[i] as f64))
        .collect()
}
