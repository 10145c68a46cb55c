//! Embree 4 as an accelerator (`--accel embree`) and as the independent
//! oracle raylab's own intersection code is checked against. Behind the
//! `embree` cargo feature; `make deps` installs the library.
//!
//! The scene handed to Embree is made of Embree's own primitives only, so
//! every hit it reports is Embree's arithmetic, never an echo of ours:
//!
//! - all triangles form one `RTC_GEOMETRY_TYPE_TRIANGLE` mesh (three
//!   vertices each, exactly raylab's coordinates);
//! - all spheres form one `RTC_GEOMETRY_TYPE_SPHERE_POINT` geometry
//!   (centre and radius per point);
//! - each ellipsoid is an `RTC_GEOMETRY_TYPE_INSTANCE` of a shared scene
//!   holding the unit sphere, with the affine map x = R·S·x' + c of
//!   [`Ellipsoid::from_unit`](crate::shape::Ellipsoid::from_unit). Embree
//!   reports the normal in the unit sphere's space; the world normal is the
//!   inverse transpose applied to it, (R·S)⁻ᵀ n'.
//! - infinite planes are left out: Embree has no unbounded primitive, and a
//!   [`Scene`](crate::scene::Scene) tests its planes outside the accelerator
//!   anyway, as it does for every accelerator.
//!
//! Hits map back to raylab's primitive index through per-geometry tables
//! (Embree's `geomID`/`primID`, or `instID` for ellipsoids). For triangles
//! Embree's `u`, `v` are raylab's barycentrics (p = (1−u−v)p0 + u·p1 +
//! v·p2); for the quadrics `u = v = 0`, as raylab's own tests report.
//!
//! The ray interval: raylab asks for hits in the open interval (0, t_max),
//! Embree for hits in the closed [tnear, tfar]. We pass tnear = the
//! smallest normal float (not 0, which the closed interval would include;
//! not a denormal, which DAZ reads as 0) and tfar = the float just below
//! t_max. So both ends are excluded, up to Embree's own rounding there.
//!
//! Counting: Embree's traversal and primitive tests happen inside the
//! library and cannot be counted, so node visits and ray–primitive tests
//! stay at zero. `primitive_hit` is counted once per query that reports a
//! hit (brute force and the BVHs count every closer hit found on the way,
//! so compare those counts only between Embree runs).
//!
//! Why `embree4-sys` alone and not the `embree4-rs` 0.0.16 wrapper: its
//! device, scene and geometry handles are private, so a sphere or instance
//! geometry made through `embree4-sys` cannot join one of its scenes
//! (Embree refuses geometries of another device), a scene cannot be
//! instanced, and it offers no `rtcOccluded1`. Its `intersect_1` also hands
//! Embree the 80-byte `RTCRayHit` of the 4.2 headers, which the 4.4 library
//! overruns (see `device.rs`); and `Device::try_new(Some(..))` passes a
//! configuration string without a terminating NUL.
//!
//! Layout: this file holds the accelerator type [`EmbreeAccel`] (the Embree
//! objects it owns and what each Embree geometry id stands for) and its
//! error type; `config.rs` names the build settings
//! (`embree[:low|medium|high][+robust]`), `scene.rs` builds the Embree scene
//! from raylab's primitives, and `query.rs` traces rays through it (the
//! [`Accel`](super::Accel) implementation and the oracle's
//! [`EmbreeAccel::trace`]). `device.rs` wraps the Embree device and the
//! ray/hit record, `mxcsr.rs` the FTZ/DAZ floating-point modes Embree asks
//! for.

mod config;
mod device;
mod mxcsr;
mod query;
mod scene;

pub use config::{BuildQuality, EmbreeConfig, EMBREE_GRAMMAR};
pub use mxcsr::{enable_ftz_daz, ftz_daz_enabled};
pub use query::EmbreeHit;

use self::device::Device;
use crate::math::Mat3;
use embree4_sys as sys;
use std::fmt;
use std::sync::Arc;

/// What went wrong talking to Embree: the call and Embree's own message.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("Embree: {0}")]
pub struct EmbreeError(String);

impl EmbreeError {
    fn new(message: impl Into<String>) -> Self {
        Self(message.into())
    }
}

/// What an Embree geometry id stands for.
#[derive(Clone, Debug)]
enum Geometry {
    /// The triangle mesh: raylab index of each Embree primitive.
    Triangles(Vec<u32>),
    /// The sphere points: raylab index of each Embree primitive.
    Spheres(Vec<u32>),
    /// An instance of the unit sphere: the raylab index of the ellipsoid
    /// and the inverse transpose that takes normals to world space.
    Ellipsoid { prim: u32, normal_to_world: Mat3 },
}

/// The Embree objects of one accelerator, released together.
struct Inner {
    device: Device,
    scene: sys::RTCScene,
    /// The unit sphere the ellipsoids instance (null without ellipsoids).
    unit_sphere: sys::RTCScene,
    /// Indexed by the geometry id Embree assigned in `scene`.
    geometries: Vec<Geometry>,
    config: EmbreeConfig,
    counts: [usize; 3],
}

// SAFETY: `Inner` owns its scene handles (released once, in `Drop`), its
// device (`Send`, see `device.rs`) and plain data; Embree scenes, like
// devices, are not tied to the thread that made them.
unsafe impl Send for Inner {}
// SAFETY: through a `&Inner` (the `Arc` the render threads share) the scenes
// are only queried, with `rtcIntersect1`/`rtcOccluded1`, which Embree allows
// from any number of threads at once on a committed scene. Every change and
// commit happens in `EmbreeAccel::build`, before the `Arc` exists, and the
// release in `Drop`, after its last owner: queries never overlap either, as
// Embree requires. The device is `Sync` (see `device.rs`).
unsafe impl Sync for Inner {}

impl Drop for Inner {
    fn drop(&mut self) {
        // The scenes go before the device (released after, by its own
        // `Drop`); Embree counts references, so the order is not critical.
        if !self.scene.is_null() {
            // SAFETY: a non-null `scene` is the handle `rtcNewScene` gave
            // `build`, released once, here.
            unsafe { sys::rtcReleaseScene(self.scene) };
        }
        if !self.unit_sphere.is_null() {
            // SAFETY: as for `scene`.
            unsafe { sys::rtcReleaseScene(self.unit_sphere) };
        }
    }
}

/// Embree 4 as a raylab accelerator. Cheap to clone (the Embree scene is
/// shared); safe to query from many threads at once.
#[derive(Clone)]
pub struct EmbreeAccel {
    inner: Arc<Inner>,
}

impl fmt::Debug for EmbreeAccel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let [t, s, e] = self.inner.counts;
        f.debug_struct("EmbreeAccel")
            .field("config", &self.inner.config)
            .field("triangles", &t)
            .field("spheres", &s)
            .field("ellipsoids", &e)
            .finish()
    }
}

/// The version of the Embree library raylab is linked with (e.g. "4.4.0"),
/// for run metadata. Creates and releases a device to ask.
///
/// ```
/// let version = raylab::accel::embree::library_version().unwrap();
/// assert!(version.starts_with("4."));
/// ```
pub fn library_version() -> Result<String, EmbreeError> {
    Ok(Device::new()?.version())
}

#[cfg(test)]
mod tests {
    use crate::shape::{Primitive, Shape};

    /// A primitive of object 0.
    pub(super) fn prim(shape: Shape) -> Primitive {
        Primitive { shape, object: 0 }
    }
}
