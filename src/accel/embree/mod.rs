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

mod device;
mod mxcsr;

pub use mxcsr::{enable_ftz_daz, ftz_daz_enabled};

use self::device::{Device, RayHit, INVALID_ID};
use self::mxcsr::FtzDazScope;
use super::Accel;
use crate::math::{Mat3, Ray, Vec3};
use crate::shape::{PreparedRay, PrimHit, Primitive, Shape};
use crate::stats::Stats;
use embree4_sys as sys;
use std::fmt;
use std::str::FromStr;
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

/// Embree's BVH build quality (`RTC_BUILD_QUALITY_*`): build time against
/// trace time.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum BuildQuality {
    /// Fast (Morton-code) build, slower traversal.
    Low,
    /// Embree's default: binned SAH.
    #[default]
    Medium,
    /// SAH with spatial splits: slowest build, fastest traversal.
    High,
}

impl BuildQuality {
    fn to_sys(self) -> sys::RTCBuildQuality {
        match self {
            BuildQuality::Low => sys::RTCBuildQuality::LOW,
            BuildQuality::Medium => sys::RTCBuildQuality::MEDIUM,
            BuildQuality::High => sys::RTCBuildQuality::HIGH,
        }
    }

    fn name(self) -> &'static str {
        match self {
            BuildQuality::Low => "low",
            BuildQuality::Medium => "medium",
            BuildQuality::High => "high",
        }
    }
}

/// How to build the Embree scene. Named `embree[:low|medium|high][+robust]`
/// (see [`EMBREE_GRAMMAR`]); plain `embree` is medium quality, not robust.
///
/// ```
/// use raylab::accel::embree::{BuildQuality, EmbreeConfig};
/// let c: EmbreeConfig = "embree:high+robust".parse().unwrap();
/// assert_eq!((c.quality, c.robust), (BuildQuality::High, true));
/// assert_eq!(EmbreeConfig::default().to_string(), "embree");
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct EmbreeConfig {
    pub quality: BuildQuality,
    /// `RTC_SCENE_FLAG_ROBUST`: robust traversal, no optimisations that
    /// trade arithmetic accuracy for speed; meant against rays slipping
    /// between neighbouring triangles (Embree does not promise a watertight
    /// test even so). About a third slower on the camel.
    pub robust: bool,
}

/// The accepted accelerator names, for error messages.
pub const EMBREE_GRAMMAR: &str = "`embree[:low|medium|high][+robust]`";

impl FromStr for EmbreeConfig {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || format!("unknown accelerator `{s}` (expected {EMBREE_GRAMMAR})");
        let rest = s.strip_prefix("embree").ok_or_else(bad)?;
        let (rest, robust) = match rest.strip_suffix("+robust") {
            Some(r) => (r, true),
            None => (rest, false),
        };
        let quality = match rest {
            "" => BuildQuality::Medium,
            ":low" => BuildQuality::Low,
            ":medium" => BuildQuality::Medium,
            ":high" => BuildQuality::High,
            _ => return Err(bad()),
        };
        Ok(Self { quality, robust })
    }
}

impl fmt::Display for EmbreeConfig {
    /// The shortest name that parses back to the same configuration.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "embree")?;
        if self.quality != BuildQuality::Medium {
            write!(f, ":{}", self.quality.name())?;
        }
        if self.robust {
            write!(f, "+robust")?;
        }
        Ok(())
    }
}

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

// SAFETY: a committed Embree scene may be queried from any number of threads
// at once (rtcIntersect1/rtcOccluded1 are thread-safe); nothing mutates the
// scenes after `build`, and they are released only when the last `Arc`
// owner drops.
unsafe impl Send for Inner {}
unsafe impl Sync for Inner {}

impl Drop for Inner {
    fn drop(&mut self) {
        // SAFETY: handles created in `build` and released once, here. The
        // device (released after, by its own Drop) is reference-counted by
        // Embree, so the order is not critical, but scenes go first anyway.
        unsafe {
            if !self.scene.is_null() {
                sys::rtcReleaseScene(self.scene);
            }
            if !self.unit_sphere.is_null() {
                sys::rtcReleaseScene(self.unit_sphere);
            }
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

/// Bytes per item of the buffers we fill: FLOAT3 vertices, UINT3 triangles,
/// FLOAT4 sphere points (centre, radius).
const FLOAT3: usize = 3 * std::mem::size_of::<f32>();
const UINT3: usize = 3 * std::mem::size_of::<u32>();
const FLOAT4: usize = 4 * std::mem::size_of::<f32>();

/// A geometry handle released on every exit path (the scene it is attached
/// to holds its own reference).
struct GeometryHandle(sys::RTCGeometry);

impl Drop for GeometryHandle {
    fn drop(&mut self) {
        // SAFETY: created by rtcNewGeometry, released once.
        unsafe { sys::rtcReleaseGeometry(self.0) }
    }
}

impl GeometryHandle {
    fn new(device: &Device, kind: sys::RTCGeometryType) -> Result<Self, EmbreeError> {
        // SAFETY: valid device.
        let g = unsafe { sys::rtcNewGeometry(device.handle, kind) };
        device.check("rtcNewGeometry")?;
        if g.is_null() {
            return Err(EmbreeError::new("rtcNewGeometry returned no geometry"));
        }
        Ok(Self(g))
    }

    /// A new Embree-owned buffer in slot 0 of items of `stride` bytes,
    /// filled from `data` (a whole number of items).
    fn fill_buffer<T: Copy>(
        &self,
        device: &Device,
        kind: sys::RTCBufferType,
        format: sys::RTCFormat,
        stride: usize,
        data: &[T],
    ) -> Result<(), EmbreeError> {
        let bytes = std::mem::size_of_val(data);
        if stride == 0 || bytes % stride != 0 {
            return Err(EmbreeError::new(format!(
                "{bytes} bytes of buffer data are not whole items of {stride} bytes"
            )));
        }
        let count = bytes / stride;
        // SAFETY: valid geometry. Embree allocates count·stride bytes (plus
        // the padding it needs for vector loads) and returns them.
        let ptr = unsafe { sys::rtcSetNewGeometryBuffer(self.0, kind, 0, format, stride, count) };
        device.check("rtcSetNewGeometryBuffer")?;
        if ptr.is_null() {
            return Err(EmbreeError::new(
                "rtcSetNewGeometryBuffer returned no buffer",
            ));
        }
        // SAFETY: the buffer holds count·stride = size_of_val(data) bytes,
        // suitably aligned for f32/u32 (Embree aligns to 16), and does not
        // overlap `data`.
        unsafe {
            std::ptr::copy_nonoverlapping(data.as_ptr(), ptr as *mut T, data.len());
        }
        Ok(())
    }

    /// Commit, then attach to `scene`; returns the geometry id.
    fn commit_and_attach(&self, device: &Device, scene: sys::RTCScene) -> Result<u32, EmbreeError> {
        // SAFETY: valid geometry and scene of the same device.
        let id = unsafe {
            sys::rtcCommitGeometry(self.0);
            sys::rtcAttachGeometry(scene, self.0)
        };
        device.check("attaching a geometry")?;
        Ok(id)
    }
}

/// A new scene with the configuration's quality and flags.
fn new_scene(device: &Device, config: EmbreeConfig) -> Result<sys::RTCScene, EmbreeError> {
    // SAFETY: valid device.
    let scene = unsafe { sys::rtcNewScene(device.handle) };
    device.check("rtcNewScene")?;
    if scene.is_null() {
        return Err(EmbreeError::new("rtcNewScene returned no scene"));
    }
    let flags = if config.robust {
        sys::RTCSceneFlags::ROBUST
    } else {
        sys::RTCSceneFlags::NONE
    };
    // SAFETY: valid scene.
    unsafe {
        sys::rtcSetSceneBuildQuality(scene, config.quality.to_sys());
        sys::rtcSetSceneFlags(scene, flags);
    }
    if let Err(e) = device.check("setting the scene's quality and flags") {
        // SAFETY: the scene is ours and not stored anywhere yet.
        unsafe { sys::rtcReleaseScene(scene) };
        return Err(e);
    }
    Ok(scene)
}

/// Build the scene's BVH (with FTZ/DAZ on in this thread, as Embree asks).
fn commit_scene(device: &Device, scene: sys::RTCScene) -> Result<(), EmbreeError> {
    {
        let _ftz = FtzDazScope::new();
        // SAFETY: valid scene whose geometries are committed.
        unsafe { sys::rtcCommitScene(scene) };
    }
    device.check("rtcCommitScene")
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
    /// Build an Embree scene over the primitives `ids` (indices into
    /// `prims`). Fails if an index is out of range, a primitive is an
    /// infinite plane (test those outside, as [`Scene`](crate::scene::Scene)
    /// does), or Embree reports an error.
    pub fn build(
        prims: &[Primitive],
        ids: &[u32],
        config: EmbreeConfig,
    ) -> Result<Self, EmbreeError> {
        let device = Device::new()?;
        // From here on, `inner` owns every handle, so an early return
        // releases them.
        let mut inner = Inner {
            scene: std::ptr::null_mut(),
            unit_sphere: std::ptr::null_mut(),
            geometries: Vec::new(),
            config,
            counts: [0; 3],
            device,
        };
        inner.scene = new_scene(&inner.device, config)?;

        let mut tri_ids = Vec::new();
        let mut tri_vertices: Vec<f32> = Vec::new();
        let mut sphere_ids = Vec::new();
        let mut sphere_points: Vec<f32> = Vec::new();
        let mut ellipsoids = Vec::new();
        for &id in ids {
            let prim = prims.get(id as usize).ok_or_else(|| {
                EmbreeError::new(format!(
                    "primitive index {id} out of range ({} primitives)",
                    prims.len()
                ))
            })?;
            match &prim.shape {
                Shape::Triangle(t) => {
                    tri_ids.push(id);
                    tri_vertices.extend(t.p.iter().flat_map(|p| p.to_array()));
                }
                Shape::Sphere(s) => {
                    sphere_ids.push(id);
                    // raylab's sphere test uses r² only, so a negative
                    // radius is the sphere of radius |r|.
                    let c = s.centre;
                    sphere_points.extend([c.x, c.y, c.z, s.radius.abs()]);
                }
                Shape::Ellipsoid(e) => ellipsoids.push((id, *e)),
                Shape::Plane(_) => {
                    return Err(EmbreeError::new(format!(
                        "primitive {id} is an infinite plane, which Embree cannot hold; \
                         test planes outside the accelerator"
                    )))
                }
            }
        }
        inner.counts = [tri_ids.len(), sphere_ids.len(), ellipsoids.len()];

        if !tri_ids.is_empty() {
            let dev = &inner.device;
            let g = GeometryHandle::new(dev, sys::RTCGeometryType::TRIANGLE)?;
            // Three vertices per triangle, unshared: exactly raylab's
            // coordinates (shared edges still have bit-identical ends).
            let count = u32::try_from(3 * tri_ids.len())
                .map_err(|_| EmbreeError::new("more triangles than Embree can index"))?;
            let indices: Vec<u32> = (0..count).collect();
            g.fill_buffer(
                dev,
                sys::RTCBufferType::VERTEX,
                sys::RTCFormat::FLOAT3,
                FLOAT3,
                &tri_vertices,
            )?;
            g.fill_buffer(
                dev,
                sys::RTCBufferType::INDEX,
                sys::RTCFormat::UINT3,
                UINT3,
                &indices,
            )?;
            let geom_id = g.commit_and_attach(dev, inner.scene)?;
            inner.register(geom_id, Geometry::Triangles(tri_ids))?;
        }

        if !sphere_ids.is_empty() {
            let dev = &inner.device;
            let g = GeometryHandle::new(dev, sys::RTCGeometryType::SPHERE_POINT)?;
            g.fill_buffer(
                dev,
                sys::RTCBufferType::VERTEX,
                sys::RTCFormat::FLOAT4,
                FLOAT4,
                &sphere_points,
            )?;
            let geom_id = g.commit_and_attach(dev, inner.scene)?;
            inner.register(geom_id, Geometry::Spheres(sphere_ids))?;
        }

        if !ellipsoids.is_empty() {
            // The unit sphere, committed before the instances that use it
            // (Embree's required order: instanced scene, instance, top).
            inner.unit_sphere = new_scene(&inner.device, config)?;
            let dev = &inner.device;
            let g = GeometryHandle::new(dev, sys::RTCGeometryType::SPHERE_POINT)?;
            g.fill_buffer(
                dev,
                sys::RTCBufferType::VERTEX,
                sys::RTCFormat::FLOAT4,
                FLOAT4,
                &[0.0f32, 0.0, 0.0, 1.0],
            )?;
            g.commit_and_attach(dev, inner.unit_sphere)?;
            drop(g);
            commit_scene(&inner.device, inner.unit_sphere)?;

            for (id, e) in ellipsoids {
                let dev = &inner.device;
                let m = e.from_unit();
                // FLOAT3X4_COLUMN_MAJOR: the three columns of R·S, then the
                // translation.
                let xfm: [f32; 12] = [
                    m.x_axis.x, m.x_axis.y, m.x_axis.z, m.y_axis.x, m.y_axis.y, m.y_axis.z,
                    m.z_axis.x, m.z_axis.y, m.z_axis.z, e.centre.x, e.centre.y, e.centre.z,
                ];
                let g = GeometryHandle::new(dev, sys::RTCGeometryType::INSTANCE)?;
                // SAFETY: valid instance geometry and committed scene; the
                // transform is 12 floats in the declared format.
                unsafe {
                    sys::rtcSetGeometryInstancedScene(g.0, inner.unit_sphere);
                    sys::rtcSetGeometryTransform(
                        g.0,
                        0,
                        sys::RTCFormat::FLOAT3X4_COLUMN_MAJOR,
                        xfm.as_ptr() as *const std::ffi::c_void,
                    );
                }
                dev.check("setting up an ellipsoid instance")?;
                let geom_id = g.commit_and_attach(dev, inner.scene)?;
                // Normals transform by the inverse transpose of the
                // object-to-world map: (R·S)⁻ᵀ = (S⁻¹Rᵀ)ᵀ, the transpose
                // of the ellipsoid's own world-to-unit map.
                let normal_to_world = e.to_unit().transpose();
                inner.register(
                    geom_id,
                    Geometry::Ellipsoid {
                        prim: id,
                        normal_to_world,
                    },
                )?;
            }
        }

        commit_scene(&inner.device, inner.scene)?;
        Ok(Self {
            inner: Arc::new(inner),
        })
    }

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
    /// Record what geometry `id` stands for. Embree numbers geometries
    /// 0, 1, 2, … in attach order; anything else is a surprise we refuse.
    fn register(&mut self, id: u32, g: Geometry) -> Result<(), EmbreeError> {
        if id as usize != self.geometries.len() {
            return Err(EmbreeError::new(format!(
                "Embree gave geometry id {id}, expected {}",
                self.geometries.len()
            )));
        }
        self.geometries.push(g);
        Ok(())
    }

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
    use super::*;
    use crate::shape::{Ellipsoid, Plane, Sphere, Triangle};
    use crate::stats::Counters;

    fn prim(shape: Shape) -> Primitive {
        Primitive { shape, object: 0 }
    }

    #[test]
    fn names_parse_and_print_back() {
        for (name, quality, robust) in [
            ("embree", BuildQuality::Medium, false),
            ("embree:low", BuildQuality::Low, false),
            ("embree:high", BuildQuality::High, false),
            ("embree+robust", BuildQuality::Medium, true),
            ("embree:high+robust", BuildQuality::High, true),
        ] {
            let c: EmbreeConfig = name.parse().unwrap();
            assert_eq!(c, EmbreeConfig { quality, robust });
            assert_eq!(c.to_string(), name);
        }
        assert_eq!(
            "embree:medium".parse::<EmbreeConfig>().unwrap().to_string(),
            "embree"
        );
        for bad in [
            "embre",
            "embree:",
            "embree:fast",
            "embree+robust:high",
            "embree++robust",
            "bvh",
        ] {
            let e = bad.parse::<EmbreeConfig>().unwrap_err();
            assert!(e.contains(bad) && e.contains("embree[:low"), "{e}");
        }
    }

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
    fn planes_and_bad_indices_are_errors() {
        let prims = vec![prim(Shape::Plane(Plane::new(Vec3::ZERO, Vec3::Y)))];
        let e = EmbreeAccel::build(&prims, &[0], EmbreeConfig::default()).unwrap_err();
        assert!(e.to_string().contains("plane"), "{e}");
        let e = EmbreeAccel::build(&prims, &[7], EmbreeConfig::default()).unwrap_err();
        assert!(e.to_string().contains("out of range"), "{e}");
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
