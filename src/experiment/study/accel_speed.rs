//! `kind = "accel_speed"`: traversal throughput of one of raylab's
//! accelerators against a reference accelerator (Embree 4 by default) on
//! identical rays, measured in the same run (`analysis/embree-speed.toml`).
//!
//! One run loads a scene, builds both accelerators (each build timed:
//! `warmup` untimed builds, then `repeats` timed ones, medians reported),
//! makes the four ray sets of [`crate::workload`] (primary, shadow,
//! diffuse, random) once, and then, for each set, times the two
//! accelerators alternately (`warmup` untimed passes each, then `repeats`
//! timed passes of A, B, A, B, …) so that a disturbance of the machine
//! falls on both sides rather than one. The timed loop is
//! [`trace`]: `intersect` (closest hit) or `occluded` (shadow rays: any
//! hit) on each ray, through the accelerators' public interface — Embree's
//! through `rtcIntersect1`/`rtcOccluded1`, one ray at a time — on a rayon
//! pool of `threads` workers built before any clock starts.
//!
//! Columns `{kind}_nodes_per_ray`, `…_volume_tests_per_ray` and
//! `…_prim_tests_per_ray` count the work behind our side's time (one extra
//! pass with [`Counters`]; Embree does not count).
//!
//! The two sides must agree on which rays hit (`{kind}_hit_disagree`: the
//! number of rays where only one of them found a hit; rounding at edges
//! allows a handful in a million, see `raylab validate`): a throughput
//! figure for a different answer would compare nothing.

use super::{
    int_param, seconds_cell, str_param, ParamDoc, ParamError, Row, RunContext, Study,
    StudySettings, Timings,
};
use crate::accel::{Accel, AccelKind, Accelerator};
use crate::experiment::sweep::RunPoint;
use crate::io::scene_file::{load_scene, Overrides};
use crate::scene::Scene;
use crate::shape::PreparedRay;
use crate::stats::{Counters, NoStats};
use crate::workload::{trace, trace_serial, Segment, Workload};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// The `accel_speed` study.
#[derive(Clone, Copy, Debug, Default)]
pub struct AccelSpeed;

const PARAMETERS: &[ParamDoc] = &[
    ParamDoc {
        name: "scene",
        doc: "scene file (TOML), relative to the manifest's folder; required",
    },
    ParamDoc {
        name: "accel",
        doc: "raylab's accelerator to measure (default `bvh4`, the 4-wide SAH box BVH)",
    },
    ParamDoc {
        name: "reference",
        doc: "the accelerator it is measured against (default `embree:high+robust`)",
    },
    ParamDoc {
        name: "resolution",
        doc:
            "camera rays \"WxH\" (default \"800x600\"); shadow and diffuse rays start at their hits",
    },
    ParamDoc {
        name: "random_rays",
        doc: "rays through the bounds (default: as many as pixels)",
    },
    ParamDoc {
        name: "threads",
        doc: "worker threads tracing (default 1)",
    },
    ParamDoc {
        name: "seed",
        doc: "seed of the diffuse and random rays (default 1)",
    },
];

struct Config {
    scene: PathBuf,
    accel: AccelKind,
    reference: AccelKind,
    width: u32,
    height: u32,
    random: Option<usize>,
    threads: usize,
    seed: u64,
}

fn accel_param(run: &RunPoint, name: &str, default: &str) -> Result<AccelKind, ParamError> {
    str_param(run, name)?
        .unwrap_or(default)
        .parse()
        .map_err(|e| ParamError::new(name, e))
}

fn config(run: &RunPoint, base_dir: &Path) -> Result<Config, ParamError> {
    let scene = super::render_cost::scene_param(run, base_dir)?;
    let accel = accel_param(run, "accel", "bvh4")?;
    let reference = accel_param(run, "reference", "embree:high+robust")?;
    let (width, height) = match str_param(run, "resolution")? {
        None => (800, 600),
        Some(r) => super::render_cost::parse_resolution(r).ok_or_else(|| {
            ParamError::new(
                "resolution",
                format!("`{r}` is not \"WxH\" with positive sides"),
            )
        })?,
    };
    let random = int_param(run, "random_rays", 0, 1 << 30)?.map(|n| n as usize);
    let threads = int_param(run, "threads", 1, 1024)?.unwrap_or(1) as usize;
    let seed = int_param(run, "seed", 0, i64::MAX)?.unwrap_or(1) as u64;
    Ok(Config {
        scene,
        accel,
        reference,
        width,
        height,
        random,
        threads,
        seed,
    })
}

/// Whether each ray of `rays` hits, through `accel` (any-hit or closest).
fn hit_flags(accel: &Accelerator, scene: &Scene, rays: &[Segment], any_hit: bool) -> Vec<bool> {
    let prims = &scene.prims[..];
    rays.par_iter()
        .map(|r: &Segment| {
            let ray: &PreparedRay = &r.ray;
            if any_hit {
                accel.occluded(prims, ray, r.t_max, &mut NoStats)
            } else {
                accel.intersect(prims, ray, r.t_max, &mut NoStats).is_some()
            }
        })
        .collect()
}

const SIDES: [&str; 2] = ["ours", "ref"];

impl Study for AccelSpeed {
    fn kind(&self) -> &'static str {
        "accel_speed"
    }

    fn parameters(&self) -> &'static [ParamDoc] {
        PARAMETERS
    }

    fn columns(&self, _settings: &StudySettings) -> Vec<String> {
        let mut cols: Vec<String> = ["triangles", "primitives", "threads"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        for side in SIDES {
            cols.push(format!("{side}_build_median_s"));
        }
        for k in Workload::KINDS {
            cols.push(format!("{k}_rays"));
            cols.push(format!("{k}_hits"));
            cols.push(format!("{k}_hit_disagree"));
            for side in SIDES {
                cols.push(format!("{side}_{k}_median_s"));
                cols.push(format!("{side}_{k}_mrays_s"));
            }
            cols.push(format!("{k}_ratio"));
            cols.push(format!("{k}_nodes_per_ray"));
            cols.push(format!("{k}_volume_tests_per_ray"));
            cols.push(format!("{k}_prim_tests_per_ray"));
        }
        cols
    }

    fn check(&self, run: &RunPoint, base_dir: &Path) -> Result<(), ParamError> {
        config(run, base_dir).map(|_| ())
    }

    fn run(&self, run: &RunPoint, ctx: &RunContext<'_>) -> anyhow::Result<Row> {
        let cfg = config(run, ctx.base_dir).map_err(ParamError::into_error)?;
        let overrides = Overrides {
            width: Some(cfg.width),
            height: Some(cfg.height),
            accel: Some(cfg.accel),
            ..Default::default()
        };
        let scene = load_scene(&cfg.scene, &overrides)?;
        let bounded: Vec<u32> = (0..scene.prims.len() as u32)
            .filter(|&i| scene.prims[i as usize].bounds().is_some())
            .collect();
        let (warmup, repeats) = (ctx.settings.warmup, ctx.settings.repeats);
        let mut sides = Vec::new();
        let mut row: Row = vec![
            ("triangles".into(), scene.triangle_count().to_string()),
            ("primitives".into(), bounded.len().to_string()),
            ("threads".into(), cfg.threads.to_string()),
        ];
        for (side, kind) in SIDES.iter().zip([cfg.accel, cfg.reference]) {
            let build = Timings::measure(warmup, repeats, || {
                Accelerator::build(kind, &scene.prims, bounded.clone())
            });
            let accel = Accelerator::build(kind, &scene.prims, bounded.clone())
                .map_err(|e| anyhow::anyhow!("building `{kind}`: {e}"))?;
            row.push((
                format!("{side}_build_median_s"),
                seconds_cell(build.median()),
            ));
            sides.push(accel);
        }
        let random = cfg.random.unwrap_or((cfg.width * cfg.height) as usize);
        let work = Workload::from_scene(&scene, random, cfg.seed);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(cfg.threads)
            .build()?;
        for k in Workload::KINDS {
            let rays = work.get(k);
            let flags: Vec<Vec<bool>> = sides
                .iter()
                .map(|a| hit_flags(a, &scene, rays, k.any_hit()))
                .collect();
            let hits = flags[0].iter().filter(|&&h| h).count();
            let disagree = flags[0]
                .iter()
                .zip(&flags[1])
                .filter(|(a, b)| a != b)
                .count();
            let mut times: [Vec<f64>; 2] = [Vec::new(), Vec::new()];
            pool.install(|| {
                for a in &sides {
                    for _ in 0..warmup {
                        std::hint::black_box(trace(a, &scene, rays, k.any_hit()));
                    }
                }
                for _ in 0..repeats {
                    for (i, a) in sides.iter().enumerate() {
                        let t = Timings::measure(0, 1, || trace(a, &scene, rays, k.any_hit()));
                        times[i].push(t.seconds[0]);
                    }
                }
            });
            row.push((format!("{k}_rays"), rays.len().to_string()));
            row.push((format!("{k}_hits"), hits.to_string()));
            row.push((format!("{k}_hit_disagree"), disagree.to_string()));
            let mut mrays = [0.0; 2];
            for (i, side) in SIDES.iter().enumerate() {
                let median = super::median(&times[i]);
                mrays[i] = rays.len() as f64 / median / 1e6;
                row.push((format!("{side}_{k}_median_s"), seconds_cell(median)));
                row.push((format!("{side}_{k}_mrays_s"), format!("{:.4}", mrays[i])));
            }
            row.push((format!("{k}_ratio"), format!("{:.4}", mrays[0] / mrays[1])));
            // The work behind our side's time, counted in one more pass.
            let mut c = Counters::default();
            trace_serial(&sides[0], &scene, rays, k.any_hit(), &mut c);
            let per_ray = |n: u64| format!("{:.3}", n as f64 / rays.len().max(1) as f64);
            let volume_tests = c.box_tests + c.bounding_sphere_tests + c.bounding_ellipsoid_tests;
            let prim_tests = c.triangle_tests + c.sphere_tests + c.ellipsoid_tests;
            row.push((format!("{k}_nodes_per_ray"), per_ray(c.nodes_visited)));
            row.push((format!("{k}_volume_tests_per_ray"), per_ray(volume_tests)));
            row.push((format!("{k}_prim_tests_per_ray"), per_ray(prim_tests)));
        }
        Ok(row)
    }
}
