//! The hit of a *known* primitive as a smooth function of the ray and of
//! the primitive's geometry, over [`Real`].
//!
//! Traversal (the accelerators, in `f32`) decides *which* primitive a ray
//! hits. Given that primitive, the distance, point and normals of the hit
//! are closed-form functions of the ray's origin and direction and of the
//! shape's parameters; evaluated on dual numbers they carry the
//! derivatives of the hit with respect to the scene's parameters (the
//! *interior* derivative: the primitive is held fixed, so a change of which
//! surface the ray sees is not part of it). These are the same closed forms
//! the `f32` shapes use (the sphere's roots, the ellipsoid's map to the unit
//! sphere, the plane's ratio), except the triangle: its watertight test
//! decides the hit, and the hit's distance and barycentrics are then the
//! ratio of Möller–Trumbore's determinants, which the shear of the
//! watertight test does not let one differentiate.
//!
//! [`ShapeR::sample_point`] and [`ShapeR::area`] are the emitters' uniform
//! point sampling and area, used by the `f32` light sampler too.

use super::{Hit, Primitive, Shape, OFFSET_SCALE};
use crate::math::{max_abs, uniform_sphere, uniform_triangle, RayR, Real, Vec3, M3, V3};
use glam::Vec2;

/// A primitive's geometry over [`Real`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ShapeR<R> {
    Sphere {
        centre: V3<R>,
        radius: R,
    },
    /// `to_unit` = S⁻¹Rᵀ, as [`super::Ellipsoid`] stores it.
    Ellipsoid {
        centre: V3<R>,
        to_unit: M3<R>,
    },
    /// `normal` is unit length.
    Plane {
        point: V3<R>,
        normal: V3<R>,
    },
    Triangle {
        p: [V3<R>; 3],
    },
}

impl ShapeR<f32> {
    /// The primitive shape of this geometry, for the `f32` scene (a plane's
    /// normal is taken as the unit vector it already is).
    pub fn to_shape(&self) -> Shape {
        let v = Vec3::from;
        match *self {
            Self::Sphere { centre, radius } => Shape::Sphere(super::Sphere::new(v(centre), radius)),
            Self::Ellipsoid { centre, to_unit } => {
                Shape::Ellipsoid(super::Ellipsoid::from_to_unit(v(centre), to_unit.to_mat3()))
            }
            Self::Plane { point, normal } => Shape::Plane(super::Plane {
                point: v(point),
                normal: v(normal),
            }),
            Self::Triangle { p } => {
                Shape::Triangle(super::Triangle::new(v(p[0]), v(p[1]), v(p[2])))
            }
        }
    }
}

impl<R: Real> ShapeR<R> {
    /// The ellipsoid of centre `centre`, radii `radii` and rotation
    /// `rotate` (Euler angles in degrees, as the scene files give them).
    pub fn ellipsoid(centre: V3<R>, radii: V3<R>, rotate: V3<R>) -> Self {
        let rotation = M3::rotation_xyz_degrees(rotate);
        Self::Ellipsoid {
            centre,
            to_unit: super::ellipsoid::to_unit(radii, &rotation),
        }
    }

    /// The constant (derivative-free) geometry of `prim`.
    pub fn of(prim: &Primitive) -> Self {
        match &prim.shape {
            Shape::Sphere(s) => Self::Sphere {
                centre: V3::from_vec3(s.centre),
                radius: R::from_f32(s.radius),
            },
            Shape::Ellipsoid(e) => Self::Ellipsoid {
                centre: V3::from_vec3(e.centre),
                to_unit: M3::from_mat3(e.to_unit()),
            },
            Shape::Plane(p) => Self::Plane {
                point: V3::from_vec3(p.point),
                normal: V3::from_vec3(p.normal),
            },
            Shape::Triangle(t) => Self::Triangle {
                p: t.p.map(V3::from_vec3),
            },
        }
    }

    /// Surface area (spheres and triangles: the shapes lights sample).
    pub fn area(&self) -> R {
        match *self {
            Self::Triangle { p } => R::from_f32(0.5) * (p[1] - p[0]).cross(p[2] - p[0]).length(),
            Self::Sphere { radius, .. } => {
                R::from_f32(2.0 * std::f32::consts::TAU) * radius * radius
            }
            Self::Ellipsoid { .. } | Self::Plane { .. } => R::zero(),
        }
    }

    /// The point of a triangle or sphere that has the surface coordinates
    /// of `p` (a point on it, as a value): the barycentrics of `p` in the
    /// triangle, its direction from the sphere's centre. As a function of
    /// the parameters it is how a point painted on the surface moves (the
    /// material point that [`ShapeR::sample_point`] draws for fixed random
    /// numbers); `None` for the shapes lights do not sample, and for a
    /// degenerate triangle or sphere.
    pub fn material_point(&self, p: Vec3) -> Option<V3<R>> {
        match *self {
            Self::Triangle { p: [a, b, c] } => {
                let (e1, e2, d) = (b.value() - a.value(), c.value() - a.value(), p - a.value());
                let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
                let det = d11 * d22 - d12 * d12;
                if det.is_nan() || det <= 0.0 {
                    return None;
                }
                let (d1, d2) = (d.dot(e1), d.dot(e2));
                let u = (d22 * d1 - d12 * d2) / det;
                let v = (d11 * d2 - d12 * d1) / det;
                Some(a + (b - a) * R::from_f32(u) + (c - a) * R::from_f32(v))
            }
            Self::Sphere { centre, radius } => {
                let n = (p - centre.value()).try_normalize()?;
                Some(centre + V3::from_vec3(n) * radius)
            }
            Self::Ellipsoid { .. } | Self::Plane { .. } => None,
        }
    }

    /// A uniformly distributed point on a triangle or sphere and the unit
    /// normal there, from two uniform numbers: the point moves with the
    /// shape for fixed `u` (a reparameterisation of the uniform density).
    pub fn sample_point(&self, u: Vec2) -> (V3<R>, V3<R>) {
        match *self {
            Self::Triangle { p } => (triangle_point(p, u), triangle_normal(p)),
            Self::Sphere { centre, radius } => {
                let n = V3::from_vec3(uniform_sphere(u));
                (centre + n * radius, n)
            }
            Self::Ellipsoid { .. } | Self::Plane { .. } => {
                unreachable!("only triangles and spheres are sampled as lights")
            }
        }
    }

    /// The outward normal (unnormalised for none of the shapes: unit) at a
    /// point `p` on the surface, with the triangle's barycentrics `uv`.
    pub fn outward_normal(&self, p: V3<R>) -> V3<R> {
        match *self {
            Self::Sphere { centre, radius } => ((p - centre) / radius).normalize(),
            Self::Ellipsoid { centre, to_unit } => to_unit
                .transpose()
                .mul_vec(to_unit.mul_vec(p - centre))
                .normalize(),
            Self::Plane { normal, .. } => normal,
            Self::Triangle { p } => triangle_normal(p),
        }
    }

    /// Distance and barycentrics (u, v of vertices 1 and 2; zero for other
    /// shapes) of the hit `near` (the distance traversal found) along `ray`.
    fn distance(&self, ray: &RayR<R>, near: f32) -> (R, R, R) {
        let z = R::zero();
        match *self {
            Self::Sphere { centre, radius } => (sphere_root(centre, radius, ray, near), z, z),
            Self::Ellipsoid { centre, to_unit } => {
                let local = RayR::new(
                    to_unit.mul_vec(ray.origin - centre),
                    to_unit.mul_vec(ray.dir),
                );
                (sphere_root(V3::zero(), R::one(), &local, near), z, z)
            }
            Self::Plane { point, normal } => {
                (normal.dot(point - ray.origin) / normal.dot(ray.dir), z, z)
            }
            Self::Triangle { p: [a, b, c] } => {
                // Möller & Trumbore (1997): Cramer's rule on
                // o + t·d = a + u·(b − a) + v·(c − a).
                let (e1, e2) = (b - a, c - a);
                let pv = ray.dir.cross(e2);
                let inv = R::one() / e1.dot(pv);
                let tv = ray.origin - a;
                let qv = tv.cross(e1);
                (e2.dot(qv) * inv, tv.dot(pv) * inv, ray.dir.dot(qv) * inv)
            }
        }
    }
}

/// The root of |o + t·d − c|² = r² nearer to `near` (which root traversal
/// found: the entry from outside, the exit from inside), by the same stable
/// formula as [`super::Sphere::roots`].
fn sphere_root<R: Real>(centre: V3<R>, radius: R, ray: &RayR<R>, near: f32) -> R {
    let f = ray.origin - centre;
    let a = ray.dir.dot(ray.dir);
    let b = -f.dot(ray.dir);
    let c = f.dot(f) - radius * radius;
    let l = f + ray.dir * (b / a);
    // A grazing hit can round to a slightly negative discriminant here;
    // the tangent point is then the hit (the derivative there is infinite).
    let disc = (radius * radius - l.dot(l)).max(R::zero());
    let s = (a * disc).sqrt();
    let q = if b.value() >= 0.0 { b + s } else { b - s };
    if q.value() == 0.0 {
        return R::zero();
    }
    let (t0, t1) = (c / q, q / a);
    if (t0.value() - near).abs() <= (t1.value() - near).abs() {
        t0
    } else {
        t1
    }
}

/// A hit with its distance, point and normals as [`Real`]s. `hit` is the
/// `f32` record traversal produced: which primitive and object, which side,
/// and the point the shadow rays start from.
#[derive(Clone, Copy, Debug)]
pub struct HitR<R> {
    pub hit: Hit,
    pub t: R,
    pub point: V3<R>,
    /// Unit geometric normal on the side the ray came from.
    pub geometric_normal: V3<R>,
    /// Unit shading normal on the side the ray came from.
    pub shading_normal: V3<R>,
}

impl From<Hit> for HitR<f32> {
    #[inline(always)]
    fn from(hit: Hit) -> Self {
        Self {
            hit,
            t: hit.t,
            point: hit.point.into(),
            geometric_normal: hit.geometric_normal.into(),
            shading_normal: hit.shading_normal.into(),
        }
    }
}

impl<R: Real> HitR<R> {
    /// The hit of `shape` that traversal found (`hit`) along `ray`, as a
    /// function of both. `vertex_normals` are a mesh triangle's shading
    /// normals (interpolated with the hit's barycentrics, as
    /// [`crate::scene::Scene::hit_details`] does), `None` for flat shading.
    pub fn on(
        shape: &ShapeR<R>,
        vertex_normals: Option<[V3<R>; 3]>,
        ray: &RayR<R>,
        hit: Hit,
    ) -> Self {
        let (t, u, v) = shape.distance(ray, hit.t);
        let point = ray.at(t);
        let outward = shape.outward_normal(point);
        let mut shading = outward;
        if let Some([na, nb, nc]) = vertex_normals {
            let n = na * (R::one() - u - v) + nb * u + nc * v;
            if n.value().length() > 0.0 {
                let n = n.normalize();
                shading = if n.dot(outward).value() < 0.0 { -n } else { n };
            }
        }
        let sign = R::from_f32(if hit.front_face { 1.0 } else { -1.0 });
        Self {
            hit,
            t,
            point,
            geometric_normal: outward * sign,
            shading_normal: shading * sign,
        }
    }

    /// The origin of a ray leaving the hit in direction `dir`
    /// ([`Hit::spawn_origin`]'s rule: offset along the geometric normal to
    /// the side `dir` points to, by a constant ε).
    #[inline]
    pub fn spawn_origin(&self, dir: V3<R>) -> V3<R> {
        offset_origin(self.point, self.geometric_normal, dir)
    }

    /// The `f32` point.
    #[inline(always)]
    pub fn point_value(&self) -> Vec3 {
        self.point.value()
    }
}

/// The origin of a ray that leaves `point`, where the geometric normal is
/// `n`, in direction `dir`: the point moved by ε = [`OFFSET_SCALE`] ·
/// max(1, max|pᵢ|) along `n`, to the side `dir` points to. Every ray that
/// leaves a surface starts here ([`HitR::spawn_origin`], and the path
/// tracer's lanes).
#[inline(always)]
pub fn offset_origin<R: Real>(point: V3<R>, n: V3<R>, dir: V3<R>) -> V3<R> {
    let eps = R::from_f32(OFFSET_SCALE * max_abs(point.value()).max(1.0));
    if n.value().dot(dir.value()) >= 0.0 {
        point + n * eps
    } else {
        point - n * eps
    }
}

/// The point of triangle `p` that two uniform numbers `u` place, uniformly
/// in area ([`uniform_triangle`]'s barycentrics).
#[inline]
pub fn triangle_point<R: Real>([a, b, c]: [V3<R>; 3], u: Vec2) -> V3<R> {
    let (b1, b2) = uniform_triangle(u);
    a + (b - a) * R::from_f32(b1) + (c - a) * R::from_f32(b2)
}

/// The unit geometric normal (b − a) × (c − a) of triangle `p`
/// (counter-clockwise vertices face the viewer), zero where the cross
/// product's length or its reciprocal is not a positive finite number (a
/// degenerate triangle): glam's `normalize_or_zero`, over [`Real`]. Every
/// triangle normal in raylab is this one.
#[inline]
pub fn triangle_normal<R: Real>([a, b, c]: [V3<R>; 3]) -> V3<R> {
    let n = (b - a).cross(c - a);
    let rcp = R::one() / n.length();
    if rcp.value().is_finite() && rcp.value() > 0.0 {
        n * rcp
    } else {
        V3::zero()
    }
}
