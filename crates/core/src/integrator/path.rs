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
//! ([`crate::lighting`]'s rule, [`LightModel::Physical`]).
//!
//! **Russian roulette.** Once `rr_start` bounces have been taken, a path
//! continues with probability q = min(1, max channel of the throughput β)
//! and β is divided by q when it does: E[β'] = q·β/q = β, so the estimator
//! stays unbiased (Arvo & Kirk 1990).
//!
//! **Lanes.** `direct` and `path:K` renders of scenes of triangles run
//! this estimator over groups of samples in lockstep ([`super::lanes`]),
//! bit for bit: the functions below are what it calls, per lane or over
//! the lanes.
//!
//! **Random numbers.** Vertex i of sample j of pixel (x, y) draws from a
//! SplitMix64 stream keyed by (seed, pixel, j, i); its k-th number is
//! dimension k: light choice, two for the light point, two for the BRDF
//! direction, one for Russian roulette. Every vertex draws all six whether
//! or not it uses them, so a sample's numbers never depend on thread count,
//! on the light list, or on what earlier vertices did.

use super::{Integrator, SampleContext};
use crate::lighting::{lambert_area_sample, lambert_point_lights, LightModel};
use crate::math::{cosine_hemisphere, orthonormal_basis_r, Color, Ray, RayR, Real, SplitMix64, V3};
use crate::scene::{Scene, View};
use crate::shading::{area_to_solid_angle, cosine_pdf, power_heuristic};
use crate::shape::{Hit, HitR};
use crate::stats::{RayKind, Stats};
use glam::Vec2;

/// Bounces before Russian roulette starts, by default: the first bounces
/// carry most of the light, and cutting them early adds variance for
/// little saved time.
pub const DEFAULT_RR_START: u32 = 3;

/// How area lights are sampled. [`LightStrategy::Mis`] is what renders use;
/// the other two exist to check that all three agree in expectation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LightStrategy {
    /// Light sampling and BRDF sampling, combined by the power heuristic.
    #[default]
    Mis,
    /// Light sampling only: emitters that light sampling can reach add
    /// nothing when a BRDF-sampled ray hits them.
    LightOnly,
    /// BRDF sampling only: no shadow rays to area lights (point lights
    /// still get theirs, being reachable no other way).
    BsdfOnly,
}

/// The path tracer's settings (the scene supplies the rest).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PathTracer {
    /// Bounces after the camera hit (0 = direct light only; see the module
    /// docs).
    pub max_bounces: u32,
    /// Russian roulette once this many bounces have been taken; `None`
    /// never (paths run to `max_bounces`).
    pub rr_start: Option<u32>,
    pub strategy: LightStrategy,
}

impl PathTracer {
    /// Up to `max_bounces` bounces, MIS, Russian roulette after
    /// [`DEFAULT_RR_START`] bounces.
    pub fn new(max_bounces: u32) -> Self {
        Self {
            max_bounces,
            rr_start: Some(DEFAULT_RR_START),
            strategy: LightStrategy::Mis,
        }
    }
}

/// Numbers drawn per vertex (see the module docs).
pub(crate) const DIMS_PER_VERTEX: usize = 6;

/// The random numbers of vertex `bounce` of the sample `ctx`: the first
/// [`DIMS_PER_VERTEX`] of the stream [`vertex_key`] keys.
#[inline]
pub(crate) fn vertex_numbers(ctx: &SampleContext, bounce: u32) -> [f32; DIMS_PER_VERTEX] {
    let (seed, pixel, key) = vertex_key(ctx, bounce);
    let mut rng = SplitMix64(SplitMix64::keyed(seed, pixel, key));
    std::array::from_fn(|_| rng.next_f32())
}

/// The key of vertex `bounce`'s stream of the sample `ctx`, as
/// [`SplitMix64::keyed`]'s (seed, pixel, key): the pixel sampler's keying
/// with the sample index and the bounce for its key, salted.
#[inline(always)]
pub(crate) fn vertex_key(ctx: &SampleContext, bounce: u32) -> (u64, u64, u64) {
    // A salt keeps these streams apart from the pixel sampler's, which are
    // keyed by (seed, pixel, sample index) through the same hash.
    const PATH_SALT: u64 = 0x7061_7468_7472_6163; // "pathtrac"
    let pixel = (u64::from(ctx.py) << 32) | u64::from(ctx.px);
    let sample = (u64::from(ctx.index) << 32) | u64::from(bounce);
    (ctx.seed, pixel, sample ^ PATH_SALT)
}

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
        emitted + self.walk(view, hit, 0, one, ctx, stats, end, visit)
    }

    /// The light the path gathers from vertex `first` at `hit` on, the
    /// throughput there being `beta`: each vertex's light samples and the
    /// emission its BRDF ray finds, until the path ends.
    #[allow(clippy::too_many_arguments)]
    fn walk<V: View, S: Stats, E: PathEnd>(
        &self,
        view: &V,
        mut hit: HitR<V::R>,
        first: u32,
        mut beta: V3<V::R>,
        ctx: &SampleContext,
        stats: &mut S,
        end: Option<&E>,
        visit: &mut impl FnMut(&Vertex<'_, V::R>),
    ) -> V3<V::R> {
        let scene = view.scene();
        let mut radiance = V3::zero();
        for bounce in first..=self.max_bounces {
            let albedo = view.material(hit.hit.object).lambert_albedo(hit.point);
            if albedo.value() == Color::ZERO {
                break;
            }
            visit(&Vertex {
                bounce,
                hit: &hit,
                beta,
                albedo,
            });
            let u = vertex_numbers(ctx, bounce);
            let n = hit.shading_normal;
            radiance +=
                beta * albedo * lambert_point_lights(view, &hit, LightModel::Physical, stats);
            if self.strategy != LightStrategy::BsdfOnly {
                if let Some(s) = scene.area_lights.sample(u[0], Vec2::new(u[1], u[2])) {
                    let mis = self.strategy == LightStrategy::Mis;
                    let s = view.area_sample(&s);
                    radiance += beta * albedo * lambert_area_sample(view, &hit, &s, mis, stats);
                }
            }

            // Cosine-weighted BRDF sample: f·cos θ / p = (ρ/π)·cos θ / (cos θ/π) = ρ.
            // The direction is built in the frame of the (parameter-
            // dependent) normal, so for fixed numbers it turns with it.
            let local = cosine_hemisphere(Vec2::new(u[3], u[4]));
            let (t, b) = orthonormal_basis_r(n);
            let l = |c: f32| V::R::from_f32(c);
            let wi = (t * l(local.x) + b * l(local.y) + n * l(local.z)).normalize();
            if local.z <= 0.0 || hit.geometric_normal.value().dot(wi.value()) <= 0.0 {
                // Below the true surface (only with interpolated normals).
                break;
            }
            // Its density is fixed by the local direction: cos θ = local.z.
            let pdf_brdf = cosine_pdf(V::R::from_f32(local.z));
            beta = beta * albedo;
            let step = (bounce, u[5], pdf_brdf);
            match self.follow(
                view,
                &hit,
                wi,
                step,
                &mut beta,
                ctx,
                stats,
                end,
                &mut radiance,
            ) {
                Some(next) => hit = next,
                None => break,
            }
        }
        radiance
    }

    /// The BRDF ray of vertex `bounce` at `hit` along `wi` (density
    /// `pdf_brdf`; `u_rr` the vertex's Russian-roulette number), `beta`
    /// already times the vertex's albedo: adds what its hit contributes
    /// (background, MIS-weighted emission, the `end`'s light) to `radiance`
    /// and returns the next vertex, or `None` where the path ends.
    #[allow(clippy::too_many_arguments)]
    fn follow<V: View, S: Stats, E: PathEnd>(
        &self,
        view: &V,
        hit: &HitR<V::R>,
        wi: V3<V::R>,
        (bounce, u_rr, pdf_brdf): (u32, f32, V::R),
        beta: &mut V3<V::R>,
        ctx: &SampleContext,
        stats: &mut S,
        end: Option<&E>,
        radiance: &mut V3<V::R>,
    ) -> Option<HitR<V::R>> {
        let scene = view.scene();
        let next_ray = RayR::new(hit.spawn_origin(wi), wi);
        stats.ray(RayKind::Path);
        let Some(found) = scene.intersect(&next_ray.value(), scene.settings.max_distance, stats)
        else {
            *radiance += *beta * view.background();
            return None;
        };
        let next = view.surface(&next_ray, found);
        let le = view.material(found.object).emission;
        if le.value() != Color::ZERO {
            let w = self.brdf_hit_weight(view, &next, le, wi, pdf_brdf);
            *radiance += *beta * le * w;
        }
        if let Some(end) = end {
            // The next vertex's numbers, which it no longer needs.
            let v = vertex_numbers(ctx, bounce + 1);
            let albedo = view.material(found.object).lambert_albedo(next.point);
            let cached = V3::from_vec3(end.light_at(&found, [v[0], v[1], v[2]]));
            *radiance += *beta * albedo * cached;
            return None;
        }
        if bounce == self.max_bounces {
            return None;
        }
        if self.rr_start.is_some_and(|s| bounce + 1 >= s) {
            // A discrete choice: its probability is a constant of the
            // estimator, not differentiated.
            let q = beta.value().max_element().min(1.0);
            if u_rr >= q {
                return None;
            }
            *beta = *beta / V::R::from_f32(q);
        }
        Some(next)
    }
    // ANCHOR_END: path_radiance

    /// What the estimator gathers along direction `wi` from vertex `bounce`
    /// at `hit`, with the sample `ctx`'s own random numbers for everything
    /// after: the BRDF ray's MIS-weighted emission and every later vertex's
    /// light, times `beta` (the throughput times the vertex's albedo). This
    /// is the vertex's integrand over directions (divided by cos θ/π), which
    /// the boundary term of the gradient render evaluates either side of a
    /// discontinuity. Zero below the surface.
    #[allow(clippy::too_many_arguments)]
    pub fn continue_along<V: View, S: Stats>(
        &self,
        view: &V,
        hit: &HitR<V::R>,
        wi: V3<V::R>,
        bounce: u32,
        beta: V3<V::R>,
        ctx: &SampleContext,
        stats: &mut S,
    ) -> V3<V::R> {
        let mut radiance = V3::zero();
        let cos = hit.shading_normal.dot(wi);
        if cos.value() <= 0.0 || hit.geometric_normal.value().dot(wi.value()) <= 0.0 {
            return radiance;
        }
        let u_rr = vertex_numbers(ctx, bounce)[5];
        let step = (bounce, u_rr, cosine_pdf(cos));
        let mut beta = beta;
        let none = None::<&NoEnd>;
        if let Some(next) = self.follow(
            view,
            hit,
            wi,
            step,
            &mut beta,
            ctx,
            stats,
            none,
            &mut radiance,
        ) {
            radiance += self.walk(view, next, bounce + 1, beta, ctx, stats, none, &mut |_| {});
        }
        radiance
    }

    /// The weight of emission `le` found at `next` by a BRDF-sampled ray of
    /// direction `wi` and density `pdf_brdf`.
    pub(crate) fn brdf_hit_weight<V: View>(
        &self,
        view: &V,
        next: &HitR<V::R>,
        le: V3<V::R>,
        wi: V3<V::R>,
        pdf_brdf: V::R,
    ) -> V::R {
        let one = V::R::one();
        let pdf_area = view.emitter_pdf(next.hit.prim, le);
        if pdf_area.value() == 0.0 {
            return one; // not reachable by light sampling
        }
        match self.strategy {
            LightStrategy::BsdfOnly => one,
            LightStrategy::LightOnly => V::R::zero(),
            LightStrategy::Mis => {
                let cos_l = next.geometric_normal.dot(wi).abs();
                if cos_l.value() <= 0.0 {
                    return one;
                }
                let pdf_light = area_to_solid_angle(pdf_area, next.t * next.t, cos_l);
                power_heuristic(pdf_brdf, pdf_light)
            }
        }
    }
}
