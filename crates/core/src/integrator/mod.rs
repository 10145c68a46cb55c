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

pub mod adaptive;
pub mod bsdf;
pub mod floodfill;
pub mod lanes;
pub mod path;
pub mod progress;
pub mod vertex;
pub mod whitted;

pub use floodfill::{FloodFillIntegrator, FloodFillSettings};
pub use path::PathTracer;
pub use whitted::Whitted;

use crate::error::ParseError;
use crate::film::{Film, FilmSample, Filter, PixelStats};
use crate::gi::GiError;
use crate::math::{Color, Ray, RayR, Real, V3};
use crate::sampler::Sampler;
use crate::scene::{Scene, View};
use crate::stats::{Counters, RenderStats, Stats};
use glam::Vec2;
use rayon::prelude::*;

/// Where a camera sample comes from: the integrators that use random
/// numbers seed them from this, never from thread state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SampleContext {
    pub px: u32,
    pub py: u32,
    pub index: u32,
    pub seed: u64,
}

impl SampleContext {
    /// The sample's position on the image plane (the pixel's corner plus
    /// the scene sampler's offset) and its camera ray: where every render
    /// loop's samples start ([`render_pixel`], [`lanes`]'s groups).
    #[inline(always)]
    pub(crate) fn camera_ray(&self, scene: &Scene) -> (Vec2, Ray) {
        let off = scene
            .settings
            .sampler
            .sample(self.px, self.py, self.index, self.seed);
        let pos = Vec2::new(self.px as f32, self.py as f32) + off;
        (pos, scene.camera.generate_ray(pos.x, pos.y))
    }
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

/// The integrators a render can use, as named on the command line and in
/// manifests: `whitted`, `direct` (path tracing with no bounce: emission
/// seen plus light sampled at the first hit), `path:K` (up to K bounces
/// after the camera hit; see [`path`] for what a bounce is) and
/// `floodfill[:…]` (one bounce, then S4's voxel cache; see [`floodfill`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum IntegratorKind {
    Whitted,
    Direct,
    Path(PathTracer),
    FloodFill(FloodFillSettings),
}

/// An integrator ready to render frames of one scene: for flood fill, with
/// its cache built and warmed up.
pub enum Prepared {
    Plain(IntegratorKind),
    FloodFill(Box<FloodFillIntegrator>),
}

impl Prepared {
    /// Render one frame (flood fill: its propagation steps, then the
    /// render).
    pub fn frame<S: RenderStats>(
        &mut self,
        scene: &Scene,
        threads: Option<usize>,
    ) -> Result<(Film, S), RenderError> {
        match self {
            Prepared::Plain(kind) => kind.render(scene, threads),
            Prepared::FloodFill(ff) => Ok(ff.frame(scene, threads)),
        }
    }
}

/// Why a render could not start: only flood fill can fail, when its cache
/// cannot be built over the scene.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum RenderError {
    /// The flood-fill cache (its voxel grid, its settings) could not be
    /// built.
    #[error(transparent)]
    FloodFillCache(#[from] GiError),
}

/// The most bounces `path:K` accepts (a typo guard; Russian roulette ends
/// nearly every path long before).
pub const MAX_BOUNCES: u32 = 1024;

impl IntegratorKind {
    /// Parse `whitted`, `direct` or `path:K` (K in 0..=[`MAX_BOUNCES`]).
    pub fn parse(s: &str) -> Result<Self, ParseError> {
        if let Some(rest) = s.strip_prefix("floodfill") {
            return FloodFillSettings::parse(rest).map(Self::FloodFill);
        }
        match s.split_once(':') {
            None if s == "whitted" => Ok(Self::Whitted),
            None if s == "direct" => Ok(Self::Direct),
            Some(("path", k)) => match k.parse::<u32>() {
                Ok(k) if k <= MAX_BOUNCES => Ok(Self::Path(PathTracer::new(k))),
                _ => Err(ParseError::Value {
                    what: "path bounce count".into(),
                    expected: format!("an integer in 0..={MAX_BOUNCES}"),
                    given: k.to_string(),
                }),
            },
            _ => Err(ParseError::Unknown {
                what: "integrator",
                given: s.to_string(),
                expected: "`whitted`, `direct`, `path:K`, K = bounces after the camera hit, \
                           e.g. `path:4`, or `floodfill[:key=value,…]`"
                    .into(),
            }),
        }
    }

    /// The name it parses from (`whitted`, `direct`, `path:4`).
    pub fn name(&self) -> String {
        match self {
            Self::Whitted => "whitted".into(),
            Self::Direct => "direct".into(),
            Self::Path(p) => format!("path:{}", p.max_bounces),
            Self::FloodFill(f) => f.name(),
        }
    }

    /// Get ready to render frames of `scene` (builds the flood-fill cache;
    /// fails only when the scene cannot be voxelised).
    pub fn prepare(&self, scene: &Scene) -> Result<Prepared, RenderError> {
        Ok(match self {
            Self::FloodFill(f) => {
                Prepared::FloodFill(Box::new(FloodFillIntegrator::build(scene, *f)?))
            }
            other => Prepared::Plain(*other),
        })
    }

    /// The path tracer this kind runs, if it is one (`direct` is the path
    /// tracer with no bounce).
    pub fn path_tracer(&self) -> Option<PathTracer> {
        match *self {
            Self::Whitted | Self::FloodFill(_) => None,
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

    /// One sample's radiance along `ray` on `view` (the `f32` scene or the
    /// derivative code's dual-number view), with this integrator and no
    /// counting: what the gradient render and the boundary term evaluate
    /// per sample. Flood fill, whose cache the derivative code does not
    /// differentiate, has none: zero (callers refuse it before rendering).
    pub fn radiance_on<V: View>(
        &self,
        view: &V,
        ray: &RayR<V::R>,
        ctx: &SampleContext,
    ) -> V3<V::R> {
        let mut stats = crate::stats::NoStats;
        match self {
            Self::Whitted => Whitted.radiance_of(view, ray, &mut stats),
            Self::Direct | Self::Path(_) => {
                let p = self
                    .path_tracer()
                    .expect("direct and path are path tracers");
                p.trace(view, ray, ctx, &mut stats, None::<&path::NoEnd>)
            }
            Self::FloodFill(_) => V3::splat(V::R::zero()),
        }
    }

    /// Render the scene with this integrator (see [`render`]).
    /// Flood fill builds and warms its cache first (see [`Self::prepare`]
    /// to build it once for many frames); that alone can fail, when the
    /// scene cannot be voxelised.
    pub fn render<S>(&self, scene: &Scene, threads: Option<usize>) -> Result<(Film, S), RenderError>
    where
        S: RenderStats,
    {
        Ok(match self {
            Self::Whitted => render(scene, &Whitted, threads),
            Self::Direct | Self::Path(_) => {
                let p = self
                    .path_tracer()
                    .expect("direct and path are path tracers");
                // Over groups of samples where the lanes cover the scene.
                lanes::render(scene, &p, threads)
            }
            Self::FloodFill(_) => self.prepare(scene)?.frame(scene, threads)?,
        })
    }
}

impl std::str::FromStr for IntegratorKind {
    type Err = ParseError;
    fn from_str(s: &str) -> Result<Self, ParseError> {
        Self::parse(s)
    }
}

impl std::fmt::Display for IntegratorKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.name())
    }
}

/// Render every pixel of the scene's camera with the scene's sampler and
/// reconstruction filter. `threads = None` uses rayon's global pool (all
/// cores).
pub fn render<I, S>(scene: &Scene, integrator: &I, threads: Option<usize>) -> (Film, S)
where
    I: Integrator,
    S: RenderStats,
{
    in_pool(threads, || {
        let (film, total, _) = render_film::<I, S>(scene, integrator, false);
        (film, total)
    })
}

/// Render with full counters and keep each pixel's own counts (the cost
/// buffers behind per-pixel heatmaps): returns the film, the totals and one
/// [`Counters`] per pixel, row-major.
pub fn render_with_costs<I: Integrator>(
    scene: &Scene,
    integrator: &I,
    threads: Option<usize>,
) -> (Film, Counters, Vec<Counters>) {
    in_pool(threads, || {
        render_film::<I, Counters>(scene, integrator, true)
    })
}

/// The most worker threads any command starts (`--threads`, a manifest's
/// `threads`): beyond the hardware threads of the largest machines (two
/// 192-core, 384-thread processors have 768), so it never limits real
/// parallelism; oversubscribing further only adds switching, and each
/// thread reserves its own stack. Asking for more is an error, not a
/// silent clamp.
pub const MAX_THREADS: usize = 1024;

/// Run `f` on a pool of `threads` workers (at most [`MAX_THREADS`]), or on
/// rayon's global pool.
pub(crate) fn in_pool<T: Send>(threads: Option<usize>, f: impl FnOnce() -> T + Send) -> T {
    match threads {
        None => f(),
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n.clamp(1, MAX_THREADS))
            .build()
            .expect("building a rayon thread pool") // only fails on OS thread exhaustion
            .install(f),
    }
}

/// The render loop, written once: `row` renders image row `py` into its
/// pixels, with a statistics sink of its own, in parallel over the rows;
/// each row is announced to [`progress`] and reported done there. Returns
/// the sinks' sum and each row's output, in row order. The one-sample
/// renders ([`render_film`]) and the path tracer's groups
/// ([`lanes::render`]) run their rows here.
pub(crate) fn render_rows<S, T>(
    film: &mut Film,
    row: impl Fn(u32, &mut [PixelStats], &mut S) -> T + Sync,
) -> (S, Vec<T>)
where
    S: RenderStats,
    T: Send,
{
    progress::announce(u64::from(film.height));
    let rows: Vec<(S, T)> = film
        .pixels
        .par_chunks_mut(film.width as usize)
        .enumerate()
        // One row per task: rayon otherwise runs runs of rows that nobody
        // can steal from once started, and rows differ in cost.
        .with_max_len(1)
        .map(|(py, pixels)| {
            let mut stats = S::default();
            let out = row(py as u32, pixels, &mut stats);
            progress::row_done();
            (stats, out)
        })
        .collect();
    let mut total = S::default();
    let outputs = rows
        .into_iter()
        .map(|(stats, out)| {
            total += stats;
            out
        })
        .collect();
    (total, outputs)
}

/// What one image row of [`render_film`] produced besides its statistics
/// total: each pixel's own statistics (when asked for) and its samples
/// (when a filter wider than the box needs them).
struct RowOutput<S> {
    per_pixel: Vec<S>,
    samples: Vec<FilmSample>,
}

/// The one-sample renders: [`render_rows`] with [`render_pixel`] along
/// each row. Returns the film (filtered if the scene asks for a filter),
/// the totals and, if `per_pixel`, each pixel's statistics (else an empty
/// vector).
fn render_film<I, S>(scene: &Scene, integrator: &I, per_pixel: bool) -> (Film, S, Vec<S>)
where
    I: Integrator,
    S: RenderStats,
{
    if let Sampler::Adaptive { threshold, depth } = scene.settings.sampler {
        let (film, pixels) = adaptive::render::<I, S>(scene, integrator, threshold, depth);
        let mut total = S::default();
        for p in &pixels {
            total += p.clone();
        }
        return (film, total, if per_pixel { pixels } else { Vec::new() });
    }
    let cam = &scene.camera;
    let spp = scene.settings.sampler.spp();
    let filter = scene.settings.filter;
    let keep_samples = filter != Filter::Box;
    let mut film = Film::new(cam.width, cam.height);
    let (total, rows) = render_rows(&mut film, |py, row, row_total: &mut S| {
        let mut out = RowOutput {
            per_pixel: Vec::with_capacity(if per_pixel { row.len() } else { 0 }),
            samples: Vec::with_capacity(if keep_samples {
                row.len() * spp as usize
            } else {
                0
            }),
        };
        for (px, pixel) in row.iter_mut().enumerate() {
            let mut stats = S::default();
            let samples = keep_samples.then_some(&mut out.samples);
            *pixel = render_pixel(scene, integrator, px as u32, py, samples, &mut stats);
            if per_pixel {
                out.per_pixel.push(stats.clone());
            }
            *row_total += stats;
        }
        out
    });
    // Sized once: grown by doubling it could hold twice the pixels.
    let mut pixels = Vec::with_capacity(if per_pixel {
        cam.width as usize * cam.height as usize
    } else {
        0
    });
    // Each row's samples stay where the row put them: gathering them into
    // one vector would hold them twice (film::memory counts them once).
    let mut samples = Vec::with_capacity(rows.len());
    for row in rows {
        pixels.extend(row.per_pixel);
        samples.push(row.samples);
    }
    if keep_samples {
        film.reconstruct(filter, &samples, spp as usize);
    }
    (film, total, pixels)
}

/// One pixel's samples through the scene's sampler: their running
/// statistics, and each sample's film position and value appended to
/// `samples` when given.
#[inline]
fn render_pixel<I: Integrator, S: Stats>(
    scene: &Scene,
    integrator: &I,
    px: u32,
    py: u32,
    mut samples: Option<&mut Vec<FilmSample>>,
    stats: &mut S,
) -> PixelStats {
    let sampler = scene.settings.sampler;
    let seed = scene.settings.seed;
    let mut acc = PixelStats::default();
    for index in 0..sampler.spp() {
        let ctx = SampleContext {
            px,
            py,
            index,
            seed,
        };
        let (pos, ray) = ctx.camera_ray(scene);
        let value = integrator.radiance(scene, &ray, &ctx, stats);
        acc.add(value);
        if let Some(s) = samples.as_deref_mut() {
            s.push(FilmSample { pos, value });
        }
    }
    acc
}
