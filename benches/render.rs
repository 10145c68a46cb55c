//! Rendering throughput, printed as ratios measured in one run: counters on
//! vs off (goal: `Counters` costs under 10 % over `NoStats`) and 1 vs 2
//! threads. A small harness rather than criterion: each configuration is
//! rendered once to warm up, then `REPEATS` times; medians are compared.
//!
//! Run with `make bench` (or `cargo bench --bench render`).

use raylab::integrator::{render, Whitted};
use raylab::io::scene_file::{load_scene, Overrides};
use raylab::scene::Scene;
use raylab::stats::{Counters, NoStats, RayCounts, RenderStats};
use std::path::Path;
use std::time::Instant;

const REPEATS: usize = 7;

fn median_seconds<S: RenderStats>(scene: &Scene, threads: usize) -> f64 {
    render::<_, S>(scene, &Whitted, Some(threads));
    let mut times: Vec<f64> = (0..REPEATS)
        .map(|_| {
            let t = Instant::now();
            std::hint::black_box(render::<_, S>(scene, &Whitted, Some(threads)));
            t.elapsed().as_secs_f64()
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[REPEATS / 2]
}

fn main() {
    // `cargo bench` passes `--bench`; `cargo test --all-targets` runs this
    // binary without it, where the build alone is the check.
    if !std::env::args().any(|a| a == "--bench") {
        println!("benchmark built; run it with `cargo bench` (make bench)");
        return;
    }
    let scenes = [
        (
            "S1 spheres 400×300",
            "data/scenes/s1-spheres.toml",
            400,
            300,
        ),
        (
            "S1 family 20 (5 obj × 4 lights) 320×240",
            "data/scenes/s1-family/s1-20.toml",
            320,
            240,
        ),
        (
            "Cornell box 200×200",
            "data/scenes/cornell-box.toml",
            200,
            200,
        ),
    ];
    println!(
        "{:<42} {:>10} {:>10} {:>9} {:>10} {:>9}",
        "scene", "Mrays/s", "NoStats s", "Counters", "2 threads", "speed-up"
    );
    for (name, path, w, h) in scenes {
        let o = Overrides {
            width: Some(w),
            height: Some(h),
            ..Default::default()
        };
        let scene = load_scene(Path::new(path), &o).expect("bench scene (run make deps)");
        let (_, RayCounts(c)) = render::<_, RayCounts>(&scene, &Whitted, Some(1));
        let off = median_seconds::<NoStats>(&scene, 1);
        let on = median_seconds::<Counters>(&scene, 1);
        let two = median_seconds::<NoStats>(&scene, 2);
        println!(
            "{:<42} {:>10.2} {:>10.4} {:>+8.1}% {:>10.4} {:>8.2}×",
            name,
            c.rays() as f64 / off / 1e6,
            off,
            (on / off - 1.0) * 100.0,
            two,
            off / two
        );
    }
    println!("(Mrays/s: all rays, 1 thread, NoStats; Counters: overhead of counting every event, 1 thread; speed-up: 1 vs 2 threads)");
}
