//! The scene as the derivative renders see it: a [`View`] whose scalars
//! are dual numbers seeded with the chosen parameters.
//!
//! Its numbers come from the one scene builder ([`crate::scene::build`]),
//! the code that makes the `f32` scene, run over `Dual<K>` with
//! [`Seeds`]: parameter i's value carries ∂/∂pᵢ = 1. Objects no
//! parameter moves are not built again: they are read from the `f32`
//! scene as constants.

use super::params::MAX_PARAMS;
use crate::camera::{CameraError, Frame};
use crate::light::{AreaSample, AreaSampleR};
use crate::material::MaterialR;
use crate::math::{Dual, RayR, Real, V3};
use crate::scene::build::{build, Numbers, ObjectR, SceneNumbers};
use crate::scene::description::SceneDescription;
use crate::scene::param::{Entity, ParamId, Target};
use crate::scene::{Scene, View};
use crate::shape::triangle::NO_MESH;
use crate::shape::{Hit, HitR, Shape, ShapeR};

/// The builder's numbers over `Dual<K>`: parameter `params[i]` is the
/// variable of partial i, every other number a constant.
pub struct Seeds<'a> {
    params: &'a [ParamId],
}

impl<'a> Seeds<'a> {
    pub fn new(params: &'a [ParamId]) -> Self {
        assert!(params.len() <= MAX_PARAMS);
        Self { params }
    }
}

impl<const K: usize> Numbers<Dual<K>> for Seeds<'_> {
    fn builds(&self, entity: Entity) -> bool {
        self.params.iter().any(|p| p.target.entity() == entity)
    }

    fn number(&self, target: Target, component: u32, value: f32) -> Dual<K> {
        let id = ParamId { target, component };
        match self.params.iter().position(|p| *p == id) {
            Some(i) => Dual::variable(value, i),
            None => Dual::from_f32(value),
        }
    }

    fn seeded(&self, target: Target) -> Vec<u32> {
        let mut c: Vec<u32> = self
            .params
            .iter()
            .filter(|p| p.target == target)
            .map(|p| p.component)
            .collect();
        c.sort_unstable();
        c
    }
}

/// The scene over `Dual<K>` for up to K parameters.
pub struct DualScene<'a, const K: usize> {
    scene: &'a Scene,
    numbers: SceneNumbers<Dual<K>>,
}

impl<'a, const K: usize> DualScene<'a, K> {
    /// Seed `params` (at most K) into the scene `desc` describes, whose
    /// `f32` scene is `scene`.
    pub fn new(
        scene: &'a Scene,
        desc: &SceneDescription,
        params: &[ParamId],
    ) -> Result<Self, CameraError> {
        assert!(params.len() <= K, "{} parameters for K = {K}", params.len());
        let numbers = build(desc, &Seeds::new(params))?;
        debug_assert_eq!(numbers.objects.len(), scene.objects.len());
        Ok(Self { scene, numbers })
    }

    /// The geometry of primitive `prim` of object `object` and, for a mesh
    /// triangle with shading normals, its three vertex normals.
    fn shape(&self, prim: u32, object: u32) -> (ShapeR<Dual<K>>, Option<[V3<Dual<K>>; 3]>) {
        let p = &self.scene.prims[prim as usize];
        match &self.numbers.objects[object as usize] {
            None => {
                let normals = match &p.shape {
                    Shape::Triangle(t) if t.mesh != NO_MESH => {
                        let mesh = &self.scene.meshes[t.mesh as usize];
                        (!mesh.normals.is_empty()).then(|| {
                            mesh.triangles[t.face as usize]
                                .map(|k| V3::from_vec3(mesh.normals[k as usize]))
                        })
                    }
                    _ => None,
                };
                (ShapeR::of(p), normals)
            }
            Some(ObjectR::Shape(s)) => (*s, None),
            Some(ObjectR::Mesh(m)) => {
                let Shape::Triangle(t) = &p.shape else {
                    unreachable!("a mesh holds triangles")
                };
                let idx = m.data().triangles[t.face as usize];
                let normals = m.has_normals().then(|| idx.map(|k| m.normal(k)));
                (
                    ShapeR::Triangle {
                        p: idx.map(|k| m.point(k)),
                    },
                    normals,
                )
            }
        }
    }

    /// The camera frame over dual numbers.
    pub fn frame(&self) -> &Frame<Dual<K>> {
        &self.numbers.camera
    }

    /// Whether some parameter moves scene object `object`.
    pub fn moves(&self, object: u32) -> bool {
        self.numbers.objects[object as usize].is_some()
    }

    /// Primitive `prim`'s geometry as a function of the parameters.
    pub fn geometry(&self, prim: u32) -> ShapeR<Dual<K>> {
        let object = self.scene.prims[prim as usize].object;
        self.shape(prim, object).0
    }

    /// Area of primitive `prim`'s shape, as a dual.
    fn area(&self, prim: u32) -> Dual<K> {
        self.geometry(prim).area()
    }
}

impl<const K: usize> View for DualScene<'_, K> {
    type R = Dual<K>;

    fn scene(&self) -> &Scene {
        self.scene
    }

    fn camera_ray(&self, x: f32, y: f32) -> RayR<Dual<K>> {
        let c = &self.scene.camera;
        self.numbers.camera.ray(x, y, c.width, c.height)
    }

    fn surface(&self, ray: &RayR<Dual<K>>, hit: Hit) -> HitR<Dual<K>> {
        let (shape, normals) = self.shape(hit.prim, hit.object);
        HitR::on(&shape, normals, ray, hit)
    }

    fn material(&self, object: u32) -> MaterialR<Dual<K>> {
        self.numbers.materials[self.scene.objects[object as usize].material as usize]
    }

    fn point_light(&self, i: usize) -> (V3<Dual<K>>, V3<Dual<K>>) {
        let l = &self.numbers.lights[i];
        (l.position, l.radiance)
    }

    fn area_sample(&self, s: &AreaSample) -> AreaSampleR<Dual<K>> {
        let object = self.scene.prims[s.prim as usize].object;
        let emission = self.material(object).emission;
        if !self.moves(object) {
            let mut r = s.real::<Dual<K>>();
            r.emission = emission;
            return r;
        }
        let (shape, _) = self.shape(s.prim, object);
        let (point, normal) = shape.sample_point(s.u);
        // p_A = P(emitter)/A: the choice of emitter is discrete (its
        // probability is not differentiated), the uniform density 1/A is.
        let area = shape.area();
        AreaSampleR {
            point,
            normal,
            emission,
            pdf_area: Dual::from_f32(s.pdf_area * area.value()) / area,
        }
    }

    fn emitter_pdf(&self, prim: u32, emission: V3<Dual<K>>) -> Dual<K> {
        let p = &self.scene.prims[prim as usize];
        let value = self.scene.area_lights.pdf_area(p, emission.value());
        if value == 0.0 || !self.moves(p.object) {
            return Dual::from_f32(value);
        }
        let area = self.area(prim);
        Dual::from_f32(value * area.value()) / area
    }

    fn background(&self) -> V3<Dual<K>> {
        self.numbers.background
    }

    fn ambient(&self) -> V3<Dual<K>> {
        self.numbers.ambient
    }
}
