//! Direct light at a surface point: which lights an estimator sees, the
//! shadow ray behind each, and the light they deliver. Written once for
//! the Whitted integrator, the path tracer (`direct`, `path:K`) and the
//! flood-fill cache's wall faces; the formulas themselves are the
//! [`crate::shading`] kernels.
//!
//! **The rule for `whitted_only` point lights.** A point light flagged
//! `whitted_only` stands in for an emissive surface that the Whitted
//! integrator cannot see as a light (the Cornell box's ceiling lamp). Only
//! [`LightModel::Whitted`] sees it; every physically based estimator
//! ([`LightModel::Physical`]: the path tracer, direct lighting, and the
//! flood-fill cache however it is built) skips it, since it samples the
//! emitter itself and counting both would double the light.
//!
//! Sits above [`crate::scene`] (it traces shadow rays through the scene)
//! and below the integrators and [`crate::gi`].

use crate::light::{AreaSampleR, Falloff, PointLight};
use crate::math::{Color, Real, SplitMix64, Vec3, V3};
use crate::scene::{Scene, View};
use crate::shading;
use crate::shape::{Hit, HitR};
use crate::stats::{NoStats, RayKind, Stats};
use glam::Vec2;

/// Which point lights an estimator sees (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightModel {
    /// Every point light, `whitted_only` stand-ins included.
    Whitted,
    /// Every point light but the `whitted_only` stand-ins.
    Physical,
}

impl LightModel {
    /// Whether this model sees `light`.
    #[inline]
    pub fn sees(self, light: &PointLight) -> bool {
        self == LightModel::Whitted || !light.whitted_only
    }
}

/// Whether `target` is visible from `hit`: one shadow ray (counted as
/// [`RayKind::Shadow`]) built by [`Hit::shadow_segment`]. `dir` is the unit
/// direction towards `target`.
#[inline]
pub fn visible<S: Stats>(scene: &Scene, hit: &Hit, dir: Vec3, target: Vec3, stats: &mut S) -> bool {
    let (shadow, t_max) = hit.shadow_segment(dir, target);
    stats.ray(RayKind::Shadow);
    !scene.occluded(&shadow, t_max, stats)
}

/// One point light as seen from a hit.
#[derive(Clone, Copy, Debug)]
pub struct Incidence<R> {
    /// Unit direction towards the light.
    pub dir: V3<R>,
    /// cos θ = n·l with the shading normal (> 0).
    pub cos_theta: R,
    /// The light arriving at the point (falloff applied).
    pub arriving: V3<R>,
}

/// The light point light `i` sends to `hit`, if it reaches it: the light
/// must lie in front of both the shading and the geometric normal (the
/// geometric test keeps shadow rays from starting inside the object) and
/// be visible. Which lights reach the point is decided on values; the
/// direction, cosine and arriving light are the view's [`Real`]s.
#[inline]
pub fn point_light_incidence<V: View, S: Stats>(
    view: &V,
    hit: &HitR<V::R>,
    i: usize,
    stats: &mut S,
) -> Option<Incidence<V::R>> {
    let light = &view.scene().lights[i];
    let (position, radiance) = view.point_light(i);
    let to_light = position - hit.point;
    let dist = to_light.length();
    let l = to_light / dist;
    let cos_theta = hit.shading_normal.dot(l);
    if cos_theta.value() <= 0.0 || hit.geometric_normal.value().dot(l.value()) <= 0.0 {
        return None;
    }
    if !visible(view.scene(), &hit.hit, l.value(), position.value(), stats) {
        return None;
    }
    let inverse_square = light.falloff == Falloff::InverseSquare;
    Some(Incidence {
        dir: l,
        cos_theta,
        arriving: shading::point_light_arriving(radiance, inverse_square, dist),
    })
}

/// Σ over the point lights `model` sees of arriving light × cos θ behind a
/// shadow ray: the light a Lambertian surface reflects, over its albedo
/// ([`shading::lambert_point_light`]).
#[inline]
pub fn lambert_point_lights<V: View, S: Stats>(
    view: &V,
    hit: &HitR<V::R>,
    model: LightModel,
    stats: &mut S,
) -> V3<V::R> {
    let mut sum = V3::zero();
    for (i, light) in view.scene().lights.iter().enumerate() {
        if !model.sees(light) {
            continue;
        }
        if let Some(inc) = point_light_incidence(view, hit, i, stats) {
            sum += shading::lambert_point_light(inc.arriving, inc.cos_theta);
        }
    }
    sum
}

/// One area-light sample's estimate of the light a Lambertian surface at
/// `hit` reflects, over its albedo: L_e·(cos θ/π)·w/p_ω behind a shadow
/// ray, with the power-heuristic MIS weight against cosine sampling when
/// `mis` (else weight 1: light sampling alone).
#[inline]
pub fn lambert_area_sample<V: View, S: Stats>(
    view: &V,
    hit: &HitR<V::R>,
    s: &AreaSampleR<V::R>,
    mis: bool,
    stats: &mut S,
) -> V3<V::R> {
    let geometric = hit.geometric_normal.value();
    let t = lambert_area_terms(hit.point, hit.shading_normal, geometric, s, mis);
    if !(t.lit && visible(view.scene(), &hit.hit, t.wi.value(), s.point.value(), stats)) {
        return V3::zero();
    }
    t.value
}

/// [`lambert_area_sample`] before its shadow ray, at a surface point
/// `point` with shading normal `n` and geometric normal `geometric`.
#[derive(Clone, Copy, Debug)]
pub struct AreaTerms<R> {
    /// Unit direction to the light point.
    pub wi: V3<R>,
    /// Whether the sample counts if the light point is visible: it lies in
    /// front of both normals, the light faces the point, and its density
    /// in solid angle is positive and finite.
    pub lit: bool,
    /// Its estimate when it counts and is visible.
    pub value: V3<R>,
}

/// The terms of [`lambert_area_sample`] (computed whether or not the
/// sample counts; `lit` says). The path tracer's lanes call it on every
/// lane at once.
#[inline(always)]
pub fn lambert_area_terms<R: Real>(
    point: V3<R>,
    n: V3<R>,
    geometric: Vec3,
    s: &AreaSampleR<R>,
    mis: bool,
) -> AreaTerms<R> {
    let to = s.point - point;
    let d2 = to.length_squared();
    let wi = to / d2.sqrt();
    let cos_x = n.dot(wi);
    let cos_l = s.normal.dot(wi).abs();
    let facing = cos_x.value() > 0.0 && geometric.dot(wi.value()) > 0.0 && cos_l.value() > 0.0;
    let pdf_light = shading::area_to_solid_angle(s.pdf_area, d2, cos_l);
    let p = pdf_light.value();
    let w = if mis {
        shading::power_heuristic(pdf_light, shading::cosine_pdf(cos_x))
    } else {
        R::one()
    };
    AreaTerms {
        wi,
        lit: facing && p > 0.0 && p.is_finite(),
        value: shading::lambert_light_sample(s.emission, cos_x, w, pdf_light),
    }
}

/// The direct light a surface at `p` with unit normal `n` receives, over
/// its albedo (a surface of albedo ρ re-emits ρ × it): the point lights of
/// [`LightModel::Physical`] plus the mean of `area_samples` light-only
/// area-light samples. This is how the flood-fill cache lights its wall
/// faces, whoever builds it. The samples' random numbers are keyed by the
/// point, so the result does not depend on the thread count.
pub fn surface_direct(scene: &Scene, p: Vec3, n: Vec3, area_samples: u32) -> Color {
    let hit = HitR::from(Hit::at_surface(p, n));
    let mut stats = NoStats;
    let mut sum: Color = lambert_point_lights(scene, &hit, LightModel::Physical, &mut stats).into();
    if area_samples > 0 && scene.area_lights.total_weight() > 0.0 {
        let key = p
            .to_array()
            .iter()
            .fold(0u64, |h, c| SplitMix64::mix(h ^ u64::from(c.to_bits())));
        let mut rng = SplitMix64(key);
        let mut area = Color::ZERO;
        for _ in 0..area_samples {
            let (sel, u, v) = (rng.next_f32(), rng.next_f32(), rng.next_f32());
            if let Some(s) = scene.area_lights.sample(sel, Vec2::new(u, v)) {
                let s = AreaSampleR::from(s);
                area += Color::from(lambert_area_sample(scene, &hit, &s, false, &mut stats));
            }
        }
        sum += area / area_samples as f32;
    }
    sum
}
