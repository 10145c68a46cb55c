//! The scene as the derivative renders see it: a [`View`] whose scalars
//! are dual numbers seeded with the chosen parameters.
//!
//! Every quantity the integrators read (camera frame, hit geometry,
//! materials, point lights, area-light samples, background, ambient) is
//! rebuilt from the scene file's own numbers by the same formulas the
//! loader uses ([`Frame::new`], [`mesh_affine`], the ellipsoid's S⁻¹Rᵀ,
//! [`ShapeR`]), with parameter i's value carrying ∂/∂pᵢ = 1. Entities no
//! parameter touches are read from the `f32` scene as constants.

use super::params::{Entity, Param};
use crate::camera::Frame;
use crate::io::scene_file::{
    face_area_normal, fit_box, load_mesh, mesh_affine, NormalsDef, ScaleDef, SceneFile,
};
use crate::light::{AreaSample, AreaSampleR};
use crate::material::MaterialR;
use crate::math::{Dual, RayR, Real, Vec3, M3, V3};
use crate::scene::{Scene, View};
use crate::shape::triangle::NO_MESH;
use crate::shape::{Hit, HitR, Shape, ShapeR};
use std::path::Path;

/// A mesh whose transform depends on parameters: its own (untransformed)
/// positions and the transform as dual numbers.
struct MeshDual<const K: usize> {
    positions: Vec<Vec3>,
    linear: M3<Dual<K>>,
    offset: V3<Dual<K>>,
    /// N(θ)·N(θ₀)⁻¹: maps the loader's (normalised) normals to the
    /// parameter-dependent ones before renormalising.
    normal: M3<Dual<K>>,
    /// For `normals = "computed"`: the mesh's faces and, per vertex, the
    /// faces around it, to sum the moved faces' normals as the loader does.
    computed: Option<Adjacency>,
}

/// A mesh's faces and, per vertex, the faces around it.
type Adjacency = (Vec<[u32; 3]>, Vec<Vec<u32>>);

impl<const K: usize> MeshDual<K> {
    fn point(&self, k: u32) -> V3<Dual<K>> {
        self.linear
            .mul_vec(V3::from_vec3(self.positions[k as usize]))
            + self.offset
    }

    /// Vertex `k`'s area-weighted normal from the moved faces around it,
    /// normalised ([`crate::io::scene_file::vertex_normals`]).
    fn computed_normal(&self, k: u32) -> V3<Dual<K>> {
        let (faces, around) = self.computed.as_ref().expect("computed normals");
        let mut n = V3::zero();
        for &f in &around[k as usize] {
            n += face_area_normal(faces[f as usize].map(|v| self.point(v)));
        }
        if n.value().length() > 0.0 {
            n.normalize()
        } else {
            n
        }
    }
}

/// What an object's geometry is, if parameters move it.
enum ObjectDual<const K: usize> {
    Shape(ShapeR<Dual<K>>),
    Mesh(Box<MeshDual<K>>),
}

/// The scene over `Dual<K>` for up to K parameters.
pub struct DualScene<'a, const K: usize> {
    scene: &'a Scene,
    camera: Frame<Dual<K>>,
    materials: Vec<MaterialR<Dual<K>>>,
    lights: Vec<(V3<Dual<K>>, V3<Dual<K>>)>,
    /// Per scene object; `None` for objects no parameter moves.
    objects: Vec<Option<ObjectDual<K>>>,
    background: V3<Dual<K>>,
    ambient: V3<Dual<K>>,
}

/// The duals of one field's components: `values` seeded with the
/// parameters among `params` that name (entity, field).
fn seeded<const K: usize>(
    params: &[Param],
    entity: Entity,
    field: &str,
    values: &[f32],
) -> Vec<Dual<K>> {
    values
        .iter()
        .enumerate()
        .map(|(c, &v)| {
            match params
                .iter()
                .position(|p| p.entity == entity && p.field == field && p.component == c)
            {
                Some(i) => Dual::variable(v, i),
                None => Dual::from_f32(v),
            }
        })
        .collect()
}

fn vec3<const K: usize>(d: &[Dual<K>]) -> V3<Dual<K>> {
    V3::new(d[0], d[1], d[2])
}

impl<'a, const K: usize> DualScene<'a, K> {
    /// Seed `params` (at most K) into `scene`, loaded from `file` (read
    /// from `path`, against which mesh files resolve).
    pub fn new(
        scene: &'a Scene,
        file: &SceneFile,
        path: &Path,
        params: &[Param],
    ) -> Result<Self, String> {
        assert!(params.len() <= K, "{} parameters for K = {K}", params.len());
        let touches = |e: Entity| params.iter().any(|p| p.entity == e);
        let seed =
            |e: Entity, field: &str, v: Vec3| vec3(&seeded::<K>(params, e, field, &v.to_array()));
        let scalar = |e: Entity, field: &str, v: f32| seeded::<K>(params, e, field, &[v])[0];

        let c = &file.camera;
        let cam = &scene.camera;
        let aspect = c
            .aspect
            .unwrap_or(cam.width as f32 / cam.height.max(1) as f32);
        let camera = Frame::new(
            seed(Entity::Camera, "eye", c.eye),
            seed(Entity::Camera, "look_at", c.look_at),
            seed(Entity::Camera, "up", c.up),
            scalar(Entity::Camera, "fov", c.fov),
            scalar(Entity::Camera, "aspect", aspect),
            scalar(Entity::Camera, "near", c.near),
        )
        .map_err(|e| format!("[camera]: {e}"))?;

        let materials = scene
            .materials
            .iter()
            .enumerate()
            .map(|(i, m)| {
                let e = Entity::Material(i as u32);
                let mut r = m.real::<Dual<K>>();
                if touches(e) {
                    r.color = seed(e, "color", m.color);
                    r.ambient = scalar(e, "ambient", m.ambient);
                    r.diffuse = scalar(e, "diffuse", m.diffuse);
                    r.specular = scalar(e, "specular", m.specular);
                    r.shininess = scalar(e, "shininess", m.shininess);
                    r.specular_color = seed(e, "specular_color", m.specular_color);
                    r.reflectivity = scalar(e, "reflectivity", m.reflectivity);
                    r.transparency = scalar(e, "transparency", m.transparency);
                    r.ior = scalar(e, "ior", m.ior);
                    r.emission = seed(e, "emission", m.emission);
                }
                r
            })
            .collect();

        let lights = file
            .light
            .iter()
            .enumerate()
            .map(|(i, l)| {
                let (l, e) = (l.get_ref(), Entity::Light(i as u32));
                let colour = seed(e, "color", l.color);
                let intensity = scalar(e, "intensity", l.intensity);
                (seed(e, "position", l.position), colour * intensity)
            })
            .collect();

        // Scene objects are numbered in file order: spheres, ellipsoids,
        // planes, triangles, meshes (as the loader adds them).
        let mut objects: Vec<Option<ObjectDual<K>>> = Vec::with_capacity(scene.objects.len());
        for (i, s) in file.sphere.iter().enumerate() {
            let (s, e) = (s.get_ref(), Entity::Sphere(i as u32));
            objects.push(touches(e).then(|| {
                ObjectDual::Shape(ShapeR::Sphere {
                    centre: seed(e, "center", s.center),
                    radius: scalar(e, "radius", s.radius),
                })
            }));
        }
        for (i, d) in file.ellipsoid.iter().enumerate() {
            let (d, e) = (d.get_ref(), Entity::Ellipsoid(i as u32));
            objects.push(touches(e).then(|| {
                let radii = seed(e, "radii", d.radii);
                let rot = M3::rotation_xyz_degrees(seed(e, "rotate", d.rotate));
                let one = Dual::from_f32(1.0);
                let inv = V3::new(one / radii.x, one / radii.y, one / radii.z);
                ObjectDual::Shape(ShapeR::Ellipsoid {
                    centre: seed(e, "center", d.center),
                    to_unit: M3::diagonal(inv).mul_mat(&rot.transpose()),
                })
            }));
        }
        for (i, p) in file.plane.iter().enumerate() {
            let (p, e) = (p.get_ref(), Entity::Plane(i as u32));
            objects.push(touches(e).then(|| {
                ObjectDual::Shape(ShapeR::Plane {
                    point: seed(e, "point", p.point),
                    normal: seed(e, "normal", p.normal).normalize(),
                })
            }));
        }
        for (i, t) in file.triangle.iter().enumerate() {
            let (t, e) = (t.get_ref(), Entity::Triangle(i as u32));
            objects.push(touches(e).then(|| {
                let flat: Vec<f32> = t.vertices.iter().flat_map(|v| v.to_array()).collect();
                let d = seeded::<K>(params, e, "vertices", &flat);
                ObjectDual::Shape(ShapeR::Triangle {
                    p: [vec3(&d[0..3]), vec3(&d[3..6]), vec3(&d[6..9])],
                })
            }));
        }
        let base = path.parent().unwrap_or(Path::new("."));
        for (i, m) in file.mesh.iter().enumerate() {
            let (m, e) = (m.get_ref(), Entity::Mesh(i as u32));
            if !touches(e) {
                objects.push(None);
                continue;
            }
            let (data, _) = load_mesh(m, base).map_err(|msg| format!("mesh[{i}]: {msg}"))?;
            let scale = match m.scale {
                ScaleDef::Uniform(s) => V3::splat(scalar(e, "scale", s)),
                ScaleDef::PerAxis(v) => seed(e, "scale", v),
            };
            let fit = match m.fit {
                None => None,
                Some(size) => {
                    let (largest, centre) = fit_box(&data.positions)?;
                    Some((scalar(e, "fit", size), largest, centre))
                }
            };
            let (linear, offset, normal) = mesh_affine(
                scale,
                seed(e, "rotate", m.rotate),
                seed(e, "translate", m.translate),
                fit,
            );
            // The loader's normals are N(θ₀)·n normalised; N(θ)·N(θ₀)⁻¹
            // maps them onto N(θ)·n up to a positive factor, which the
            // renormalisation removes. N(θ₀)⁻¹ = (R·S⁻¹)⁻¹ = S·Rᵀ.
            let back = M3::from_rows(
                V3::from_vec3(linear.rows[0].value()),
                V3::from_vec3(linear.rows[1].value()),
                V3::from_vec3(linear.rows[2].value()),
            )
            .transpose(); // N(θ₀)⁻¹ = S·Rᵀ = L(θ₀)ᵀ
            let computed = (m.normals == NormalsDef::Computed).then(|| {
                let mut around = vec![Vec::new(); data.positions.len()];
                for (f, t) in data.triangles.iter().enumerate() {
                    for &k in t {
                        around[k as usize].push(f as u32);
                    }
                }
                (data.triangles.clone(), around)
            });
            objects.push(Some(ObjectDual::Mesh(Box::new(MeshDual {
                positions: data.positions,
                linear,
                offset,
                normal: normal.mul_mat(&back),
                computed,
            }))));
        }
        debug_assert_eq!(objects.len(), scene.objects.len());

        let r = &file.render;
        Ok(Self {
            scene,
            camera,
            materials,
            lights,
            objects,
            background: seed(Entity::Render, "background", r.background),
            ambient: seed(Entity::Render, "ambient", r.ambient),
        })
    }

    /// The geometry of primitive `prim` of object `object` and, for a mesh
    /// triangle with shading normals, its three vertex normals.
    fn shape(&self, prim: u32, object: u32) -> (ShapeR<Dual<K>>, Option<[V3<Dual<K>>; 3]>) {
        let p = &self.scene.prims[prim as usize];
        let mesh_normals = |normal: Option<&M3<Dual<K>>>| -> Option<[V3<Dual<K>>; 3]> {
            let Shape::Triangle(t) = &p.shape else {
                return None;
            };
            if t.mesh == NO_MESH {
                return None;
            }
            let mesh = &self.scene.meshes[t.mesh as usize];
            if mesh.normals.is_empty() {
                return None;
            }
            let idx = mesh.triangles[t.face as usize];
            Some(idx.map(|k| {
                let n = V3::from_vec3(mesh.normals[k as usize]);
                match normal {
                    Some(m) => m.mul_vec(n),
                    None => n,
                }
            }))
        };
        match &self.objects[object as usize] {
            None => (ShapeR::of(p), mesh_normals(None)),
            Some(ObjectDual::Shape(s)) => (*s, None),
            Some(ObjectDual::Mesh(m)) => {
                let Shape::Triangle(t) = &p.shape else {
                    unreachable!("a mesh holds triangles")
                };
                let idx = self.scene.meshes[t.mesh as usize].triangles[t.face as usize];
                let p3 = idx.map(|k| m.point(k));
                let normals = if m.computed.is_some() {
                    Some(idx.map(|k| m.computed_normal(k)))
                } else {
                    mesh_normals(Some(&m.normal))
                };
                (ShapeR::Triangle { p: p3 }, normals)
            }
        }
    }

    /// The camera frame over dual numbers.
    pub fn frame(&self) -> &Frame<Dual<K>> {
        &self.camera
    }

    /// Whether some parameter moves scene object `object`.
    pub fn moves(&self, object: u32) -> bool {
        self.objects[object as usize].is_some()
    }

    /// Primitive `prim`'s geometry as a function of the parameters.
    pub fn geometry(&self, prim: u32) -> ShapeR<Dual<K>> {
        let object = self.scene.prims[prim as usize].object;
        self.shape(prim, object).0
    }

    /// Area of primitive `prim`'s shape: as a dual, and its value.
    fn area(&self, prim: u32) -> Dual<K> {
        let object = self.scene.prims[prim as usize].object;
        self.shape(prim, object).0.area()
    }
}

impl<const K: usize> View for DualScene<'_, K> {
    type R = Dual<K>;

    fn scene(&self) -> &Scene {
        self.scene
    }

    fn camera_ray(&self, x: f32, y: f32) -> RayR<Dual<K>> {
        let c = &self.scene.camera;
        self.camera.ray(x, y, c.width, c.height)
    }

    fn surface(&self, ray: &RayR<Dual<K>>, hit: Hit) -> HitR<Dual<K>> {
        let (shape, normals) = self.shape(hit.prim, hit.object);
        HitR::on(&shape, normals, ray, hit)
    }

    fn material(&self, object: u32) -> MaterialR<Dual<K>> {
        self.materials[self.scene.objects[object as usize].material as usize]
    }

    fn point_light(&self, i: usize) -> (V3<Dual<K>>, V3<Dual<K>>) {
        self.lights[i]
    }

    fn area_sample(&self, s: &AreaSample) -> AreaSampleR<Dual<K>> {
        let object = self.scene.prims[s.prim as usize].object;
        let emission = self.material(object).emission;
        if self.objects[object as usize].is_none() {
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
        if value == 0.0 || self.objects[p.object as usize].is_none() {
            return Dual::from_f32(value);
        }
        let area = self.area(prim);
        Dual::from_f32(value * area.value()) / area
    }

    fn background(&self) -> V3<Dual<K>> {
        self.background
    }

    fn ambient(&self) -> V3<Dual<K>> {
        self.ambient
    }
}
