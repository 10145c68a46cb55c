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

use crate::analysis::plot::{Heatmap, LineChart, Palette, Series, SeriesStyle};
use crate::sampler::Sampler;
use anyhow::{bail, Context};
use ndarray::Array2;
use rayon::prelude::*;
use rustfft::num_complex::Complex64;
use rustfft::FftPlanner;
use std::f64::consts::TAU;
use std::path::Path;

/// Sets averaged per parallel task: a fixed chunking (not rayon's adaptive
/// splitting) makes the order of the floating-point sums, and so the
/// result, the same bit for bit on any thread count.
const SETS_PER_TASK: usize = 16;

/// The largest frequency bound accepted (the product costs (2F+1)²·N per
/// set; 512 is far past any useful picture of a pixel's pattern).
pub const MAX_FREQ: usize = 512;

/// The averaged periodogram of M point sets of N points each.
#[derive(Clone, Debug, PartialEq)]
pub struct Periodogram {
    /// The frequency bound F: k ranges over [−F, F]².
    pub freq: usize,
    /// Points per set, N.
    pub points: usize,
    /// Sets averaged, M.
    pub sets: usize,
    /// P(k), indexed `[[ky + F, kx + F]]` (so row 0 is k_y = −F).
    pub power: Array2<f64>,
}

/// One ring of a radial average: the frequencies with |k| rounding to
/// `radius`, i.e. |k| ∈ [radius − ½, radius + ½).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ring {
    /// The ring's centre |k| (an integer, in cycles per unit square).
    pub radius: usize,
    /// Frequencies in the ring.
    pub count: usize,
    /// Mean P over the ring: the radially averaged power.
    pub mean: f64,
    /// Sample variance of P over the ring (divisor count − 1).
    pub variance: f64,
    /// 10·log10(variance / mean²) in dB (Heck et al. 2013); −∞ for a ring
    /// of equal values, NaN when the ring has no power (mean ≤ 10⁻⁹).
    pub anisotropy_db: f64,
}

/// The numbers a table of sampling patterns compares.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpectrumSummary {
    /// Mean P over 0 < |k| ≤ √N/2: how much low-frequency noise (variance
    /// of smooth integrands) the pattern leaves. White noise gives 1; the
    /// bound is ≤ rather than < so that N = 4 still has frequencies (the
    /// four at |k| = 1).
    pub low_freq_power: f64,
    /// Mean of the rings' mean power (rings 1 … F−1).
    pub mean_radial_power: f64,
    /// The largest P(k) over k ≠ 0.
    pub peak_power: f64,
    /// Where it is: (kₓ, k_y) with k_y ≥ 0 (P is symmetric, P(−k) = P(k)),
    /// the smallest |k| among equal peaks.
    pub peak_k: (i64, i64),
    /// Mean anisotropy over the rings with a finite value, in dB.
    pub mean_anisotropy_db: f64,
    /// The white-noise anisotropy of an average over M sets,
    /// 10·log10(1/M) dB.
    pub white_noise_anisotropy_db: f64,
}

impl SpectrumSummary {
    /// |k| of the peak.
    pub fn peak_radius(&self) -> f64 {
        (self.peak_k.0 as f64).hypot(self.peak_k.1 as f64)
    }
}

/// exp(−2πi k·u) for k = −F … F, written into `row` (length 2F+1).
fn phases(u: f64, freq: usize, row: &mut [Complex64]) {
    for (i, z) in row.iter_mut().enumerate() {
        let k = i as f64 - freq as f64;
        // Reduce k·u modulo 1 before scaling by 2π: the argument stays in
        // [0, 2π), where sin and cos are accurate to an ulp.
        let (s, c) = (TAU * (k * u).rem_euclid(1.0)).sin_cos();
        *z = Complex64::new(c, -s);
    }
}

/// The periodogram |Σⱼ exp(−2πi k·xⱼ)|² / N of one point set (not
/// averaged), indexed `[[ky + F, kx + F]]`. An empty set gives zeros.
pub fn set_periodogram(points: &[[f64; 2]], freq: usize) -> Array2<f64> {
    let side = 2 * freq + 1;
    let n = points.len();
    if n == 0 {
        return Array2::zeros((side, side));
    }
    // Y[ky, j] = exp(−2πi ky yⱼ) and X[j, kx] = exp(−2πi kx xⱼ): the sum
    // over j of their products is the matrix product Y·X.
    let mut y = Array2::<Complex64>::zeros((side, n));
    let mut x = Array2::<Complex64>::zeros((n, side));
    let mut row = vec![Complex64::new(0.0, 0.0); side];
    for (j, p) in points.iter().enumerate() {
        phases(p[0], freq, &mut row);
        x.row_mut(j).iter_mut().zip(&row).for_each(|(a, b)| *a = *b);
        phases(p[1], freq, &mut row);
        y.column_mut(j)
            .iter_mut()
            .zip(&row)
            .for_each(|(a, b)| *a = *b);
    }
    let sums = y.dot(&x);
    sums.mapv(|s| s.norm_sqr() / n as f64)
}

/// The average of the periodograms of `sets` point sets, set `m` being
/// `set(m)`; all sets must have `n` points. Runs in parallel over sets;
/// the result does not depend on the thread count.
pub fn periodogram_of(
    sets: usize,
    n: usize,
    freq: usize,
    set: impl Fn(usize) -> Vec<[f64; 2]> + Sync,
) -> Periodogram {
    let side = 2 * freq + 1;
    let tasks = sets.div_ceil(SETS_PER_TASK);
    let partial: Vec<Array2<f64>> = (0..tasks)
        .into_par_iter()
        .map(|t| {
            let mut sum = Array2::<f64>::zeros((side, side));
            for m in t * SETS_PER_TASK..((t + 1) * SETS_PER_TASK).min(sets) {
                let pts = set(m);
                debug_assert_eq!(pts.len(), n, "set {m} has {} points", pts.len());
                sum += &set_periodogram(&pts, freq);
            }
            sum
        })
        .collect();
    let mut power = Array2::<f64>::zeros((side, side));
    for p in &partial {
        power += p;
    }
    if sets > 0 {
        power /= sets as f64;
    }
    Periodogram {
        freq,
        points: n,
        sets,
        power,
    }
}

/// The averaged periodogram of explicit point sets (each of the same size).
pub fn periodogram(sets: &[Vec<[f64; 2]>], freq: usize) -> Periodogram {
    let n = sets.first().map_or(0, Vec::len);
    assert!(
        sets.iter().all(|s| s.len() == n),
        "point sets of different sizes"
    );
    periodogram_of(sets.len(), n, freq, |m| sets[m].clone())
}

/// The `m`-th point set of a sampler: the samples 0 … spp−1 of pixel
/// (m mod 2¹⁶, m div 2¹⁶) with `seed`. Each pixel is an independent
/// realisation of the pattern (its own jitter, rotation or shift).
pub fn sampler_set(sampler: &Sampler, m: usize, seed: u64) -> Vec<[f64; 2]> {
    let (px, py) = ((m & 0xffff) as u32, (m >> 16) as u32);
    (0..sampler.spp())
        .map(|i| {
            let p = sampler.sample(px, py, i, seed);
            [f64::from(p.x), f64::from(p.y)]
        })
        .collect()
}

/// The periodogram of `sampler`, averaged over `sets` pixels (see
/// [`sampler_set`]).
pub fn sampler_periodogram(sampler: &Sampler, sets: usize, freq: usize, seed: u64) -> Periodogram {
    periodogram_of(sets, sampler.spp() as usize, freq, |m| {
        sampler_set(sampler, m, seed)
    })
}

impl Periodogram {
    /// P(kₓ, k_y); panics outside [−F, F]².
    pub fn at(&self, kx: i64, ky: i64) -> f64 {
        let f = self.freq as i64;
        assert!(
            kx.abs() <= f && ky.abs() <= f,
            "k = ({kx}, {ky}) outside ±{f}"
        );
        self.power[[(ky + f) as usize, (kx + f) as usize]]
    }

    /// Every (kₓ, k_y, P) of the square.
    fn entries(&self) -> impl Iterator<Item = (i64, i64, f64)> + '_ {
        let f = self.freq as i64;
        self.power
            .indexed_iter()
            .map(move |((r, c), &p)| (c as i64 - f, r as i64 - f, p))
    }

    /// The rings r = 1 … F−1 (ring F would be cut by the edges of the
    /// square, which reach only |k| = F along the axes).
    pub fn rings(&self) -> Vec<Ring> {
        let nr = self.freq.saturating_sub(1);
        let mut members: Vec<Vec<f64>> = vec![Vec::new(); nr];
        for (kx, ky, p) in self.entries() {
            let r = (kx as f64).hypot(ky as f64).round() as usize;
            if (1..=nr).contains(&r) {
                members[r - 1].push(p);
            }
        }
        members
            .iter()
            .enumerate()
            .map(|(i, v)| ring_stats(i + 1, v))
            .collect()
    }

    /// The summary numbers; see [`SpectrumSummary`].
    pub fn summary(&self) -> SpectrumSummary {
        let low_r = (self.points as f64).sqrt() / 2.0;
        let (mut low_sum, mut low_n) = (0.0, 0usize);
        let mut peak: Option<(f64, (i64, i64))> = None;
        for (kx, ky, p) in self.entries() {
            let r = (kx as f64).hypot(ky as f64);
            if r == 0.0 {
                continue;
            }
            if r <= low_r + 1e-9 {
                low_sum += p;
                low_n += 1;
            }
            // One half-plane (k_y > 0, or k_y = 0 and kₓ > 0): P(−k) = P(k).
            if ky < 0 || (ky == 0 && kx < 0) {
                continue;
            }
            let better = match peak {
                None => true,
                Some((q, (qx, qy))) => {
                    let tol = 1e-9 * q.abs().max(p.abs());
                    p > q + tol || ((p - q).abs() <= tol && r < (qx as f64).hypot(qy as f64) - 1e-9)
                }
            };
            if better {
                peak = Some((p, (kx, ky)));
            }
        }
        let rings = self.rings();
        let finite: Vec<f64> = rings
            .iter()
            .map(|r| r.anisotropy_db)
            .filter(|a| a.is_finite())
            .collect();
        let mean = |v: &[f64]| {
            if v.is_empty() {
                f64::NAN
            } else {
                v.iter().sum::<f64>() / v.len() as f64
            }
        };
        let ring_means: Vec<f64> = rings.iter().map(|r| r.mean).collect();
        let (peak_power, peak_k) = peak.unwrap_or((f64::NAN, (0, 0)));
        SpectrumSummary {
            low_freq_power: if low_n > 0 {
                low_sum / low_n as f64
            } else {
                f64::NAN
            },
            mean_radial_power: mean(&ring_means),
            peak_power,
            peak_k,
            mean_anisotropy_db: mean(&finite),
            white_noise_anisotropy_db: white_noise_anisotropy_db(self.sets),
        }
    }
}

/// 10·log10(1/M): the anisotropy of white noise averaged over M sets (see
/// the module documentation for the exact 10·log10((1 − 1/N)/M)).
pub fn white_noise_anisotropy_db(sets: usize) -> f64 {
    -10.0 * (sets.max(1) as f64).log10()
}

/// Ring mean power at or below which a ring counts as empty (anisotropy
/// NaN): far above f64 rounding of the sums (~10⁻³⁰ for a grid's zeros),
/// far below any real pattern's power.
const NO_POWER: f64 = 1e-9;

/// Mean, sample variance and anisotropy of the values of one ring.
fn ring_stats(radius: usize, values: &[f64]) -> Ring {
    let n = values.len();
    let mean = values.iter().sum::<f64>() / n.max(1) as f64;
    let variance = if n > 1 {
        values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64
    } else {
        f64::NAN
    };
    // A ring without power (an ordered grid between its peaks) holds only
    // rounding noise, ~10⁻³⁰, whose "anisotropy" would be meaningless.
    let anisotropy_db = if mean > NO_POWER {
        10.0 * (variance / (mean * mean)).log10()
    } else {
        f64::NAN
    };
    Ring {
        radius,
        count: n,
        mean,
        variance,
        anisotropy_db,
    }
}

// ---------------------------------------------------------------------------
// Image power spectra

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
    let mut planner = FftPlanner::<f64>::new();
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

// ---------------------------------------------------------------------------
// Curves, files and figures

/// The radial data of one pattern, as plotted and as written to CSV.
#[derive(Clone, Debug, PartialEq)]
pub struct RadialCurve {
    /// Legend text (a sampler name).
    pub label: String,
    /// Points per set, N.
    pub points: usize,
    /// Sets averaged, M.
    pub sets: usize,
    /// The rings.
    pub rings: Vec<Ring>,
}

impl RadialCurve {
    /// The rings of `p`, labelled.
    pub fn new(label: impl Into<String>, p: &Periodogram) -> Self {
        Self {
            label: label.into(),
            points: p.points,
            sets: p.sets,
            rings: p.rings(),
        }
    }
}

/// Header of the per-ring CSV written by [`write_rings_csv`].
const RINGS_HEADER: [&str; 8] = [
    "sampler",
    "spp",
    "sets",
    "radius",
    "count",
    "mean_power",
    "variance",
    "anisotropy_db",
];

/// Write the rings of every curve to `path` in long format (one row per
/// curve and ring; columns [`RINGS_HEADER`]), atomically.
pub fn write_rings_csv(path: &Path, curves: &[RadialCurve]) -> anyhow::Result<()> {
    crate::io::write_atomically(path, |tmp| {
        let mut w = csv::Writer::from_path(tmp)
            .with_context(|| format!("{}: cannot create", path.display()))?;
        w.write_record(RINGS_HEADER)?;
        for c in curves {
            for r in &c.rings {
                w.write_record([
                    c.label.clone(),
                    c.points.to_string(),
                    c.sets.to_string(),
                    r.radius.to_string(),
                    r.count.to_string(),
                    format!("{:.9e}", r.mean),
                    format!("{:.9e}", r.variance),
                    format!("{:.6}", r.anisotropy_db),
                ])?;
            }
        }
        w.flush()
            .with_context(|| format!("{}: cannot write", path.display()))?;
        Ok(())
    })
}

/// Read a CSV written by [`write_rings_csv`] back into curves, in the
/// order their labels first appear.
pub fn read_rings_csv(path: &Path) -> anyhow::Result<Vec<RadialCurve>> {
    let mut reader =
        csv::Reader::from_path(path).with_context(|| format!("{}: cannot read", path.display()))?;
    let header: Vec<String> = reader
        .headers()
        .with_context(|| format!("{}:1: cannot read the header", path.display()))?
        .iter()
        .map(str::to_string)
        .collect();
    if header != RINGS_HEADER {
        bail!(
            "{}:1: expected the columns {}, found {}",
            path.display(),
            RINGS_HEADER.join(","),
            header.join(",")
        );
    }
    let mut curves: Vec<RadialCurve> = Vec::new();
    for (i, record) in reader.records().enumerate() {
        let line = i + 2;
        let record = record.with_context(|| format!("{}:{line}: cannot read", path.display()))?;
        let num = |col: usize| -> anyhow::Result<f64> {
            record[col].parse::<f64>().with_context(|| {
                format!(
                    "{}:{line}: `{}` is not a number ({})",
                    path.display(),
                    &record[col],
                    RINGS_HEADER[col]
                )
            })
        };
        let int = |col: usize| -> anyhow::Result<usize> {
            record[col].parse::<usize>().with_context(|| {
                format!(
                    "{}:{line}: `{}` is not a count ({})",
                    path.display(),
                    &record[col],
                    RINGS_HEADER[col]
                )
            })
        };
        let ring = Ring {
            radius: int(3)?,
            count: int(4)?,
            mean: num(5)?,
            variance: num(6)?,
            anisotropy_db: num(7)?,
        };
        let label = &record[0];
        match curves.iter_mut().find(|c| c.label == label) {
            Some(c) => c.rings.push(ring),
            None => curves.push(RadialCurve {
                label: label.to_string(),
                points: int(1)?,
                sets: int(2)?,
                rings: vec![ring],
            }),
        }
    }
    Ok(curves)
}

/// The periodogram as a log-scale heatmap with k_y up and DC (always
/// P(0) = N) in the middle, drawn grey so that the colours span the rest;
/// values below 10⁻² are drawn as 10⁻² (the colour bar says so): an
/// ordered grid's zeros are rounding noise of ~10⁻³⁰.
pub fn periodogram_heatmap(p: &Periodogram, title: impl Into<String>) -> Heatmap {
    const FLOOR: f64 = 1e-2;
    let f = p.freq as f64;
    let side = p.power.nrows();
    // Row 0 of a heatmap is drawn at the top: flip so k_y grows upwards.
    let data = Array2::from_shape_fn(p.power.dim(), |(r, c)| {
        if r == p.freq && c == p.freq {
            f64::NAN
        } else {
            p.power[[side - 1 - r, c]].max(FLOOR)
        }
    });
    let mut map = Heatmap::new(title, data);
    map.log_scale = true;
    map.palette = Palette::Magma;
    map.value_label = "P(k), log scale (< 10⁻² shown as 10⁻²; DC grey)".into();
    map.x_label = "kₓ (cycles per pixel)".into();
    map.y_label = "k_y".into();
    map.extent = Some([-f - 0.5, f + 0.5, -f - 0.5, f + 0.5]);
    map
}

/// The distinct N of `curves`, in order of appearance.
fn sample_counts(curves: &[RadialCurve]) -> Vec<usize> {
    let mut ns: Vec<usize> = Vec::new();
    for c in curves {
        if !ns.contains(&c.points) {
            ns.push(c.points);
        }
    }
    ns
}

/// Radial power against |k| for each curve (linear axes, as Heck et al.
/// draw it), with the white-noise line at 1 and a vertical line at each
/// pattern's sampling rate √N.
pub fn radial_chart(curves: &[RadialCurve], title: impl Into<String>) -> LineChart {
    let mut chart = LineChart::new(title, "|k| (cycles per pixel)", "radially averaged power P");
    let mut top: f64 = 1.0;
    let mut right: f64 = 1.0;
    for c in curves {
        let pts: Vec<(f64, f64)> = c.rings.iter().map(|r| (r.radius as f64, r.mean)).collect();
        top = pts.iter().map(|p| p.1).fold(top, f64::max);
        right = pts.iter().map(|p| p.0).fold(right, f64::max);
        chart
            .series
            .push(Series::new(c.label.clone(), pts, SeriesStyle::LinePoints));
    }
    chart.series.push(Series::new(
        "white noise (P = 1)",
        vec![(0.0, 1.0), (right, 1.0)],
        SeriesStyle::Dashed,
    ));
    for n in sample_counts(curves) {
        let s = (n as f64).sqrt();
        chart.series.push(Series::new(
            format!(
                "sampling rate √N = {} (N = {n})",
                crate::analysis::plot::format_tick(s)
            ),
            vec![(s, 0.0), (s, top)],
            SeriesStyle::Dashed,
        ));
    }
    chart
}

/// Anisotropy per ring for each curve, with the white-noise reference
/// 10·log10(1/M) for each distinct M.
pub fn anisotropy_chart(curves: &[RadialCurve], title: impl Into<String>) -> LineChart {
    let mut chart = LineChart::new(title, "|k| (cycles per pixel)", "anisotropy (dB)");
    let mut right: f64 = 1.0;
    for c in curves {
        let pts: Vec<(f64, f64)> = c
            .rings
            .iter()
            .map(|r| (r.radius as f64, r.anisotropy_db))
            .collect();
        right = pts.iter().map(|p| p.0).fold(right, f64::max);
        chart
            .series
            .push(Series::new(c.label.clone(), pts, SeriesStyle::LinePoints));
    }
    let mut ms: Vec<usize> = curves.iter().map(|c| c.sets).collect();
    ms.sort_unstable();
    ms.dedup();
    for m in ms {
        let a = white_noise_anisotropy_db(m);
        chart.series.push(Series::new(
            format!("white noise, 10·log10(1/M) = {a:.1} dB (M = {m})"),
            vec![(0.0, a), (right, a)],
            SeriesStyle::Dashed,
        ));
    }
    chart
}

// ---------------------------------------------------------------------------
// Sampling-pattern reports (`raylab spectrum`, the `aa_patterns` study)

/// The largest number of sets accepted (a typo guard: 10⁶ sets of 64
/// points at F = 32 is already minutes of work).
pub const MAX_SETS: usize = 1_000_000;

/// Check a set count and a frequency bound, saying what is expected.
pub fn check_sets_and_freq(sets: usize, freq: usize) -> Result<(), String> {
    if !(1..=MAX_SETS).contains(&sets) {
        return Err(format!(
            "the number of point sets must be in 1..={MAX_SETS}, got {sets}"
        ));
    }
    if !(2..=MAX_FREQ).contains(&freq) {
        return Err(format!(
            "the frequency bound F must be in 2..={MAX_FREQ} (rings 1 … F−1 are reported), got {freq}"
        ));
    }
    Ok(())
}

/// One sampling pattern's spectrum, labelled.
#[derive(Clone, Debug, PartialEq)]
pub struct PatternSpectrum {
    /// How the user named the sampler (`jitter:4`).
    pub label: String,
    /// The sampler.
    pub sampler: Sampler,
    /// Its periodogram.
    pub periodogram: Periodogram,
    /// Its summary numbers.
    pub summary: SpectrumSummary,
}

impl PatternSpectrum {
    /// Compute the periodogram of `sampler` over `sets` pixels.
    pub fn compute(
        label: impl Into<String>,
        sampler: Sampler,
        sets: usize,
        freq: usize,
        seed: u64,
    ) -> Self {
        let periodogram = sampler_periodogram(&sampler, sets, freq, seed);
        let summary = periodogram.summary();
        Self {
            label: label.into(),
            sampler,
            periodogram,
            summary,
        }
    }

    /// Its rings as a curve.
    pub fn curve(&self) -> RadialCurve {
        RadialCurve::new(self.label.clone(), &self.periodogram)
    }

    /// Write its periodogram image as `stem.png` and `stem.svg`.
    pub fn save_heatmap(&self, stem: &Path) -> anyhow::Result<()> {
        let p = &self.periodogram;
        periodogram_heatmap(
            p,
            format!(
                "Periodogram of {} (N = {}, mean of M = {} sets)",
                self.label, p.points, p.sets
            ),
        )
        .save(stem)
    }
}

/// Write the files of `raylab spectrum` into `out` (created if missing):
/// the periodogram image `spectrum.png`/`.svg` (one sampler) or
/// `spectrum-NAME.png`/`.svg` (several), the overlaid `radial` and
/// `anisotropy` charts (PNG + SVG) and `spectrum.csv` (every ring of every
/// sampler). Returns the paths written.
pub fn write_spectra(out: &Path, spectra: &[PatternSpectrum]) -> anyhow::Result<Vec<String>> {
    std::fs::create_dir_all(out)
        .with_context(|| format!("{}: cannot create the output folder", out.display()))?;
    let mut written = Vec::new();
    for s in spectra {
        let stem = if spectra.len() == 1 {
            "spectrum".to_string()
        } else {
            format!("spectrum-{}", s.sampler.name())
        };
        s.save_heatmap(&out.join(&stem))?;
        written.push(format!("{stem}.png"));
    }
    let curves: Vec<RadialCurve> = spectra.iter().map(PatternSpectrum::curve).collect();
    radial_chart(&curves, "Radially averaged power of the sampling patterns")
        .save(&out.join("radial"))?;
    anisotropy_chart(&curves, "Anisotropy of the sampling patterns")
        .save(&out.join("anisotropy"))?;
    write_rings_csv(&out.join("spectrum.csv"), &curves)?;
    written.extend([
        "radial.png".into(),
        "anisotropy.png".into(),
        "spectrum.csv".into(),
    ]);
    Ok(written)
}

/// A plain-text table of the summaries, one line per sampler.
pub fn summary_table(spectra: &[PatternSpectrum]) -> String {
    use std::fmt::Write as _;
    let mut t = String::new();
    let _ = writeln!(
        t,
        "{:<12} {:>5} {:>7} {:>12} {:>12} {:>11} {:>13} {:>15}",
        "sampler",
        "N",
        "sets",
        "P(|k|≤√N/2)",
        "mean radial",
        "peak P",
        "at k (|k|)",
        "anisotropy dB"
    );
    for s in spectra {
        let m = &s.summary;
        let _ = writeln!(
            t,
            "{:<12} {:>5} {:>7} {:>12.4} {:>12.4} {:>11.4} {:>13} {:>15.2}",
            s.label,
            s.periodogram.points,
            s.periodogram.sets,
            m.low_freq_power,
            m.mean_radial_power,
            m.peak_power,
            format!("({},{}) {:.2}", m.peak_k.0, m.peak_k.1, m.peak_radius()),
            m.mean_anisotropy_db,
        );
    }
    if let Some(s) = spectra.first() {
        let _ = writeln!(
            t,
            "white noise: P = 1 at every k ≠ 0; anisotropy 10·log10(1/M) = {:.2} dB for M = {}",
            s.summary.white_noise_anisotropy_db, s.periodogram.sets
        );
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Phases are exact at the quarter turns and conjugate-symmetric.
    #[test]
    fn phases_are_unit_and_symmetric() {
        let mut row = vec![Complex64::new(0.0, 0.0); 9];
        phases(0.25, 4, &mut row);
        // k = 1 (index 5): exp(−iπ/2) = −i.
        assert!((row[5] - Complex64::new(0.0, -1.0)).norm() < 1e-15);
        for i in 0..9 {
            assert!((row[i].norm() - 1.0).abs() < 1e-15);
            assert!((row[i] - row[8 - i].conj()).norm() < 1e-15);
        }
    }

    /// Ring statistics of known values.
    #[test]
    fn ring_stats_of_known_values() {
        let r = ring_stats(3, &[1.0, 3.0]);
        assert_eq!((r.radius, r.count, r.mean, r.variance), (3, 2, 2.0, 2.0));
        assert!((r.anisotropy_db - 10.0 * 0.5f64.log10()).abs() < 1e-12);
        // Rounding noise has no anisotropy.
        assert!(ring_stats(1, &[0.0, 3e-30]).anisotropy_db.is_nan());
    }
}
