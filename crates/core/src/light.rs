//! Lights. Point lights as in S1/S2: a position, a colour and an intensity;
//! shadows are hard (one shadow ray per light). Area lights are emissive
//! primitives, gathered once per scene into [`AreaLights`] so the path
//! tracer can sample them (next-event estimation).

use crate::math::{luminance, Color, Real, Vec3, V3};
use crate::shading::point_light_arriving;
use crate::shape::smooth::{triangle_normal, triangle_point};
use crate::shape::{Primitive, Shape, ShapeR, Triangle};
use glam::Vec2;

/// How a point light's irradiance falls off with distance d.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Falloff {
    /// No falloff: the sources' classroom model (S1/S2).
    #[default]
    None,
    /// Physical 1/d².
    InverseSquare,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointLight {
    pub position: Vec3,
    /// Colour × intensity.
    pub radiance: Color,
    pub falloff: Falloff,
    /// A stand-in for an area light in the Whitted integrator only: the
    /// path tracer skips it, since it samples the emissive surface itself
    /// (the Cornell box has both; counting both would double the light).
    pub whitted_only: bool,
}

impl PointLight {
    /// The light's contribution arriving at distance `d`.
    #[inline]
    pub fn arriving(&self, d: f32) -> Color {
        let inverse_square = self.falloff == Falloff::InverseSquare;
        point_light_arriving(V3::from(self.radiance), inverse_square, d).into()
    }
}

/// Emissive surfaces the path tracer samples for next-event estimation:
/// every triangle and sphere whose material has non-zero emission
/// (ellipsoids and planes still emit when a path hits them, but are not
/// sampled: an ellipsoid has no closed-form area, a plane is infinite).
///
/// Emitters are chosen in proportion to their power Φ ∝ lum(L_e)·A (two-
/// sided Lambertian emission: Φ = 2π·A·L_e for every emitter alike, so the
/// common factor drops out), then a point is chosen uniformly on the chosen
/// shape. The density of a point y with respect to area is then
/// p_A(y) = (lum(L_e)·A / W) · (1/A) = lum(L_e) / W, W = Σ lum(L_e,j)·A_j,
/// which does not depend on which emitter y lies on: [`AreaLights::pdf_area`]
/// needs only the emission seen at a hit.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AreaLights {
    /// The sampled emitters, in primitive order.
    pub emitters: Vec<Emitter>,
    /// Running sums of the emitters' weights lum(L_e)·A (last = W).
    cdf: Vec<f64>,
}

/// One sampled emitter: its primitive, shape and emitted radiance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Emitter {
    /// Index of the primitive in the scene.
    pub prim: u32,
    pub shape: EmitterShape,
    /// Emitted radiance L_e (the same in every direction, on both sides).
    pub emission: Color,
    /// The area density of a point sampled on it, lum(L_e)/W
    /// ([`AreaLights::pdf_area`] of its emission), stored once rather than
    /// divided at every sample.
    pdf_area: f32,
}

/// The geometry of an emitter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EmitterShape {
    /// A triangle and its unit normal, computed once
    /// ([`triangle_normal`]): light sampling would otherwise recompute it
    /// for every sample.
    Triangle(Triangle, Vec3),
    Sphere {
        centre: Vec3,
        radius: f32,
    },
}

impl Emitter {
    /// A sphere holding the emitter: (centre, radius); for a triangle its
    /// centroid and the farthest corner's distance.
    pub fn bounding_sphere(&self) -> (Vec3, f32) {
        match self.shape {
            EmitterShape::Triangle(t, _) => {
                let c = (t.p[0] + t.p[1] + t.p[2]) / 3.0;
                let r = t.p.iter().map(|&p| p.distance(c)).fold(0.0, f32::max);
                (c, r)
            }
            EmitterShape::Sphere { centre, radius } => (centre, radius),
        }
    }
}

impl EmitterShape {
    fn of(shape: &Shape) -> Option<Self> {
        match shape {
            Shape::Triangle(t) => Some(Self::Triangle(
                *t,
                triangle_normal(t.p.map(V3::from)).into(),
            )),
            Shape::Sphere(s) => Some(Self::Sphere {
                centre: s.centre,
                radius: s.radius,
            }),
            Shape::Ellipsoid(_) | Shape::Plane(_) => None,
        }
    }

    /// The same geometry over [`Real`] (the formulas live there).
    fn real(&self) -> ShapeR<f32> {
        match *self {
            Self::Triangle(t, _) => ShapeR::Triangle {
                p: t.p.map(V3::from),
            },
            Self::Sphere { centre, radius } => ShapeR::Sphere {
                centre: centre.into(),
                radius,
            },
        }
    }

    /// Surface area.
    pub fn area(&self) -> f32 {
        self.real().area()
    }

    /// A uniformly distributed point on the surface and the unit normal
    /// there, from two uniform numbers in [0, 1).
    pub fn sample(&self, u: Vec2) -> (Vec3, Vec3) {
        if let Self::Triangle(t, normal) = self {
            return (triangle_point(t.p.map(V3::from), u).into(), *normal);
        }
        let (p, n) = self.real().sample_point(u);
        (p.into(), n.into())
    }
}

/// A point sampled on an area light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AreaSample {
    /// The primitive the point lies on.
    pub prim: u32,
    /// The two numbers that placed the point on it.
    pub u: Vec2,
    pub point: Vec3,
    /// Unit surface normal at the point (either side: emission is two-sided).
    pub normal: Vec3,
    pub emission: Color,
    /// Density of the point with respect to surface area (see
    /// [`AreaLights`]).
    pub pdf_area: f32,
}

/// [`AreaSample`] over [`Real`]: the point, normal and area density move
/// with the emitter's parameters for the same random numbers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AreaSampleR<R> {
    pub point: V3<R>,
    pub normal: V3<R>,
    pub emission: V3<R>,
    pub pdf_area: R,
}

impl AreaSample {
    /// The sample as constants over [`Real`].
    #[inline(always)]
    pub fn real<R: Real>(&self) -> AreaSampleR<R> {
        AreaSampleR {
            point: V3::from_vec3(self.point),
            normal: V3::from_vec3(self.normal),
            emission: V3::from_vec3(self.emission),
            pdf_area: R::from_f32(self.pdf_area),
        }
    }
}

impl From<AreaSample> for AreaSampleR<f32> {
    #[inline(always)]
    fn from(s: AreaSample) -> Self {
        s.real()
    }
}

/// lum(L_e)/W: the area density of a point sampled on an emitter of
/// radiance `emission` among emitters of total weight W = `total` (the
/// choice by weight lum(L_e)·A, then uniform on its area A).
#[inline]
fn density(emission: Color, total: f64) -> f32 {
    (f64::from(luminance(emission)) / total) as f32
}

impl AreaLights {
    /// Collect the emitters among `prims`; `emission(object)` is the emitted
    /// radiance of an object's material.
    pub fn build(prims: &[Primitive], emission: impl Fn(u32) -> Color) -> Self {
        let mut lights = Self::default();
        let mut total = 0.0f64;
        for (i, prim) in prims.iter().enumerate() {
            let le = emission(prim.object);
            let Some(shape) = EmitterShape::of(&prim.shape) else {
                continue;
            };
            let weight = f64::from(luminance(le)) * f64::from(shape.area());
            if !(weight > 0.0 && weight.is_finite()) {
                continue;
            }
            total += weight;
            lights.cdf.push(total);
            lights.emitters.push(Emitter {
                prim: i as u32,
                shape,
                emission: le,
                pdf_area: 0.0,
            });
        }
        for e in &mut lights.emitters {
            e.pdf_area = density(e.emission, total);
        }
        lights
    }

    /// No emitter to sample.
    pub fn is_empty(&self) -> bool {
        self.emitters.is_empty()
    }

    /// W = Σ lum(L_e)·A over the emitters.
    pub fn total_weight(&self) -> f64 {
        self.cdf.last().copied().unwrap_or(0.0)
    }

    /// Pick an emitter with `u_select` ∈ [0, 1) and a point on it with `u`.
    /// `None` when there are no emitters.
    #[inline]
    pub fn sample(&self, u_select: f32, u: Vec2) -> Option<AreaSample> {
        let total = self.total_weight();
        if total <= 0.0 {
            return None;
        }
        let target = f64::from(u_select) * total;
        let i = self
            .cdf
            .partition_point(|&c| c <= target)
            .min(self.cdf.len() - 1);
        let e = &self.emitters[i];
        let (point, normal) = e.shape.sample(u);
        Some(AreaSample {
            prim: e.prim,
            u,
            point,
            normal,
            emission: e.emission,
            pdf_area: e.pdf_area,
        })
    }

    /// The area density with which [`AreaLights::sample`] picks a point on
    /// `prim` when that primitive emits `emission`: lum(L_e)/W for sampled
    /// shapes (triangles, spheres), 0 for shapes never sampled.
    #[inline]
    pub fn pdf_area(&self, prim: &Primitive, emission: Color) -> f32 {
        let total = self.total_weight();
        match prim.shape {
            Shape::Triangle(_) | Shape::Sphere(_) if total > 0.0 => density(emission, total),
            _ => 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::SplitMix64;
    use crate::shape::Sphere;

    /// A sampled point's area density is the one [`AreaLights::pdf_area`]
    /// gives its primitive's emission (MIS weighs both), bit for bit, and
    /// the densities integrate to one: Σ pdf·A over the emitters.
    #[test]
    fn sampled_density_is_the_queried_one() {
        let tri = |x: f32| {
            Shape::Triangle(Triangle::new(
                Vec3::new(x, 0.0, 0.0),
                Vec3::new(x + 1.0, 0.0, 0.0),
                Vec3::new(x, 2.0, 0.5),
            ))
        };
        let prims: Vec<Primitive> = [
            tri(0.0),
            Shape::Sphere(Sphere::new(Vec3::new(0.0, 5.0, 0.0), 0.7)),
            tri(3.0),
            tri(6.0),
        ]
        .into_iter()
        .zip(0..)
        .map(|(shape, object)| Primitive { shape, object })
        .collect();
        // Object 3 emits nothing: not an emitter.
        let emission = |o: u32| {
            [
                Color::new(3.0, 2.0, 1.0),
                Color::splat(0.5),
                Color::new(0.1, 7.0, 0.2),
                Color::ZERO,
            ][o as usize]
        };
        let lights = AreaLights::build(&prims, emission);
        assert_eq!(lights.emitters.len(), 3);
        let mut rng = SplitMix64(11);
        let mut seen = [false; 3];
        for _ in 0..2000 {
            let u = Vec2::new(rng.range(0.0, 1.0), rng.range(0.0, 1.0));
            let s = lights.sample(rng.range(0.0, 1.0), u).unwrap();
            let prim = &prims[s.prim as usize];
            assert_eq!(s.emission, emission(prim.object));
            let queried = lights.pdf_area(prim, s.emission);
            assert_eq!(s.pdf_area.to_bits(), queried.to_bits());
            seen[s.prim as usize] = true;
        }
        assert_eq!(seen, [true; 3]);
        let total: f64 = lights
            .emitters
            .iter()
            .map(|e| f64::from(e.pdf_area) * f64::from(e.shape.area()))
            .sum();
        assert!((total - 1.0).abs() < 1e-6, "{total}");
    }
}
