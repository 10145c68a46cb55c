//! The scene as its file describes it: every number of the file, checked,
//! with meshes read (once) and names resolved to indices, but nothing
//! derived yet. [`crate::io::scene_file`] parses a file into one;
//! [`super::build`] turns one into the numbers a renderer reads, over any
//! [`Real`](crate::math::Real): the `f32` [`Scene`](super::Scene) and the
//! derivative code's dual-number view are built from it by the same code.
//! Parameters ([`super::param`]) read and write its numbers.
//!
//! Objects are numbered in file order by kind: spheres, ellipsoids,
//! planes, triangles, then meshes (as the scene's `objects` are);
//! materials in name order.

use super::param::Entity;
use super::RenderSettings;
use crate::accel::AccelKind;
pub use crate::camera::CameraDesc;
use crate::camera::CameraError;
use crate::light::Falloff;
use crate::material::Material;
use crate::math::{Color, Vec3};
use crate::shape::MeshData;
use std::sync::Arc;

/// A parsed, checked scene file.
#[derive(Clone, Debug)]
pub struct SceneDescription {
    /// Image size in pixels.
    pub width: u32,
    pub height: u32,
    pub camera: CameraDesc,
    pub settings: RenderSettings,
    pub accel: AccelKind,
    /// Materials in name order: the scene's material indices.
    pub materials: Vec<NamedMaterial>,
    pub spheres: Vec<SphereDesc>,
    pub ellipsoids: Vec<EllipsoidDesc>,
    pub planes: Vec<PlaneDesc>,
    pub triangles: Vec<TriangleDesc>,
    pub meshes: Vec<MeshDesc>,
    pub lights: Vec<LightDesc>,
}

/// A material and the name the file gave it.
#[derive(Clone, Debug, PartialEq)]
pub struct NamedMaterial {
    pub name: String,
    pub material: Material,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphereDesc {
    pub center: Vec3,
    pub radius: f32,
    pub material: u32,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EllipsoidDesc {
    pub center: Vec3,
    pub radii: Vec3,
    /// Euler angles in degrees about x, then y, then z.
    pub rotate: Vec3,
    pub material: u32,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlaneDesc {
    pub point: Vec3,
    /// Any non-zero vector; the plane's normal is it normalised.
    pub normal: Vec3,
    pub material: u32,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleDesc {
    pub vertices: [Vec3; 3],
    pub material: u32,
}

/// A mesh's scale: one factor for all axes, or one per axis (as the file
/// writes it: a parameter `mesh[i].scale` has one or three components).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Scale {
    Uniform(f32),
    PerAxis(Vec3),
}

impl Scale {
    /// The factor along each axis.
    pub fn per_axis(self) -> Vec3 {
        match self {
            Scale::Uniform(s) => Vec3::splat(s),
            Scale::PerAxis(v) => v,
        }
    }
}

/// Which shading normals a mesh gets.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Normals {
    /// The file's vertex normals where it has them, else flat.
    #[default]
    File,
    /// Flat shading (geometric normals).
    Flat,
    /// Area-weighted averages of the faces around each vertex (smooth
    /// shading for files without normals).
    Computed,
}

/// A triangle mesh and its object transform: optional fit to a box, then
/// scale, rotate (degrees) and translate.
#[derive(Clone, Debug)]
pub struct MeshDesc {
    /// What the mesh is (its file, or its generator) for names and
    /// messages.
    pub label: String,
    /// The mesh in its own coordinates, read once; shared by the
    /// descriptions cloned from this one until a parameter moves a vertex.
    pub data: Arc<MeshData>,
    /// Scale the mesh's bounding box to this largest side, centred at the
    /// origin, before the rest.
    pub fit: Option<f32>,
    pub scale: Scale,
    pub rotate: Vec3,
    pub translate: Vec3,
    pub normals: Normals,
    pub material: u32,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightDesc {
    pub position: Vec3,
    pub color: Color,
    pub intensity: f32,
    pub falloff: Falloff,
    /// Used by the Whitted integrator only (a stand-in for an emissive
    /// surface, which the path tracer samples instead).
    pub whitted_only: bool,
}

/// A value of a scene description that is out of range: which entity,
/// and what was expected.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{message}")]
pub struct InvalidValue {
    pub entity: Entity,
    pub message: String,
}

impl SceneDescription {
    /// Check every number against its range, entity by entity, in file
    /// order (materials, objects, lights, then `[render]` and `[camera]`,
    /// as the loader reads them): the loader's check, and the check of a
    /// description whose parameters were set to new values (finite
    /// differences, inverse rendering). The error names the entity and the
    /// field.
    pub fn check(&self) -> Result<(), InvalidValue> {
        let bad = |entity: Entity, message: String| Err(InvalidValue { entity, message });
        let finite = |entity: Entity, what: &str, v: Vec3| {
            if v.is_finite() {
                Ok(())
            } else {
                bad(entity, format!("`{what}` must be finite, got {v}"))
            }
        };
        for (i, m) in self.materials.iter().enumerate() {
            m.material.validate().or_else(|msg| {
                bad(
                    Entity::Material(i as u32),
                    format!("material `{}`: {msg}", m.name),
                )
            })?;
        }
        for (i, d) in self.spheres.iter().enumerate() {
            let e = Entity::Sphere(i as u32);
            finite(e, "center", d.center)?;
            if !(d.radius > 0.0 && d.radius.is_finite()) {
                return bad(e, format!("`radius` must be positive, got {}", d.radius));
            }
        }
        for (i, d) in self.ellipsoids.iter().enumerate() {
            let e = Entity::Ellipsoid(i as u32);
            finite(e, "center", d.center)?;
            finite(e, "rotate", d.rotate)?;
            if !(d.radii.is_finite() && d.radii.min_element() > 0.0) {
                return bad(e, format!("`radii` must be positive, got {}", d.radii));
            }
        }
        for (i, d) in self.planes.iter().enumerate() {
            let e = Entity::Plane(i as u32);
            finite(e, "point", d.point)?;
            if !(d.normal.is_finite() && d.normal.length() > 0.0) {
                return bad(
                    e,
                    format!("`normal` must be a non-zero vector, got {}", d.normal),
                );
            }
        }
        for (i, d) in self.triangles.iter().enumerate() {
            for v in d.vertices {
                finite(Entity::Triangle(i as u32), "vertices", v)?;
            }
        }
        for (i, d) in self.meshes.iter().enumerate() {
            d.check().or_else(|msg| bad(Entity::Mesh(i as u32), msg))?;
        }
        for (i, d) in self.lights.iter().enumerate() {
            let e = Entity::Light(i as u32);
            finite(e, "position", d.position)?;
            let radiance = d.color * d.intensity;
            if !(radiance.is_finite() && radiance.min_element() >= 0.0) {
                return bad(e, "light `color` × `intensity` must be non-negative".into());
            }
        }
        let s = &self.settings;
        if s.max_distance.is_nan() || s.max_distance <= 0.0 || !s.min_weight.is_finite() {
            return bad(
                Entity::Render,
                "`max_distance` must be positive and `min_weight` finite".into(),
            );
        }
        for (name, c) in [("background", s.background), ("ambient", s.ambient)] {
            finite(Entity::Render, name, c)?;
        }
        if self.width == 0 || self.height == 0 {
            return bad(
                Entity::Camera,
                CameraError::Size(self.width, self.height).to_string(),
            );
        }
        self.camera.check().map_err(|e| InvalidValue {
            entity: Entity::Camera,
            message: e.to_string(),
        })?;
        Ok(())
    }

    /// How many objects the scene has (spheres, ellipsoids, planes,
    /// triangles and meshes).
    pub fn object_count(&self) -> usize {
        self.spheres.len()
            + self.ellipsoids.len()
            + self.planes.len()
            + self.triangles.len()
            + self.meshes.len()
    }

    /// The entity of scene object `object` (in the numbering of the module
    /// docs).
    pub fn object_entity(&self, object: u32) -> Entity {
        let mut i = object;
        for (n, make) in [
            (self.spheres.len(), Entity::Sphere as fn(u32) -> Entity),
            (self.ellipsoids.len(), Entity::Ellipsoid),
            (self.planes.len(), Entity::Plane),
            (self.triangles.len(), Entity::Triangle),
        ] {
            if (i as usize) < n {
                return make(i);
            }
            i -= n as u32;
        }
        Entity::Mesh(i)
    }

    /// The material of each object, in object order.
    pub fn object_materials(&self) -> impl Iterator<Item = u32> + '_ {
        (self.spheres.iter().map(|d| d.material))
            .chain(self.ellipsoids.iter().map(|d| d.material))
            .chain(self.planes.iter().map(|d| d.material))
            .chain(self.triangles.iter().map(|d| d.material))
            .chain(self.meshes.iter().map(|d| d.material))
    }
}

impl MeshDesc {
    /// The transform's numbers in range, and a box to `fit` to.
    fn check(&self) -> Result<(), String> {
        let scale = self.scale.per_axis();
        if !(scale.is_finite() && scale.abs().min_element() > 0.0) {
            return Err(format!("`scale` must be non-zero and finite, got {scale}"));
        }
        if !(self.rotate.is_finite() && self.translate.is_finite()) {
            return Err("`rotate` and `translate` must be finite".into());
        }
        if let Some(size) = self.fit {
            if !(size > 0.0 && size.is_finite()) {
                return Err(format!("`fit` must be positive, got {size}"));
            }
            fit_box(&self.data.positions)?;
        }
        if self.data.positions.iter().any(|p| !p.is_finite()) {
            return Err("`vertices` must be finite".into());
        }
        Ok(())
    }
}

/// What `fit` needs of a mesh's own positions: the largest extent of their
/// bounding box and its centre.
pub fn fit_box(positions: &[Vec3]) -> Result<(f32, Vec3), String> {
    let (lo, hi) = positions.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), &p| (lo.min(p), hi.max(p)),
    );
    let largest = (hi - lo).max_element();
    if largest.is_nan() || largest <= 0.0 {
        return Err("cannot `fit` a mesh whose bounding box is a point".into());
    }
    Ok((largest, 0.5 * (lo + hi)))
}
