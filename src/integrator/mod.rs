//! Integrators turn a camera ray into a colour, and [`render`] drives one
//! over the image in parallel.
//!
//! The render loop is parallel over image rows (rayon). Each row is computed
//! by one thread with its own statistics sink; sinks are summed after the
//! loop, so there are no atomics or locks on the hot path, and because every
//! sample is a pure function of (pixel, sample index, seed) the image is the
//! same bit for bit on any number of threads.
//!
//! [`IntegratorKind`] names the integrators a user can pick (`whitted`,
//! `direct`, `path:K`) and renders with the chosen one, dispatching once
//! per render so every ray runs monomorphised code.

pub mod path;
pub mod whitted;

pub use path::PathTracer;
pub use whitted::Whitted;

use crate::film::{Film, PixelStats};
use crate::math::{Color, Ray, Vec3};
use crate::scene::Scene;
use crate::shape::Hit;
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

/// Whether `target` is visible from `hit`: one shadow ray (counted as
/// [`crate::stats::RayKind::Shadow`]) from the hit point, offset to the
/// side `dir` leaves on, stopping ε short of the target (see
/// [`whitted`]'s module docs for ε). `dir` is the unit direction towards
/// `target`.
#[inline]
pub fn visible<S: Stats>(scene: &Scene, hit: &Hit, dir: Vec3, target: Vec3, stats: &mut S) -> bool {
    let origin = whitted::offset_origin(hit, dir);
    let to_target = target - origin;
    let len = to_target.length();
    stats.ray(crate::stats::RayKind::Shadow);
    let shadow = Ray::new(origin, to_target / len);
    !scene.occluded(&shadow, len * (1.0 - whitted::OFFSET_SCALE), stats)
}

/// The integrators a render can use, as named on the command line and in
/// manifests: `whitted`, `direct` (path tracing with no bounce: emission
/// seen plus light sampled at the first hit) and `path:K` (up to K bounces
/// after the camera hit; see [`path`] for what a bounce is).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum IntegratorKind {
    Whitted,
    Direct,
    Path(PathTracer),
}

/// The most bounces `path:K` accepts (a typo guard; Russian roulette ends
/// nearly every path long before).
pub const MAX_BOUNCES: u32 = 1024;

impl IntegratorKind {
    /// Parse `whitted`, `direct` or `path:K` (K in 0..=[`MAX_BOUNCES`]).
    pub fn parse(s: &str) -> Result<Self, String> {
        match s.split_once(':') {
            None if s == "whitted" => Ok(Self::Whitted),
            None if s == "direct" => Ok(Self::Direct),
            Some(("path", k)) => match k.parse::<u32>() {
                Ok(k) if k <= MAX_BOUNCES => Ok(Self::Path(PathTracer::new(k))),
                _ => Err(format!(
                    "path bounce count must be an integer in 0..={MAX_BOUNCES}, got `{k}`"
                )),
            },
            _ => Err(format!(
                "unknown integrator `{s}` (expected `whitted`, `direct` or `path:K`, \
                 K = bounces after the camera hit, e.g. `path:4`)"
            )),
        }
    }

    /// The name it parses from (`whitted`, `direct`, `path:4`).
    pub fn name(&self) -> String {
        match self {
            Self::Whitted => "whitted".into(),
            Self::Direct => "direct".into(),
            Self::Path(p) => format!("path:{}", p.max_bounces),
        }
    }

    /// The path tracer this kind runs, if it is one (`direct` is the path
    /// tracer with no bounce).
    pub fn path_tracer(&self) -> Option<PathTracer> {
        match *self {
            Self::Whitted => None,
            Self::Direct => Some(PathTracer::new(0)),
            Self::Path(p) => Some(p),
        }
    }

    /// Set the bounce count after which Russian roulette starts (`None`:
    /// never); no effect on `whitted` and `direct`.
    pub fn with_rr_start(mut self, rr_start: Option<u32>) -> Self {
        if let Self::Path(p) = &mut self {
            p.rr_start = rr_start;
        }
        self
    }

    /// Render the scene with this integrator (see [`render`]).
    pub fn render<S>(&self, scene: &Scene, threads: Option<usize>) -> (Film, S)
    where
        S: Stats + Default + AddAssign + Send,
    {
        match self.path_tracer() {
            None => render(scene, &Whitted, threads),
            Some(p) => render(scene, &p, threads),
        }
    }
}

impl std::str::FromStr for IntegratorKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Self::parse(s)
    }
}

impl std::fmt::Display for IntegratorKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.name())
    }
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
