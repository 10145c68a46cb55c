//! `--set PATH=VALUE` on `render` and `grad`: a parameter of the scene set
//! through the parameter table changes the image as it should, gives the
//! same bits as the scene file edited by hand, and every refusal (an
//! unknown parameter, a value of the wrong shape, a value out of range,
//! text that is not PATH=VALUE) names `--set` and the parameter, exits
//! with status 2 and writes nothing.

use crate::{raylab, stderr, write};
use raylab::film::LinearImage;
use raylab::io::image::read_image;
use std::path::Path;

/// 16×12 pixels: a grey sphere lit by one light in front of a coloured
/// background, and a second, smaller sphere.
const SCENE: &str = r#"[image]
width = 16
height = 12
[camera]
eye = [0.0, 0.0, 5.0]
look_at = [0.0, 0.0, 0.0]
fov = 40.0
[render]
background = [0.2, 0.3, 0.4]
[materials.m]
color = [0.5, 0.5, 0.5]
[[sphere]]
center = [0.0, 0.0, 0.0]
radius = 1.0
material = "m"
[[sphere]]
center = [1.2, 0.8, 0.5]
radius = 0.3
material = "m"
[[light]]
position = [2.0, 2.0, 2.0]
"#;

/// `raylab render SCENE -o OUT ARGS…`, which must succeed; the image.
fn render(scene: &Path, out: &Path, args: &[&str]) -> LinearImage {
    let mut all = vec![
        "render",
        scene.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "-q",
    ];
    all.extend_from_slice(args);
    let o = raylab(&all);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    read_image(out).unwrap()
}

/// The pixels (row-major) and whether each shows the background.
fn pixels(img: &LinearImage) -> Vec<[f32; 3]> {
    let (h, w, _) = img.dim();
    (0..h)
        .flat_map(|y| (0..w).map(move |x| (y, x)))
        .map(|(y, x)| [img[[y, x, 0]], img[[y, x, 1]], img[[y, x, 2]]])
        .collect()
}

const BACKGROUND: [f32; 3] = [0.2, 0.3, 0.4];

#[test]
fn lights_and_ambient_off_leave_black_objects_on_the_background() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(dir.path(), "s.toml", SCENE);
    let lit = pixels(&render(&scene, &dir.path().join("lit.exr"), &[]));
    let dark = pixels(&render(
        &scene,
        &dir.path().join("dark.exr"),
        &[
            "--set",
            "light[0].intensity=0",
            "--set",
            "render.ambient=[0,0,0]",
        ],
    ));
    let objects = lit.iter().filter(|p| **p != BACKGROUND).count();
    assert!(
        objects > 20 && objects < lit.len(),
        "{objects} object pixels"
    );
    for (l, d) in lit.iter().zip(&dark) {
        if *l == BACKGROUND {
            assert_eq!(*d, BACKGROUND);
        } else {
            assert!(l.iter().any(|&c| c > 0.0), "a lit object pixel is black");
            assert_eq!(*d, [0.0; 3], "an object pixel without light: {d:?}");
        }
    }
}

#[test]
fn a_tiny_radius_makes_the_sphere_vanish() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(dir.path(), "s.toml", SCENE);
    let objects = |img: &LinearImage| pixels(img).iter().filter(|p| **p != BACKGROUND).count();
    let before = objects(&render(&scene, &dir.path().join("a.exr"), &[]));
    let after = objects(&render(
        &scene,
        &dir.path().join("b.exr"),
        &["--set", "sphere[0].radius=0.01"],
    ));
    // Sphere 0 covers most of the object pixels; a radius of 0.01 at
    // distance 5 is a thirtieth of a pixel, left to a centre sample by luck.
    let small = objects(&render(
        &scene,
        &dir.path().join("c.exr"),
        &[
            "--set",
            "sphere[0].radius=0.01",
            "--set",
            "sphere[1].radius=0.01",
        ],
    ));
    assert!(before > 30, "{before}");
    assert!(after < before / 3 && after > 0, "{before} → {after}");
    assert!(small <= 1, "{small} pixels left");
}

/// Whether two images are the same, bit for bit.
fn same_bits(a: &LinearImage, b: &LinearImage) -> bool {
    a.dim() == b.dim()
        && a.iter()
            .zip(b.iter())
            .all(|(x, y)| x.to_bits() == y.to_bits())
}

/// The settings of the bit-for-bit tests, and the scene file edited by hand
/// to the values they leave (the component set after its vector wins).
const SETTINGS: &[&str] = &[
    "materials.m.color=[0.2, 0.9, 0.4]",
    "materials.m.color[0]=0.7",
    "camera.fov=50",
    "sphere[0].center=[0.3,0.1,0]",
    "light[0].intensity=0.45",
    "render.ambient=[0.5,0.6,0.7]",
];

fn edited() -> String {
    let s = SCENE
        .replace("color = [0.5, 0.5, 0.5]", "color = [0.7, 0.9, 0.4]")
        .replace("fov = 40.0", "fov = 50")
        .replace("center = [0.0, 0.0, 0.0]", "center = [0.3, 0.1, 0.0]")
        .replace(
            "position = [2.0, 2.0, 2.0]",
            "position = [2.0, 2.0, 2.0]\nintensity = 0.45",
        )
        .replace(
            "background = [0.2, 0.3, 0.4]",
            "background = [0.2, 0.3, 0.4]\nambient = [0.5, 0.6, 0.7]",
        );
    assert_ne!(s, SCENE);
    s
}

fn set_args() -> Vec<&'static str> {
    SETTINGS.iter().flat_map(|s| ["--set", *s]).collect()
}

#[test]
fn set_renders_what_the_edited_file_renders_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(dir.path(), "s.toml", SCENE);
    let edited = write(dir.path(), "edited.toml", &edited());
    let plain = render(
        &scene,
        &dir.path().join("plain.exr"),
        &["--sampler", "jitter:2"],
    );
    for ext in ["exr", "png"] {
        let set_out = dir.path().join(format!("set.{ext}"));
        let file_out = dir.path().join(format!("file.{ext}"));
        let mut args = vec!["--sampler", "jitter:2"];
        args.extend(set_args());
        let set = render(&scene, &set_out, &args);
        let file = render(&edited, &file_out, &["--sampler", "jitter:2"]);
        assert!(
            same_bits(&set, &file),
            "{ext}: --set and the edited file differ"
        );
        assert!(!same_bits(&set, &plain), "{ext}: --set changed nothing");
        if ext == "png" {
            assert_eq!(
                std::fs::read(&set_out).unwrap(),
                std::fs::read(&file_out).unwrap()
            );
        }
    }
}

#[test]
fn grad_takes_set_too() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(dir.path(), "s.toml", SCENE);
    let edited = write(dir.path(), "edited.toml", &edited());
    let grad = |scene: &Path, out: &str, set: &[&str]| {
        let out = dir.path().join(out);
        let mut args = vec![
            "grad",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--param",
            "light[0].intensity",
            "--param",
            "sphere[0].radius",
            "--visibility",
            "interior",
        ];
        args.extend_from_slice(set);
        let o = raylab(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        let text = String::from_utf8_lossy(&o.stdout).into_owned();
        let images = [
            "image.exr",
            "light[0].intensity.exr",
            "sphere[0].radius.exr",
        ]
        .map(|f| read_image(&out.join(f)).unwrap());
        (text, images)
    };
    let (set_text, set) = grad(&scene, "set", &set_args());
    let (file_text, file) = grad(&edited, "file", &[]);
    for (a, b) in set.iter().zip(&file) {
        assert!(same_bits(a, b), "grad: --set and the edited file differ");
    }
    // The parameters' values are the set ones.
    for text in [&set_text, &file_text] {
        assert!(text.contains("0.45"), "{text}");
    }
}

#[test]
fn bad_settings_are_usage_errors_naming_the_parameter() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(dir.path(), "s.toml", SCENE);
    let out = dir.path().join("out.png");
    let grad_out = dir.path().join("g");
    for (setting, wants) in [
        // Parameters the scene does not have (what exists is listed).
        (
            "sphere[3].radius=1",
            &[
                "sphere[3].radius",
                "2 `[[sphere]]` entries",
                "sphere[0]…sphere[1]",
            ][..],
        ),
        (
            "materials.q.color=[1,1,1]",
            &["materials.q.color", "no material `q`", "`m`"][..],
        ),
        (
            "sphere[0].size=2",
            &["no field `size`", "`sphere[0].center`, `sphere[0].radius`"][..],
        ),
        (
            "lamp[0].intensity=0",
            &["lamp[0].intensity", "unknown section `lamp`", "`light[i]`"][..],
        ),
        (
            "render.max_depth=2",
            &["render.max_depth", "an integer", "use --max-depth"][..],
        ),
        ("camera.aspect=2", &["camera.aspect", "is not set"][..]),
        // Values of the wrong shape.
        (
            "render.ambient=2",
            &[
                "render.ambient",
                "takes a vector `[x,y,z]`",
                "`render.ambient[0]=…`",
                "got a number",
            ][..],
        ),
        (
            "light[0].intensity=[1,1,1]",
            &[
                "light[0].intensity",
                "takes a number, got a list of 3 numbers",
            ][..],
        ),
        (
            "materials.m.color[1]=[0.5]",
            &[
                "materials.m.color[1]",
                "takes a number, got a list of 1 number",
            ][..],
        ),
        (
            "sphere[0].center=[1,2]",
            &[
                "sphere[0].center",
                "takes a vector",
                "got a list of 2 numbers",
            ][..],
        ),
        // Values out of range: the scene file's own checks.
        (
            "sphere[0].radius=-1",
            &["--set sphere[0].radius: `radius` must be positive, got -1"][..],
        ),
        (
            "materials.m.ior=0",
            &["--set materials.m.ior: material `m`:", "ior"][..],
        ),
        (
            "camera.fov=200",
            &["--set camera.fov: [camera]: view angle must be in (0, 180) degrees, got 200"][..],
        ),
        (
            "camera.eye=[0,0,0]",
            &["--set camera.eye: [camera]: eye and look_at coincide"][..],
        ),
        (
            "sphere[1].center=[0,0,2e12]",
            &["--set sphere[1].center:", "lies beyond ±1e12"][..],
        ),
        (
            "light[0].color=[-1,0,0]",
            &["--set light[0].color:", "non-negative"][..],
        ),
        // Text that is not PATH=VALUE (refused by the command line's parser).
        (
            "light[0].intensity",
            &["--set", "has no `=`", "PATH=VALUE"][..],
        ),
        ("=1", &["--set", "no parameter before `=`"][..]),
        (
            "light[0].intensity=",
            &["--set", "light[0].intensity", "no value"][..],
        ),
        (
            "light[0].intensity=bright",
            &["light[0].intensity", "`bright` is not a number"][..],
        ),
        (
            "light[0].intensity=nan",
            &["light[0].intensity", "`nan` is not a finite number"][..],
        ),
        (
            "light[0].intensity=1e39",
            &["light[0].intensity", "`1e39` is not a finite number"][..],
        ),
        (
            "render.ambient=[1,1",
            &["render.ambient", "does not end with `]`"][..],
        ),
    ] {
        for cmd in ["render", "grad"] {
            let mut args = vec![cmd, scene.to_str().unwrap(), "--set", setting];
            match cmd {
                "render" => args.extend(["-o", out.to_str().unwrap()]),
                _ => args.extend(["-o", grad_out.to_str().unwrap(), "--param", "camera.fov"]),
            }
            let o = raylab(&args);
            let err = stderr(&o);
            assert_eq!(o.status.code(), Some(2), "{cmd} --set {setting}: {err}");
            for w in wants {
                assert!(
                    err.contains(w),
                    "{cmd} --set {setting}: `{err}` lacks `{w}`"
                );
            }
            assert!(!err.contains("panicked"), "{err}");
            assert!(
                !out.exists() && !grad_out.exists(),
                "{setting}: nothing may be written"
            );
        }
    }
}

/// A value out of range gets the message the scene file gets with that
/// value, naming `--set PATH` instead of the file and its line; the
/// setting after which the scene stopped being valid is the one named.
#[test]
fn out_of_range_values_get_the_scene_files_message() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(dir.path(), "s.toml", SCENE);
    for (setting, from, to) in [
        ("sphere[0].radius=-1", "radius = 1.0", "radius = -1"),
        ("camera.fov=200", "fov = 40.0", "fov = 200"),
        (
            "materials.m.ior=-1.5",
            "color = [0.5, 0.5, 0.5]",
            "color = [0.5, 0.5, 0.5]\nior = -1.5",
        ),
    ] {
        let bad = write(dir.path(), "bad.toml", &SCENE.replacen(from, to, 1));
        let out = dir.path().join("x.png");
        let file = raylab(&["render", bad.to_str().unwrap(), "-o", out.to_str().unwrap()]);
        let set = raylab(&[
            "render",
            scene.to_str().unwrap(),
            "--set",
            "light[0].intensity=2",
            "--set",
            setting,
            "--set",
            "camera.near=0.5",
            "-o",
            out.to_str().unwrap(),
        ]);
        let (file_err, set_err) = (stderr(&file), stderr(&set));
        let path = setting.split_once('=').unwrap().0;
        let message = set_err
            .strip_prefix(&format!("error: --set {path}: "))
            .unwrap_or_else(|| panic!("{set_err}"));
        assert!(
            file_err.ends_with(message),
            "file: {file_err}set: {set_err}"
        );
        assert_eq!(set.status.code(), Some(2));
        assert!(!out.exists());
    }
}
