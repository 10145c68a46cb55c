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
use super::params::Param;
use super::rim::{moves_hits, rim_term, RimStats, Rims};
use super::view::DualScene;
use crate::film::Filter;
use crate::integrator::{in_pool, IntegratorKind, SampleContext};
use crate::io::scene_file::SceneFile;
use crate::sampler::Sampler;
use crate::scene::{Scene, View};
use glam::Vec2;
use rayon::prelude::*;
use std::path::Path;

/// The most parameters one pass carries.
pub const MAX_K: usize = 16;

/// Per-pixel derivatives of an image with respect to some parameters.
#[derive(Clone, Debug)]
pub struct Gradients {
    pub width: u32,
    pub height: u32,
    pub params: Vec<Param>,
    /// Per parameter, per pixel and channel (row-major, RGB interleaved):
    /// the mean over the pixel's samples of ∂sample/∂param, plus (with
    /// `Full` visibility) the boundary term.
    pub mean: Vec<Vec<f32>>,
    /// The same layout: `count` × the variance of the pixel's estimate
    /// (divide by `count` for that variance). With `Interior` visibility
    /// this is the unbiased sample variance of ∂sample/∂param.
    pub variance: Vec<Vec<f32>>,
    /// Per parameter, per pixel: the same for the channel mean (R+G+B)/3,
    /// for the standard error of the image mean's derivative.
    pub variance_grey: Vec<Vec<f32>>,
    /// Samples per pixel.
    pub count: u32,
    pub visibility: Visibility,
    /// The boundary term alone (already in `mean`): empty planes and no
    /// samples with `Interior` visibility.
    pub boundary: Boundary,
    /// What the rim zones' sampler did (its part of the interior
    /// derivative is in `mean`; [`super::rim`]).
    pub rim: RimStats,
}

impl Gradients {
    /// The derivative of the image mean (over pixels and channels) with
    /// respect to parameter `i`, and its standard error (pixels are
    /// independent; the channels of one pixel are not, hence the grey
    /// variance).
    pub fn image_mean(&self, i: usize) -> (f64, f64) {
        let n = (self.width * self.height) as f64;
        let mean = self.mean[i].iter().map(|&x| f64::from(x)).sum::<f64>() / (3.0 * n);
        let var: f64 = self.variance_grey[i]
            .iter()
            .map(|&v| f64::from(v))
            .sum::<f64>()
            / f64::from(self.count.max(1));
        (mean, var.sqrt() / n)
    }

    /// The standard error of [`Gradients::grey`] per pixel.
    pub fn grey_se(&self, i: usize) -> Vec<f32> {
        let m = self.count.max(1) as f32;
        self.variance_grey[i]
            .iter()
            .map(|&v| (v / m).sqrt())
            .collect()
    }

    /// Parameter `i`'s derivative per pixel, averaged over the channels.
    pub fn grey(&self, i: usize) -> Vec<f32> {
        self.mean[i]
            .chunks_exact(3)
            .map(|c| (c[0] + c[1] + c[2]) / 3.0)
            .collect()
    }
}

/// Check that `integrator` and the scene's sampler and filter are ones the
/// gradient render supports.
pub fn check_supported(scene: &Scene, integrator: &IntegratorKind) -> Result<(), String> {
    if let IntegratorKind::FloodFill(_) = integrator {
        return Err(
            "the gradient render supports `whitted`, `direct` and `path:K`; flood fill's cache \
             is not differentiated"
                .into(),
        );
    }
    if let Sampler::Adaptive { .. } = scene.settings.sampler {
        return Err(
            "the gradient render needs a fixed sampler (adaptive sampling decides its sample \
             count from the image)"
                .into(),
        );
    }
    if scene.settings.filter != Filter::Box {
        return Err(format!(
            "the gradient render averages each pixel's samples (the box filter); the scene \
             asks for `{}`: use `--filter box`",
            scene.settings.filter.name()
        ));
    }
    Ok(())
}

/// Render the derivatives of `scene` (loaded from `file`, read from `path`)
/// with respect to `params` with `integrator`, on `threads` threads (`None`:
/// all cores): the interior derivative, plus the boundary term with
/// `Full` visibility. The result is the same on any number of threads.
pub fn render_gradients(
    scene: &Scene,
    file: &SceneFile,
    path: &Path,
    params: &[Param],
    integrator: IntegratorKind,
    visibility: Visibility,
    threads: Option<usize>,
) -> Result<Gradients, String> {
    check_supported(scene, &integrator)?;
    let cam = &scene.camera;
    let mut out = Gradients {
        width: cam.width,
        height: cam.height,
        params: params.to_vec(),
        mean: Vec::new(),
        variance: Vec::new(),
        variance_grey: Vec::new(),
        count: scene.settings.sampler.spp(),
        visibility,
        boundary: Boundary::default(),
        rim: RimStats::default(),
    };
    for chunk in params.chunks(MAX_K) {
        let run = (scene, file, path, chunk, integrator, visibility, threads);
        let (mut mean, mut variance, mut grey, boundary, rim) = match chunk.len() {
            1 => pass::<1>(run)?,
            2 => pass::<2>(run)?,
            3 | 4 => pass::<4>(run)?,
            5..=8 => pass::<8>(run)?,
            _ => pass::<16>(run)?,
        };
        if let Some(b) = boundary {
            let m = out.count as f32;
            for k in 0..chunk.len() {
                add(&mut mean[k], &b.mean[k], 1.0);
                add(&mut variance[k], &b.variance[k], m);
                add(&mut grey[k], &b.variance_grey[k], m);
            }
            out.boundary.extend(b);
        }
        out.rim.add(&rim);
        out.mean.extend(mean);
        out.variance.extend(variance);
        out.variance_grey.extend(grey);
    }
    Ok(out)
}

/// a += s·b, element by element.
fn add(a: &mut [f32], b: &[f32], s: f32) {
    for (x, y) in a.iter_mut().zip(b) {
        *x += s * y;
    }
}

/// The interior planes (mean, variance, grey variance), with `Full`
/// visibility the boundary term, and the rim sampler's counters.
type Planes = (
    Vec<Vec<f32>>,
    Vec<Vec<f32>>,
    Vec<Vec<f32>>,
    Option<Boundary>,
    RimStats,
);

/// What one pass needs: the scene, its file and path, the parameters, the
/// integrator, the visibility and the threads.
type Run<'a> = (
    &'a Scene,
    &'a SceneFile,
    &'a Path,
    &'a [Param],
    IntegratorKind,
    Visibility,
    Option<usize>,
);

/// Running sums of one pixel's samples' partials.
struct PixelSums<const K: usize> {
    s1: [[f64; 3]; K],
    s2: [[f64; 3]; K],
    g2: [f64; K],
}

/// One pass with K-wide duals for `params` (≤ K of them).
fn pass<const K: usize>(
    (scene, file, path, params, integrator, visibility, threads): Run<'_>,
) -> Result<Planes, String> {
    let view = DualScene::<K>::new(scene, file, path, params)?;
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
    // Per row: for each pixel, (mean, variance, grey variance) per param.
    crate::integrator::progress::announce(h as u64);
    let rows: Vec<Vec<[f32; 7]>> = in_pool(threads, || {
        (0..h)
            .into_par_iter()
            .map(|py| {
                let mut row = Vec::with_capacity(w * n);
                for px in 0..w {
                    let mut sums = PixelSums::<K> {
                        s1: [[0.0; 3]; K],
                        s2: [[0.0; 3]; K],
                        g2: [0.0; K],
                    };
                    for index in 0..spp {
                        let (px, py) = (px as u32, py as u32);
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
                        for k in 0..n {
                            let d = [v.x.d[k], v.y.d[k], v.z.d[k]].map(f64::from);
                            for (c, &dc) in d.iter().enumerate() {
                                sums.s1[k][c] += dc;
                                sums.s2[k][c] += dc * dc;
                            }
                            let g = (d[0] + d[1] + d[2]) / 3.0;
                            sums.g2[k] += g * g;
                        }
                    }
                    let m = f64::from(spp);
                    let var = |s1: f64, s2: f64| {
                        if spp > 1 {
                            ((s2 - s1 * s1 / m) / (m - 1.0)).max(0.0) as f32
                        } else {
                            0.0
                        }
                    };
                    for k in 0..n {
                        let (s1, s2) = (sums.s1[k], sums.s2[k]);
                        let g1 = (s1[0] + s1[1] + s1[2]) / 3.0;
                        row.push([
                            (s1[0] / m) as f32,
                            (s1[1] / m) as f32,
                            (s1[2] / m) as f32,
                            var(s1[0], s2[0]),
                            var(s1[1], s2[1]),
                            var(s1[2], s2[2]),
                            var(g1, sums.g2[k]),
                        ]);
                    }
                }
                crate::integrator::progress::row_done();
                row
            })
            .collect()
    });
    let mut mean = vec![Vec::with_capacity(w * h * 3); n];
    let mut variance = vec![Vec::with_capacity(w * h * 3); n];
    let mut grey = vec![Vec::with_capacity(w * h); n];
    for row in rows {
        for (j, v) in row.iter().enumerate() {
            let k = j % n;
            mean[k].extend_from_slice(&v[0..3]);
            variance[k].extend_from_slice(&v[3..6]);
            grey[k].push(v[6]);
        }
    }
    // The rim zones the pixel samples left out.
    let rim = rim_term(&view, &rims, n, &integrator, spp, seed, threads);
    let m = spp as f32;
    for k in 0..n {
        add(&mut mean[k], &rim.mean[k], 1.0);
        add(&mut variance[k], &rim.variance[k], m);
        add(&mut grey[k], &rim.variance_grey[k], m);
    }
    let boundary = (visibility == Visibility::Full).then(|| {
        let mut b = boundary_term(&view, params, &integrator, spp as f32, seed, threads);
        // What paths meet after the camera ray (`direct`, `path:K`).
        if let Some(tracer) = integrator.path_tracer() {
            b.absorb(path_term(&view, params, &tracer, spp, seed, threads));
        }
        b
    });
    Ok((mean, variance, grey, boundary, rim.stats))
}
