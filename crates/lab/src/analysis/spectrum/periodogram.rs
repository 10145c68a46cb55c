//! Point-set periodograms of sampling patterns (Heck, Schlömer and Deussen
//! 2013; see [`super`] for the definition and the white-noise reference):
//! one set's periodogram as a complex matrix product, the average over M
//! sets in parallel (bit-identical on any thread count), its rings and the
//! summary numbers a table of patterns compares. Part of
//! [`crate::analysis::spectrum`].

use ndarray::Array2;
use raylab::sampler::Sampler;
use rayon::prelude::*;
use rustfft::num_complex::Complex64;
use std::f64::consts::TAU;

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
