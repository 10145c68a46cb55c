//! Integrators turn a camera ray into a colour, and [`render`] drives one
//! over the image in parallel.
//!
//! The render loop is parallel over image rows (rayon). Each row is computed
//! by one thread with its own statistics sink; sinks are summed after the
//! loop, so there are no atomics or locks on the hot path, and because every
//! sample is a pure function of (pixel, sample index, seed) the image is the
//! same bit for bit on any number of threads.

pub mod whitted;

pub use whitted::Whitted;

use crate::film::{Film, PixelStats};
use crate::math::{Color, Ray};
use crate::scene::Scene;
use crate::stats::{Counters, Stats};
use rayon::prelude::*;
use std::ops::AddAssign;

/// Where a camera sample comes from: the integrators that use random
/// numbers seed them from this, never from thread state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SampleContext {
    pub px: u32,
    pub py: u32,
    pub index: u32,
    pub seed: u64,
}

/// An integrator: the colour seen along a camera ray.
pub trait Integrator: Sync {
    fn radiance<S: Stats>(
        &self,
        scene: &Scene,
        ray: &Ray,
        ctx: &SampleContext,
        stats: &mut S,
    ) -> Color;
}

/// Render every pixel of the scene's camera with the scene's sampler.
/// `threads = None` uses rayon's global pool (all cores).
pub fn render<I, S>(scene: &Scene, integrator: &I, threads: Option<usize>) -> (Film, S)
where
    I: Integrator,
    S: Stats + Default + AddAssign + Send,
{
    in_pool(threads, || render_rows::<I, S>(scene, integrator))
}

/// Render with full counters and keep each pixel's own counts (the cost
/// buffers behind per-pixel heatmaps): returns the film, the totals and one
/// [`Counters`] per pixel, row-major.
pub fn render_with_costs<I: Integrator>(
    scene: &Scene,
    integrator: &I,
    threads: Option<usize>,
) -> (Film, Counters, Vec<Counters>) {
    let run = || {
        let cam = &scene.camera;
        let (w, spp, seed) = (
            cam.width as usize,
            scene.settings.sampler.spp(),
            scene.settings.seed,
        );
        let mut film = Film::new(cam.width, cam.height);
        let mut costs = vec![Counters::default(); film.pixels.len()];
        let total = film
            .pixels
            .par_chunks_mut(w)
            .zip(costs.par_chunks_mut(w))
            .enumerate()
            .map(|(py, (row, cost_row))| {
                let mut row_total = Counters::default();
                for (px, (pixel, cost)) in row.iter_mut().zip(cost_row.iter_mut()).enumerate() {
                    *pixel = render_pixel(scene, integrator, px as u32, py as u32, spp, seed, cost);
                    row_total += *cost;
                }
                row_total
            })
            .reduce(Counters::default, |mut a, b| {
                a += b;
                a
            });
        (film, total, costs)
    };
    in_pool(threads, run)
}

/// Run `f` on a pool of `threads` workers, or on rayon's global pool.
fn in_pool<T: Send>(threads: Option<usize>, f: impl FnOnce() -> T + Send) -> T {
    match threads {
        None => f(),
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n.max(1))
            .build()
            .expect("building a rayon thread pool") // only fails on OS thread exhaustion
            .install(f),
    }
}

fn render_rows<I, S>(scene: &Scene, integrator: &I) -> (Film, S)
where
    I: Integrator,
    S: Stats + Default + AddAssign + Send,
{
    let cam = &scene.camera;
    let sampler = scene.settings.sampler;
    let spp = sampler.spp();
    let seed = scene.settings.seed;
    let mut film = Film::new(cam.width, cam.height);
    let stats = film
        .pixels
        .par_chunks_mut(cam.width as usize)
        .enumerate()
        .map(|(py, row)| {
            let mut stats = S::default();
            for (px, pixel) in row.iter_mut().enumerate() {
                *pixel = render_pixel(
                    scene, integrator, px as u32, py as u32, spp, seed, &mut stats,
                );
            }
            stats
        })
        .reduce(S::default, |mut a, b| {
            a += b;
            a
        });
    (film, stats)
}

#[inline]
fn render_pixel<I: Integrator, S: Stats>(
    scene: &Scene,
    integrator: &I,
    px: u32,
    py: u32,
    spp: u32,
    seed: u64,
    stats: &mut S,
) -> PixelStats {
    let mut acc = PixelStats::default();
    for index in 0..spp {
        let off = scene.settings.sampler.sample(px, py, index, seed);
        let ray = scene
            .camera
            .generate_ray(px as f32 + off.x, py as f32 + off.y);
        let ctx = SampleContext {
            px,
            py,
            index,
            seed,
        };
        acc.add(integrator.radiance(scene, &ray, &ctx, stats));
    }
    acc
}
