//! Scene parameters: the continuous numbers of a scene description,
//! addressed by typed ids. This is the one table of them: parsing a name
//! (`materials.red.color[0]`, `light[0].position[2]`, `sphere[1].radius`,
//! `triangle[4].vertices[1][0]`, `mesh[0].vertices[10..20]`, `camera.fov`…)
//! into an id, the id's canonical name, reading and writing its value in a
//! [`SceneDescription`], and listing every parameter a scene has. Seeding
//! dual numbers ([`super::build::Numbers`]), the finite-difference check
//! and inverse rendering's updates all go through it.
//!
//! An id is an entity (`sphere[1]`), a field of that entity's kind
//! ([`SphereField::Radius`]: the kinds' field enums make a misspelt field
//! unrepresentable) and a component: 0 for a number, the axis for a
//! vector, 3·vertex + axis for points (a triangle's three `vertices`, or
//! a mesh's `vertices`, every vertex of the mesh in its own coordinates).
//! A [`Selection`] is a contiguous range of one field's components, so
//! a mesh's 10⁵ vertices are one selection, not 3·10⁵ names.
//!
//! A field left at its default (a light's `intensity`) is still a
//! parameter; a field the file does not set and that has no default value
//! to differentiate (`camera.aspect`, which then follows the image size;
//! `mesh[i].fit`) is not. Integers, names, flags, cut-offs and textures are
//! not differentiable, and a name that does not resolve is an error naming
//! what exists where it stopped matching.

use super::description::{Scale, SceneDescription};
use crate::math::Vec3;
use crate::shape::MeshData;
use std::fmt;
use std::ops::Range;
use std::sync::Arc;

/// The part of the scene a parameter belongs to.
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

/// The shape of a field's value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shape {
    /// One number.
    Scalar,
    /// Three numbers (x, y, z or r, g, b).
    Vector,
    /// Points, indexed `[vertex][axis]`: a triangle's three vertices, or
    /// all of a mesh's.
    Points,
}

/// A field enum per entity kind: its variants, their keys in the scene
/// file and their shapes.
macro_rules! fields {
    ($(#[$meta:meta])* $name:ident { $($variant:ident = $key:literal : $shape:ident),* $(,)? }) => {
        $(#[$meta])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
        pub enum $name {
            $($variant),*
        }

        impl $name {
            /// Every field, in the order the scene file reference lists them.
            pub const ALL: &'static [Self] = &[$(Self::$variant),*];

            /// The field's key in the scene file.
            pub fn key(self) -> &'static str {
                match self {
                    $(Self::$variant => $key),*
                }
            }

            /// The field's shape.
            pub fn shape(self) -> Shape {
                match self {
                    $(Self::$variant => Shape::$shape),*
                }
            }

            fn from_key(key: &str) -> Option<Self> {
                Self::ALL.iter().copied().find(|f| f.key() == key)
            }
        }
    };
}

fields!(
    /// The differentiable fields of `[camera]`.
    CameraField {
        Eye = "eye": Vector,
        LookAt = "look_at": Vector,
        Up = "up": Vector,
        Fov = "fov": Scalar,
        Near = "near": Scalar,
        Aspect = "aspect": Scalar,
    }
);
fields!(
    /// The differentiable fields of `[render]`.
    RenderField {
        Background = "background": Vector,
        Ambient = "ambient": Vector,
    }
);
fields!(
    /// The differentiable fields of a `[materials.NAME]` table.
    MaterialField {
        Color = "color": Vector,
        Ambient = "ambient": Scalar,
        Diffuse = "diffuse": Scalar,
        Specular = "specular": Scalar,
        Shininess = "shininess": Scalar,
        SpecularColor = "specular_color": Vector,
        Reflectivity = "reflectivity": Scalar,
        Transparency = "transparency": Scalar,
        Ior = "ior": Scalar,
        Emission = "emission": Vector,
    }
);
fields!(
    /// The differentiable fields of a `[[sphere]]`.
    SphereField {
        Center = "center": Vector,
        Radius = "radius": Scalar,
    }
);
fields!(
    /// The differentiable fields of an `[[ellipsoid]]`.
    EllipsoidField {
        Center = "center": Vector,
        Radii = "radii": Vector,
        Rotate = "rotate": Vector,
    }
);
fields!(
    /// The differentiable fields of a `[[plane]]`.
    PlaneField {
        Point = "point": Vector,
        Normal = "normal": Vector,
    }
);
fields!(
    /// The differentiable fields of a `[[triangle]]`.
    TriangleField {
        Vertices = "vertices": Points,
    }
);
fields!(
    /// The differentiable fields of a `[[mesh]]`: its transform, and the
    /// positions of all its vertices in its own coordinates (before the
    /// transform; not a key of the scene file, which names the mesh's
    /// file).
    MeshField {
        Translate = "translate": Vector,
        Rotate = "rotate": Vector,
        // One number or three, as the file writes it (`Target::len`).
        Scale = "scale": Scalar,
        Fit = "fit": Scalar,
        Vertices = "vertices": Points,
    }
);
fields!(
    /// The differentiable fields of a `[[light]]`.
    LightField {
        Position = "position": Vector,
        Color = "color": Vector,
        Intensity = "intensity": Scalar,
    }
);

/// A field of an entity: what a parameter addresses, short of the
/// component.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Target {
    Camera(CameraField),
    Render(RenderField),
    Material(u32, MaterialField),
    Sphere(u32, SphereField),
    Ellipsoid(u32, EllipsoidField),
    Plane(u32, PlaneField),
    Triangle(u32, TriangleField),
    Mesh(u32, MeshField),
    Light(u32, LightField),
}

impl Target {
    /// The entity the field belongs to.
    pub fn entity(self) -> Entity {
        match self {
            Target::Camera(_) => Entity::Camera,
            Target::Render(_) => Entity::Render,
            Target::Material(i, _) => Entity::Material(i),
            Target::Sphere(i, _) => Entity::Sphere(i),
            Target::Ellipsoid(i, _) => Entity::Ellipsoid(i),
            Target::Plane(i, _) => Entity::Plane(i),
            Target::Triangle(i, _) => Entity::Triangle(i),
            Target::Mesh(i, _) => Entity::Mesh(i),
            Target::Light(i, _) => Entity::Light(i),
        }
    }

    /// The field's key in the scene file.
    pub fn key(self) -> &'static str {
        match self {
            Target::Camera(f) => f.key(),
            Target::Render(f) => f.key(),
            Target::Material(_, f) => f.key(),
            Target::Sphere(_, f) => f.key(),
            Target::Ellipsoid(_, f) => f.key(),
            Target::Plane(_, f) => f.key(),
            Target::Triangle(_, f) => f.key(),
            Target::Mesh(_, f) => f.key(),
            Target::Light(_, f) => f.key(),
        }
    }

    /// The field's shape as declared (a mesh's `scale` may be a vector in
    /// a given file: [`SceneDescription::shape_of`]).
    fn declared_shape(self) -> Shape {
        match self {
            Target::Camera(f) => f.shape(),
            Target::Render(f) => f.shape(),
            Target::Material(_, f) => f.shape(),
            Target::Sphere(_, f) => f.shape(),
            Target::Ellipsoid(_, f) => f.shape(),
            Target::Plane(_, f) => f.shape(),
            Target::Triangle(_, f) => f.shape(),
            Target::Mesh(_, f) => f.shape(),
            Target::Light(_, f) => f.shape(),
        }
    }
}

/// One number of the scene: a field and a component of it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct ParamId {
    pub target: Target,
    pub component: u32,
}

/// Components `components` of one field: what a parameter name selects.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Selection {
    pub target: Target,
    pub components: Range<u32>,
}

impl Selection {
    /// The selected numbers' ids, in component order.
    pub fn ids(&self) -> impl Iterator<Item = ParamId> + '_ {
        self.components.clone().map(|component| ParamId {
            target: self.target,
            component,
        })
    }

    /// How many numbers it selects.
    pub fn len(&self) -> usize {
        self.components.len()
    }

    pub fn is_empty(&self) -> bool {
        self.components.is_empty()
    }
}

/// A parameter name that does not resolve: the name and why.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("parameter `{path}`: {message}")]
pub struct ParamError {
    pub path: String,
    pub message: String,
}

/// Fields that exist but are not differentiable, and why.
const NOT_DIFFERENTIABLE: &[(&str, &str)] = &[
    ("material", "a material name"),
    ("texture", "textures are not differentiable parameters"),
    ("falloff", "a choice, not a number"),
    ("whitted_only", "a flag"),
    ("file", "a file name"),
    ("procedural", "a generator's settings"),
    ("normals", "a choice, not a number"),
    ("width", "an integer"),
    ("height", "an integer"),
    ("max_depth", "an integer"),
    ("seed", "an integer"),
    ("sampler", "a name"),
    ("filter", "a name"),
    ("accel", "a name"),
    ("min_weight", "a cut-off (the image jumps where it acts)"),
    ("max_distance", "a cut-off (the image jumps where it acts)"),
];

/// Top-level sections of a scene file.
const SECTIONS: &str = "`camera`, `render`, `materials.NAME`, `sphere[i]`, `ellipsoid[i]`, \
                        `plane[i]`, `triangle[i]`, `mesh[i]`, `light[i]`";

/// One index of a path step: `[n]` or `[a..b]`.
#[derive(Clone, Debug, PartialEq)]
enum Index {
    One(u32),
    Range(u32, u32),
}

/// One `name[i][j]` step of a path.
#[derive(Debug, PartialEq)]
struct Step<'a> {
    name: &'a str,
    indices: Vec<Index>,
}

fn parse_steps(path: &str) -> Result<Vec<Step<'_>>, String> {
    if path.is_empty() {
        return Err("empty name".into());
    }
    segments(path)
        .map(|seg| {
            let (name, mut rest) = match seg.find('[') {
                Some(i) => (&seg[..i], &seg[i..]),
                None => (seg, ""),
            };
            if name.is_empty() {
                return Err(format!("`{seg}` has no field name"));
            }
            let mut indices = Vec::new();
            while !rest.is_empty() {
                let close = rest
                    .find(']')
                    .filter(|_| rest.starts_with('['))
                    .ok_or_else(|| format!("malformed index in `{seg}` (expected `[n]`)"))?;
                let inner = &rest[1..close];
                let number = |s: &str| {
                    s.parse::<u32>().map_err(|_| {
                        format!("index `{inner}` in `{seg}` is not a non-negative integer")
                    })
                };
                indices.push(match inner.split_once("..") {
                    Some((a, b)) => Index::Range(number(a)?, number(b)?),
                    None => Index::One(number(inner)?),
                });
                rest = &rest[close + 1..];
            }
            Ok(Step { name, indices })
        })
        .collect()
}

/// The `.`-separated segments of a path, leaving the `..` of an index
/// range (`vertices[1..3]`) inside its segment.
fn segments(path: &str) -> impl Iterator<Item = &str> {
    let mut depth = 0i32;
    path.split(move |c| {
        match c {
            '[' => depth += 1,
            ']' => depth -= 1,
            _ => {}
        }
        c == '.' && depth == 0
    })
}

fn list(items: impl Iterator<Item = String>) -> String {
    let v: Vec<String> = items.map(|s| format!("`{s}`")).collect();
    if v.is_empty() {
        "none".into()
    } else {
        v.join(", ")
    }
}

/// Where each field's numbers live in a description, written once for
/// shared and mutable access ([`SceneDescription::numbers`] and
/// [`SceneDescription::numbers_mut`]): `$($mut)?` is empty or `mut`.
macro_rules! field_numbers {
    ($desc:expr, $target:expr $(, $mut:tt)?) => {{
        let d = $desc;
        match $target {
            Target::Camera(f) => {
                let c = & $($mut)? d.camera;
                match f {
                    CameraField::Eye => (& $($mut)? c.eye).floats(),
                    CameraField::LookAt => (& $($mut)? c.look_at).floats(),
                    CameraField::Up => (& $($mut)? c.up).floats(),
                    CameraField::Fov => (& $($mut)? c.fov).floats(),
                    CameraField::Near => (& $($mut)? c.near).floats(),
                    CameraField::Aspect => (& $($mut)? c.aspect).floats(),
                }
            }
            Target::Render(f) => {
                let r = & $($mut)? d.settings;
                match f {
                    RenderField::Background => (& $($mut)? r.background).floats(),
                    RenderField::Ambient => (& $($mut)? r.ambient).floats(),
                }
            }
            Target::Material(i, f) => {
                let m = & $($mut)? d.materials[i as usize].material;
                match f {
                    MaterialField::Color => (& $($mut)? m.color).floats(),
                    MaterialField::Ambient => (& $($mut)? m.ambient).floats(),
                    MaterialField::Diffuse => (& $($mut)? m.diffuse).floats(),
                    MaterialField::Specular => (& $($mut)? m.specular).floats(),
                    MaterialField::Shininess => (& $($mut)? m.shininess).floats(),
                    MaterialField::SpecularColor => (& $($mut)? m.specular_color).floats(),
                    MaterialField::Reflectivity => (& $($mut)? m.reflectivity).floats(),
                    MaterialField::Transparency => (& $($mut)? m.transparency).floats(),
                    MaterialField::Ior => (& $($mut)? m.ior).floats(),
                    MaterialField::Emission => (& $($mut)? m.emission).floats(),
                }
            }
            Target::Sphere(i, f) => {
                let s = & $($mut)? d.spheres[i as usize];
                match f {
                    SphereField::Center => (& $($mut)? s.center).floats(),
                    SphereField::Radius => (& $($mut)? s.radius).floats(),
                }
            }
            Target::Ellipsoid(i, f) => {
                let e = & $($mut)? d.ellipsoids[i as usize];
                match f {
                    EllipsoidField::Center => (& $($mut)? e.center).floats(),
                    EllipsoidField::Radii => (& $($mut)? e.radii).floats(),
                    EllipsoidField::Rotate => (& $($mut)? e.rotate).floats(),
                }
            }
            Target::Plane(i, f) => {
                let p = & $($mut)? d.planes[i as usize];
                match f {
                    PlaneField::Point => (& $($mut)? p.point).floats(),
                    PlaneField::Normal => (& $($mut)? p.normal).floats(),
                }
            }
            Target::Triangle(i, TriangleField::Vertices) => {
                (& $($mut)? d.triangles[i as usize].vertices).floats()
            }
            Target::Mesh(i, f) => {
                let m = & $($mut)? d.meshes[i as usize];
                match f {
                    MeshField::Translate => (& $($mut)? m.translate).floats(),
                    MeshField::Rotate => (& $($mut)? m.rotate).floats(),
                    MeshField::Scale => (& $($mut)? m.scale).floats(),
                    MeshField::Fit => (& $($mut)? m.fit).floats(),
                    MeshField::Vertices => (& $($mut)? m.data).floats(),
                }
            }
            Target::Light(i, f) => {
                let l = & $($mut)? d.lights[i as usize];
                match f {
                    LightField::Position => (& $($mut)? l.position).floats(),
                    LightField::Color => (& $($mut)? l.color).floats(),
                    LightField::Intensity => (& $($mut)? l.intensity).floats(),
                }
            }
        }
    }};
}

/// A field's storage as a slice of `f32`: shared or mutable, so that
/// [`field_numbers`] is written once.
trait Floats {
    type Slice;
    fn floats(self) -> Self::Slice;
}

impl<'a> Floats for &'a f32 {
    type Slice = &'a [f32];
    fn floats(self) -> &'a [f32] {
        std::slice::from_ref(self)
    }
}

impl<'a> Floats for &'a mut f32 {
    type Slice = &'a mut [f32];
    fn floats(self) -> &'a mut [f32] {
        std::slice::from_mut(self)
    }
}

impl<'a> Floats for &'a Vec3 {
    type Slice = &'a [f32];
    fn floats(self) -> &'a [f32] {
        AsRef::<[f32; 3]>::as_ref(self)
    }
}

impl<'a> Floats for &'a mut Vec3 {
    type Slice = &'a mut [f32];
    fn floats(self) -> &'a mut [f32] {
        AsMut::<[f32; 3]>::as_mut(self)
    }
}

impl<'a> Floats for &'a [Vec3; 3] {
    type Slice = &'a [f32];
    fn floats(self) -> &'a [f32] {
        bytemuck::cast_slice(self)
    }
}

impl<'a> Floats for &'a mut [Vec3; 3] {
    type Slice = &'a mut [f32];
    fn floats(self) -> &'a mut [f32] {
        bytemuck::cast_slice_mut(self)
    }
}

/// An optional field is a parameter only where it is set
/// ([`SceneDescription::len_of`] refuses the others).
impl<'a> Floats for &'a Option<f32> {
    type Slice = &'a [f32];
    fn floats(self) -> &'a [f32] {
        self.as_ref()
            .expect("a parameter of an unset optional field")
            .floats()
    }
}

impl<'a> Floats for &'a mut Option<f32> {
    type Slice = &'a mut [f32];
    fn floats(self) -> &'a mut [f32] {
        self.as_mut()
            .expect("a parameter of an unset optional field")
            .floats()
    }
}

impl<'a> Floats for &'a Scale {
    type Slice = &'a [f32];
    fn floats(self) -> &'a [f32] {
        match self {
            Scale::Uniform(s) => s.floats(),
            Scale::PerAxis(v) => v.floats(),
        }
    }
}

impl<'a> Floats for &'a mut Scale {
    type Slice = &'a mut [f32];
    fn floats(self) -> &'a mut [f32] {
        match self {
            Scale::Uniform(s) => s.floats(),
            Scale::PerAxis(v) => v.floats(),
        }
    }
}

/// A mesh's vertex positions (copied first, when written, if another
/// description shares them).
impl<'a> Floats for &'a Arc<MeshData> {
    type Slice = &'a [f32];
    fn floats(self) -> &'a [f32] {
        bytemuck::cast_slice(&self.positions)
    }
}

impl<'a> Floats for &'a mut Arc<MeshData> {
    type Slice = &'a mut [f32];
    fn floats(self) -> &'a mut [f32] {
        bytemuck::cast_slice_mut(&mut Arc::make_mut(self).positions)
    }
}

impl SceneDescription {
    /// Resolve a parameter name into the components it selects (a field
    /// without an index is all of them).
    pub fn select(&self, path: &str) -> Result<Selection, ParamError> {
        self.select_steps(path).map_err(|message| ParamError {
            path: path.to_string(),
            message,
        })
    }

    fn select_steps(&self, path: &str) -> Result<Selection, String> {
        let steps = parse_steps(path)?;
        let (entity, rest) = self.entity_of(&steps)?;
        let prefix = self.entity_name(entity);
        let fields = || {
            list(
                self.field_keys(entity)
                    .iter()
                    .map(|f| format!("{prefix}.{f}")),
            )
        };
        let [field_step] = rest else {
            return Err(if rest.is_empty() {
                format!("name a field: {}", fields())
            } else {
                format!("`{}` has no sub-fields", rest[0].name)
            });
        };
        let Some(target) = field_of(entity, field_step.name) else {
            if let Some((_, why)) = NOT_DIFFERENTIABLE
                .iter()
                .find(|(f, _)| *f == field_step.name)
            {
                return Err(format!(
                    "`{}` is not differentiable ({why}); differentiable here: {}",
                    field_step.name,
                    fields()
                ));
            }
            return Err(format!(
                "no field `{}` (differentiable here: {})",
                field_step.name,
                fields()
            ));
        };
        let full = format!("{prefix}.{}", target.key());
        let len = self
            .len_of(target)
            .map_err(|why| format!("`{full}` {why}"))?;
        let components = match (self.shape_of(target), field_step.indices.as_slice()) {
            (_, []) => 0..len,
            (Shape::Vector, [Index::One(c)]) if *c < 3 => *c..c + 1,
            (Shape::Points, [Index::One(v)]) if 3 * v < len => 3 * v..3 * v + 3,
            (Shape::Points, [Index::Range(a, b)]) if a < b && 3 * b <= len => 3 * a..3 * b,
            (Shape::Points, [Index::One(v), Index::One(c)]) if 3 * v < len && *c < 3 => {
                3 * v + c..3 * v + c + 1
            }
            (Shape::Scalar, _) => return Err(format!("`{full}` is a number and takes no index")),
            (Shape::Vector, _) => {
                return Err(format!(
                    "`{full}` is a vector: index it with [0], [1] or [2], or not at all"
                ))
            }
            (Shape::Points, _) => {
                return Err(format!(
                    "`{full}` holds {} points: index it as [vertex][axis] (axis 0…2), \
                     [vertex], [first..end] or not at all",
                    len / 3
                ))
            }
        };
        Ok(Selection { target, components })
    }

    /// The entity the first steps of a path name, and the steps left.
    fn entity_of<'s, 'a>(&self, steps: &'s [Step<'a>]) -> Result<(Entity, &'s [Step<'a>]), String> {
        let first = &steps[0];
        let no_index = |s: &Step| {
            if s.indices.is_empty() {
                Ok(())
            } else {
                Err(format!("`{}` takes no index", s.name))
            }
        };
        let indexed = |s: &Step, count: usize| -> Result<u32, String> {
            match s.indices.as_slice() {
                [Index::One(i)] if (*i as usize) < count => Ok(*i),
                [Index::One(i)] => Err(format!(
                    "the scene has {count} `[[{}]]` entr{} ({}), not index {i}",
                    s.name,
                    if count == 1 { "y" } else { "ies" },
                    if count == 0 {
                        "none".to_string()
                    } else {
                        format!("{}[0]…{}[{}]", s.name, s.name, count - 1)
                    }
                )),
                _ => Err(format!(
                    "`{}` needs one index, e.g. `{}[0]`",
                    s.name, s.name
                )),
            }
        };
        Ok(match first.name {
            "camera" => {
                no_index(first)?;
                (Entity::Camera, &steps[1..])
            }
            "render" => {
                no_index(first)?;
                (Entity::Render, &steps[1..])
            }
            "image" => {
                return Err(
                    "`image.width` and `image.height` are integers, not differentiable".into(),
                )
            }
            "materials" => {
                no_index(first)?;
                let names = || list(self.materials.iter().map(|m| m.name.clone()));
                let Some(m) = steps.get(1) else {
                    return Err(format!(
                        "name a material: {}",
                        list(
                            self.materials
                                .iter()
                                .map(|m| format!("materials.{}", m.name))
                        )
                    ));
                };
                no_index(m)?;
                let Some(index) = self.materials.iter().position(|n| n.name == m.name) else {
                    return Err(format!(
                        "no material `{}` (the scene defines {})",
                        m.name,
                        names()
                    ));
                };
                (Entity::Material(index as u32), &steps[2..])
            }
            "sphere" => (
                Entity::Sphere(indexed(first, self.spheres.len())?),
                &steps[1..],
            ),
            "ellipsoid" => (
                Entity::Ellipsoid(indexed(first, self.ellipsoids.len())?),
                &steps[1..],
            ),
            "plane" => (
                Entity::Plane(indexed(first, self.planes.len())?),
                &steps[1..],
            ),
            "triangle" => (
                Entity::Triangle(indexed(first, self.triangles.len())?),
                &steps[1..],
            ),
            "mesh" => (
                Entity::Mesh(indexed(first, self.meshes.len())?),
                &steps[1..],
            ),
            "light" => (
                Entity::Light(indexed(first, self.lights.len())?),
                &steps[1..],
            ),
            other => {
                return Err(format!(
                    "unknown section `{other}` (a parameter starts with one of {SECTIONS})"
                ))
            }
        })
    }

    /// The entity's name as a parameter's prefix (`materials.red`,
    /// `sphere[1]`, `camera`).
    pub fn entity_name(&self, entity: Entity) -> String {
        match entity {
            Entity::Camera => "camera".into(),
            Entity::Render => "render".into(),
            Entity::Material(i) => format!("materials.{}", self.materials[i as usize].name),
            Entity::Sphere(i) => format!("sphere[{i}]"),
            Entity::Ellipsoid(i) => format!("ellipsoid[{i}]"),
            Entity::Plane(i) => format!("plane[{i}]"),
            Entity::Triangle(i) => format!("triangle[{i}]"),
            Entity::Mesh(i) => format!("mesh[{i}]"),
            Entity::Light(i) => format!("light[{i}]"),
        }
    }

    /// The keys of an entity's differentiable fields.
    fn field_keys(&self, entity: Entity) -> Vec<&'static str> {
        fields_of(entity).into_iter().map(Target::key).collect()
    }

    /// A field's shape in this scene (a mesh's `scale` is a vector where
    /// the file gives one per axis).
    pub fn shape_of(&self, target: Target) -> Shape {
        match target {
            Target::Mesh(i, MeshField::Scale) => match self.meshes[i as usize].scale {
                Scale::Uniform(_) => Shape::Scalar,
                Scale::PerAxis(_) => Shape::Vector,
            },
            t => t.declared_shape(),
        }
    }

    /// How many components the field has here, or why it is no parameter
    /// (an optional field the file does not set).
    pub fn len_of(&self, target: Target) -> Result<u32, &'static str> {
        Ok(match target {
            Target::Camera(CameraField::Aspect) if self.camera.aspect.is_none() => {
                return Err(
                    "is not set: the aspect then follows the image size (an integer); \
                            set it in the scene file to differentiate it",
                )
            }
            Target::Mesh(i, MeshField::Fit) if self.meshes[i as usize].fit.is_none() => {
                return Err("is not set (the mesh keeps its own size)")
            }
            Target::Mesh(i, MeshField::Vertices) => {
                3 * self.meshes[i as usize].data.positions.len() as u32
            }
            Target::Triangle(..) => 9,
            t => match self.shape_of(t) {
                Shape::Scalar => 1,
                Shape::Vector => 3,
                Shape::Points => unreachable!("points are triangles' and meshes'"),
            },
        })
    }

    /// The canonical name of a parameter, with every index
    /// (`materials.red.color[0]`, `triangle[0].vertices[2][1]`): output
    /// files are named after it.
    pub fn param_name(&self, id: ParamId) -> String {
        let prefix = self.entity_name(id.target.entity());
        let key = id.target.key();
        let c = id.component;
        match self.shape_of(id.target) {
            Shape::Scalar => format!("{prefix}.{key}"),
            Shape::Vector => format!("{prefix}.{key}[{c}]"),
            Shape::Points => format!("{prefix}.{key}[{}][{}]", c / 3, c % 3),
        }
    }

    /// Every parameter of the scene, one selection per field: all of each
    /// field's components (optional fields only where set).
    pub fn parameters(&self) -> Vec<Selection> {
        let mut entities = vec![Entity::Camera, Entity::Render];
        let n = |len: usize| 0..len as u32;
        entities.extend(n(self.materials.len()).map(Entity::Material));
        entities.extend(n(self.spheres.len()).map(Entity::Sphere));
        entities.extend(n(self.ellipsoids.len()).map(Entity::Ellipsoid));
        entities.extend(n(self.planes.len()).map(Entity::Plane));
        entities.extend(n(self.triangles.len()).map(Entity::Triangle));
        entities.extend(n(self.meshes.len()).map(Entity::Mesh));
        entities.extend(n(self.lights.len()).map(Entity::Light));
        entities
            .into_iter()
            .flat_map(fields_of)
            .filter_map(|target| {
                let len = self.len_of(target).ok()?;
                Some(Selection {
                    target,
                    components: 0..len,
                })
            })
            .collect()
    }

    /// The value of one parameter.
    ///
    /// # Panics
    /// If `id` does not address a number of this description (ids come
    /// from [`SceneDescription::select`] on it).
    pub fn value(&self, id: ParamId) -> f32 {
        self.numbers(id.target)[id.component as usize]
    }

    /// All components of a field, flattened (vectors x, y, z; points
    /// vertex by vertex).
    pub fn values(&self, target: Target) -> Vec<f32> {
        self.numbers(target).to_vec()
    }

    /// Set one parameter (no range check: [`SceneDescription::check`]
    /// says whether the result is a valid scene).
    ///
    /// # Panics
    /// As [`SceneDescription::value`].
    pub fn set_value(&mut self, id: ParamId, v: f32) {
        self.numbers_mut(id.target)[id.component as usize] = v;
    }

    /// The field's numbers, flattened.
    fn numbers(&self, target: Target) -> &[f32] {
        field_numbers!(self, target)
    }

    /// The field's numbers, flattened, to write (a mesh's vertices are
    /// copied first if another description shares them).
    fn numbers_mut(&mut self, target: Target) -> &mut [f32] {
        field_numbers!(self, target, mut)
    }
}

/// The target of field `key` of `entity`, if it is a differentiable one.
fn field_of(entity: Entity, key: &str) -> Option<Target> {
    Some(match entity {
        Entity::Camera => Target::Camera(CameraField::from_key(key)?),
        Entity::Render => Target::Render(RenderField::from_key(key)?),
        Entity::Material(i) => Target::Material(i, MaterialField::from_key(key)?),
        Entity::Sphere(i) => Target::Sphere(i, SphereField::from_key(key)?),
        Entity::Ellipsoid(i) => Target::Ellipsoid(i, EllipsoidField::from_key(key)?),
        Entity::Plane(i) => Target::Plane(i, PlaneField::from_key(key)?),
        Entity::Triangle(i) => Target::Triangle(i, TriangleField::from_key(key)?),
        Entity::Mesh(i) => Target::Mesh(i, MeshField::from_key(key)?),
        Entity::Light(i) => Target::Light(i, LightField::from_key(key)?),
    })
}

/// Every differentiable field of `entity`.
fn fields_of(entity: Entity) -> Vec<Target> {
    match entity {
        Entity::Camera => CameraField::ALL
            .iter()
            .map(|&f| Target::Camera(f))
            .collect(),
        Entity::Render => RenderField::ALL
            .iter()
            .map(|&f| Target::Render(f))
            .collect(),
        Entity::Material(i) => MaterialField::ALL
            .iter()
            .map(|&f| Target::Material(i, f))
            .collect(),
        Entity::Sphere(i) => SphereField::ALL
            .iter()
            .map(|&f| Target::Sphere(i, f))
            .collect(),
        Entity::Ellipsoid(i) => EllipsoidField::ALL
            .iter()
            .map(|&f| Target::Ellipsoid(i, f))
            .collect(),
        Entity::Plane(i) => PlaneField::ALL
            .iter()
            .map(|&f| Target::Plane(i, f))
            .collect(),
        Entity::Triangle(i) => TriangleField::ALL
            .iter()
            .map(|&f| Target::Triangle(i, f))
            .collect(),
        Entity::Mesh(i) => MeshField::ALL.iter().map(|&f| Target::Mesh(i, f)).collect(),
        Entity::Light(i) => LightField::ALL
            .iter()
            .map(|&f| Target::Light(i, f))
            .collect(),
    }
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
