//! `kind = "embree_oracle"`: raylab's intersections against Embree 4 on one
//! input per run (a mesh file, or random spheres or ellipsoids), through
//! [`crate::validate`]: every ray set, one raylab accelerator, one row of
//! disagreement counts by class and |Δt|/t and normal-angle percentiles.
//! Each run also writes its histograms (`<input>-rel-dt`,
//! `<input>-normal-angle`) and its disagreement bar chart beside data.csv.

use super::{
    int_param, seconds_cell, str_param, ParamDoc, ParamError, Row, RunContext, Study, StudySettings,
};
use crate::accel::{AccelKind, EmbreeConfig};
use crate::experiment::sweep::RunPoint;
use crate::validate::{random_quadrics, validate, Input, Options, Place};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The `embree_oracle` study.
#[derive(Clone, Copy, Debug, Default)]
pub struct EmbreeOracle;

const PARAMETERS: &[ParamDoc] = &[
    ParamDoc {
        name: "mesh",
        doc: "mesh file (.obj, .ply, .off, .3ds), relative to the manifest's folder; \
              or `quadrics` instead",
    },
    ParamDoc {
        name: "quadrics",
        doc: "`spheres` or `ellipsoids`: `count` random ones in [−10, 10]³ (see `validate::random_quadrics`)",
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
];

const COLUMNS: &[&str] = &[
    "input",
    "label",
    "primitives",
    "triangles",
    "closed",
    "sets",
    "rays_total",
    "hits",
    "tie_edge",
    "tie_coincident",
    "edge",
    "vertex",
    "grazing",
    "elsewhere",
    "leak_raylab",
    "leak_embree",
    "any_hit_explained",
    "unexplained",
    "edge_per_million",
    "vertex_per_million",
    "rel_dt_p50",
    "rel_dt_p99",
    "rel_dt_max",
    "rel_dt_max_above_floor",
    "normal_angle_p50",
    "normal_angle_max",
    "seconds",
];

/// What one run validates.
enum Source {
    Mesh(PathBuf),
    Quadrics { ellipsoids: bool, count: usize },
}

struct Config {
    source: Source,
    options: Options,
}

fn config(run: &RunPoint, base_dir: &Path) -> Result<Config, ParamError> {
    let source = match (str_param(run, "mesh")?, str_param(run, "quadrics")?) {
        (Some(m), None) => {
            let path = base_dir.join(m);
            if !path.is_file() {
                return Err(ParamError::new(
                    "mesh",
                    format!("{}: no such mesh file", path.display()),
                ));
            }
            Source::Mesh(path)
        }
        (None, Some(q)) => {
            let ellipsoids = match q {
                "spheres" => false,
                "ellipsoids" => true,
                _ => {
                    return Err(ParamError::new(
                        "quadrics",
                        format!("`{q}`: expected `spheres` or `ellipsoids`"),
                    ))
                }
            };
            let count = int_param(run, "count", 1, 1_000_000)?.unwrap_or(200) as usize;
            Source::Quadrics { ellipsoids, count }
        }
        _ => {
            return Err(ParamError {
                param: None,
                message: "give exactly one of `mesh` and `quadrics`".into(),
            })
        }
    };
    let accel = str_param(run, "accel")?
        .unwrap_or("bvh")
        .parse::<AccelKind>()
        .map_err(|e| ParamError::new("accel", e))?;
    let embree = str_param(run, "embree")?
        .unwrap_or("embree")
        .parse::<EmbreeConfig>()
        .map_err(|e| ParamError::new("embree", e))?;
    let options = Options {
        rays: int_param(run, "rays", 1, 100_000_000)?.unwrap_or(10_000) as usize,
        seed: int_param(run, "seed", 0, i64::MAX)?.unwrap_or(1) as u64,
        accels: vec![accel],
        embree,
        ..Options::default()
    };
    Ok(Config { source, options })
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

fn per_million(count: u64, rays: u64) -> String {
    format!("{:.1}", count as f64 * 1e6 / rays.max(1) as f64)
}

impl Study for EmbreeOracle {
    fn kind(&self) -> &'static str {
        "embree_oracle"
    }

    fn parameters(&self) -> &'static [ParamDoc] {
        PARAMETERS
    }

    fn columns(&self, _settings: &StudySettings) -> Vec<String> {
        COLUMNS.iter().map(|s| s.to_string()).collect()
    }

    fn check(&self, run: &RunPoint, base_dir: &Path) -> Result<(), ParamError> {
        config(run, base_dir).map(|_| ())
    }

    fn run(&self, run: &RunPoint, ctx: &RunContext<'_>) -> anyhow::Result<Row> {
        let cfg = config(run, ctx.base_dir).map_err(ParamError::into_error)?;
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
        let cell = |x: f64| {
            if x.is_nan() {
                String::new()
            } else {
                format!("{x:e}")
            }
        };
        let values = [
            input.name.clone(),
            short_label(&input.name),
            report.primitives.to_string(),
            report.triangles.to_string(),
            report.closed.to_string(),
            report.sets.len().to_string(),
            t.rays.to_string(),
            t.hits().to_string(),
            t.tie_edge.to_string(),
            t.tie_coincident.to_string(),
            t.disagreements_at(Place::Edge).to_string(),
            t.disagreements_at(Place::Vertex).to_string(),
            t.disagreements_at(Place::Grazing).to_string(),
            t.disagreements_at(Place::Elsewhere).to_string(),
            t.edge_leaks.0.to_string(),
            t.edge_leaks.1.to_string(),
            t.any_hit_explained.to_string(),
            t.unexplained().to_string(),
            per_million(t.disagreements_at(Place::Edge), t.rays),
            per_million(t.disagreements_at(Place::Vertex), t.rays),
            cell(dt[0]),
            cell(dt[1]),
            cell(dt[2]),
            cell(t.max_rel_dt_above_floor as f64),
            cell(angle[0]),
            cell(angle[2]),
            seconds_cell(seconds),
        ];
        Ok(COLUMNS
            .iter()
            .zip(values)
            .map(|(c, v)| (c.to_string(), v))
            .collect())
    }
}
