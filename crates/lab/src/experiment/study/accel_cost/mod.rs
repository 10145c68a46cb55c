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
//! 4. records the tree's shape ([`raylab::accel::BvhStats`]) and the cost of
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

mod measure;
mod scene;

pub use measure::{image_difference, ImageDifference, MIN_SAMPLE_SIDE};
pub use scene::{mesh_scene, parse_procedural, LabelledMesh, MeshSource, ProceduralSpec};

use super::{RunContext, Study, StudySettings, Timings};
use crate::experiment::params::{
    or_default, parsed, parsed_opt, typed_params, InRange, ParamDoc, Resolution, RunParamError,
};
use crate::experiment::row::{CounterCells, Exp, Fixed, Secs};
use crate::experiment::sweep::RunPoint;
use crate::Error;
use measure::{cache_key, cached, extrapolate_brute, store, volume_test_ns, Measured};
use raylab::accel::AccelKind;
use raylab::integrator::{render, Whitted};
use raylab::stats::{Counters, NoStats};
use serde::ser::SerializeMap;
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::time::Instant;

/// The `accel_cost` study.
#[derive(Clone, Copy, Debug, Default)]
pub struct AccelCost;

/// The parameters of a run.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AccelCostParams {
    /// Mesh file, relative to the manifest's folder.
    #[serde(default)]
    pub mesh: Option<String>,
    /// Generated mesh instead of `mesh`.
    #[serde(default, deserialize_with = "parsed_opt")]
    pub procedural: Option<ProceduralSpec>,
    /// The accelerator measured.
    #[serde(deserialize_with = "parsed")]
    pub accel: AccelKind,
    /// Image size.
    #[serde(default, deserialize_with = "parsed_opt")]
    pub resolution: Option<Resolution>,
    /// Largest mesh brute force renders in full.
    #[serde(default)]
    pub brute_max_faces: Option<InRange<0, { i64::MAX }>>,
    /// Triangle tests of the reduced brute-force render.
    #[serde(default)]
    pub brute_sample_tests: Option<f64>,
    /// Reference accelerator where brute force is not run.
    #[serde(default, deserialize_with = "parsed_opt")]
    pub reference: Option<AccelKind>,
}

typed_params!(
    AccelCostParams,
    [
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
    ]
);

/// Default of `brute_max_faces`: brute force at 200×200 on this many faces
/// takes about a minute on the 2-core test machine (about 10⁵ rays × 2·10⁴
/// triangle tests × ~10 ns, times warm-up, repeats and the counted render
/// shared out over two threads).
pub const DEFAULT_BRUTE_MAX_FACES: u64 = 20_000;

/// Default of `brute_sample_tests`, the triangle tests the reduced
/// brute-force render of an extrapolated row aims at: 10⁸ tests take a few
/// seconds on the test machine (~20–50 ns per test and ray, 2 threads),
/// long enough for a stable per-test cost; the sample keeps at least
/// [`MIN_SAMPLE_SIDE`]² pixels.
pub const DEFAULT_BRUTE_SAMPLE_TESTS: f64 = 1.0e8;

/// A run's parameters, checked.
pub struct AccelCostConfig {
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

/// Counters whose per-ray means every row has (`…_per_ray`).
pub const PER_RAY: [&str; 5] = [
    "nodes_visited",
    "box_tests",
    "bounding_sphere_tests",
    "bounding_ellipsoid_tests",
    "triangle_tests",
];

/// The per-ray means of [`PER_RAY`], as `NAME_per_ray` columns in the
/// order of [`Counters::named`].
#[derive(Clone, Copy, Debug, Default)]
pub struct PerRay {
    /// The counters of the row.
    pub counters: Counters,
    /// The rays they are divided by.
    pub rays: u64,
}

impl Serialize for PerRay {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut map = s.serialize_map(Some(PER_RAY.len()))?;
        for (name, v) in self.counters.named() {
            if PER_RAY.contains(&name) {
                let mean = Fixed::<6>(v as f64 / self.rays.max(1) as f64);
                map.serialize_entry(&format!("{name}_per_ray"), &mean)?;
            }
        }
        map.end()
    }
}

/// The tree's shape ([`raylab::accel::BvhStats`]); empty cells for brute
/// force.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct BvhCells {
    /// Nodes.
    pub bvh_nodes: Option<usize>,
    /// Leaves.
    pub bvh_leaves: Option<usize>,
    /// Depth.
    pub bvh_depth: Option<usize>,
    /// Mean primitives per leaf.
    pub mean_leaf_prims: Option<Fixed<4>>,
    /// Memory.
    pub bvh_bytes: Option<usize>,
    /// SAH cost of the tree.
    pub sah_cost: Option<Fixed<4>>,
    /// Mean child-to-parent area ratio.
    pub mean_area_ratio: Option<Fixed<4>>,
    /// Mean child-to-parent volume ratio.
    pub mean_volume_ratio: Option<Fixed<4>>,
    /// Total volume of the nodes over the root's.
    pub total_volume_ratio: Option<Fixed<4>>,
}

/// One row: an accelerator on a mesh.
#[derive(Clone, Debug, Default, Serialize)]
pub struct AccelCostRow {
    /// Triangles of the mesh.
    pub faces: u64,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Pixels of the image.
    pub pixels: u64,
    /// Worker threads rendering.
    pub threads: usize,
    /// Loading the mesh and making the scene.
    pub load_s: Secs,
    /// Building the accelerator.
    pub build_s: Secs,
    /// Each timed render (scaled for an extrapolated row).
    pub render_s: Vec<Secs>,
    /// Median of the timed renders.
    pub render_median_s: Secs,
    /// Shortest timed render.
    pub render_min_s: Secs,
    /// Longest timed render.
    pub render_max_s: Secs,
    /// Median process CPU time of the timed renders.
    pub render_cpu_median_s: Secs,
    /// Build plus median render.
    pub total_s: Secs,
    /// Whether the times are extrapolated (brute force on a large mesh).
    pub extrapolated: bool,
    /// Side of the reduced render an extrapolation used.
    pub brute_sample_side: Option<u32>,
    /// Every counter of the counted render.
    #[serde(flatten)]
    pub counters: CounterCells,
    /// Rays of every kind.
    pub rays: u64,
    /// Per-ray means of nodes and tests.
    #[serde(flatten)]
    pub per_ray: PerRay,
    /// Bounding-volume tests per ray.
    pub bv_tests_per_ray: Fixed<6>,
    /// Bounding-volume and primitive tests per ray.
    pub tests_per_ray: Fixed<6>,
    /// Median render time per ray, ns.
    pub ns_per_ray: Fixed<3>,
    /// One bounding-volume test, ns (wall clock).
    pub bv_test_ns: Option<Fixed<4>>,
    /// One bounding-volume test, ns (CPU time).
    pub bv_test_cpu_ns: Option<Fixed<4>>,
    /// The tree's shape.
    #[serde(flatten)]
    pub bvh: BvhCells,
    /// The accelerator whose image this one is compared with.
    pub compared_with: String,
    /// Pixels that differ.
    pub differing_pixels: Option<u64>,
    /// Largest channel difference.
    pub max_difference: Option<Exp<f32>>,
    /// Whether the images are equal.
    pub image_equal: Option<bool>,
}

impl Study for AccelCost {
    type Params = AccelCostParams;
    type Config = AccelCostConfig;
    type Row = AccelCostRow;

    fn configure(
        &self,
        p: AccelCostParams,
        base_dir: &Path,
    ) -> Result<AccelCostConfig, RunParamError> {
        let LabelledMesh { source, label } =
            MeshSource::from_params(p.mesh, p.procedural, base_dir)?;
        let res = p.resolution.unwrap_or(Resolution {
            width: 200,
            height: 200,
        });
        let brute_sample_tests = p.brute_sample_tests.unwrap_or(DEFAULT_BRUTE_SAMPLE_TESTS);
        if brute_sample_tests < 1.0 {
            return Err(RunParamError::new(
                "brute_sample_tests",
                format!("must be a number of at least 1, got {brute_sample_tests}"),
            ));
        }
        let reference = or_default(p.reference, "reference", "bvh:aabb:sah")?;
        if reference == AccelKind::Brute {
            return Err(RunParamError::new(
                "reference",
                "must not be `brute`: it is the stand-in where brute force is too slow",
            ));
        }
        Ok(AccelCostConfig {
            source,
            label,
            accel: p.accel,
            width: res.width,
            height: res.height,
            brute_max_faces: p
                .brute_max_faces
                .map_or(DEFAULT_BRUTE_MAX_FACES, |n| n.get() as u64),
            brute_sample_tests,
            reference,
        })
    }

    fn template(&self, settings: &StudySettings) -> AccelCostRow {
        AccelCostRow {
            render_s: vec![Secs::default(); settings.repeats as usize],
            ..Default::default()
        }
    }

    fn run(
        &self,
        cfg: AccelCostConfig,
        _run: &RunPoint,
        ctx: &RunContext<'_>,
    ) -> Result<AccelCostRow, Error> {
        let start = Instant::now();
        let mut scene =
            mesh_scene(&cfg.source, cfg.width, cfg.height).map_err(|e| Error::Mesh {
                label: cfg.label.clone(),
                error: Box::new(e),
            })?;
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
                    scene.set_accel(ref_kind).map_err(Error::accel(ref_kind))?;
                    let (film, _) = render::<_, NoStats>(&scene, &Whitted, None);
                    store(key, film.image())
                }
            })
        };

        let start = Instant::now();
        scene
            .set_accel(cfg.accel)
            .map_err(Error::accel(cfg.accel))?;
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
        let scaled = |s: f64| Secs(s * measured.scale);
        let median = measured.timings.median() * measured.scale;
        let per_ray = |v: u64| Fixed(v as f64 / rays.max(1) as f64);
        let bv_ns = volume_test_ns(&scene, settings);
        let bvh = match scene.accel.bvh_stats(&scene.prims) {
            Some(s) => BvhCells {
                bvh_nodes: Some(s.nodes),
                bvh_leaves: Some(s.leaves),
                bvh_depth: Some(s.max_depth),
                mean_leaf_prims: Some(Fixed(s.mean_leaf_prims)),
                bvh_bytes: Some(s.memory_bytes),
                sah_cost: Some(Fixed(s.sah_cost)),
                mean_area_ratio: Some(Fixed(s.mean_area_ratio)),
                mean_volume_ratio: Some(Fixed(s.mean_volume_ratio)),
                total_volume_ratio: Some(Fixed(s.total_volume_ratio)),
            },
            None => BvhCells::default(),
        };
        let (compared_with, diff) = match (&reference, &image) {
            (Some(r), Some(img)) => (ref_kind.to_string(), Some(image_difference(r, img))),
            _ => (String::new(), None),
        };
        Ok(AccelCostRow {
            faces,
            width: w,
            height: h,
            pixels: u64::from(w) * u64::from(h),
            threads: rayon::current_num_threads(),
            load_s: Secs(load_s),
            build_s: Secs(build_s),
            render_s: measured
                .timings
                .seconds
                .iter()
                .map(|&s| scaled(s))
                .collect(),
            render_median_s: Secs(median),
            render_min_s: scaled(measured.timings.min()),
            render_max_s: scaled(measured.timings.max()),
            render_cpu_median_s: scaled(measured.timings.cpu_median()),
            total_s: Secs(build_s + median),
            extrapolated: extrapolate,
            brute_sample_side: measured.sample_side,
            counters: CounterCells(c),
            rays,
            per_ray: PerRay { counters: c, rays },
            bv_tests_per_ray: per_ray(c.bounding_volume_tests()),
            tests_per_ray: per_ray(c.bounding_volume_tests() + c.primitive_tests()),
            ns_per_ray: Fixed(median * 1e9 / rays.max(1) as f64),
            bv_test_ns: bv_ns.map(|t| Fixed(t.0)),
            bv_test_cpu_ns: bv_ns.map(|t| Fixed(t.1)),
            bvh,
            compared_with,
            differing_pixels: diff.map(|d| d.pixels),
            max_difference: diff.map(|d| Exp(d.max)),
            image_equal: diff.map(|d| d.pixels == 0),
        })
    }
}
