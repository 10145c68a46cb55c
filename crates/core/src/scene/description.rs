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

use super::transform::MeshTransform;
use super::RenderSettings;
use crate::accel::AccelKind;
pub use crate::camera::CameraDesc;
use crate::camera::CameraError;
use crate::light::Falloff;
use crate::material::Material;
use crate::math::{Color, ShowVec, Vec3, MAX_COORDINATE, V3};
use crate::shape::MeshData;
use std::fmt;
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
        // A place in the scene, `reach` being how far its object extends
        // from it (a radius).
        let placed = |entity: Entity, what: &str, v: Vec3, reach: f32| {
            finite(entity, what, v)?;
            if v.abs().max_element() + reach > MAX_COORDINATE {
                return bad(entity, beyond_bound(what, v, reach));
            }
            Ok(())
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
            if !(d.radius > 0.0 && d.radius.is_finite()) {
                return bad(e, format!("`radius` must be positive, got {}", d.radius));
            }
            placed(e, "center", d.center, d.radius)?;
        }
        for (i, d) in self.ellipsoids.iter().enumerate() {
            let e = Entity::Ellipsoid(i as u32);
            finite(e, "rotate", d.rotate)?;
            if !(d.radii.is_finite() && d.radii.min_element() > 0.0) {
                return bad(e, format!("`radii` must be positive, got {}", d.radii));
            }
            placed(e, "center", d.center, d.radii.max_element())?;
        }
        for (i, d) in self.planes.iter().enumerate() {
            let e = Entity::Plane(i as u32);
            placed(e, "point", d.point, 0.0)?;
            let length = d.normal.length();
            if !(length.is_finite() && length > 0.0) {
                return bad(
                    e,
                    format!("`normal` must be a non-zero vector, got {}", d.normal),
                );
            }
        }
        for (i, d) in self.triangles.iter().enumerate() {
            for v in d.vertices {
                placed(Entity::Triangle(i as u32), "vertices", v, 0.0)?;
            }
        }
        for (i, d) in self.meshes.iter().enumerate() {
            d.check().or_else(|msg| bad(Entity::Mesh(i as u32), msg))?;
        }
        for (i, d) in self.lights.iter().enumerate() {
            let e = Entity::Light(i as u32);
            placed(e, "position", d.position, 0.0)?;
            finite(e, "color", d.color)?;
            if !d.intensity.is_finite() {
                return bad(
                    e,
                    format!("`intensity` must be finite, got {}", d.intensity),
                );
            }
            let radiance = d.color * d.intensity;
            if !radiance.is_finite() {
                return bad(
                    e,
                    format!(
                        "`color` × `intensity` = {} × {} overflows single precision \
                         (largest {:e})",
                        ShowVec(d.color),
                        d.intensity,
                        f32::MAX
                    ),
                );
            }
            if radiance.min_element() < 0.0 {
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
        let tree = self.whitted_tree();
        if tree.rays > MAX_WHITTED_TREE as f64 {
            return bad(Entity::Render, tree.refusal(s));
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

/// The most rays one camera ray's Whitted tree may hold (2²⁰): a tree
/// that large costs a camera ray a million rays, a render of a 64×64
/// image four billion. Beyond it a scene is refused before rendering, with
/// the bound and the settings that give it, so that a pair of mirrors at
/// `max_depth = 4294967295` or glass behind glass at `max_depth = 64`
/// (2⁶⁴ rays) cannot start a render that never ends.
pub const MAX_WHITTED_TREE: u64 = 1 << 20;

/// The largest Whitted ray tree a camera ray can grow in a scene
/// ([`SceneDescription::whitted_tree`]).
#[derive(Clone, Debug, PartialEq)]
pub struct WhittedTree {
    /// The bound on the rays of one camera ray's tree (camera ray
    /// included).
    pub rays: f64,
    /// The levels it has (depths 0 … levels − 1).
    pub levels: u64,
    /// Rays a hit may spawn: 2 with a material that both reflects and
    /// refracts, 1 with one that does either, else 0.
    pub branching: u32,
    /// A material that gives `branching`, named for the message.
    pub material: Option<String>,
}

impl WhittedTree {
    /// Why a scene with this tree is refused, and what to change.
    fn refusal(&self, s: &RenderSettings) -> String {
        let why = match &self.material {
            Some(m) if self.branching == 2 => {
                format!("material `{m}` both reflects and refracts, so each hit spawns two rays")
            }
            Some(m) => format!("material `{m}` spawns a ray at each hit"),
            None => String::new(),
        };
        let deepest = (1..=self.levels)
            .take_while(|&d| tree_rays(self.branching, d) <= MAX_WHITTED_TREE as f64)
            .last()
            .unwrap_or(1);
        format!(
            "`max_depth` = {} with `min_weight` = {} lets one camera ray's Whitted ray tree \
             grow to {:.3e} rays ({why}, {} levels deep before the weight cut-off); \
             at most {MAX_WHITTED_TREE} (2^20) are allowed: lower `max_depth` to {deepest} \
             or raise `min_weight`",
            s.max_depth, s.min_weight, self.rays, self.levels
        )
    }
}

/// Rays in a full tree of `levels` levels where each ray spawns
/// `branching`.
fn tree_rays(branching: u32, levels: u64) -> f64 {
    match branching {
        0 => 1.0,
        1 => levels as f64,
        b => (f64::from(b).powf(levels as f64) - 1.0) / (f64::from(b) - 1.0),
    }
}

impl SceneDescription {
    /// The largest tree of rays one camera ray can spawn under Whitted's
    /// rules (`crate::integrator::whitted`): a hit on a material with
    /// transparency k_t > 0 spawns a refracted ray of weight × k_t, one
    /// with reflectivity k_r > 0 a reflected ray of weight × k_r (× (k_r +
    /// k_t) under total internal reflection); no ray of depth `max_depth`
    /// or more, nor of weight below `min_weight`, is spawned. With f the
    /// largest k_r + k_t, weights fall at least as f^depth, so below 1 the
    /// weight cut-off ends every branch after ln(min_weight)/ln(f) levels.
    pub fn whitted_tree(&self) -> WhittedTree {
        let s = &self.settings;
        let mut branching = 0;
        let mut material = None;
        let mut factor = 0.0f64;
        for m in &self.materials {
            let (kr, kt) = (m.material.reflectivity, m.material.transparency);
            let b = u32::from(kr > 0.0) + u32::from(kt > 0.0);
            if b > branching {
                (branching, material) = (b, Some(m.name.clone()));
            }
            if b > 0 {
                factor = factor.max(f64::from(kr.max(0.0)) + f64::from(kt.max(0.0)));
            }
        }
        let mut levels = u64::from(s.max_depth.max(1));
        let min_weight = f64::from(s.min_weight);
        if branching > 0 && factor < 1.0 && min_weight > 0.0 {
            // Depth d is spawned only if factor^d ≥ min_weight.
            let by_weight = if factor <= 0.0 {
                1
            } else {
                (min_weight.ln() / factor.ln()).floor().max(0.0) as u64 + 1
            };
            levels = levels.min(by_weight);
        }
        if branching == 0 {
            levels = 1;
        }
        WhittedTree {
            rays: tree_rays(branching, levels),
            levels,
            branching,
            material,
        }
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
            if fit_box(&self.data.positions).is_none() {
                return Err("cannot `fit` a mesh whose bounding box is a point".into());
            }
        }
        if self.data.positions.iter().any(|p| !p.is_finite()) {
            return Err("`vertices` must be finite".into());
        }
        let (lo, hi) = self.placed_box();
        let reach = lo.abs().max(hi.abs()).max_element();
        if reach.is_nan() || reach > MAX_COORDINATE {
            return Err(format!(
                "placed by `fit`, `scale`, `rotate` and `translate`, the mesh reaches \
                 {reach:e}, beyond ±{MAX_COORDINATE:e}, the largest coordinate raylab's \
                 geometry may have"
            ));
        }
        Ok(())
    }

    /// The box around the placed mesh: its own bounding box's eight
    /// corners, placed (a linear map keeps the mesh inside their hull).
    /// Overflow shows as an infinite or NaN corner.
    fn placed_box(&self) -> (Vec3, Vec3) {
        let own = self.data.positions.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), &p| (lo.min(p), hi.max(p)),
        );
        let fit = self.fit.and_then(|size| {
            fit_box(&self.data.positions).map(|(largest, centre)| (size, largest, centre))
        });
        let t = MeshTransform::<f32>::new(
            V3::from_vec3(self.scale.per_axis()),
            V3::from_vec3(self.rotate),
            V3::from_vec3(self.translate),
            fit,
        );
        (0..8).fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), k| {
                let pick = |bit: u32, a: f32, b: f32| if k & bit == 0 { a } else { b };
                let corner = Vec3::new(
                    pick(1, own.0.x, own.1.x),
                    pick(2, own.0.y, own.1.y),
                    pick(4, own.0.z, own.1.z),
                );
                let p = t.point(V3::from_vec3(corner)).value();
                // NaN (∞ − ∞) must not be lost by min/max.
                let p = if p.is_nan() {
                    Vec3::splat(f32::INFINITY)
                } else {
                    p
                };
                (lo.min(p), hi.max(p))
            },
        )
    }
}

/// The message for a place beyond [`MAX_COORDINATE`].
fn beyond_bound(what: &str, v: Vec3, reach: f32) -> String {
    let extent = if reach > 0.0 {
        format!(" (with the object's reach of {reach:e} from it)")
    } else {
        String::new()
    };
    format!(
        "`{what}` = {} lies beyond ±{MAX_COORDINATE:e}{extent}, the largest coordinate \
         raylab's geometry may have (its ray tests would overflow single precision)",
        ShowVec(v)
    )
}

/// What `fit` needs of a mesh's own positions: the largest extent of their
/// bounding box and its centre; `None` when the box is a point (or
/// empty), which cannot be fitted.
pub(crate) fn fit_box(positions: &[Vec3]) -> Option<(f32, Vec3)> {
    let (lo, hi) = positions.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), &p| (lo.min(p), hi.max(p)),
    );
    let largest = (hi - lo).max_element();
    if largest.is_nan() || largest <= 0.0 {
        return None;
    }
    Some((largest, 0.5 * (lo + hi)))
}

/// A part of the scene: what a parameter belongs to, and what a value
/// out of range is reported against.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Entity {
    Camera,
    Render,
    /// Index in name order (the scene's material index).
    Material(u32),
    Sphere(u32),
    Ellipsoid(u32),
    Plane(u32),
    Triangle(u32),
    Mesh(u32),
    Light(u32),
}

impl fmt::Display for Entity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Entity::Camera => f.write_str("[camera]"),
            Entity::Render => f.write_str("[render]"),
            Entity::Material(i) => write!(f, "material {i}"),
            Entity::Sphere(i) => write!(f, "sphere[{i}]"),
            Entity::Ellipsoid(i) => write!(f, "ellipsoid[{i}]"),
            Entity::Plane(i) => write!(f, "plane[{i}]"),
            Entity::Triangle(i) => write!(f, "triangle[{i}]"),
            Entity::Mesh(i) => write!(f, "mesh[{i}]"),
            Entity::Light(i) => write!(f, "light[{i}]"),
        }
    }
}
