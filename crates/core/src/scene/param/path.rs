//! Parameter names: parsing a path (`sphere[1].center[2]`,
//! `mesh[0].vertices[4..9]`) into the [`Selection`] it names, with
//! errors that say what exists where the name stopped matching.

use super::{field_of, Entity, ParamError, Selection, ValueShape};
use crate::scene::SceneDescription;

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
            (ValueShape::Vector, [Index::One(c)]) if *c < 3 => *c..c + 1,
            (ValueShape::Points, [Index::One(v)]) if 3 * v < len => 3 * v..3 * v + 3,
            (ValueShape::Points, [Index::Range(a, b)]) if a < b && 3 * b <= len => 3 * a..3 * b,
            (ValueShape::Points, [Index::One(v), Index::One(c)]) if 3 * v < len && *c < 3 => {
                3 * v + c..3 * v + c + 1
            }
            (ValueShape::Scalar, _) => {
                return Err(format!("`{full}` is a number and takes no index"))
            }
            (ValueShape::Vector, _) => {
                return Err(format!(
                    "`{full}` is a vector: index it with [0], [1] or [2], or not at all"
                ))
            }
            (ValueShape::Points, _) => {
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
}
