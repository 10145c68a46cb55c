//! Spectra: the point-set periodogram against its definition and against
//! what theory says of white noise, ordered grids and jitter; the image
//! power spectrum against a naive 2D DFT; `raylab spectrum` and the
//! `aa_patterns` study end to end.
//!
//! Statistical tolerances come from white noise: for N independent uniform
//! points and integer k ≠ 0, E[P(k)] = 1 and Var[P(k)] = 1 − 1/N, and P at
//! k and k' ≠ ±k are uncorrelated (expand |Σ|⁴), while P(−k) = P(k). So a
//! mean over M sets and c frequencies of a ring (c/2 independent ones)
//! has standard deviation √((1 − 1/N) / (M·c/2)). Seeds are fixed, so a
//! test that passes passes every time; 5σ bounds say the numbers are
//! right, not lucky.

use crate::raylab;
use ndarray::Array2;
use raylab::math::SplitMix64;
use raylab::sampler::Sampler;
use raylab_lab::analysis::spectrum::{
    periodogram, power_spectrum, radial_profile, sampler_periodogram, set_periodogram,
    white_noise_anisotropy_db,
};
use raylab_lab::experiment::{run_experiment, ExperimentOptions};
use std::f64::consts::{PI, TAU};

fn sampler(s: &str) -> Sampler {
    Sampler::parse(s).unwrap()
}

/// Uniform random numbers in [0, 1) for test data.
fn uniform(seed: u64, n: usize) -> Vec<f64> {
    let mut r = SplitMix64(seed);
    (0..n).map(|_| r.next_f32() as f64).collect()
}

/// The definition, written directly: a double loop over frequencies and
/// points, with the phase 2π k·x taken whole (no factorisation, no
/// reduction modulo 1).
fn naive_periodogram(points: &[[f64; 2]], freq: i64) -> Array2<f64> {
    let side = (2 * freq + 1) as usize;
    let mut p = Array2::zeros((side, side));
    for ky in -freq..=freq {
        for kx in -freq..=freq {
            let (mut re, mut im) = (0.0, 0.0);
            for x in points {
                let phase = -TAU * (kx as f64 * x[0] + ky as f64 * x[1]);
                re += phase.cos();
                im += phase.sin();
            }
            p[[(ky + freq) as usize, (kx + freq) as usize]] =
                (re * re + im * im) / points.len() as f64;
        }
    }
    p
}

/// The fast periodogram (factorised matrix product) equals the direct sum.
/// Both add N ≤ 13 unit phasors in f64 with phase errors ~|k|·10⁻¹⁶, so
/// they agree to ~10⁻¹³ absolutely; 10⁻⁶ of max(P, 1) is the required
/// bar and leaves no room for a wrong sign or index.
#[test]
fn fast_periodogram_matches_the_direct_sum() {
    for (seed, n, freq) in [(1u64, 13usize, 7i64), (2, 1, 3), (3, 5, 10)] {
        let u = uniform(seed, 2 * n);
        let pts: Vec<[f64; 2]> = (0..n).map(|j| [u[2 * j], u[2 * j + 1]]).collect();
        let fast = set_periodogram(&pts, freq as usize);
        let slow = naive_periodogram(&pts, freq);
        assert_eq!(fast.dim(), slow.dim());
        for (a, b) in fast.iter().zip(slow.iter()) {
            assert!((a - b).abs() <= 1e-6 * b.max(1.0), "{a} vs {b}");
        }
        // DC is always N (every phasor is 1).
        assert!((fast[[freq as usize, freq as usize]] - n as f64).abs() < 1e-12);
    }
}

/// Averaging: the periodogram of several sets is the mean of theirs, and
/// does not depend on the thread count, bit for bit.
#[test]
fn averaging_is_the_mean_and_thread_independent() {
    let sets: Vec<Vec<[f64; 2]>> = (0..37)
        .map(|m| {
            let u = uniform(100 + m, 8);
            (0..4).map(|j| [u[2 * j], u[2 * j + 1]]).collect()
        })
        .collect();
    let avg = periodogram(&sets, 5);
    let mut sum = Array2::<f64>::zeros((11, 11));
    for s in &sets {
        sum += &set_periodogram(s, 5);
    }
    sum /= sets.len() as f64;
    // Sums of 37 values in a different order: a few ulps of ~1.
    assert!(avg
        .power
        .iter()
        .zip(&sum)
        .all(|(a, b)| (a - b).abs() < 1e-12));

    let s = sampler("jitter:4");
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| sampler_periodogram(&s, 100, 6, 9));
    let three = rayon::ThreadPoolBuilder::new()
        .num_threads(3)
        .build()
        .unwrap()
        .install(|| sampler_periodogram(&s, 100, 6, 9));
    assert_eq!(one, three);
}

/// A k×k ordered grid at sub-pixel centres: Σⱼ exp(−2πi kₓ(i + ½)/k) is
/// k·(±1) when k divides kₓ and 0 otherwise, so P = N at every multiple
/// of k (both coordinates) and 0 elsewhere. The grid's coordinates and
/// phases are exact in binary, so "0" holds to rounding, far below 10⁻⁹.
#[test]
fn ordered_grid_has_peaks_exactly_at_multiples_of_k() {
    for k in [2i64, 4] {
        let s = sampler(&format!("ogss:{k}"));
        let n = (k * k) as f64;
        let p = sampler_periodogram(&s, 4, 12, 0);
        for ky in -12..=12 {
            for kx in -12..=12 {
                let v = p.at(kx, ky);
                if kx % k == 0 && ky % k == 0 {
                    assert!((v - n).abs() < 1e-9, "k={k}: P({kx},{ky}) = {v}");
                } else {
                    assert!(v.abs() < 1e-9, "k={k}: P({kx},{ky}) = {v}");
                }
            }
        }
        let m = p.summary();
        assert!((m.peak_power - n).abs() < 1e-9);
        assert_eq!(m.peak_k, (k, 0));
    }
}

/// White noise: every ring's mean power is 1 within 5σ, σ = √((1 − 1/N) /
/// (M·c/2)) for a ring of c frequencies, and the mean over all rings is 1
/// within 5σ of the pooled count.
#[test]
fn random_points_have_flat_unit_radial_power() {
    let (m, n) = (256usize, 16.0f64);
    let p = sampler_periodogram(&sampler("random:16"), m, 24, 7);
    let rings = p.rings();
    assert_eq!(rings.len(), 23);
    let mut total = 0usize;
    let mut weighted = 0.0;
    for r in &rings {
        let sigma = ((1.0 - 1.0 / n) / (m as f64 * r.count as f64 / 2.0)).sqrt();
        assert!(
            (r.mean - 1.0).abs() < 5.0 * sigma,
            "ring {}: mean {} (σ {sigma})",
            r.radius,
            r.mean
        );
        total += r.count;
        weighted += r.mean * r.count as f64;
    }
    let pooled = weighted / total as f64;
    let sigma = ((1.0 - 1.0 / n) / (m as f64 * total as f64 / 2.0)).sqrt();
    assert!((pooled - 1.0).abs() < 5.0 * sigma, "{pooled} (σ {sigma})");
}

/// Anisotropy: white noise sits near 10·log10(1/M); a grid is far above.
///
/// For random points each ring's variance/mean² estimates (1 − 1/N)/M;
/// the log of a variance estimated from ~πr independent values has a
/// spread of ~4.3·√(2/(πr)) dB (3.5 dB at r = 1, under 1 dB at r = 20)
/// and a downward bias of the same order divided by √(πr), so the mean
/// over 23 rings lies within about 0.5 dB (1σ) of the line: 2 dB is four
/// of those. The 4×4 grid's ring 4 holds its four peaks P = 16 among
/// ~24 zeros: variance/mean² ≈ 6, about +8 dB, 30 dB above white noise.
#[test]
fn anisotropy_of_random_and_grid() {
    let m = 256;
    let random = sampler_periodogram(&sampler("random:16"), m, 24, 3).summary();
    let reference = white_noise_anisotropy_db(m);
    assert!((reference + 24.08).abs() < 0.01);
    let exact = 10.0 * ((1.0 - 1.0 / 16.0) / m as f64).log10();
    assert!(
        (random.mean_anisotropy_db - exact).abs() < 2.0,
        "random: {} dB, expected about {exact} dB",
        random.mean_anisotropy_db
    );

    let grid = sampler_periodogram(&sampler("ogss:4"), m, 24, 3);
    // Between its peaks the grid has no power, so no anisotropy.
    assert!(grid.rings()[0].anisotropy_db.is_nan());
    let ring4 = grid.rings()[3];
    assert_eq!(ring4.radius, 4);
    assert!(ring4.anisotropy_db > 5.0, "{}", ring4.anisotropy_db);
    assert!(ring4.anisotropy_db > reference + 25.0);
}

/// Jitter removes low-frequency power. For K×K jittered strata and k not
/// a multiple of K, E[P(k)] = 1 − sinc²(πkₓ/K)·sinc²(πk_y/K) (the points
/// are a grid plus uniform cell offsets; the grid term vanishes there).
/// The 12 frequencies with 0 < |k| ≤ √16/2 = 2 then average 0.376, far
/// below white noise's 1. Both are checked within 5σ, σ = √(1/(M·6))
/// (6 independent frequencies; jitter's variance is below white noise's).
#[test]
fn jitter_has_less_low_frequency_power_than_random() {
    let m = 256;
    let jitter = sampler_periodogram(&sampler("jitter:4"), m, 8, 5).summary();
    let random = sampler_periodogram(&sampler("random:16"), m, 8, 5).summary();
    let sinc = |x: f64| if x == 0.0 { 1.0 } else { x.sin() / x };
    let mut expected = 0.0;
    let mut count = 0;
    for ky in -2i32..=2 {
        for kx in -2i32..=2 {
            let r2 = kx * kx + ky * ky;
            if r2 == 0 || r2 > 4 {
                continue;
            }
            let s = sinc(PI * kx as f64 / 4.0) * sinc(PI * ky as f64 / 4.0);
            expected += 1.0 - s * s;
            count += 1;
        }
    }
    assert_eq!(count, 12);
    expected /= count as f64;
    assert!((expected - 0.376).abs() < 0.001, "{expected}");
    let sigma = (1.0 / (m as f64 * 6.0)).sqrt();
    assert!(
        (jitter.low_freq_power - expected).abs() < 5.0 * sigma,
        "jitter {} vs {expected}",
        jitter.low_freq_power
    );
    assert!((random.low_freq_power - 1.0).abs() < 5.0 * sigma);
    assert!(jitter.low_freq_power < random.low_freq_power - 0.4);
}

/// The naive 2D DFT, shifted as numpy's fftshift: entry (r, c) is the
/// frequency index (r − H/2, c − W/2).
fn naive_power_spectrum(img: &Array2<f64>) -> Array2<f64> {
    let (h, w) = img.dim();
    Array2::from_shape_fn((h, w), |(r, c)| {
        let (ky, kx) = (r as f64 - (h / 2) as f64, c as f64 - (w / 2) as f64);
        let (mut re, mut im) = (0.0, 0.0);
        for ((y, x), v) in img.indexed_iter() {
            let phase = -TAU * (kx * x as f64 / w as f64 + ky * y as f64 / h as f64);
            re += v * phase.cos();
            im += v * phase.sin();
        }
        (re * re + im * im) / (h * w) as f64
    })
}

/// FFT power spectrum = naive DFT (odd and even sizes, not square), to
/// 10⁻⁶ of the largest entry: both are f64 sums of 40–63 terms, accurate
/// to ~10⁻¹⁴ of the total power. Parseval: the entries sum to Σ image².
#[test]
fn image_power_spectrum_matches_a_naive_dft() {
    for (h, w, seed) in [(5usize, 8usize, 1u64), (7, 9, 2), (6, 6, 3)] {
        let u = uniform(seed, h * w);
        let img = Array2::from_shape_vec((h, w), u.iter().map(|v| v - 0.3).collect()).unwrap();
        let fast = power_spectrum(&img);
        let slow = naive_power_spectrum(&img);
        let top = slow.iter().copied().fold(0.0, f64::max);
        for (a, b) in fast.iter().zip(slow.iter()) {
            assert!((a - b).abs() <= 1e-6 * top, "{h}×{w}: {a} vs {b}");
        }
        let energy: f64 = img.iter().map(|v| v * v).sum();
        assert!((fast.sum() - energy).abs() < 1e-9 * energy);
        // DC at (H/2, W/2) holds (Σ image)² / (H·W).
        let dc = img.sum().powi(2) / (h * w) as f64;
        assert!((fast[[h / 2, w / 2]] - dc).abs() < 1e-9 * dc.max(1.0));
    }
}

/// The radial profile of a pure cosine of 8/64 cycles per pixel along x
/// has all its power (A²/4 · 2 entries = 0.5 for A = 1, spread over the
/// ring's members) in the ring at 0.125 cycles per pixel, and none
/// elsewhere (a whole number of periods: no leakage).
#[test]
fn radial_profile_finds_a_cosine() {
    let n = 64;
    let img = Array2::from_shape_fn((n, n), |(_, x)| (TAU * 8.0 * x as f64 / n as f64).cos());
    let spec = power_spectrum(&img);
    let prof = radial_profile(&spec);
    assert_eq!(prof.len(), 32);
    assert!((prof[0].0 - 1.0 / 64.0).abs() < 1e-15 && (prof[31].0 - 0.5).abs() < 1e-15);
    for (f, p) in &prof {
        if (f - 0.125).abs() < 1e-9 {
            assert!(*p > 0.1, "{f}: {p}");
        } else {
            assert!(p.abs() < 1e-20, "{f}: {p}");
        }
    }
    // Σ image² = N²/2 splits into two peaks of N²/4 each; the ring at
    // radius 8 (|f|/Δ rounding to 8) has a known member count.
    let members = (0..n)
        .flat_map(|r| (0..n).map(move |c| (r as f64 - 32.0, c as f64 - 32.0)))
        .filter(|(y, x)| x.hypot(*y).round() == 8.0)
        .count();
    let ring = prof[7].1;
    assert!((ring - 2.0 * (n * n) as f64 / 4.0 / members as f64).abs() < 1e-9);
}

/// `raylab spectrum` writes its files for several samplers, and refuses
/// bad arguments with a clear message and no output.
#[test]
fn spectrum_command_writes_files_and_rejects_bad_args() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("spec");
    let o = raylab(&[
        "spectrum",
        "--sampler",
        "ogss:4,random:16",
        "--sets",
        "32",
        "--freq",
        "8",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("ogss4") && text.contains("random16"),
        "{text}"
    );
    for f in [
        "spectrum-ogss4.png",
        "spectrum-random16.svg",
        "radial.png",
        "radial.svg",
        "anisotropy.png",
        "anisotropy.svg",
        "spectrum.csv",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let curves = raylab_lab::analysis::spectrum::read_rings_csv(&out.join("spectrum.csv")).unwrap();
    assert_eq!(curves.len(), 2);
    assert_eq!((curves[0].points, curves[0].sets), (16, 32));
    assert_eq!(curves[1].rings.len(), 7);

    for (args, expect) in [
        (vec!["--sampler", "poisson:4"], "unknown sampler"),
        (vec!["--sampler", "rgss", "--sets", "0"], "point sets"),
        (vec!["--sampler", "rgss", "--freq", "1"], "frequency bound"),
    ] {
        let bad = dir.path().join("bad");
        let mut all = vec!["spectrum"];
        all.extend(args);
        all.extend(["--out", bad.to_str().unwrap()]);
        let o = raylab(&all);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains(expect), "{err}");
        assert!(!bad.exists());
    }
}

/// The `aa_patterns` study: a row per sampler with its summary, per-run
/// files, and the overlaid radial curves per sample count.
/// A small `aa_patterns` study with a bar figure of its samplers.
const AA_MANIFEST: &str = r#"name = "aa"
kind = "aa_patterns"
threads = 1
[fixed]
sets = 16
freq = 6
[[sweep]]
name = "patterns"
sampler = ["ogss:2", "rgss", "jitter:4", "random:16"]

[[figure]]
file = "low"
kind = "bar"
x = "sampler"
y = "low_freq_power"
title = "low-frequency power"
"#;

/// A line figure over a column of names (the samplers) has no x to draw
/// them at: an error naming the column and a value, not an empty chart.
#[test]
fn a_line_figure_over_text_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = dir.path().join("aa.toml");
    std::fs::write(
        &manifest,
        AA_MANIFEST.replace("kind = \"bar\"", "kind = \"line\""),
    )
    .unwrap();
    let opts = ExperimentOptions {
        out_dir: Some(dir.path().join("out")),
        ..ExperimentOptions::default()
    };
    let e = run_experiment(&manifest, &opts).unwrap_err().to_string();
    assert!(
        e.contains("x column `sampler` holds no number in the 4 rows drawn (e.g. `ogss:2`)"),
        "{e}"
    );
}

#[test]
fn aa_patterns_study_runs() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = dir.path().join("aa.toml");
    std::fs::write(&manifest, AA_MANIFEST).unwrap();
    let opts = ExperimentOptions {
        out_dir: Some(dir.path().join("out")),
        ..ExperimentOptions::default()
    };
    let report = run_experiment(&manifest, &opts).unwrap();
    assert_eq!(report.runs_done, 4);
    let out = &report.out_dir;
    for f in [
        "aa-rgss-m16-f6-s1-spectrum.png",
        "aa-jitter4-m16-f6-s1-radial.csv",
        "aa-radial-4spp.png",
        "aa-anisotropy-16spp.svg",
        "low.png",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    assert!(report.figures.contains(&"aa-radial-16spp".to_string()));
    let data = std::fs::read_to_string(out.join("data.csv")).unwrap();
    let header = data.lines().next().unwrap();
    assert!(header.contains("low_freq_power") && header.contains("radial_csv"));
    // The 2×2 grid's first peak is P = 4 at |k| = 2.
    let row = data.lines().find(|l| l.contains("ogss:2")).unwrap();
    assert!(row.contains(",2.000000,"), "{row}");
}
