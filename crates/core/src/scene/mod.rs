//! A scene ready to render: camera, materials, lights, primitives and the
//! accelerator built over them.
//!
//! - [`description`]: the scene as its file describes it (what
//!   [`crate::io::scene_file`] parses a file into, checked);
//! - [`param`]: the description's continuous numbers as typed parameters;
//! - [`build`]: the one builder from a description to the numbers a
//!   renderer reads, over any [`Real`]: [`Scene::build`] makes the `f32`
//!   scene with it, the derivative code its dual-number view.

pub mod build;
pub mod description;
pub mod param;
pub mod transform;

use crate::accel::{Accel, AccelError, AccelKind, Accelerator};
use crate::camera::{Camera, CameraError};
use crate::film::memory::MemoryError;
use crate::film::Filter;
use crate::light::{AreaLights, AreaSample, AreaSampleR, PointLight};
use crate::material::{Material, MaterialR};
use crate::math::{Aabb, RayR, Real, V3};
use crate::math::{Color, Ray, Vec3};
use crate::sampler::Sampler;
use crate::shape::triangle::NO_MESH;
use crate::shape::{Hit, HitR, PreparedRay, PrimHit, Primitive, Shape, Triangle};
use crate::stats::Stats;
use build::{ObjectR, Plain};
use description::{InvalidValue, SceneDescription};

/// What the integrators read of a scene, over a [`Real`] scalar `R`.
///
/// A [`Scene`] is the view with `R = f32`: every method returns what the
/// scene holds, unchanged, so the renders run exactly as if they read the
/// scene directly. The derivative code's view (`crate::diff`) returns the
/// same quantities as dual numbers carrying their derivatives with respect
/// to chosen scene parameters. Traversal is not part of a view: it stays
/// `f32` on [`View::scene`] and only decides which primitive is hit; the
/// view then gives that hit as a function of the parameters
/// ([`View::surface`]).
pub trait View: Sync {
    type R: Real;
    /// The scene traversal and visibility run on.
    fn scene(&self) -> &Scene;
    /// The camera ray through film position (x, y) in pixels.
    fn camera_ray(&self, x: f32, y: f32) -> RayR<Self::R>;
    /// The hit `hit` (found by traversal along `ray.value()`) as a
    /// function of the ray and the primitive's geometry.
    fn surface(&self, ray: &RayR<Self::R>, hit: Hit) -> HitR<Self::R>;
    /// The material of scene object `object`.
    fn material(&self, object: u32) -> MaterialR<Self::R>;
    /// Point light `i`'s position and radiance (colour × intensity).
    fn point_light(&self, i: usize) -> (V3<Self::R>, V3<Self::R>);
    /// The area-light sample `s` (drawn by the scene's `f32` sampler, which
    /// makes the discrete choice of emitter) with its point, normal,
    /// emission and area density as functions of the emitter's parameters.
    fn area_sample(&self, s: &AreaSample) -> AreaSampleR<Self::R>;
    /// The area density with which light sampling picks a point on
    /// primitive `prim` that emits `emission` ([`AreaLights::pdf_area`]).
    fn emitter_pdf(&self, prim: u32, emission: V3<Self::R>) -> Self::R;
    /// Radiance of rays that leave the scene.
    fn background(&self) -> V3<Self::R>;
    /// The ambient light of the Whitted integrator.
    fn ambient(&self) -> V3<Self::R>;
}

impl View for Scene {
    type R = f32;
    #[inline(always)]
    fn scene(&self) -> &Scene {
        self
    }
    #[inline(always)]
    fn camera_ray(&self, x: f32, y: f32) -> RayR<f32> {
        self.camera.generate_ray(x, y).into()
    }
    #[inline(always)]
    fn surface(&self, _: &RayR<f32>, hit: Hit) -> HitR<f32> {
        hit.into()
    }
    #[inline(always)]
    fn material(&self, object: u32) -> MaterialR<f32> {
        self.materials[self.objects[object as usize].material as usize].real()
    }
    #[inline(always)]
    fn point_light(&self, i: usize) -> (V3<f32>, V3<f32>) {
        let l = &self.lights[i];
        (l.position.into(), l.radiance.into())
    }
    #[inline(always)]
    fn area_sample(&self, s: &AreaSample) -> AreaSampleR<f32> {
        (*s).into()
    }
    #[inline(always)]
    fn emitter_pdf(&self, prim: u32, emission: V3<f32>) -> f32 {
        self.area_lights
            .pdf_area(&self.prims[prim as usize], emission.into())
    }
    #[inline(always)]
    fn background(&self) -> V3<f32> {
        self.settings.background.into()
    }
    #[inline(always)]
    fn ambient(&self) -> V3<f32> {
        self.settings.ambient.into()
    }
}

/// Settings that control the integrator, not the geometry.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderSettings {
    /// Colour of rays that hit nothing.
    pub background: Color,
    /// Ambient light colour (multiplied by each material's k_a and colour).
    pub ambient: Color,
    /// Maximum recursion depth: camera rays are depth 0, and no ray of depth
    /// `max_depth` or more is spawned.
    pub max_depth: u32,
    /// Secondary rays whose weight (product of k_r/k_t along the path) falls
    /// below this are not traced.
    pub min_weight: f32,
    /// Rays end after this distance (S2's "maximum distance m").
    pub max_distance: f32,
    pub sampler: Sampler,
    /// How pixels are made from samples (box = each pixel's own mean).
    pub filter: Filter,
    pub seed: u64,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            background: Color::ZERO,
            ambient: Color::ONE,
            max_depth: 5,
            min_weight: 1e-3,
            max_distance: 1e30,
            sampler: Sampler::Centre,
            filter: Filter::Box,
            seed: 0,
        }
    }
}

/// One object of the scene file: a sphere, an ellipsoid, a plane, a
/// triangle or a whole mesh. Primitives point back to their object.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneObject {
    /// A readable name such as `sphere[0]` or `mesh[1] camel.off`.
    pub name: String,
    pub material: u32,
}

/// Per-vertex shading normals of a mesh (empty when the file had none).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshShading {
    pub normals: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
}

#[derive(Clone, Debug)]
pub struct Scene {
    pub camera: Camera,
    pub settings: RenderSettings,
    pub materials: Vec<Material>,
    pub objects: Vec<SceneObject>,
    pub lights: Vec<PointLight>,
    pub prims: Vec<Primitive>,
    /// Primitives without bounds (planes), tested outside the accelerator.
    pub unbounded: Vec<u32>,
    pub meshes: Vec<MeshShading>,
    pub accel: Accelerator,
    /// The emissive triangles and spheres, for light sampling.
    pub area_lights: AreaLights,
}

/// Why a scene description could not become a scene.
#[derive(Debug, Clone, thiserror::Error)]
pub enum SceneError {
    /// A number out of range ([`SceneDescription::check`]).
    #[error(transparent)]
    Invalid(#[from] InvalidValue),
    /// A camera whose frame degenerates.
    #[error("[camera]: {0}")]
    Camera(CameraError),
    /// A film larger than the machine can hold.
    #[error(transparent)]
    Memory(#[from] MemoryError),
    /// An accelerator that could not be built (Embree's or obvhs's
    /// message).
    #[error("accelerator: {0}")]
    Accel(AccelError),
}

/// Not `#[from]`: the variant's message already holds the camera's, so
/// it has no `source` for an error chain to print twice.
impl From<CameraError> for SceneError {
    fn from(e: CameraError) -> Self {
        Self::Camera(e)
    }
}

impl Scene {
    /// Build the scene `desc` describes, after checking its numbers: the
    /// film it renders and its triangles built must fit in memory
    /// ([`crate::film::memory`], `TRIANGLE_BYTES` each), the
    /// geometry comes from the one builder ([`build::build`] over `f32`),
    /// and the accelerator is built over it (which only Embree and obvhs
    /// can fail to do).
    pub fn build(desc: &SceneDescription) -> Result<Self, SceneError> {
        desc.check()?;
        let (width, height) = (desc.width, desc.height);
        let settings = desc.settings;
        let spp = settings.sampler.spp();
        crate::film::memory::check(
            || format!("[image]: a {width}×{height} image at {spp} samples per pixel"),
            // The least any render holds (a PNG); `raylab render` checks
            // again for its output.
            crate::film::memory::render_bytes(&crate::film::memory::RenderHolds {
                width,
                height,
                spp,
                keep_samples: settings.filter != Filter::Box,
                output: crate::film::memory::OutputFormat::Png,
                threads: 1,
            }),
        )?;
        let triangles = desc.triangles.len() as u128
            + desc
                .meshes
                .iter()
                .map(|m| m.data.triangles.len() as u128)
                .sum::<u128>();
        crate::film::memory::check(
            || format!("a scene of {triangles} triangles (their primitives and tree)"),
            triangles * crate::film::memory::TRIANGLE_BYTES,
        )?;
        let numbers = build::build(desc, &Plain)?;
        let camera = Camera::from_frame(&numbers.camera, width, height)?;
        let materials: Vec<Material> = desc.materials.iter().map(|m| m.material).collect();
        let lights = desc
            .lights
            .iter()
            .zip(&numbers.lights)
            .map(|(d, l)| PointLight {
                position: l.position.into(),
                radiance: l.radiance.into(),
                falloff: d.falloff,
                whitted_only: d.whitted_only,
            })
            .collect();
        let mut objects = Vec::with_capacity(numbers.objects.len());
        let mut prims = Vec::new();
        let mut meshes = Vec::new();
        for (o, (object, material)) in numbers
            .objects
            .iter()
            .zip(desc.object_materials())
            .enumerate()
        {
            let entity = desc.object_entity(o as u32);
            let o = o as u32;
            match object.as_ref().expect("the f32 numbers build every object") {
                ObjectR::Shape(s) => {
                    objects.push(SceneObject {
                        name: entity.to_string(),
                        material,
                    });
                    prims.push(Primitive {
                        shape: s.to_shape(),
                        object: o,
                    });
                }
                ObjectR::Mesh(m) => {
                    let param::Entity::Mesh(i) = entity else {
                        unreachable!("meshes are mesh entities")
                    };
                    objects.push(SceneObject {
                        name: format!("{entity} {}", desc.meshes[i as usize].label),
                        material,
                    });
                    let n = m.data().positions.len() as u32;
                    let positions: Vec<Vec3> = (0..n).map(|k| m.point(k).into()).collect();
                    let normals = if m.has_normals() {
                        m.normals().into_iter().map(Vec3::from).collect()
                    } else {
                        Vec::new()
                    };
                    let mesh = meshes.len() as u32;
                    for (face, tri) in m.data().triangles.iter().enumerate() {
                        prims.push(Primitive {
                            shape: Shape::Triangle(Triangle {
                                p: tri.map(|k| positions[k as usize]),
                                mesh,
                                face: face as u32,
                            }),
                            object: o,
                        });
                    }
                    meshes.push(MeshShading {
                        normals,
                        triangles: m.data().triangles.clone(),
                    });
                }
            }
        }
        let (bounded, unbounded): (Vec<u32>, Vec<u32>) =
            (0..prims.len() as u32).partition(|&i| prims[i as usize].bounds().is_some());
        let accel = Accelerator::build(desc.accel, &prims, bounded).map_err(SceneError::Accel)?;
        let area_lights = AreaLights::build(&prims, |object| {
            materials[objects[object as usize].material as usize].emission
        });
        Ok(Self {
            camera,
            settings,
            materials,
            objects,
            lights,
            prims,
            unbounded,
            meshes,
            accel,
            area_lights,
        })
    }

    /// Rebuild the accelerator as another kind.
    pub fn set_accel(&mut self, kind: AccelKind) -> Result<(), AccelError> {
        let bounded = (0..self.prims.len() as u32)
            .filter(|&i| self.prims[i as usize].bounds().is_some())
            .collect();
        self.accel = Accelerator::build(kind, &self.prims, bounded)?;
        Ok(())
    }

    /// Aabb of every bounded primitive.
    pub fn bounds(&self) -> Aabb {
        crate::shape::bounds_of(&self.prims)
    }

    /// Number of triangles in the scene.
    pub fn triangle_count(&self) -> usize {
        crate::shape::triangle_count(&self.prims)
    }

    /// Closest primitive hit in (0, t_max): accelerator plus unbounded
    /// primitives.
    #[inline]
    pub fn intersect_prim<S: Stats>(
        &self,
        ray: &PreparedRay,
        t_max: f32,
        stats: &mut S,
    ) -> Option<(u32, PrimHit)> {
        let mut best = self.accel.intersect(&self.prims, ray, t_max, stats);
        if self.unbounded.is_empty() {
            return best;
        }
        let mut t = best.map_or(t_max, |(_, h)| h.t);
        crate::accel::brute::closest_in(
            &self.prims,
            &self.unbounded,
            ray,
            &mut t,
            &mut best,
            stats,
        );
        best
    }

    /// Closest hit in (0, t_max), with point and normals.
    #[inline]
    pub fn intersect<S: Stats>(&self, ray: &Ray, t_max: f32, stats: &mut S) -> Option<Hit> {
        let pr = PreparedRay::new(*ray);
        let (id, h) = self.intersect_prim(&pr, t_max, stats)?;
        Some(self.hit_details(ray, id, &h))
    }

    /// Whether anything lies on the ray in (0, t_max).
    #[inline]
    pub fn occluded<S: Stats>(&self, ray: &Ray, t_max: f32, stats: &mut S) -> bool {
        let pr = PreparedRay::new(*ray);
        crate::accel::brute::any_in(&self.prims, &self.unbounded, &pr, t_max, stats)
            || self.accel.occluded(&self.prims, &pr, t_max, stats)
    }

    /// Build the full hit record for primitive `id` hit at `h`.
    pub fn hit_details(&self, ray: &Ray, id: u32, h: &PrimHit) -> Hit {
        let prim = &self.prims[id as usize];
        let outward = prim.outward_normal(ray, h);
        let mut shading = outward;
        if let Shape::Triangle(tri) = &prim.shape {
            if tri.mesh != NO_MESH {
                let mesh = &self.meshes[tri.mesh as usize];
                if !mesh.normals.is_empty() {
                    let [a, b, c] = mesh.triangles[tri.face as usize];
                    let n = (1.0 - h.u - h.v) * mesh.normals[a as usize]
                        + h.u * mesh.normals[b as usize]
                        + h.v * mesh.normals[c as usize];
                    // Interpolated normals can vanish or point to the other
                    // side of the geometric one; keep them on its side.
                    if let Some(n) = n.try_normalize() {
                        shading = if n.dot(outward) < 0.0 { -n } else { n };
                    }
                }
            }
        }
        Hit::oriented(ray, h.t, outward, shading, id, prim.object)
    }

    /// The material of a hit's object.
    #[inline]
    pub fn material(&self, hit: &Hit) -> &Material {
        &self.materials[self.objects[hit.object as usize].material as usize]
    }
}
