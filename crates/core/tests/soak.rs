//! Soak test: one process renders 300 generated valid scenes through the
//! library API, as a long-running user of the library (a server, a sweep)
//! would, and checks that nothing panics, every image is finite and the
//! resident memory stays flat.
//!
//! Each scene is TOML text made from a seeded SplitMix64 stream and loaded
//! with `io::scene_file::parse_scene`, so it goes through the loader users
//! go through: random spheres, ellipsoids, planes, triangles and small
//! meshes (`data/meshes/cube.obj`, procedural icospheres, torus knots and
//! terrains); diffuse, mirror, glass, textured (checker, zone plate) and
//! emissive materials (emissive spheres and triangles are area lights);
//! point lights with and without falloff; every sampler (`centre`,
//! `ogss:K`, `rgss`, `jitter:K`, `random:N`, `halton:N`, `sobol:N`,
//! `adaptive`), filter (`box`, `tent`, `mitchell`), integrator (`whitted`,
//! `direct`, `path:K`, and `floodfill` at a coarse resolution every 15th
//! scene) and accelerator (`brute`, `bvh` with each bounding volume and
//! builder, `bvh4`, `bvh8`, `embree`). Images are 24×16.
//!
//! Memory: `VmRSS` from `/proc/self/status` after every scene (its scene,
//! accelerator and film dropped). After a warm-up — the allocator's arenas
//! (one per rayon thread), Embree's device and thread pool, rayon's pool —
//! the RSS must stay flat: the highest value over the second half is at most
//! the value after scene 20 plus 16 MiB. The margin: a scene's whole
//! working set is under 2 MiB (a 24×16 film, a few hundred primitives and
//! their BVH, a flood-fill grid of 8³ voxels), so freed memory the
//! allocator keeps in its arenas, or a new high-water mark in one of them,
//! stays a few MiB; 16 MiB is several times that, and a leak of one
//! scene's working set per scene (150 × ≥ 100 KiB) would still exceed it.
//!
//! `cargo test --test soak -- --nocapture` prints the curve (scene, RSS);
//! `RAYLAB_SOAK_SCENES=3000` runs longer.

use raylab::integrator::IntegratorKind;
use raylab::io::scene_file::{parse_scene, Overrides};
use raylab::math::SplitMix64;
use raylab::stats::Counters;
use std::fmt::Write as _;

const SCENES: usize = 300;

/// `RAYLAB_SOAK_SCENES=N` renders N scenes instead (at least 2·BASELINE).
fn scenes() -> usize {
    std::env::var("RAYLAB_SOAK_SCENES")
        .ok()
        .and_then(|v| v.parse().ok())
        .map_or(SCENES, |n: usize| n.max(2 * BASELINE))
}
/// The scene whose RSS is the baseline.
const BASELINE: usize = 20;
/// How far above the baseline the second half may go.
const MARGIN_KB: u64 = 16 * 1024;

/// Resident set size in KiB.
fn rss_kb() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").expect("/proc/self/status");
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        .expect("VmRSS in /proc/self/status")
}

/// A small random generator for the scene text.
struct Gen(SplitMix64);

impl Gen {
    fn f(&mut self, lo: f32, hi: f32) -> f32 {
        self.0.range(lo, hi)
    }
    fn pick<'a>(&mut self, options: &[&'a str]) -> &'a str {
        options[self.0.below(options.len())]
    }
    fn n(&mut self, lo: usize, hi: usize) -> usize {
        lo + self.0.below(hi - lo + 1)
    }
    fn v(&mut self, lo: f32, hi: f32) -> String {
        format!(
            "[{}, {}, {}]",
            self.f(lo, hi),
            self.f(lo, hi),
            self.f(lo, hi)
        )
    }
    fn chance(&mut self, p: f32) -> bool {
        self.0.next_f32() < p
    }
}

/// What a generated scene asks for, to say which combination failed.
struct Generated {
    text: String,
    integrator: String,
}

fn scene_text(index: usize) -> Generated {
    let mut g = Gen(SplitMix64(SplitMix64::mix(0x50AC ^ index as u64)));
    let mut t = String::new();
    let sampler = match g.n(0, 7) {
        0 => "centre".to_string(),
        1 => format!("ogss:{}", g.n(1, 3)),
        2 => "rgss".into(),
        3 => format!("jitter:{}", g.n(1, 3)),
        4 => format!("random:{}", g.n(1, 8)),
        5 => format!("halton:{}", g.n(1, 8)),
        6 => format!("sobol:{}", g.n(1, 8)),
        _ => "adaptive".into(),
    };
    let accel = g.pick(&[
        "brute",
        "bvh",
        "bvh2",
        "bvh:sphere",
        "bvh:ellipsoid:s3",
        "bvh:sphere-ritter:sah:2",
        "bvh:ellipsoid-ritter",
        "bvh:aabb:s3:1",
        "bvh4",
        "bvh8",
        "embree",
    ]);
    let integrator = if index % 15 == 7 {
        "floodfill:res=8,warm=4".to_string()
    } else {
        match g.n(0, 3) {
            0 => "whitted".into(),
            1 => "direct".into(),
            _ => format!("path:{}", g.n(1, 4)),
        }
    };
    let _ = write!(
        t,
        "[image]\nwidth = 24\nheight = 16\n\
         [camera]\neye = [{}, {}, {}]\nlook_at = [0.0, 0.5, 0.0]\nfov = {}\n\
         [render]\nbackground = {}\nambient = {}\nmax_depth = {}\nsampler = \"{sampler}\"\n\
         filter = \"{}\"\naccel = \"{accel}\"\nseed = {}\n",
        g.f(-3.0, 3.0),
        g.f(0.5, 3.0),
        g.f(5.0, 8.0),
        g.f(30.0, 70.0),
        g.v(0.0, 0.3),
        g.v(0.0, 0.2),
        g.n(1, 5),
        g.pick(&["box", "tent", "mitchell"]),
        g.0.next_u64() >> 12,
    );
    // Materials: m0 is always plain diffuse, so every scene has one.
    let materials = g.n(2, 5);
    for m in 0..materials {
        let _ = write!(t, "[materials.m{m}]\ncolor = {}\n", g.v(0.1, 0.95));
        let kind = if m == 0 {
            "diffuse"
        } else {
            g.pick(&["diffuse", "mirror", "glass", "checker", "zone", "emissive"])
        };
        let _ = match kind {
            "mirror" => write!(t, "ambient = 0.05\ndiffuse = 0.2\nreflectivity = {}\n", g.f(0.5, 1.0)),
            "glass" => write!(
                t,
                "ambient = 0.0\ndiffuse = 0.05\nspecular = 0.5\nshininess = 80.0\ntransparency = {}\nior = {}\n",
                g.f(0.7, 1.0),
                g.f(1.1, 2.4)
            ),
            "checker" => write!(
                t,
                "ambient = 0.3\ndiffuse = 0.7\ntexture = {{ kind = \"checker\", size = {}, color = {} }}\n",
                g.f(0.1, 1.0),
                g.v(0.0, 0.3)
            ),
            "zone" => write!(
                t,
                "ambient = 0.3\ndiffuse = 0.7\ntexture = {{ kind = \"zone_plate\", k = {}, color = {} }}\n",
                g.f(1.0, 40.0),
                g.v(0.0, 0.3)
            ),
            "emissive" => write!(t, "ambient = 0.0\ndiffuse = 0.2\nemission = {}\n", g.v(1.0, 8.0)),
            _ => write!(
                t,
                "ambient = {}\ndiffuse = {}\nspecular = {}\nshininess = {}\n",
                g.f(0.0, 0.4),
                g.f(0.3, 1.0),
                g.f(0.0, 0.5),
                g.f(1.0, 100.0)
            ),
        };
    }
    let material = |g: &mut Gen| format!("m{}", g.n(0, materials - 1));
    for _ in 0..g.n(1, 6) {
        let m = material(&mut g);
        let _ = write!(
            t,
            "[[sphere]]\ncenter = {}\nradius = {}\nmaterial = \"{m}\"\n",
            g.v(-2.0, 2.0),
            g.f(0.1, 0.9)
        );
    }
    for _ in 0..g.n(0, 2) {
        let m = material(&mut g);
        let _ = write!(
            t,
            "[[ellipsoid]]\ncenter = {}\nradii = {}\nrotate = {}\nmaterial = \"{m}\"\n",
            g.v(-2.0, 2.0),
            g.v(0.1, 0.8),
            g.v(-90.0, 90.0)
        );
    }
    if g.chance(0.6) {
        let m = material(&mut g);
        let _ = write!(
            t,
            "[[plane]]\npoint = [0.0, {}, 0.0]\nnormal = [{}, 1.0, {}]\nmaterial = \"{m}\"\n",
            g.f(-1.5, -0.5),
            g.f(-0.2, 0.2),
            g.f(-0.2, 0.2)
        );
    }
    for _ in 0..g.n(0, 3) {
        let m = material(&mut g);
        let _ = write!(
            t,
            "[[triangle]]\nvertices = [{}, {}, {}]\nmaterial = \"{m}\"\n",
            g.v(-2.0, 2.0),
            g.v(-2.0, 2.0),
            g.v(-2.0, 2.0)
        );
    }
    if g.chance(0.5) {
        let m = material(&mut g);
        let shape = match g.n(0, 3) {
            0 => "file = \"../meshes/cube.obj\"".to_string(),
            1 => format!(
                "procedural = {{ kind = \"icosphere\", level = {} }}",
                g.n(0, 2)
            ),
            2 => format!(
                "procedural = {{ kind = \"torus_knot\", p = 2, q = 3, segments = {}, sides = {} }}",
                g.n(8, 32),
                g.n(3, 8)
            ),
            _ => format!(
                "procedural = {{ kind = \"terrain\", n = {}, seed = {} }}",
                g.n(2, 12),
                g.n(0, 1000)
            ),
        };
        let _ = write!(
            t,
            "[[mesh]]\n{shape}\nmaterial = \"{m}\"\nfit = {}\nrotate = {}\ntranslate = {}\nnormals = \"{}\"\n",
            g.f(0.5, 2.0),
            g.v(-45.0, 45.0),
            g.v(-1.0, 1.0),
            g.pick(&["file", "flat", "computed"])
        );
    }
    for _ in 0..g.n(1, 3) {
        let (x, y, z) = (g.f(-4.0, 4.0), g.f(1.0, 5.0), g.f(-2.0, 6.0));
        let _ = write!(
            t,
            "[[light]]\nposition = [{x}, {y}, {z}]\ncolor = {}\nintensity = {}\nfalloff = \"{}\"\nwhitted_only = {}\n",
            g.v(0.5, 1.0),
            g.f(0.2, 1.5),
            g.pick(&["none", "inverse_square"]),
            g.chance(0.2)
        );
    }
    Generated {
        text: t,
        integrator,
    }
}

#[test]
fn hundreds_of_scenes_in_one_process_keep_memory_flat() {
    // `../meshes/cube.obj` resolves from here; the file itself is not read.
    let path = raylab_testkit::repo().join("data/scenes/soak.toml");
    let start = std::time::Instant::now();
    let count = scenes();
    let mut curve: Vec<(usize, u64)> = Vec::with_capacity(count);
    let mut floodfill = (0, 0);
    let mut seen: std::collections::BTreeMap<String, usize> = Default::default();
    for i in 0..count {
        let g = scene_text(i);
        {
            let scene = parse_scene(&g.text, &path, &Overrides::default())
                .unwrap_or_else(|e| panic!("scene {i}: {e}\n{}", g.text));
            let kind = IntegratorKind::parse(&g.integrator).expect("integrator");
            for what in [
                format!("accel {}", scene.accel.kind()),
                format!(
                    "sampler {}",
                    scene
                        .settings
                        .sampler
                        .name()
                        .trim_end_matches(|c: char| c.is_ascii_digit())
                ),
                format!(
                    "integrator {}",
                    g.integrator.split(':').next().unwrap_or("")
                ),
                format!("area lights {}", !scene.area_lights.emitters.is_empty()),
            ] {
                *seen.entry(what).or_default() += 1;
            }
            let result = kind.render::<Counters>(&scene, None);
            let is_floodfill = matches!(kind, IntegratorKind::FloodFill(_));
            floodfill.0 += usize::from(is_floodfill);
            match result {
                Ok((film, counters)) => {
                    floodfill.1 += usize::from(is_floodfill);
                    assert!(counters.camera_rays > 0, "scene {i}: no camera rays");
                    let image = film.image();
                    if let Some(bad) = image.iter().find(|v| !v.is_finite()) {
                        panic!(
                            "scene {i} ({}): non-finite pixel value {bad}\n{}",
                            g.integrator, g.text
                        );
                    }
                    assert!(
                        film.pixels.iter().all(|p| p.variance().is_finite()),
                        "scene {i}: non-finite variance\n{}",
                        g.text
                    );
                }
                // Flood fill may refuse a scene it cannot voxelise; any
                // other integrator must render.
                Err(e) if is_floodfill => eprintln!("scene {i}: flood fill: {e}"),
                Err(e) => panic!("scene {i} ({}): {e}\n{}", g.integrator, g.text),
            }
        }
        curve.push((i, rss_kb()));
    }
    let seconds = start.elapsed().as_secs_f64();
    println!("soak: {count} scenes in {seconds:.1} s; RSS after each scene (KiB):");
    for chunk in curve.chunks(10) {
        let row: Vec<String> = chunk.iter().map(|(i, kb)| format!("{i:>3}:{kb}")).collect();
        println!("  {}", row.join(" "));
    }
    let seen: Vec<String> = seen.iter().map(|(k, n)| format!("{k}: {n}")).collect();
    println!("soak: scenes by kind: {}", seen.join(", "));
    println!(
        "soak: flood fill rendered {} of {} scenes",
        floodfill.1, floodfill.0
    );
    assert!(
        floodfill.1 > 0,
        "no flood-fill render succeeded of {}",
        floodfill.0
    );
    let baseline = curve[BASELINE].1;
    let (worst_at, worst) = curve[count / 2..]
        .iter()
        .copied()
        .max_by_key(|&(_, kb)| kb)
        .expect("second half");
    println!(
        "soak: RSS {baseline} KiB after scene {BASELINE}, at most {worst} KiB (scene {worst_at}) in the second half; limit {} KiB",
        baseline + MARGIN_KB
    );
    assert!(
        worst <= baseline + MARGIN_KB,
        "RSS grew from {baseline} KiB (scene {BASELINE}) to {worst} KiB (scene {worst_at}): more than {MARGIN_KB} KiB"
    );
}
