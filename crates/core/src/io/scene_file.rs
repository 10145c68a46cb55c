//! Scene files: TOML, parsed with serde. The schema is documented in the
//! book's reference (`book/src/reference/scene-files.md`). Unknown fields, unknown material names, bad
//! values and unreadable meshes are errors that name the file and the line.

use super::procedural::Procedural;
use super::{line_col, InputError, MeshData, Place};
use crate::accel::AccelKind;
use crate::camera::Camera;
use crate::film::Filter;
use crate::light::{Falloff, PointLight};
use crate::material::Material;
use crate::math::{rotation_xyz_degrees, Color, Mat3, Real, Vec3, M3, V3};
use crate::sampler::Sampler;
use crate::scene::{MeshShading, RenderSettings, Scene, SceneObject};
use crate::shape::{Ellipsoid, Plane, Primitive, Shape, Sphere, Triangle};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};
use toml::Spanned;

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    pub image: ImageDef,
    pub camera: CameraDef,
    #[serde(default)]
    pub render: RenderDef,
    #[serde(default)]
    pub materials: BTreeMap<String, Spanned<Material>>,
    #[serde(default)]
    pub sphere: Vec<Spanned<SphereDef>>,
    #[serde(default)]
    pub ellipsoid: Vec<Spanned<EllipsoidDef>>,
    #[serde(default)]
    pub plane: Vec<Spanned<PlaneDef>>,
    #[serde(default)]
    pub triangle: Vec<Spanned<TriangleDef>>,
    #[serde(default)]
    pub mesh: Vec<Spanned<MeshDef>>,
    #[serde(default)]
    pub light: Vec<Spanned<LightDef>>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
pub struct ImageDef {
    pub width: u32,
    pub height: u32,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
pub struct CameraDef {
    pub eye: Vec3,
    pub look_at: Vec3,
    #[serde(default = "default_up")]
    pub up: Vec3,
    /// Vertical view angle θ in degrees.
    pub fov: f32,
    /// Near-plane distance N.
    #[serde(default = "one")]
    pub near: f32,
    /// W/H; defaults to width/height.
    pub aspect: Option<f32>,
}

fn default_up() -> Vec3 {
    Vec3::Y
}
fn one() -> f32 {
    1.0
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields, default)]
pub struct RenderDef {
    pub background: Color,
    pub ambient: Color,
    pub max_depth: u32,
    pub min_weight: f32,
    pub max_distance: f32,
    pub sampler: Spanned<String>,
    /// Reconstruction filter: `box`, `tent` or `mitchell`.
    pub filter: Spanned<String>,
    pub seed: u64,
    pub accel: Spanned<String>,
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
pub struct SphereDef {
    pub center: Vec3,
    pub radius: f32,
    pub material: Spanned<String>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
pub struct EllipsoidDef {
    pub center: Vec3,
    pub radii: Vec3,
    /// Euler angles in degrees about x, then y, then z.
    #[serde(default)]
    pub rotate: Vec3,
    pub material: Spanned<String>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
pub struct PlaneDef {
    pub point: Vec3,
    pub normal: Vec3,
    pub material: Spanned<String>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
pub struct TriangleDef {
    pub vertices: [Vec3; 3],
    pub material: Spanned<String>,
}

/// Uniform or per-axis scale.
#[derive(Deserialize, Debug, Clone, Copy)]
#[serde(untagged)]
pub enum ScaleDef {
    Uniform(f32),
    PerAxis(Vec3),
}

impl Default for ScaleDef {
    fn default() -> Self {
        ScaleDef::Uniform(1.0)
    }
}

/// Which shading normals a mesh gets.
#[derive(Deserialize, Debug, Clone, Copy, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum NormalsDef {
    /// The file's vertex normals where it has them, else flat.
    #[default]
    File,
    /// Flat shading (geometric normals).
    Flat,
    /// Area-weighted averages of the faces around each vertex (smooth
    /// shading for files without normals).
    Computed,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
pub struct MeshDef {
    /// Mesh file, relative to the scene file (give this or `procedural`).
    pub file: Option<PathBuf>,
    /// A generated mesh instead of a file, e.g.
    /// `{ kind = "icosphere", level = 6 }`.
    pub procedural: Option<Procedural>,
    pub material: Spanned<String>,
    /// If given, the mesh is first centred at the origin and scaled so the
    /// largest side of its bounding box is `fit` (meshes come in any units).
    pub fit: Option<f32>,
    #[serde(default)]
    pub scale: ScaleDef,
    #[serde(default)]
    pub rotate: Vec3,
    #[serde(default)]
    pub translate: Vec3,
    #[serde(default)]
    pub normals: NormalsDef,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
pub struct LightDef {
    pub position: Vec3,
    #[serde(default = "white")]
    pub color: Color,
    #[serde(default = "one")]
    pub intensity: f32,
    #[serde(default)]
    pub falloff: Falloff,
    /// Used by the Whitted integrator only (a stand-in for an emissive
    /// surface, which the path tracer samples instead).
    #[serde(default)]
    pub whitted_only: bool,
}

fn white() -> Color {
    Color::ONE
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

/// Load and build a scene from a TOML file.
pub fn load_scene(path: &Path, overrides: &Overrides) -> Result<Scene, InputError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| InputError::file(path, format!("cannot read scene file: {e}")))?;
    parse_scene(&text, path, overrides)
}

/// Build a scene from TOML text; `path` names the file in errors and
/// anchors relative mesh paths.
pub fn parse_scene(text: &str, path: &Path, overrides: &Overrides) -> Result<Scene, InputError> {
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

    // Materials by name, in name order.
    let mut names: BTreeMap<&str, u32> = BTreeMap::new();
    let mut materials = Vec::new();
    for (name, m) in &file.materials {
        m.get_ref()
            .validate()
            .map_err(|msg| at(m.span(), format!("material `{name}`: {msg}")))?;
        names.insert(name, materials.len() as u32);
        materials.push(*m.get_ref());
    }
    let material = |m: &Spanned<String>| -> Result<u32, InputError> {
        names.get(m.get_ref().as_str()).copied().ok_or_else(|| {
            let known: Vec<_> = names.keys().map(|k| format!("`{k}`")).collect();
            at(
                m.span(),
                format!(
                    "unknown material `{}` (defined: {})",
                    m.get_ref(),
                    if known.is_empty() {
                        "none".into()
                    } else {
                        known.join(", ")
                    }
                ),
            )
        })
    };
    let finite = |v: Vec3, what: &str, span: Range<usize>| {
        if v.is_finite() {
            Ok(())
        } else {
            Err(at(span, format!("`{what}` must be finite, got {v}")))
        }
    };

    let mut objects = Vec::new();
    let mut prims = Vec::new();
    let mut meshes = Vec::new();
    let mut add_object = |name: String, mat: u32| {
        objects.push(SceneObject {
            name,
            material: mat,
        });
        objects.len() as u32 - 1
    };

    for (i, s) in file.sphere.iter().enumerate() {
        let (d, span) = (s.get_ref(), s.span());
        finite(d.center, "center", span.clone())?;
        if !(d.radius > 0.0 && d.radius.is_finite()) {
            return Err(at(
                span,
                format!("`radius` must be positive, got {}", d.radius),
            ));
        }
        let object = add_object(format!("sphere[{i}]"), material(&d.material)?);
        prims.push(Primitive {
            shape: Shape::Sphere(Sphere::new(d.center, d.radius)),
            object,
        });
    }
    for (i, e) in file.ellipsoid.iter().enumerate() {
        let (d, span) = (e.get_ref(), e.span());
        finite(d.center, "center", span.clone())?;
        finite(d.rotate, "rotate", span.clone())?;
        if !(d.radii.is_finite() && d.radii.min_element() > 0.0) {
            return Err(at(
                span,
                format!("`radii` must be positive, got {}", d.radii),
            ));
        }
        let object = add_object(format!("ellipsoid[{i}]"), material(&d.material)?);
        let rot = rotation_xyz_degrees(d.rotate);
        prims.push(Primitive {
            shape: Shape::Ellipsoid(Ellipsoid::new(d.center, d.radii, rot)),
            object,
        });
    }
    for (i, p) in file.plane.iter().enumerate() {
        let (d, span) = (p.get_ref(), p.span());
        finite(d.point, "point", span.clone())?;
        if !(d.normal.is_finite() && d.normal.length() > 0.0) {
            return Err(at(
                span,
                format!("`normal` must be a non-zero vector, got {}", d.normal),
            ));
        }
        let object = add_object(format!("plane[{i}]"), material(&d.material)?);
        prims.push(Primitive {
            shape: Shape::Plane(Plane::new(d.point, d.normal)),
            object,
        });
    }
    for (i, t) in file.triangle.iter().enumerate() {
        let (d, span) = (t.get_ref(), t.span());
        for v in d.vertices {
            finite(v, "vertices", span.clone())?;
        }
        let object = add_object(format!("triangle[{i}]"), material(&d.material)?);
        let [a, b, c] = d.vertices;
        prims.push(Primitive {
            shape: Shape::Triangle(Triangle::new(a, b, c)),
            object,
        });
    }
    for (i, m) in file.mesh.iter().enumerate() {
        let (d, span) = (m.get_ref(), m.span());
        let mat = material(&d.material)?;
        let (data, label) = load_mesh(d, base).map_err(|msg| at(span.clone(), msg))?;
        let transform =
            MeshTransform::new(d, &data.positions).map_err(|msg| at(span.clone(), msg))?;
        let object = add_object(format!("mesh[{i}] {label}"), mat);
        let mesh_index = meshes.len() as u32;
        let positions: Vec<Vec3> = data.positions.iter().map(|&p| transform.point(p)).collect();
        let normals = match d.normals {
            NormalsDef::Flat => Vec::new(),
            NormalsDef::File => data.normals.iter().map(|&n| transform.normal(n)).collect(),
            NormalsDef::Computed => vertex_normals(&positions, &data.triangles),
        };
        for (face, tri) in data.triangles.iter().enumerate() {
            let [a, b, c] = tri.map(|k| positions[k as usize]);
            prims.push(Primitive {
                shape: Shape::Triangle(Triangle {
                    p: [a, b, c],
                    mesh: mesh_index,
                    face: face as u32,
                }),
                object,
            });
        }
        meshes.push(MeshShading {
            normals,
            triangles: data.triangles,
        });
    }

    let mut lights = Vec::new();
    for l in &file.light {
        let (d, span) = (l.get_ref(), l.span());
        finite(d.position, "position", span.clone())?;
        let radiance = d.color * d.intensity;
        if !(radiance.is_finite() && radiance.min_element() >= 0.0) {
            return Err(at(
                span,
                "light `color` × `intensity` must be non-negative".into(),
            ));
        }
        lights.push(PointLight {
            position: d.position,
            radiance,
            falloff: d.falloff,
            whitted_only: d.whitted_only,
        });
    }

    let r = &file.render;
    let sampler = match overrides.sampler {
        Some(s) => s,
        None => Sampler::parse(r.sampler.get_ref()).map_err(|msg| at(r.sampler.span(), msg))?,
    };
    let filter = match overrides.filter {
        Some(f) => f,
        None => Filter::parse(r.filter.get_ref()).map_err(|msg| at(r.filter.span(), msg))?,
    };
    let accel = match overrides.accel {
        Some(a) => a,
        None => r
            .accel
            .get_ref()
            .parse()
            .map_err(|msg| at(r.accel.span(), msg))?,
    };
    let settings = RenderSettings {
        background: r.background,
        ambient: r.ambient,
        max_depth: overrides.max_depth.unwrap_or(r.max_depth),
        min_weight: r.min_weight,
        max_distance: r.max_distance,
        sampler,
        filter,
        seed: overrides.seed.unwrap_or(r.seed),
    };
    if settings.max_distance.is_nan()
        || settings.max_distance <= 0.0
        || !settings.min_weight.is_finite()
    {
        return Err(InputError::file(
            path,
            "[render]: `max_distance` must be positive and `min_weight` finite",
        ));
    }
    let width = overrides.width.unwrap_or(file.image.width);
    let height = overrides.height.unwrap_or(file.image.height);
    let c = &file.camera;
    let aspect = c.aspect.unwrap_or(width as f32 / height.max(1) as f32);
    let camera = Camera::new(c.eye, c.look_at, c.up, c.fov, aspect, c.near, width, height)
        .map_err(|e| InputError::file(path, format!("[camera]: {e}")))?;
    let spp = settings.sampler.spp();
    let keep_samples = settings.filter != Filter::Box;
    crate::film::memory::check(
        || format!("[image]: a {width}×{height} image at {spp} samples per pixel"),
        crate::film::memory::render_bytes(width, height, spp, keep_samples),
    )
    .map_err(|e| InputError::file(path, e.to_string()))?;

    Scene::new(
        camera, settings, materials, objects, lights, prims, meshes, accel,
    )
    .map_err(|e| InputError::file(path, format!("accelerator: {e}")))
}

/// The mesh data of a `[[mesh]]` entry and a label for it.
pub fn load_mesh(d: &MeshDef, base: &Path) -> Result<(MeshData, String), String> {
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

/// The object transform of a mesh: optional fit to a box, then scale, rotate
/// and translate (x' = T·R·S·x).
struct MeshTransform {
    linear: Mat3,
    /// Inverse transpose of `linear`, for normals.
    normal: Mat3,
    offset: Vec3,
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

/// A mesh's transform over [`Real`] (the one formula; the loader runs it on
/// `f32`, the derivative code on dual numbers): `fit` (the target size, with
/// the mesh's [`fit_box`]), then `scale`, `rotate` (degrees) and
/// `translate`. Returns the linear part L = R·S, the offset and the normal
/// map (L⁻ᵀ = R·S⁻¹, S being diagonal and R orthonormal).
pub fn mesh_affine<R: Real>(
    scale: V3<R>,
    rotate: V3<R>,
    translate: V3<R>,
    fit: Option<(R, f32, Vec3)>,
) -> (M3<R>, V3<R>, M3<R>) {
    let (fit_scale, centre) = match fit {
        None => (R::one(), V3::zero()),
        Some((size, largest, centre)) => (size / R::from_f32(largest), V3::from_vec3(centre)),
    };
    let s = scale * fit_scale;
    let rot = M3::rotation_xyz_degrees(rotate);
    let linear = rot.mul_mat(&M3::diagonal(s));
    let one = R::one();
    let normal = rot.mul_mat(&M3::diagonal(V3::new(one / s.x, one / s.y, one / s.z)));
    (linear, translate - linear.mul_vec(centre), normal)
}

impl MeshTransform {
    fn new(d: &MeshDef, positions: &[Vec3]) -> Result<Self, String> {
        let scale = match d.scale {
            ScaleDef::Uniform(s) => Vec3::splat(s),
            ScaleDef::PerAxis(v) => v,
        };
        if !(scale.is_finite() && scale.abs().min_element() > 0.0) {
            return Err(format!("`scale` must be non-zero and finite, got {scale}"));
        }
        if !(d.rotate.is_finite() && d.translate.is_finite()) {
            return Err("`rotate` and `translate` must be finite".into());
        }
        let fit = match d.fit {
            None => None,
            Some(size) if size > 0.0 && size.is_finite() => {
                let (largest, centre) = fit_box(positions)?;
                Some((size, largest, centre))
            }
            Some(size) => return Err(format!("`fit` must be positive, got {size}")),
        };
        let (linear, offset, normal) =
            mesh_affine(scale.into(), d.rotate.into(), d.translate.into(), fit);
        let mat = |m: M3<f32>| {
            Mat3::from_cols(m.rows[0].into(), m.rows[1].into(), m.rows[2].into()).transpose()
        };
        Ok(Self {
            linear: mat(linear),
            normal: mat(normal),
            offset: offset.into(),
        })
    }

    fn point(&self, p: Vec3) -> Vec3 {
        self.linear * p + self.offset
    }

    fn normal(&self, n: Vec3) -> Vec3 {
        (self.normal * n).normalize_or_zero()
    }
}

/// Area-weighted vertex normals: the sum of the (unnormalised) face normals
/// around each vertex, normalised.
pub fn vertex_normals(positions: &[Vec3], triangles: &[[u32; 3]]) -> Vec<Vec3> {
    let mut normals = vec![Vec3::ZERO; positions.len()];
    for t in triangles {
        let n: Vec3 = face_area_normal(t.map(|k| V3::from(positions[k as usize]))).into();
        for &k in t {
            normals[k as usize] += n;
        }
    }
    normals.iter().map(|n| n.normalize_or_zero()).collect()
}

/// A face's normal scaled by twice its area, (b − a) × (c − a): the term
/// of [`vertex_normals`]' sums.
#[inline]
pub fn face_area_normal<R: Real>([a, b, c]: [V3<R>; 3]) -> V3<R> {
    (b - a).cross(c - a)
}
