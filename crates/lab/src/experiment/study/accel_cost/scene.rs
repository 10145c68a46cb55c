//! The automatic scene of an `accel_cost` run: where its mesh comes from
//! ([`MeshSource`], a file or a procedural spec such as
//! "icosphere:LEVEL") and S3's kind of image of it ([`mesh_scene`]).

use crate::experiment::params::FromParam;
use raylab::camera::{Camera, CameraDesc};
use raylab::io::procedural::{Procedural, MAX_TRIANGLES};
use raylab::io::scene_file::{parse_scene, Overrides};
use raylab::math::Vec3;
use raylab::scene::Scene;
use std::path::PathBuf;

/// Vertical view angle of the automatic camera, in degrees.
const FOV_DEG: f32 = 40.0;

/// Where a run's mesh comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum MeshSource {
    /// A mesh file (absolute, or relative to the working directory).
    File(PathBuf),
    /// A generated mesh.
    Procedural(Procedural),
}

impl MeshSource {
    /// The mesh a run names by `mesh` (a file, relative to the manifest's
    /// folder `base_dir`) or by `procedural`, exactly one of them; with
    /// the label its rows carry.
    pub fn from_params(
        mesh: Option<String>,
        procedural: Option<ProceduralSpec>,
        base_dir: &std::path::Path,
    ) -> Result<(Self, String), crate::experiment::params::ParamError> {
        use crate::experiment::params::{existing_file, ParamError};
        match (mesh, procedural) {
            (Some(_), Some(_)) => Err(ParamError::new(
                "procedural",
                "give `mesh` or `procedural`, not both",
            )),
            (None, None) => Err(ParamError::run(
                "`mesh` or `procedural` is required (in [fixed] or in the sweep)",
            )),
            (Some(m), None) => Ok((
                MeshSource::File(existing_file(base_dir, "mesh", &m, "mesh")?),
                m,
            )),
            (None, Some(spec)) => Ok((MeshSource::Procedural(spec.procedural), spec.text)),
        }
    }

    /// The `[[mesh]]` lines of a scene file that load this mesh.
    fn scene_lines(&self) -> String {
        match self {
            // Relative to the scene's name, which sits beside the mesh.
            MeshSource::File(p) => format!(
                "file = {}",
                toml::Value::String(
                    p.file_name()
                        .map(|n| n.to_string_lossy().into_owned())
                        .unwrap_or_default()
                )
            ),
            MeshSource::Procedural(Procedural::Icosphere { level }) => {
                format!("procedural = {{ kind = \"icosphere\", level = {level} }}")
            }
            MeshSource::Procedural(Procedural::TorusKnot {
                p,
                q,
                segments,
                sides,
            }) => format!(
                "procedural = {{ kind = \"torus_knot\", p = {p}, q = {q}, \
                 segments = {segments}, sides = {sides} }}"
            ),
            MeshSource::Procedural(Procedural::Terrain { n, seed }) => {
                format!("procedural = {{ kind = \"terrain\", n = {n}, seed = {seed} }}")
            }
        }
    }
}

/// Parse "icosphere:LEVEL", "torus_knot:P:Q:SEGMENTS:SIDES" or
/// "terrain:N:SEED".
pub fn parse_procedural(spec: &str) -> Result<Procedural, String> {
    let parts: Vec<&str> = spec.split(':').collect();
    let num = |i: usize| -> Result<u64, String> {
        parts[i]
            .trim()
            .parse()
            .map_err(|_| format!("`{}` in `{spec}` is not a non-negative integer", parts[i]))
    };
    let small = |i: usize| -> Result<u32, String> {
        u32::try_from(num(i)?).map_err(|_| format!("`{}` in `{spec}` is too large", parts[i]))
    };
    let p = match (parts[0], parts.len()) {
        ("icosphere", 2) => Procedural::Icosphere { level: small(1)? },
        ("torus_knot", 5) => Procedural::TorusKnot {
            p: small(1)?,
            q: small(2)?,
            segments: small(3)?,
            sides: small(4)?,
        },
        ("terrain", 3) => Procedural::Terrain {
            n: small(1)?,
            seed: num(2)?,
        },
        _ => {
            return Err(format!(
                "`{spec}` is not \"icosphere:LEVEL\", \"torus_knot:P:Q:SEGMENTS:SIDES\" \
                 or \"terrain:N:SEED\""
            ))
        }
    };
    let count = p.triangle_count();
    if count == 0 || count > MAX_TRIANGLES {
        return Err(format!(
            "`{spec}` gives {count} triangles; expected 1 to {MAX_TRIANGLES}"
        ));
    }
    Ok(p)
}

/// S3's kind of image of a mesh, as a scene: the mesh centred and scaled so
/// its largest side is 2 (`fit = 2`), a warm Phong material (k_a 0.1,
/// k_d 0.7, k_s 0.4, shininess 40, reflectivity 0.2: reflection rays from
/// every hit, mostly leaving the mesh), one point light above and in front
/// to the left (shadow rays from every hit), a dark blue background, and a
/// pinhole camera (40° vertical view) looking at the centre of the mesh's
/// bounding box from the front, slightly above and to the right, at the
/// distance where the box's bounding sphere just fits the image height.
/// S3 also made its meshes transparent; raylab's automatic scene does not,
/// because refraction through the many test meshes that are not closed
/// would make the ray tree depend on their holes. The accelerator is brute
/// force (free to build); change it with [`Scene::set_accel`].
pub fn mesh_scene(source: &MeshSource, width: u32, height: u32) -> anyhow::Result<Scene> {
    let text = format!(
        "[image]\nwidth = {width}\nheight = {height}\n\n\
         [camera]\neye = [0.0, 0.0, 5.0]\nlook_at = [0.0, 0.0, 0.0]\nfov = {FOV_DEG}\n\n\
         [render]\nbackground = [0.05, 0.06, 0.1]\nambient = [1.0, 1.0, 1.0]\n\
         max_depth = 5\naccel = \"brute\"\n\n\
         [materials.s3]\ncolor = [0.8, 0.62, 0.42]\nambient = 0.1\ndiffuse = 0.7\n\
         specular = 0.4\nshininess = 40.0\nreflectivity = 0.2\n\n\
         [[mesh]]\n{}\nmaterial = \"s3\"\nfit = 2.0\n\n\
         [[light]]\nposition = [-4.0, 6.0, 6.0]\n",
        source.scene_lines()
    );
    let name = match source {
        MeshSource::File(p) => p.with_extension("auto-scene.toml"),
        MeshSource::Procedural(_) => PathBuf::from("procedural.auto-scene.toml"),
    };
    let mut scene = parse_scene(&text, &name, &Overrides::default())?;
    let b = scene.bounds();
    if b.min.x > b.max.x {
        anyhow::bail!("{}: the mesh has no triangles", name.display());
    }
    let centre = 0.5 * (b.min + b.max);
    let radius = (0.5 * (b.max - b.min).length()).max(1e-3);
    let distance = radius / (0.5 * FOV_DEG.to_radians()).sin();
    let eye = centre + distance * Vec3::new(0.3, 0.35, 1.0).normalize();
    let desc = CameraDesc {
        eye,
        look_at: centre,
        up: Vec3::Y,
        fov: FOV_DEG,
        near: 1.0,
        aspect: None,
    };
    scene.camera = Camera::new(&desc, width, height)
        .map_err(|e| anyhow::anyhow!("{}: automatic camera: {e}", name.display()))?;
    Ok(scene)
}

/// The `procedural` parameter: the spec as written (it names the mesh in
/// messages) and the mesh it describes.
#[derive(Clone, Debug, PartialEq)]
pub struct ProceduralSpec {
    /// The spec, e.g. "icosphere:4".
    pub text: String,
    /// The generated mesh it describes.
    pub procedural: Procedural,
}

impl FromParam for ProceduralSpec {
    fn from_param(s: &str) -> Result<Self, String> {
        Ok(ProceduralSpec {
            text: s.to_string(),
            procedural: parse_procedural(s)?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn procedural_specs_parse_and_reject() {
        assert_eq!(
            parse_procedural("icosphere:3"),
            Ok(Procedural::Icosphere { level: 3 })
        );
        assert_eq!(
            parse_procedural("torus_knot:2:3:100:10"),
            Ok(Procedural::TorusKnot {
                p: 2,
                q: 3,
                segments: 100,
                sides: 10
            })
        );
        assert!(parse_procedural("terrain:4").is_err());
        assert!(parse_procedural("icosphere:x").is_err());
        assert!(parse_procedural("icosphere:20")
            .unwrap_err()
            .contains("triangles; expected 1 to"));
        assert!(parse_procedural("cube:1").is_err());
    }
}
