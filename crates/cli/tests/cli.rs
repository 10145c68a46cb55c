//! The `raylab` binary: bad input gets a clear error naming the file and the
//! line, a non-zero exit, and no output file.

use crate::{raylab, stderr, write};

const GOOD: &str = r#"[image]
width = 16
height = 12
[camera]
eye = [0.0, 0.0, 5.0]
look_at = [0.0, 0.0, 0.0]
fov = 40.0
[materials.m]
color = [0.5, 0.5, 0.5]
[[sphere]]
center = [0.0, 0.0, 0.0]
radius = 1.0
material = "m"
[[light]]
position = [2.0, 2.0, 2.0]
"#;

/// Run `render` on a scene text; assert failure, no output file, and that
/// stderr contains each of `expect`.
fn assert_render_fails(scene_text: &str, expect: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(dir.path(), "bad.toml", scene_text);
    let out = dir.path().join("out.png");
    let o = raylab(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    let err = stderr(&o);
    assert!(!o.status.success(), "should fail: {err}");
    assert!(!out.exists(), "no output may be left behind");
    assert!(
        std::fs::read_dir(dir.path()).unwrap().count() == 1,
        "no temporary files may be left behind"
    );
    assert!(!err.contains("panicked"), "{err}");
    for e in expect {
        assert!(err.contains(e), "stderr lacks {e:?}: {err}");
    }
}

#[test]
fn good_scene_renders_and_reports() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(dir.path(), "ok.toml", GOOD);
    for ext in ["png", "exr"] {
        let out = dir.path().join(format!("out.{ext}"));
        let o = raylab(&[
            "render",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--threads",
            "2",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let text = String::from_utf8_lossy(&o.stdout);
        for word in ["16×12", "camera", "shadow", "rays/s"] {
            assert!(text.contains(word), "stdout lacks {word}: {text}");
        }
        assert!(out.exists());
    }
}

#[test]
fn missing_scene_file() {
    let o = raylab(&["render", "no/such/scene.toml", "-o", "/tmp/never.png"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("no/such/scene.toml"), "{}", stderr(&o));
}

#[test]
fn malformed_toml_names_file_and_line() {
    let text = GOOD.replace("fov = 40.0", "fov = = 40.0");
    assert_render_fails(&text, &["bad.toml:7:"]);
}

#[test]
fn unknown_field_names_file_line_and_field() {
    let text = GOOD.replace("radius = 1.0", "radius = 1.0\nradiu = 2.0");
    assert_render_fails(&text, &["bad.toml:13:1:", "radiu"]);
}

#[test]
fn unknown_material_names_file_line_and_material() {
    let text = GOOD.replace("material = \"m\"", "material = \"gold\"");
    assert_render_fails(
        &text,
        &["bad.toml:13:12:", "unknown material `gold`", "`m`"],
    );
}

#[test]
fn bad_values_are_rejected() {
    assert_render_fails(
        &GOOD.replace("radius = 1.0", "radius = -1.0"),
        &["bad.toml:", "radius"],
    );
    assert_render_fails(
        &GOOD.replace("radius = 1.0", "radius = nan"),
        &["bad.toml:", "radius"],
    );
    assert_render_fails(
        &GOOD.replace("fov = 40.0", "fov = 0.0"),
        &["bad.toml", "view angle"],
    );
    assert_render_fails(
        &GOOD.replace("[0.0, 0.0, 5.0]", "[0.0, 0.0]"),
        &["bad.toml:5:"],
    );
    let mesh = format!("{GOOD}\n[[mesh]]\nfile = \"missing.off\"\nmaterial = \"m\"\n");
    assert_render_fails(&mesh, &["bad.toml:", "missing.off"]);
    // Every number finite, named by its field: a NaN eye is not "eye and
    // look_at coincide", and 1e39 is ∞ as the f32 the renderer uses.
    assert_render_fails(
        &GOOD.replace("[0.0, 0.0, 5.0]", "[0.0, 0.0, nan]"),
        &["bad.toml:5:", "`camera.eye[2]` is not a number"],
    );
    assert_render_fails(
        &GOOD.replace("position = [2.0, 2.0, 2.0]", "position = [2.0, inf, 2.0]"),
        &["bad.toml:", "`light[0].position[1]` is infinite"],
    );
    assert_render_fails(
        &GOOD.replace("radius = 1.0", "radius = 1e39"),
        &["bad.toml:", "`sphere[0].radius`", "32-bit float"],
    );
    // An image the machine cannot hold: refused before allocating, with
    // the size and the memory it would need.
    let huge = GOOD.replace("width = 16\nheight = 12", "width = 100000\nheight = 100000");
    assert_render_fails(
        &huge,
        &["bad.toml:", "100000×100000", "would need", "GB of memory"],
    );
}

/// Two parallel mirrors and no cut-off but a depth of a million: the
/// Whitted recursion, run as a loop, cannot overflow the stack (it used
/// to abort with signal 6); 2×2 pixels of a million bounces each.
#[test]
fn mirror_corridor_of_a_million_bounces_renders() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(
        dir.path(),
        "corridor.toml",
        r#"[image]
width = 2
height = 2
[render]
max_depth = 1000000
min_weight = 0.0
[camera]
eye = [0.0, 0.0, 0.0]
look_at = [1.0, 0.0, 0.0]
fov = 30.0
[materials.mirror]
color = [0.1, 0.1, 0.1]
reflectivity = 1.0
[[plane]]
point = [5.0, 0.0, 0.0]
normal = [-1.0, 0.0, 0.0]
material = "mirror"
[[plane]]
point = [-5.0, 0.0, 0.0]
normal = [1.0, 0.0, 0.0]
material = "mirror"
[[light]]
position = [0.0, 1.0, 0.0]
"#,
    );
    let out = dir.path().join("c.png");
    let o = raylab(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("3999996 reflection"), "{text}");
    assert!(out.is_file());
}

#[test]
fn bad_arguments_fail_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(dir.path(), "ok.toml", GOOD);
    let s = scene.to_str().unwrap();
    let out = dir.path().join("x.jpg");
    let o = raylab(&["render", s, "-o", out.to_str().unwrap()]);
    assert!(!o.status.success() && stderr(&o).contains("x.jpg"));
    let png = dir.path().join("x.png");
    for bad in [
        vec!["--threads", "0"],
        vec!["--sampler", "jitter"],
        vec!["--accel", "octree"],
        vec!["--width", "-3"],
        vec!["--width", "0"],
    ] {
        let mut args = vec!["render", s, "-o", png.to_str().unwrap()];
        args.extend(bad.iter());
        let o = raylab(&args);
        assert!(!o.status.success(), "{bad:?} should fail");
        assert!(!png.exists(), "{bad:?} left an output");
        assert!(!stderr(&o).contains("panicked"), "{}", stderr(&o));
    }
    // A missing output folder is made; one that cannot be (its parent is a
    // file, which stops even root) is an error naming the output.
    let nested = dir.path().join("new/folder/out.png");
    let o = raylab(&["render", s, "-o", nested.to_str().unwrap()]);
    assert!(o.status.success() && nested.is_file(), "{}", stderr(&o));
    let blocked = scene.join("out.png");
    let o = raylab(&["render", s, "-o", blocked.to_str().unwrap()]);
    assert!(
        !o.status.success() && stderr(&o).contains(blocked.to_str().unwrap()),
        "{}",
        stderr(&o)
    );
}

/// A bad integrator name or roulette depth fails before anything is
/// written, naming the accepted forms.
#[test]
fn bad_integrator_arguments_fail_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(dir.path(), "s.toml", GOOD);
    let out = dir.path().join("out.png");
    for (args, expect) in [
        (vec!["--integrator", "pathtracer"], "path:K"),
        (vec!["--integrator", "path:-1"], "0..="),
        (vec!["--rr-depth", "soon"], "off"),
    ] {
        let mut all = vec![
            "render",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ];
        all.extend(args);
        let o = raylab(&all);
        assert!(
            !o.status.success() && stderr(&o).contains(expect),
            "{}",
            stderr(&o)
        );
        assert!(!out.exists());
    }
    // A reference of another size is an error, and nothing is written.
    let reference = dir.path().join("ref.png");
    let small = write(
        dir.path(),
        "small.toml",
        &GOOD.replace("width = 16", "width = 8"),
    );
    assert!(raylab(&[
        "render",
        small.to_str().unwrap(),
        "-o",
        reference.to_str().unwrap()
    ])
    .status
    .success());
    let o = raylab(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--integrator",
        "direct",
        "--reference",
        reference.to_str().unwrap(),
    ]);
    assert!(
        !o.status.success() && stderr(&o).contains("sizes differ"),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists());
}

/// obvhs holds triangle meshes only: a scene of a sphere is refused, the
/// sphere named, with no output and no panic.
#[cfg(feature = "obvhs")]
#[test]
fn obvhs_refuses_a_sphere_scene() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(dir.path(), "sphere.toml", GOOD);
    let out = dir.path().join("out.png");
    let o = raylab(&[
        "render",
        scene.to_str().unwrap(),
        "--accel",
        "obvhs",
        "-o",
        out.to_str().unwrap(),
    ]);
    let err = stderr(&o);
    assert!(!o.status.success(), "should fail: {err}");
    assert!(!out.exists(), "no output may be left behind");
    assert!(!err.contains("panicked"), "{err}");
    assert!(
        err.contains("obvhs") && err.contains("triangle meshes only") && err.contains("1 sphere"),
        "{err}"
    );
}

#[test]
fn help_documents_every_render_option() {
    let o = raylab(&["render", "--help"]);
    let text = String::from_utf8_lossy(&o.stdout);
    for opt in [
        "--output",
        "--width",
        "--height",
        "--threads",
        "--sampler",
        "--accel",
        "--max-depth",
        "--seed",
        "--integrator",
        "--rr-depth",
        "--reference",
    ] {
        assert!(text.contains(opt), "--help lacks {opt}");
    }
}

/// `raylab validate`: a clean run exits 0 and writes its CSV and figures;
/// a tolerance it cannot meet makes it exit non-zero; bad input fails with
/// the file named and nothing written.
#[cfg(feature = "embree")]
mod validate {
    use super::{raylab, stderr, write, GOOD};

    fn external(rel: &str) -> String {
        raylab_testkit::repo()
            .join("data/external")
            .join(rel)
            .to_string_lossy()
            .into_owned()
    }

    #[test]
    fn clean_run_writes_csv_and_figures() {
        let dir = tempfile::tempdir().unwrap();
        let csv = dir.path().join("worst.csv");
        let out = dir.path().join("figs");
        let o = raylab(&[
            "validate",
            "--mesh",
            &external("assimp/3DS/fels.3ds"),
            "--rays",
            "2e3",
            "--csv",
            csv.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let text = String::from_utf8_lossy(&o.stdout);
        for set in [
            "random", "surface", "camera", "inside", "edges", "vertices", "grazing",
        ] {
            assert!(text.contains(set), "no {set} row: {text}");
        }
        // Header plus at least one worst case (edge rays always give some).
        let rows = std::fs::read_to_string(&csv).unwrap().lines().count();
        assert!(rows > 1, "{rows} lines in the CSV");
        for stem in [
            "validate-rel-dt",
            "validate-normal-angle",
            "validate-disagreements",
        ] {
            assert!(out.join(format!("{stem}.png")).is_file(), "{stem}.png");
            assert!(out.join(format!("{stem}.svg")).is_file(), "{stem}.svg");
        }
    }

    /// Rays aimed at edges disagree now and then by rounding: demanding
    /// none (`--max-borderline 0`) is a breach. (`--t-rel 0` no longer is
    /// on the camel: the rounding floor of the coordinates, which now
    /// includes the triangle's own, covers every |Δt| there.)
    #[test]
    fn tolerance_breach_exits_non_zero() {
        let mesh = external("cgal/camel.off");
        let args = [
            "validate",
            "--mesh",
            &mesh,
            "--rays",
            "2000",
            "--max-borderline",
            "0",
        ];
        let o = raylab(&args);
        let err = stderr(&o);
        assert!(!o.status.success(), "--max-borderline 0 should fail");
        assert!(err.contains("tolerances exceeded"), "{err}");
        assert!(!err.contains("panicked"), "{err}");
    }

    #[test]
    fn bad_input_fails_cleanly() {
        let dir = tempfile::tempdir().unwrap();
        let csv = dir.path().join("worst.csv");
        let scene = write(dir.path(), "ok.toml", GOOD);
        let cases: Vec<(Vec<String>, &str)> = vec![
            (vec!["--mesh".into(), "no/such.off".into()], "no/such.off"),
            (
                vec!["--mesh".into(), external("assimp/invalid/empty.off")],
                "empty.off",
            ),
            (
                vec!["--mesh".into(), external("assimp/OFF/invalid.off")],
                "invalid.off",
            ),
            (
                vec!["--mesh".into(), external("assimp/invalid/malformed.obj")],
                "malformed.obj",
            ),
            (
                vec![
                    "--scene".into(),
                    scene.to_string_lossy().into(),
                    "--rays".into(),
                    "lots".into(),
                ],
                "lots",
            ),
            (
                vec![
                    "--scene".into(),
                    scene.to_string_lossy().into(),
                    "--t-rel".into(),
                    "-1".into(),
                ],
                "-1",
            ),
            (
                vec![
                    "--scene".into(),
                    scene.to_string_lossy().into(),
                    "--accel".into(),
                    "octree".into(),
                ],
                "octree",
            ),
            (vec![], "--mesh"),
        ];
        for (extra, expect) in cases {
            let mut args = vec!["validate".to_string()];
            args.extend(extra.iter().cloned());
            args.extend(["--csv".to_string(), csv.to_string_lossy().into()]);
            let o = raylab(&args.iter().map(String::as_str).collect::<Vec<_>>());
            let err = stderr(&o);
            assert!(!o.status.success(), "{extra:?} should fail");
            assert!(
                err.contains(expect),
                "{extra:?}: stderr lacks {expect:?}: {err}"
            );
            assert!(!err.contains("panicked"), "{err}");
            assert!(!csv.exists(), "{extra:?} left a CSV");
        }
    }
}

#[test]
fn grad_writes_derivative_images_and_reports() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(dir.path(), "s.toml", GOOD);
    let out = dir.path().join("g");
    let o = raylab(&[
        "grad",
        scene.to_str().unwrap(),
        "--param",
        "materials.m.color",
        "--param",
        "light[0].intensity",
        "--check",
        "fd",
        "-o",
        out.to_str().unwrap(),
    ]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", stderr(&o));
    for want in [
        "4 parameters",
        "∂mean/∂p",
        "light[0].intensity",
        "central differences",
    ] {
        assert!(text.contains(want), "`{want}` missing from:\n{text}");
    }
    assert!(out.join("image.exr").is_file());
    for p in [
        "materials.m.color[0]",
        "materials.m.color[2]",
        "light[0].intensity",
    ] {
        for ext in ["exr", "png", "svg", "fd-diff.png"] {
            assert!(out.join(format!("{p}.{ext}")).is_file(), "{p}.{ext}");
        }
    }
    let exr = raylab::io::image::read_exr_channels(&out.join("light[0].intensity.exr")).unwrap();
    for ch in [
        "R",
        "G",
        "B",
        "variance.R",
        "variance.G",
        "variance.B",
        "count",
    ] {
        assert!(exr.get(ch).is_some(), "channel {ch}");
    }
}

#[test]
fn grad_errors_name_the_parameter_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(dir.path(), "s.toml", GOOD);
    let out = dir.path().join("g");
    let run = |args: &[&str]| {
        let mut all = vec!["grad", scene.to_str().unwrap(), "-o", out.to_str().unwrap()];
        all.extend_from_slice(args);
        raylab(&all)
    };
    for (args, wants) in [
        (
            &["--param", "sphere[3].radius"][..],
            &["sphere[3].radius", "1 `[[sphere]]` entry"][..],
        ),
        (
            &["--param", "materials.q.color"][..],
            &["no material `q`", "`m`"][..],
        ),
        (&["--param", "image.width"][..], &["integers"][..]),
        (
            &["--param", "light[0].intensity", "--integrator", "floodfill"][..],
            &["flood fill"][..],
        ),
        (
            &["--param", "light[0].intensity", "--sampler", "adaptive"][..],
            &["adaptive"][..],
        ),
        (
            &["--param", "materials.m.reflectivity", "--check", "fd"][..],
            &["materials.m.reflectivity set to -0.00", "smaller step"][..],
        ),
    ] {
        let o = run(args);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
        for w in wants {
            assert!(err.contains(w), "{args:?}: `{err}` lacks `{w}`");
        }
        assert!(!err.contains("panicked"), "{err}");
        assert!(!out.exists(), "{args:?}: nothing may be written");
    }
    // Bad option values are usage errors (exit 2).
    let o = run(&["--param", "light[0].intensity", "--check", "fd:-1"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}

/// A signal on a render in progress (each of io::interrupt::SIGNALS:
/// Ctrl-C, SIGTERM, a closed terminal's SIGHUP, …): the process ends with 128 + the signal's
/// number, through raylab's handler (a default death has no exit code),
/// and leaves neither the output nor a temporary file (io::interrupt).
#[cfg(unix)]
#[test]
fn interrupted_render_leaves_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let slow = GOOD
        .replace("width = 16\nheight = 12", "width = 64\nheight = 64")
        .replace(
            "[materials.m]",
            "[render]\nsampler = \"random:4096\"\n[materials.m]",
        );
    let scene = write(dir.path(), "slow.toml", &slow);
    let out = dir.path().join("slow.png");
    for signal in raylab::io::interrupt::SIGNALS {
        let mut child = crate::raylab_command()
            .args([
                "render",
                scene.to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
            ])
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        std::thread::sleep(std::time::Duration::from_millis(300));
        // SAFETY: `kill` takes no pointer (it is `unsafe` only as a foreign
        // call); the pid is our own child's, not yet waited for, so it cannot
        // have been reaped and reused: the signal reaches the process we spawned.
        unsafe {
            libc::kill(child.id() as libc::pid_t, signal);
        }
        let status = child.wait().unwrap();
        assert_eq!(
            status.code(),
            Some(128 + signal),
            "signal {signal}: {status:?}"
        );
        let left: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(left, vec![std::ffi::OsString::from("slow.toml")]);
    }
}
