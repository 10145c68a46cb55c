//! `raylab stats`: the command runs end to end on small images and writes
//! its heatmaps, and the percentile code gives the textbook answers.

use raylab_lab::report::stats::{percentile, Distribution};

/// The CLI on the S1 spheres (few primitives, so brute force is among the
/// defaults) at 32×24 to stay fast; every expected PNG and SVG must exist
/// and be non-empty.
#[test]
fn stats_command_prints_the_table_and_writes_heatmaps() {
    let dir = tempfile::tempdir().unwrap();
    let out = crate::raylab_command()
        .args(["stats", "data/scenes/s1-spheres.toml", "--width", "32"])
        .args(["--height", "24", "--threads", "2", "--out"])
        .arg(dir.path())
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for section in [
        "Statistics: brute",
        "Statistics: bvh:aabb:sah",
        "Statistics: bvh:sphere:s3",
        "Statistics: bvh:ellipsoid:s3",
        "Primitive tests / ray",
        "p99",
    ] {
        assert!(text.contains(section), "missing `{section}` in\n{text}");
    }
    for accel in ["brute", "bvh-aabb-sah", "bvh-sphere-s3", "bvh-ellipsoid-s3"] {
        for map in ["nodes", "prim-tests"] {
            for ext in ["png", "svg"] {
                let p = dir.path().join(format!("{accel}-{map}.{ext}"));
                let len = std::fs::metadata(&p).map_or(0, |m| m.len());
                assert!(len > 0, "{} missing or empty", p.display());
            }
        }
    }
}

#[test]
fn stats_command_rejects_a_missing_scene_without_panicking() {
    let out = crate::raylab_command()
        .args(["stats", "data/scenes/no-such-scene.toml"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("no-such-scene"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}

/// Nearest rank (Hyndman and Fan definition 1) on 1..=10: the p-th
/// percentile is element ⌈p·n/100⌉, so p50 = 5, p90 = 9, p99 = 10 (rank
/// ⌈9.9⌉ = 10), and p0 is the minimum. Exact integers, so no tolerance.
#[test]
fn nearest_rank_percentiles_on_known_data() {
    let v: Vec<u64> = (1..=10).collect();
    assert_eq!(percentile(&v, 50.0), Some(5));
    assert_eq!(percentile(&v, 90.0), Some(9));
    assert_eq!(percentile(&v, 91.0), Some(10));
    assert_eq!(percentile(&v, 99.0), Some(10));
    assert_eq!(percentile(&v, 0.0), Some(1));
    assert_eq!(percentile(&[7], 50.0), Some(7));
    assert_eq!(percentile(&[], 50.0), None);
    assert_eq!(percentile(&v, 101.0), None);
    assert_eq!(percentile(&v, f64::NAN), None);
}

/// A skewed sample, given unsorted: 99 rays with 1 test and one with 1000
/// (a grazing ray). The median and p90 ignore the outlier, p99 is rank 99
/// (still 1), the max and the mean see it: mean = (99 + 1000) / 100 = 10.99.
/// The sum is exact and one division rounds once, so the error is below
/// half an ulp of 10.99 (~1e-15); 1e-12 leaves room without hiding a bug.
#[test]
fn distribution_of_a_skewed_sample() {
    let mut v = vec![1u64; 99];
    v.insert(17, 1000);
    let d = Distribution::of(&mut v).unwrap();
    assert_eq!((d.p50, d.p90, d.p99, d.max), (1, 1, 1, 1000));
    assert!((d.mean - 10.99).abs() < 1e-12);
    assert!(Distribution::of(&mut []).is_none());
}
