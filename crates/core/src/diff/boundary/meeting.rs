//! The curves where two surfaces pass through each other: a sphere or an
//! ellipsoid through a plane, two spheres (circles and ellipses in closed
//! form, as functions of the parameters), across which what is seen jumps
//! from one surface to the other; and the band along them where the
//! renderer's own offset rays misbehave, beyond which their jump is
//! taken.

use super::curves::Curve;
use crate::math::{orthonormal_basis_r, Real, Vec3, M3, V3};
use crate::scene::Scene;
use crate::shape::{Shape, ShapeR, OFFSET_SCALE};

/// How far inside each other two surfaces must pass for their meeting
/// curve to count: its radius over the smaller radius involved. Below it
/// they touch (a contact, where the derivative is one-sided and the curve's
/// radius changes as the square root of the parameter, so its speed is
/// unbounded) and no curve is sampled.
pub const MEETING_MIN: f32 = 1e-3;

/// The circle where the sphere (`centre`, `radius`) passes through the
/// plane through `point` with unit normal `normal`; `None` where they do
/// not cross (or only touch, [`MEETING_MIN`]).
pub fn sphere_plane<R: Real>(
    centre: V3<R>,
    radius: R,
    point: V3<R>,
    normal: V3<R>,
) -> Option<Curve<R>> {
    let d = (centre - point).dot(normal);
    let rho2 = radius * radius - d * d;
    // NaN (a degenerate sphere) fails too.
    let crosses = rho2.value() > (MEETING_MIN * radius.value()).powi(2);
    if !crosses {
        return None;
    }
    let rho = rho2.sqrt();
    let (a, b) = orthonormal_basis_r(normal);
    Some(Curve::Ellipse {
        centre: centre - normal * d,
        a: a * rho,
        b: b * rho,
    })
}

/// The circle where two spheres pass through each other: in the plane
/// normal to the line of centres at distance (D² + r₁² − r₂²)/2D from the
/// first, D the distance between the centres; `None` where they do not
/// cross (one inside the other, apart, or touching).
pub fn sphere_sphere<R: Real>(c1: V3<R>, r1: R, c2: V3<R>, r2: R) -> Option<Curve<R>> {
    let axis = c2 - c1;
    let dist = axis.dot(axis).sqrt();
    let apart = dist.value() > 0.0;
    if !apart {
        return None;
    }
    let u = axis / dist;
    let along = (dist * dist + r1 * r1 - r2 * r2) / (dist * R::from_f32(2.0));
    let rho2 = r1 * r1 - along * along;
    let small = r1.value().min(r2.value());
    let crosses = rho2.value() > (MEETING_MIN * small).powi(2);
    if !crosses {
        return None;
    }
    let rho = rho2.sqrt();
    let (a, b) = orthonormal_basis_r(u);
    Some(Curve::Ellipse {
        centre: c1 + u * along,
        a: a * rho,
        b: b * rho,
    })
}

/// The ellipse where the ellipsoid {p : |to_unit·(p − centre)| = 1}
/// passes through a plane: the unit sphere's circle with the plane mapped
/// into its space (normal M⁻ᵀn, M = `to_unit`), mapped back.
pub fn ellipsoid_plane<R: Real>(
    centre: V3<R>,
    to_unit: &M3<R>,
    point: V3<R>,
    normal: V3<R>,
) -> Option<Curve<R>> {
    let back = to_unit.inverse()?;
    let n = back.transpose().mul_vec(normal);
    let len = n.dot(n).sqrt();
    let nonzero = len.value() > 0.0;
    if !nonzero {
        return None;
    }
    // The mapped plane: n̂·u = (n·(point − centre)) / |n|.
    let n = n / len;
    let offset = normal.dot(point - centre) / len;
    let unit = sphere_plane(V3::zero(), R::one(), n * offset, n)?;
    // An affine map takes the circle to an ellipse: centre and axes.
    let Curve::Ellipse { centre: c, a, b } = unit else {
        return None;
    };
    Some(Curve::Ellipse {
        centre: centre + back.mul_vec(c),
        a: back.mul_vec(a),
        b: back.mul_vec(b),
    })
}

/// The curve where two primitives of geometry `a` and `b` pass through
/// each other, where it is a conic in closed form: a sphere or an
/// ellipsoid through a plane, two spheres. Across it what is seen jumps
/// from one surface to the other, whichever side it is seen from, and it
/// moves with either. `None` for other pairs (an ellipsoid through a
/// sphere or another ellipsoid meets it in a quartic; triangles are not
/// handled) and where they do not cross.
pub fn meeting<R: Real>(a: &ShapeR<R>, b: &ShapeR<R>) -> Option<Curve<R>> {
    use ShapeR::{Ellipsoid, Plane, Sphere};
    match (a, b) {
        (Sphere { centre, radius }, Plane { point, normal })
        | (Plane { point, normal }, Sphere { centre, radius }) => {
            sphere_plane(*centre, *radius, *point, *normal)
        }
        (Ellipsoid { centre, to_unit }, Plane { point, normal })
        | (Plane { point, normal }, Ellipsoid { centre, to_unit }) => {
            ellipsoid_plane(*centre, to_unit, *point, *normal)
        }
        (
            Sphere {
                centre: c1,
                radius: r1,
            },
            Sphere {
                centre: c2,
                radius: r2,
            },
        ) => sphere_sphere(*c1, *r1, *c2, *r2),
        _ => None,
    }
}

/// How far from the curve where `a` and `b` meet, at its point `s`, the
/// renderer's own rays misbehave: rays leaving a hit start
/// δ = [`OFFSET_SCALE`]·max(1, max|s_i|) off its surface, and near the
/// curve that start lies inside the other surface (or under a plane)
/// wherever the two surfaces' normals are more than 90° apart
/// (cos φ = n_a·n_b < 0, as where a sphere sunk less than halfway
/// meets a floor): within δ·(−cos φ)/sin φ of the curve, along either
/// surface, shadow rays find the other surface and the point is dark.
/// That band moves with the curve, so the jump across the curve is the
/// one from beyond the band on one side to beyond it on the other: the
/// distance returned (1.5 times the band's width, 0 where there is none)
/// is where the jump must be taken. A plane's normal is taken on the side
/// of `viewpoint`. Close up on a sphere sunk into a floor, taken at the
/// usual 10⁻³ pixel the jump read the band's dark instead of the lit
/// sphere, and the image mean's derivative came out 241 standard errors
/// off (`crates/core/tests/boundary/`); at 512×512 pixels of the whole scene, 25 %
/// off.
pub fn meeting_band(a: &ShapeR<f32>, b: &ShapeR<f32>, s: Vec3, viewpoint: Vec3) -> f32 {
    let normal = |shape: &ShapeR<f32>| {
        let n = shape.outward_normal(V3::from_vec3(s)).value();
        match shape {
            ShapeR::Plane { .. } if n.dot(viewpoint - s) < 0.0 => -n,
            _ => n,
        }
    };
    let cos = normal(a).dot(normal(b));
    if cos >= 0.0 {
        return 0.0;
    }
    let sin = (1.0 - cos * cos).max(0.0).sqrt().max(1e-3);
    let delta = OFFSET_SCALE * s.abs().max_element().max(1.0);
    1.5 * delta * -cos / sin
}

/// The pairs of primitives of `scene` that can meet in a curve
/// [`meeting`] handles (a sphere or an ellipsoid with a plane, two
/// spheres) and do, at the scene's values: what the eye and path vertices
/// see jump across.
pub fn meeting_pairs(scene: &Scene) -> Vec<(u32, u32)> {
    let conic = |p: &crate::shape::Primitive| {
        matches!(
            p.shape,
            Shape::Sphere(_) | Shape::Ellipsoid(_) | Shape::Plane(_)
        )
    };
    let mut pairs = Vec::new();
    for (i, p) in scene.prims.iter().enumerate().filter(|(_, p)| conic(p)) {
        for (j, q) in scene.prims.iter().enumerate().skip(i + 1) {
            if !conic(q) {
                continue;
            }
            let (a, b) = (ShapeR::<f32>::of(p), ShapeR::<f32>::of(q));
            if meeting(&a, &b).is_some() {
                pairs.push((i as u32, j as u32));
            }
        }
    }
    pairs
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Dual;

    fn v(x: f32, y: f32, z: f32) -> V3<f32> {
        V3::new(x, y, z)
    }

    /// Every point of a meeting curve lies on both surfaces; surfaces that
    /// only touch, or do not meet, have none; and the curve moves as the
    /// closed form says: a sphere of radius r whose centre is d from a
    /// plane meets it in a circle of radius √(r² − d²), whose derivative
    /// by d is −d/√(r² − d²).
    #[test]
    fn meeting_curves_lie_on_both_surfaces() {
        let on_sphere = |p: V3<f32>, c: V3<f32>, r: f32| ((p - c).length() - r).abs() < 1e-5;
        let (point, normal) = (v(0.0, 0.2, 0.0), v(0.1, 1.0, -0.2).normalize());
        let plane = ShapeR::Plane { point, normal };
        let (c, r) = (v(0.3, 0.5, -0.1), 0.8);
        let sphere = ShapeR::Sphere {
            centre: c,
            radius: r,
        };
        let curve = meeting(&plane, &sphere).unwrap();
        let rot = M3::<f32>::rotation_xyz_degrees(v(20.0, -35.0, 50.0));
        let to_unit = M3::diagonal(v(1.0 / 0.9, 1.0 / 0.6, 1.0 / 0.5)).mul_mat(&rot.transpose());
        let ellipsoid = ShapeR::Ellipsoid { centre: c, to_unit };
        let oval = meeting(&ellipsoid, &plane).unwrap();
        let c2 = v(0.9, 0.7, 0.3);
        let pair = meeting(
            &sphere,
            &ShapeR::Sphere {
                centre: c2,
                radius: 0.5,
            },
        )
        .unwrap();
        for k in 0..16 {
            let t = k as f32 / 16.0;
            let p = curve.point(t);
            assert!(on_sphere(p, c, r) && (p - point).dot(normal).abs() < 1e-6);
            let p = oval.point(t);
            assert!((to_unit.mul_vec(p - c).length() - 1.0).abs() < 1e-5);
            assert!((p - point).dot(normal).abs() < 1e-6);
            let p = pair.point(t);
            assert!(on_sphere(p, c, r) && on_sphere(p, c2, 0.5), "{k}");
        }
        // Touching (the sphere resting on the plane) or apart: no curve.
        let resting = ShapeR::Sphere {
            centre: point + normal * 0.8,
            radius: 0.8,
        };
        assert!(meeting(&resting, &plane).is_none());
        let far = ShapeR::Sphere {
            centre: v(5.0, 5.0, 5.0),
            radius: 0.5,
        };
        assert!(meeting(&sphere, &far).is_none() && meeting(&far, &plane).is_none());
        // The radius's derivative by the centre's height.
        let y = Dual::<1>::variable(0.3, 0);
        let c = V3::new(Dual::from_f32(0.0), y, Dual::from_f32(0.0));
        let floor = (V3::<Dual<1>>::zero(), V3::from_vec3(Vec3::Y));
        let Curve::Ellipse { a, .. } =
            sphere_plane(c, Dual::from_f32(0.8), floor.0, floor.1).unwrap()
        else {
            unreachable!()
        };
        let rho = a.value().length();
        assert!((rho - (0.64f32 - 0.09).sqrt()).abs() < 1e-6);
        let drho = a.value().dot(Vec3::new(a.x.d[0], a.y.d[0], a.z.d[0])) / rho;
        assert!((drho - (-0.3 / rho)).abs() < 1e-5, "{drho}");
    }
}
