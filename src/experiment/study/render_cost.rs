//! `kind = "render_cost"`: what rendering a scene costs, in time and in
//! counted work (S1's timing tables and anything like them).
//!
//! One run loads a scene (timed as `load_s`: parsing, mesh reading and the
//! accelerator build), renders it `warmup` times untimed and `repeats`
//! times timed with the [`NoStats`] sink, so the timed renders pay nothing
//! for instrumentation, and then once more with [`Counters`] for the counts
//! of rays and tests (its time is recorded as `counted_render_s`, which
//! shows what counting costs, but is not a timing to report). Each timed
//! render also records the process CPU time (all threads), whose median is
//! `render_cpu_median_s`: a cross-check that other programs on the machine
//! disturb far less than the wall clock. A timed
//! render is [`render`] alone: film allocation and every ray, not the
//! scene load, not thread start-up (the experiment's thread pool is built
//! once) and not image encoding.

use super::{
    int_param, seconds_cell, str_param, ParamDoc, ParamError, Row, RunContext, Study,
    StudySettings, Timings,
};
use crate::accel::AccelKind;
use crate::experiment::sweep::RunPoint;
use crate::film::Filter;
use crate::integrator::{render, Whitted};
use crate::io::scene_file::{load_scene, Overrides};
use crate::sampler::Sampler;
use crate::stats::{Counters, NoStats};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The `render_cost` study.
#[derive(Clone, Copy, Debug, Default)]
pub struct RenderCost;

pub(super) const PARAMETERS: &[ParamDoc] = &[
    ParamDoc {
        name: "scene",
        doc: "scene file (TOML), relative to the manifest's folder; required",
    },
    ParamDoc {
        name: "sampler",
        doc: "`centre` or `ogss:K` (default: the scene's)",
    },
    ParamDoc {
        name: "accel",
        doc: "accelerator name, as `raylab render --accel` (default: the scene's)",
    },
    ParamDoc {
        name: "resolution",
        doc: "image size as \"WxH\", e.g. \"800x600\" (default: the scene's)",
    },
    ParamDoc {
        name: "width",
        doc: "image width in pixels (instead of `resolution`)",
    },
    ParamDoc {
        name: "height",
        doc: "image height in pixels (instead of `resolution`)",
    },
    ParamDoc {
        name: "max_depth",
        doc: "maximum recursion depth (default: the scene's)",
    },
    ParamDoc {
        name: "seed",
        doc: "seed for randomised samplers and integrators (default: the scene's)",
    },
    ParamDoc {
        name: "filter",
        doc: "reconstruction filter: box, tent or mitchell (default: the scene's)",
    },
];

/// The largest image side accepted (a typo guard, not a renderer limit).
const MAX_SIDE: i64 = 65_536;

/// A run's parameters, parsed.
pub(super) struct Config {
    pub scene: PathBuf,
    pub overrides: Overrides,
}

/// Parse "WxH" (or "W×H").
pub(super) fn parse_resolution(s: &str) -> Option<(u32, u32)> {
    let (w, h) = s.split_once('x').or_else(|| s.split_once('×'))?;
    let (w, h) = (w.trim().parse::<u32>().ok()?, h.trim().parse::<u32>().ok()?);
    (w > 0 && h > 0 && i64::from(w) <= MAX_SIDE && i64::from(h) <= MAX_SIDE).then_some((w, h))
}

/// The required `scene` parameter, resolved against the manifest's folder
/// and checked to be a file.
pub(super) fn scene_param(run: &RunPoint, base_dir: &Path) -> Result<PathBuf, ParamError> {
    let scene = str_param(run, "scene")?
        .ok_or_else(|| ParamError {
            param: None,
            message: "`scene` is required (in [fixed] or in the sweep)".into(),
        })
        .map(|s| base_dir.join(s))?;
    if !scene.is_file() {
        return Err(ParamError::new(
            "scene",
            format!("{}: no such scene file", scene.display()),
        ));
    }
    Ok(scene)
}

/// The parameters every rendering study shares: scene, sampler, filter,
/// accel, resolution (or width/height), max_depth, seed.
pub(super) fn config(run: &RunPoint, base_dir: &Path) -> Result<Config, ParamError> {
    let scene = scene_param(run, base_dir)?;
    let sampler = str_param(run, "sampler")?
        .map(Sampler::parse)
        .transpose()
        .map_err(|e| ParamError::new("sampler", e))?;
    let filter = str_param(run, "filter")?
        .map(Filter::parse)
        .transpose()
        .map_err(|e| ParamError::new("filter", e))?;
    let accel = str_param(run, "accel")?
        .map(str::parse::<AccelKind>)
        .transpose()
        .map_err(|e| ParamError::new("accel", e))?;
    let mut width = int_param(run, "width", 1, MAX_SIDE)?.map(|w| w as u32);
    let mut height = int_param(run, "height", 1, MAX_SIDE)?.map(|h| h as u32);
    if let Some(res) = str_param(run, "resolution")? {
        if width.is_some() || height.is_some() {
            return Err(ParamError::new(
                "resolution",
                "give `resolution` or `width`/`height`, not both",
            ));
        }
        let (w, h) = parse_resolution(res).ok_or_else(|| {
            ParamError::new(
                "resolution",
                format!("`{res}` is not \"WxH\" with sides in 1..={MAX_SIDE}"),
            )
        })?;
        (width, height) = (Some(w), Some(h));
    }
    let max_depth = int_param(run, "max_depth", 0, 1_000)?.map(|d| d as u32);
    let seed = int_param(run, "seed", 0, i64::MAX)?.map(|s| s as u64);
    Ok(Config {
        scene,
        overrides: Overrides {
            width,
            height,
            sampler,
            filter,
            accel,
            max_depth,
            seed,
        },
    })
}

impl Study for RenderCost {
    fn kind(&self) -> &'static str {
        "render_cost"
    }

    fn parameters(&self) -> &'static [ParamDoc] {
        PARAMETERS
    }

    fn columns(&self, settings: &StudySettings) -> Vec<String> {
        let mut cols: Vec<String> = [
            "width", "height", "pixels", "spp", "samples", "threads", "load_s",
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
                "counted_render_s",
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
        cols.extend(
            ["rays", "rays_per_s", "ns_per_sample"]
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
        let scene = load_scene(&cfg.scene, &cfg.overrides)?;
        let load_s = start.elapsed().as_secs_f64();

        let timings = Timings::measure(ctx.settings.warmup, ctx.settings.repeats, || {
            render::<_, NoStats>(&scene, &Whitted, None)
        });
        let start = Instant::now();
        let (film, counters) = render::<_, Counters>(&scene, &Whitted, None);
        let counted_s = start.elapsed().as_secs_f64();
        drop(film);

        let (w, h) = (scene.camera.width, scene.camera.height);
        let pixels = u64::from(w) * u64::from(h);
        let spp = scene.settings.sampler.spp();
        let samples = pixels * u64::from(spp);
        let median = timings.median();
        let mut row: Row = vec![
            ("width".into(), w.to_string()),
            ("height".into(), h.to_string()),
            ("pixels".into(), pixels.to_string()),
            ("spp".into(), spp.to_string()),
            ("samples".into(), samples.to_string()),
            ("threads".into(), rayon::current_num_threads().to_string()),
            ("load_s".into(), seconds_cell(load_s)),
        ];
        for (i, s) in timings.seconds.iter().enumerate() {
            row.push((format!("render_s_{}", i + 1), seconds_cell(*s)));
        }
        row.extend([
            ("render_median_s".into(), seconds_cell(median)),
            ("render_min_s".into(), seconds_cell(timings.min())),
            ("render_max_s".into(), seconds_cell(timings.max())),
            (
                "render_cpu_median_s".into(),
                seconds_cell(timings.cpu_median()),
            ),
            ("counted_render_s".into(), seconds_cell(counted_s)),
        ]);
        row.extend(
            counters
                .named()
                .iter()
                .map(|(name, v)| (name.to_string(), v.to_string())),
        );
        let rays = counters.rays();
        row.extend([
            ("rays".into(), rays.to_string()),
            ("rays_per_s".into(), format!("{:.1}", rays as f64 / median)),
            (
                "ns_per_sample".into(),
                format!("{:.3}", median * 1e9 / samples.max(1) as f64),
            ),
        ]);
        Ok(row)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resolutions_parse_with_x_or_times() {
        assert_eq!(parse_resolution("800x600"), Some((800, 600)));
        assert_eq!(parse_resolution("325×243"), Some((325, 243)));
        assert_eq!(parse_resolution("0x5"), None);
        assert_eq!(parse_resolution("800"), None);
        assert_eq!(parse_resolution("99999x1"), None);
    }
}
