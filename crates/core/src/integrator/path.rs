//! Monte Carlo path tracing (Kajiya 1986) for Lambertian surfaces, with
//! next-event estimation and multiple importance sampling.
//!
//! Every surface reflects as a Lambertian BRDF f = ρ/π whose albedo ρ is the
//! Phong material's diffuse part, k_d × colour clamped to [0, 1]
//! ([`crate::material::Material::lambert_albedo`]); specular, mirror and glass terms are
//! ignored. Emission is two-sided and the same in every direction (a
//! material's `emission` is the radiance L_e). Rays that leave the scene
//! return the background colour (an unsampled, uniform environment).
//!
//! **Bounces.** The camera ray's hit x₁ is not a bounce. A *bounce* is a
//! direction sampled from the BRDF at a vertex to continue the path: with
//! `max_bounces = K` the path has vertices x₁ … x_{K+1}, and the image holds
//! every light path with at most K + 1 reflections, i.e. direct light plus
//! K indirect bounces. `K = 0` is direct lighting only (S4's "direct
//! only"); S4's "1 spp 4 bounces" is K = 4 at one sample per pixel and
//! "2 spp 1 bounce" K = 1 at two. As in pbrt's `PathIntegrator`, the last
//! vertex still traces one BRDF ray, whose hit only contributes the
//! emission it sees (the BRDF-sampling half of that vertex's MIS pair), so
//! a path of K bounces traces K + 1 path rays plus its shadow rays.
//!
//! **Light sampling.** At each vertex: one shadow ray to each point light
//! (a delta light, reachable by light sampling only) and one to a point on
//! an emissive triangle or sphere ([`AreaLights`](crate::light::AreaLights):
//! chosen by power, uniform on the shape). Area-light samples and emitters
//! hit by BRDF-sampled rays are combined by Veach's power heuristic (β = 2,
//! one sample each): w_light = p_l² / (p_l² + p_b²), w_brdf = p_b² / (p_l² +
//! p_b²), with p_l = p_A·d²/|cos θ_l| (the light's area density turned into
//! solid angle) and p_b = cos θ/π. Emitters that are never sampled
//! (ellipsoids, planes) get weight 1 when a BRDF ray finds them.
//!
//! **Point lights.** A point light's `color × intensity` is taken as its
//! radiant intensity divided by π, I = π·c·i, so a Lambertian surface of
//! albedo ρ lit from distance d at angle θ reflects
//! L = (ρ/π)·I·falloff(d)·cos θ = ρ·c·i·falloff(d)·cos θ: exactly the
//! Whitted integrator's diffuse term k_d·C·E·(n·l). Lights flagged
//! `whitted_only` (stand-ins for an emissive surface) are skipped
//! ([`crate::lighting`]'s rule, [`LightModel::Physical`](crate::lighting::LightModel::Physical)).
//!
//! **Russian roulette.** Once `rr_start` bounces have been taken, a path
//! continues with probability q = min(1, max channel of the throughput β)
//! and β is divided by q when it does: E[β'] = q·β/q = β, so the estimator
//! stays unbiased (Arvo & Kirk 1990).
//!
//! **One vertex, two loops.** Each step at a vertex (the BSDF, next-event
//! estimation, the BSDF sample and throughput update, the emission its ray
//! finds, Russian roulette) is written once in [`super::vertex`] and
//! [`super::bsdf`]. This file runs them one sample at a time, over any
//! [`Real`]; `direct` and `path:K` renders of scenes of triangles run the
//! same steps over groups of samples in lockstep ([`super::lanes`]), in the
//! same order, so bit for bit.
//!
//! **Random numbers.** Vertex i of sample j of pixel (x, y) draws from a
//! SplitMix64 stream keyed by (seed, pixel, j, i); its k-th number is
//! dimension k: light choice, two for the light point, two for the BRDF
//! direction, one for Russian roulette. Every vertex draws all six whether
//! or not it uses them, so a sample's numbers never depend on thread count,
//! on the light list, or on what earlier vertices did.

use super::bsdf::Bsdf;
use super::vertex::{point_lights, vertex_numbers, VertexNumbers};
pub use super::vertex::{LightStrategy, PathTracer, DEFAULT_RR_START};
use super::{Integrator, SampleContext};
use crate::math::{Color, Ray, RayR, Real, V3};
use crate::scene::{Scene, View};
use crate::shape::{Hit, HitR};
use crate::stats::{RayKind, Stats};

impl Integrator for PathTracer {
    fn radiance<S: Stats>(
        &self,
        scene: &Scene,
        ray: &Ray,
        ctx: &SampleContext,
        stats: &mut S,
    ) -> Color {
        self.trace(scene, &RayR::from(*ray), ctx, stats, None::<&NoEnd>)
            .into()
    }
}

/// What ends a path early at the first bounce's hit instead of going on:
/// the flood-fill cache ([`super::floodfill`]) reads its stored light there.
pub trait PathEnd {
    /// The light leaving `hit` towards the path, divided by the albedo
    /// there (the caller multiplies by it); `u` are three uniform numbers.
    fn light_at(&self, hit: &Hit, u: [f32; 3]) -> Color;
}

/// The `PathEnd` of a plain path tracer (never used).
pub enum NoEnd {}

impl PathEnd for NoEnd {
    fn light_at(&self, _: &Hit, _: [f32; 3]) -> Color {
        match *self {}
    }
}

/// A path vertex as [`PathTracer::trace_visiting`] reports it, before its
/// light sampling: the hit, the bounce index (0 at the camera ray's hit),
/// the throughput β of the path up to it and its albedo.
pub struct Vertex<'a, R> {
    pub bounce: u32,
    pub hit: &'a HitR<R>,
    pub beta: V3<R>,
    pub albedo: V3<R>,
}

/// What a path carries from vertex to vertex: its throughput β and the
/// light it has gathered.
struct PathState<R> {
    beta: V3<R>,
    radiance: V3<R>,
}

impl<R: Real> PathState<R> {
    /// Adds `light`, if any, to the light gathered.
    #[inline(always)]
    fn gather(&mut self, light: Option<V3<R>>) {
        if let Some(light) = light {
            self.radiance += light;
        }
    }
}

/// What stays the same along one sample's path: the sample (whose numbers
/// key the vertices' random numbers), the counters, and what ends the path
/// early, if anything.
struct PathSample<'a, S, E> {
    ctx: &'a SampleContext,
    stats: &'a mut S,
    end: Option<&'a E>,
}

/// The BSDF ray of vertex `bounce`: its direction `wi` and density `pdf`,
/// and the vertex's Russian-roulette number.
struct BsdfRay<R> {
    bounce: u32,
    wi: V3<R>,
    pdf: R,
    roulette: f32,
}

impl PathTracer {
    /// The radiance along a camera ray. With `end`, the path stops at the
    /// first bounce's hit x₂: after the emission found there (MIS-weighted
    /// as usual), x₂ adds albedo × `end.light_at(x₂)` in place of its own
    /// light sampling and further bounces.
    #[inline]
    pub fn trace<V: View, S: Stats, E: PathEnd>(
        &self,
        view: &V,
        ray: &RayR<V::R>,
        ctx: &SampleContext,
        stats: &mut S,
        end: Option<&E>,
    ) -> V3<V::R> {
        self.trace_visiting(view, ray, ctx, stats, end, &mut |_| {})
    }

    /// [`PathTracer::trace`], calling `visit` at every vertex (the boundary
    /// term of the gradient render samples the vertices' integrals there).
    // ANCHOR: path_radiance
    pub fn trace_visiting<V: View, S: Stats, E: PathEnd>(
        &self,
        view: &V,
        ray: &RayR<V::R>,
        ctx: &SampleContext,
        stats: &mut S,
        end: Option<&E>,
        visit: &mut impl FnMut(&Vertex<'_, V::R>),
    ) -> V3<V::R> {
        let scene = view.scene();
        stats.ray(RayKind::Camera);
        let Some(found) = scene.intersect(&ray.value(), scene.settings.max_distance, stats) else {
            return view.background();
        };
        let hit = view.surface(ray, found);
        // Emission seen directly has no other strategy to share with.
        let emitted = view.material(found.object).emission;
        let one = V3::splat(V::R::one());
        let mut sample = PathSample { ctx, stats, end };
        emitted + self.walk(view, hit, 0, one, &mut sample, visit)
    }

    /// The light the path gathers from vertex `first` at `hit` on, the
    /// throughput there being `beta`: each vertex's light samples and the
    /// emission its BSDF ray finds, until the path ends. The steps are
    /// [`super::vertex`]'s, in its order.
    fn walk<V: View, S: Stats, E: PathEnd>(
        &self,
        view: &V,
        mut hit: HitR<V::R>,
        first: u32,
        beta: V3<V::R>,
        sample: &mut PathSample<'_, S, E>,
        visit: &mut impl FnMut(&Vertex<'_, V::R>),
    ) -> V3<V::R> {
        let mut path = PathState {
            beta,
            radiance: V3::zero(),
        };
        for bounce in first..=self.max_bounces {
            let bsdf = Bsdf::of(view, &hit);
            if !bsdf.reflects() {
                break;
            }
            visit(&Vertex {
                bounce,
                hit: &hit,
                beta: path.beta,
                albedo: bsdf.albedo,
            });
            let u = VertexNumbers::from(vertex_numbers(sample.ctx, bounce));
            let stats = &mut *sample.stats;
            path.radiance += bsdf.reflected(path.beta, point_lights(view, &hit, stats));
            if let Some(light) = self.area_light(view, &hit, &u, stats) {
                path.radiance += bsdf.reflected(path.beta, light);
            }
            let s = bsdf.sample(hit.shading_normal, hit.geometric_normal.value(), u.bsdf);
            if s.below {
                break;
            }
            path.beta = s.throughput(path.beta);
            let ray = BsdfRay {
                bounce,
                wi: s.wi,
                pdf: s.pdf,
                roulette: u.roulette,
            };
            match self.follow(view, &hit, ray, &mut path, sample) {
                Some(next) => hit = next,
                None => break,
            }
        }
        path.radiance
    }

    /// The BSDF ray `ray` from `hit` (the path's β already times the
    /// sample's weight): adds what it brings back (background, MIS-weighted
    /// emission, the `end`'s light) to the path's light and returns the
    /// next vertex, or `None` where the path ends.
    fn follow<V: View, S: Stats, E: PathEnd>(
        &self,
        view: &V,
        hit: &HitR<V::R>,
        ray: BsdfRay<V::R>,
        path: &mut PathState<V::R>,
        sample: &mut PathSample<'_, S, E>,
    ) -> Option<HitR<V::R>> {
        let scene = view.scene();
        let next_ray = RayR::new(hit.spawn_origin(ray.wi), ray.wi);
        sample.stats.ray(RayKind::Path);
        let max = scene.settings.max_distance;
        let Some(found) = scene.intersect(&next_ray.value(), max, sample.stats) else {
            path.gather(self.bsdf_ray_light(view, None, ray.wi, ray.pdf, path.beta));
            return None;
        };
        let next = view.surface(&next_ray, found);
        path.gather(self.bsdf_ray_light(view, Some(&next), ray.wi, ray.pdf, path.beta));
        if let Some(end) = sample.end {
            // The next vertex's light numbers, which it no longer needs.
            let v = VertexNumbers::from(vertex_numbers(sample.ctx, ray.bounce + 1));
            let cached = V3::from_vec3(end.light_at(&next.hit, v.light));
            path.radiance += Bsdf::of(view, &next).reflected(path.beta, cached);
            return None;
        }
        path.beta = self.carry_on(ray.bounce, path.beta, ray.roulette)?;
        Some(next)
    }
    // ANCHOR_END: path_radiance

    /// What the estimator gathers along direction `wi` from the vertex
    /// `from`, with the sample `ctx`'s own random numbers for everything
    /// after: the BSDF ray's MIS-weighted emission and every later vertex's
    /// light, times the throughput there (β times the vertex's albedo).
    /// This is the vertex's integrand over directions (divided by cos θ/π),
    /// which the boundary term of the gradient render evaluates either side
    /// of a discontinuity. Zero below the surface.
    pub fn continue_along<V: View, S: Stats>(
        &self,
        view: &V,
        from: &Vertex<'_, V::R>,
        wi: V3<V::R>,
        ctx: &SampleContext,
        stats: &mut S,
    ) -> V3<V::R> {
        let hit = from.hit;
        let bsdf = Bsdf {
            albedo: from.albedo,
        };
        let n = hit.shading_normal;
        let Some(s) = bsdf.sample_towards(n, hit.geometric_normal.value(), wi) else {
            return V3::zero();
        };
        let u = VertexNumbers::from(vertex_numbers(ctx, from.bounce));
        let mut path = PathState {
            beta: s.throughput(from.beta),
            radiance: V3::zero(),
        };
        let mut sample = PathSample {
            ctx,
            stats,
            end: None::<&NoEnd>,
        };
        let ray = BsdfRay {
            bounce: from.bounce,
            wi,
            pdf: s.pdf,
            roulette: u.roulette,
        };
        if let Some(next) = self.follow(view, hit, ray, &mut path, &mut sample) {
            let first = from.bounce + 1;
            let rest = self.walk(view, next, first, path.beta, &mut sample, &mut |_| {});
            path.radiance += rest;
        }
        path.radiance
    }
}
