//! Rendering throughput, printed as ratios measured in one run: counters on
//! vs off (target: `Counters` costs at most 5 % over `NoStats` on Whitted
//! renders of the S1 scenes and the camel) and 1 vs 2 threads (target: at
//! least 1.9× on renders of 0.2 s or more), each row marked against them.
//! A small harness rather than criterion: the three configurations
//! (`NoStats` and `Counters` on 1 thread, `NoStats` on 2) are rendered in
//! turn, one warm-up round and then `REPEATS` rounds, and each ratio is the
//! median of the rounds' ratios, so that a machine whose speed drifts
//! during the run (a shared VM) does not pass its drift off as overhead.
//!
//! Run with `make bench` (or `cargo bench --bench render`, and
//! `cargo bench --bench render -- camel` for the scenes whose name contains
//! a word given).

use raylab::integrator::{render, Whitted};
use raylab::io::scene_file::{load_scene, Overrides};
use raylab::scene::Scene;
use raylab::stats::{Counters, NoStats, RayCounts, RenderStats};
use std::time::Instant;

const REPEATS: usize = 9;

/// Seconds of one render of `scene` on `threads` threads, counting into `S`.
fn seconds<S: RenderStats>(scene: &Scene, threads: usize) -> f64 {
    let t = Instant::now();
    std::hint::black_box(render::<_, S>(scene, &Whitted, Some(threads)));
    t.elapsed().as_secs_f64()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The three configurations timed in turn, `REPEATS` rounds after one
/// warm-up round: `NoStats` on 1 thread, `Counters` on 1 thread, `NoStats`
/// on 2 threads. A drift of the machine's speed over the run falls on all
/// three alike, and each ratio is the median of the rounds' own ratios.
/// Returns (median NoStats seconds, median 2-thread seconds, counters'
/// overhead, speed-up).
fn alternating(scene: &Scene) -> (f64, f64, f64, f64) {
    let round = || {
        (
            seconds::<NoStats>(scene, 1),
            seconds::<Counters>(scene, 1),
            seconds::<NoStats>(scene, 2),
        )
    };
    round();
    let rounds: Vec<(f64, f64, f64)> = (0..REPEATS).map(|_| round()).collect();
    let of = |f: &dyn Fn(&(f64, f64, f64)) -> f64| median(rounds.iter().map(f).collect());
    (
        of(&|r| r.0),
        of(&|r| r.2),
        of(&|r| r.1 / r.0 - 1.0),
        of(&|r| r.0 / r.2),
    )
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
            "S1 spheres 960×720",
            "data/scenes/s1-spheres.toml",
            960,
            720,
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
        // The mesh scene names `bvh`, the fastest tree (bvh8).
        ("CGAL camel 1200×900", "data/scenes/camel.toml", 1200, 900),
    ];
    println!(
        "{:<42} {:>10} {:>10} {:>9} {:>10} {:>9}  targets",
        "scene", "Mrays/s", "NoStats s", "Counters", "2 threads", "speed-up"
    );
    // `cargo bench --bench render -- camel`: only the scenes whose name
    // contains one of the words given.
    let words: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with('-'))
        .map(|a| a.to_lowercase())
        .collect();
    let wanted =
        |name: &str| words.is_empty() || words.iter().any(|w| name.to_lowercase().contains(w));
    for (name, path, w, h) in scenes.into_iter().filter(|s| wanted(s.0)) {
        let o = Overrides {
            width: Some(w),
            height: Some(h),
            ..Default::default()
        };
        let scene =
            load_scene(&raylab_testkit::repo_path(path), &o).expect("bench scene (run make deps)");
        let (_, RayCounts(c)) = render::<_, RayCounts>(&scene, &Whitted, Some(1));
        let (off, two, overhead, speed_up) = alternating(&scene);
        let counters = if overhead <= 0.05 { "ok" } else { "MISSED" };
        // Thread scaling is a target only where a render is long enough
        // for the pool's start-up and the last tiles not to dominate.
        let scaling = match (off >= 0.2, speed_up >= 1.9) {
            (false, _) => "n/a (< 0.2 s)",
            (true, true) => "ok",
            (true, false) => "MISSED",
        };
        println!(
            "{:<42} {:>10.2} {:>10.4} {:>+8.1}% {:>10.4} {:>8.2}×  counters {counters}, threads {scaling}",
            name,
            c.rays() as f64 / off / 1e6,
            off,
            overhead * 100.0,
            two,
            speed_up
        );
    }
    println!("(Mrays/s: all rays, 1 thread, NoStats; Counters: overhead of counting every event, 1 thread, target ≤ 5 %; speed-up: 1 vs 2 threads, target ≥ 1.9× on renders ≥ 0.2 s)");
}
