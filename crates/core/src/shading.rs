//! The shading kernels: every local formula of the renderers, written once
//! as a small pure function over a [`Real`] scalar.
//!
//! The Whitted integrator, the path tracer (`direct`, `path:K`), the
//! flood-fill cache's wall light and the derivative code all call these;
//! the GPU shaders are the only other copies, and tests hold them to these.
//! Visibility (shadow rays) is not here: it needs the scene, and lives in
//! [`crate::lighting`], which decides *whether* a light is seen and then
//! calls these kernels for *how much*.
//!
//! Conventions: `n` is the unit shading normal on the side the ray came
//! from, `l` the unit direction towards the light, `view` the unit
//! direction towards the viewer (−ray direction); colours are linear RGB.

use crate::math::{Real, V3};

/// Mirror direction of `d` about the unit normal `n` (S2: P = 2(N·(−D))N +
/// D). `d` may have any length and the result keeps it.
// ANCHOR: reflect
#[inline(always)]
pub fn reflect<R: Real>(d: V3<R>, n: V3<R>) -> V3<R> {
    d + n * (R::from_f32(2.0) * n.dot(-d))
}
// ANCHOR_END: reflect

// ANCHOR: refract
/// Refracted direction by Snell's law (S2's formula). `i` points *away* from
/// the surface towards where the ray came from (I = −D, unit), `n` is the unit
/// normal on the incident side (n·i > 0), `eta = n1/n2`. Returns `None` on
/// total internal reflection, where the square root's argument is negative:
/// T = (η(N·I) − sqrt(1 − η²(1 − (N·I)²)))·N − η·I.
#[inline(always)]
pub fn refract<R: Real>(i: V3<R>, n: V3<R>, eta: R) -> Option<V3<R>> {
    let cos_i = n.dot(i);
    let one = R::one();
    let k = one - eta * eta * (one - cos_i * cos_i);
    if k.value() < 0.0 {
        None
    } else {
        Some(n * (eta * cos_i - k.sqrt()) - i * eta)
    }
}
// ANCHOR_END: refract

/// The Phong material's coefficients at one point, as the local model
/// needs them.
#[derive(Clone, Copy, Debug)]
pub struct Phong<R> {
    /// Diffuse coefficient k_d.
    pub diffuse: R,
    /// Specular coefficient k_s.
    pub specular: R,
    /// Phong exponent.
    pub shininess: R,
    /// Surface colour at the point (texture applied).
    pub albedo: V3<R>,
    /// Colour of the highlight.
    pub specular_color: V3<R>,
}

// ANCHOR: phong
/// Light reflected towards `view` from one point light whose light
/// arriving at the point is `e`, by Phong's local model (diffuse +
/// specular, with R the light direction mirrored about the normal, as in
/// S1/S2): e·(k_d·(n·l)·colour + k_s·max(0, R·V)^shininess·specular colour).
/// The caller has checked that the light is in front (n·l > 0) and visible.
#[inline(always)]
pub fn phong<R: Real>(m: &Phong<R>, n: V3<R>, l: V3<R>, view: V3<R>, e: V3<R>) -> V3<R> {
    let diffuse = m.diffuse * n.dot(l);
    let r = reflect(-l, n);
    let specular = m.specular * r.dot(view).max(R::zero()).pow(m.shininess);
    e * (m.albedo * diffuse + m.specular_color * specular)
}
// ANCHOR_END: phong

/// The Whitted integrator's constant term: emission plus the ambient light
/// reflected by k_a and the surface colour.
#[inline(always)]
pub fn emission_and_ambient<R: Real>(
    emission: V3<R>,
    ka: R,
    ambient: V3<R>,
    albedo: V3<R>,
) -> V3<R> {
    emission + ambient * ka * albedo
}

/// The light a point light of `radiance` (colour × intensity) delivers at
/// distance `d`: no falloff (S1/S2's classroom model) or the physical 1/d².
#[inline(always)]
pub fn point_light_arriving<R: Real>(radiance: V3<R>, inverse_square: bool, d: R) -> V3<R> {
    if inverse_square {
        radiance / (d * d)
    } else {
        radiance
    }
}

/// A Lambertian surface's reflected radiance over its albedo for one point
/// light: arriving light × cos θ. With raylab's point-light convention
/// I = π·c·i (see [`crate::integrator::path`]) the BRDF's 1/π cancels, so
/// this equals the Whitted integrator's diffuse term divided by k_d·colour.
#[inline(always)]
pub fn lambert_point_light<R: Real>(arriving: V3<R>, cos_theta: R) -> V3<R> {
    arriving * cos_theta
}

/// Solid-angle density of a point sampled on a surface with area density
/// `pdf_area`, seen at squared distance `d2` and angle cos θ′ = `cos_light`
/// to the surface's normal: p_ω = p_A·d²/|cos θ′|.
#[inline(always)]
pub fn area_to_solid_angle<R: Real>(pdf_area: R, d2: R, cos_light: R) -> R {
    pdf_area * d2 / cos_light
}

// ANCHOR: power_heuristic
/// Veach's power heuristic (β = 2) for one sample from each of two
/// strategies: the weight of the strategy with density `a`.
#[inline(always)]
pub fn power_heuristic<R: Real>(a: R, b: R) -> R {
    let (a2, b2) = (a * a, b * b);
    if (a2 + b2).value() > 0.0 {
        a2 / (a2 + b2)
    } else {
        R::zero()
    }
}
// ANCHOR_END: power_heuristic

/// One light sample's estimate of the light a Lambertian surface reflects,
/// over its albedo: L_e·(cos θ/π)·w / p_ω, the BRDF ρ/π times cos θ divided
/// by the sample's solid-angle density, weighted by its MIS weight `w`.
#[inline(always)]
pub fn lambert_light_sample<R: Real>(
    emission: V3<R>,
    cos_theta: R,
    weight: R,
    pdf_solid_angle: R,
) -> V3<R> {
    emission * (cos_theta * R::from_f32(std::f32::consts::FRAC_1_PI) * weight / pdf_solid_angle)
}

/// Density of a cosine-weighted direction at angle θ to the normal:
/// cos θ/π (the BRDF-sampling half of the path tracer's MIS pair).
#[inline(always)]
pub fn cosine_pdf<R: Real>(cos_theta: R) -> R {
    cos_theta * R::from_f32(std::f32::consts::FRAC_1_PI)
}
