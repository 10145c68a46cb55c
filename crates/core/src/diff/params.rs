//! Differentiable parameters, named by their place in the scene file:
//! `materials.red.color[0]`, `light[0].position[2]`, `sphere[1].radius`,
//! `triangle[4].vertices[1][0]`, `mesh[0].translate[1]`, `camera.fov`…
//!
//! A name resolves against a schema of the scene file's continuous fields
//! (so a field left at its default, such as a light's `intensity`, is still
//! a parameter). A vector field without an index (`materials.red.color`)
//! stands for all its components. Integers, names, flags, cut-offs and
//! textures are not differentiable, and a name that does not resolve is an
//! error naming what exists at the place where it stopped matching.

use crate::io::scene_file::{ScaleDef, SceneFile};
use crate::math::Vec3;

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
pub enum Kind {
    Scalar,
    Vector,
    /// Three points (a triangle's `vertices`), indexed `[vertex][axis]`.
    Points,
}

impl Kind {
    fn len(self) -> usize {
        match self {
            Kind::Scalar => 1,
            Kind::Vector => 3,
            Kind::Points => 9,
        }
    }
}

/// One scalar of the scene file: a field of an entity and a component
/// (0 for scalars; the axis for vectors; 3·vertex + axis for points).
#[derive(Clone, Debug, PartialEq)]
pub struct Param {
    /// The canonical name, as written on the command line with every index
    /// (`materials.red.color[0]`): output files are named after it.
    pub name: String,
    pub entity: Entity,
    pub field: &'static str,
    pub component: usize,
    /// The value in the scene file (or its default).
    pub value: f32,
}

/// Differentiable fields per section, with their shapes.
const CAMERA: &[(&str, Kind)] = &[
    ("eye", Kind::Vector),
    ("look_at", Kind::Vector),
    ("up", Kind::Vector),
    ("fov", Kind::Scalar),
    ("near", Kind::Scalar),
    ("aspect", Kind::Scalar),
];
const RENDER: &[(&str, Kind)] = &[("background", Kind::Vector), ("ambient", Kind::Vector)];
const MATERIAL: &[(&str, Kind)] = &[
    ("color", Kind::Vector),
    ("ambient", Kind::Scalar),
    ("diffuse", Kind::Scalar),
    ("specular", Kind::Scalar),
    ("shininess", Kind::Scalar),
    ("specular_color", Kind::Vector),
    ("reflectivity", Kind::Scalar),
    ("transparency", Kind::Scalar),
    ("ior", Kind::Scalar),
    ("emission", Kind::Vector),
];
const SPHERE: &[(&str, Kind)] = &[("center", Kind::Vector), ("radius", Kind::Scalar)];
const ELLIPSOID: &[(&str, Kind)] = &[
    ("center", Kind::Vector),
    ("radii", Kind::Vector),
    ("rotate", Kind::Vector),
];
const PLANE: &[(&str, Kind)] = &[("point", Kind::Vector), ("normal", Kind::Vector)];
const TRIANGLE: &[(&str, Kind)] = &[("vertices", Kind::Points)];
const MESH: &[(&str, Kind)] = &[
    ("translate", Kind::Vector),
    ("rotate", Kind::Vector),
    ("scale", Kind::Scalar), // or Vector, as the file writes it
    ("fit", Kind::Scalar),
];
const LIGHT: &[(&str, Kind)] = &[
    ("position", Kind::Vector),
    ("color", Kind::Vector),
    ("intensity", Kind::Scalar),
];

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

/// One `name[i][j]` step of a path.
#[derive(Debug, PartialEq)]
struct Step<'a> {
    name: &'a str,
    indices: Vec<usize>,
}

fn parse_steps(path: &str) -> Result<Vec<Step<'_>>, String> {
    let bad = |why: &str| format!("parameter `{path}`: {why}");
    if path.is_empty() {
        return Err(bad("empty name"));
    }
    path.split('.')
        .map(|seg| {
            let (name, mut rest) = match seg.find('[') {
                Some(i) => (&seg[..i], &seg[i..]),
                None => (seg, ""),
            };
            if name.is_empty() {
                return Err(bad(&format!("`{seg}` has no field name")));
            }
            let mut indices = Vec::new();
            while !rest.is_empty() {
                let close = rest
                    .find(']')
                    .filter(|_| rest.starts_with('['))
                    .ok_or_else(|| bad(&format!("malformed index in `{seg}` (expected `[n]`)")))?;
                let n = rest[1..close].parse::<usize>().map_err(|_| {
                    bad(&format!(
                        "index `{}` in `{seg}` is not a non-negative integer",
                        &rest[1..close]
                    ))
                })?;
                indices.push(n);
                rest = &rest[close + 1..];
            }
            Ok(Step { name, indices })
        })
        .collect()
}

/// Resolve a parameter name against a scene file: one [`Param`] per
/// component it names.
pub fn resolve(path: &str, file: &SceneFile) -> Result<Vec<Param>, String> {
    let steps = parse_steps(path)?;
    let err = |why: String| format!("parameter `{path}`: {why}");
    let no_index = |s: &Step| {
        if s.indices.is_empty() {
            Ok(())
        } else {
            Err(err(format!("`{}` takes no index", s.name)))
        }
    };
    let indexed = |s: &Step, count: usize| -> Result<u32, String> {
        match s.indices.as_slice() {
            [i] if *i < count => Ok(*i as u32),
            [i] => Err(err(format!(
                "the scene has {count} `[[{}]]` entr{} ({}), not index {i}",
                s.name,
                if count == 1 { "y" } else { "ies" },
                if count == 0 {
                    "none".to_string()
                } else {
                    format!("{}[0]…{}[{}]", s.name, s.name, count - 1)
                }
            ))),
            _ => Err(err(format!(
                "`{}` needs one index, e.g. `{}[0]`",
                s.name, s.name
            ))),
        }
    };
    let first = &steps[0];
    let (entity, schema, prefix, rest) = match first.name {
        "camera" => {
            no_index(first)?;
            (Entity::Camera, CAMERA, "camera".to_string(), &steps[1..])
        }
        "render" => {
            no_index(first)?;
            (Entity::Render, RENDER, "render".to_string(), &steps[1..])
        }
        "image" => {
            return Err(err(
                "`image.width` and `image.height` are integers, not differentiable".into(),
            ))
        }
        "materials" => {
            no_index(first)?;
            let names: Vec<&String> = file.materials.keys().collect();
            let Some(m) = steps.get(1) else {
                return Err(err(format!(
                    "name a material: {}",
                    list(names.iter().map(|n| format!("materials.{n}")))
                )));
            };
            no_index(m)?;
            let Some(index) = names.iter().position(|n| n.as_str() == m.name) else {
                return Err(err(format!(
                    "no material `{}` (the scene defines {})",
                    m.name,
                    list(names.iter().map(|n| n.to_string()))
                )));
            };
            (
                Entity::Material(index as u32),
                MATERIAL,
                format!("materials.{}", m.name),
                &steps[2..],
            )
        }
        "sphere" => {
            let i = indexed(first, file.sphere.len())?;
            (
                Entity::Sphere(i),
                SPHERE,
                format!("sphere[{i}]"),
                &steps[1..],
            )
        }
        "ellipsoid" => {
            let i = indexed(first, file.ellipsoid.len())?;
            (
                Entity::Ellipsoid(i),
                ELLIPSOID,
                format!("ellipsoid[{i}]"),
                &steps[1..],
            )
        }
        "plane" => {
            let i = indexed(first, file.plane.len())?;
            (Entity::Plane(i), PLANE, format!("plane[{i}]"), &steps[1..])
        }
        "triangle" => {
            let i = indexed(first, file.triangle.len())?;
            (
                Entity::Triangle(i),
                TRIANGLE,
                format!("triangle[{i}]"),
                &steps[1..],
            )
        }
        "mesh" => {
            let i = indexed(first, file.mesh.len())?;
            (Entity::Mesh(i), MESH, format!("mesh[{i}]"), &steps[1..])
        }
        "light" => {
            let i = indexed(first, file.light.len())?;
            (Entity::Light(i), LIGHT, format!("light[{i}]"), &steps[1..])
        }
        other => {
            return Err(err(format!(
                "unknown section `{other}` (a parameter starts with one of {SECTIONS})"
            )))
        }
    };
    let fields = || list(schema.iter().map(|(f, _)| format!("{prefix}.{f}")));
    let [field_step] = rest else {
        return Err(err(if rest.is_empty() {
            format!("name a field: {}", fields())
        } else {
            format!("`{}` has no sub-fields", rest[0].name)
        }));
    };
    let Some(&(field, mut kind)) = schema.iter().find(|(f, _)| *f == field_step.name) else {
        if let Some((_, why)) = NOT_DIFFERENTIABLE
            .iter()
            .find(|(f, _)| *f == field_step.name)
        {
            return Err(err(format!(
                "`{}` is not differentiable ({why}); differentiable here: {}",
                field_step.name,
                fields()
            )));
        }
        return Err(err(format!(
            "no field `{}` (differentiable here: {})",
            field_step.name,
            fields()
        )));
    };
    let values = field_values(file, entity, field)
        .map_err(|why| err(format!("`{prefix}.{field}` {why}")))?;
    if values.len() == 3 && kind == Kind::Scalar {
        kind = Kind::Vector; // a mesh's per-axis `scale`
    }
    let components: Vec<usize> = match (kind, field_step.indices.as_slice()) {
        (_, []) => (0..kind.len()).collect(),
        (Kind::Vector, [c]) if *c < 3 => vec![*c],
        (Kind::Points, [v]) if *v < 3 => (3 * v..3 * v + 3).collect(),
        (Kind::Points, [v, c]) if *v < 3 && *c < 3 => vec![3 * v + c],
        (Kind::Scalar, _) => {
            return Err(err(format!(
                "`{prefix}.{field}` is a number and takes no index"
            )))
        }
        (Kind::Vector, _) => {
            return Err(err(format!(
                "`{prefix}.{field}` is a vector: index it with [0], [1] or [2], or not at all"
            )))
        }
        (Kind::Points, _) => {
            return Err(err(format!(
                "`{prefix}.{field}` holds three points: index it as [vertex][axis], \
                 each 0…2, [vertex], or not at all"
            )))
        }
    };
    Ok(components
        .into_iter()
        .map(|c| Param {
            name: match kind {
                Kind::Scalar => format!("{prefix}.{field}"),
                Kind::Vector => format!("{prefix}.{field}[{c}]"),
                Kind::Points => format!("{prefix}.{field}[{}][{}]", c / 3, c % 3),
            },
            entity,
            field,
            component: c,
            value: values[c],
        })
        .collect())
}

/// The most parameter components one gradient render takes (16 passes of
/// 16): each costs about a render and 28 bytes per pixel of output.
pub const MAX_PARAMS: usize = 256;

/// Resolve several names; a component named twice is an error, and so are
/// more than [`MAX_PARAMS`] components.
pub fn resolve_all(paths: &[String], file: &SceneFile) -> Result<Vec<Param>, String> {
    let mut out: Vec<Param> = Vec::new();
    for p in paths {
        for param in resolve(p, file)? {
            if out.len() == MAX_PARAMS {
                return Err(format!(
                    "more than {MAX_PARAMS} parameter components (the limit of one gradient \
                     render); split them over several runs"
                ));
            }
            if out.iter().any(|q| q.name == param.name) {
                return Err(format!("parameter `{}` is named twice", param.name));
            }
            out.push(param);
        }
    }
    if out.is_empty() {
        return Err("no parameter given (use --param, e.g. `--param materials.red.color`)".into());
    }
    Ok(out)
}

fn list(items: impl Iterator<Item = String>) -> String {
    let v: Vec<String> = items.map(|s| format!("`{s}`")).collect();
    if v.is_empty() {
        "none".into()
    } else {
        v.join(", ")
    }
}

fn v3(v: Vec3) -> Vec<f32> {
    v.to_array().to_vec()
}

/// The current values (defaults included) of a field, flattened.
pub fn field_values(file: &SceneFile, entity: Entity, field: &str) -> Result<Vec<f32>, String> {
    let i = |k: u32| k as usize;
    Ok(match entity {
        Entity::Camera => {
            let c = &file.camera;
            match field {
                "eye" => v3(c.eye),
                "look_at" => v3(c.look_at),
                "up" => v3(c.up),
                "fov" => vec![c.fov],
                "near" => vec![c.near],
                "aspect" => vec![c.aspect.ok_or(
                    "is not set: the aspect then follows the image size (an integer); \
                     set it in the scene file to differentiate it",
                )?],
                _ => unreachable!("schema"),
            }
        }
        Entity::Render => match field {
            "background" => v3(file.render.background),
            "ambient" => v3(file.render.ambient),
            _ => unreachable!("schema"),
        },
        Entity::Material(k) => {
            let m = file
                .materials
                .values()
                .nth(i(k))
                .expect("resolved index")
                .get_ref();
            match field {
                "color" => v3(m.color),
                "ambient" => vec![m.ambient],
                "diffuse" => vec![m.diffuse],
                "specular" => vec![m.specular],
                "shininess" => vec![m.shininess],
                "specular_color" => v3(m.specular_color),
                "reflectivity" => vec![m.reflectivity],
                "transparency" => vec![m.transparency],
                "ior" => vec![m.ior],
                "emission" => v3(m.emission),
                _ => unreachable!("schema"),
            }
        }
        Entity::Sphere(k) => {
            let s = file.sphere[i(k)].get_ref();
            match field {
                "center" => v3(s.center),
                _ => vec![s.radius],
            }
        }
        Entity::Ellipsoid(k) => {
            let e = file.ellipsoid[i(k)].get_ref();
            match field {
                "center" => v3(e.center),
                "radii" => v3(e.radii),
                _ => v3(e.rotate),
            }
        }
        Entity::Plane(k) => {
            let p = file.plane[i(k)].get_ref();
            match field {
                "point" => v3(p.point),
                _ => v3(p.normal),
            }
        }
        Entity::Triangle(k) => file.triangle[i(k)]
            .get_ref()
            .vertices
            .iter()
            .flat_map(|v| v.to_array())
            .collect(),
        Entity::Mesh(k) => {
            let m = file.mesh[i(k)].get_ref();
            match field {
                "translate" => v3(m.translate),
                "rotate" => v3(m.rotate),
                "scale" => match m.scale {
                    ScaleDef::Uniform(s) => vec![s],
                    ScaleDef::PerAxis(v) => v3(v),
                },
                _ => vec![m.fit.ok_or("is not set (the mesh keeps its own size)")?],
            }
        }
        Entity::Light(k) => {
            let l = file.light[i(k)].get_ref();
            match field {
                "position" => v3(l.position),
                "color" => v3(l.color),
                _ => vec![l.intensity],
            }
        }
    })
}
