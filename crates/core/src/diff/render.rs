//! The gradient render: every pixel's derivative with respect to each
//! parameter, by forward-mode differentiation of the same estimator the
//! `f32` render computes.
//!
//! For each sample of each pixel the camera ray, the hits, the shading and
//! the light samples are evaluated on `Dual<K>` through a
//! [`DualScene`]; traversal and every discrete decision (which primitive,
//! which light, whether a shadow ray is blocked, total internal reflection,
//! Russian roulette) are taken on values, exactly as in the `f32` render,
//! and the random numbers are the render's own (same seed, same per-pixel
//! streams). The per-pixel result is the mean of the samples' derivatives,
//! with its sample variance: the derivative of the pixel estimator, an
//! unbiased estimate of the *interior* derivative (see [`super`]). Where
//! a parameter moves what camera rays meet (geometry, the camera, an
//! index of refraction), the rim zones of spheres are sampled on the
//! sphere instead ([`super::rim`]): still unbiased, but there no longer
//! the derivative of the `f32` render's own samples.
//!
//! With [`Visibility::Full`] (the default of `raylab grad`) each pass then
//! adds the boundary term ([`super::boundary`]) on the same duals, with
//! about as many samples per pixel of curve length as the pixels have,
//! and for the path tracer the vertex terms
//! ([`super::boundary::vertex`]), one path per pixel sample.
//!
//! Parameters are taken K at a time with K ∈ {1, 2, 4, 8, 16} (the smallest
//! that holds them); more than 16 run in several passes.

use super::boundary::mirror::mirrors;
use super::boundary::vertex::path_term;
use super::boundary::{boundary_term, Boundary, Visibility};
use super::params::moves_hits;
use super::planes::{PixelMoments, Planes, Spread};
use super::rim::{rim_term, RimStats, Rims};
use super::view::DualScene;
use super::DiffError;
use crate::film::Filter;
use crate::integrator::{in_pool, IntegratorKind, SampleContext};
use crate::sampler::Sampler;
use crate::scene::description::SceneDescription;
use crate::scene::param::ParamId;
use crate::scene::{Scene, View};
use glam::Vec2;
use rayon::prelude::*;

/// The most parameters one pass carries.
pub const MAX_K: usize = 16;

/// Per-pixel derivatives of an image with respect to some parameters.
#[derive(Clone, Debug)]
pub struct Gradients {
    pub width: u32,
    pub height: u32,
    pub params: Vec<ParamId>,
    /// Per parameter, per pixel and channel (row-major, RGB interleaved):
    /// `mean` is the mean over the pixel's samples of ∂sample/∂param,
    /// plus (with `Full` visibility) the boundary term; `variance` is
    /// `count` × the variance of the pixel's estimate (divide by `count`
    /// for that variance; with `Interior` visibility the unbiased sample
    /// variance of ∂sample/∂param); `variance_grey` the same per pixel for
    /// the channel mean (R+G+B)/3, for the standard error of the image
    /// mean's derivative.
    pub planes: Planes,
    /// Samples per pixel.
    pub count: u32,
    pub visibility: Visibility,
    /// The boundary term alone (already in `planes`): empty planes and no
    /// samples with `Interior` visibility.
    pub boundary: Boundary,
    /// What the rim zones' sampler did (its part of the interior
    /// derivative is in `planes`; [`super::rim`]).
    pub rim: RimStats,
}

impl Gradients {
    /// The derivative of the image mean (over pixels and channels) with
    /// respect to parameter `i`, and its standard error (pixels are
    /// independent; the channels of one pixel are not, hence the grey
    /// variance).
    pub fn image_mean(&self, i: usize) -> (f64, f64) {
        let n = (self.width * self.height) as f64;
        let mean = self.planes.mean[i]
            .iter()
            .map(|&x| f64::from(x))
            .sum::<f64>()
            / (3.0 * n);
        let var: f64 = self.planes.variance_grey[i]
            .iter()
            .map(|&v| f64::from(v))
            .sum::<f64>()
            / f64::from(self.count.max(1));
        (mean, var.sqrt() / n)
    }

    /// The standard error of [`Gradients::grey`] per pixel.
    pub fn grey_se(&self, i: usize) -> Vec<f32> {
        let m = self.count.max(1) as f32;
        self.planes.variance_grey[i]
            .iter()
            .map(|&v| (v / m).sqrt())
            .collect()
    }

    /// Parameter `i`'s derivative per pixel, averaged over the channels.
    pub fn grey(&self, i: usize) -> Vec<f32> {
        self.planes.mean[i]
            .chunks_exact(3)
            .map(|c| (c[0] + c[1] + c[2]) / 3.0)
            .collect()
    }
}

/// Check that `integrator` and the scene's sampler and filter are ones the
/// gradient render supports.
pub fn check_supported(scene: &Scene, integrator: &IntegratorKind) -> Result<(), DiffError> {
    let refuse = |why: String| Err(DiffError::Unsupported(why));
    if let IntegratorKind::FloodFill(_) = integrator {
        return refuse(
            "the gradient render supports `whitted`, `direct` and `path:K`; flood fill's cache \
             is not differentiated"
                .into(),
        );
    }
    if let Sampler::Adaptive { .. } = scene.settings.sampler {
        return refuse(
            "the gradient render needs a fixed sampler (adaptive sampling decides its sample \
             count from the image)"
                .into(),
        );
    }
    if scene.settings.filter != Filter::Box {
        return refuse(format!(
            "the gradient render averages each pixel's samples (the box filter); the scene \
             asks for `{}`: use `--filter box`",
            scene.settings.filter.name()
        ));
    }
    Ok(())
}

/// What a gradient render differentiates and how: the scene, its
/// description, the parameters, the integrator, the visibility term and
/// the threads (`None`: all cores).
#[derive(Clone, Copy)]
pub struct GradientRender<'a> {
    pub scene: &'a Scene,
    pub desc: &'a SceneDescription,
    pub params: &'a [ParamId],
    pub integrator: IntegratorKind,
    pub visibility: Visibility,
    pub threads: Option<usize>,
}

/// The K of the pass that carries `n` parameters (at most [`MAX_K`]).
fn pass_width(n: usize) -> usize {
    match n {
        0..=2 => n.max(1),
        3 | 4 => 4,
        5..=8 => 8,
        _ => MAX_K,
    }
}

/// What [`render_gradients`] holds at its peak, in the pass where it is
/// largest: the derivative planes of the parameters of the passes before
/// ([`Planes`]: mean, variance and grey variance, 28 bytes per pixel
/// each), twice with `Full` visibility (the boundary term's own are kept
/// apart); each pixel's [`PixelMoments`] of the pass's K duals beside the
/// pass's planes (the rim zones add into them), then those beside the
/// boundary term's and, for the path tracer, the vertex term's planes and
/// per-pixel moments; with `Full` visibility under Whitted, a curved
/// mirror's grid at its largest
/// ([`super::boundary::curved::grid_bytes`]); and the worker threads.
/// Measured against peak resident memory in crates/cli/tests/memory.rs
/// (within +10 %/−0 % with the interior derivative). The boundary term's
/// planes and the grid are counted whole: the pages of a plane no curve
/// crosses are never written, so never resident, and the peak is lower
/// by up to their size; the grid's bound is its largest, rarely reached.
pub fn gradient_bytes(r: &GradientRender<'_>) -> u128 {
    use crate::film::memory::THREAD_BYTES;
    use std::mem::size_of;
    let cam = &r.scene.camera;
    let pixels = u128::from(cam.width) * u128::from(cam.height);
    let plane = (7 * size_of::<f32>()) as u128;
    let full = r.visibility == Visibility::Full;
    let path = full && r.integrator.path_tracer().is_some();
    // Pass by pass: the planes of the passes before (twice with the
    // boundary term's), the pass's own planes, beside first its per-pixel
    // moments (dropped once the planes hold them), then the boundary
    // term's; the peak is the largest.
    let mut peak = 0;
    for (i, chunk) in r.params.chunks(MAX_K).enumerate() {
        let kept = (i * MAX_K) as u128 * plane * if full { 2 } else { 1 };
        let m = chunk.len() as u128;
        let moments = (4 * pass_width(chunk.len()) * size_of::<crate::math::Moments>()) as u128;
        let mut boundary = 0;
        if full {
            boundary += m * plane;
        }
        if path {
            boundary += m * plane + moments + size_of::<super::BoundaryStats>() as u128;
        }
        peak = peak.max(kept + m * plane + moments.max(boundary));
    }
    let grid = if full && matches!(r.integrator, IntegratorKind::Whitted) {
        super::boundary::curved::grid_bytes(r.scene)
    } else {
        0
    };
    let threads = r.threads.unwrap_or_else(rayon::current_num_threads).max(1) as u128;
    pixels * peak + grid + threads * THREAD_BYTES
}

/// Render the derivatives of `r.scene` with respect to `r.params`: the
/// interior derivative, plus the boundary term with `Full` visibility.
/// The result is the same on any number of threads. Refused before any
/// work when [`gradient_bytes`] exceeds the memory available.
pub fn render_gradients(r: &GradientRender<'_>) -> Result<Gradients, DiffError> {
    check_supported(r.scene, &r.integrator)?;
    crate::film::memory::check(
        || {
            format!(
                "the derivatives of {}×{} pixels with respect to {} parameters",
                r.scene.camera.width,
                r.scene.camera.height,
                r.params.len()
            )
        },
        gradient_bytes(r),
    )?;
    let cam = &r.scene.camera;
    let mut out = Gradients {
        width: cam.width,
        height: cam.height,
        params: r.params.to_vec(),
        planes: Planes::default(),
        count: r.scene.settings.sampler.spp(),
        visibility: r.visibility,
        boundary: Boundary::default(),
        rim: RimStats::default(),
    };
    for chunk in r.params.chunks(MAX_K) {
        let pass = GradientRender {
            params: chunk,
            ..*r
        };
        let mut result = match pass_width(chunk.len()) {
            1 => run_pass::<1>(&pass)?,
            2 => run_pass::<2>(&pass)?,
            4 => run_pass::<4>(&pass)?,
            8 => run_pass::<8>(&pass)?,
            _ => run_pass::<16>(&pass)?,
        };
        if let Some(b) = result.boundary {
            result.planes.add_scaled(&b.planes, out.count as f32);
            out.boundary.extend(b);
        }
        out.rim.add(&result.rim);
        out.planes.extend(result.planes);
    }
    Ok(out)
}

/// What one pass of up to K parameters makes: the interior planes (the
/// rim zones' part included), with `Full` visibility the boundary term,
/// and the rim sampler's counters.
struct Pass {
    planes: Planes,
    boundary: Option<Boundary>,
    rim: RimStats,
}

/// One pass with K-wide duals for `r.params` (≤ K of them).
fn run_pass<const K: usize>(r: &GradientRender<'_>) -> Result<Pass, DiffError> {
    let (scene, params, integrator) = (r.scene, r.params, &r.integrator);
    let view = DualScene::<K>::new(scene, r.desc, params)?;
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    let sampler = scene.settings.sampler;
    let seed = scene.settings.seed;
    let spp = sampler.spp();
    let n = params.len();
    // Rim zones only where a parameter moves what a camera ray meets at a
    // fixed film point (module `rim`); elsewhere the derivative stays that
    // of the `f32` render's own estimator. Flat mirrors reflect under
    // Whitted only.
    let rims = if params.iter().any(moves_hits) {
        let flat: Vec<_> = match integrator {
            IntegratorKind::Whitted => mirrors(&view).iter().map(|m| m.value()).collect(),
            _ => Vec::new(),
        };
        Rims::of(scene, &flat)
    } else {
        Rims::default()
    };
    crate::integrator::progress::announce(h as u64);
    let rows: Vec<Vec<PixelMoments<K>>> = in_pool(r.threads, || {
        (0..h)
            .into_par_iter()
            .map(|py| {
                let row = (0..w)
                    .map(|px| {
                        let (px, py) = (px as u32, py as u32);
                        let mut sums = PixelMoments::<K>::default();
                        for index in 0..spp {
                            let off = sampler.sample(px, py, index, seed);
                            let pos = Vec2::new(px as f32, py as f32) + off;
                            let ray = view.camera_ray(pos.x, pos.y);
                            if rims.owns(scene, &ray.value()) {
                                // Counts 0: the rim sampler covers it.
                                continue;
                            }
                            let ctx = SampleContext {
                                px,
                                py,
                                index,
                                seed,
                            };
                            let v = integrator.radiance_on(&view, &ray, &ctx);
                            let partials: [[f64; 3]; K] = std::array::from_fn(|k| {
                                [v.x.d[k], v.y.d[k], v.z.d[k]].map(f64::from)
                            });
                            sums.add(&partials[..n]);
                        }
                        sums
                    })
                    .collect();
                crate::integrator::progress::row_done();
                row
            })
            .collect()
    });
    let mut planes = Planes::zeros(n, scene.camera.width, scene.camera.height);
    for (py, row) in rows.iter().enumerate() {
        for (px, sums) in row.iter().enumerate() {
            planes.add_pixel(py * w + px, n, sums, f64::from(spp), Spread::Samples);
        }
    }
    drop(rows);
    // The rim zones the pixel samples left out.
    let rim = rim_term(
        &view,
        &rims,
        n,
        integrator,
        spp,
        seed,
        r.threads,
        &mut planes,
    );
    let boundary = (r.visibility == Visibility::Full).then(|| {
        let mut b = boundary_term(&view, params, integrator, spp as f32, seed, r.threads);
        // What paths meet after the camera ray (`direct`, `path:K`).
        if let Some(tracer) = integrator.path_tracer() {
            b.absorb(path_term(&view, params, &tracer, spp, seed, r.threads));
        }
        b
    });
    Ok(Pass {
        planes,
        boundary,
        rim,
    })
}
