//! Tracing rays through an [`EmbreeAccel`]: the closest hit
//! (`rtcIntersect1`) and any hit (`rtcOccluded1`) on raylab's open
//! interval (0, t_max), mapped back to raylab's primitive index; as an
//! [`Accel`] for rendering, and as [`EmbreeAccel::trace`] with Embree's own
//! normal for the oracle. Part of [`crate::accel::embree`].

use super::device::{self, RayHit, INVALID_ID};
use super::mxcsr::FtzDazScope;
use super::{EmbreeAccel, EmbreeConfig, Geometry, Inner};
use crate::accel::Accel;
use crate::math::{Ray, Vec3};
use crate::shape::{PreparedRay, PrimHit, Primitive};
use crate::stats::Stats;
use embree4_sys as sys;

/// A hit as Embree reports it, with its own world-space normal: what the
/// oracle compares against raylab.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmbreeHit {
    /// Index of the primitive in the list the accelerator was built from.
    pub prim: u32,
    /// Ray parameter and barycentrics (zero for spheres and ellipsoids).
    pub hit: PrimHit,
    /// Unit outward geometric normal in world space, from Embree's `Ng`
    /// (for triangles (p1 − p0) × (p2 − p0), as raylab's). Zero if Embree
    /// reported a degenerate one.
    pub normal: Vec3,
}

/// The smallest t Embree is asked about: the smallest normal float, so
/// that t = 0 is excluded (a denormal would be read as 0 under DAZ).
const TNEAR: f32 = f32::MIN_POSITIVE;

/// Embree's tfar for raylab's open bound t_max: the float just below it
/// (Rust's `f32::next_down` needs 1.86; raylab supports 1.80, and positive
/// floats order like their bit patterns), or `None` when (0, t_max) holds
/// no float Embree would test: t_max ≤ TNEAR, or NaN.
fn tfar(t_max: f32) -> Option<f32> {
    if t_max.is_nan() || t_max <= TNEAR {
        None
    } else if t_max.is_infinite() {
        Some(t_max)
    } else {
        Some(f32::from_bits(t_max.to_bits() - 1))
    }
}

impl EmbreeAccel {
    /// The build settings.
    pub fn config(&self) -> EmbreeConfig {
        self.inner.config
    }

    /// The linked Embree library's version, e.g. "4.4.0".
    pub fn version(&self) -> String {
        self.inner.device.version()
    }

    /// Closest hit in (0, t_max), with Embree's own world-space normal.
    pub fn trace(&self, ray: &Ray, t_max: f32) -> Option<EmbreeHit> {
        let rh = self.intersect_raw(ray, t_max)?;
        let (prim, geometry) = self.inner.resolve(&rh.hit)?;
        let ng = Vec3::new(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z);
        let (hit, normal) = match geometry {
            Geometry::Triangles(_) => (prim_hit(rh.ray.tfar, rh.hit.u, rh.hit.v), ng),
            Geometry::Spheres(_) => (prim_hit(rh.ray.tfar, 0.0, 0.0), ng),
            Geometry::Ellipsoid {
                normal_to_world, ..
            } => (prim_hit(rh.ray.tfar, 0.0, 0.0), *normal_to_world * ng),
        };
        Some(EmbreeHit {
            prim,
            hit,
            normal: normal.normalize_or_zero(),
        })
    }

    // ANCHOR: intersect1
    /// One `rtcIntersect1`: the ray/hit record after the query, or `None`
    /// on a miss or an empty interval.
    #[inline]
    fn intersect_raw(&self, ray: &Ray, t_max: f32) -> Option<sys::RTCRayHit> {
        let mut rh = RayHit::new(
            ray.origin.to_array(),
            ray.dir.to_array(),
            TNEAR,
            tfar(t_max)?,
        );
        {
            let _ftz = FtzDazScope::new();
            // SAFETY: committed scene; `rh` is a writable, 16-byte aligned
            // record large enough for what this library writes (see
            // `device`); null arguments mean Embree's defaults.
            unsafe {
                sys::rtcIntersect1(
                    self.inner.scene,
                    &mut rh as *mut RayHit as *mut sys::RTCRayHit,
                    std::ptr::null_mut(),
                )
            };
        }
        (rh.rayhit.hit.geomID != INVALID_ID).then_some(rh.rayhit)
    }
    // ANCHOR_END: intersect1

    /// One `rtcOccluded1`: whether anything is hit in (0, t_max).
    #[inline]
    fn occluded_raw(&self, ray: &Ray, t_max: f32) -> bool {
        let Some(tfar) = tfar(t_max) else {
            return false;
        };
        let mut r = device::ray(ray.origin.to_array(), ray.dir.to_array(), TNEAR, tfar);
        {
            let _ftz = FtzDazScope::new();
            // SAFETY: committed scene; the RTCRay record is unchanged in
            // newer Embree; null arguments mean Embree's defaults.
            unsafe { sys::rtcOccluded1(self.inner.scene, &mut r, std::ptr::null_mut()) };
        }
        // Embree marks an occluded ray by setting tfar to −∞.
        r.tfar == f32::NEG_INFINITY
    }
}

#[inline(always)]
fn prim_hit(t: f32, u: f32, v: f32) -> PrimHit {
    PrimHit { t, u, v }
}
impl Inner {
    /// The raylab primitive of an Embree hit, and its geometry. `None` only
    /// if Embree reported ids it was never given.
    #[inline]
    fn resolve(&self, hit: &sys::RTCHit) -> Option<(u32, &Geometry)> {
        // An ellipsoid hit is a hit on the unit sphere's geometry 0 inside
        // the instance `instID[0]` of the top scene.
        let top = if hit.instID[0] != INVALID_ID {
            hit.instID[0]
        } else {
            hit.geomID
        };
        let g = self.geometries.get(top as usize)?;
        let prim = match g {
            Geometry::Triangles(ids) | Geometry::Spheres(ids) => *ids.get(hit.primID as usize)?,
            Geometry::Ellipsoid { prim, .. } => *prim,
        };
        Some((prim, g))
    }
}

impl Accel for EmbreeAccel {
    /// `rtcIntersect1`. `prims` is not read: Embree holds its own copy of
    /// the geometry, made by [`EmbreeAccel::build`].
    #[inline]
    fn intersect<S: Stats>(
        &self,
        _prims: &[Primitive],
        ray: &PreparedRay,
        t_max: f32,
        stats: &mut S,
    ) -> Option<(u32, PrimHit)> {
        let rh = self.intersect_raw(&ray.ray, t_max)?;
        let (prim, g) = self.inner.resolve(&rh.hit)?;
        stats.primitive_hit();
        let hit = match g {
            Geometry::Triangles(_) => prim_hit(rh.ray.tfar, rh.hit.u, rh.hit.v),
            _ => prim_hit(rh.ray.tfar, 0.0, 0.0),
        };
        Some((prim, hit))
    }

    /// `rtcOccluded1`.
    #[inline]
    fn occluded<S: Stats>(
        &self,
        _prims: &[Primitive],
        ray: &PreparedRay,
        t_max: f32,
        stats: &mut S,
    ) -> bool {
        let hit = self.occluded_raw(&ray.ray, t_max);
        if hit {
            stats.primitive_hit();
        }
        hit
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::prim;
    use super::*;
    use crate::shape::{Ellipsoid, Shape, Sphere, Triangle};
    use crate::stats::Counters;

    #[test]
    fn tfar_is_the_float_below_t_max() {
        assert_eq!(tfar(1.0), Some(1.0 - f32::EPSILON / 2.0));
        assert_eq!(tfar(f32::INFINITY), Some(f32::INFINITY));
        assert!(tfar(2.0 * TNEAR).unwrap() > TNEAR);
        for empty in [TNEAR, 0.0, -1.0, f32::NAN, f32::NEG_INFINITY] {
            assert_eq!(tfar(empty), None, "{empty}");
        }
    }

    #[test]
    fn one_of_each_shape() {
        let e = Ellipsoid::new(
            Vec3::new(0.0, 0.0, -10.0),
            Vec3::new(2.0, 1.0, 0.5),
            crate::math::rotation_xyz_degrees(Vec3::new(0.0, 0.0, 90.0)),
        );
        let prims = vec![
            prim(Shape::Triangle(Triangle::new(
                Vec3::new(0.0, 0.0, -2.0),
                Vec3::new(1.0, 0.0, -2.0),
                Vec3::new(0.0, 1.0, -2.0),
            ))),
            prim(Shape::Sphere(Sphere::new(Vec3::new(5.0, 0.0, -5.0), 1.0))),
            prim(Shape::Ellipsoid(e)),
        ];
        let accel = EmbreeAccel::build(&prims, &[0, 1, 2], EmbreeConfig::default()).unwrap();
        assert!(accel.version().starts_with("4."));
        let mut stats = Counters::default();

        // The triangle, with raylab's barycentrics and normal.
        let r = Ray::new(Vec3::new(0.25, 0.5, 0.0), -Vec3::Z);
        let (id, h) = accel
            .intersect(&prims, &PreparedRay::new(r), f32::INFINITY, &mut stats)
            .unwrap();
        assert_eq!(id, 0);
        assert!((h.t - 2.0).abs() < 1e-6 && (h.u - 0.25).abs() < 1e-6 && (h.v - 0.5).abs() < 1e-6);
        assert!((accel.trace(&r, f32::INFINITY).unwrap().normal - Vec3::Z).length() < 1e-6);
        assert_eq!(stats.primitive_hits, 1);
        // t_max is exclusive, and so is 0.
        assert!(accel.trace(&r, 2.0).is_none());
        assert!(accel.trace(&r, 2.0 + 1e-5).is_some());
        assert!(!accel.occluded(&prims, &PreparedRay::new(r), 2.0, &mut stats));
        assert!(accel.occluded(&prims, &PreparedRay::new(r), 2.5, &mut stats));
        let on_plane = Ray::new(Vec3::new(0.25, 0.25, -2.0), -Vec3::Z);
        assert!(accel.trace(&on_plane, 1e-3).is_none(), "no hit at t = 0");

        // The sphere from outside: entry at t = 4.
        let r = Ray::new(Vec3::new(5.0, 0.0, 0.0), -Vec3::Z);
        let h = accel.trace(&r, f32::INFINITY).unwrap();
        assert_eq!(h.prim, 1);
        assert!((h.hit.t - 4.0).abs() < 1e-5);
        assert!((h.normal - Vec3::Z).length() < 1e-5);

        // The ellipsoid: rotated 90° about z, so its x radius 2 lies along
        // y. From +y it is entered at y = 2; from +x at x = 1.
        let r = Ray::new(Vec3::new(0.0, 10.0, -10.0), -Vec3::Y);
        let h = accel.trace(&r, f32::INFINITY).unwrap();
        assert_eq!(h.prim, 2);
        assert!((h.hit.t - 8.0).abs() < 1e-5, "{h:?}");
        assert!((h.normal - Vec3::Y).length() < 1e-5, "{h:?}");
        let r = Ray::new(Vec3::new(10.0, 0.0, -10.0), -Vec3::X);
        let h = accel.trace(&r, f32::INFINITY).unwrap();
        assert!((h.hit.t - 9.0).abs() < 1e-5, "{h:?}");
    }
    #[test]
    fn empty_scene_misses() {
        let accel = EmbreeAccel::build(&[], &[], EmbreeConfig::default()).unwrap();
        let r = PreparedRay::new(Ray::new(Vec3::ZERO, Vec3::X));
        assert!(accel
            .intersect(&[], &r, f32::INFINITY, &mut Counters::default())
            .is_none());
        assert!(!accel.occluded(&[], &r, f32::INFINITY, &mut Counters::default()));
    }

    #[test]
    fn the_padded_record_receives_the_trailing_write() {
        // The linked Embree (4.4 with instance arrays) writes instPrimID[0]
        // in the 4 bytes after the 80-byte record of the 4.2 headers: the
        // reason for `RayHit`'s padding. Nothing beyond those 4 bytes.
        let prims = vec![prim(Shape::Triangle(Triangle::new(
            Vec3::ZERO,
            Vec3::X,
            Vec3::Y,
        )))];
        let accel = EmbreeAccel::build(&prims, &[0], EmbreeConfig::default()).unwrap();
        let mut rh = RayHit::new([0.25, 0.25, 1.0], [0.0, 0.0, -1.0], 0.0, f32::INFINITY);
        const SENTINEL: u32 = 0xABAB_ABAB;
        rh.set_tail(SENTINEL);
        // SAFETY: as in `intersect_raw`.
        unsafe {
            sys::rtcIntersect1(
                accel.inner.scene,
                &mut rh as *mut RayHit as *mut sys::RTCRayHit,
                std::ptr::null_mut(),
            )
        };
        assert_eq!(rh.rayhit.hit.geomID, 0);
        let tail = rh.tail();
        assert_eq!(tail[0], INVALID_ID, "instPrimID[0] written (4.4 layout)");
        assert_eq!(
            tail[1..],
            [SENTINEL; 3],
            "nothing written past instPrimID[0]"
        );
    }
}
