//! The curves in 3-D along which what a viewpoint sees changes: the
//! silhouettes of spheres and ellipsoids (exact: circles and ellipses, not
//! tessellations), the silhouette and crease edges of triangle meshes,
//! planes' horizons and the curves where a sphere or an ellipsoid passes
//! through a plane or two spheres through each other, as functions of the
//! parameters ([`Real`]).

use crate::camera::Frame;
use crate::math::{orthonormal_basis_r, Real, Vec3, M3, V3};
use crate::scene::Scene;
use crate::shape::triangle::NO_MESH;
use crate::shape::{Shape, ShapeR};
use std::collections::HashMap;

/// A curve s(t), t ∈ [0, 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Curve<R> {
    /// centre + a·cos 2πt + b·sin 2πt.
    Ellipse { centre: V3<R>, a: V3<R>, b: V3<R> },
    /// p0 + t·(p1 − p0).
    Segment { p0: V3<R>, p1: V3<R> },
}

impl<R: Real> Curve<R> {
    /// The point at `t`.
    pub fn point(&self, t: R) -> V3<R> {
        match *self {
            Self::Ellipse { centre, a, b } => {
                let phi = t * R::from_f32(std::f32::consts::TAU);
                centre + a * phi.cos() + b * phi.sin()
            }
            Self::Segment { p0, p1 } => p0 + (p1 - p0) * t,
        }
    }

    /// The same curve with every point mapped by `f`.
    pub fn map<S: Real>(&self, f: impl Fn(V3<R>) -> V3<S>) -> Curve<S> {
        match *self {
            Self::Ellipse { centre, a, b } => Curve::Ellipse {
                centre: f(centre),
                a: f(a),
                b: f(b),
            },
            Self::Segment { p0, p1 } => Curve::Segment {
                p0: f(p0),
                p1: f(p1),
            },
        }
    }
}

/// The silhouette of the sphere (`centre`, `radius`) seen from `o`: the
/// circle of points p with (p − c)·(p − o) = 0, centred at
/// c + (r²/|d|²)·d with radius r·√(1 − r²/|d|²), d = o − c, in the plane
/// normal to d. `None` when `o` is not outside the sphere.
pub fn sphere_silhouette<R: Real>(centre: V3<R>, radius: R, o: V3<R>) -> Option<Curve<R>> {
    let d = o - centre;
    let (d2, r2) = (d.dot(d), radius * radius);
    if d2.value() <= r2.value() * (1.0 + 1e-5) {
        return None;
    }
    let k = r2 / d2;
    let rho = (r2 * (R::one() - k)).sqrt();
    let (a, b) = orthonormal_basis_r(d.normalize());
    Some(Curve::Ellipse {
        centre: centre + d * k,
        a: a * rho,
        b: b * rho,
    })
}

/// The silhouette of the ellipsoid {p : |to_unit·(p − centre)| = 1} seen
/// from `o`: the unit sphere's silhouette from the mapped viewpoint, mapped
/// back (an affine map keeps tangency).
pub fn ellipsoid_silhouette<R: Real>(centre: V3<R>, to_unit: &M3<R>, o: V3<R>) -> Option<Curve<R>> {
    let back = to_unit.inverse()?;
    let unit = sphere_silhouette(V3::zero(), R::one(), to_unit.mul_vec(o - centre))?;
    Some(match unit {
        Curve::Ellipse { centre: c, a, b } => Curve::Ellipse {
            centre: centre + back.mul_vec(c),
            a: back.mul_vec(a),
            b: back.mul_vec(b),
        },
        seg => seg,
    })
}

/// A mesh edge: its two end points as (primitive, corner) and the faces
/// (primitives) that share it: one for a border edge, two inside a
/// manifold mesh, more where the mesh is not manifold.
#[derive(Clone, Debug, PartialEq)]
pub struct Edge {
    pub ends: [(u32, usize); 2],
    pub faces: Vec<u32>,
    /// Whether the faces' shading is continuous across the edge (a mesh
    /// with vertex normals), so that only a change of side makes it a
    /// discontinuity.
    pub smooth: bool,
}

/// Every edge of every triangle of `scene`, with the faces sharing it:
/// mesh triangles by their vertex indices, lone triangles (`[[triangle]]`
/// entries) by their corners' positions. Two lone triangles that meet
/// along an edge (a wall's two halves, a wall and the ceiling) share it:
/// kept as two border edges, every jump across it would be sampled twice,
/// once per border, each sample seeing the whole jump.
pub fn mesh_edges(scene: &Scene) -> Vec<Edge> {
    /// What identifies an edge: a mesh and two vertex indices, or two
    /// corners' bits (−0 and +0 one key).
    #[derive(Hash, PartialEq, Eq)]
    enum Key {
        Index(u32, u32, u32),
        Position([[u32; 3]; 2]),
    }
    let bits = |p: Vec3| [p.x, p.y, p.z].map(|c| (c + 0.0).to_bits());
    let mut edges: Vec<Edge> = Vec::new();
    let mut index: HashMap<Key, usize> = HashMap::new();
    for (id, p) in scene.prims.iter().enumerate() {
        let Shape::Triangle(t) = &p.shape else {
            continue;
        };
        let id = id as u32;
        let smooth = t.mesh != NO_MESH && !scene.meshes[t.mesh as usize].normals.is_empty();
        for (i, j) in [(0, 1), (1, 2), (2, 0)] {
            let key = if t.mesh == NO_MESH {
                let (a, b) = (bits(t.p[i]), bits(t.p[j]));
                Key::Position([a.min(b), a.max(b)])
            } else {
                let v = scene.meshes[t.mesh as usize].triangles[t.face as usize];
                Key::Index(t.mesh, v[i].min(v[j]), v[i].max(v[j]))
            };
            match index.get(&key) {
                Some(&e) => edges[e].faces.push(id),
                None => {
                    index.insert(key, edges.len());
                    edges.push(Edge {
                        ends: [(id, i), (id, j)],
                        faces: vec![id],
                        smooth,
                    });
                }
            }
        }
    }
    edges
}

/// Which side of face `prim`'s plane `o` lies on (+1 the side its winding
/// faces, −1 the other, 0 in the plane), and its unit normal.
fn side(scene: &Scene, prim: u32, o: Vec3) -> (f32, Vec3) {
    let Shape::Triangle(t) = &scene.prims[prim as usize].shape else {
        unreachable!("mesh edges join triangles")
    };
    let n = t.normal();
    (n.dot(o - t.p[0]).signum(), n)
}

/// Whether `e` is a discontinuity of what `o` sees: a border or
/// non-manifold edge, a silhouette (its faces on opposite sides of `o`),
/// or, with `creases`, an edge between faces facing `o` the same way whose
/// shading differs: flat shading with normals more than 10⁻³ rad apart,
/// or two materials.
pub fn edge_matters(scene: &Scene, e: &Edge, o: Vec3, creases: bool) -> bool {
    if e.faces.len() != 2 {
        return true;
    }
    let (s0, n0) = side(scene, e.faces[0], o);
    let (s1, n1) = side(scene, e.faces[1], o);
    if s0 != s1 {
        return true;
    }
    let material = |f: u32| scene.objects[scene.prims[f as usize].object as usize].material;
    creases
        && ((!e.smooth && n0.cross(n1).length() > 1e-3)
            || material(e.faces[0]) != material(e.faces[1]))
}

/// Edge `e`'s segment, its end points taken from `point(prim, corner)`.
pub fn edge_curve<R: Real>(e: &Edge, point: impl Fn(u32, usize) -> V3<R>) -> Curve<R> {
    Curve::Segment {
        p0: point(e.ends[0].0, e.ends[0].1),
        p1: point(e.ends[1].0, e.ends[1].1),
    }
}

/// The silhouette of a smooth primitive (sphere or ellipsoid) of geometry
/// `shape` seen from `o`; `None` for other shapes or a viewpoint inside.
pub fn smooth_silhouette<R: Real>(shape: &ShapeR<R>, o: V3<R>) -> Option<Curve<R>> {
    match shape {
        ShapeR::Sphere { centre, radius } => sphere_silhouette(*centre, *radius, o),
        ShapeR::Ellipsoid { centre, to_unit } => ellipsoid_silhouette(*centre, to_unit, o),
        _ => None,
    }
}

/// The horizon of a plane with unit normal `normal` seen by the camera
/// `frame`: the film line of the directions parallel to the plane (where
/// the plane, infinitely far, meets what lies beyond it). As a curve in
/// 3-D it is the segment e + a + λ·b, λ ∈ [−L, L], with e the eye, a the
/// view direction's part in the plane (unit) and b = normal × a: every
/// point of it lies in the direction e + (a direction parallel to the
/// plane), and L is long enough for the segment's image to cross the
/// whole film. Its motion is that of the camera's turning and the plane's
/// tilt, not of the eye's or the plane's translation. `None` when the
/// camera looks along the normal (the horizon is at the film's infinity).
pub fn horizon<R: Real>(frame: &Frame<R>, normal: V3<R>) -> Option<Curve<R>> {
    let forward = -frame.n;
    let along = forward - normal * forward.dot(normal);
    let depth = along.value().length();
    if depth < 1e-3 {
        return None;
    }
    let a = along.normalize();
    let b = normal.cross(a);
    // The segment's image runs through the film, near·λ/depth from the
    // image of e + a, itself at most as far from the centre as a corner
    // is when the horizon is on the film at all.
    let corner = frame.half_width.value().hypot(frame.half_height.value());
    let reach = R::from_f32(4.0 * corner / frame.near.value() * depth + 1.0);
    Some(Curve::Segment {
        p0: frame.eye + a - b * reach,
        p1: frame.eye + a + b * reach,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Dual;

    fn v(x: f32, y: f32, z: f32) -> V3<f32> {
        V3::new(x, y, z)
    }

    /// The horizon's points all lie in directions parallel to the plane,
    /// and its image crosses the film as a straight line from border to
    /// border where the horizon is in view: at the film height a ray
    /// parallel to the plane takes.
    #[test]
    fn a_horizon_is_the_film_line_of_directions_parallel_to_the_plane() {
        let (w, h) = (40, 30);
        let eye = v(0.3, 1.5, 6.0);
        let frame = Frame::new(
            eye,
            v(0.0, 1.0, 0.0),
            v(0.0, 1.0, 0.0),
            40.0,
            4.0 / 3.0,
            1.0,
        )
        .unwrap();
        let normal = v(0.05, 1.0, 0.1).normalize();
        let curve = horizon(&frame, normal).unwrap();
        let mut xs = Vec::new();
        for i in 0..=100 {
            let s = curve.point(i as f32 / 100.0);
            assert!((s - eye).dot(normal).abs() < 1e-5, "{i}");
            if let Some((x, y)) = frame.project(s, w, h) {
                xs.push(x);
                // A ray through (x, y) is parallel to the plane.
                let ray = frame.ray(x, y, w, h);
                assert!(
                    ray.dir.dot(normal).abs() < 1e-4,
                    "{i}: {}",
                    ray.dir.dot(normal)
                );
            }
        }
        let (lo, hi) = xs
            .iter()
            .fold((f32::MAX, f32::MIN), |(a, b), &x| (a.min(x), b.max(x)));
        assert!(lo < 0.0 && hi > w as f32, "{lo} {hi}");
        // Looking straight down the normal, the horizon is at infinity.
        let down = Frame::new(
            eye,
            eye - v(0.0, 5.0, 0.0),
            v(0.0, 0.0, 1.0),
            40.0,
            1.0,
            1.0,
        )
        .unwrap();
        assert!(horizon(&down, v(0.0, 1.0, 0.0)).is_none());
    }

    #[test]
    fn sphere_silhouette_points_are_tangent_to_the_view() {
        let (c, r, o) = (v(0.5, -1.0, 2.0), 1.3, v(4.0, 2.0, -3.0));
        let curve = sphere_silhouette(c, r, o).unwrap();
        for k in 0..16 {
            let p = curve.point(k as f32 / 16.0);
            assert!(((p - c).length() - r).abs() < 1e-5);
            assert!((p - c).dot(p - o).abs() < 1e-4);
        }
        assert!(sphere_silhouette(c, r, v(0.6, -1.0, 2.0)).is_none());
    }

    #[test]
    fn ellipsoid_silhouette_points_are_tangent_to_the_view() {
        let centre = v(0.2, 0.3, -0.1);
        let rot = M3::<f32>::rotation_xyz_degrees(v(20.0, -35.0, 50.0));
        let scale = M3::diagonal(v(1.0 / 2.0, 1.0 / 0.7, 1.0 / 1.2));
        let to_unit = scale.mul_mat(&rot.transpose());
        let o = v(3.0, 4.0, 5.0);
        let curve = ellipsoid_silhouette(centre, &to_unit, o).unwrap();
        for k in 0..16 {
            let p = curve.point(k as f32 / 16.0);
            let u = to_unit.mul_vec(p - centre);
            assert!((u.length() - 1.0).abs() < 1e-5);
            // The normal there (∝ Mᵀ·u) is perpendicular to the view.
            let n = to_unit.transpose().mul_vec(u);
            assert!(n.normalize().dot((p - o).normalize()).abs() < 1e-4);
        }
    }

    #[test]
    fn silhouette_moves_with_the_sphere() {
        // Moving the centre by δ along x moves the silhouette circle's
        // centre by about δ (the view is along z, far away).
        let c = V3::new(
            Dual::<1>::variable(0.0, 0),
            Dual::from_f32(0.0),
            Dual::from_f32(0.0),
        );
        let o = V3::new(
            Dual::from_f32(0.0),
            Dual::from_f32(0.0),
            Dual::from_f32(1e3),
        );
        let Curve::Ellipse { centre, .. } = sphere_silhouette(c, Dual::from_f32(1.0), o).unwrap()
        else {
            unreachable!()
        };
        assert!((centre.x.d[0] - 1.0).abs() < 1e-5);
    }

    #[test]
    fn inverse_undoes_the_matrix() {
        let m = M3::<f32>::rotation_xyz_degrees(v(10.0, 70.0, -30.0))
            .mul_mat(&M3::diagonal(v(2.0, 0.5, 3.0)));
        let i = m.inverse().unwrap().mul_mat(&m);
        for r in 0..3 {
            for c in 0..3 {
                let want = if r == c { 1.0 } else { 0.0 };
                assert!((i.rows[r].get(c) - want).abs() < 1e-5);
            }
        }
        assert!(M3::diagonal(v(1.0, 0.0, 1.0)).inverse().is_none());
    }

    /// Lone triangles that meet share their edge (the Cornell box's walls
    /// had each crease twice, once per border, and each border's samples
    /// saw the whole jump: camera derivatives along the ceiling's creases
    /// came out about twice the boundary term). Seen from the eye, an edge
    /// between two materials in one plane is a crease, one inside a
    /// material is none; −0 and +0 are one corner.
    #[test]
    fn lone_triangles_that_meet_share_their_edges() {
        let text = r#"
[image]
width = 8
height = 8
[camera]
eye = [0.5, 0.5, 5.0]
look_at = [0.5, 0.5, 0.0]
fov = 40.0
[materials.a]
color = [1.0, 1.0, 1.0]
[materials.b]
color = [0.5, 0.5, 0.5]
[[triangle]]
vertices = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]]
material = "a"
[[triangle]]
vertices = [[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]]
material = "a"
[[triangle]]
vertices = [[-0.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.5, 2.0, 0.0]]
material = "b"
"#;
        let overrides = crate::io::scene_file::Overrides::default();
        let scene =
            crate::io::scene_file::parse_scene(text, std::path::Path::new("t.toml"), &overrides)
                .unwrap();
        let edges = mesh_edges(&scene);
        assert_eq!(edges.len(), 7, "{edges:?}");
        let shared: Vec<&Edge> = edges.iter().filter(|e| e.faces.len() == 2).collect();
        assert_eq!(shared.len(), 2);
        let eye = Vec3::new(0.5, 0.5, 5.0);
        let matters: Vec<bool> = shared
            .iter()
            .map(|e| edge_matters(&scene, e, eye, true))
            .collect();
        // The diagonal (faces 0 and 1, one material) and the a–b edge.
        assert_eq!(shared[0].faces, vec![0, 1]);
        assert_eq!(matters, vec![false, true]);
        assert!(!edge_matters(&scene, shared[1], eye, false));
    }
}
