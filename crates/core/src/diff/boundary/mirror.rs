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
//! The two radiance evaluations at x ± ε are the integrator's own. A
//! sample counts only where M shows s at x ([`Mirror::shows`]: the camera
//! ray at x meets M first and the reflected ray reaches s, two rays):
//! elsewhere there is no edge at x, and the two evaluations would differ
//! by the image's smooth change over 2ε, a small bias summed along all of
//! a reflected curve that the mirror does not show (without the check,
//! the mirror test's mesh mirror failed on 5 % of its pixels).
//!
//! Coplanar mirrors (a quad's two triangles) are one mirror: sampled once
//! per triangle, a curve seen in both would be counted twice. Curves in
//! the mirror's own plane (its edges, shadows falling on it) are its own
//! image: they are sampled as seen directly, not again here.
//!
//! A mesh is a flat mirror when all its triangles lie in one plane and its
//! shading normals, if it has any, are that plane's (a quad read from a
//! file); otherwise its reflections are not covered. A curved mirror's
//! (a sphere, an ellipsoid), what is seen through glass, and chains of
//! bounces that include either are [`super::curved`]'s; a flat mirror
//! seen in a flat mirror is not covered.

use crate::diff::view::DualScene;
use crate::math::{max_abs, Dual, Ray, Real, Vec3, V3};
use crate::scene::{Scene, View};
use crate::shape::triangle::NO_MESH;
use crate::shape::{Hit, Shape, ShapeR, OFFSET_SCALE};
use crate::stats::NoStats;
use std::collections::HashMap;

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

    /// The mirror as the renderer's reflected rays see it near `q`, a
    /// point of its plane: a ray reflected at q starts ε = OFFSET_SCALE ·
    /// max(|q|∞, 1) off it on the side of `viewer` (the renderer's spawn
    /// rule), so it leaves as if reflected by the plane moved ε/2 towards
    /// that side. The edges a mirror shows sit there: at S1's scale ε is
    /// several times the boundary term's 10⁻³-pixel jump offset, and with
    /// the plane itself the two evaluations of a jump fell on the same side
    /// of the floor's reflections of silhouettes.
    pub fn as_traced(&self, q: Vec3, viewer: Vec3) -> Self {
        let n = self.normal.value();
        let side = if (viewer - q).dot(n) < 0.0 { -1.0 } else { 1.0 };
        let eps = OFFSET_SCALE * max_abs(q).max(1.0);
        Mirror {
            object: self.object,
            point: self.point + self.normal * R::from_f32(0.5 * side * eps),
            normal: self.normal,
        }
    }

    /// Whether `p` lies in the plane, to `f32` round-off of coordinates
    /// of `p`'s size.
    pub fn holds(&self, p: Vec3) -> bool {
        let d = (p - self.point.value()).dot(self.normal.value());
        d.abs() <= 1e-5 * p.abs().max_element().max(1.0)
    }
}

impl Mirror<f32> {
    /// Whether the mirror shows `target` at film point `(x, y)`: the
    /// camera ray there meets a reflecting surface in the mirror's plane
    /// first, `target` lies on the eye's side of it, and the reflected ray
    /// reaches the last hundredth of the way to `target` unhidden (the
    /// rest is where it grazes `target`'s own surface). Where it does not,
    /// the curve makes no edge at `(x, y)`, and a sample there would see
    /// only the image's smooth change over the two offsets of its
    /// radiance evaluations.
    pub fn shows(&self, scene: &Scene, (x, y): (f32, f32), target: Vec3) -> bool {
        let Some((ray, hit)) = self.meets(scene, (x, y)) else {
            return false;
        };
        let n = self.normal.value();
        let to = target - hit.point;
        if to.dot(n) * (ray.origin - hit.point).dot(n) <= 0.0 {
            return false;
        }
        let dist = to.length();
        let dir = to / dist;
        let start = hit.point + dir * (1e-4 * dist.max(1e-3));
        !scene.occluded(&Ray::new(start, dir), 0.99 * dist, &mut NoStats)
    }

    /// The camera ray through film point `(x, y)` and its hit, where it
    /// meets a reflecting surface in the mirror's plane first (one ray).
    pub fn meets(&self, scene: &Scene, (x, y): (f32, f32)) -> Option<(Ray, Hit)> {
        let ray = scene.camera_ray(x, y).value();
        let hit = scene.intersect(&ray, scene.settings.max_distance, &mut NoStats)?;
        let material = &scene.materials[scene.objects[hit.object as usize].material as usize];
        (self.holds(hit.point) && material.reflectivity > 0.0).then_some((ray, hit))
    }
}

/// The flat mirrors of the scene, coplanar ones once: the planes, lone
/// triangles and meshes whose material reflects, a mesh when all its
/// triangles lie in one plane and its shading normals (if it has any) are
/// that plane's.
pub fn mirrors<const K: usize>(view: &DualScene<'_, K>) -> Vec<Mirror<Dual<K>>> {
    let scene = view.scene();
    // Candidates as (object, primitives): one per plane or lone triangle,
    // one per mesh, in the order of their first primitive.
    let mut groups: Vec<(u32, Vec<u32>)> = Vec::new();
    let mut meshes: HashMap<u32, usize> = HashMap::new();
    for (prim, p) in scene.prims.iter().enumerate() {
        if view.material(p.object).reflectivity.value() <= 0.0 {
            continue;
        }
        let prim = prim as u32;
        match &p.shape {
            Shape::Plane(_) => groups.push((p.object, vec![prim])),
            Shape::Triangle(t) if t.mesh == NO_MESH => groups.push((p.object, vec![prim])),
            Shape::Triangle(t) => {
                let g = *meshes.entry(t.mesh).or_insert_with(|| {
                    groups.push((p.object, Vec::new()));
                    groups.len() - 1
                });
                groups[g].1.push(prim);
            }
            Shape::Sphere(_) | Shape::Ellipsoid(_) => {}
        }
    }
    let mut out: Vec<Mirror<Dual<K>>> = Vec::new();
    for (object, prims) in groups {
        let Some(m) = flat(view, object, &prims) else {
            continue;
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

/// The plane of `prims` (primitives of `object`) when they make one flat
/// mirror: a plane, or triangles in one plane (degenerate ones aside)
/// whose shading normals, where they have them, are the plane's.
fn flat<const K: usize>(
    view: &DualScene<'_, K>,
    object: u32,
    prims: &[u32],
) -> Option<Mirror<Dual<K>>> {
    let scene = view.scene();
    let mut mirror: Option<Mirror<Dual<K>>> = None;
    for &prim in prims {
        let [a, b, c] = match view.geometry(prim) {
            ShapeR::Plane { point, normal } => {
                return Some(Mirror {
                    object,
                    point,
                    normal,
                })
            }
            ShapeR::Triangle { p } => p,
            ShapeR::Sphere { .. } | ShapeR::Ellipsoid { .. } => return None,
        };
        let n = (b - a).cross(c - a);
        if n.value().length() == 0.0 {
            continue; // degenerate: reflects nothing
        }
        let m = *mirror.get_or_insert(Mirror {
            object,
            point: a,
            normal: n.normalize(),
        });
        if ![a, b, c].iter().all(|q| m.holds(q.value())) {
            return None;
        }
        if let Shape::Triangle(t) = &scene.prims[prim as usize].shape {
            if t.mesh != NO_MESH {
                let mesh = &scene.meshes[t.mesh as usize];
                let bent = |k: &u32| {
                    let s = mesh.normals[*k as usize].normalize_or_zero();
                    s.cross(m.normal.value()).length() > 1e-4
                };
                let corners = mesh.triangles[t.face as usize];
                if !mesh.normals.is_empty() && corners.iter().any(bent) {
                    return None;
                }
            }
        }
    }
    mirror
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
