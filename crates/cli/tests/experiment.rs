//! Experiments and `raylab diff`: manifests expand into the right runs,
//! malformed manifests get errors naming the file, line and field, a run
//! writes `data.csv`, `meta.json` and its figures, `--resume` runs only
//! what is missing, and `raylab diff` reports metrics or clear errors.

use crate::raylab;
use ndarray::Array3;
use raylab::io::image::write_image;
use raylab_lab::experiment::{load_manifest, run_experiment, ExperimentOptions};
use std::path::Path;

use raylab_testkit::experiment::{setup, write, MANIFEST};

fn quiet(out: &Path) -> ExperimentOptions {
    ExperimentOptions {
        out_dir: Some(out.to_path_buf()),
        ..ExperimentOptions::default()
    }
}

#[test]
fn manifest_expands_products_ranges_and_templates() {
    let (_dir, path) = setup(MANIFEST);
    let m = load_manifest(&path).unwrap();
    assert_eq!((m.repeats, m.warmup, m.threads), (3, 1, Some(1)));
    let plan = m.plan().unwrap();
    assert_eq!(plan.runs.len(), 4 + 9);
    let sizes: Vec<_> = plan.runs.iter().filter(|r| r.sweep == "sizes").collect();
    // The first parameter written varies slowest.
    let pairs: Vec<(String, String)> = sizes
        .iter()
        .map(|r| {
            (
                r.get("resolution").unwrap().to_string(),
                r.get("sampler").unwrap().to_string(),
            )
        })
        .collect();
    assert_eq!(
        pairs[..2],
        [
            ("8x6".to_string(), "centre".to_string()),
            ("8x6".to_string(), "ogss:2".to_string())
        ]
    );
    let scenes: Vec<_> = plan.runs.iter().filter(|r| r.sweep == "scenes").collect();
    let depths: Vec<String> = scenes[..3]
        .iter()
        .map(|r| r.get("max_depth").unwrap().to_string())
        .collect();
    assert_eq!(depths, ["1", "3", "5"]);
    assert_eq!(scenes[8].get("scene").unwrap().to_string(), "scene-3.toml");
    // A sweep's value replaces the fixed one.
    assert_eq!(scenes[0].get("scene").unwrap().to_string(), "scene-1.toml");
    // Columns: sweep, the parameters in the order written, the study's.
    assert_eq!(
        plan.columns[..6],
        [
            "sweep",
            "scene",
            "resolution",
            "sampler",
            "index",
            "max_depth"
        ]
    );
    for c in [
        "render_s_3",
        "render_median_s",
        "load_s",
        "camera_rays",
        "rays_per_s",
    ] {
        assert!(plan.columns.iter().any(|x| x == c), "{c}");
    }
    assert!(!plan.columns.iter().any(|x| x == "render_s_4"));
}

#[test]
fn quick_overrides_repeats_and_lists() {
    let (_dir, path) = setup(MANIFEST);
    let q = load_manifest(&path).unwrap().with_quick().unwrap();
    assert!(q.quick_applied);
    assert_eq!((q.repeats, q.warmup), (1, 0));
    let plan = q.plan().unwrap();
    // sizes: 1 resolution × 2 samplers; scenes: 1 index × 3 depths.
    assert_eq!(plan.runs.len(), 2 + 3);
    assert!(plan.columns.iter().any(|c| c == "render_s_1"));
    assert!(!plan.columns.iter().any(|c| c == "render_s_2"));
    let without_quick = MANIFEST.split("[quick]").next().unwrap().to_string()
        + &MANIFEST[MANIFEST.find("[[figure]]").unwrap()..];
    let (_dir2, path2) = setup(&without_quick);
    let err = load_manifest(&path2).unwrap().with_quick().unwrap_err();
    assert!(err.to_string().contains("no [quick] block"), "{err}");
}

/// Load (and plan) `manifest` with `from` replaced by `to`; assert the
/// error names the manifest at the line where `to` is, and contains each
/// of `expect`.
fn assert_manifest_error(from: &str, to: &str, expect: &[&str]) {
    assert!(MANIFEST.contains(from), "{from}");
    let text = MANIFEST.replacen(from, to, 1);
    let (_dir, path) = setup(&text);
    let err = load_manifest(&path)
        .and_then(|m| m.plan().map(|_| ()))
        .expect_err(to)
        .to_string();
    let line = text[..text.find(to).unwrap()].matches('\n').count() + 1;
    let place = format!("tiny.toml:{line}:");
    assert!(err.contains(&place), "{err:?} should contain {place:?}");
    for e in expect {
        assert!(err.contains(e), "{err:?} should contain {e:?}");
    }
}

#[test]
fn malformed_manifests_name_file_line_and_field() {
    // Unknown fields, at the top level and inside a figure.
    assert_manifest_error("repeats = 3", "repeat = 3", &["unknown field `repeat`"]);
    assert_manifest_error(
        "title = \"time\"",
        "colour = \"red\"",
        &["unknown field `colour`"],
    );
    // Bad ranges.
    assert_manifest_error(
        "{ from = 1, to = 5, count = 3 }",
        "{ from = 1, to = 5, step = 0 }",
        &["max_depth", "step"],
    );
    assert_manifest_error(
        "{ from = 1, to = 3, step = 1 }",
        "{ from = 1, to = 3, step = -1 }",
        &["index", "wrong sign"],
    );
    assert_manifest_error(
        "{ from = 1, to = 3, step = 1 }",
        "{ from = 1, upto = 3, step = 1 }",
        &["index", "unknown key `upto`"],
    );
    // Unknown study kind and unknown parameter.
    assert_manifest_error(
        "kind = \"render_cost\"",
        "kind = \"bvh_ladder_x\"",
        &["unknown study kind `bvh_ladder_x`", "render_cost"],
    );
    assert_manifest_error(
        "sampler = [\"centre\", \"ogss:2\"]",
        "sampelr = [\"centre\", \"ogss:2\"]",
        &["unknown parameter `sampelr`"],
    );
    // Values the study rejects, found before anything runs.
    assert_manifest_error(
        "sampler = [\"centre\", \"ogss:2\"]",
        "sampler = [\"centre\", \"ogss:0\"]",
        &["sweep `sizes`, parameter `sampler`", "ogss"],
    );
    assert_manifest_error(
        "resolution = [\"8x6\", \"16x12\"]",
        "resolution = [\"8x6\", \"16by12\"]",
        &["resolution", "16by12"],
    );
    assert_manifest_error(
        "scene = \"scene-{index}.toml\"",
        "scene = \"scene-{index:02}.toml\"",
        &["scene-01.toml", "no such scene file"],
    );
    assert_manifest_error(
        "scene = \"scene-{index}.toml\"",
        "scene = \"scene-{index}{idx}.toml\"",
        &[
            "sweep `scenes`, parameter `scene`",
            "`{idx}`",
            "names no parameter",
        ],
    );
    // Figures must name columns and sweeps that exist.
    assert_manifest_error("y = \"rays\"", "y = \"rayz\"", &["figure `depth`", "rayz"]);
    assert_manifest_error(
        "sweep = \"scenes\"",
        "sweep = \"scnes\"",
        &["no sweep is named `scnes`"],
    );
    assert_manifest_error(
        "[quick.sweep.scenes]",
        "[quick.sweep.scens]",
        &["no sweep is named `scens`"],
    );
    assert_manifest_error(
        "repeats = 3",
        "repeats = 0",
        &["`repeats` must be at least 1"],
    );
    assert_manifest_error(
        "title = \"time\"",
        "legend = \"middle\"",
        &["legend `middle` is not one of auto, upper-left"],
    );
}

#[test]
fn run_writes_csv_meta_and_figures() {
    let (dir, path) = setup(MANIFEST);
    let out = dir.path().join("out");
    let report = run_experiment(&path, &quiet(&out)).unwrap();
    assert_eq!((report.runs_total, report.runs_done), (13, 13));
    assert_eq!(report.threads, 1);

    let mut rdr = csv::Reader::from_path(out.join("data.csv")).unwrap();
    let header: Vec<String> = rdr.headers().unwrap().iter().map(String::from).collect();
    for c in [
        "sweep",
        "scene",
        "resolution",
        "sampler",
        "index",
        "max_depth",
        "width",
        "height",
        "pixels",
        "spp",
        "samples",
        "threads",
        "load_s",
        "render_s_1",
        "render_s_2",
        "render_s_3",
        "render_median_s",
        "render_min_s",
        "render_max_s",
        "render_cpu_median_s",
        "counted_render_s",
        "camera_rays",
        "shadow_rays",
        "reflection_rays",
        "refraction_rays",
        "sphere_tests",
        "plane_tests",
        "rays",
        "rays_per_s",
        "ns_per_sample",
    ] {
        assert!(header.iter().any(|h| h == c), "data.csv lacks {c}");
    }
    let rows: Vec<csv::StringRecord> = rdr.records().map(Result::unwrap).collect();
    assert_eq!(rows.len(), 13);
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    // OGSS 2×2 traces exactly four camera rays per pixel.
    let (cam, px, spp) = (col("camera_rays"), col("pixels"), col("spp"));
    for r in &rows {
        let n: u64 = r[px].parse().unwrap();
        let s: u64 = r[spp].parse().unwrap();
        assert_eq!(r[cam].parse::<u64>().unwrap(), n * s);
        let (lo, med, hi): (f64, f64, f64) = (
            r[col("render_min_s")].parse().unwrap(),
            r[col("render_median_s")].parse().unwrap(),
            r[col("render_max_s")].parse().unwrap(),
        );
        assert!(lo <= med && med <= hi && lo > 0.0);
    }
    assert_eq!(&rows[1][col("resolution")], "8x6");
    assert_eq!(&rows[1][col("sampler")], "ogss:2");
    assert_eq!(&rows[1][col("spp")], "4");
    // A parameter a sweep lacks is an empty cell.
    assert_eq!(&rows[0][col("index")], "");

    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("meta.json")).unwrap()).unwrap();
    for key in [
        "manifest",
        "raylab_version",
        "git_revision",
        "git_dirty",
        "cpu_model",
        "threads",
        "optimised",
        "started_utc",
        "finished_utc",
        "wall_time_s",
        "quick",
        "runs_total",
        "complete",
        "figures",
        "summary",
    ] {
        assert!(meta.get(key).is_some(), "meta.json lacks {key}");
    }
    assert_eq!(meta["raylab_version"], env!("CARGO_PKG_VERSION"));
    assert_eq!(meta["complete"], true);
    assert_eq!(meta["manifest"]["repeats"], 3);
    assert_eq!(
        meta["manifest"]["sweep"][1]["params"]["max_depth"],
        serde_json::json!([1, 3, 5])
    );
    let started = meta["started_utc"].as_str().unwrap();
    assert!(started.len() == 20 && started.ends_with('Z') && started.as_bytes()[10] == b'T');
    assert_eq!(meta["summary"][0]["figure"], "ratio");
    // Two measured series (wall clock, labelled; CPU time), one reference.
    let series = &meta["summary"][0]["series"];
    assert_eq!(series[0]["label"], "wall");
    assert_eq!(series[1]["label"], "render_cpu_median_s");
    assert_eq!(series[1]["measured"], true);
    assert_eq!(series[2]["mean"], 3.25);
    assert_eq!(series[2]["measured"], false);

    for stem in ["time", "ratio", "depth"] {
        for ext in ["png", "svg"] {
            let f = out.join(format!("{stem}.{ext}"));
            assert!(
                std::fs::metadata(&f).unwrap().len() > 1000,
                "{}",
                f.display()
            );
        }
    }
}

#[test]
fn resume_runs_only_the_missing_rows() {
    let (dir, path) = setup(MANIFEST);
    let out = dir.path().join("out");
    let opts = quiet(&out);
    run_experiment(&path, &opts).unwrap();
    let csv_path = out.join("data.csv");
    let full = std::fs::read_to_string(&csv_path).unwrap();
    let lines: Vec<&str> = full.lines().collect();
    assert_eq!(lines.len(), 1 + 13);

    // Interrupted: the last two rows never finished, and a third was cut
    // off in the middle of being written.
    let kept = &lines[..lines.len() - 3];
    let partial = &lines[lines.len() - 3][..20];
    std::fs::write(&csv_path, kept.join("\n") + "\n" + partial).unwrap();
    let resumed = ExperimentOptions {
        resume: true,
        ..opts.clone()
    };
    let report = run_experiment(&path, &resumed).unwrap();
    assert_eq!((report.runs_skipped, report.runs_done), (10, 3));
    let after = std::fs::read_to_string(&csv_path).unwrap();
    let after: Vec<&str> = after.lines().collect();
    assert_eq!(after.len(), 1 + 13);
    // The kept rows (with their timings) are untouched.
    assert_eq!(after[..kept.len()], kept[..]);

    // Nothing missing: nothing is run, the figures are redrawn.
    std::fs::remove_file(out.join("time.png")).unwrap();
    let report = run_experiment(&path, &resumed).unwrap();
    assert_eq!((report.runs_skipped, report.runs_done), (13, 0));
    assert!(out.join("time.png").exists());

    // Without --resume the table starts afresh.
    let report = run_experiment(&path, &opts).unwrap();
    assert_eq!(report.runs_done, 13);

    // A table of other columns (repeats changed) is not resumed into.
    let (_dir2, path2) = setup(&MANIFEST.replace("repeats = 3", "repeats = 2"));
    let err = run_experiment(&path2, &resumed).unwrap_err();
    assert!(format!("{err:#}").contains("columns differ"), "{err:#}");
}

#[test]
fn cli_runs_quick_experiment_and_prints_summary() {
    let (dir, path) = setup(MANIFEST);
    let out = dir.path().join("q");
    let o = raylab(&[
        "experiment",
        path.to_str().unwrap(),
        "--quick",
        "--out",
        out.to_str().unwrap(),
        "--threads",
        "2",
    ]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(stdout.contains("5 runs"), "{stdout}");
    assert!(stdout.contains("summary    ratio: mean"), "{stdout}");
    let meta = std::fs::read_to_string(out.join("meta.json")).unwrap();
    assert!(meta.contains("\"quick\": true"));

    // A bad manifest: non-zero exit, an error naming the place.
    let bad = write(
        dir.path(),
        "bad.toml",
        &MANIFEST.replace("repeats = 3", "repeats = \"3\""),
    );
    let o = raylab(&["experiment", bad.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(err.contains("bad.toml:4:"), "{err}");
}

/// The shipped S1 manifest is valid, and its quick form is small and runs.
#[test]
fn s1_manifest_plans_its_tables() {
    let path = raylab_testkit::repo().join("analysis/s1-ogss-cost.toml");
    let m = load_manifest(&path).unwrap();
    assert_eq!(m.repeats, 5);
    assert_eq!(m.plan().unwrap().runs.len(), 21 * 2 + 20 * 2);
    let q = m.with_quick().unwrap();
    assert_eq!(q.plan().unwrap().runs.len(), 3 * 2 + 4 * 2);

    // The quick version runs (a few seconds) and draws every figure.
    let dir = tempfile::tempdir().unwrap();
    let opts = ExperimentOptions {
        quick: true,
        ..quiet(dir.path())
    };
    let report = run_experiment(&path, &opts).unwrap();
    assert_eq!(report.runs_done, 14);
    assert_eq!(report.figures.len(), m.figures.len());
    for s in &report.summary {
        // Wall clock, CPU time, S1's published values.
        assert_eq!(s.series.len(), 3, "{s:?}");
        assert!(s.series[0].mean > 1.0, "{s:?}");
    }
    assert_eq!(report.summary[0].series[2].mean.to_string()[..4], *"3.32");
}

fn gradient(w: usize, h: usize, shift: f32) -> Array3<f32> {
    Array3::from_shape_fn((h, w, 3), |(y, x, c)| {
        ((x + y + c) as f32 / (w + h + 2) as f32 + shift).min(1.0)
    })
}

#[test]
fn diff_reports_metrics_and_errors() {
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("a.png");
    let b = dir.path().join("b.png");
    let c = dir.path().join("c.png");
    write_image(&a, &gradient(32, 24, 0.0)).unwrap();
    write_image(&b, &gradient(32, 24, 0.2)).unwrap();
    write_image(&c, &gradient(16, 24, 0.0)).unwrap();
    let (a, b, c) = (
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        c.to_str().unwrap(),
    );

    // Identical: PSNR is infinite ("inf" in JSON, ∞ in the table).
    let o = raylab(&["diff", a, a, "--json"]);
    assert!(o.status.success());
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(json["psnr"], "inf");
    assert_eq!(json["mse"], 0.0);
    let o = raylab(&["diff", a, a]);
    assert!(String::from_utf8_lossy(&o.stdout).contains('∞'));

    // Different: finite numbers; the error map is written when asked for.
    let map = dir.path().join("map.png");
    let o = raylab(&["diff", a, b, "--json", "--out", map.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let psnr = json["psnr"].as_f64().unwrap();
    assert!(psnr.is_finite() && psnr > 0.0, "{psnr}");
    assert!(json["mse"].as_f64().unwrap() > 0.0);
    assert!(json["flip"]["mean"].as_f64().unwrap() > 0.0);
    let img = image::open(&map).unwrap();
    assert_eq!((img.width(), img.height()), (32, 24));
    let o = raylab(&["diff", a, b]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("PSNR") && text.contains("dB") && text.contains("FLIP mean"));

    // Size mismatch and missing files: non-zero exit, the files named.
    let o = raylab(&["diff", a, c]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(
        err.contains("a.png") && err.contains("c.png") && err.contains("32×24"),
        "{err}"
    );
    let missing = dir.path().join("nope.png");
    let o = raylab(&["diff", a, missing.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(err.contains("nope.png"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}

/// The shipped Embree speed manifest plans its runs, and its quick form
/// runs: all three sides (ours, Embree, the obvhs peer) traced the same
/// rays (hit/miss agreement up to the few rays rounding decides at shared
/// edges: at most 1 in 10³), every throughput and ratio is a positive
/// number, and the counts of our side's work are there.
#[cfg(all(feature = "embree", feature = "obvhs"))]
#[test]
fn embree_speed_manifest_measures_both_sides_on_the_same_rays() {
    let path = raylab_testkit::repo().join("analysis/embree-speed.toml");
    let m = load_manifest(&path).unwrap();
    assert_eq!(m.plan().unwrap().runs.len(), 5 * 2);
    let dir = tempfile::tempdir().unwrap();
    let opts = ExperimentOptions {
        quick: true,
        ..quiet(dir.path())
    };
    let report = run_experiment(&path, &opts).unwrap();
    assert_eq!(report.runs_done, 2);
    assert_eq!(report.figures.len(), m.figures.len());
    let mut rows = csv::Reader::from_path(dir.path().join("data.csv")).unwrap();
    let headers = rows.headers().unwrap().clone();
    let mut n = 0;
    for row in rows.records() {
        let row = row.unwrap();
        let get = |name: &str| -> f64 {
            let i = headers.iter().position(|h| h == name).unwrap();
            row[i].parse().unwrap()
        };
        assert_eq!(get("triangles"), 19536.0);
        for kind in ["camera", "shadow", "path", "random"] {
            let rays = get(&format!("{kind}_rays"));
            assert!(rays > 1000.0, "{kind}: {rays} rays");
            assert!(get(&format!("{kind}_hit_disagree")) <= rays * 1e-3);
            for col in ["ours_{}_mrays_s", "ref_{}_mrays_s", "{}_ratio"] {
                let v = get(&col.replace("{}", kind));
                assert!(v.is_finite() && v > 0.0, "{col} {kind}: {v}");
            }
            assert!(get(&format!("{kind}_volume_tests_per_ray")) >= 1.0);
            // The peer (obvhs) on the same rays: its throughput, the
            // ratio, and hit/miss agreement with ours up to edge roundings
            // (obvhs's triangle test is not watertight; see crates/core/tests/obvhs.rs).
            assert!(get(&format!("{kind}_peer_hit_disagree")) <= rays * 1e-3);
            for col in ["peer_{}_mrays_s", "{}_peer_ratio"] {
                let v = get(&col.replace("{}", kind));
                assert!(v.is_finite() && v > 0.0, "{col} {kind}: {v}");
            }
        }
        assert!(get("peer_build_median_s") > 0.0);
        n += 1;
    }
    assert_eq!(n, 2);
}
