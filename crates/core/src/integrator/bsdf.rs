//! The BSDF at a path vertex: how the surface scatters light, as the path
//! tracer's estimator uses it ([`super::vertex`]). Its three operations are
//! what any BSDF is to the estimator: [`Bsdf::sample`] draws a direction to
//! continue the path, [`Bsdf::pdf`] is the density it draws with (the BSDF
//! half of the MIS pairs), and [`Bsdf::reflected`] evaluates it on a light
//! sample. Both of the estimator's loops, one sample at a time and the
//! 16-lane groups, call these, written once over [`Real`].
//!
//! Today every surface is Lambertian: f = ρ/π with ρ the material's albedo
//! ([`crate::material::MaterialR::lambert_albedo`]), directions drawn
//! cosine-weighted (p = cos θ/π), so a sample's weight f·cos θ/p is ρ.
//! Other BSDFs (conductors, dielectrics, microfacets) are for later work to
//! add here.

use crate::math::{cosine_hemisphere, orthonormal_basis_r, Color, Real, V3};
use crate::scene::View;
use crate::shading::cosine_pdf;
use crate::shape::HitR;
use glam::{Vec2, Vec3};

/// The BSDF at one surface point: Lambert's f = ρ/π.
#[derive(Clone, Copy, Debug)]
pub struct Bsdf<R> {
    /// The albedo ρ.
    pub albedo: V3<R>,
}

/// A direction drawn from a [`Bsdf`] (or the draw that would give a
/// known direction: [`Bsdf::sample_towards`]).
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample<R> {
    /// Unit direction the path continues in.
    pub wi: V3<R>,
    /// Its density in solid angle.
    pub pdf: R,
    /// f·cos θ/p: what the path's throughput is multiplied by when it goes
    /// this way ([`BsdfSample::throughput`]).
    pub weight: V3<R>,
    /// Whether the direction leaves below the surface, where the path ends
    /// instead ([`below`]).
    pub below: bool,
}

impl<R: Real> Bsdf<R> {
    /// The BSDF of the material at `hit`.
    #[inline(always)]
    pub fn of<V: View<R = R>>(view: &V, hit: &HitR<R>) -> Self {
        Self {
            albedo: view.material(hit.hit.object).lambert_albedo(hit.point),
        }
    }

    /// Whether it reflects any light (a path ends at a surface that does
    /// not).
    #[inline(always)]
    pub fn reflects(&self) -> bool {
        self.albedo.value() != Color::ZERO
    }

    /// The BSDF evaluated on a light sample: β × the light the surface
    /// reflects towards the path, given `white`, the light a white
    /// Lambertian surface (ρ = 1) would reflect there, which is the form
    /// [`crate::lighting`]'s estimates (and the flood-fill cache) deliver
    /// (L·(cos θ/π)·w/p for an area-light sample; point lights' π cancels
    /// in their convention). Lambert's f·cos θ = ρ·(cos θ/π) puts the
    /// colour ρ here: β·ρ·white.
    #[inline(always)]
    pub fn reflected(&self, beta: V3<R>, white: V3<R>) -> V3<R> {
        beta * self.albedo * white
    }

    /// The density with which [`Bsdf::sample`] draws a direction at angle
    /// θ to the shading normal: cos θ/π.
    #[inline(always)]
    pub fn pdf(&self, cos_theta: R) -> R {
        cosine_pdf(cos_theta)
    }

    /// A cosine-weighted direction for the two uniform numbers `u`, in the
    /// frame of the unit shading normal `n` (built from the normal, so for
    /// fixed numbers the direction turns with a parameter-dependent
    /// normal); `geometric` is the unit geometric normal. Its density is
    /// fixed by the local direction (cos θ is its z), its weight is ρ.
    #[inline(always)]
    pub fn sample(&self, n: V3<R>, geometric: Vec3, u: Vec2) -> BsdfSample<R> {
        let local = cosine_hemisphere(u);
        let (t, b) = orthonormal_basis_r(n);
        let l = |c: f32| R::from_f32(c);
        let wi = (t * l(local.x) + b * l(local.y) + n * l(local.z)).normalize();
        BsdfSample {
            wi,
            pdf: self.pdf(l(local.z)),
            weight: self.albedo,
            below: below(local.z, geometric, wi.value()),
        }
    }

    /// The sample of unit direction `wi` (the draw of [`Bsdf::sample`]
    /// that would give it), or `None` where `wi` leaves below the surface.
    #[inline]
    pub fn sample_towards(&self, n: V3<R>, geometric: Vec3, wi: V3<R>) -> Option<BsdfSample<R>> {
        let cos = n.dot(wi);
        if below(cos.value(), geometric, wi.value()) {
            return None;
        }
        Some(BsdfSample {
            wi,
            pdf: self.pdf(cos),
            weight: self.albedo,
            below: false,
        })
    }
}

impl<R: Real> BsdfSample<R> {
    /// The throughput `beta` of a path that goes this way.
    #[inline(always)]
    pub fn throughput(&self, beta: V3<R>) -> V3<R> {
        beta * self.weight
    }
}

/// Whether direction `wi`, at cosine `cos` to the shading normal, leaves
/// below the surface: not in front of the shading normal, or behind the
/// geometric normal `geometric` (which interpolated normals allow). A ray
/// there would start inside the object, so the path ends instead.
#[inline(always)]
pub fn below(cos: f32, geometric: Vec3, wi: Vec3) -> bool {
    cos <= 0.0 || geometric.dot(wi) <= 0.0
}
