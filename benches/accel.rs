//! Accelerator throughput on real meshes, printed as a table: Mrays/s of
//! every BVH variant (`BvhConfig::all()`) and of brute force (smallest mesh
//! only) for three kinds of ray, build times, the cost of `Counters` over
//! `NoStats`, and the 1 → 2 thread speed-up of a full render.
//!
//! A small harness rather than criterion, like `benches/render.rs`: every
//! measurement runs once to warm up, then `REPEATS` times, and the median is
//! reported (DESIGN.md: "timings are taken in release builds, warm, over
//! repeats; report medians"). Traversal is timed single-threaded through
//! `Accel::intersect` / `Accel::occluded` on the scene's mesh alone (the
//! floor plane is not in the accelerator), so the numbers are the
//! accelerator's own.
//!
//! Ray sets, fixed before timing so every accelerator traces the same rays:
//! - primary: camera rays through the pixel centres at 400×300;
//! - shadow: from each primary hit (mesh or floor) towards the scene's first
//!   light, any-hit, stopping short of the light;
//! - diffuse: from each primary hit, one cosine-distributed direction about
//!   the shading normal, closest hit.
//!
//! Run with `make bench` or `cargo bench --bench accel`.

use raylab::accel::{Accel, AccelKind, Accelerator, BvhConfig};
use raylab::integrator::whitted::offset_origin;
use raylab::integrator::{render, Whitted};
use raylab::io::scene_file::{load_scene, Overrides};
use raylab::math::{Ray, Vec3};
use raylab::scene::Scene;
use raylab::shape::PreparedRay;
use raylab::stats::{Counters, NoStats, Stats};
use std::f32::consts::PI;
use std::path::Path;
use std::time::Instant;

const REPEATS: usize = 5;
const WIDTH: u32 = 400;
const HEIGHT: u32 = 300;
/// Brute force tests every triangle for every ray (~2·10⁴ per ray on the
/// camel): one ray in this many keeps it to about a second per ray set.
const BRUTE_STRIDE: usize = 16;

/// Median wall-clock seconds of `f` over `REPEATS` runs after one warm-up.
fn median_seconds(mut f: impl FnMut()) -> f64 {
    f();
    let mut t: Vec<f64> = (0..REPEATS)
        .map(|_| {
            let s = Instant::now();
            f();
            s.elapsed().as_secs_f64()
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[REPEATS / 2]
}

/// One segment to trace: a prepared ray and its far limit.
#[derive(Clone, Copy)]
struct Segment {
    ray: PreparedRay,
    t_max: f32,
}

struct RaySets {
    primary: Vec<Segment>,
    shadow: Vec<Segment>,
    diffuse: Vec<Segment>,
}

/// A counter-based hash to [0, 1) (SplitMix64 finaliser, Steele, Lea and
/// Flood 2014): the same rays on every run without a generator crate.
fn unit(mut z: u64) -> f32 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 40) as f32 / (1u64 << 24) as f32
}

/// A cosine-distributed unit direction about `n`: Malley's method (uniform
/// point on the unit disc lifted to the hemisphere, pbrt-v4 §A.5.3), in the
/// orthonormal basis of Duff et al., "Building an Orthonormal Basis,
/// Revisited" (JCGT 2017).
fn cosine_direction(n: Vec3, u1: f32, u2: f32) -> Vec3 {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let t = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let bt = Vec3::new(b, sign + n.y * n.y * a, -n.y);
    let (r, phi) = (u1.sqrt(), 2.0 * PI * u2);
    let z = (1.0 - u1).max(0.0).sqrt();
    (r * phi.cos() * t + r * phi.sin() * bt + z * n).normalize()
}

fn ray_sets(scene: &Scene) -> RaySets {
    let cam = &scene.camera;
    let light = scene.lights.first().map(|l| l.position);
    let far = scene.settings.max_distance;
    let mut sets = RaySets {
        primary: Vec::new(),
        shadow: Vec::new(),
        diffuse: Vec::new(),
    };
    for py in 0..cam.height {
        for px in 0..cam.width {
            let ray = cam.generate_ray(px as f32 + 0.5, py as f32 + 0.5);
            sets.primary.push(Segment {
                ray: PreparedRay::new(ray),
                t_max: far,
            });
            let Some(hit) = scene.intersect(&ray, far, &mut NoStats) else {
                continue;
            };
            if let Some(lp) = light {
                let l = (lp - hit.point).normalize();
                let o = offset_origin(&hit, l);
                let d = lp - o;
                let len = d.length();
                sets.shadow.push(Segment {
                    ray: PreparedRay::new(Ray::new(o, d / len)),
                    t_max: len * (1.0 - 1e-4),
                });
            }
            let i = u64::from(py * cam.width + px);
            let dir = cosine_direction(hit.shading_normal, unit(2 * i), unit(2 * i + 1));
            sets.diffuse.push(Segment {
                ray: PreparedRay::new(Ray::new(offset_origin(&hit, dir), dir)),
                t_max: far,
            });
        }
    }
    sets
}

/// Mrays/s of closest-hit (`any = false`) or any-hit queries over `rays`.
fn throughput<S: Stats + Default>(scene: &Scene, rays: &[Segment], any: bool) -> f64 {
    let (a, p) = (&scene.accel, &scene.prims[..]);
    let secs = median_seconds(|| {
        let mut s = S::default();
        let mut hits = 0u32;
        for r in rays {
            let hit = if any {
                a.occluded(p, &r.ray, r.t_max, &mut s)
            } else {
                a.intersect(p, &r.ray, r.t_max, &mut s).is_some()
            };
            hits += u32::from(hit);
        }
        std::hint::black_box((hits, s));
    });
    rays.len() as f64 / secs / 1e6
}

/// Four significant digits, so that brute force (~10⁻³ Mrays/s) and the
/// BVHs (~1–10 Mrays/s) both read.
fn sig4(x: f64) -> String {
    let decimals = (3 - x.abs().log10().floor() as i32).clamp(0, 8) as usize;
    format!("{x:.decimals$}")
}

fn strided(v: &[Segment]) -> Vec<Segment> {
    v.iter().step_by(BRUTE_STRIDE).copied().collect()
}

fn main() {
    // `cargo bench` passes `--bench`; `cargo test --all-targets` runs this
    // binary without it, where the build alone is the check.
    if !std::env::args().any(|a| a == "--bench") {
        println!("benchmark built; run it with `cargo bench` (make bench)");
        return;
    }
    let meshes = [
        ("camel (19 536 tris)", "data/scenes/camel.toml"),
        (
            "ChineseDragon-10kv (19 994)",
            "data/scenes/chinese-dragon.toml",
        ),
        ("bunny00 (75 408)", "data/scenes/bunny.toml"),
    ];
    let o = Overrides {
        width: Some(WIDTH),
        height: Some(HEIGHT),
        accel: Some(AccelKind::Brute),
        ..Default::default()
    };
    println!("Single thread, {WIDTH}×{HEIGHT} camera rays, medians of {REPEATS} runs; Mrays/s.");
    let mut overhead = Vec::new();
    for (i, (name, path)) in meshes.iter().enumerate() {
        let mut scene = match load_scene(Path::new(path), &o) {
            Ok(s) => s,
            Err(e) => {
                println!("{name}: skipped ({e}); run `make deps` for the meshes");
                continue;
            }
        };
        let sets = ray_sets(&scene);
        println!(
            "\n{name}: {} primary, {} shadow, {} diffuse rays{}",
            sets.primary.len(),
            sets.shadow.len(),
            sets.diffuse.len(),
            if i == 0 {
                format!(" (brute: every {BRUTE_STRIDE}th)")
            } else {
                String::new()
            }
        );
        println!(
            "  {:<26} {:>9} {:>9} {:>9} {:>10} {:>9}",
            "accelerator", "primary", "shadow", "diffuse", "build ms", "vs sah"
        );
        let bounded: Vec<u32> = (0..scene.prims.len() as u32)
            .filter(|&i| scene.prims[i as usize].bounds().is_some())
            .collect();
        let mut kinds: Vec<AccelKind> = BvhConfig::all().map(AccelKind::Bvh).collect();
        if i == 0 {
            kinds.insert(0, AccelKind::Brute);
        }
        let mut sah_primary = None;
        let mut rows = Vec::new();
        for kind in kinds {
            let build = median_seconds(|| {
                std::hint::black_box(Accelerator::build(kind, &scene.prims, bounded.clone())).ok();
            });
            if let Err(e) = scene.set_accel(kind) {
                println!("  {kind:<26} skipped: {e}");
                continue;
            }
            let (p, s, d) = if kind == AccelKind::Brute {
                (
                    strided(&sets.primary),
                    strided(&sets.shadow),
                    strided(&sets.diffuse),
                )
            } else {
                (
                    sets.primary.clone(),
                    sets.shadow.clone(),
                    sets.diffuse.clone(),
                )
            };
            let tp = throughput::<NoStats>(&scene, &p, false);
            let ts = throughput::<NoStats>(&scene, &s, true);
            let td = throughput::<NoStats>(&scene, &d, false);
            if kind.to_string() == "bvh:aabb:sah" {
                sah_primary = Some(tp);
                let tc = throughput::<Counters>(&scene, &p, false);
                overhead.push((name.to_string(), tp, tc));
            }
            rows.push((kind, tp, ts, td, build));
        }
        for (kind, tp, ts, td, build) in rows {
            let rel = sah_primary.map_or(f64::NAN, |s| tp / s);
            println!(
                "  {:<26} {:>9} {:>9} {:>9} {:>10.2} {rel:>8.4}×",
                kind.to_string(),
                sig4(tp),
                sig4(ts),
                sig4(td),
                build * 1e3
            );
        }
    }

    println!("\nCounters vs NoStats, bvh:aabb:sah primary rays (goal: overhead ≤ 10 %)");
    for (name, off, on) in overhead {
        println!(
            "  {name:<28} NoStats {off:>7.3}  Counters {on:>7.3} Mrays/s  overhead {:>+6.1} %",
            (off / on - 1.0) * 100.0
        );
    }

    match load_scene(
        Path::new("data/scenes/camel.toml"),
        &Overrides {
            width: Some(WIDTH),
            height: Some(HEIGHT),
            ..Default::default()
        },
    ) {
        Ok(scene) => {
            let t1 = median_seconds(|| {
                std::hint::black_box(render::<_, NoStats>(&scene, &Whitted, Some(1)));
            });
            let t2 = median_seconds(|| {
                std::hint::black_box(render::<_, NoStats>(&scene, &Whitted, Some(2)));
            });
            println!(
                "\nCamel render (Whitted, scene's accelerator {}), NoStats: 1 thread {:.1} ms, \
                 2 threads {:.1} ms, speed-up {:.2}× (goal ≥ 1.8×)",
                scene.accel.kind(),
                t1 * 1e3,
                t2 * 1e3,
                t1 / t2
            );
        }
        Err(e) => println!("camel render skipped: {e}"),
    }
}
