//! Accelerator throughput on real meshes and on the Cornell box (the scene
//! `make bench-peers` path-traces: 36 triangles, one wide node over seven
//! leaves, so what a ray costs is its fixed part: setting up, the node
//! test, one or two leaves), printed as a table: Mrays/s of
//! every BVH variant (`BvhConfig::all()`, `bvh4`, `bvh8`) and of brute force (smallest mesh
//! only) for four kinds of ray, build times, the cost of `Counters` over
//! `NoStats`, and the 1 → 2 thread speed-up of a full render.
//!
//! A small harness rather than criterion, like `crates/core/benches/render.rs`: every
//! measurement runs once to warm up, then `REPEATS` times, and the median is
//! reported (ARCHITECTURE.md's rule: timings are taken in release builds,
//! warm, over repeats, and medians reported). Traversal is timed single-threaded through
//! `Accel::intersect` / `Accel::occluded` on the scene's mesh alone (the
//! floor plane is not in the accelerator), so the numbers are the
//! accelerator's own.
//!
//! Ray sets, fixed before timing so every accelerator traces the same rays:
//! - primary: camera rays through the pixel centres at 400×300;
//! - shadow: from each primary hit (mesh or floor) towards the scene's first
//!   light, any-hit, stopping short of the light;
//! - diffuse: from each primary hit, one cosine-distributed direction about
//!   the shading normal, closest hit;
//! - random: as many rays as pixels, from a sphere around the mesh through
//!   uniform points of its bounds, closest hit (the least coherent set).
//!
//! The sets are `raylab::workload`'s, shared with the `accel_speed`
//! study (`analysis/embree-speed.toml`).
//!
//! Every row also gives its throughput for each set relative to Embree 4's
//! (`embree`: high build quality, robust, `rtcIntersect1`/`rtcOccluded1` on
//! the same rays, same thread), the targets for `bvh8` being ≥ 1.0× on
//! primary rays and ≥ 0.8× on the other sets, and
//! relative to the obvhs crate's compressed 8-wide BVH (`obvhs`, a peer
//! Rust library: its `medium_build` preset, `ray_traverse` /
//! `ray_traverse_miss` one ray at a time, same rays, same thread; its own
//! row is there too), the target for `bvh8` being > 1× on every set.
//!
//! Run with `make bench` or `cargo bench --bench accel`. To measure a subset,
//! `RAYLAB_BENCH_ACCELS=bvh:aabb:sah,embree` picks accelerators (names as in
//! `--accel`) and `RAYLAB_BENCH_MESHES=camel` picks meshes by name prefix.

use raylab::accel::{AccelKind, Accelerator, BvhConfig};
use raylab::integrator::{render, Whitted};
use raylab::io::scene_file::{load_scene, Overrides};
use raylab::scene::Scene;
use raylab::stats::{Counters, NoStats, Stats};
use raylab::workload::{trace_serial, Segment, Workload};
use std::time::Instant;

const REPEATS: usize = 5;
const WIDTH: u32 = 400;
const HEIGHT: u32 = 300;
/// Brute force tests every triangle for every ray (~2·10⁴ per ray on the
/// camel): one ray in this many keeps it to about a second per ray set.
const BRUTE_STRIDE: usize = 16;
/// The Embree configuration every row is compared with: the one the issue's
/// reference figures were measured with.
const EMBREE: &str = "embree:high+robust";
/// The peer library every row is also compared with (crates/core/src/accel/obvhs.rs).
const OBVHS: &str = "obvhs";

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

/// Mrays/s of closest-hit (`any = false`) or any-hit queries over `rays`,
/// single thread, counting into `S`.
fn throughput<S: Stats + Default>(scene: &Scene, rays: &[Segment], any: bool) -> f64 {
    let secs = median_seconds(|| {
        let mut s = S::default();
        let hits = trace_serial(&scene.accel, scene, rays, any, &mut s);
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
    let list = |var: &str| {
        std::env::var(var)
            .ok()
            .map(|v| v.split(',').map(str::to_string).collect::<Vec<_>>())
    };
    let only_accels = list("RAYLAB_BENCH_ACCELS");
    let only_meshes = list("RAYLAB_BENCH_MESHES");
    let mut meshes = vec![
        ("camel (19 536 tris)", "data/scenes/camel.toml"),
        (
            "ChineseDragon-10kv (19 994)",
            "data/scenes/chinese-dragon.toml",
        ),
        ("bunny00 (75 408)", "data/scenes/bunny.toml"),
        // The scene `make bench-peers` path-traces (module doc).
        ("cornell-box (36 tris)", "data/scenes/cornell-box.toml"),
    ];
    if let Some(only) = &only_meshes {
        meshes.retain(|(name, _)| only.iter().any(|m| name.starts_with(m.as_str())));
    }
    let o = Overrides {
        width: Some(WIDTH),
        height: Some(HEIGHT),
        accel: Some(AccelKind::Bvh(BvhConfig::default())),
        ..Default::default()
    };
    println!("Single thread, {WIDTH}×{HEIGHT} camera rays, medians of {REPEATS} runs; Mrays/s.");
    let mut overhead = Vec::new();
    for (i, (name, path)) in meshes.iter().enumerate() {
        let mut scene = match load_scene(&raylab_testkit::repo_path(path), &o) {
            Ok(s) => s,
            Err(e) => {
                println!("{name}: skipped ({e}); run `make deps` for the meshes");
                continue;
            }
        };
        let sets = Workload::from_scene(&scene, (WIDTH * HEIGHT) as usize, 1);
        println!(
            "\n{name}: {}{}",
            Workload::KINDS
                .map(|k| format!("{} {k}", sets.get(k).len()))
                .join(", "),
            if i == 0 {
                format!(" rays (brute: every {BRUTE_STRIDE}th)")
            } else {
                " rays".to_string()
            }
        );
        println!(
            "  {:<20} {:>8} {:>8} {:>8} {:>8} {:>9} {:>7}  vs Embree (c / s / p / r)    \
             vs obvhs (c / s / p / r)",
            "accelerator", "camera", "shadow", "path", "random", "build ms", "vs sah"
        );
        let bounded: Vec<u32> = (0..scene.prims.len() as u32)
            .filter(|&i| scene.prims[i as usize].bounds().is_some())
            .collect();
        let mut kinds: Vec<AccelKind> = BvhConfig::all().map(AccelKind::Bvh).collect();
        kinds.push(AccelKind::Bvh4);
        kinds.push(AccelKind::Bvh8);
        if i == 0 {
            kinds.insert(0, AccelKind::Brute);
        }
        #[cfg(feature = "embree")]
        kinds.push(EMBREE.parse().expect("a valid Embree name"));
        #[cfg(feature = "obvhs")]
        kinds.push(OBVHS.parse().expect("a valid obvhs name"));
        if let Some(only) = &only_accels {
            kinds.retain(|k| only.contains(&k.to_string()));
        }
        let mut sah_primary = None;
        let mut embree = [f64::NAN; 4];
        let mut obvhs = [f64::NAN; 4];
        let mut rows = Vec::new();
        for kind in kinds {
            let build = median_seconds(|| {
                std::hint::black_box(Accelerator::build(kind, &scene.prims, bounded.clone())).ok();
            });
            if let Err(e) = scene.set_accel(kind) {
                println!("  {kind:<20} skipped: {e}");
                continue;
            }
            let tput = Workload::KINDS.map(|k| {
                let rays = sets.get(k);
                if kind == AccelKind::Brute {
                    throughput::<NoStats>(&scene, &strided(rays), k.any_hit())
                } else {
                    throughput::<NoStats>(&scene, rays, k.any_hit())
                }
            });
            if kind.to_string() == EMBREE {
                embree = tput;
            }
            if kind.to_string() == OBVHS {
                obvhs = tput;
            }
            if kind.to_string() == "bvh:aabb:sah" {
                sah_primary = Some(tput[0]);
            }
            if matches!(kind.to_string().as_str(), "bvh:aabb:sah" | "bvh8") {
                let tc = throughput::<Counters>(&scene, &sets.primary, false);
                overhead.push((format!("{name}, {kind}"), tput[0], tc));
            }
            rows.push((kind, tput, build));
        }
        // Each set's throughput over another's: "1.234× 0.987× …".
        let ratios = |tput: &[f64; 4], of: &[f64; 4]| {
            (0..4)
                .map(|k| format!("{:.3}×", tput[k] / of[k]))
                .collect::<Vec<_>>()
                .join(" ")
        };
        for (kind, tput, build) in rows {
            let rel = sah_primary.map_or(f64::NAN, |s| tput[0] / s);
            println!(
                "  {:<20} {} {:>9.2} {rel:>6.3}×  {}  {}",
                kind.to_string(),
                tput.map(|t| format!("{:>8}", sig4(t))).join(" "),
                build * 1e3,
                ratios(&tput, &embree),
                ratios(&tput, &obvhs),
            );
        }
    }

    println!(
        "\nCounters vs NoStats, primary rays, traversal alone (the target, ≤ 5 % on whole \
         Whitted renders, is measured by crates/core/benches/render.rs)"
    );
    for (name, off, on) in overhead {
        println!(
            "  {name:<36} NoStats {off:>7.3}  Counters {on:>7.3} Mrays/s  overhead {:>+6.1} %",
            (off / on - 1.0) * 100.0
        );
    }

    match load_scene(
        &raylab_testkit::repo_path("data/scenes/camel.toml"),
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
                 2 threads {:.1} ms, speed-up {:.2}× (a short render: the target, ≥ 1.9× on renders \
                 of ≥ 0.2 s, is measured by crates/core/benches/render.rs)",
                scene.accel.kind(),
                t1 * 1e3,
                t2 * 1e3,
                t1 / t2
            );
        }
        Err(e) => println!("camel render skipped: {e}"),
    }
}
