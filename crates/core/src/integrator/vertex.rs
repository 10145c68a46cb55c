//! One vertex of the path tracer's estimator ([`super::path`] describes
//! it), written once: the tracer's settings ([`PathTracer`]), a vertex's
//! random numbers, and each step taken there. Two loops run the steps, in
//! the same order:
//!
//! - [`super::path`]'s one-sample loop (`PathTracer::walk` and `follow`),
//!   over any [`Real`], so the derivative code runs it on dual numbers;
//! - [`super::lanes`]'s groups of 16 samples in lockstep, which call each
//!   step per lane inside their loops over the lanes, where the compiler
//!   inlines it and turns the arithmetic into SIMD instructions.
//!
//! The steps at a vertex x, with β the path's throughput up to x:
//!
//! 1. **The BSDF** at x ([`Bsdf::of`](super::bsdf::Bsdf::of)); a surface that reflects nothing
//!    ends the path ([`Bsdf::reflects`](super::bsdf::Bsdf::reflects)).
//! 2. **The numbers**: six uniform numbers keyed by (seed, pixel, sample,
//!    vertex) (`vertex_numbers`), by what they are for
//!    (`VertexNumbers`).
//! 3. **Next-event estimation**: every point light behind a shadow ray
//!    (`point_lights`) and one area-light sample (`pick_area_light`,
//!    weighted by [`crate::lighting::lambert_area_terms`] with the MIS
//!    weight when `PathTracer::mis`, behind a shadow ray; one sample at a
//!    time that is `PathTracer::area_light`), each through the BSDF
//!    ([`Bsdf::reflected`](super::bsdf::Bsdf::reflected)).
//! 4. **The BSDF sample**: a direction, its density and whether it leaves
//!    below the surface, which ends the path ([`Bsdf::sample`](super::bsdf::Bsdf::sample)); then the
//!    throughput update β ← β·f·cos θ/p ([`super::bsdf::BsdfSample::throughput`]).
//! 5. **The BSDF ray**: what it brings back, the background or the emission
//!    of the surface it finds weighted for MIS
//!    (`PathTracer::bsdf_ray_light`, `PathTracer::emission_weight`).
//! 6. **Going on**: the last bounce or Russian roulette ends the path
//!    (`PathTracer::carry_on`, `roulette`); else the surface found is
//!    the next vertex.

use super::SampleContext;
use crate::light::AreaSample;
use crate::lighting::{lambert_area_sample, lambert_point_lights, LightModel};
use crate::math::{Color, Real, SplitMix64, V3};
use crate::scene::{Scene, View};
use crate::shading::{area_to_solid_angle, power_heuristic};
use crate::shape::HitR;
use crate::stats::Stats;
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
    /// Bounces after the camera hit (0 = direct light only; see
    /// [`super::path`]).
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

/// Numbers drawn per vertex (see [`VertexNumbers`]).
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

/// A vertex's [`vertex_numbers`] by what they are for: dimension 0 picks
/// the emitter, 1–2 the point on it, 3–4 the BSDF direction, 5 is Russian
/// roulette's. Every vertex draws all six whether or not it uses them.
#[derive(Clone, Copy, Debug)]
pub(crate) struct VertexNumbers {
    /// The area-light sample's: the emitter's, then the point's two.
    pub light: [f32; 3],
    /// The BSDF direction's.
    pub bsdf: Vec2,
    /// Russian roulette's.
    pub roulette: f32,
}

impl From<[f32; DIMS_PER_VERTEX]> for VertexNumbers {
    #[inline(always)]
    fn from(u: [f32; DIMS_PER_VERTEX]) -> Self {
        Self {
            light: [u[0], u[1], u[2]],
            bsdf: Vec2::new(u[3], u[4]),
            roulette: u[5],
        }
    }
}

/// The point lights the path tracer sees ([`LightModel::Physical`]).
const LIGHTS: LightModel = LightModel::Physical;

/// Whether `scene` has point lights the path tracer sees.
pub(crate) fn sees_point_lights(scene: &Scene) -> bool {
    scene.lights.iter().any(|l| LIGHTS.sees(l))
}

/// Next-event estimation's point lights at `hit`: each one's light behind
/// a shadow ray, as a white Lambertian surface reflects it (for
/// [`Bsdf::reflected`](super::bsdf::Bsdf::reflected)).
#[inline(always)]
pub(crate) fn point_lights<V: View, S: Stats>(
    view: &V,
    hit: &HitR<V::R>,
    stats: &mut S,
) -> V3<V::R> {
    lambert_point_lights(view, hit, LIGHTS, stats)
}

/// The area-light sample the numbers `u` pick: an emitter chosen by power,
/// a point uniform on it; `None` where the scene has no emitters.
#[inline(always)]
pub(crate) fn pick_area_light(scene: &Scene, u: &VertexNumbers) -> Option<AreaSample> {
    scene
        .area_lights
        .sample(u.light[0], Vec2::new(u.light[1], u.light[2]))
}

/// Russian roulette (Arvo & Kirk 1990) with the uniform number `u`: the
/// path goes on with probability q = min(1, max channel of `beta`), its
/// throughput divided by q (`None`: it ends). E[β'] = q·β/q = β, so the
/// estimator stays unbiased.
#[inline(always)]
pub(crate) fn roulette<R: Real>(beta: V3<R>, u: f32) -> Option<V3<R>> {
    // A discrete choice: its probability is a constant of the estimator,
    // not differentiated.
    let q = beta.value().max_element().min(1.0);
    if u >= q {
        return None;
    }
    Some(beta / R::from_f32(q))
}

impl PathTracer {
    /// Whether vertices sample an area light (every strategy but BSDF
    /// sampling alone).
    #[inline(always)]
    pub(crate) fn samples_area_lights(&self) -> bool {
        self.strategy != LightStrategy::BsdfOnly
    }

    /// Whether area-light samples carry the power heuristic's MIS weight
    /// (else weight 1: light sampling alone).
    #[inline(always)]
    pub(crate) fn mis(&self) -> bool {
        self.strategy == LightStrategy::Mis
    }

    /// Next-event estimation's area-light sample at `hit`, one sample at a
    /// time: the point `u` picks, weighted, behind its shadow ray, as a
    /// white Lambertian surface reflects it (for
    /// [`Bsdf::reflected`](super::bsdf::Bsdf::reflected));
    /// `None` where no sample is drawn.
    #[inline(always)]
    pub(crate) fn area_light<V: View, S: Stats>(
        &self,
        view: &V,
        hit: &HitR<V::R>,
        u: &VertexNumbers,
        stats: &mut S,
    ) -> Option<V3<V::R>> {
        if !self.samples_area_lights() {
            return None;
        }
        let s = view.area_sample(&pick_area_light(view.scene(), u)?);
        Some(lambert_area_sample(view, hit, &s, self.mis(), stats))
    }

    /// What a vertex's BSDF ray (direction `wi`, density `pdf`) brings back
    /// to a path of throughput `beta` (already times the sample's weight):
    /// the background where it left the scene (`next` is `None`), else the
    /// emission of the surface `next` it found, weighted by
    /// [`PathTracer::emission_weight`]; `None` where that surface emits
    /// nothing.
    #[inline(always)]
    pub(crate) fn bsdf_ray_light<V: View>(
        &self,
        view: &V,
        next: Option<&HitR<V::R>>,
        wi: V3<V::R>,
        pdf: V::R,
        beta: V3<V::R>,
    ) -> Option<V3<V::R>> {
        let Some(next) = next else {
            return Some(beta * view.background());
        };
        let le = view.material(next.hit.object).emission;
        if le.value() == Color::ZERO {
            return None;
        }
        Some(beta * le * self.emission_weight(view, next, le, wi, pdf))
    }

    /// The weight of emission `le` found at `next` by a BSDF-sampled ray of
    /// direction `wi` and density `pdf_bsdf`: the power heuristic against
    /// the area-light sample that could have drawn the point (1 where
    /// light sampling cannot reach it, 0 under light sampling alone).
    pub(crate) fn emission_weight<V: View>(
        &self,
        view: &V,
        next: &HitR<V::R>,
        le: V3<V::R>,
        wi: V3<V::R>,
        pdf_bsdf: V::R,
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
                power_heuristic(pdf_bsdf, pdf_light)
            }
        }
    }

    /// Whether the path goes on to the surface vertex `bounce`'s BSDF ray
    /// found, and with what throughput (`beta` before, `u_rr` the vertex's
    /// roulette number): not after the last bounce, and once `rr_start`
    /// bounces have been taken only if it survives [`roulette`].
    #[inline(always)]
    pub(crate) fn carry_on<R: Real>(&self, bounce: u32, beta: V3<R>, u_rr: f32) -> Option<V3<R>> {
        if bounce == self.max_bounces {
            return None;
        }
        if self.rr_start.is_some_and(|s| bounce + 1 >= s) {
            return roulette(beta, u_rr);
        }
        Some(beta)
    }
}
