//! The one scene builder: from a [`SceneDescription`] to the numbers the
//! integrators read, over any [`Real`]. Every formula from the file's
//! numbers to a renderer's lives here once: the camera frame, materials,
//! point lights' radiance, each shape's geometry (a plane's unit normal,
//! an ellipsoid's map to the unit sphere S⁻¹Rᵀ) and a mesh's object
//! transform, vertices and shading normals.
//!
//! The builder reads every number through [`Numbers`]: [`Plain`] gives
//! them as they are (`f32`), which is how [`Scene::build`](super::Scene::build)
//! makes the scene that renders; the derivative code's numbers seed the
//! parameters it differentiates as dual variables, and the same code then
//! builds the scene over dual numbers (`crate::diff::DualScene`). A
//! `Numbers` also says which objects to build: all of them for the `f32`
//! scene, only those a parameter moves for the dual one (the others are
//! the `f32` scene's, as constants), so a dual view of a million-triangle
//! mesh holds nothing it does not need. Meshes read their vertices on
//! demand ([`MeshR::point`]), so a moved mesh is not copied either.

use super::description::{fit_box, MeshDesc, Normals, SceneDescription};
use super::param::{
    CameraField, EllipsoidField, Entity, LightField, MaterialField, MeshField, PlaneField,
    RenderField, SphereField, Target, TriangleField,
};
pub use super::transform::MeshTransform;
use crate::camera::{CameraError, Frame};
use crate::material::MaterialR;
use crate::math::{Real, Vec3, V3};
use crate::shape::{MeshData, ShapeR};
use std::sync::{Arc, OnceLock};

/// How the builder reads the description's numbers, over `R`.
pub trait Numbers<R: Real> {
    /// Whether to build the objects of `entity` over `R` (else they are
    /// left out: see the module docs).
    fn builds(&self, entity: Entity) -> bool;

    /// Component `component` of field `target`, whose value in the
    /// description is `value`.
    fn number(&self, target: Target, component: u32, value: f32) -> R;

    /// The components of `target` that carry more than their value (for
    /// `f32`, none): which of a mesh's vertices to read through
    /// [`Numbers::number`], the others being read as they are.
    fn seeded(&self, target: Target) -> Vec<u32>;

    /// A vector field's three components.
    fn vector(&self, target: Target, v: Vec3) -> V3<R> {
        V3::new(
            self.number(target, 0, v.x),
            self.number(target, 1, v.y),
            self.number(target, 2, v.z),
        )
    }
}

/// The description's numbers as they are, for the `f32` scene.
pub struct Plain;

impl Numbers<f32> for Plain {
    #[inline]
    fn builds(&self, _: Entity) -> bool {
        true
    }
    #[inline]
    fn number(&self, _: Target, _: u32, value: f32) -> f32 {
        value
    }
    fn seeded(&self, _: Target) -> Vec<u32> {
        Vec::new()
    }
}

/// A point light over `R`: its position and radiance (colour ×
/// intensity).
#[derive(Clone, Copy, Debug)]
pub struct LightR<R> {
    pub position: V3<R>,
    pub radiance: V3<R>,
}

/// An object's geometry over `R`.
#[derive(Clone, Debug)]
pub enum ObjectR<R> {
    Shape(ShapeR<R>),
    Mesh(Box<MeshR<R>>),
}

/// The scene's numbers over `R`, as [`build`] makes them.
#[derive(Clone, Debug)]
pub struct SceneNumbers<R> {
    pub camera: Frame<R>,
    /// By material index.
    pub materials: Vec<MaterialR<R>>,
    pub lights: Vec<LightR<R>>,
    /// By object index; `None` for objects the [`Numbers`] did not build.
    pub objects: Vec<Option<ObjectR<R>>>,
    pub background: V3<R>,
    pub ambient: V3<R>,
}

/// Build the scene's numbers from `desc`, reading each through `numbers`.
/// Fails only where the camera's frame is degenerate (the eye at the
/// target, up along the view).
pub fn build<R: Real, N: Numbers<R>>(
    desc: &SceneDescription,
    numbers: &N,
) -> Result<SceneNumbers<R>, CameraError> {
    let n = numbers;
    let c = &desc.camera;
    let aspect = c.aspect_for(desc.width, desc.height);
    let cam = |f| Target::Camera(f);
    let camera = Frame::new(
        n.vector(cam(CameraField::Eye), c.eye),
        n.vector(cam(CameraField::LookAt), c.look_at),
        n.vector(cam(CameraField::Up), c.up),
        n.number(cam(CameraField::Fov), 0, c.fov),
        n.number(cam(CameraField::Aspect), 0, aspect),
        n.number(cam(CameraField::Near), 0, c.near),
    )?;
    let materials = (0..desc.materials.len() as u32)
        .map(|i| material(desc, i, n))
        .collect();
    let lights = desc
        .lights
        .iter()
        .enumerate()
        .map(|(i, l)| {
            let t = |f| Target::Light(i as u32, f);
            let colour = n.vector(t(LightField::Color), l.color);
            let intensity = n.number(t(LightField::Intensity), 0, l.intensity);
            LightR {
                position: n.vector(t(LightField::Position), l.position),
                radiance: colour * intensity,
            }
        })
        .collect();
    let objects = (0..desc.object_count() as u32)
        .map(|o| {
            let entity = desc.object_entity(o);
            n.builds(entity).then(|| object(desc, entity, n))
        })
        .collect();
    let s = &desc.settings;
    let r = |f| Target::Render(f);
    Ok(SceneNumbers {
        camera,
        materials,
        lights,
        objects,
        background: n.vector(r(RenderField::Background), s.background),
        ambient: n.vector(r(RenderField::Ambient), s.ambient),
    })
}

/// Material `i`'s numbers.
fn material<R: Real, N: Numbers<R>>(desc: &SceneDescription, i: u32, n: &N) -> MaterialR<R> {
    let m = &desc.materials[i as usize].material;
    let t = |f| Target::Material(i, f);
    let s = |f, v| n.number(t(f), 0, v);
    let v = |f, v| n.vector(t(f), v);
    MaterialR {
        color: v(MaterialField::Color, m.color),
        ambient: s(MaterialField::Ambient, m.ambient),
        diffuse: s(MaterialField::Diffuse, m.diffuse),
        specular: s(MaterialField::Specular, m.specular),
        shininess: s(MaterialField::Shininess, m.shininess),
        specular_color: v(MaterialField::SpecularColor, m.specular_color),
        reflectivity: s(MaterialField::Reflectivity, m.reflectivity),
        transparency: s(MaterialField::Transparency, m.transparency),
        ior: s(MaterialField::Ior, m.ior),
        emission: v(MaterialField::Emission, m.emission),
        texture: m.texture,
    }
}

/// The geometry of the object `entity` names.
fn object<R: Real, N: Numbers<R>>(desc: &SceneDescription, entity: Entity, n: &N) -> ObjectR<R> {
    ObjectR::Shape(match entity {
        Entity::Sphere(i) => {
            let d = &desc.spheres[i as usize];
            let t = |f| Target::Sphere(i, f);
            ShapeR::Sphere {
                centre: n.vector(t(SphereField::Center), d.center),
                radius: n.number(t(SphereField::Radius), 0, d.radius),
            }
        }
        Entity::Ellipsoid(i) => {
            let d = &desc.ellipsoids[i as usize];
            let t = |f| Target::Ellipsoid(i, f);
            ShapeR::ellipsoid(
                n.vector(t(EllipsoidField::Center), d.center),
                n.vector(t(EllipsoidField::Radii), d.radii),
                n.vector(t(EllipsoidField::Rotate), d.rotate),
            )
        }
        Entity::Plane(i) => {
            let d = &desc.planes[i as usize];
            let t = |f| Target::Plane(i, f);
            ShapeR::Plane {
                point: n.vector(t(PlaneField::Point), d.point),
                normal: n.vector(t(PlaneField::Normal), d.normal).normalize(),
            }
        }
        Entity::Triangle(i) => {
            let d = &desc.triangles[i as usize];
            let t = Target::Triangle(i, TriangleField::Vertices);
            let c = |k: usize| {
                let p = d.vertices[k];
                let at = |a: usize, v: f32| n.number(t, (3 * k + a) as u32, v);
                V3::new(at(0, p.x), at(1, p.y), at(2, p.z))
            };
            ShapeR::Triangle {
                p: [c(0), c(1), c(2)],
            }
        }
        Entity::Mesh(i) => return ObjectR::Mesh(Box::new(MeshR::new(desc, i, n))),
        Entity::Camera | Entity::Render | Entity::Material(_) | Entity::Light(_) => {
            unreachable!("objects are shapes and meshes")
        }
    })
}

/// A mesh over `R`: its data (shared with the description), its
/// transform, and the vertices that carry more than their value.
#[derive(Clone, Debug)]
pub struct MeshR<R> {
    data: Arc<MeshData>,
    transform: MeshTransform<R>,
    normals: Normals,
    /// For `normals = "computed"`: the faces around each vertex, built on
    /// the first [`MeshR::normal`] (a whole mesh's normals, [`MeshR::normals`],
    /// need none).
    around: OnceLock<Adjacency>,
    /// Vertices read through the [`Numbers`] (by vertex), sorted.
    seeded: Vec<(u32, V3<R>)>,
}

impl<R: Real> MeshR<R> {
    fn new<N: Numbers<R>>(desc: &SceneDescription, i: u32, n: &N) -> Self {
        let d: &MeshDesc = &desc.meshes[i as usize];
        let t = |f| Target::Mesh(i, f);
        let scale = match d.scale {
            super::description::Scale::Uniform(s) => V3::splat(n.number(t(MeshField::Scale), 0, s)),
            super::description::Scale::PerAxis(v) => n.vector(t(MeshField::Scale), v),
        };
        let fit = d.fit.map(|size| {
            let (largest, centre) =
                fit_box(&d.data.positions).expect("checked by SceneDescription::check");
            (n.number(t(MeshField::Fit), 0, size), largest, centre)
        });
        let transform = MeshTransform::new(
            scale,
            n.vector(t(MeshField::Rotate), d.rotate),
            n.vector(t(MeshField::Translate), d.translate),
            fit,
        );
        let vertices = t(MeshField::Vertices);
        let mut seeded: Vec<(u32, V3<R>)> = Vec::new();
        for c in n.seeded(vertices) {
            let k = c / 3;
            if seeded.last().is_some_and(|(v, _)| *v == k) {
                continue;
            }
            let p = d.data.positions[k as usize];
            let at = |a: u32, v: f32| n.number(vertices, 3 * k + a, v);
            seeded.push((k, V3::new(at(0, p.x), at(1, p.y), at(2, p.z))));
        }
        Self {
            data: Arc::clone(&d.data),
            transform,
            normals: d.normals,
            around: OnceLock::new(),
            seeded,
        }
    }

    /// The mesh's data in its own coordinates.
    pub fn data(&self) -> &MeshData {
        &self.data
    }

    /// Vertex `k` in its own coordinates.
    #[inline]
    fn own(&self, k: u32) -> V3<R> {
        match self.seeded.binary_search_by_key(&k, |(v, _)| *v) {
            Ok(at) => self.seeded[at].1,
            Err(_) => V3::from_vec3(self.data.positions[k as usize]),
        }
    }

    /// Vertex `k`, placed.
    #[inline]
    pub fn point(&self, k: u32) -> V3<R> {
        self.transform.point(self.own(k))
    }

    /// Whether the mesh shades with interpolated vertex normals.
    pub fn has_normals(&self) -> bool {
        match self.normals {
            Normals::Flat => false,
            Normals::File => !self.data.normals.is_empty(),
            Normals::Computed => true,
        }
    }

    /// Vertex `k`'s shading normal (only where [`MeshR::has_normals`]):
    /// the file's, placed; or, computed, the sum of the (placed) faces'
    /// area-weighted normals around it, normalised.
    pub fn normal(&self, k: u32) -> V3<R> {
        match self.normals {
            Normals::Computed => {
                let around = self.around.get_or_init(|| Adjacency::of(&self.data));
                let mut sum = V3::zero();
                for &f in around.faces_of(k) {
                    let tri = self.data.triangles[f as usize];
                    sum += face_area_normal(tri.map(|v| self.point(v)));
                }
                sum.normalize_or_zero()
            }
            Normals::File | Normals::Flat => self
                .transform
                .normal(V3::from_vec3(self.data.normals[k as usize])),
        }
    }

    /// Every vertex's shading normal (only where [`MeshR::has_normals`]),
    /// equal to [`MeshR::normal`] of each, bit for bit: a computed normal
    /// sums the same faces in the same (face) order, but each face's
    /// normal is computed once rather than once per corner, and no
    /// adjacency is built.
    pub fn normals(&self) -> Vec<V3<R>> {
        let n = self.data.positions.len();
        match self.normals {
            Normals::Computed => {
                let points: Vec<V3<R>> = (0..n as u32).map(|k| self.point(k)).collect();
                let mut sums = vec![V3::zero(); n];
                for tri in &self.data.triangles {
                    let area_normal = face_area_normal(tri.map(|v| points[v as usize]));
                    for &k in tri {
                        sums[k as usize] += area_normal;
                    }
                }
                sums.into_iter().map(V3::normalize_or_zero).collect()
            }
            Normals::File | Normals::Flat => (0..n as u32).map(|k| self.normal(k)).collect(),
        }
    }
}

/// The faces around each vertex of a mesh, in face order (compressed rows:
/// vertex k's faces are `faces[start[k]..start[k + 1]]`).
#[derive(Clone, Debug)]
struct Adjacency {
    start: Vec<u32>,
    faces: Vec<u32>,
}

impl Adjacency {
    fn of(mesh: &MeshData) -> Self {
        let mut start = vec![0u32; mesh.positions.len() + 1];
        for t in &mesh.triangles {
            for &k in t {
                start[k as usize + 1] += 1;
            }
        }
        for k in 0..mesh.positions.len() {
            start[k + 1] += start[k];
        }
        let mut next = start.clone();
        let mut faces = vec![0u32; 3 * mesh.triangles.len()];
        for (f, t) in mesh.triangles.iter().enumerate() {
            for &k in t {
                faces[next[k as usize] as usize] = f as u32;
                next[k as usize] += 1;
            }
        }
        Self { start, faces }
    }

    fn faces_of(&self, k: u32) -> &[u32] {
        &self.faces[self.start[k as usize] as usize..self.start[k as usize + 1] as usize]
    }
}

/// A face's normal scaled by twice its area, (b − a) × (c − a): the terms
/// of a computed vertex normal.
#[inline]
pub fn face_area_normal<R: Real>([a, b, c]: [V3<R>; 3]) -> V3<R> {
    (b - a).cross(c - a)
}
