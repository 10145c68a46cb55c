//! The GPU port through the command line: `--device gpu` for `render` and
//! `stats`, compared with the CPU's output.

use crate::raylab;
use raylab_testkit::gpu::{gpu, TOLERANCE};

#[test]
fn the_cli_renders_on_the_gpu_and_names_the_adapter() {
    if gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("s1.exr");
    let o = raylab(&[
        "render",
        "data/scenes/s1-spheres.toml",
        "--width",
        "40",
        "--height",
        "30",
        "--device",
        "gpu",
        "-o",
        out.to_str().unwrap(),
    ]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(text.contains("device     GPU: "), "{text}");
    assert!(text.contains("kernel"), "{text}");
    assert!(out.exists());
    // No noise from the Vulkan drivers' display probing.
    assert!(!String::from_utf8_lossy(&o.stderr).contains("XDG_RUNTIME_DIR"));

    // `raylab diff` on the CPU's and the GPU's files: within the tolerance.
    let cpu = dir.path().join("s1-cpu.exr");
    let size = ["--width", "40", "--height", "30"];
    let o = raylab(
        &[
            &["render", "data/scenes/s1-spheres.toml"],
            &size[..],
            &["-o", cpu.to_str().unwrap()],
        ]
        .concat(),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = raylab(&[
        "diff",
        out.to_str().unwrap(),
        cpu.to_str().unwrap(),
        "--json",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let max = json["max_abs_error"].as_f64().unwrap();
    assert!(
        max <= f64::from(TOLERANCE),
        "raylab diff: max |GPU − CPU| = {max}"
    );

    // The path tracer has no GPU port: exit 1, nothing written.
    let bad = dir.path().join("path.png");
    let o = raylab(&[
        "render",
        "data/scenes/s1-spheres.toml",
        "--device",
        "gpu",
        "--integrator",
        "path:2",
        "-o",
        bad.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("Whitted integrator only"), "{err}");
    assert!(!bad.exists());
}

#[test]
fn a_bad_device_name_is_a_usage_error() {
    let o = raylab(&[
        "render",
        "data/scenes/s1-spheres.toml",
        "--device",
        "tpu",
        "-o",
        "out/never.png",
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("unknown device `tpu`"), "{err}");
}

#[test]
fn stats_on_the_gpu_counts_what_the_cpu_counts() {
    if gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let mut tables = Vec::new();
    for device in ["cpu", "gpu"] {
        let o = raylab(&[
            "stats",
            "data/scenes/camel.toml",
            "--accel",
            "bvh:ellipsoid",
            "--width",
            "40",
            "--height",
            "30",
            "--device",
            device,
            "--out",
            dir.path().join(device).to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        // The table without times and paths.
        let text = String::from_utf8_lossy(&o.stdout).into_owned();
        tables.push(
            text.lines()
                .filter(|l| {
                    !l.contains("(s)")
                        && !l.contains("loaded in")
                        && !l.starts_with("GPU:")
                        && !l.starts_with("Heatmaps")
                })
                .map(str::to_owned)
                .collect::<Vec<_>>(),
        );
        assert!(dir
            .path()
            .join(device)
            .join("bvh-ellipsoid-sah-nodes.png")
            .exists());
    }
    assert_eq!(tables[0], tables[1]);
}
