//! Scene parameters: the continuous numbers of a scene description,
//! addressed by typed ids. This is the one table of them: parsing a name
//! (`materials.red.color[0]`, `light[0].position[2]`, `sphere[1].radius`,
//! `triangle[4].vertices[1][0]`, `mesh[0].vertices[10..20]`, `camera.fov`…)
//! into an id, the id's canonical name, reading and writing its value in a
//! [`SceneDescription`], and listing every parameter a scene has. Seeding
//! dual numbers ([`super::build::Numbers`]), the finite-difference check
//! and inverse rendering's updates all go through it, and so does the
//! command line's `--set PATH=VALUE` ([`Setting`]).
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

pub use super::description::Entity;
use super::description::{Scale, SceneDescription};
use std::ops::Range;

/// The shape of a field's value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ValueShape {
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
            pub fn shape(self) -> ValueShape {
                match self {
                    $(Self::$variant => ValueShape::$shape),*
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
    fn declared_shape(self) -> ValueShape {
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

mod path;
mod setting;
mod values;

pub use setting::{SetError, SetValue, Setting, SettingError};

impl SceneDescription {
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
    pub fn shape_of(&self, target: Target) -> ValueShape {
        match target {
            Target::Mesh(i, MeshField::Scale) => match self.meshes[i as usize].scale {
                Scale::Uniform(_) => ValueShape::Scalar,
                Scale::PerAxis(_) => ValueShape::Vector,
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
                ValueShape::Scalar => 1,
                ValueShape::Vector => 3,
                ValueShape::Points => unreachable!("points are triangles' and meshes'"),
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
            ValueShape::Scalar => format!("{prefix}.{key}"),
            ValueShape::Vector => format!("{prefix}.{key}[{c}]"),
            ValueShape::Points => format!("{prefix}.{key}[{}][{}]", c / 3, c % 3),
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
