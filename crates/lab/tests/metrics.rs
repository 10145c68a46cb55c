//! Image metrics: MSE, relMSE, PSNR, max error and ꟻLIP, through both the
//! in-memory API and `diff_files`.

use ndarray::{Array2, Array3};
use raylab::io::image::{write_image, LinearImage};
use raylab_lab::analysis::metrics::{
    compare, diff_files, flip_stats, max_abs_error, mse, psnr, rel_mse, MetricsError,
    REL_MSE_EPSILON,
};
use std::path::Path;

/// A deterministic "random" image whose values are multiples of 1/1024 in
/// [0, max]: such dyadic values are exact in f32, so adding a power-of-two
/// offset to them is exact too (see `constant_offset_gives_mse_delta_squared`).
fn random_dyadic_image(h: usize, w: usize, max: f32, seed: u64) -> LinearImage {
    let mut state = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    let steps = (max * 1024.0) as u64 + 1;
    Array3::from_shape_fn((h, w, 3), |_| {
        // 64-bit LCG (Knuth's MMIX constants); the high bits are the best.
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 33) % steps) as f32 / 1024.0
    })
}

fn constant_image(h: usize, w: usize, v: f32) -> LinearImage {
    Array3::from_elem((h, w, 3), v)
}

#[test]
fn identical_images_have_zero_error_and_infinite_psnr() {
    let a = random_dyadic_image(24, 32, 1.0, 1);
    let m = compare(&a, &a).unwrap();
    assert_eq!(m.mse, 0.0);
    assert_eq!(m.rel_mse, 0.0);
    assert_eq!(m.max_abs_error, 0.0);
    assert!(m.psnr.is_infinite() && m.psnr > 0.0);
    // ꟻLIP's colour and feature differences are both exactly zero for equal
    // inputs, and 0^(1−0) = 0, so every statistic is exactly zero.
    assert_eq!(m.flip.mean, 0.0);
    assert_eq!(m.flip.weighted_median, 0.0);
    assert_eq!(m.flip.max, 0.0);
    let table = m.to_string();
    assert!(table.contains("∞ (identical)"), "{table}");
}

#[test]
fn constant_offset_gives_mse_delta_squared() {
    // Values k/1024 ≤ 1 − 1/16 plus δ = 1/16 stay in [0, 1]. All of them
    // have at most 10 fractional bits, so a + δ is exact in f32 and every
    // per-channel difference is exactly δ; the squares are exactly 2⁻⁸ and
    // their f64 sum is exact (N·2⁻⁸ needs far fewer than 53 bits), so MSE is
    // δ² to the last bit. 1e-9 relative only leaves room for a different
    // summation order in a future implementation.
    let delta = 1.0f32 / 16.0;
    let reference = random_dyadic_image(20, 30, 1.0 - delta, 7);
    let test = reference.mapv(|v| v + delta);
    assert!(test.iter().all(|&v| (0.0..=1.0).contains(&v)));
    let d = f64::from(delta);
    let expect = d * d;
    let got = mse(&test, &reference);
    assert!(
        (got - expect).abs() <= 1e-9 * expect,
        "MSE {got} vs {expect}"
    );
    assert_eq!(max_abs_error(&test, &reference), d);
    // PSNR = 10·log10(1/δ²) = 20·log10(16) dB.
    let want_psnr = 20.0 * 16f64.log10();
    assert!((psnr(&test, &reference, 1.0) - want_psnr).abs() < 1e-9);
}

#[test]
fn rel_mse_on_constant_images_matches_the_formula() {
    // (0.75 − 0.5)² / (0.5² + 0.01) = 0.0625 / 0.26; inputs are exact in f32
    // so the only rounding is in the final f64 division and mean.
    let reference = constant_image(5, 7, 0.5);
    let test = constant_image(5, 7, 0.75);
    let expect = 0.0625 / (0.25 + REL_MSE_EPSILON);
    let got = rel_mse(&test, &reference);
    assert!((got - expect).abs() < 1e-12 * expect, "{got} vs {expect}");
    // Against a black reference ε alone is the denominator: 0.125² / 0.01.
    let black = constant_image(5, 7, 0.0);
    let dark = constant_image(5, 7, 0.125);
    let got = rel_mse(&dark, &black);
    assert!((got - 1.5625).abs() < 1e-12, "{got}");
    // Not symmetric: the reference is the second argument.
    assert!(rel_mse(&black, &dark) < 1.0);
}

#[test]
fn black_against_white_is_near_the_flip_maximum() {
    // For two flat images ꟻLIP's feature (edge/point) difference is 0, so
    // the error is the colour error alone: the HyAB distance of black and
    // white (ΔL = 100, no chroma) raised to 0.7, which is above 0.4·cmax,
    // so it lands in the compressed top band [0.95, 1] of ꟻLIP's error
    // scale (the reference code gives 0.9674 here). Any value in (0.9, 1]
    // shows that band was hit; 1 is the most ꟻLIP can report.
    let black = constant_image(16, 16, 0.0);
    let white = constant_image(16, 16, 1.0);
    let m = compare(&black, &white).unwrap();
    assert!(m.flip.mean > 0.9 && m.flip.mean <= 1.0, "{:?}", m.flip);
    assert!(m.flip.min > 0.9 && m.flip.max <= 1.0, "{:?}", m.flip);
    assert_eq!(m.mse, 1.0);
    assert_eq!(m.psnr, 0.0);
}

#[test]
fn flip_weighted_percentiles_follow_the_reference_tool() {
    // Errors 0.1, 0.2, 0.3, 0.4 sum to 1; running sums are 0.1, 0.3, 0.6,
    // 1.0. The tool's weighted p-percentile is the first error at which the
    // running sum exceeds p·total: 0.2 for p = 0.25, 0.3 for 0.5, 0.4 for
    // 0.75 (the plain median would be 0.25). The gaps between running sums
    // (≥ 0.05) dwarf f32 rounding, so equality is safe.
    let map = Array2::from_shape_vec((2, 2), vec![0.1f32, 0.2, 0.3, 0.4]).unwrap();
    let s = flip_stats(&map);
    assert!((s.mean - 0.25).abs() < 1e-6, "{s:?}");
    assert_eq!(s.q1, f64::from(0.2f32));
    assert_eq!(s.weighted_median, f64::from(0.3f32));
    assert_eq!(s.q3, f64::from(0.4f32));
    assert_eq!(s.min, f64::from(0.1f32));
    assert_eq!(s.max, f64::from(0.4f32));
}

#[test]
fn size_mismatch_is_an_error_naming_both_sizes() {
    let a = constant_image(3, 4, 0.5);
    let b = constant_image(3, 5, 0.5);
    let err = compare(&a, &b).unwrap_err();
    assert_eq!(
        err,
        MetricsError::SizeMismatch {
            test: (4, 3),
            reference: (5, 3)
        }
    );
    let msg = err.to_string();
    assert!(msg.contains("4×3") && msg.contains("5×3"), "{msg}");
    // The unchecked scalar metrics answer NaN instead of panicking.
    assert!(mse(&a, &b).is_nan());
    assert!(compare(&constant_image(0, 0, 0.0), &constant_image(0, 0, 0.0)).is_err());
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn diff_files_writes_the_error_map() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("test.exr"), dir.path().join("ref.exr"));
    // A white dot on flat grey: an error ꟻLIP's filters cannot mask.
    let reference = constant_image(12, 16, 0.25);
    let mut test = reference.clone();
    for c in 0..3 {
        test[[5, 5, c]] = 1.0;
    }
    write_image(&a, &test).unwrap();
    write_image(&b, &reference).unwrap();
    let map = dir.path().join("map.png");
    let m = diff_files(&a, &b, Some(&map)).unwrap();
    assert!(m.mse > 0.0 && m.flip.mean > 0.0);
    let img = image::open(&map).unwrap().to_rgb8();
    assert_eq!((img.width(), img.height()), (16, 12));
    // Magma is dark for no error: the changed pixel outshines a far corner.
    let brightness = |x, y| {
        img.get_pixel(x, y)
            .0
            .iter()
            .map(|&c| u32::from(c))
            .sum::<u32>()
    };
    assert!(brightness(5, 5) > brightness(15, 11) + 100);
    assert_eq!(files_in(dir.path()), ["map.png", "ref.exr", "test.exr"]);
}

#[test]
fn diff_files_leaves_nothing_behind_on_error() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.png"), dir.path().join("b.png"));
    write_image(&a, &constant_image(4, 6, 0.2)).unwrap();
    write_image(&b, &constant_image(5, 6, 0.2)).unwrap();
    let map = dir.path().join("map.png");
    let err = diff_files(&a, &b, Some(&map)).unwrap_err().to_string();
    assert!(err.contains("6×4") && err.contains("6×5"), "{err}");
    // A missing input names the file; a non-PNG map name is refused.
    let missing = dir.path().join("missing.exr");
    let err = diff_files(&missing, &b, Some(&map))
        .unwrap_err()
        .to_string();
    assert!(err.contains("missing.exr"), "{err}");
    let err = diff_files(&a, &a, Some(&dir.path().join("map.exr")))
        .unwrap_err()
        .to_string();
    assert!(err.contains("map.exr"), "{err}");
    assert_eq!(files_in(dir.path()), ["a.png", "b.png"]);
}
