//! `kind = "embree_oracle"`: raylab's intersections against Embree 4 on one
//! input per run (a mesh file, or random spheres or ellipsoids), through
//! [`crate::validate`]: every ray set, one raylab accelerator, one row of
//! disagreement counts by class and |Δt|/t and normal-angle percentiles.
//! Each run also writes its histograms (`<input>-rel-dt`,
//! `<input>-normal-angle`) and its disagreement bar chart beside data.csv.

use super::{RunContext, Study};
use crate::experiment::params::{
    existing_file, or_default, parsed_opt, typed_params, InRange, ParamDoc, RunParamError,
};
use crate::experiment::row::{Exp, Fixed, Secs};
use crate::experiment::sweep::RunPoint;
use crate::validate::{random_quadrics, validate, HitPlace, Input, ValidationOptions};
use crate::Error;
use raylab::accel::{AccelKind, EmbreeConfig};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The `embree_oracle` study.
#[derive(Clone, Copy, Debug, Default)]
pub struct EmbreeOracle;

/// Random quadrics instead of a mesh.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Quadrics {
    /// Random spheres.
    Spheres,
    /// Random ellipsoids.
    Ellipsoids,
}

/// The parameters of a run.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EmbreeOracleParams {
    /// Mesh file, relative to the manifest's folder.
    #[serde(default)]
    pub mesh: Option<String>,
    /// Random quadrics instead of a mesh.
    #[serde(default)]
    pub quadrics: Option<Quadrics>,
    /// Number of quadrics.
    #[serde(default)]
    pub count: Option<InRange<1, 1_000_000>>,
    /// Rays per ray set.
    #[serde(default)]
    pub rays: Option<InRange<1, 100_000_000>>,
    /// Seed of the ray sets.
    #[serde(default)]
    pub seed: Option<u64>,
    /// raylab accelerator under test.
    #[serde(default, deserialize_with = "parsed_opt")]
    pub accel: Option<AccelKind>,
    /// Embree configuration.
    #[serde(default, deserialize_with = "parsed_opt")]
    pub embree: Option<EmbreeConfig>,
}

typed_params!(
    EmbreeOracleParams,
    [
        ParamDoc {
            name: "mesh",
            doc: "mesh file (.obj, .ply, .off, .3ds), relative to the manifest's folder; \
                  or `quadrics` instead",
        },
        ParamDoc {
            name: "quadrics",
            doc: "`spheres` or `ellipsoids`: `count` random ones in [−10, 10]³ (see \
                  `validate::random_quadrics`)",
        },
        ParamDoc {
            name: "count",
            doc: "number of quadrics (default 200)",
        },
        ParamDoc {
            name: "rays",
            doc: "rays per ray set (default 10000)",
        },
        ParamDoc {
            name: "seed",
            doc: "seed of the ray sets (default 1)",
        },
        ParamDoc {
            name: "accel",
            doc: "raylab accelerator under test (default `bvh`)",
        },
        ParamDoc {
            name: "embree",
            doc: "Embree configuration, `embree[:low|medium|high][+robust]` (default `embree`)",
        },
    ]
);

/// One row: the disagreements of one input.
#[derive(Clone, Debug, Default, Serialize)]
pub struct EmbreeOracleRow {
    /// The input's name.
    pub input: String,
    /// A short label for bar charts.
    pub label: String,
    /// Primitives of the input.
    pub primitives: usize,
    /// Triangles of the input.
    pub triangles: usize,
    /// Whether the mesh is closed.
    pub closed: bool,
    /// Ray sets traced.
    pub sets: usize,
    /// Rays over all sets.
    pub rays_total: u64,
    /// Rays that hit.
    pub hits: u64,
    /// Ties at an edge.
    pub tie_edge: u64,
    /// Ties between coincident surfaces.
    pub tie_coincident: u64,
    /// Disagreements at an edge.
    pub edge: u64,
    /// Disagreements at a vertex.
    pub vertex: u64,
    /// Disagreements at grazing angles.
    pub grazing: u64,
    /// Disagreements at the ray's origin (rays that start on a surface).
    pub origin: u64,
    /// Disagreements elsewhere.
    pub elsewhere: u64,
    /// Edge and vertex rays where raylab missed.
    pub leak_raylab: u64,
    /// Edge and vertex rays where Embree missed.
    pub leak_embree: u64,
    /// Any-hit disagreements explained by closest-hit ones.
    pub any_hit_explained: u64,
    /// Disagreements no class explains.
    pub unexplained: u64,
    /// Edge disagreements per million rays.
    pub edge_per_million: Fixed<1>,
    /// Vertex disagreements per million rays.
    pub vertex_per_million: Fixed<1>,
    /// Median |Δt|/t.
    pub rel_dt_p50: Exp,
    /// 99th percentile of |Δt|/t.
    pub rel_dt_p99: Exp,
    /// Largest |Δt|/t.
    pub rel_dt_max: Exp,
    /// Largest |Δt|/t above the rounding floor.
    pub rel_dt_max_above_floor: Exp,
    /// Median angle between the normals.
    pub normal_angle_p50: Exp,
    /// Largest angle between the normals.
    pub normal_angle_max: Exp,
    /// Time to validate.
    pub seconds: Secs,
}

/// What one run validates.
pub enum Source {
    /// A mesh file.
    Mesh(PathBuf),
    /// Random quadrics.
    Quadrics {
        /// Ellipsoids rather than spheres.
        ellipsoids: bool,
        /// How many.
        count: usize,
    },
}

/// A run's parameters, checked.
pub struct EmbreeOracleConfig {
    source: Source,
    options: ValidationOptions,
}

/// A category label short enough for a bar chart of a dozen inputs: the
/// file's stem, cut to 6 characters and an ellipsis if longer than 7.
fn short_label(name: &str) -> String {
    let stem = name.rsplit_once('.').map_or(name, |(s, _)| s);
    if stem.chars().count() <= 7 {
        stem.to_string()
    } else {
        stem.chars().take(6).chain(['…']).collect()
    }
}

fn per_million(count: u64, rays: u64) -> Fixed<1> {
    Fixed(count as f64 * 1e6 / rays.max(1) as f64)
}

impl Study for EmbreeOracle {
    type Params = EmbreeOracleParams;
    type Config = EmbreeOracleConfig;
    type Row = EmbreeOracleRow;

    fn configure(
        &self,
        p: EmbreeOracleParams,
        base_dir: &Path,
    ) -> Result<EmbreeOracleConfig, RunParamError> {
        let source = match (&p.mesh, p.quadrics) {
            (Some(m), None) => Source::Mesh(existing_file(base_dir, "mesh", m, "mesh")?),
            (None, Some(q)) => Source::Quadrics {
                ellipsoids: q == Quadrics::Ellipsoids,
                count: p.count.map_or(200, |c| c.get() as usize),
            },
            _ => {
                return Err(RunParamError::run(
                    "give exactly one of `mesh` and `quadrics`",
                ))
            }
        };
        let options = ValidationOptions {
            rays: p.rays.map_or(10_000, |r| r.get() as usize),
            seed: p.seed.unwrap_or(1),
            accels: vec![or_default(p.accel, "accel", "bvh")?],
            embree: or_default(p.embree, "embree", "embree")?,
            ..ValidationOptions::default()
        };
        Ok(EmbreeOracleConfig { source, options })
    }

    fn run(
        &self,
        cfg: EmbreeOracleConfig,
        _run: &RunPoint,
        ctx: &RunContext<'_>,
    ) -> Result<EmbreeOracleRow, Error> {
        let input = match &cfg.source {
            Source::Mesh(path) => Input::from_mesh(path)?,
            Source::Quadrics { ellipsoids, count } => Input {
                name: if *ellipsoids { "ellipsoids" } else { "spheres" }.into(),
                prims: random_quadrics(*count, cfg.options.seed, *ellipsoids),
                camera: None,
            },
        };
        let start = Instant::now();
        let report = validate(&input, &cfg.options)?;
        let seconds = start.elapsed().as_secs_f64();
        let stem = format!("{}-", input.name.replace(['.', ' ', ':'], "-"));
        report.write_figures(ctx.out_dir, &stem)?;
        let t = report.overall();
        let dt = t.rel_dt_percentiles();
        let angle = t.normal_angle_percentiles();
        Ok(EmbreeOracleRow {
            label: short_label(&input.name),
            input: input.name,
            primitives: report.primitives,
            triangles: report.triangles,
            closed: report.closed,
            sets: report.sets.len(),
            rays_total: t.rays,
            hits: t.hits(),
            tie_edge: t.tie_edge,
            tie_coincident: t.tie_coincident,
            edge: t.disagreements_at(HitPlace::Edge),
            vertex: t.disagreements_at(HitPlace::Vertex),
            grazing: t.disagreements_at(HitPlace::Grazing),
            origin: t.disagreements_at(HitPlace::Origin),
            elsewhere: t.disagreements_at(HitPlace::Elsewhere),
            leak_raylab: t.edge_leaks.0,
            leak_embree: t.edge_leaks.1,
            any_hit_explained: t.any_hit_explained,
            unexplained: t.unexplained(),
            edge_per_million: per_million(t.disagreements_at(HitPlace::Edge), t.rays),
            vertex_per_million: per_million(t.disagreements_at(HitPlace::Vertex), t.rays),
            rel_dt_p50: Exp(dt[0]),
            rel_dt_p99: Exp(dt[1]),
            rel_dt_max: Exp(dt[2]),
            rel_dt_max_above_floor: Exp(t.max_rel_dt_above_floor as f64),
            normal_angle_p50: Exp(angle[0]),
            normal_angle_max: Exp(angle[2]),
            seconds: Secs(seconds),
        })
    }
}
