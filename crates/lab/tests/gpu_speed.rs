//! The `gpu_speed` study (S3's GPU tables): a tiny manifest of both
//! devices and two accelerators runs; GPU rows carry the time split and
//! CPU rows leave it empty; the totals add up; both devices count the same
//! rays; every row and meta.json name the adapter; brute force above its
//! face limit is refused.

use raylab_lab::experiment::{run_experiment, ExperimentOptions};
use std::collections::HashMap;
use std::path::Path;

use raylab_testkit::experiment::{num, read_rows};

fn manifest(dir: &Path, brute_max_faces: u32) -> std::path::PathBuf {
    let path = dir.join("gpu.toml");
    std::fs::write(
        &path,
        format!(
            r#"
name = "gpu-tiny"
kind = "gpu_speed"
repeats = 2
warmup = 0

[[sweep]]
name = "tiny"
procedural = "icosphere:1"
resolution = "48x36"
brute_max_faces = {brute_max_faces}
accel = ["brute", "bvh:aabb:s3"]
device = ["cpu", "gpu"]
"#
        ),
    )
    .unwrap();
    path
}

/// The adapter (`make deps` installs Mesa's lavapipe, so CI always has
/// one): no adapter is a failure, unless RAYLAB_NO_GPU=1 skips the GPU
/// tests on purpose (then `None`).
fn adapter() -> Option<String> {
    if std::env::var("RAYLAB_NO_GPU").is_ok_and(|v| v == "1") {
        eprintln!("RAYLAB_NO_GPU=1: gpu_speed not run, on purpose");
        return None;
    }
    match raylab_gpu::Gpu::new() {
        Ok(g) => Some(g.describe()),
        Err(e) => panic!("{e}\n(set RAYLAB_NO_GPU=1 to skip the GPU tests on purpose)"),
    }
}

#[test]
fn gpu_rows_split_the_time_and_count_the_cpus_rays() {
    let Some(adapter) = adapter() else { return };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let opts = ExperimentOptions {
        out_dir: Some(out.clone()),
        ..ExperimentOptions::default()
    };
    let report = run_experiment(&manifest(dir.path(), 1000), &opts).unwrap();
    assert_eq!(report.runs_done, 4);
    let rows = read_rows(&out.join("data.csv"));
    assert_eq!(rows.len(), 4);
    let split = ["upload_s", "shader_s", "kernel_s", "readback_s"];
    let mut rays: HashMap<(String, String), f64> = HashMap::new();
    for r in &rows {
        let what = format!("{} on the {}", r["accel"], r["device"]);
        assert_eq!(num(r, "faces"), 80.0, "{what}");
        let (build, median) = (num(r, "build_s"), num(r, "render_median_s"));
        assert!(
            (num(r, "total_s") - (build + median)).abs() <= 1e-6 * (build + median) + 1e-9,
            "{what}: total_s is not build_s + render_median_s"
        );
        assert!(num(r, "render_min_s") <= median && median <= num(r, "render_max_s"));
        assert!(
            num(r, "rays") >= 48.0 * 36.0,
            "{what}: fewer rays than pixels"
        );
        assert_eq!(r["gpu_adapter"], adapter, "{what}");
        let software = r["gpu_software"] == "true";
        assert_eq!(
            r["gpu_class"],
            if software {
                "software GPU (runs on the CPU)"
            } else {
                "hardware GPU"
            }
        );
        match r["device"].as_str() {
            "gpu" => {
                let parts: Vec<f64> = split.iter().map(|c| num(r, c)).collect();
                assert!(parts.iter().all(|&p| p >= 0.0), "{what}: {parts:?}");
                // The timed call is the whole render: at least its parts
                // (the split is that of the median one of two repeats).
                assert!(num(r, "render_max_s") >= parts.iter().sum::<f64>() * 0.999);
                assert_eq!(num(r, "trace_s"), num(r, "kernel_s"), "{what}");
            }
            "cpu" => {
                for c in split.iter().chain(&["kernel_timestamped"]) {
                    assert_eq!(r[*c], "", "{what}: {c} on a CPU row");
                }
                assert_eq!(num(r, "trace_s"), median, "{what}");
            }
            other => panic!("device {other}"),
        }
        rays.insert((r["accel"].clone(), r["device"].clone()), num(r, "rays"));
    }
    // The same ray tree on both devices, up to the rare pixel whose camera
    // or shadow ray grazes an edge (a tie the two devices may break apart).
    for accel in ["brute", "bvh:aabb:s3"] {
        let (c, g) = (
            rays[&(accel.to_string(), "cpu".to_string())],
            rays[&(accel.to_string(), "gpu".to_string())],
        );
        assert!((c - g).abs() <= 0.01 * c, "{accel}: CPU {c} rays, GPU {g}");
    }
    let meta = std::fs::read_to_string(out.join("meta.json")).unwrap();
    let meta: serde_json::Value = serde_json::from_str(&meta).unwrap();
    assert!(
        meta["device"].as_str().unwrap().starts_with(&adapter),
        "{}",
        meta["device"]
    );
}

#[test]
fn brute_force_above_its_face_limit_is_refused() {
    if adapter().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let opts = ExperimentOptions {
        out_dir: Some(dir.path().join("out")),
        ..ExperimentOptions::default()
    };
    let err = run_experiment(&manifest(dir.path(), 10), &opts).unwrap_err();
    let msg = format!("{err:#}");
    assert!(
        msg.contains("80 faces") && msg.contains("brute_max_faces = 10"),
        "{msg}"
    );
}
