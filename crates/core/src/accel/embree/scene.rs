//! Building the Embree scene of an [`EmbreeAccel`] from raylab's
//! primitives: one triangle mesh, one sphere-point geometry, one instance of
//! a shared unit sphere per ellipsoid (see [`super`] for why these), each
//! made through an owned geometry handle so that every error path releases
//! what it made. Part of [`crate::accel::embree`].

use super::device::Device;
use super::mxcsr::FtzDazScope;
use super::{EmbreeAccel, EmbreeConfig, EmbreeError, Geometry, Inner};
use crate::shape::{Primitive, Shape};
use embree4_sys as sys;
use std::sync::Arc;

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
        // SAFETY: `self.0` is the non-null handle `rtcNewGeometry` returned
        // (checked in `new`), and this is its owner's one release (a scene it
        // is attached to holds its own reference).
        unsafe { sys::rtcReleaseGeometry(self.0) }
    }
}

impl GeometryHandle {
    fn new(device: &Device, kind: sys::RTCGeometryType) -> Result<Self, EmbreeError> {
        // SAFETY: `device.handle` is a live device (released only when
        // `device` drops); `kind` is a geometry type of the bindings.
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
        if stride == 0 || !bytes.is_multiple_of(stride) {
            return Err(EmbreeError::new(format!(
                "{bytes} bytes of buffer data are not whole items of {stride} bytes"
            )));
        }
        let count = bytes / stride;
        // SAFETY: `self.0` is a live geometry (see `Drop`). Embree allocates
        // count·stride bytes (plus the padding it needs for vector loads)
        // and returns them, or null (checked below).
        let ptr = unsafe { sys::rtcSetNewGeometryBuffer(self.0, kind, 0, format, stride, count) };
        device.check("rtcSetNewGeometryBuffer")?;
        if ptr.is_null() {
            return Err(EmbreeError::new(
                "rtcSetNewGeometryBuffer returned no buffer",
            ));
        }
        // SAFETY: the buffer, non-null, holds count·stride =
        // size_of_val(data) bytes, aligned to 16 (Embree's buffers), more
        // than the f32 and u32 items passed here need; Embree made it
        // fresh, so it does not overlap `data`.
        unsafe {
            std::ptr::copy_nonoverlapping(data.as_ptr(), ptr as *mut T, data.len());
        }
        Ok(())
    }

    /// Commit, then attach to `scene`; returns the geometry id.
    fn commit_and_attach(&self, device: &Device, scene: sys::RTCScene) -> Result<u32, EmbreeError> {
        // SAFETY: `self.0` is a live geometry (see `Drop`), its buffers
        // filled.
        unsafe { sys::rtcCommitGeometry(self.0) };
        // SAFETY: `self.0` is a live geometry and `scene` a live scene
        // (owned by the `Inner` under construction), both of `device`: the
        // pairing Embree requires.
        let id = unsafe { sys::rtcAttachGeometry(scene, self.0) };
        device.check("attaching a geometry")?;
        Ok(id)
    }
}

/// A new scene with the configuration's quality and flags.
fn new_scene(device: &Device, config: EmbreeConfig) -> Result<sys::RTCScene, EmbreeError> {
    // SAFETY: `device.handle` is a live device (released only when
    // `device` drops).
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
    // SAFETY: `scene` is the live, non-null scene just made; the quality
    // is a value of the bindings' enum.
    unsafe { sys::rtcSetSceneBuildQuality(scene, config.quality.to_sys()) };
    // SAFETY: as above, with flags the bindings define.
    unsafe { sys::rtcSetSceneFlags(scene, flags) };
    if let Err(e) = device.check("setting the scene's quality and flags") {
        // SAFETY: the scene is ours and not stored anywhere yet, so this
        // is its one release.
        unsafe { sys::rtcReleaseScene(scene) };
        return Err(e);
    }
    Ok(scene)
}

/// Build the scene's BVH (with FTZ/DAZ on in this thread, as Embree asks).
fn commit_scene(device: &Device, scene: sys::RTCScene) -> Result<(), EmbreeError> {
    {
        let _ftz = FtzDazScope::new();
        // SAFETY: `scene` is a live scene (owned by the `Inner` being
        // built, on this thread only) whose geometries are committed.
        unsafe { sys::rtcCommitScene(scene) };
    }
    device.check("rtcCommitScene")
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
                // SAFETY: `g.0` is a live instance geometry and
                // `inner.unit_sphere` a live, committed scene of the same
                // device.
                unsafe { sys::rtcSetGeometryInstancedScene(g.0, inner.unit_sphere) };
                // SAFETY: `g.0` as above; `xfm` is the 12 floats the declared
                // format reads, alive for the call (Embree copies them).
                unsafe {
                    sys::rtcSetGeometryTransform(
                        g.0,
                        0,
                        sys::RTCFormat::FLOAT3X4_COLUMN_MAJOR,
                        xfm.as_ptr() as *const std::ffi::c_void,
                    )
                };
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
}

#[cfg(test)]
mod tests {
    use super::super::tests::prim;
    use super::*;
    use crate::math::Vec3;
    use crate::shape::Plane;

    #[test]
    fn planes_and_bad_indices_are_errors() {
        let prims = vec![prim(Shape::Plane(Plane::new(Vec3::ZERO, Vec3::Y)))];
        let e = EmbreeAccel::build(&prims, &[0], EmbreeConfig::default()).unwrap_err();
        assert!(e.to_string().contains("plane"), "{e}");
        let e = EmbreeAccel::build(&prims, &[7], EmbreeConfig::default()).unwrap_err();
        assert!(e.to_string().contains("out of range"), "{e}");
    }
}
