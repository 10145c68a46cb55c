//! `kind = "accel_cost"`: what an accelerator costs and saves on one mesh
//! (S3's table of render times: basic tracer against BVHs of boxes, spheres
//! and ellipses, and the bounding-volume comparison behind it).
//!
//! One run = (mesh, accelerator, resolution). The mesh — a file (`mesh`)
//! or a procedural spec (`procedural`) — gets an automatic scene of S3's
//! kind ([`mesh_scene`]): the mesh fitted into a 2-unit box, a Phong
//! material with some reflection, one point light casting shadows, and a
//! camera that frames the mesh's bounding sphere. The run then
//!
//! 1. renders the reference image if it needs one and no earlier run of
//!    the process left it in the cache: brute force's when the mesh has at
//!    most `brute_max_faces` faces, else the `reference` accelerator's
//!    (default `bvh:aabb:sah`), and says which in `compared_with`;
//! 2. builds the accelerator (`build_s`), renders `warmup` times untimed and
//!    `repeats` times timed with [`NoStats`] (`render_median_s`), then once
//!    with [`Counters`] for the rays by kind and the per-ray means of nodes
//!    visited and of each kind of test;
//! 3. compares its image with the reference pixel by pixel (exact equality:
//!    `differing_pixels`, `max_difference` over channels);
//! 4. records the tree's shape ([`crate::accel::BvhStats`]) and the cost of
//!    one test of its own bounding volumes (`bv_test_ns`): one thread tests
//!    a fixed set of camera rays (a 32×32 grid over the image) against up
//!    to 2048 nodes spread over the tree, timed like a render
//!    (`bv_test_ns` from wall-clock time, `bv_test_cpu_ns` from CPU time).
//!
//! Brute force on a mesh above `brute_max_faces` is not rendered in full:
//! it would take minutes to hours. Its row is marked `extrapolated = true`
//! and its time is *cost per triangle test × tests it would do*: brute
//! force renders the same view at a reduced square resolution
//! (`brute_sample_side`, chosen so the sample does about
//! `brute_sample_tests` triangle tests) with repeats, giving seconds per
//! triangle test and triangle tests per ray; the tests it would do at full
//! size are those per ray times the rays the reference accelerator counted
//! at full size (the ray tree depends only on the hits, which agree). The
//! row's triangle-test count is that estimate too.

use super::render_cost::parse_resolution;
use super::{
    float_param, int_param, seconds_cell, str_param, ParamDoc, ParamError, Row, RunContext, Study,
    StudySettings, Timings,
};
use crate::accel::AccelKind;
use crate::camera::Camera;
use crate::experiment::sweep::RunPoint;
use crate::integrator::{render, Whitted};
use crate::io::image::LinearImage;
use crate::io::procedural::{Procedural, MAX_TRIANGLES};
use crate::io::scene_file::{parse_scene, Overrides};
use crate::math::Vec3;
use crate::scene::Scene;
use crate::shape::PreparedRay;
use crate::stats::{Counters, NoStats};
use anyhow::Context;
use std::collections::HashMap;
use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::Instant;

/// The `accel_cost` study.
#[derive(Clone, Copy, Debug, Default)]
pub struct AccelCost;

const PARAMETERS: &[ParamDoc] = &[
    ParamDoc {
        name: "mesh",
        doc: "mesh file (.obj .ply .off .3ds), relative to the manifest's folder; \
              or give `procedural`",
    },
    ParamDoc {
        name: "procedural",
        doc: "generated mesh instead of `mesh`: \"icosphere:LEVEL\", \
              \"torus_knot:P:Q:SEGMENTS:SIDES\" or \"terrain:N:SEED\"",
    },
    ParamDoc {
        name: "accel",
        doc: "accelerator name, as `raylab render --accel`; required",
    },
    ParamDoc {
        name: "resolution",
        doc: "image size \"WxH\" (default \"200x200\", S3's)",
    },
    ParamDoc {
        name: "brute_max_faces",
        doc: "largest mesh brute force renders in full (default 20000): above, brute \
              force is extrapolated and images are compared with `reference`",
    },
    ParamDoc {
        name: "brute_sample_tests",
        doc: "triangle tests the reduced brute-force render of an extrapolated row aims \
              at (default 1e8, a few seconds)",
    },
    ParamDoc {
        name: "reference",
        doc: "accelerator whose image is the reference where brute force is not run \
              (default \"bvh:aabb:sah\")",
    },
];

/// Default of `brute_max_faces`: brute force at 200×200 on this many faces
/// takes about a minute on the 2-core test machine (about 10⁵ rays × 2·10⁴
/// triangle tests × ~10 ns, times warm-up, repeats and the counted render
/// shared out over two threads).
pub const DEFAULT_BRUTE_MAX_FACES: i64 = 20_000;

/// Default of `brute_sample_tests`, the triangle tests the reduced
/// brute-force render of an extrapolated row aims at: 10⁸ tests take a few
/// seconds on the test machine (~20–50 ns per test and ray, 2 threads),
/// long enough for a stable per-test cost; the sample keeps at least
/// [`MIN_SAMPLE_SIDE`]² pixels.
pub const DEFAULT_BRUTE_SAMPLE_TESTS: f64 = 1.0e8;

/// Smallest side of the reduced brute-force render (64 pixels: fewer make
/// the share of rays that hit the mesh, and so tests per ray, too coarse).
pub const MIN_SAMPLE_SIDE: u32 = 8;

/// Rays per side of the camera-ray grid used to time bounding-volume tests.
const VOLUME_TEST_GRID: u32 = 32;

/// Nodes each of those rays is tested against.
const VOLUME_TEST_NODES: usize = 2048;

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
    scene.camera = Camera::new(
        eye,
        centre,
        Vec3::Y,
        FOV_DEG,
        width as f32 / height as f32,
        1.0,
        width,
        height,
    )
    .map_err(|e| anyhow::anyhow!("{}: automatic camera: {e}", name.display()))?;
    Ok(scene)
}

/// A run's parameters, parsed.
struct Config {
    source: MeshSource,
    /// How the mesh was named in the manifest (cache key, messages).
    label: String,
    accel: AccelKind,
    width: u32,
    height: u32,
    brute_max_faces: u64,
    brute_sample_tests: f64,
    reference: AccelKind,
}

fn config(run: &RunPoint, base_dir: &Path) -> Result<Config, ParamError> {
    let (source, label) = match (str_param(run, "mesh")?, str_param(run, "procedural")?) {
        (Some(_), Some(_)) => {
            return Err(ParamError::new(
                "procedural",
                "give `mesh` or `procedural`, not both",
            ))
        }
        (None, None) => {
            return Err(ParamError {
                param: None,
                message: "`mesh` or `procedural` is required (in [fixed] or in the sweep)".into(),
            })
        }
        (Some(m), None) => {
            let path = base_dir.join(m);
            if !path.is_file() {
                return Err(ParamError::new(
                    "mesh",
                    format!("{}: no such mesh file", path.display()),
                ));
            }
            (MeshSource::File(path), m.to_string())
        }
        (None, Some(p)) => (
            MeshSource::Procedural(
                parse_procedural(p).map_err(|e| ParamError::new("procedural", e))?,
            ),
            p.to_string(),
        ),
    };
    let accel_name = str_param(run, "accel")?.ok_or_else(|| ParamError {
        param: None,
        message: "`accel` is required (in [fixed] or in the sweep)".into(),
    })?;
    let accel = accel_name
        .parse::<AccelKind>()
        .map_err(|e| ParamError::new("accel", e))?;
    let (width, height) = match str_param(run, "resolution")? {
        None => (200, 200),
        Some(res) => parse_resolution(res).ok_or_else(|| {
            ParamError::new(
                "resolution",
                format!("`{res}` is not \"WxH\" with positive sides, e.g. \"200x200\""),
            )
        })?,
    };
    let brute_max_faces =
        int_param(run, "brute_max_faces", 0, i64::MAX)?.unwrap_or(DEFAULT_BRUTE_MAX_FACES) as u64;
    let brute_sample_tests = float_param(run, "brute_sample_tests", 1.0, f64::MAX)?
        .unwrap_or(DEFAULT_BRUTE_SAMPLE_TESTS);
    let reference = match str_param(run, "reference")? {
        None => "bvh:aabb:sah".parse().expect("a valid accelerator name"),
        Some(r) => r
            .parse::<AccelKind>()
            .map_err(|e| ParamError::new("reference", e))?,
    };
    if reference == AccelKind::Brute {
        return Err(ParamError::new(
            "reference",
            "must not be `brute`: it is the stand-in where brute force is too slow",
        ));
    }
    Ok(Config {
        source,
        label,
        accel,
        width,
        height,
        brute_max_faces,
        brute_sample_tests,
        reference,
    })
}

/// Reference images already rendered by this process, by (mesh, size,
/// accelerator): each BVH row of a mesh compares with the same image, and
/// rendering it once per mesh rather than once per row keeps brute force
/// affordable. A row never depends on this cache for its numbers: a miss
/// only means rendering the image again (e.g. in another shard).
fn reference_cache() -> &'static Mutex<HashMap<String, Arc<LinearImage>>> {
    static CACHE: OnceLock<Mutex<HashMap<String, Arc<LinearImage>>>> = OnceLock::new();
    CACHE.get_or_init(Default::default)
}

fn cache_key(cfg: &Config, accel: AccelKind) -> String {
    format!("{}|{}x{}|{accel}", cfg.label, cfg.width, cfg.height)
}

/// The cached image, if any (a poisoned lock only means another run
/// panicked mid-insert; the map itself is still usable).
fn cached(key: &str) -> Option<Arc<LinearImage>> {
    let map = reference_cache().lock().unwrap_or_else(|e| e.into_inner());
    map.get(key).cloned()
}

fn store(key: String, image: LinearImage) -> Arc<LinearImage> {
    let image = Arc::new(image);
    let mut map = reference_cache().lock().unwrap_or_else(|e| e.into_inner());
    map.insert(key, image.clone());
    image
}

/// How two images of the same size differ: (pixels with any channel not
/// bit-for-bit equal, largest absolute channel difference).
pub fn image_difference(a: &LinearImage, b: &LinearImage) -> (u64, f32) {
    assert_eq!(a.dim(), b.dim(), "images of different sizes");
    let (h, w, channels) = a.dim();
    let mut differing = 0u64;
    let mut max = 0.0f32;
    for y in 0..h {
        for x in 0..w {
            let mut differs = false;
            for c in 0..channels {
                let (p, q) = (a[[y, x, c]], b[[y, x, c]]);
                if p.to_bits() != q.to_bits() {
                    differs = true;
                    max = max.max((p - q).abs());
                }
            }
            differing += u64::from(differs);
        }
    }
    (differing, max)
}

/// Per-ray means written by every row: (column, counter) pairs.
const PER_RAY: [&str; 5] = [
    "nodes_visited",
    "box_tests",
    "bounding_sphere_tests",
    "bounding_ellipsoid_tests",
    "triangle_tests",
];

/// Columns of the tree's shape, empty for brute force.
const BVH_COLUMNS: [&str; 9] = [
    "bvh_nodes",
    "bvh_leaves",
    "bvh_depth",
    "mean_leaf_prims",
    "bvh_bytes",
    "sah_cost",
    "mean_area_ratio",
    "mean_volume_ratio",
    "total_volume_ratio",
];

/// What the timed part of a row measured.
struct Measured {
    timings: Timings,
    /// Factor from the timings to the reported times (1, or for an
    /// extrapolated row the full-size triangle tests over the sample's).
    scale: f64,
    counters: Counters,
    sample_side: Option<u32>,
}

impl Study for AccelCost {
    fn kind(&self) -> &'static str {
        "accel_cost"
    }

    fn parameters(&self) -> &'static [ParamDoc] {
        PARAMETERS
    }

    fn columns(&self, settings: &StudySettings) -> Vec<String> {
        let mut cols: Vec<String> = [
            "faces", "width", "height", "pixels", "threads", "load_s", "build_s",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        cols.extend((1..=settings.repeats).map(|i| format!("render_s_{i}")));
        cols.extend(
            [
                "render_median_s",
                "render_min_s",
                "render_max_s",
                "render_cpu_median_s",
                "total_s",
                "extrapolated",
                "brute_sample_side",
            ]
            .iter()
            .map(|s| s.to_string()),
        );
        cols.extend(
            Counters::default()
                .named()
                .iter()
                .map(|(name, _)| name.to_string()),
        );
        cols.push("rays".into());
        cols.extend(PER_RAY.iter().map(|c| format!("{c}_per_ray")));
        cols.extend(
            [
                "bv_tests_per_ray",
                "tests_per_ray",
                "ns_per_ray",
                "bv_test_ns",
                "bv_test_cpu_ns",
            ]
            .iter()
            .map(|s| s.to_string()),
        );
        cols.extend(BVH_COLUMNS.iter().map(|s| s.to_string()));
        cols.extend(
            [
                "compared_with",
                "differing_pixels",
                "max_difference",
                "image_equal",
            ]
            .iter()
            .map(|s| s.to_string()),
        );
        cols
    }

    fn check(&self, run: &RunPoint, base_dir: &Path) -> Result<(), ParamError> {
        config(run, base_dir).map(|_| ())
    }

    fn run(&self, run: &RunPoint, ctx: &RunContext<'_>) -> anyhow::Result<Row> {
        let cfg = config(run, ctx.base_dir).map_err(ParamError::into_error)?;
        let start = Instant::now();
        let mut scene = mesh_scene(&cfg.source, cfg.width, cfg.height)
            .with_context(|| format!("mesh `{}`", cfg.label))?;
        let load_s = start.elapsed().as_secs_f64();
        let faces = scene.triangle_count() as u64;
        let brute_runs = faces <= cfg.brute_max_faces;
        let extrapolate = cfg.accel == AccelKind::Brute && !brute_runs;
        let ref_kind = if brute_runs {
            AccelKind::Brute
        } else {
            cfg.reference
        };

        // The reference image, unless this row is the reference itself.
        let reference = if cfg.accel == ref_kind {
            None
        } else {
            let key = cache_key(&cfg, ref_kind);
            Some(match cached(&key) {
                Some(img) => img,
                None => {
                    scene.set_accel(ref_kind).map_err(anyhow::Error::msg)?;
                    let (film, _) = render::<_, NoStats>(&scene, &Whitted, None);
                    store(key, film.image())
                }
            })
        };

        let start = Instant::now();
        scene.set_accel(cfg.accel).map_err(anyhow::Error::msg)?;
        let build_s = start.elapsed().as_secs_f64();

        let settings = ctx.settings;
        let mut image = None;
        let measured = if extrapolate {
            extrapolate_brute(&mut scene, &cfg, settings)?
        } else {
            let timings = Timings::measure(settings.warmup, settings.repeats, || {
                render::<_, NoStats>(&scene, &Whitted, None)
            });
            let (film, counters) = render::<_, Counters>(&scene, &Whitted, None);
            image = Some(film.image());
            Measured {
                timings,
                scale: 1.0,
                counters,
                sample_side: None,
            }
        };
        if let (Some(img), true) = (&image, cfg.accel == ref_kind) {
            store(cache_key(&cfg, ref_kind), img.clone());
        }

        let (w, h) = (cfg.width, cfg.height);
        let c = measured.counters;
        let rays = c.rays();
        let median = measured.timings.median() * measured.scale;
        let mut row: Row = vec![
            ("faces".into(), faces.to_string()),
            ("width".into(), w.to_string()),
            ("height".into(), h.to_string()),
            ("pixels".into(), (u64::from(w) * u64::from(h)).to_string()),
            ("threads".into(), rayon::current_num_threads().to_string()),
            ("load_s".into(), seconds_cell(load_s)),
            ("build_s".into(), seconds_cell(build_s)),
        ];
        for (i, s) in measured.timings.seconds.iter().enumerate() {
            row.push((
                format!("render_s_{}", i + 1),
                seconds_cell(s * measured.scale),
            ));
        }
        row.extend([
            ("render_median_s".into(), seconds_cell(median)),
            (
                "render_min_s".into(),
                seconds_cell(measured.timings.min() * measured.scale),
            ),
            (
                "render_max_s".into(),
                seconds_cell(measured.timings.max() * measured.scale),
            ),
            (
                "render_cpu_median_s".into(),
                seconds_cell(measured.timings.cpu_median() * measured.scale),
            ),
            ("total_s".into(), seconds_cell(build_s + median)),
            ("extrapolated".into(), extrapolate.to_string()),
            (
                "brute_sample_side".into(),
                measured
                    .sample_side
                    .map(|s| s.to_string())
                    .unwrap_or_default(),
            ),
        ]);
        row.extend(
            c.named()
                .iter()
                .map(|(n, v)| (n.to_string(), v.to_string())),
        );
        row.push(("rays".into(), rays.to_string()));
        let per_ray = |v: u64| format!("{:.6}", v as f64 / rays.max(1) as f64);
        for (name, v) in c.named() {
            if PER_RAY.contains(&name) {
                row.push((format!("{name}_per_ray"), per_ray(v)));
            }
        }
        let bv_ns = volume_test_ns(&scene, settings);
        let ns_cell = |ns: Option<f64>| ns.map(|ns| format!("{ns:.4}")).unwrap_or_default();
        row.extend([
            (
                "bv_tests_per_ray".into(),
                per_ray(c.bounding_volume_tests()),
            ),
            (
                "tests_per_ray".into(),
                per_ray(c.bounding_volume_tests() + c.primitive_tests()),
            ),
            (
                "ns_per_ray".into(),
                format!("{:.3}", median * 1e9 / rays.max(1) as f64),
            ),
            ("bv_test_ns".into(), ns_cell(bv_ns.map(|t| t.0))),
            ("bv_test_cpu_ns".into(), ns_cell(bv_ns.map(|t| t.1))),
        ]);
        let stats = scene.accel.bvh_stats(&scene.prims);
        let bvh_cells: [String; 9] = match stats {
            Some(s) => [
                s.nodes.to_string(),
                s.leaves.to_string(),
                s.max_depth.to_string(),
                format!("{:.4}", s.mean_leaf_prims),
                s.memory_bytes.to_string(),
                format!("{:.4}", s.sah_cost),
                format!("{:.4}", s.mean_area_ratio),
                format!("{:.4}", s.mean_volume_ratio),
                format!("{:.4}", s.total_volume_ratio),
            ],
            None => Default::default(),
        };
        row.extend(BVH_COLUMNS.iter().map(|c| c.to_string()).zip(bvh_cells));
        let (with, diff) = match (&reference, &image) {
            (Some(r), Some(img)) => (ref_kind.to_string(), Some(image_difference(r, img))),
            _ => (String::new(), None),
        };
        row.extend([
            ("compared_with".into(), with),
            (
                "differing_pixels".into(),
                diff.map(|d| d.0.to_string()).unwrap_or_default(),
            ),
            (
                "max_difference".into(),
                diff.map(|d| format!("{:e}", d.1)).unwrap_or_default(),
            ),
            (
                "image_equal".into(),
                diff.map(|d| (d.0 == 0).to_string()).unwrap_or_default(),
            ),
        ]);
        Ok(row)
    }
}

/// Brute force's time at full size from a reduced render (module docs):
/// the reference accelerator counts the full-size rays, brute force renders
/// a square sample of about `brute_sample_tests` triangle tests with
/// repeats, and the timings are scaled by full-size tests over sample
/// tests. Leaves `scene` with brute force at the sample size.
fn extrapolate_brute(
    scene: &mut Scene,
    cfg: &Config,
    settings: StudySettings,
) -> anyhow::Result<Measured> {
    scene.set_accel(cfg.reference).map_err(anyhow::Error::msg)?;
    let (_, full) = render::<_, Counters>(scene, &Whitted, None);
    let full_camera = scene.camera;
    let pixels = f64::from(full_camera.width) * f64::from(full_camera.height);
    let rays_per_pixel = full.rays() as f64 / pixels;
    let faces = scene.triangle_count().max(1) as f64;
    let side = (cfg.brute_sample_tests / (rays_per_pixel * faces))
        .sqrt()
        .floor()
        .clamp(
            f64::from(MIN_SAMPLE_SIDE),
            f64::from(full_camera.width.min(full_camera.height)),
        ) as u32;
    // Same eye, frame and view angles; fewer, larger pixels.
    scene.camera.width = side;
    scene.camera.height = side;
    scene
        .set_accel(AccelKind::Brute)
        .map_err(anyhow::Error::msg)?;
    let timings = Timings::measure(settings.warmup, settings.repeats, || {
        render::<_, NoStats>(scene, &Whitted, None)
    });
    let (_, sample) = render::<_, Counters>(scene, &Whitted, None);
    scene.camera = full_camera;
    let tests_per_ray = sample.triangle_tests as f64 / sample.rays().max(1) as f64;
    let full_tests = tests_per_ray * full.rays() as f64;
    let counters = Counters {
        nodes_visited: 0,
        box_tests: 0,
        bounding_sphere_tests: 0,
        bounding_ellipsoid_tests: 0,
        triangle_tests: full_tests.round() as u64,
        ..full
    };
    Ok(Measured {
        timings,
        scale: full_tests / sample.triangle_tests.max(1) as f64,
        counters,
        sample_side: Some(side),
    })
}

/// Nanoseconds per test of the scene's own bounding volumes (module docs),
/// from the median wall-clock and the median process CPU time (the test
/// loop runs on one thread, so on a shared machine the CPU time is the
/// steadier of the two); `None` without a BVH.
fn volume_test_ns(scene: &Scene, settings: StudySettings) -> Option<(f64, f64)> {
    let cam = &scene.camera;
    let rays: Vec<PreparedRay> = (0..VOLUME_TEST_GRID * VOLUME_TEST_GRID)
        .map(|i| {
            let (gx, gy) = (i % VOLUME_TEST_GRID, i / VOLUME_TEST_GRID);
            let x = (gx as f32 + 0.5) * cam.width as f32 / VOLUME_TEST_GRID as f32;
            let y = (gy as f32 + 0.5) * cam.height as f32 / VOLUME_TEST_GRID as f32;
            PreparedRay::new(cam.generate_ray(x, y))
        })
        .collect();
    let (tests, _) = scene.accel.test_volumes(&rays, VOLUME_TEST_NODES)?;
    let t = Timings::measure(settings.warmup.max(1), settings.repeats.max(1), || {
        black_box(
            scene
                .accel
                .test_volumes(black_box(&rays), VOLUME_TEST_NODES),
        )
    });
    let per_test = 1e9 / tests.max(1) as f64;
    Some((t.median() * per_test, t.cpu_median() * per_test))
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::Array3;

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

    #[test]
    fn image_difference_counts_pixels_not_channels() {
        let a = Array3::<f32>::zeros((2, 3, 3));
        let mut b = a.clone();
        b[[1, 2, 0]] = 0.25;
        b[[1, 2, 2]] = -0.5;
        b[[0, 0, 1]] = 0.125;
        assert_eq!(image_difference(&a, &b), (2, 0.5));
        assert_eq!(image_difference(&a, &a), (0, 0.0));
    }
}
