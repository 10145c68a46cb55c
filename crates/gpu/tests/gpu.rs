//! The GPU port (`--device gpu`, crates/gpu/src/) against the CPU: the same image
//! within 1e-4 per pixel and channel, the same per-pixel counters, two GPU
//! runs bit-identical, and clear errors for what the GPU does not do.
//!
//! These run on whatever adapter wgpu finds: Mesa's lavapipe (software
//! Vulkan, installed by `make deps`) on machines without a GPU. No adapter
//! is a test failure, never a silent skip, unless `RAYLAB_NO_GPU=1` is set
//! on purpose.
//!
//! The tolerance per pixel and channel is argued where it is defined,
//! [`raylab_testkit::gpu::TOLERANCE`].

use raylab::accel::AccelKind;
use raylab::integrator::{render_with_costs, Whitted};
use raylab::io::scene_file::{load_scene, Overrides};
use raylab::sampler::Sampler;
use raylab::scene::Scene;
use raylab::shape::PreparedRay;
use raylab::stats::Counters;
use raylab_gpu::{Gpu, GpuRender};

use raylab_testkit::gpu::{gpu, TOLERANCE};

fn load(path: &str, overrides: &Overrides) -> Scene {
    load_scene(&raylab_testkit::repo_path(path), overrides)
        .unwrap_or_else(|e| panic!("{e} (run `make deps` for the meshes)"))
}

fn small(width: u32, height: u32) -> Overrides {
    Overrides {
        width: Some(width),
        height: Some(height),
        ..Default::default()
    }
}

/// The primitive the CPU's camera ray for sample 0 of each pixel hits.
fn cpu_first_hits(scene: &Scene) -> Vec<Option<u32>> {
    let cam = &scene.camera;
    let set = &scene.settings;
    let mut out = Vec::new();
    for py in 0..cam.height {
        for px in 0..cam.width {
            let off = set.sampler.sample(px, py, 0, set.seed);
            let ray = cam.generate_ray(px as f32 + off.x, py as f32 + off.y);
            let hit = scene.intersect_prim(
                &PreparedRay::new(ray),
                set.max_distance,
                &mut raylab::stats::NoStats,
            );
            out.push(hit.map(|(id, _)| id));
        }
    }
    out
}

/// Whether the CPU's camera ray for sample 0 of pixel (x, y) sits at a tie
/// with primitive `other` (`None`: nothing): `other` lies on it at the
/// same depth within 1e-5 (coincident or intersecting faces), or a ray
/// turned by at most 1e-5 rad hits `other` (an edge or a silhouette).
fn switches_to(scene: &Scene, x: u32, y: u32, other: Option<u32>) -> bool {
    let set = &scene.settings;
    let off = set.sampler.sample(x, y, 0, set.seed);
    let ray = scene
        .camera
        .generate_ray(x as f32 + off.x, y as f32 + off.y);
    let prepared = PreparedRay::new(ray);
    let cpu = scene.intersect_prim(&prepared, set.max_distance, &mut raylab::stats::NoStats);
    // A tie in depth: the GPU's primitive lies on the CPU's ray within
    // 1e-5 (relative) of the CPU's hit (coincident or intersecting faces).
    if let (Some((_, h)), Some(o)) = (cpu, other) {
        let t = scene.prims[o as usize].intersect(
            &prepared,
            f32::INFINITY,
            &mut raylab::stats::NoStats,
        );
        if t.is_some_and(|g| (g.t - h.t).abs() <= 1e-5 * h.t) {
            return true;
        }
    }
    let (e1, e2) = ray.dir.any_orthonormal_pair();
    for delta in [1e-7f32, 1e-6, 1e-5] {
        for k in 0..32 {
            let a = k as f32 * std::f32::consts::TAU / 32.0;
            let dir = (ray.dir + delta * (a.cos() * e1 + a.sin() * e2)).normalize();
            let turned = raylab::math::Ray::new(ray.origin, dir);
            let hit = scene.intersect_prim(
                &PreparedRay::new(turned),
                set.max_distance,
                &mut raylab::stats::NoStats,
            );
            if hit.map(|(id, _)| id) == other {
                return true;
            }
        }
    }
    false
}

/// What one comparison found.
#[derive(Debug, Default)]
struct Comparison {
    pixels: usize,
    /// Largest |GPU − CPU| over the pixels where both devices took the same
    /// decisions (same counters, same first hit).
    max_diff_same: f32,
    /// Pixels where the devices took different decisions (a tie at an
    /// edge): counters or first hit differ.
    ties: Vec<(u32, u32)>,
    /// Of those, the ones whose colours also differ beyond the tolerance.
    ties_visible: usize,
}

/// Render `scene` on both devices and compare pixel by pixel; asserts the
/// tolerance and the tie rules, and returns the findings.
fn compare(label: &str, scene: &Scene) -> Option<Comparison> {
    let gpu = gpu()?;
    let (cpu_film, cpu_total, cpu_pixels) = render_with_costs(scene, &Whitted, None);
    let out: GpuRender = gpu
        .render(scene, true)
        .unwrap_or_else(|e| panic!("{label}: {e}"));
    let cpu_hits = cpu_first_hits(scene);
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    let mut c = Comparison {
        pixels: w * h,
        ..Default::default()
    };
    let mut tie_total = Counters::default();
    let mut tie_cpu_total = Counters::default();
    for i in 0..w * h {
        let (g, p) = (&out.film.pixels[i], &cpu_film.pixels[i]);
        assert_eq!(g.count, p.count, "{label}: samples in pixel {i}");
        let diff = (g.mean - p.mean).abs().max_element();
        let same = out.pixel_counters[i] == cpu_pixels[i] && out.first_hit[i] == cpu_hits[i];
        if same {
            c.max_diff_same = c.max_diff_same.max(diff);
            assert!(
                diff <= TOLERANCE,
                "{label}: pixel ({}, {}) differs by {diff} with the same rays and tests (GPU {:?}, CPU {:?})",
                i % w,
                i / w,
                g.mean,
                p.mean
            );
        } else {
            let (x, y) = ((i % w) as u32, (i / w) as u32);
            c.ties.push((x, y));
            c.ties_visible += usize::from(diff > TOLERANCE);
            tie_total += out.pixel_counters[i];
            tie_cpu_total += cpu_pixels[i];
            if out.first_hit[i] != cpu_hits[i] {
                // A camera ray that found another primitive: a tie in depth,
                // or turning the CPU's ray by at most 1e-5 rad (1/1000 of a
                // pixel here) finds the GPU's primitive, i.e. the ray passes
                // where the two meet (a shared edge, or a silhouette against
                // another primitive or the background).
                assert!(
                    switches_to(scene, x, y, out.first_hit[i]),
                    "{label}: at ({x}, {y}) the GPU's first hit {:?} is neither at the CPU's depth nor within 1e-5 rad of the CPU's {:?}: not a tie",
                    out.first_hit[i],
                    cpu_hits[i]
                );
            }
        }
    }
    // The counters agree everywhere else: the totals less the tie pixels'
    // are equal.
    let strip = |t: Counters, ties: Counters| -> Vec<u64> {
        t.named()
            .iter()
            .zip(ties.named())
            .map(|((_, a), (_, b))| a - b)
            .collect()
    };
    assert_eq!(
        strip(out.total(), tie_total),
        strip(cpu_total, tie_cpu_total),
        "{label}: counters outside the tie pixels"
    );
    // Ties are rare: at most 1 % of the pixels (none at all on lavapipe so
    // far; a GPU that fuses multiply-adds moves a few edge pixels).
    assert!(
        c.ties.len() * 100 <= c.pixels,
        "{label}: {} of {} pixels took different decisions: {:?}",
        c.ties.len(),
        c.pixels,
        &c.ties[..c.ties.len().min(20)]
    );
    eprintln!(
        "{label:<40} {:>6} px  max |Δ| {:.2e} (same decisions)  ties {} ({} beyond 1e-4){}",
        c.pixels,
        c.max_diff_same,
        c.ties.len(),
        c.ties_visible,
        if c.ties.is_empty() {
            String::new()
        } else {
            format!(" at {:?}", &c.ties[..c.ties.len().min(8)])
        }
    );
    Some(c)
}

#[test]
fn s1_scene_matches_the_cpu_with_every_sampler() {
    for sampler in [
        "centre", "ogss:2", "rgss", "jitter:2", "random:3", "halton:3", "sobol:4",
    ] {
        let overrides = Overrides {
            sampler: Some(Sampler::parse(sampler).unwrap()),
            seed: Some(7),
            ..small(64, 48)
        };
        let scene = load("data/scenes/s1-spheres.toml", &overrides);
        compare(&format!("s1-spheres {sampler}"), &scene);
    }
    // The full-size image once, as `raylab render` makes it.
    let scene = load("data/scenes/s1-spheres.toml", &small(200, 150));
    compare("s1-spheres 200×150", &scene);
}

#[test]
fn the_twenty_scene_family_matches_the_cpu() {
    let mut n = 0;
    for i in 1..=20 {
        let path = format!("data/scenes/s1-family/s1-{i:02}.toml");
        let scene = load(&path, &small(64, 48));
        if compare(&path, &scene).is_some() {
            n += 1;
        }
    }
    assert!(n == 20 || gpu().is_none());
}

#[test]
fn a_mesh_scene_matches_the_cpu_with_every_tree() {
    for accel in [
        "bvh:aabb:sah",
        "bvh:sphere:sah",
        "bvh:ellipsoid:sah",
        "bvh:sphere-ritter:s3",
        "bvh:ellipsoid-ritter:s3",
        "bvh:aabb:s3",
        "bvh4",
    ] {
        let overrides = Overrides {
            accel: Some(accel.parse::<AccelKind>().unwrap()),
            ..small(64, 48)
        };
        let scene = load("data/scenes/camel.toml", &overrides);
        compare(&format!("camel {accel}"), &scene);
    }
    // Brute force (S3's basic tracer) on the Cornell box, whose planes are
    // also brute-forced beside any tree; smooth normals (the bunny).
    for (path, accel) in [
        ("data/scenes/bunny.toml", "bvh2"),
        ("data/scenes/cornell-box.toml", "brute"),
        ("data/scenes/cornell-box.toml", "bvh4"),
        ("data/scenes/leak-rooms.toml", "bvh2"),
    ] {
        let overrides = Overrides {
            accel: Some(accel.parse::<AccelKind>().unwrap()),
            ..small(48, 36)
        };
        let scene = load(path, &overrides);
        compare(&format!("{path} {accel}"), &scene);
    }
}

#[test]
fn two_gpu_renders_are_bit_identical() {
    let Some(gpu) = gpu() else { return };
    let overrides = Overrides {
        sampler: Some(Sampler::parse("random:2").unwrap()),
        ..small(80, 60)
    };
    let scene = load("data/scenes/s1-spheres.toml", &overrides);
    let bits = |r: &GpuRender| -> Vec<u32> {
        r.film
            .pixels
            .iter()
            .flat_map(|p| p.mean.to_array().into_iter().chain(p.m2.to_array()))
            .map(f32::to_bits)
            .collect()
    };
    let a = gpu.render(&scene, true).unwrap();
    let b = gpu.render(&scene, true).unwrap();
    let c = gpu.render(&scene, false).unwrap();
    assert_eq!(bits(&a), bits(&b));
    assert_eq!(a.pixel_counters, b.pixel_counters);
    // Counting changes nothing but the counts.
    assert_eq!(bits(&a), bits(&c));
}

#[test]
fn a_scene_beyond_the_adapters_buffer_limit_is_a_clear_error() {
    if gpu().is_none() {
        return;
    }
    let limit = 1 << 20;
    let small_gpu = Gpu::with_binding_limit(limit).unwrap();
    let overrides = Overrides {
        accel: Some("bvh4".parse().unwrap()),
        ..small(32, 24)
    };
    let scene = load("data/scenes/camel.toml", &overrides);
    let err = small_gpu
        .render(&scene, false)
        .err()
        .expect("camel is > 1 MiB")
        .to_string();
    assert!(
        err.contains("max_storage_buffer_binding_size 1048576") && err.contains("the scene needs"),
        "{err}"
    );
}

#[test]
fn what_the_gpu_does_not_do_is_refused_by_name() {
    let Some(gpu) = gpu() else { return };
    let mut cases: Vec<(&str, Overrides, &str)> = vec![
        (
            "data/scenes/s1-spheres.toml",
            Overrides {
                sampler: Some(Sampler::parse("adaptive").unwrap()),
                ..small(8, 6)
            },
            "adaptive sampler",
        ),
        (
            "data/scenes/s1-spheres.toml",
            Overrides {
                filter: Some(raylab::film::Filter::parse("tent").unwrap()),
                ..small(8, 6)
            },
            "tent filter",
        ),
        (
            // Not S1: its glass both reflects and refracts, and a tree of
            // 2^33 rays is refused when the scene loads.
            "data/scenes/torus-knot.toml",
            Overrides {
                max_depth: Some(33),
                ..small(8, 6)
            },
            "max_depth ≤ 32",
        ),
        // The mesh scenes name the fastest tree, `bvh` = `bvh8`.
        ("data/scenes/camel.toml", small(8, 6), "no 8-wide tree"),
    ];
    // Embree's tree, where the core crate was built with Embree (as the
    // workspace's tests build it).
    if let Ok(embree) = "embree".parse::<AccelKind>() {
        cases.push((
            "data/scenes/s1-spheres.toml",
            Overrides {
                accel: Some(embree),
                ..small(8, 6)
            },
            "inside another library (Embree or obvhs)",
        ));
    }
    for (path, overrides, want) in cases {
        let scene = load(path, &overrides);
        let err = gpu.render(&scene, false).err().expect(want).to_string();
        assert!(err.contains(want), "{want}: {err}");
    }
}

/// lavapipe ends a shader invocation's loops after 65535 iterations in all;
/// brute force over the bunny's 75 408 triangles needs more per pixel, and
/// the render is refused by name rather than returned wrong.
#[test]
fn lavapipes_loop_limit_is_an_error_not_a_wrong_image() {
    let Some(gpu) = gpu() else { return };
    if !gpu.describe().contains("llvmpipe") {
        eprintln!("not lavapipe: no loop limit to meet");
        return;
    }
    let overrides = Overrides {
        accel: Some(AccelKind::Brute),
        ..small(16, 12)
    };
    let scene = load("data/scenes/bunny.toml", &overrides);
    let err = gpu
        .render(&scene, false)
        .err()
        .expect("over the limit")
        .to_string();
    assert!(
        err.contains("65 535") && err.contains("brute force over 75408 primitives"),
        "{err}"
    );
}
