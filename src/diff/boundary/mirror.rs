//! Edges seen in flat mirrors: what the Whitted integrator's reflected
//! rays find when the reflecting surface is a plane or a lone triangle.
//!
//! A camera ray that meets a flat mirror M continues as the ray from the
//! eye's mirror image e′ = R_M(e) through the same point, so what it finds
//! beyond M is what e′ sees, and every curve along which that changes (a
//! silhouette or crease seen from e′, a point light's shadow edge on a
//! receiver) appears on the film at the projection of its mirror image
//! R_M(s), R_M(p) = p − 2((p − q)·n)n for M's plane through q with unit
//! normal n. [`super::boundary_term`] samples those curves as it samples
//! what the eye sees directly, with the film position x = project(R_M(s))
//! on dual numbers, so x moves with the mirror as well as with the curve.
//! The two radiance evaluations at x ± ε are the integrator's own: where
//! the camera ray at x does not meet M (it misses it, or something hides
//! it), or the reflected ray does not reach s, both sides see the same
//! thing and the sample adds 0, so nothing has to be clipped to M.
//!
//! Coplanar mirrors (a quad's two triangles) are one mirror: sampled once
//! per triangle, a curve seen in both would be counted twice. Curves in
//! the mirror's own plane (its edges, shadows falling on it) are its own
//! image: they are sampled as seen directly, not again here.
//!
//! Not covered: a mirror of a mesh (only planes and `[[triangle]]`
//! entries, whose normals are flat, reflect as one plane), a curved
//! mirror, a second reflection, and what is seen through glass.

use crate::diff::view::DualScene;
use crate::math::{Dual, Real, Vec3, V3};
use crate::scene::View;
use crate::shape::triangle::NO_MESH;
use crate::shape::{Shape, ShapeR};

/// A flat reflecting surface: a point `point` of its plane and the
/// plane's unit normal.
#[derive(Clone, Copy, Debug)]
pub struct Mirror<R> {
    /// The scene object it belongs to (whose motion moves it).
    pub object: u32,
    pub point: V3<R>,
    pub normal: V3<R>,
}

impl<R: Real> Mirror<R> {
    /// The mirror image of point `p`.
    pub fn reflect(&self, p: V3<R>) -> V3<R> {
        let d = (p - self.point).dot(self.normal);
        p - self.normal * (d + d)
    }

    /// The same plane on another number type, derivatives dropped.
    pub fn value<S: Real>(&self) -> Mirror<S> {
        Mirror {
            object: self.object,
            point: V3::from_vec3(self.point.value()),
            normal: V3::from_vec3(self.normal.value()),
        }
    }

    /// Whether `p` lies in the plane, to `f32` round-off of coordinates
    /// of `p`'s size.
    pub fn holds(&self, p: Vec3) -> bool {
        let d = (p - self.point.value()).dot(self.normal.value());
        d.abs() <= 1e-5 * p.abs().max_element().max(1.0)
    }
}

/// The flat mirrors of the scene (planes and lone triangles whose material
/// reflects), coplanar ones once.
pub fn mirrors<const K: usize>(view: &DualScene<'_, K>) -> Vec<Mirror<Dual<K>>> {
    let scene = view.scene();
    let mut out: Vec<Mirror<Dual<K>>> = Vec::new();
    for (prim, p) in scene.prims.iter().enumerate() {
        let flat = match &p.shape {
            Shape::Plane(_) => true,
            Shape::Triangle(t) => t.mesh == NO_MESH,
            _ => false,
        };
        if !flat || view.material(p.object).reflectivity.value() <= 0.0 {
            continue;
        }
        let (point, normal) = match view.geometry(prim as u32) {
            ShapeR::Plane { point, normal } => (point, normal),
            ShapeR::Triangle { p: [a, b, c] } => {
                let n = (b - a).cross(c - a);
                if n.value().length() == 0.0 {
                    continue; // degenerate: reflects nothing
                }
                (a, n.normalize())
            }
            _ => continue,
        };
        let m = Mirror {
            object: p.object,
            point,
            normal,
        };
        let same = |o: &Mirror<Dual<K>>| {
            let (n, q) = (m.normal.value(), m.point.value());
            o.normal.value().cross(n).length() <= 1e-5 && o.holds(q)
        };
        if !out.iter().any(same) {
            out.push(m);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The mirror image is the point on the normal's line at the same
    /// distance on the other side; twice it is the point again; the
    /// plane's own points are their images.
    #[test]
    fn a_mirror_image_is_symmetric_about_the_plane() {
        let m = Mirror::<f32> {
            object: 0,
            point: V3::new(1.0, 2.0, -1.0),
            normal: V3::new(0.3, 0.9, -0.2).normalize(),
        };
        let p = V3::new(-0.7, 5.0, 2.5);
        let r = m.reflect(p);
        let (dp, dr) = ((p - m.point).dot(m.normal), (r - m.point).dot(m.normal));
        assert!((dp + dr).abs() < 1e-5 && dp.abs() > 1.0);
        assert!((r - p).cross(m.normal).value().length() < 1e-5);
        assert!((m.reflect(r) - p).value().length() < 1e-5);
        let q = m.point + V3::new(0.2, 0.1, 0.75).cross(m.normal);
        assert!(m.holds(q.value()) && !m.holds(p.value()));
        assert!((m.reflect(q) - q).value().length() < 1e-5);
    }
}
