//! The `accel_cost` study and S3's BVH ladder: the quick ladder runs, every
//! BVH image equals the reference (brute force's where it ran), the
//! per-ray columns agree with the counter totals, brute force above its
//! face limit is extrapolated and marked, and bad parameters are reported
//! at their place in the manifest.

use raylab_lab::experiment::{load_manifest, run_experiment, ExperimentOptions};
use std::path::PathBuf;

fn repo() -> PathBuf {
    raylab_testkit::repo().to_path_buf()
}

use raylab_testkit::experiment::{num, read_rows};

/// Brute-force face limit of the ladder's `[quick]` block.
const QUICK_BRUTE_MAX_FACES: f64 = 1000.0;

#[test]
fn quick_ladder_matches_brute_force_and_counts_consistently() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let opts = ExperimentOptions {
        quick: true,
        out_dir: Some(out.clone()),
        ..ExperimentOptions::default()
    };
    let report = run_experiment(&repo().join("analysis/s3-bvh-ladder.toml"), &opts).unwrap();
    assert_eq!(report.runs_done, report.runs_total);
    let rows = read_rows(&out.join("data.csv"));
    // 4 meshes + 1 procedural, 6 accelerators each.
    assert_eq!(rows.len(), 30);

    let mut extrapolated = 0;
    for r in &rows {
        let what = format!("{} on {}{}", r["accel"], r["mesh"], r["procedural"]);
        let faces = num(r, "faces");
        let rays = num(r, "rays");
        assert!(rays >= 200.0 * 200.0, "{what}: fewer rays than pixels");

        // Per-ray means are the counter totals over the rays, written with
        // 6 decimals: off by at most 5e-7 per ray, i.e. 5e-7·rays in total
        // (+1 for the rounding of an extrapolated count).
        for c in [
            "nodes_visited",
            "box_tests",
            "bounding_sphere_tests",
            "bounding_ellipsoid_tests",
            "triangle_tests",
        ] {
            let total = num(r, c);
            let per_ray = num(r, &format!("{c}_per_ray"));
            assert!(
                (per_ray * rays - total).abs() <= 5e-7 * rays + 1.0,
                "{what}: {c}_per_ray {per_ray} × {rays} rays ≠ {total}"
            );
        }
        let tests = num(r, "box_tests")
            + num(r, "bounding_sphere_tests")
            + num(r, "bounding_ellipsoid_tests")
            + num(r, "triangle_tests")
            + num(r, "sphere_tests")
            + num(r, "ellipsoid_tests")
            + num(r, "plane_tests");
        assert!((num(r, "tests_per_ray") * rays - tests).abs() <= 5e-7 * rays + 1.0);

        if r["accel"] == "brute" {
            assert_eq!(
                r["extrapolated"] == "true",
                faces > QUICK_BRUTE_MAX_FACES,
                "{what}"
            );
            // Brute force tests every triangle for each closest-hit ray and
            // stops shadow rays at their first blocker: between
            // camera rays × faces and rays × faces tests.
            let tri = num(r, "triangle_tests");
            assert!(
                tri >= num(r, "camera_rays") * faces * (1.0 - 1e-6),
                "{what}"
            );
            assert!(tri <= rays * faces * (1.0 + 1e-6), "{what}");
            assert_eq!(num(r, "nodes_visited"), 0.0);
            if r["extrapolated"] == "true" {
                extrapolated += 1;
                assert!(num(r, "brute_sample_side") >= 8.0, "{what}");
                assert!(num(r, "render_median_s") > 0.0, "{what}");
            }
            assert_eq!(r["compared_with"], "", "{what}");
        } else {
            assert_eq!(r["extrapolated"], "false", "{what}");
            assert!(num(r, "bvh_nodes") >= 1.0, "{what}");
            assert!(num(r, "bvh_leaves") >= 1.0, "{what}");
            if r["accel"].starts_with("bvh:") {
                assert!(num(r, "bv_test_ns") > 0.0, "{what}");
            } else {
                // One volume test is timed for the binary trees only
                // (studies.md).
                assert_eq!(r["accel"], "bvh", "{what}");
                assert_eq!(r["bv_test_ns"], "", "{what}");
            }
            let reference = if faces <= QUICK_BRUTE_MAX_FACES {
                "brute"
            } else {
                "bvh:aabb:sah"
            };
            if r["accel"] == reference {
                assert_eq!(r["compared_with"], "", "{what}");
            } else {
                // S3's detail-loss test: exactly the same image.
                assert_eq!(r["compared_with"], reference, "{what}");
                assert_eq!(r["differing_pixels"], "0", "{what}");
                assert_eq!(r["image_equal"], "true", "{what}");
            }
        }
    }
    assert_eq!(extrapolated, 1, "icosphere:4 (5120 faces) is extrapolated");
    for f in [
        "s3-render-time",
        "s3-render-time-all",
        "s3-tests-per-ray",
        "s3-triangle-tests-per-ray",
        "s3-image-difference",
        "s3-render-time-box-trees",
    ] {
        assert!(out.join(format!("{f}.png")).is_file(), "{f}.png");
    }
}

/// A one-run `accel_cost` manifest whose `[fixed]` block is `fixed`.
fn manifest(fixed: &str) -> String {
    format!(
        "name = \"bad\"\nkind = \"accel_cost\"\n\n[fixed]\n{fixed}\n\n\
         [[sweep]]\nname = \"s\"\nresolution = [\"8x8\"]\n"
    )
}

/// Plan `fixed`'s manifest and assert the error names the manifest, the
/// line of `at` and each of `expect`.
fn assert_plan_error(fixed: &str, at: &str, expect: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let text = manifest(fixed);
    let path = dir.path().join("bad.toml");
    std::fs::write(&path, &text).unwrap();
    let err = load_manifest(&path)
        .and_then(|m| m.plan().map(|_| ()))
        .expect_err(fixed)
        .to_string();
    let line = text[..text.find(at).unwrap()].matches('\n').count() + 1;
    let place = format!("bad.toml:{line}:");
    assert!(err.contains(&place), "{err:?} should contain {place:?}");
    for e in expect {
        assert!(err.contains(e), "{err:?} should contain {e:?}");
    }
}

#[test]
fn bad_accel_cost_parameters_name_their_place() {
    let cube = format!(
        "mesh = {:?}",
        repo()
            .join("data/external/cgal/cube.off")
            .display()
            .to_string()
    );
    assert_plan_error(
        &format!("{cube}\naccel = \"bvh:cone\""),
        "accel = ",
        &["accel", "unknown volume `cone`"],
    );
    assert_plan_error(
        "mesh = \"no-such.off\"\naccel = \"brute\"",
        "mesh = ",
        &["no such mesh file"],
    );
    assert_plan_error(
        "procedural = \"icosphere:30\"\naccel = \"brute\"",
        "procedural = ",
        &["triangles; expected 1 to"],
    );
    assert_plan_error(
        "procedural = \"cube:3\"\naccel = \"brute\"",
        "procedural = ",
        &["not \"icosphere:LEVEL\""],
    );
    assert_plan_error(
        &format!("{cube}\nprocedural = \"icosphere:1\"\naccel = \"brute\""),
        "procedural = ",
        &["not both"],
    );
    assert_plan_error(
        &format!("{cube}\naccel = \"brute\"\nreference = \"brute\""),
        "reference = ",
        &["must not be `brute`"],
    );
    assert_plan_error(
        &format!("{cube}\naccel = \"brute\"\nbrute_max_faces = -1"),
        "brute_max_faces = ",
        &["brute_max_faces", "must be in"],
    );
    assert_plan_error(
        &format!("{cube}\naccel = \"brute\"\nbrute_sample_tests = \"many\""),
        "brute_sample_tests = ",
        &["must be a number"],
    );
    assert_plan_error(&cube, "[[sweep]]", &["`accel` is required"]);
}
