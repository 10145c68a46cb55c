//! Speed of one flood-fill propagation step (S4's cache, `raylab::gi`) on
//! the Cornell box voxelised at 32³, 64³ and 128³, on one thread (the
//! issue's goal: well under 5 ms at 64³ on one core) and on the rayon pool.
//!
//! A small harness like `crates/core/benches/render.rs`: each measurement runs
//! `STEPS` steps once to warm up, then `REPEATS` times, and the median
//! time per step is printed with steps/s. Rows: linear and gamma averaging
//! (gamma runs the same loop on I^γ, so it should cost the same), and the
//! step with the residual (which gamma pays for with powers).
//!
//! Run with `make bench` or `cargo bench --bench floodfill`.

use raylab::gi::{
    Averaging, FloodFill, FloodFillConfig, GridSpec, Threads, DEFAULT_WALL_LIGHT_SAMPLES,
};
use raylab::io::scene_file::{load_scene, Overrides};
use raylab_lab::experiment::study::{median, process_cpu_seconds};
use std::time::Instant;

const REPEATS: usize = 7;

/// Median (wall, process CPU) seconds per step. CPU time is what one core
/// spends, and what other programs on a shared machine disturb least: they
/// can delay the thread but not add to its CPU time.
fn median_seconds_per_step(
    ff: &mut FloodFill,
    steps: usize,
    threads: Threads,
    residual: bool,
) -> (f64, f64) {
    let run = |ff: &mut FloodFill| {
        let cpu = process_cpu_seconds();
        let s = Instant::now();
        for _ in 0..steps {
            if residual {
                std::hint::black_box(ff.step_with_residual(threads));
            } else {
                ff.step(threads);
            }
        }
        let wall = s.elapsed().as_secs_f64() / steps as f64;
        (wall, (process_cpu_seconds() - cpu) / steps as f64)
    };
    run(ff);
    let (wall, cpu): (Vec<f64>, Vec<f64>) = (0..REPEATS).map(|_| run(ff)).unzip();
    (median(&wall), median(&cpu))
}

fn main() {
    let scene = load_scene(
        &raylab_testkit::repo_path("data/scenes/cornell-box.toml"),
        &Overrides::default(),
    )
    .expect("the Cornell box scene");
    println!(
        "flood-fill step, Cornell box, median of {REPEATS} (rayon pool: {} threads)",
        rayon::current_num_threads()
    );
    println!(
        "{:>5} {:>7} {:>9} {:>8} {:>10} {:>12} {:>9}",
        "grid", "avg", "residual", "threads", "ms/step", "cpu ms/step", "steps/s"
    );
    for res in [32usize, 64, 128] {
        // Enough steps per repeat for ~50 ms at the expected speed.
        let steps = (4 * 64usize.pow(3) / res.pow(3)).clamp(2, 64) * 4;
        for averaging in [Averaging::Linear, Averaging::Gamma] {
            let cfg = FloodFillConfig {
                averaging,
                ..FloodFillConfig::default()
            };
            let mut ff =
                FloodFill::from_scene(&scene, &GridSpec::new(res), cfg, DEFAULT_WALL_LIGHT_SAMPLES)
                    .expect("voxelise the Cornell box");
            for (threads, name) in [(Threads::One, "one"), (Threads::Pool, "pool")] {
                for residual in [false, true] {
                    let (s, cpu) = median_seconds_per_step(&mut ff, steps, threads, residual);
                    println!(
                        "{:>5} {:>7} {:>9} {:>8} {:>10.3} {:>12.3} {:>9.0}",
                        format!("{res}³"),
                        format!("{averaging:?}").to_lowercase(),
                        if residual { "yes" } else { "no" },
                        name,
                        s * 1e3,
                        cpu * 1e3,
                        1.0 / s
                    );
                }
            }
        }
    }
}
