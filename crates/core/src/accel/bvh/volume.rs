//! Bounding volumes of the BVH: the axis-aligned box ([`Aabb`]), the sphere
//! ([`BoundingSphere`]) and the axis-aligned ellipsoid
//! ([`BoundingEllipsoid`]) that S3 compares. They share the
//! [`BoundingVolume`] trait, so the builders and the traversal are written
//! once and instantiated per volume (static dispatch, no per-test branch on
//! the volume kind).
//!
//! Every volume is *conservative*: its ray test may report a hit for a ray
//! that misses it by a rounding error, never a miss for a ray that touches
//! it, because a missed node loses every primitive below it. Fits are padded
//! by [`FIT_PAD`] and the ray tests allow for their own rounding (the box
//! after Ize, the quadrics by a per-ray margin), see each test.

use crate::math::{slab4_distances, Aabb, Ray, Vec3};
use crate::shape::sphere::Sphere;
use crate::shape::PreparedRay;
use crate::stats::Stats;
use glam::{Vec4, Vec4Swizzles};
use std::f32::consts::PI;
use std::fmt;

/// Relative padding of fitted radii: f32 fits carry a few units of
/// roundoff (ε = 2⁻²⁴ ≈ 6·10⁻⁸) in the centre and the distances, so a
/// point on the surface can land up to ~5ε outside; 10⁻⁶ ≈ 17ε covers it
/// and costs nothing measurable in tightness.
pub const FIT_PAD: f32 = 1.0 + 1.0e-6;

/// Relative margin of the quadric ray tests, per unit of distance from the
/// ray origin to the volume centre. The closest-approach vector of
/// [`Sphere::roots`] is a difference of two vectors of length ≈ |o − c|
/// and carries an absolute error of about 8ε·|o − c| (ε = 2⁻²⁴); padding the
/// radius by 32ε·(|o − c| + r) keeps the test conservative, including for
/// tangent rays.
pub const QUADRIC_MARGIN: f32 = 32.0 * UNIT_ROUNDOFF;

/// ε = 2⁻²⁴, the largest relative error of one rounded f32 operation.
const UNIT_ROUNDOFF: f32 = f32::EPSILON * 0.5;

/// A volume that bounds a group of primitives and can be tested against a
/// ray. Implementations are plain old data (`#[repr(C)]`, no pointers) so
/// flattened trees can be uploaded as they are.
pub trait BoundingVolume: Copy + Send + Sync + fmt::Debug + PartialEq + 'static {
    /// The volume's name in accelerator names (`aabb`, `sphere`,
    /// `ellipsoid`).
    const NAME: &'static str;

    /// Whether S3's builder takes split axes in turn (x, y, z, x, …) rather
    /// than the longest axis: S3 does so for spheres, "which have no longest
    /// axis".
    const ROUND_ROBIN_AXES: bool;

    /// S3's fit: the volume derived from the axis-aligned box of the
    /// enclosed geometry alone. It contains the whole box, so it contains
    /// anything inside the box.
    fn from_bounds(b: &Aabb) -> Self;

    /// A tighter fit over `points`, the support points of the enclosed
    /// primitives (points whose convex hull contains them: a triangle's
    /// vertices, the corners of a quadric's box), whose box is `b`. Since
    /// every volume here is convex, enclosing the points encloses the
    /// primitives.
    fn fit_points(points: &[Vec3], b: &Aabb) -> Self;

    /// Whether the ray meets the volume somewhere in [0, `t_max`]; if so,
    /// the entry distance clamped to 0 (a ray starting inside enters at 0),
    /// which orders the traversal nearest child first. Counts one test of
    /// this volume kind in `stats`.
    fn hit<S: Stats>(&self, ray: &PreparedRay, t_max: f32, stats: &mut S) -> Option<f32>;

    /// Surface area: the SAH weighs a child by its area because the chance
    /// that a random ray hitting a convex body also hits a convex body
    /// inside it is the ratio of their areas (Cauchy's surface-area
    /// formula).
    fn surface_area(&self) -> f32;

    /// Enclosed volume.
    fn volume(&self) -> f32;

    /// Axis-aligned bounds of the volume itself.
    fn bounds(&self) -> Aabb;

    /// Whether `p` lies inside the volume scaled about its centre by
    /// 1 + `tol`; for consistency checks of built trees.
    fn contains(&self, p: Vec3, tol: f32) -> bool;

    /// The two children of an interior node in the layout the traversal
    /// reads them in, stored in the parent (see [`super::Packed`]). Spheres
    /// and ellipsoids keep the pair as it is; boxes transpose it so that
    /// both are tested with one set of 4-wide operations.
    type Pair: Copy + Send + Sync + fmt::Debug + 'static;

    /// Pack two sibling volumes.
    fn pair(left: &Self, right: &Self) -> Self::Pair;

    /// [`Self::hit`] for both volumes of a pair, with the same results and
    /// the same counts (two tests).
    fn hit_pair<S: Stats>(
        pair: &Self::Pair,
        ray: &PreparedRay,
        t_max: f32,
        stats: &mut S,
    ) -> [Option<f32>; 2];
}

impl BoundingVolume for Aabb {
    type Pair = AabbPair;

    fn pair(l: &Self, r: &Self) -> AabbPair {
        AabbPair {
            x: Vec4::new(l.min.x, r.min.x, l.max.x, r.max.x),
            y: Vec4::new(l.min.y, r.min.y, l.max.y, r.max.y),
            z: Vec4::new(l.min.z, r.min.z, l.max.z, r.max.z),
        }
    }

    /// The slab test for two boxes at once: per axis one 4-wide subtract
    /// and multiply give the distances to [left min, right min, left max,
    /// right max]; with the halves swapped they are the other planes, and
    /// [`slab4_distances`] (the interval logic of the one 4-wide slab test)
    /// does the rest. Lanes 2 and 3 repeat the two boxes and are ignored.
    /// Bit-identical to [`Aabb::slab`] on each box.
    #[inline]
    fn hit_pair<S: Stats>(
        p: &AabbPair,
        ray: &PreparedRay,
        t_max: f32,
        stats: &mut S,
    ) -> [Option<f32>; 2] {
        stats.box_test();
        stats.box_test();
        let (o, inv) = (ray.ray.origin, ray.inv_dir);
        let t = [
            (p.x - Vec4::splat(o.x)) * Vec4::splat(inv.x),
            (p.y - Vec4::splat(o.y)) * Vec4::splat(inv.y),
            (p.z - Vec4::splat(o.z)) * Vec4::splat(inv.z),
        ];
        let swapped = t.map(|v| v.zwxy());
        let (enter, bits) = slab4_distances(&t, &swapped, t_max);
        [
            (bits & 1 != 0).then_some(enter.x),
            (bits & 2 != 0).then_some(enter.y),
        ]
    }

    const NAME: &'static str = "aabb";
    const ROUND_ROBIN_AXES: bool = false;

    #[inline]
    fn from_bounds(b: &Aabb) -> Self {
        *b
    }

    /// The box of the points is the box of the primitives: nothing tighter
    /// exists for an axis-aligned box.
    fn fit_points(_points: &[Vec3], b: &Aabb) -> Self {
        *b
    }

    /// The slab test ([`Aabb::slab`]), counted.
    #[inline]
    fn hit<S: Stats>(&self, ray: &PreparedRay, t_max: f32, stats: &mut S) -> Option<f32> {
        stats.box_test();
        self.slab(ray.ray.origin, ray.inv_dir, t_max)
    }

    #[inline]
    fn surface_area(&self) -> f32 {
        Aabb::surface_area(self)
    }

    fn volume(&self) -> f32 {
        Aabb::volume(self)
    }

    fn bounds(&self) -> Aabb {
        *self
    }

    fn contains(&self, p: Vec3, tol: f32) -> bool {
        let c = 0.5 * (self.min + self.max);
        let h = 0.5 * (self.max - self.min) * (1.0 + tol);
        (p.cmpge(self.min) & p.cmple(self.max)).all() || (p - c).abs().cmple(h).all()
    }
}

/// Two sibling boxes transposed for `hit_pair`: per axis, the lanes
/// are [left min, right min, left max, right max]. 48 bytes, 16-aligned.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AabbPair {
    pub x: Vec4,
    pub y: Vec4,
    pub z: Vec4,
}

/// Sphere bounding volume (S3): |x − c| ≤ r.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoundingSphere {
    pub centre: Vec3,
    pub radius: f32,
}

impl BoundingVolume for BoundingSphere {
    type Pair = [Self; 2];

    fn pair(left: &Self, right: &Self) -> Self::Pair {
        [*left, *right]
    }

    #[inline]
    fn hit_pair<S: Stats>(
        pair: &Self::Pair,
        ray: &PreparedRay,
        t_max: f32,
        stats: &mut S,
    ) -> [Option<f32>; 2] {
        [
            pair[0].hit(ray, t_max, stats),
            pair[1].hit(ray, t_max, stats),
        ]
    }

    const NAME: &'static str = "sphere";
    const ROUND_ROBIN_AXES: bool = true;

    /// S3's fit: centre = midpoint of the box's min and max corners,
    /// radius = distance from the centre to the corners.
    #[inline]
    fn from_bounds(b: &Aabb) -> Self {
        let (centre, h) = centre_and_half_extent(b);
        BoundingSphere {
            centre,
            radius: h.length() * FIT_PAD,
        }
    }

    /// The smaller of Ritter's sphere and the sphere about the box centre
    /// through the farthest point (see `tight_ball`); never larger than
    /// S3's fit, whose radius reaches the box corners.
    fn fit_points(points: &[Vec3], b: &Aabb) -> Self {
        let (centre, radius) = tight_ball(points, b.centre(), |p| p);
        BoundingSphere {
            centre,
            radius: radius * FIT_PAD,
        }
    }

    /// The quadratic test of S3, done by [`Sphere::roots`] (the stable form
    /// the sphere primitive uses) on a padded radius.
    #[inline]
    fn hit<S: Stats>(&self, ray: &PreparedRay, t_max: f32, stats: &mut S) -> Option<f32> {
        stats.bounding_sphere_test();
        unit_quadric_entry(
            ray.ray.origin - self.centre,
            ray.ray.dir,
            self.radius,
            t_max,
        )
    }

    #[inline]
    fn surface_area(&self) -> f32 {
        4.0 * PI * self.radius * self.radius
    }

    fn volume(&self) -> f32 {
        4.0 / 3.0 * PI * self.radius * self.radius * self.radius
    }

    fn bounds(&self) -> Aabb {
        let r = Vec3::splat(self.radius);
        Aabb {
            min: self.centre - r,
            max: self.centre + r,
        }
    }

    fn contains(&self, p: Vec3, tol: f32) -> bool {
        (p - self.centre).length() <= self.radius * (1.0 + tol)
    }
}

/// Axis-aligned ellipsoid bounding volume (S3):
/// (x−px)²/Rx² + (y−py)²/Ry² + (z−pz)²/Rz² ≤ 1. Stores the reciprocal radii
/// the ray test multiplies by.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoundingEllipsoid {
    pub centre: Vec3,
    pub inv_radii: Vec3,
}

impl BoundingEllipsoid {
    /// The radii (Rx, Ry, Rz).
    pub fn radii(&self) -> Vec3 {
        self.inv_radii.recip()
    }

    fn new(centre: Vec3, radii: Vec3) -> Self {
        BoundingEllipsoid {
            centre,
            inv_radii: radii.recip(),
        }
    }
}

/// The centre of a box and its half-extents measured from that centre as
/// rounded: a box far from the origin has a centre off the exact midpoint by
/// up to ε·|centre|, which can be large next to a small box, so each
/// half-extent is the larger of max − c and c − min. Every point of the box
/// is then within hᵢ of c along each axis, whatever the rounding.
fn centre_and_half_extent(b: &Aabb) -> (Vec3, Vec3) {
    let c = b.centre();
    (c, (b.max - c).max(c - b.min).max(Vec3::ZERO))
}

/// [`centre_and_half_extent`] with each half-extent raised to at least
/// 2⁻¹⁰ of the largest (and to the smallest normal float): a flat box (a
/// leaf holding one axis-aligned triangle) would otherwise give an
/// ellipsoid of radius 0, whose reciprocal is infinite. The floor thickens
/// such ellipsoids by a thousandth of their size.
fn floored_half_extent(b: &Aabb) -> (Vec3, Vec3) {
    let (c, h) = centre_and_half_extent(b);
    let floor = (h.max_element() * (1.0 / 1024.0)).max(f32::MIN_POSITIVE);
    (c, h.max(Vec3::splat(floor)))
}

impl BoundingVolume for BoundingEllipsoid {
    type Pair = [Self; 2];

    fn pair(left: &Self, right: &Self) -> Self::Pair {
        [*left, *right]
    }

    #[inline]
    fn hit_pair<S: Stats>(
        pair: &Self::Pair,
        ray: &PreparedRay,
        t_max: f32,
        stats: &mut S,
    ) -> [Option<f32>; 2] {
        [
            pair[0].hit(ray, t_max, stats),
            pair[1].hit(ray, t_max, stats),
        ]
    }

    const NAME: &'static str = "ellipsoid";
    const ROUND_ROBIN_AXES: bool = false;

    /// S3's fit: centre of the box, radii = half-extents × √3. This is what
    /// "mapping the box to a cube" gives: scale each axis so the box becomes
    /// the cube [−1, 1]³, take the cube's circumscribed sphere (radius √3,
    /// through the 8 corners), and scale back; the ellipsoid passes through
    /// the box's corners, so it contains the box.
    fn from_bounds(b: &Aabb) -> Self {
        let (c, h) = floored_half_extent(b);
        Self::new(c, h * (3.0f32.sqrt() * FIT_PAD))
    }

    /// The same construction with the tight sphere in the cube's
    /// coordinates: map the points by q = (p − c)/h, take the smaller of
    /// Ritter's sphere and the centred sphere through the farthest q
    /// (`tight_ball`; the centred one alone has radius ≤ √3, so this is
    /// never larger than S3's fit), and map back. An axis-scaled sphere is an
    /// axis-aligned ellipsoid, and a linear map preserves containment. The
    /// scale is measured again from the centre as rounded in world space,
    /// for the reason given at `centre_and_half_extent`.
    fn fit_points(points: &[Vec3], b: &Aabb) -> Self {
        let (c, h) = floored_half_extent(b);
        let inv_h = h.recip();
        let (qc, _) = tight_ball(points, Vec3::ZERO, |p| (p - c) * inv_h);
        let centre = c + qc * h;
        let s = points
            .iter()
            .map(|&p| ((p - centre) * inv_h).length())
            .fold(0.0f32, f32::max)
            // Points spanning the box reach ±1 along its longest axis, so
            // the true scale is at least 1; only a box shrunk to a point
            // (all points equal) gets here with 0, and a zero radius has no
            // reciprocal.
            .max(1.0);
        Self::new(centre, h * (s * FIT_PAD))
    }

    /// S3 substitutes the ray into the ellipsoid equation and solves
    /// At² + Bt + C = 0 with A = Σ dᵢ²/Rᵢ², B = 2Σ dᵢ(oᵢ−pᵢ)/Rᵢ²,
    /// C = Σ (oᵢ−pᵢ)²/Rᵢ² − 1. That is exactly the unit-sphere quadratic of
    /// the ray scaled by 1/Rᵢ per axis (an affine map leaves t unchanged),
    /// so it is solved by the same stable sphere code.
    #[inline]
    fn hit<S: Stats>(&self, ray: &PreparedRay, t_max: f32, stats: &mut S) -> Option<f32> {
        stats.bounding_ellipsoid_test();
        unit_quadric_entry(
            (ray.ray.origin - self.centre) * self.inv_radii,
            ray.ray.dir * self.inv_radii,
            1.0,
            t_max,
        )
    }

    /// Knud Thomsen's approximation (2004):
    /// S ≈ 4π((aᵖbᵖ + aᵖcᵖ + bᵖcᵖ)/3)^(1/p), p ≈ 1.6075, relative error at
    /// most about 1.061 % (exact for spheres). No closed form exists (the
    /// exact area needs elliptic integrals), and 1 % is far below what
    /// matters for SAH decisions.
    fn surface_area(&self) -> f32 {
        const P: f32 = 1.6075;
        let r = self.radii();
        let (a, b, c) = (r.x.powf(P), r.y.powf(P), r.z.powf(P));
        4.0 * PI * ((a * b + a * c + b * c) / 3.0).powf(1.0 / P)
    }

    fn volume(&self) -> f32 {
        let r = self.radii();
        4.0 / 3.0 * PI * r.x * r.y * r.z
    }

    fn bounds(&self) -> Aabb {
        let r = self.radii();
        Aabb {
            min: self.centre - r,
            max: self.centre + r,
        }
    }

    fn contains(&self, p: Vec3, tol: f32) -> bool {
        ((p - self.centre) * self.inv_radii).length() <= 1.0 + tol
    }
}

/// Entry distance of the ray o + t·d (given as `f` = o − centre and `d`)
/// into the ball of radius `r` about the origin, if the ray meets it in
/// [0, t_max]; clamped to 0 when the origin is inside. The radius is padded
/// by [`QUADRIC_MARGIN`] relative to the distances involved, so rounding can
/// only turn a near miss into a hit.
#[inline(always)]
fn unit_quadric_entry(f: Vec3, d: Vec3, r: f32, t_max: f32) -> Option<f32> {
    let padded = r + QUADRIC_MARGIN * (f.length() + r);
    // NaN (a degenerate volume) fails every comparison below: a miss.
    let (t0, t1) = Sphere::roots(Vec3::ZERO, padded, &Ray::new(f, d))?;
    (t1 >= 0.0 && t0 <= t_max).then_some(t0.max(0.0))
}

/// A small ball enclosing the points `map(p)`: the smaller of
/// - Ritter's sphere (J. Ritter, "An Efficient Bounding Sphere", Graphics
///   Gems, 1990): start from two far-apart points (the farthest from an
///   arbitrary point, then the farthest from that) as a diameter, then grow
///   the ball just enough to take in each point left outside; and
/// - the ball about `centre` (the box centre) through the farthest point.
///
/// Ritter's is usually within 5–20 % of the minimal ball; the centred one
/// wins for box-like clusters. In both, the final radius is the measured
/// distance to the farthest point, so every point is inside up to the
/// rounding of one distance (covered by [`FIT_PAD`]). Returns (centre,
/// radius); (`centre`, 0) for no points.
fn tight_ball(points: &[Vec3], centre: Vec3, map: impl Fn(Vec3) -> Vec3) -> (Vec3, f32) {
    let Some(&first) = points.first() else {
        return (centre, 0.0);
    };
    let farthest_from = |a: Vec3| {
        points
            .iter()
            .map(|&p| map(p))
            .max_by(|p, q| p.distance_squared(a).total_cmp(&q.distance_squared(a)))
            .unwrap_or(a)
    };
    let radius_about = |c: Vec3| {
        points
            .iter()
            .map(|&p| map(p).distance(c))
            .fold(0.0f32, f32::max)
    };
    let y = farthest_from(map(first));
    let z = farthest_from(y);
    let mut c = 0.5 * (y + z);
    let mut r = 0.5 * y.distance(z);
    for &p in points {
        let p = map(p);
        let d = p.distance(c);
        if d > r {
            // The new ball touches p and the far side of the old one.
            let grown = 0.5 * (r + d);
            c += (p - c) * ((grown - r) / d);
            r = grown;
        }
    }
    let ritter = radius_about(c);
    let centred = radius_about(centre);
    if ritter < centred {
        (c, ritter)
    } else {
        (centre, centred)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn prep(o: Vec3, d: Vec3) -> PreparedRay {
        PreparedRay::new(Ray::new(o, d))
    }

    #[test]
    fn slab_test_handles_rays_in_a_face_plane() {
        // Parallel to x and y, starting on the plane y = min.y: 0·∞ = NaN.
        let b = Aabb {
            min: Vec3::new(0.0, 0.0, 0.0),
            max: Vec3::new(1.0, 1.0, 1.0),
        };
        let mut s = crate::stats::NoStats;
        for d in [Vec3::Z, -Vec3::Z] {
            let r = prep(Vec3::new(0.5, 0.0, 0.5 - 2.5 * d.z), d);
            assert_eq!(b.hit(&r, f32::INFINITY, &mut s), Some(2.0));
            let r = prep(Vec3::new(0.0, 1.0, 0.5), d); // on an edge, inside
            assert_eq!(b.hit(&r, f32::INFINITY, &mut s), Some(0.0));
        }
        let r = prep(Vec3::new(0.5, 1.5, -2.0), Vec3::Z);
        assert_eq!(b.hit(&r, f32::INFINITY, &mut s), None);
    }

    #[test]
    fn quadric_entry_is_clamped_and_bounded() {
        let sph = BoundingSphere {
            centre: Vec3::ZERO,
            radius: 1.0,
        };
        let mut s = crate::stats::NoStats;
        let t = sph.hit(&prep(Vec3::new(0.0, 0.0, -3.0), Vec3::Z), 10.0, &mut s);
        assert!((t.unwrap() - 2.0).abs() < 1e-5);
        assert_eq!(sph.hit(&prep(Vec3::ZERO, Vec3::Z), 10.0, &mut s), Some(0.0));
        assert_eq!(
            sph.hit(&prep(Vec3::new(0.0, 0.0, -3.0), Vec3::Z), 1.5, &mut s),
            None
        );
        assert_eq!(
            sph.hit(&prep(Vec3::new(0.0, 0.0, 3.0), Vec3::Z), 10.0, &mut s),
            None
        );
    }

    #[test]
    fn s3_ellipsoid_passes_through_the_box_corners() {
        let b = Aabb {
            min: Vec3::new(-1.0, 2.0, 0.0),
            max: Vec3::new(3.0, 3.0, 0.5),
        };
        let e = BoundingEllipsoid::from_bounds(&b);
        for i in 0..8 {
            let corner = b.corner(i);
            let q = ((corner - e.centre) * e.inv_radii).length();
            assert!(q <= 1.0 && q > 1.0 - 1e-5, "{q}");
        }
    }

    #[test]
    fn thomsen_area_is_exact_for_spheres_and_close_for_a_spheroid() {
        let e = BoundingEllipsoid::new(Vec3::ZERO, Vec3::splat(2.0));
        assert!((e.surface_area() - 16.0 * PI).abs() < 1e-3);
        // Prolate spheroid a = 2, b = c = 1: exact area
        // 2πb² + 2πab·asin(e)/e with e = √(1 − b²/a²).
        let ecc = (1.0f32 - 0.25).sqrt();
        let exact = 2.0 * PI + 2.0 * PI * 2.0 * ecc.asin() / ecc;
        let e = BoundingEllipsoid::new(Vec3::ZERO, Vec3::new(2.0, 1.0, 1.0));
        assert!((e.surface_area() / exact - 1.0).abs() < 0.0107);
    }

    #[test]
    fn tight_fits_contain_their_points_and_beat_s3() {
        let pts: Vec<Vec3> = (0..50)
            .map(|i| {
                let a = i as f32 * 2.4;
                Vec3::new(3.0 * a.cos(), a.sin(), 0.1 * (i % 5) as f32)
            })
            .collect();
        let b = pts.iter().fold(Aabb::EMPTY, |b, &p| b.include(p));
        let s = BoundingSphere::fit_points(&pts, &b);
        let e = BoundingEllipsoid::fit_points(&pts, &b);
        assert!(pts
            .iter()
            .all(|&p| s.contains(p, 0.0) && e.contains(p, 0.0)));
        assert!(s.radius <= BoundingSphere::from_bounds(&b).radius);
        assert!(e.volume() <= BoundingEllipsoid::from_bounds(&b).volume());
    }
}
