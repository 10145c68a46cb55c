//! Named ray sets for validation, each aimed at a place where intersection
//! code goes wrong: random rays through the bounds, rays aimed at the
//! surface, from inside closed meshes and quadrics, camera rays, rays aimed
//! exactly at edges and vertices, and grazing rays. Every set is a pure
//! function of the geometry and a seed.

use raylab::camera::{Camera, CameraDesc};
use raylab::math::Aabb;
use raylab::math::{Ray, SplitMix64, Vec3};
use raylab::shape::{Primitive, Shape};
use std::collections::HashMap;

/// A named list of rays. Directions are not normalised unless the set says
/// so: t is in units of the direction, on both sides alike.
#[derive(Clone, Debug, PartialEq)]
pub struct RaySet {
    pub name: &'static str,
    pub rays: Vec<Ray>,
}

/// The triangles' connectivity, found by welding vertices with bit-equal
/// positions (so files that repeat a vertex per face are still seen as
/// connected).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Topology {
    /// Distinct vertex positions.
    pub vertices: Vec<Vec3>,
    /// Distinct edges (pairs of indices into `vertices`) and the number of
    /// triangles sharing each.
    pub edges: Vec<([u32; 2], u32)>,
}

impl Topology {
    /// The topology of the triangles among `prims` (other shapes ignored).
    pub fn of(prims: &[Primitive]) -> Self {
        let mut index: HashMap<[u32; 3], u32> = HashMap::new();
        let mut vertices = Vec::new();
        let mut edges: HashMap<[u32; 2], u32> = HashMap::new();
        for p in prims {
            let Shape::Triangle(t) = &p.shape else {
                continue;
            };
            let id = t.p.map(|v| {
                *index
                    .entry(v.to_array().map(f32::to_bits))
                    .or_insert_with(|| {
                        vertices.push(v);
                        vertices.len() as u32 - 1
                    })
            });
            for k in 0..3 {
                let (a, b) = (id[k], id[(k + 1) % 3]);
                *edges.entry([a.min(b), a.max(b)]).or_insert(0) += 1;
            }
        }
        let mut edges: Vec<_> = edges.into_iter().collect();
        // Hash-map order is not deterministic; ray sets must be.
        edges.sort_unstable();
        Self { vertices, edges }
    }

    /// Closed (watertight, 2-manifold at the edges): every edge is shared
    /// by exactly two triangles. An empty topology is not closed.
    pub fn is_closed(&self) -> bool {
        !self.edges.is_empty() && self.edges.iter().all(|&(_, n)| n == 2)
    }

    /// Edges with one triangle (the mesh's border) and with more than two.
    pub fn open_and_nonmanifold_edges(&self) -> (usize, usize) {
        let open = self.edges.iter().filter(|e| e.1 == 1).count();
        (open, self.edges.iter().filter(|e| e.1 > 2).count())
    }
}

/// What the ray generators need to know about the geometry.
pub struct Geometry<'a> {
    pub prims: &'a [Primitive],
    pub bounds: Aabb,
    pub topology: &'a Topology,
    /// The scene's camera, if it has one.
    pub camera: Option<&'a Camera>,
}

impl Geometry<'_> {
    fn radius(&self) -> f32 {
        0.5 * self.bounds.extent().length()
    }

    /// A point on the sphere around the bounds at twice their radius, so
    /// outside every primitive.
    fn outside(&self, rng: &mut SplitMix64) -> Vec3 {
        self.bounds.centre() + 2.0 * self.radius().max(f32::MIN_POSITIVE) * rng.unit_vector()
    }

    fn triangles(&self) -> Vec<u32> {
        self.kind_indices(|s| matches!(s, Shape::Triangle(_)))
    }

    fn quadrics(&self) -> Vec<u32> {
        self.kind_indices(|s| matches!(s, Shape::Sphere(_) | Shape::Ellipsoid(_)))
    }

    fn kind_indices(&self, keep: impl Fn(&Shape) -> bool) -> Vec<u32> {
        (0..self.prims.len() as u32)
            .filter(|&i| keep(&self.prims[i as usize].shape))
            .collect()
    }
}

/// A ray from `origin` towards `target`, its length scaled by a random
/// factor in [0.5, 2) so t is not always near 1.
fn towards(rng: &mut SplitMix64, origin: Vec3, target: Vec3) -> Ray {
    let scale = rng.range(0.5, 2.0);
    Ray::new(origin, scale * (target - origin))
}

/// A uniformly random point of a primitive's surface (triangles) or of its
/// interior (spheres, ellipsoids: a point of the unit ball mapped by the
/// shape's transform). A plane, which validation leaves out, gives its
/// anchor point.
pub fn point_on(rng: &mut SplitMix64, p: &Primitive) -> Vec3 {
    match &p.shape {
        Shape::Triangle(t) => {
            // Folding the unit square onto the triangle keeps it uniform.
            let (mut u, mut v) = (rng.next_f32(), rng.next_f32());
            if u + v > 1.0 {
                (u, v) = (1.0 - u, 1.0 - v);
            }
            (1.0 - u - v) * t.p[0] + u * t.p[1] + v * t.p[2]
        }
        Shape::Sphere(s) => s.centre + s.radius * rng.unit_vector() * rng.next_f32().cbrt(),
        Shape::Ellipsoid(e) => {
            e.centre + e.from_unit() * (rng.unit_vector() * rng.next_f32().cbrt())
        }
        Shape::Plane(p) => p.point,
    }
}

/// `n` rays from outside the bounds (see [`Geometry::outside`]) aimed at
/// the targets `pick` draws.
fn from_outside(
    g: &Geometry,
    n: usize,
    seed: u64,
    mut pick: impl FnMut(&mut SplitMix64) -> Vec3,
) -> Vec<Ray> {
    let mut rng = SplitMix64(seed);
    (0..n)
        .map(|_| {
            let target = pick(&mut rng);
            let o = g.outside(&mut rng);
            towards(&mut rng, o, target)
        })
        .collect()
}

/// Rays from outside the bounds through a uniform point of them.
pub fn random(g: &Geometry, n: usize, seed: u64) -> Vec<Ray> {
    from_outside(g, n, seed, |rng| rng.in_box(&g.bounds))
}

/// Rays from outside aimed at uniform points of random primitives (half)
/// and from a random point of the bounds to such points (half, so some
/// start inside closed shapes and between them).
pub fn surface(g: &Geometry, n: usize, seed: u64) -> Vec<Ray> {
    let mut rng = SplitMix64(seed);
    (0..n)
        .map(|i| {
            let o = if i % 2 == 0 {
                g.outside(&mut rng)
            } else {
                rng.in_box(&g.bounds)
            };
            let p = &g.prims[rng.below(g.prims.len())];
            let target = point_on(&mut rng, p);
            towards(&mut rng, o, target)
        })
        .collect()
}

/// Camera rays: the scene's camera, or one framing the bounds (60° view,
/// from a diagonal direction at the bounds' diameter, so the bounding
/// sphere fills the view), through a ⌈√n⌉² grid of pixels at random
/// positions inside each. Unit directions.
pub fn camera(g: &Geometry, n: usize, seed: u64) -> Vec<Ray> {
    let side = (n as f64).sqrt().ceil().max(1.0) as u32;
    let own;
    let cam = match g.camera {
        Some(c) => c,
        None => {
            let c = g.bounds.centre();
            let eye = c + 2.0 * g.radius().max(1e-3) * Vec3::new(0.6, 0.5, 0.8).normalize();
            let desc = CameraDesc {
                eye,
                look_at: c,
                up: Vec3::Y,
                fov: 60.0,
                near: 1.0,
                aspect: Some(1.0),
            };
            own = Camera::new(&desc, side, side)
                .expect("a camera from a diagonal direction to a distinct point is valid");
            &own
        }
    };
    let mut rng = SplitMix64(seed);
    let (w, h) = (cam.width as f32, cam.height as f32);
    (0..n as u32)
        .map(|k| {
            let (i, j) = (k % side, k / side);
            let x = (i as f32 + rng.next_f32()) / side as f32 * w;
            let y = (j as f32 + rng.next_f32()) / side as f32 * h;
            cam.generate_ray(x, y)
        })
        .collect()
}

/// Rays from outside aimed exactly (up to the rounding of one lerp) at a
/// point of a random edge of the mesh.
pub fn edges(g: &Geometry, n: usize, seed: u64) -> Vec<Ray> {
    let t = g.topology;
    if t.edges.is_empty() {
        return Vec::new();
    }
    from_outside(g, n, seed, |rng| {
        let ([a, b], _) = t.edges[rng.below(t.edges.len())];
        t.vertices[a as usize].lerp(t.vertices[b as usize], rng.next_f32())
    })
}

/// Rays from outside aimed exactly at a random vertex of the mesh.
pub fn vertices(g: &Geometry, n: usize, seed: u64) -> Vec<Ray> {
    let t = g.topology;
    if t.vertices.is_empty() {
        return Vec::new();
    }
    from_outside(g, n, seed, |rng| t.vertices[rng.below(t.vertices.len())])
}

/// Rays aimed at a uniform point of a random triangle, at an angle to its
/// plane uniform in (0, 2·`max_deg`) (so half of them lie beyond the
/// grazing angle `max_deg` the comparison uses), from a distance of the
/// bounds' radius.
pub fn grazing(g: &Geometry, n: usize, seed: u64, max_deg: f32) -> Vec<Ray> {
    let tris = g.triangles();
    if tris.is_empty() {
        return Vec::new();
    }
    let mut rng = SplitMix64(seed);
    (0..n)
        .map(|_| {
            let p = &g.prims[tris[rng.below(tris.len())] as usize];
            let Shape::Triangle(t) = &p.shape else {
                unreachable!("triangles only")
            };
            let normal = t.normal();
            let target = point_on(&mut rng, p);
            // A random direction in the plane, tilted by α towards either
            // side.
            let in_plane = normal.cross(rng.unit_vector()).normalize_or_zero();
            let alpha = rng.range(0.0, 2.0 * max_deg).to_radians();
            let side = if rng.next_u64() & 1 == 0 { 1.0 } else { -1.0 };
            let dir = alpha.cos() * in_plane + side * alpha.sin() * normal;
            let origin = target - g.radius().max(1e-3) * dir;
            towards(&mut rng, origin, target)
        })
        .filter(|r| r.dir != Vec3::ZERO && r.dir.is_finite())
        .collect()
}

/// Rays from a random point inside a random sphere or ellipsoid, in a
/// random unit direction.
pub fn inside_quadrics(g: &Geometry, n: usize, seed: u64) -> Vec<Ray> {
    let quads = g.quadrics();
    if quads.is_empty() {
        return Vec::new();
    }
    let mut rng = SplitMix64(seed);
    (0..n)
        .map(|_| {
            let p = &g.prims[quads[rng.below(quads.len())] as usize];
            let origin = point_on(&mut rng, p);
            Ray::new(origin, rng.unit_vector())
        })
        .collect()
}

/// Rays from inside a closed mesh, in random unit directions. Interior
/// origins: a ray from outside aimed at a random surface point enters the
/// mesh at its first hit and leaves at its second (the mesh is closed), so
/// the midpoint of the two lies inside. `first_hit` finds those two hits
/// (raylab's accelerator: it only chooses origins, the comparison itself
/// is made afterwards); a candidate whose ray misses is dropped, so the
/// set may hold fewer than `n` rays. Near-silhouette candidates could
/// miscount crossings and land outside; they are rare and still valid
/// test rays.
pub fn inside_mesh(
    g: &Geometry,
    n: usize,
    seed: u64,
    first_hit: impl Fn(&Ray) -> Option<f32> + Sync,
) -> Vec<Ray> {
    use rayon::prelude::*;
    if !g.topology.is_closed() {
        return Vec::new();
    }
    let tris = g.triangles();
    let push = 1e-5 * g.radius();
    (0..n as u64)
        .into_par_iter()
        .filter_map(|k| {
            let mut rng = SplitMix64(SplitMix64::mix(seed ^ k));
            let p = &g.prims[tris[rng.below(tris.len())] as usize];
            let o = g.outside(&mut rng);
            let target = point_on(&mut rng, p);
            let r = Ray::new(o, (target - o).normalize_or_zero());
            let t1 = first_hit(&r)?;
            let entry = r.at(t1) + push * r.dir;
            let t2 = first_hit(&Ray::new(entry, r.dir))?;
            Some(Ray::new(entry + 0.5 * t2 * r.dir, rng.unit_vector()))
        })
        .collect()
}
