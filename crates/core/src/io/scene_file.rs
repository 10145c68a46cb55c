//! Scene files: TOML, parsed with serde into a
//! [`SceneDescription`] (the
//! file's numbers, checked, meshes read once), from which
//! [`Scene::build`] makes the scene. The schema is documented in the
//! book's reference (`book/src/reference/scene-files.md`). Unknown fields,
//! unknown material names, bad values and unreadable meshes are errors
//! that name the file and the line.
//!
//! A [`SceneSource`] keeps the file's text and where each entity is in it,
//! so that an error found later (a parameter set out of range by a
//! finite difference, a camera whose frame degenerates) still names its
//! place, and so that new values of parameters can be written back into
//! the text ([`SceneSource::text_with`]). Parameters set on the command
//! line (`--set PATH=VALUE`) are written into its description and checked
//! by [`SceneSource::set`], before the scene is built.

use super::procedural::Procedural;
use super::{line_col, InputError, Place};
use crate::accel::AccelKind;
use crate::camera::{Camera, CameraDesc};
use crate::film::Filter;
use crate::light::Falloff;
use crate::material::Material;
use crate::math::{Color, Vec3};
use crate::sampler::Sampler;
use crate::scene::description::{
    EllipsoidDesc, LightDesc, MeshDesc, NamedMaterial, Normals, PlaneDesc, Scale, SceneDescription,
    SphereDesc, TriangleDesc,
};
use crate::scene::param::{Entity, SetError, Setting, Target, ValueShape};
use crate::scene::{RenderSettings, Scene, SceneError};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use toml::Spanned;

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    image: ImageDef,
    camera: CameraDef,
    #[serde(default)]
    render: RenderDef,
    #[serde(default)]
    /// Not `Spanned`: toml cannot span a table made by dotted keys
    /// (`m.color = …` under `[materials]`); [`material_spans`] finds them.
    materials: BTreeMap<String, Material>,
    #[serde(default)]
    sphere: Vec<Spanned<SphereDef>>,
    #[serde(default)]
    ellipsoid: Vec<Spanned<EllipsoidDef>>,
    #[serde(default)]
    plane: Vec<Spanned<PlaneDef>>,
    #[serde(default)]
    triangle: Vec<Spanned<TriangleDef>>,
    #[serde(default)]
    mesh: Vec<Spanned<MeshDef>>,
    #[serde(default)]
    light: Vec<Spanned<LightDef>>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct ImageDef {
    width: u32,
    height: u32,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct CameraDef {
    eye: Vec3,
    look_at: Vec3,
    #[serde(default = "default_up")]
    up: Vec3,
    fov: f32,
    #[serde(default = "one")]
    near: f32,
    aspect: Option<f32>,
}

fn default_up() -> Vec3 {
    Vec3::Y
}
fn one() -> f32 {
    1.0
}
fn white() -> Color {
    Color::ONE
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields, default)]
struct RenderDef {
    background: Color,
    ambient: Color,
    max_depth: u32,
    min_weight: f32,
    max_distance: f32,
    sampler: Spanned<String>,
    /// Reconstruction filter: `box`, `tent` or `mitchell`.
    filter: Spanned<String>,
    seed: u64,
    accel: Spanned<String>,
}

impl Default for RenderDef {
    fn default() -> Self {
        let d = RenderSettings::default();
        Self {
            background: d.background,
            ambient: d.ambient,
            max_depth: d.max_depth,
            min_weight: d.min_weight,
            max_distance: d.max_distance,
            sampler: Spanned::new(0..0, "centre".into()),
            filter: Spanned::new(0..0, "box".into()),
            seed: d.seed,
            accel: Spanned::new(0..0, "brute".into()),
        }
    }
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct SphereDef {
    center: Vec3,
    radius: f32,
    material: Spanned<String>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct EllipsoidDef {
    center: Vec3,
    radii: Vec3,
    #[serde(default)]
    rotate: Vec3,
    material: Spanned<String>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct PlaneDef {
    point: Vec3,
    normal: Vec3,
    material: Spanned<String>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct TriangleDef {
    vertices: [Vec3; 3],
    material: Spanned<String>,
}

/// Uniform or per-axis scale, as the file writes it.
#[derive(Deserialize, Debug, Clone, Copy)]
#[serde(untagged)]
enum ScaleDef {
    Uniform(f32),
    PerAxis(Vec3),
}

impl Default for ScaleDef {
    fn default() -> Self {
        ScaleDef::Uniform(1.0)
    }
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct MeshDef {
    /// Mesh file, relative to the scene file (give this or `procedural`).
    file: Option<PathBuf>,
    /// A generated mesh instead of a file, e.g.
    /// `{ kind = "icosphere", level = 6 }`.
    procedural: Option<Procedural>,
    material: Spanned<String>,
    fit: Option<f32>,
    #[serde(default)]
    scale: ScaleDef,
    #[serde(default)]
    rotate: Vec3,
    #[serde(default)]
    translate: Vec3,
    #[serde(default)]
    normals: Normals,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct LightDef {
    position: Vec3,
    #[serde(default = "white")]
    color: Color,
    #[serde(default = "one")]
    intensity: f32,
    #[serde(default)]
    falloff: Falloff,
    #[serde(default)]
    whitted_only: bool,
}

/// Everything that can be overridden from the command line.
#[derive(Clone, Debug, Default)]
pub struct Overrides {
    pub width: Option<u32>,
    pub height: Option<u32>,
    pub sampler: Option<Sampler>,
    pub filter: Option<Filter>,
    pub accel: Option<AccelKind>,
    pub max_depth: Option<u32>,
    pub seed: Option<u64>,
}

impl Overrides {
    /// Apply to a description.
    pub fn apply(&self, d: &mut SceneDescription) {
        d.width = self.width.unwrap_or(d.width);
        d.height = self.height.unwrap_or(d.height);
        let s = &mut d.settings;
        s.sampler = self.sampler.unwrap_or(s.sampler);
        s.filter = self.filter.unwrap_or(s.filter);
        s.max_depth = self.max_depth.unwrap_or(s.max_depth);
        s.seed = self.seed.unwrap_or(s.seed);
        d.accel = self.accel.unwrap_or(d.accel);
    }
}

/// Why a scene file's text could not be rewritten with new values
/// ([`SceneSource::text_with`]).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum RewriteError {
    /// The file's text is not TOML (it changed since it was read).
    #[error("{0}")]
    Parse(toml::de::Error),
    /// A mesh's vertices, which live in the mesh file.
    #[error("a mesh's vertices live in its mesh file, not in the scene file")]
    MeshVertices,
    /// A table the value belongs in that the file lacks (`[camera]`,
    /// `sphere[2]`).
    #[error("the scene file has no {0}")]
    Missing(String),
    /// The rewritten table could not be written as TOML.
    #[error("{0}")]
    Serialise(toml::ser::Error),
}

/// A scene file read: its path, its text, its description, and where each
/// entity is in the text.
#[derive(Clone, Debug)]
pub struct SceneSource {
    pub path: PathBuf,
    pub text: String,
    pub description: SceneDescription,
    /// The byte span of each entity's table, by entity.
    spans: BTreeMap<Entity, Range<usize>>,
}

/// Load and build a scene from a TOML file.
pub fn load_scene(path: &Path, overrides: &Overrides) -> Result<Scene, InputError> {
    SceneSource::load(path, overrides)?.build()
}

/// Build a scene from TOML text; `path` names the file in errors and
/// anchors relative mesh paths.
pub fn parse_scene(text: &str, path: &Path, overrides: &Overrides) -> Result<Scene, InputError> {
    SceneSource::parse(text, path, overrides)?.build()
}

impl SceneSource {
    /// Read and parse the scene file at `path`, with `overrides` applied.
    pub fn load(path: &Path, overrides: &Overrides) -> Result<Self, InputError> {
        let text = super::input::read_to_string(path, super::input::InputKind::Scene)?;
        Self::parse(&text, path, overrides)
    }

    /// Parse scene text; `path` names the file in errors and anchors
    /// relative mesh paths. Every number is checked
    /// ([`SceneDescription::check`]).
    pub fn parse(text: &str, path: &Path, overrides: &Overrides) -> Result<Self, InputError> {
        let mut source = parse_description(text, path)?;
        overrides.apply(&mut source.description);
        source
            .description
            .check()
            .map_err(|e| source.error(SceneError::Invalid(e)))?;
        Ok(source)
    }

    /// Set parameters of the description from the command line (`--set
    /// PATH=VALUE`, [`Setting`]), in order (a later one wins), after the
    /// [`Overrides`]; then check the result as the file was checked
    /// ([`SceneDescription::check`], and the camera's frame, which
    /// building the scene would refuse). An error names the setting after
    /// which the scene stopped being valid, with the message the file
    /// would get. The text stays the file's: after a setting the
    /// description differs from it (errors are still placed in it).
    pub fn set(&mut self, settings: &[Setting]) -> Result<(), SetError> {
        if settings.is_empty() {
            return Ok(());
        }
        let error = |s: &Setting, message: String| SetError {
            path: s.path.clone(),
            message,
        };
        let mut desc = self.description.clone();
        for s in settings {
            desc.apply_setting(s).map_err(|e| error(s, e.message))?;
        }
        if let Err(message) = valid(&desc) {
            // A file whose own scene is invalid (a camera frame that only
            // the build refuses) is left as it is: building it gives the
            // file's error, which comes first.
            if valid(&self.description).is_err() {
                return Ok(());
            }
            // The last setting before which the scene was still valid.
            let mut blamed = 0;
            let mut before = self.description.clone();
            for (k, s) in settings.iter().enumerate().take(settings.len() - 1) {
                // Resolved above, in a description of the same entities.
                let _ = before.apply_setting(s);
                if valid(&before).is_ok() {
                    blamed = k + 1;
                }
            }
            return Err(error(&settings[blamed], message));
        }
        self.description = desc;
        Ok(())
    }

    /// The scene this file describes.
    pub fn build(&self) -> Result<Scene, InputError> {
        self.build_from(&self.description)
    }

    /// The scene of `desc`, a description of this file with new values
    /// (errors placed in this file).
    pub fn build_from(&self, desc: &SceneDescription) -> Result<Scene, InputError> {
        Scene::build(desc).map_err(|e| self.error(e))
    }

    /// An error of this file's scene as an error of the file: at the
    /// table of the entity it concerns, where it has one.
    pub fn error(&self, e: SceneError) -> InputError {
        let at = |entity: Entity, message: String| match self.spans.get(&entity) {
            Some(span) => {
                let (l, c) = line_col(&self.text, span.start);
                InputError::new(&self.path, Place::LineCol(l, c), message)
            }
            None => InputError::file(&self.path, message),
        };
        match e {
            SceneError::Invalid(v) => match v.entity {
                Entity::Camera => InputError::file(&self.path, format!("[camera]: {}", v.message)),
                Entity::Render => InputError::file(&self.path, format!("[render]: {}", v.message)),
                other => at(other, v.message),
            },
            SceneError::Camera(e) => InputError::file(&self.path, format!("[camera]: {e}")),
            SceneError::Memory(e) => InputError::file(&self.path, e.to_string()),
            SceneError::Accel(e) => InputError::file(&self.path, format!("accelerator: {e}")),
        }
    }

    /// This file's text with the values of `targets` taken from `desc` (a
    /// description of this file with new values): each field written
    /// whole, other fields and defaults as they are written (defaults of
    /// the fields written are written out). Comments are not kept.
    pub fn text_with(
        &self,
        desc: &SceneDescription,
        targets: &[Target],
    ) -> Result<String, RewriteError> {
        let mut table: toml::Table = toml::from_str(&self.text).map_err(RewriteError::Parse)?;
        let mut done: Vec<Target> = Vec::new();
        for &t in targets {
            if done.contains(&t) {
                continue;
            }
            done.push(t);
            let values = desc.values(t);
            let num = |v: f32| toml::Value::Float(f64::from(v));
            let new = match desc.shape_of(t) {
                ValueShape::Scalar => num(values[0]),
                ValueShape::Vector => toml::Value::Array(values.iter().map(|&v| num(v)).collect()),
                ValueShape::Points => {
                    if matches!(t, Target::Mesh(..)) {
                        return Err(RewriteError::MeshVertices);
                    }
                    toml::Value::Array(
                        values
                            .chunks(3)
                            .map(|c| toml::Value::Array(c.iter().map(|&v| num(v)).collect()))
                            .collect(),
                    )
                }
            };
            self.section(&mut table, t.entity())?
                .insert(t.key().to_string(), new);
        }
        toml::to_string(&table).map_err(RewriteError::Serialise)
    }

    /// The TOML table of `entity` in the file's document.
    fn section<'t>(
        &self,
        table: &'t mut toml::Table,
        entity: Entity,
    ) -> Result<&'t mut toml::Table, RewriteError> {
        let missing = |what: &str| RewriteError::Missing(what.to_string());
        let array = |key: &str, i: u32, table: &'t mut toml::Table| {
            table
                .get_mut(key)
                .and_then(|a| a.get_mut(i as usize))
                .and_then(|v| v.as_table_mut())
                .ok_or_else(|| missing(&format!("{key}[{i}]")))
        };
        match entity {
            Entity::Camera => table
                .get_mut("camera")
                .and_then(|v| v.as_table_mut())
                .ok_or_else(|| missing("[camera]")),
            Entity::Render => table
                .entry("render")
                .or_insert_with(|| toml::Value::Table(toml::Table::new()))
                .as_table_mut()
                .ok_or_else(|| missing("[render] table")),
            Entity::Material(i) => {
                let name = &self.description.materials[i as usize].name;
                table
                    .get_mut("materials")
                    .and_then(|m| m.get_mut(name.as_str()))
                    .and_then(|v| v.as_table_mut())
                    .ok_or_else(|| missing(&format!("[materials.{name}]")))
            }
            Entity::Sphere(i) => array("sphere", i, table),
            Entity::Ellipsoid(i) => array("ellipsoid", i, table),
            Entity::Plane(i) => array("plane", i, table),
            Entity::Triangle(i) => array("triangle", i, table),
            Entity::Mesh(i) => array("mesh", i, table),
            Entity::Light(i) => array("light", i, table),
        }
    }
}

/// Whether `desc` is a valid scene, as a scene file is checked: the
/// numbers' ranges and the camera's frame; the message is the one a file
/// gets, without the file's name.
fn valid(desc: &SceneDescription) -> Result<(), String> {
    desc.check().map_err(|v| match v.entity {
        Entity::Camera => format!("[camera]: {}", v.message),
        Entity::Render => format!("[render]: {}", v.message),
        _ => v.message,
    })?;
    match Camera::new(&desc.camera, desc.width, desc.height) {
        Ok(_) => Ok(()),
        Err(e) => Err(format!("[camera]: {e}")),
    }
}

/// Parse scene text into its description and the entities' places.
/// Where each material of `[materials]` is defined: its table's header,
/// or for one made by dotted keys (`m.color = …`) its first key.
fn material_spans(text: &str) -> BTreeMap<String, Range<usize>> {
    let Ok(doc) = toml_edit::ImDocument::parse(text) else {
        return BTreeMap::new();
    };
    let Some(table) = doc.get("materials").and_then(|m| m.as_table_like()) else {
        return BTreeMap::new();
    };
    table
        .iter()
        .filter_map(|(name, item)| {
            let key = table.get_key_value(name).and_then(|(k, _)| k.span());
            let span = item.span().or(key)?;
            Some((name.to_string(), span))
        })
        .collect()
}

fn parse_description(text: &str, path: &Path) -> Result<SceneSource, InputError> {
    let at = |span: Range<usize>, msg: String| {
        let (l, c) = line_col(text, span.start);
        InputError::new(path, Place::LineCol(l, c), msg)
    };
    super::toml_numbers::check_floats(text, path)?;
    let file: SceneFile = toml::from_str(text).map_err(|e| match e.span() {
        Some(span) => at(span, super::toml_message(text, &e)),
        None => InputError::file(path, super::toml_message(text, &e)),
    })?;
    let base = path.parent().unwrap_or(Path::new("."));
    let mut spans = BTreeMap::new();

    // Materials by name, in name order.
    let mut materials = Vec::new();
    let material_spans = material_spans(text);
    for (name, m) in &file.materials {
        let span = material_spans.get(name).cloned().unwrap_or(0..0);
        spans.insert(Entity::Material(materials.len() as u32), span);
        materials.push(NamedMaterial {
            name: name.clone(),
            material: *m,
        });
    }
    let material = |m: &Spanned<String>| -> Result<u32, InputError> {
        let name = m.get_ref();
        materials
            .iter()
            .position(|n| &n.name == name)
            .map(|i| i as u32)
            .ok_or_else(|| {
                let known: Vec<_> = materials.iter().map(|k| format!("`{}`", k.name)).collect();
                at(
                    m.span(),
                    format!(
                        "unknown material `{name}` (defined: {})",
                        if known.is_empty() {
                            "none".into()
                        } else {
                            known.join(", ")
                        }
                    ),
                )
            })
    };

    let mut spheres = Vec::new();
    for (i, s) in file.sphere.iter().enumerate() {
        let d = s.get_ref();
        spans.insert(Entity::Sphere(i as u32), s.span());
        spheres.push(SphereDesc {
            center: d.center,
            radius: d.radius,
            material: material(&d.material)?,
        });
    }
    let mut ellipsoids = Vec::new();
    for (i, e) in file.ellipsoid.iter().enumerate() {
        let d = e.get_ref();
        spans.insert(Entity::Ellipsoid(i as u32), e.span());
        ellipsoids.push(EllipsoidDesc {
            center: d.center,
            radii: d.radii,
            rotate: d.rotate,
            material: material(&d.material)?,
        });
    }
    let mut planes = Vec::new();
    for (i, p) in file.plane.iter().enumerate() {
        let d = p.get_ref();
        spans.insert(Entity::Plane(i as u32), p.span());
        planes.push(PlaneDesc {
            point: d.point,
            normal: d.normal,
            material: material(&d.material)?,
        });
    }
    let mut triangles = Vec::new();
    for (i, t) in file.triangle.iter().enumerate() {
        let d = t.get_ref();
        spans.insert(Entity::Triangle(i as u32), t.span());
        triangles.push(TriangleDesc {
            vertices: d.vertices,
            material: material(&d.material)?,
        });
    }
    let mut meshes = Vec::new();
    for (i, m) in file.mesh.iter().enumerate() {
        let (d, span) = (m.get_ref(), m.span());
        spans.insert(Entity::Mesh(i as u32), span.clone());
        let material = material(&d.material)?;
        let (data, label) = load_mesh(d, base).map_err(|msg| at(span.clone(), msg))?;
        meshes.push(MeshDesc {
            label,
            data: Arc::new(data),
            fit: d.fit,
            scale: match d.scale {
                ScaleDef::Uniform(s) => Scale::Uniform(s),
                ScaleDef::PerAxis(v) => Scale::PerAxis(v),
            },
            rotate: d.rotate,
            translate: d.translate,
            normals: d.normals,
            material,
        });
    }
    let mut lights = Vec::new();
    for (i, l) in file.light.iter().enumerate() {
        let d = l.get_ref();
        spans.insert(Entity::Light(i as u32), l.span());
        lights.push(LightDesc {
            position: d.position,
            color: d.color,
            intensity: d.intensity,
            falloff: d.falloff,
            whitted_only: d.whitted_only,
        });
    }

    let r = &file.render;
    let sampler =
        Sampler::parse(r.sampler.get_ref()).map_err(|e| at(r.sampler.span(), e.to_string()))?;
    let filter =
        Filter::parse(r.filter.get_ref()).map_err(|e| at(r.filter.span(), e.to_string()))?;
    let accel = r
        .accel
        .get_ref()
        .parse::<AccelKind>()
        .map_err(|e| at(r.accel.span(), e.to_string()))?;
    let c = &file.camera;
    let description = SceneDescription {
        width: file.image.width,
        height: file.image.height,
        camera: CameraDesc {
            eye: c.eye,
            look_at: c.look_at,
            up: c.up,
            fov: c.fov,
            near: c.near,
            aspect: c.aspect,
        },
        settings: RenderSettings {
            background: r.background,
            ambient: r.ambient,
            max_depth: r.max_depth,
            min_weight: r.min_weight,
            max_distance: r.max_distance,
            sampler,
            filter,
            seed: r.seed,
        },
        accel,
        materials,
        spheres,
        ellipsoids,
        planes,
        triangles,
        meshes,
        lights,
    };
    Ok(SceneSource {
        path: path.to_path_buf(),
        text: text.to_string(),
        description,
        spans,
    })
}

/// The mesh data of a `[[mesh]]` entry and a label for it.
fn load_mesh(d: &MeshDef, base: &Path) -> Result<(super::MeshData, String), String> {
    match (&d.file, &d.procedural) {
        (Some(file), None) => {
            let data = super::read_mesh(&base.join(file))
                .map_err(|e| format!("mesh `{}`: {e}", file.display()))?;
            Ok((data, file.display().to_string()))
        }
        (None, Some(p)) => {
            let data = p.generate().map_err(|e| format!("procedural mesh: {e}"))?;
            Ok((data, format!("{p:?}")))
        }
        _ => Err("a mesh needs exactly one of `file` and `procedural`".into()),
    }
}
