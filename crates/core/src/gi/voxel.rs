//! Voxelisation of a [`Scene`] into a regular grid of cubic voxels: the
//! geometry the flood-fill cache ([`super::floodfill`]) propagates light
//! through.
//!
//! A voxel is **opaque** when any surface of the scene overlaps its closed
//! box, or when it overlaps the inside of a solid (sphere, ellipsoid).
//! Surfaces are triangles (and so meshes) and infinite planes clipped to the
//! grid. The overlap tests are exact where they are cheap:
//!
//! - triangle–box: the separating-axis theorem with the 13 axes of
//!   Akenine-Möller, "Fast 3D Triangle-Box Overlap Testing" (JGT 2001): the
//!   three box normals, the triangle normal, and the nine cross products of
//!   box and triangle edges;
//! - sphere–box: the squared distance from the centre to the box
//!   (Arvo, Graphics Gems I, "A simple method for box-sphere intersection
//!   testing") against r²;
//! - plane–box: the box's projected half-width on the normal,
//!   h·(|n_x|+|n_y|+|n_z|), against the distance of its centre;
//! - ellipsoid–box: min over the box of the quadratic form
//!   q(p) = |T(p − c)|² (T maps the ellipsoid to the unit sphere) against 1.
//!   q is convex, so cyclic coordinate descent (each 1-D step an exact
//!   clamped minimiser) converges to the minimum; it stops as soon as a
//!   point with q ≤ 1 is found (overlap certain) and otherwise after
//!   [`ELLIPSOID_SWEEPS`] sweeps. For strongly elongated, rotated
//!   ellipsoids the descent may not have reached the minimum by then, so a
//!   voxel touched only by a sliver thinner than about 1 % of a voxel can
//!   be missed.
//!
//! Touching counts as overlap (closed boxes), so a surface lying exactly on
//! a voxel face makes both voxels opaque: walls are never thinner than one
//! voxel and never leak for that reason.
//!
//! An opaque voxel carries the mean **albedo** (material k_d × colour) of
//! the primitives overlapping it; it is **emissive** when one of them has
//! a non-zero emission, and then carries the mean emission of those. Every
//! other voxel is **empty** (air).

use super::GiError;
use crate::material::Material;
use crate::math::Aabb;
use crate::math::{Color, Vec3};
use crate::scene::Scene;
use crate::shape::{Ellipsoid, Plane, Shape, Sphere, Triangle};
use ndarray::Array3;

/// Coordinate-descent sweeps of the ellipsoid–box test (see module docs).
pub const ELLIPSOID_SWEEPS: usize = 24;

/// Largest resolution accepted (voxels along the longest axis): 1024³
/// voxels of the flood fill's two buffers would already need 24 GiB.
pub const MAX_RESOLUTION: usize = 1024;

/// The bytes a voxel of a flood-fill cache takes while the cache is built,
/// its dense arrays counted (the walls' terms come on top, one per face
/// between a wall and air): the grid's kind, albedo and emission and the
/// two sample counts of voxelisation, then the flood fill's open flag,
/// gain and two RGB irradiance buffers over the grid padded by one voxel.
pub const BYTES_PER_VOXEL: u128 = (size_of::<VoxelKind>()
    + 2 * size_of::<Color>()
    + 2 * size_of::<u32>()
    + size_of::<bool>()
    + size_of::<f32>()
    + 2 * 3 * size_of::<f32>()) as u128;

/// Refuse a grid of `dims` voxels that this machine cannot hold, before
/// any of it is allocated.
fn check_memory(dims: [usize; 3], resolution: usize) -> Result<(), GiError> {
    let padded: u128 = dims.iter().map(|&d| d as u128 + 2).product();
    crate::film::memory::check(
        || {
            format!(
                "a flood-fill cache of {}×{}×{} voxels (res={resolution})",
                dims[0], dims[1], dims[2]
            )
        },
        padded * BYTES_PER_VOXEL,
    )?;
    Ok(())
}

/// What a voxel holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum VoxelKind {
    /// Air: light propagates through it and is stored in it.
    #[default]
    Empty,
    /// Overlapped by a surface or a solid that does not emit.
    Opaque,
    /// Overlapped by an emitting surface: opaque, and a constant source.
    Emissive,
}

impl VoxelKind {
    /// Opaque or emissive: light neither passes through nor is stored.
    #[inline]
    pub fn is_solid(self) -> bool {
        self != VoxelKind::Empty
    }
}

/// Where the grid lies and how fine it is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridSpec {
    /// Voxels along the longest axis of the box; the voxels are cubes, so
    /// the other axes get ⌈extent / voxel size⌉ voxels.
    pub resolution: usize,
    /// The box to voxelise; `None`: the bounds of the scene's bounded
    /// primitives (planes are clipped to it).
    pub bounds: Option<Aabb>,
}

impl GridSpec {
    /// A grid of `resolution` voxels along the longest axis of the scene.
    pub fn new(resolution: usize) -> Self {
        Self {
            resolution,
            bounds: None,
        }
    }
}

/// A voxelised scene: voxel kinds, albedos and emissions on an
/// `nx × ny × nz` grid of cubes of side `voxel_size` whose corner is
/// `origin`. Arrays are indexed `[[x, y, z]]`.
#[derive(Clone, Debug)]
pub struct VoxelGrid {
    /// The minimum corner of voxel (0, 0, 0).
    pub origin: Vec3,
    /// Side of a voxel.
    pub voxel_size: f32,
    pub kind: Array3<VoxelKind>,
    /// Mean k_d × colour of the primitives overlapping the voxel (zero for
    /// empty voxels).
    pub albedo: Array3<Color>,
    /// Mean emission of the emitting primitives overlapping the voxel (zero
    /// unless emissive).
    pub emission: Array3<Color>,
}

impl VoxelGrid {
    /// An all-empty grid of `dims` cubes of side `voxel_size`, for building
    /// test set-ups by hand.
    pub fn empty(origin: Vec3, voxel_size: f32, dims: [usize; 3]) -> Self {
        Self {
            origin,
            voxel_size,
            kind: Array3::default(dims),
            albedo: Array3::from_elem(dims, Color::ZERO),
            emission: Array3::from_elem(dims, Color::ZERO),
        }
    }

    /// Voxelise `scene` (see the module docs for what counts as opaque).
    /// Fails when the resolution is 0 or above [`MAX_RESOLUTION`], or when
    /// there is no box (no bounded primitive and no `spec.bounds`).
    pub fn from_scene(scene: &Scene, spec: &GridSpec) -> Result<Self, GiError> {
        if spec.resolution == 0 || spec.resolution > MAX_RESOLUTION {
            return Err(GiError::Resolution {
                given: spec.resolution,
                max: MAX_RESOLUTION,
            });
        }
        let b = spec.bounds.unwrap_or_else(|| scene.bounds());
        if b.is_empty() || !b.min.is_finite() || !b.max.is_finite() {
            return Err(GiError::NoBounds);
        }
        let ext = b.extent();
        let longest = ext.max_element();
        if longest <= 0.0 {
            return Err(GiError::EmptyBox);
        }
        let voxel_size = longest / spec.resolution as f32;
        let n = |e: f32| ((e / voxel_size).ceil() as usize).clamp(1, spec.resolution);
        let dims = [n(ext.x), n(ext.y), n(ext.z)];
        check_memory(dims, spec.resolution)?;
        let mut grid = Self::empty(b.min, voxel_size, dims);
        let mut albedo_count = Array3::<u32>::zeros(dims);
        let mut emission_count = Array3::<u32>::zeros(dims);
        for prim in &scene.prims {
            let m: &Material =
                &scene.materials[scene.objects[prim.object as usize].material as usize];
            let albedo = m.diffuse * m.color;
            let emits = m.emission.max_element() > 0.0;
            let range = match prim.bounds() {
                Some(pb) => grid.voxel_range(&pb),
                None => Some(([0, 0, 0], dims)),
            };
            let Some((lo, hi)) = range else { continue };
            for x in lo[0]..hi[0] {
                for y in lo[1]..hi[1] {
                    for z in lo[2]..hi[2] {
                        let (bmin, bmax) = grid.voxel_box([x, y, z]);
                        let hit = match &prim.shape {
                            Shape::Triangle(t) => triangle_overlaps_box(t, bmin, bmax),
                            Shape::Sphere(s) => sphere_overlaps_box(s, bmin, bmax),
                            Shape::Plane(p) => plane_overlaps_box(p, bmin, bmax),
                            Shape::Ellipsoid(e) => ellipsoid_overlaps_box(e, bmin, bmax),
                        };
                        if !hit {
                            continue;
                        }
                        let i = [x, y, z];
                        grid.albedo[i] += albedo;
                        albedo_count[i] += 1;
                        if emits {
                            grid.emission[i] += m.emission;
                            emission_count[i] += 1;
                            grid.kind[i] = VoxelKind::Emissive;
                        } else if grid.kind[i] == VoxelKind::Empty {
                            grid.kind[i] = VoxelKind::Opaque;
                        }
                    }
                }
            }
        }
        ndarray::Zip::from(&mut grid.albedo)
            .and(&albedo_count)
            .for_each(|a, &c| *a /= c.max(1) as f32);
        ndarray::Zip::from(&mut grid.emission)
            .and(&emission_count)
            .for_each(|e, &c| *e /= c.max(1) as f32);
        Ok(grid)
    }

    /// Voxels along x, y and z.
    pub fn dims(&self) -> [usize; 3] {
        let d = self.kind.dim();
        [d.0, d.1, d.2]
    }

    /// The closed box of voxel `i`: (min, max).
    #[inline]
    pub fn voxel_box(&self, i: [usize; 3]) -> (Vec3, Vec3) {
        let min = self.origin + self.voxel_size * Vec3::new(i[0] as f32, i[1] as f32, i[2] as f32);
        (min, min + Vec3::splat(self.voxel_size))
    }

    /// The centre of voxel `i`.
    #[inline]
    pub fn voxel_centre(&self, i: [usize; 3]) -> Vec3 {
        let (a, b) = self.voxel_box(i);
        0.5 * (a + b)
    }

    /// The voxel containing `p`, or `None` outside the grid.
    #[inline]
    pub fn voxel_of(&self, p: Vec3) -> Option<[usize; 3]> {
        let g = (p - self.origin) / self.voxel_size;
        let d = self.dims();
        let mut i = [0usize; 3];
        for k in 0..3 {
            if g[k].is_nan() || g[k] < 0.0 {
                return None;
            }
            let v = g[k].floor() as usize;
            // A point exactly on the far face belongs to the last voxel.
            i[k] = if v == d[k] && g[k] == d[k] as f32 {
                v - 1
            } else {
                v
            };
            if i[k] >= d[k] {
                return None;
            }
        }
        Some(i)
    }

    /// Half-open index range [lo, hi) of the voxels whose closed boxes can
    /// meet the box `b` (a one-voxel margin against rounding), or `None`
    /// when `b` misses the grid.
    fn voxel_range(&self, b: &Aabb) -> Option<([usize; 3], [usize; 3])> {
        let d = self.dims();
        let lo_f = ((b.min - self.origin) / self.voxel_size).floor() - Vec3::ONE;
        let hi_f = ((b.max - self.origin) / self.voxel_size).floor() + Vec3::splat(2.0);
        let mut lo = [0; 3];
        let mut hi = [0; 3];
        for k in 0..3 {
            lo[k] = lo_f[k].clamp(0.0, d[k] as f32) as usize;
            hi[k] = hi_f[k].clamp(0.0, d[k] as f32) as usize;
            if lo[k] >= hi[k] {
                return None;
            }
        }
        Some((lo, hi))
    }

    /// Number of voxels of each kind: (empty, opaque, emissive).
    pub fn counts(&self) -> (usize, usize, usize) {
        let mut c = (0, 0, 0);
        for k in &self.kind {
            match k {
                VoxelKind::Empty => c.0 += 1,
                VoxelKind::Opaque => c.1 += 1,
                VoxelKind::Emissive => c.2 += 1,
            }
        }
        c
    }
}

/// The half-size of the closed box [bmin, bmax] for overlap tests, grown by
/// 10⁻⁵ of itself: a surface lying exactly on a voxel face (a wall on the
/// grid's boundary, as in a box-shaped room) touches the closed box, but
/// the f32 rounding of the centre and half-size decides that test either
/// way (it made one wall of a cube room vanish while the opposite wall
/// stayed). 10⁻⁵ of a voxel is far below any geometry a voxel resolves.
fn touching_half_size(bmin: Vec3, bmax: Vec3) -> Vec3 {
    0.5 * (bmax - bmin) * (1.0 + 1e-5)
}

/// Whether the triangle meets the closed box [bmin, bmax] (separating-axis
/// theorem, 13 axes; see the module docs).
pub fn triangle_overlaps_box(t: &Triangle, bmin: Vec3, bmax: Vec3) -> bool {
    let c = 0.5 * (bmin + bmax);
    let h = touching_half_size(bmin, bmax);
    let v = [t.p[0] - c, t.p[1] - c, t.p[2] - c];
    // A separating axis a: the triangle's projection interval misses the
    // box's, [-r, r] with r = h·|a| (componentwise).
    let separated = |a: Vec3| {
        let p = [a.dot(v[0]), a.dot(v[1]), a.dot(v[2])];
        let r = h.dot(a.abs());
        p[0].min(p[1]).min(p[2]) > r || p[0].max(p[1]).max(p[2]) < -r
    };
    // Box normals: the triangle's bounds against the box.
    for k in 0..3 {
        let lo = v[0][k].min(v[1][k]).min(v[2][k]);
        let hi = v[0][k].max(v[1][k]).max(v[2][k]);
        if lo > h[k] || hi < -h[k] {
            return false;
        }
    }
    let e = [v[1] - v[0], v[2] - v[1], v[0] - v[2]];
    // The triangle's plane.
    if separated(e[0].cross(e[1])) {
        return false;
    }
    // Cross products of edges with the box axes (a zero axis from a
    // degenerate edge separates nothing: both intervals are [0, 0]).
    for edge in e {
        for axis in [Vec3::X, Vec3::Y, Vec3::Z] {
            if separated(axis.cross(edge)) {
                return false;
            }
        }
    }
    true
}

/// Whether the solid ball meets the closed box: the squared distance from
/// the centre to the box is at most r².
pub fn sphere_overlaps_box(s: &Sphere, bmin: Vec3, bmax: Vec3) -> bool {
    let d = s.centre.clamp(bmin, bmax) - s.centre;
    d.length_squared() <= s.radius * s.radius
}

/// Whether the plane meets the closed box.
pub fn plane_overlaps_box(p: &Plane, bmin: Vec3, bmax: Vec3) -> bool {
    let c = 0.5 * (bmin + bmax);
    let h = touching_half_size(bmin, bmax);
    p.normal.dot(c - p.point).abs() <= h.dot(p.normal.abs())
}

/// Whether the solid ellipsoid meets the closed box (coordinate descent on
/// the convex quadratic form; see the module docs).
pub fn ellipsoid_overlaps_box(e: &Ellipsoid, bmin: Vec3, bmax: Vec3) -> bool {
    let t = e.to_unit();
    // q(p) = (p − c)ᵀ A (p − c) with A = TᵀT.
    let a = t.transpose() * t;
    let mut p = e.centre.clamp(bmin, bmax);
    for _ in 0..ELLIPSOID_SWEEPS {
        let d = p - e.centre;
        if d.dot(a * d) <= 1.0 {
            return true;
        }
        for k in 0..3 {
            let d = p - e.centre;
            // ∂q/∂p_k = 2 (A d)_k; the 1-D minimiser moves by −(A d)_k / A_kk.
            let g = (a * d)[k];
            let akk = a.col(k)[k];
            p[k] = (p[k] - g / akk).clamp(bmin[k], bmax[k]);
        }
    }
    let d = p - e.centre;
    d.dot(a * d) <= 1.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Mat3;

    #[test]
    fn triangle_box_separating_axes() {
        let (lo, hi) = (Vec3::ZERO, Vec3::ONE);
        // Crosses the box.
        let t = Triangle::new(
            Vec3::new(-1.0, 0.5, -1.0),
            Vec3::new(2.0, 0.5, -1.0),
            Vec3::new(0.5, 0.5, 2.0),
        );
        assert!(triangle_overlaps_box(&t, lo, hi));
        // Its bounds overlap the box but its plane x + y + z = 3.2 misses it
        // (the box reaches x + y + z = 3 at its far corner).
        let t = Triangle::new(
            Vec3::new(3.2, 0.0, 0.0),
            Vec3::new(0.0, 3.2, 0.0),
            Vec3::new(0.0, 0.0, 3.2),
        );
        assert!(!triangle_overlaps_box(&t, lo, hi));
        // Touching a face counts.
        let t = Triangle::new(
            Vec3::new(1.0, -1.0, -1.0),
            Vec3::new(1.0, 3.0, -1.0),
            Vec3::new(1.0, 0.5, 3.0),
        );
        assert!(triangle_overlaps_box(&t, lo, hi));
        // Only an edge axis separates: a flat triangle in the plane z = 0.5
        // (which cuts the box), with bounds overlapping the box, lying where
        // x + y ≥ 3 beyond the box's edge x = y = 1; the axis (1, 1, 0) =
        // Z × edge separates it.
        let t = Triangle::new(
            Vec3::new(3.0, 0.0, 0.5),
            Vec3::new(0.0, 3.0, 0.5),
            Vec3::new(3.0, 3.0, 0.5),
        );
        assert!(!triangle_overlaps_box(&t, lo, hi));
    }

    #[test]
    fn ellipsoid_box_matches_sphere_box_for_round_ellipsoids() {
        // A rotated ellipsoid with equal radii is a sphere: the two exact
        // tests must agree on every box of a grid around it.
        let rot = crate::math::rotation_xyz_degrees(Vec3::new(20.0, 35.0, -10.0));
        let e = Ellipsoid::new(Vec3::new(0.1, 0.2, 0.3), Vec3::splat(0.7), rot);
        let s = Sphere::new(Vec3::new(0.1, 0.2, 0.3), 0.7);
        let h = 0.13;
        for x in -8..8 {
            for y in -8..8 {
                for z in -8..8 {
                    let lo = Vec3::new(x as f32, y as f32, z as f32) * h;
                    let hi = lo + Vec3::splat(h);
                    let (a, b) = (
                        ellipsoid_overlaps_box(&e, lo, hi),
                        sphere_overlaps_box(&s, lo, hi),
                    );
                    // Boxes within rounding of tangency may differ.
                    let d = (s.centre.clamp(lo, hi) - s.centre).length();
                    if (d - 0.7).abs() > 1e-4 {
                        assert_eq!(a, b, "box at {lo}");
                    }
                }
            }
        }
        // An elongated one: the box beside its long axis's tip is hit, the
        // one beside the short axis at the same distance is not.
        let e = Ellipsoid::new(Vec3::ZERO, Vec3::new(2.0, 0.5, 0.5), Mat3::IDENTITY);
        assert!(ellipsoid_overlaps_box(
            &e,
            Vec3::new(1.9, -0.1, -0.1),
            Vec3::new(2.1, 0.1, 0.1)
        ));
        assert!(!ellipsoid_overlaps_box(
            &e,
            Vec3::new(-0.1, 1.9, -0.1),
            Vec3::new(0.1, 2.1, 0.1)
        ));
    }
}
