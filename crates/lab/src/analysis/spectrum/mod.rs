//! Spectra: how sample points and image errors are spread over frequency.
//!
//! Two analyses live here, both at the analysis end of the data flow:
//!
//! - **Point-set periodograms** of sampling patterns (one pixel's samples
//!   as a point set in the unit square), as defined by Heck, Schlömer and
//!   Deussen, "Blue Noise Sampling with Controlled Aliasing", ACM TOG 32(3),
//!   2013, §3: for integer frequency vectors k,
//!
//!   P(k) = |Σⱼ exp(−2πi k·xⱼ)|² / N,
//!
//!   averaged over M independent point sets. This is the definition, a
//!   direct sum over integer frequencies (no FFT, no gridding of the
//!   points). It factorises, exp(−2πi(kₓx + k_y y)) = exp(−2πi kₓx)·exp(−2πi k_y y),
//!   so one set's sums for all k ∈ [−F, F]² are one complex matrix product
//!   of the (2F+1)×N matrix exp(−2πi k_y yⱼ) by the N×(2F+1) matrix
//!   exp(−2πi kₓxⱼ), computed in f64. From it come the radially averaged
//!   power (rings of width 1 in |k|, DC excluded) and the anisotropy
//!   10·log10(variance in the ring / (ring mean)²) in dB (Heck et al. §3.2).
//!
//!   White noise (N independent uniform points) is the reference: for
//!   k ≠ 0, E[P(k)] = 1 exactly and Var[P(k)] = 1 − 1/N (expand |Σ|⁴: only
//!   the pairings j = l, m = n and j = n, m = l survive, 2N² − N terms),
//!   and P at different frequencies (other than ±k) is uncorrelated, so
//!   the anisotropy of an average over M sets is about
//!   10·log10((1 − 1/N)/M) ≈ 10·log10(1/M) dB.
//!
//! - **Image power spectra** of 2D fields (typically a luminance error
//!   image against a converged reference): |DFT|² / pixel count via
//!   `rustfft`, shifted so DC is in the middle, and its radial profile in
//!   cycles per pixel. Aliasing shows up as power at low frequencies that
//!   the reference does not have.
//!
//! Layout, one concept per file: `periodogram.rs` (point-set
//! periodograms, their rings and summary numbers), `image_spectrum.rs`
//! (power spectra of 2D fields and their radial profiles), `curves.rs` (the
//! radial data of a pattern as written to and read from CSV, and the
//! heatmap and charts drawn from it) and `patterns.rs` (the sampling-pattern
//! report of `raylab spectrum` and the `aa_patterns` study). Everything
//! public is re-exported here, so callers name it
//! `crate::analysis::spectrum::…`.

mod curves;
mod image_spectrum;
mod patterns;
mod periodogram;

pub use curves::{
    anisotropy_chart, periodogram_heatmap, radial_chart, read_rings_csv, write_rings_csv,
    RadialCurve,
};
pub use image_spectrum::{power_spectrum, radial_profile};
pub use patterns::{check_sets_and_freq, summary_table, write_spectra, PatternSpectrum, MAX_SETS};
pub use periodogram::{
    periodogram, periodogram_of, sampler_periodogram, sampler_set, set_periodogram,
    white_noise_anisotropy_db, Periodogram, Ring, SpectrumSummary, MAX_FREQ,
};
