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

use super::{RunContext, Study, StudySettings, Timings};
use crate::experiment::params::render::{RenderConfig, RenderParams};
use crate::experiment::params::RunParamError;
use crate::experiment::row::{CounterCells, Fixed, Secs};
use crate::experiment::sweep::RunPoint;
use crate::Error;
use raylab::integrator::{render, Whitted};
use raylab::io::scene_file::load_scene;
use raylab::stats::{Counters, NoStats};
use serde::Serialize;
use std::path::Path;
use std::time::Instant;

/// The `render_cost` study.
#[derive(Clone, Copy, Debug, Default)]
pub struct RenderCost;

/// One row: what rendering the scene cost.
#[derive(Clone, Debug, Default, Serialize)]
pub struct RenderCostRow {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Pixels of the image.
    pub pixels: u64,
    /// Samples per pixel of the sampler.
    pub spp: u32,
    /// Pixels × spp.
    pub samples: u64,
    /// Worker threads rendering.
    pub threads: usize,
    /// Loading the scene and building its accelerator.
    pub load_s: Secs,
    /// Each timed render (`render_s_1` … `render_s_N`).
    pub render_s: Vec<Secs>,
    /// Median of the timed renders.
    pub render_median_s: Secs,
    /// Shortest timed render.
    pub render_min_s: Secs,
    /// Longest timed render.
    pub render_max_s: Secs,
    /// Median process CPU time of the timed renders (all threads).
    pub render_cpu_median_s: Secs,
    /// The render with counters (not a timing to report).
    pub counted_render_s: Secs,
    /// Every counter of the counted render.
    #[serde(flatten)]
    pub counters: CounterCells,
    /// Rays of every kind.
    pub rays: u64,
    /// Rays over the median time.
    pub rays_per_s: Fixed<1>,
    /// Median time per camera sample, in nanoseconds.
    pub ns_per_sample: Fixed<3>,
}

impl Study for RenderCost {
    type Params = RenderParams;
    type Config = RenderConfig;
    type Row = RenderCostRow;

    fn configure(
        &self,
        params: RenderParams,
        base_dir: &Path,
    ) -> Result<RenderConfig, RunParamError> {
        params.config(base_dir)
    }

    fn template(&self, settings: &StudySettings) -> RenderCostRow {
        RenderCostRow {
            render_s: vec![Secs::default(); settings.repeats as usize],
            ..Default::default()
        }
    }

    fn run(
        &self,
        cfg: RenderConfig,
        _run: &RunPoint,
        ctx: &RunContext<'_>,
    ) -> Result<RenderCostRow, Error> {
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
        let rays = counters.rays();
        Ok(RenderCostRow {
            width: w,
            height: h,
            pixels,
            spp,
            samples,
            threads: rayon::current_num_threads(),
            load_s: Secs(load_s),
            render_s: timings.seconds.iter().map(|&s| Secs(s)).collect(),
            render_median_s: Secs(median),
            render_min_s: Secs(timings.min()),
            render_max_s: Secs(timings.max()),
            render_cpu_median_s: Secs(timings.cpu_median()),
            counted_render_s: Secs(counted_s),
            counters: CounterCells(counters),
            rays,
            rays_per_s: Fixed(rays as f64 / median),
            ns_per_sample: Fixed(median * 1e9 / samples.max(1) as f64),
        })
    }
}
