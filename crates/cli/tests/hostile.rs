//! The hostile-input suite: small generated inputs of every class that
//! once crashed, hung or misled raylab (geometry at the edge of `f32`,
//! files that are not regular files, absurd thread counts and ray trees,
//! outputs that would overwrite inputs, non-finite images), each run
//! through every subcommand it applies to. Every case must end within
//! [`LIMIT`] with exit status 1 or 2 (or 0 where the input is valid),
//! print the expected cause, never panic, leave no temporary file, and
//! leave its inputs as they were.

use std::path::{Path, PathBuf};
use std::process::{Output, Stdio};
use std::time::{Duration, Instant};

/// The longest any case may run: a refusal comes at once, and the valid
/// cases render a few pixels.
const LIMIT: Duration = Duration::from_secs(60);

use crate::LIT_SPHERE as BASE;

/// Two facing mirrors, each ray spawning one more, for ever.
const MIRRORS: &str = r#"[image]
width = 8
height = 6
[camera]
eye = [0.0, 0.0, 0.5]
look_at = [0.0, 0.0, -1.0]
fov = 40.0
[render]
max_depth = 4294967295
min_weight = 0.0
[materials.mirror]
reflectivity = 1.0
[[plane]]
point = [0.0, 0.0, -1.0]
normal = [0.0, 0.0, 1.0]
material = "mirror"
[[plane]]
point = [0.0, 0.0, 1.0]
normal = [0.0, 0.0, -1.0]
material = "mirror"
"#;

/// A grid of glass spheres at depth 64: a refraction tree of 2⁶⁴ rays.
fn glass_grid() -> String {
    let mut s = String::from(
        "[image]\nwidth = 8\nheight = 6\n[camera]\neye = [0.0, 0.0, 12.0]\n\
         look_at = [0.0, 0.0, 0.0]\nfov = 40.0\n[render]\nmax_depth = 64\n\
         [materials.glass]\nreflectivity = 0.1\ntransparency = 0.9\nior = 1.5\n",
    );
    for i in 0..5 {
        for j in 0..5 {
            s += &format!(
                "[[sphere]]\ncenter = [{}.0, {}.0, 0.0]\nradius = 0.9\nmaterial = \"glass\"\n",
                2 * i - 4,
                2 * j - 4
            );
        }
    }
    s
}

/// What a case's input folder holds, made fresh for each case.
struct Inputs {
    dir: tempfile::TempDir,
}

impl Inputs {
    fn new() -> Self {
        let inputs = Self {
            dir: tempfile::tempdir().unwrap(),
        };
        inputs.text("ok.toml", BASE);
        inputs.text("mirrors.toml", MIRRORS);
        inputs.text("glass.toml", &glass_grid());
        inputs.text(
            "far-triangle.toml",
            &BASE.replace(
                "[[light]]",
                "[[triangle]]\nvertices = [[-1e38, 0.0, 0.0], [1e38, 0.0, 0.0], [0.0, 1.0, 0.0]]\n\
                 material = \"m\"\n[[light]]",
            ),
        );
        inputs.text(
            "far-eye.toml",
            &BASE.replace("eye = [0.0, 0.0, 5.0]", "eye = [0.0, 1.0, 3e38]"),
        );
        inputs.text(
            "bright-light.toml",
            &BASE.replace(
                "position = [2.0, 2.0, 2.0]",
                "position = [2.0, 2.0, 2.0]\ncolor = [1e30, 1e30, 1e30]\nintensity = 1e30",
            ),
        );
        inputs.text(
            "dotted.toml",
            &BASE.replace(
                "[materials.m]\ncolor = [0.5, 0.5, 0.5]",
                "[materials]\nm.color = [0.5, 0.5, 0.5]",
            ),
        );
        inputs.text("image.exr", BASE);
        inputs.text("tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
        inputs.text("far.obj", "v -1e38 0 0\nv 1e38 0 0\nv 0 1 0\nf 1 2 3\n");
        inputs.text(
            "huge-scale.toml",
            &BASE.replace(
                "[[light]]",
                "[[mesh]]\nfile = \"tri.obj\"\nscale = 3e38\nmaterial = \"m\"\n[[light]]",
            ),
        );
        inputs.text(
            "fifo-mesh.toml",
            &BASE.replace(
                "[[light]]",
                "[[mesh]]\nfile = \"fifo.obj\"\nmaterial = \"m\"\n[[light]]",
            ),
        );
        inputs.text(
            "threads.toml",
            "name = \"t\"\nkind = \"render_cost\"\ndescription = \"threads\"\n\
             threads = 100000\n[fixed]\nscene = \"ok.toml\"\n[[sweep]]\nname = \"s\"\n\
             sampler = [\"centre\"]\n",
        );
        inputs.text(
            "many.toml",
            "name = \"t\"\nkind = \"render_cost\"\ndescription = \"many\"\n\
             [fixed]\nscene = \"ok.toml\"\n\
             [[sweep]]\nname = \"a\"\nseed = { from = 1, to = 1000, step = 1 }\n\
             max_depth = { from = 0, to = 599, step = 1 }\n\
             [[sweep]]\nname = \"b\"\nseed = { from = 1, to = 1000, step = 1 }\n\
             max_depth = { from = 0, to = 599, step = 1 }\n",
        );
        std::fs::create_dir(inputs.path("exp")).unwrap();
        inputs.text(
            "exp/data.csv",
            "name = \"t\"\nkind = \"render_cost\"\ndescription = \"clobbers itself\"\n\
             [fixed]\nscene = \"../ok.toml\"\n[[sweep]]\nname = \"s\"\n\
             sampler = [\"centre\"]\n",
        );
        std::fs::create_dir(inputs.path("folder.toml")).unwrap();
        for fifo in ["fifo.toml", "fifo.obj", "fifo.png"] {
            let c = std::ffi::CString::new(inputs.path(fifo).to_str().unwrap()).unwrap();
            // SAFETY: `c` is a live NUL-terminated path for the call.
            assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        }
        // Images: a small PNG, and an EXR whose left half is NaN.
        let (w, h) = (8u32, 6u32);
        let png = image::RgbImage::from_pixel(w, h, image::Rgb([128, 64, 32]));
        png.save(inputs.path("a.png")).unwrap();
        let nan: Vec<f32> = (0..w * h * 3)
            .map(|i| if (i / 3) % w < w / 2 { f32::NAN } else { 0.25 })
            .collect();
        image::Rgb32FImage::from_raw(w, h, nan)
            .unwrap()
            .save(inputs.path("nan.exr"))
            .unwrap();
        let spec = |target: &str| {
            format!(
                "scene = \"ok.toml\"\nintegrator = \"whitted\"\nsampler = \"centre\"\n\
                 snapshot_sampler = \"centre\"\niterations = 2\nloss = \"l2\"\n\
                 [target]\nimage = \"{target}\"\n[optimizer]\nkind = \"gd\"\n\
                 learning_rate = 0.1\n[[param]]\nname = \"materials.m.color[0]\"\n\
                 start = 0.5\nmin = 0.0\nmax = 1.0\n"
            )
        };
        inputs.text("nan-target.toml", &spec("nan.exr"));
        std::fs::create_dir(inputs.path("own")).unwrap();
        png.save(inputs.path("own/target.png")).unwrap();
        inputs.text(
            "own/spec.toml",
            &spec("target.png").replace("ok.toml", "../ok.toml"),
        );
        inputs
    }

    fn text(&self, name: &str, text: &str) {
        std::fs::write(self.path(name), text).unwrap();
    }

    fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }

    /// Every regular file's name and bytes, and every other entry's name.
    fn snapshot(&self) -> Vec<(PathBuf, Option<Vec<u8>>)> {
        let mut all = Vec::new();
        walk(self.dir.path(), &mut all);
        all.sort();
        all
    }
}

fn walk(dir: &Path, all: &mut Vec<(PathBuf, Option<Vec<u8>>)>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        let t = std::fs::symlink_metadata(&p).unwrap().file_type();
        if t.is_dir() {
            walk(&p, all);
        }
        let bytes = t.is_file().then(|| std::fs::read(&p).unwrap());
        all.push((p, bytes));
    }
}

/// What a case must end with.
enum Expect {
    /// Exit status 1 or 2, stderr containing this.
    Refused(&'static str),
    /// Exit status 0, stdout containing this.
    Runs(&'static str),
}

/// `raylab ARGS…` in `dir`, killed (and failed) after [`LIMIT`].
fn run_bounded(dir: &Path, args: &[&str]) -> Output {
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_raylab"))
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > LIMIT {
            child.kill().unwrap();
            child.wait().unwrap();
            panic!("raylab {args:?} ran past {LIMIT:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

/// The cases: (arguments, expectation). Paths are relative to the case's
/// input folder.
fn cases() -> Vec<(Vec<&'static str>, Expect)> {
    use Expect::*;
    let beyond = "lies beyond ±1e12";
    let mut cases: Vec<(Vec<&str>, Expect)> = Vec::new();
    // Geometry at the edge of f32, in every command that builds a scene.
    for scene_cmd in scene_commands("far-triangle.toml") {
        cases.push((scene_cmd, Refused(beyond)));
    }
    for accel in ["bvh4", "bvh2", "bvh:sphere:s3", "obvhs", "embree", "brute"] {
        cases.push((
            vec![
                "render",
                "far-triangle.toml",
                "-o",
                "x.png",
                "--accel",
                accel,
            ],
            Refused(beyond),
        ));
    }
    cases.push((
        vec!["render", "huge-scale.toml", "-o", "x.png"],
        Refused("the mesh reaches"),
    ));
    cases.push((
        vec!["validate", "--mesh", "far.obj"],
        Refused("far.obj:1: vertex [-1e38, 0, 0] lies beyond"),
    ));
    cases.push((
        vec!["render", "far-eye.toml", "-o", "x.png"],
        Refused("`eye` = [0, 1, 3e38] lies beyond"),
    ));
    cases.push((
        vec!["render", "bright-light.toml", "-o", "x.png"],
        Refused("overflows single precision"),
    ));
    // Files that are not regular files, wherever a file is read.
    for (scene_cmd, what) in scene_commands("fifo.toml")
        .into_iter()
        .map(|c| (c, "is a FIFO"))
        .chain(
            scene_commands("folder.toml")
                .into_iter()
                .map(|c| (c, "is a directory")),
        )
    {
        cases.push((scene_cmd, Refused(what)));
    }
    cases.push((
        vec!["render", "fifo-mesh.toml", "-o", "x.png"],
        Refused("fifo.obj: is a FIFO"),
    ));
    cases.push((vec!["validate", "--mesh", "fifo.obj"], Refused("is a FIFO")));
    cases.push((vec!["experiment", "fifo.toml"], Refused("is a FIFO")));
    cases.push((
        vec!["optimize", "fifo.toml", "-o", "opt"],
        Refused("is a FIFO"),
    ));
    cases.push((vec!["diff", "fifo.png", "a.png"], Refused("is a FIFO")));
    cases.push((vec!["diff", "a.png", "fifo.png"], Refused("is a FIFO")));
    cases.push((
        vec![
            "render",
            "ok.toml",
            "-o",
            "x.png",
            "--reference",
            "fifo.png",
        ],
        Refused("is a FIFO"),
    ));
    // Thread counts.
    let threads = "--threads must be from 1 to 1024";
    for cmd in scene_commands("ok.toml") {
        if cmd[0] == "validate" {
            continue; // validate runs on rayon's pool of all cores
        }
        let mut cmd = cmd;
        cmd.extend(["--threads", "100000"]);
        cases.push((cmd, Refused(threads)));
    }
    cases.push((
        vec![
            "optimize",
            "nan-target.toml",
            "-o",
            "opt",
            "--threads",
            "100000",
        ],
        Refused(threads),
    ));
    cases.push((
        vec!["experiment", "threads.toml", "--out", "exp"],
        Refused("`threads` must be from 1 to 1024"),
    ));
    // Ray trees without end.
    for scene in ["mirrors.toml", "glass.toml"] {
        for cmd in scene_commands(scene) {
            if cmd[0] == "validate" {
                continue; // traces single rays, no Whitted tree
            }
            cases.push((cmd, Refused("Whitted ray tree")));
        }
    }
    // Outputs that would overwrite inputs.
    cases.push((
        vec!["diff", "a.png", "a.png", "--out", "a.png"],
        Refused("--out would overwrite TEST"),
    ));
    cases.push((
        vec!["render", "ok.toml", "-o", "o.png", "--spp-map", "o.png"],
        Refused("--spp-map would overwrite --output"),
    ));
    cases.push((
        vec!["render", "ok.toml", "-o", "a.png", "--reference", "a.png"],
        Refused("--output would overwrite --reference"),
    ));
    cases.push((
        vec!["optimize", "own/spec.toml", "-o", "own"],
        Refused("-o's target.png would overwrite the spec's target image"),
    ));
    cases.push((
        vec!["optimize", "own/spec.toml", "-o", "own/../own/"],
        Refused("-o's target.png would overwrite"),
    ));
    // Non-finite images: named, never blamed on a parameter.
    cases.push((
        vec!["optimize", "nan-target.toml", "-o", "opt"],
        Refused("pixel (0, 0) is NaN: a target image must be finite"),
    ));
    cases.push((
        vec!["diff", "nan.exr", "a.png"],
        Runs("max |error|                 NaN"),
    ));
    // Work larger than the machine, refused before it is allocated.
    let cornell: &'static str = Box::leak(
        raylab_testkit::repo_path("data/scenes/cornell-box.toml")
            .to_string_lossy()
            .into_owned()
            .into_boxed_str(),
    );
    let grid = 1026u128.pow(3) * raylab::gi::voxel::BYTES_PER_VOXEL;
    if grid > raylab::film::memory::available_bytes() {
        cases.push((
            vec![
                "render",
                cornell,
                "-o",
                "x.png",
                "--width",
                "8",
                "--height",
                "8",
                "--integrator",
                "floodfill:res=1024",
            ],
            Refused("a flood-fill cache of 1024×1024×1024 voxels (res=1024) would need"),
        ));
    }
    cases.push((
        vec!["validate", "--scene", "ok.toml", "--rays", "1e9"],
        Refused("--rays 1000000000 (8 ray sets, 2 accelerators) would need"),
    ));
    cases.push((
        vec!["experiment", "many.toml", "--out", "exp"],
        Refused("the sweeps have 1200000 runs in all, more than 1000000"),
    ));
    // The counters of `stats` and the planes of `grad`, larger than the
    // machine where its film alone is not (guarded like the flood fill:
    // the estimate depends on the machine only through what it has).
    // Bytes per pixel below the estimates: stats counts 292, grad here
    // about 1500 (16 parameters' moments and planes in its first pass).
    let available = raylab::film::memory::available_bytes();
    if 12000u128 * 12000 * 290 > available {
        cases.push((
            vec![
                "stats", "ok.toml", "--width", "12000", "--height", "12000", "--out", "st",
            ],
            Refused("counting the costs of 12000×12000 pixels would need"),
        ));
    }
    if 6000u128 * 6000 * 1400 > available {
        let mut grad = vec![
            "grad", "ok.toml", "-o", "grad", "--width", "6000", "--height", "6000",
        ];
        for p in [
            "sphere[0].center",
            "sphere[0].radius",
            "materials.m.color",
            "light[0].position",
            "camera.eye",
            "camera.look_at",
            "camera.fov",
        ] {
            grad.extend(["--param", p]);
        }
        cases.push((
            grad,
            Refused("the derivatives of 6000×6000 pixels with respect to 17 parameters would need"),
        ));
    }
    cases.push((
        vec![
            "spectrum",
            "--sampler",
            "sobol:65536",
            "--sets",
            "100000",
            "--freq",
            "512",
            "--out",
            "sp",
        ],
        Refused("more than 2^40"),
    ));
    cases.push((
        vec!["experiment", "exp/data.csv", "--out", "exp"],
        Refused("data.csv would overwrite the manifest"),
    ));
    cases.push((
        vec!["grad", "image.exr", "-o", ".", "--param", "camera.fov"],
        Refused("an image would overwrite the scene"),
    ));
    // Parameters set on the command line (`--set`): checked as the file's
    // numbers are, in every command that takes them.
    for (set, expect) in [
        (&["sphere[0].center=[0,0,3e38]"][..], beyond),
        (
            &["sphere[0].radius=-0"][..],
            "`radius` must be positive, got -0",
        ),
        (
            &["light[0].color=[1e30,1e30,1e30]", "light[0].intensity=1e30"][..],
            "--set light[0].intensity: `color` × `intensity`",
        ),
        (
            &["light[0].intensity=1e39"][..],
            "`1e39` is not a finite number",
        ),
        (
            &["materials.m.color=[nan,0,0]"][..],
            "`nan` is not a finite number",
        ),
        (
            &["sphere[99999999999].radius=1"][..],
            "index `99999999999` in `sphere[99999999999]` is not a non-negative integer",
        ),
        (
            &["mesh[0].vertices[0..1000000000]=[1,2,3]"][..],
            "the scene has 0 `[[mesh]]` entries",
        ),
    ] {
        for mut cmd in [
            vec!["render", "ok.toml", "-o", "x.png"],
            vec!["render", "ok.toml", "-o", "x.png", "--device", "gpu"],
            vec!["grad", "ok.toml", "-o", "grad", "--param", "camera.fov"],
        ] {
            for s in set {
                cmd.extend(["--set", s]);
            }
            cases.push((cmd, Refused(expect)));
        }
    }
    // The smallest positive radius is a valid scene.
    cases.push((
        vec![
            "render",
            "ok.toml",
            "-o",
            "x.png",
            "--set",
            "sphere[0].radius=1e-45",
        ],
        Runs(""),
    ));
    // Valid TOML the parser once refused.
    cases.push((vec!["render", "dotted.toml", "-o", "x.png"], Runs("")));
    cases
}

/// The commands that load a scene file, with `scene` as it.
fn scene_commands(scene: &'static str) -> Vec<Vec<&'static str>> {
    vec![
        vec!["render", scene, "-o", "x.png"],
        vec!["render", scene, "-o", "x.png", "--device", "gpu"],
        vec!["stats", scene, "--out", "stats"],
        vec!["grad", scene, "-o", "grad", "--param", "camera.fov"],
        vec!["validate", "--scene", scene, "--rays", "100"],
    ]
}

#[test]
fn hostile_inputs_are_refused_with_their_cause() {
    let cases = cases();
    let mut failures = Vec::new();
    for (args, expect) in &cases {
        let inputs = Inputs::new();
        let before = inputs.snapshot();
        let o = run_bounded(inputs.dir.path(), args);
        let (out, err) = (
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr),
        );
        let code = o.status.code();
        let ok = match expect {
            Expect::Refused(needle) => matches!(code, Some(1 | 2)) && err.contains(needle),
            Expect::Runs(needle) => code == Some(0) && out.contains(needle),
        };
        if !ok || err.contains("panicked") {
            failures.push(format!("raylab {args:?}: exit {code:?}\n{err}{out}"));
            continue;
        }
        // Inputs untouched and no temporary file left; a refusal writes
        // nothing at all.
        let after = inputs.snapshot();
        let added: Vec<_> = after.iter().filter(|e| !before.contains(e)).collect();
        let lost: Vec<_> = before.iter().filter(|e| !after.contains(e)).collect();
        let tmp = added
            .iter()
            .any(|(p, _)| p.to_string_lossy().ends_with(".tmp"));
        let changed =
            !lost.is_empty() || tmp || (matches!(expect, Expect::Refused(_)) && !added.is_empty());
        if changed {
            let names = |v: &[&(PathBuf, Option<Vec<u8>>)]| {
                v.iter()
                    .map(|(p, _)| p.display().to_string())
                    .collect::<Vec<_>>()
            };
            failures.push(format!(
                "raylab {args:?}: files changed: added {:?}, lost or changed {:?}",
                names(&added),
                names(&lost)
            ));
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} cases failed:\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n")
    );
}
