//! S4's render mode: one sample per pixel, one bounce, and the voxel
//! flood-fill cache ([`crate::gi`]) in place of everything beyond.
//!
//! At the camera hit x₁ the path tracer adds emission and direct light
//! (next-event estimation with MIS, as in [`super::path`]); it samples one
//! bounce direction, adds the MIS-weighted emission the bounce ray finds at
//! x₂, and there — instead of light sampling and further bounces — reads
//! the cache at x₂ (S4's random voxel in the normal-oriented hemisphere, or
//! trilinear interpolation), multiplies by x₂'s albedo and ends the path.
//!
//! The cache is built once per scene ([`FloodFillIntegrator::build`]):
//! voxelisation, sources (emissive voxels, and each wall face lit directly
//! re-emitting albedo × its direct light, estimated here with the path
//! tracer's own light sampling so both see the same lights: point lights
//! always, area lights only without wall reflection — with it, their light
//! reaches the walls from the emissive voxels and is reflected there
//! already, and injecting it too would count it twice), and `warm`
//! propagation steps before the first frame (by default until the largest
//! change of a step falls below 10⁻⁴ of the largest value). Each frame then
//! runs `steps` more propagation steps (S4: one step every third frame)
//! before rendering: [`FloodFillIntegrator::frame`] is what a frame costs.
//!
//! The spec string (`--integrator floodfill:…`): comma-separated `key=value`
//! pairs after `floodfill:`, all optional —
//! `res` (voxels along the scene's longest axis, default 64), `alpha`
//! (gain per step, default 1: energy-consistent; S4 used 2.43902), `avg`
//! (`linear` or S4's `gamma`), `bounce` (`on`: walls reflect the light in
//! front of them, default; `off`: S4's scheme), `lookup` (`hemisphere`,
//! S4's, default; or `trilinear`), `warm` (steps before the first frame, or
//! `converge`, default), `steps` (per frame, default 1), `max` (saturation
//! of stored values, default none), `light` (area-light samples per wall
//! face for the direct light without wall reflection, default 16). `floodfill:s4` is S4's published
//! scheme (α = 2.43902, gamma, no wall reflection), saturated at 1 since it
//! diverges otherwise.

use super::path::{PathEnd, PathTracer};
use super::{Integrator, SampleContext};
use crate::error::ParseError;
use crate::film::Film;
use crate::gi::{
    wall_light, Averaging, FloodFill, FloodFillConfig, GiError, GridSpec, Lookup, Threads,
    VoxelGrid, DEFAULT_WALL_LIGHT_SAMPLES,
};
use crate::math::{Color, Ray, RayR};
use crate::scene::Scene;
use crate::shape::Hit;
use crate::stats::{RenderStats, Stats};
use std::time::Instant;

/// Most warm-up steps `warm=converge` runs (a 96³ grid needs about 500).
pub const MAX_WARM_STEPS: u32 = 4096;
/// `warm=converge` stops when a step changes no value by more than this
/// fraction of the largest value.
pub const CONVERGED: f64 = 1e-4;

/// When the cache starts being used.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Warm {
    /// This many steps.
    Steps(u32),
    /// Until converged (at most [`MAX_WARM_STEPS`]).
    Converge,
}

/// The settings of the flood-fill render mode (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FloodFillSettings {
    pub resolution: usize,
    pub config: FloodFillConfig,
    pub lookup: Lookup,
    pub warm: Warm,
    /// Area-light samples per lit wall face.
    pub light_samples: u32,
}

impl Default for FloodFillSettings {
    fn default() -> Self {
        Self {
            resolution: 64,
            config: FloodFillConfig::default(),
            lookup: Lookup::Hemisphere,
            warm: Warm::Converge,
            light_samples: DEFAULT_WALL_LIGHT_SAMPLES,
        }
    }
}

/// The keys of `floodfill:key=value,…`, for error messages.
const OPTION_KEYS: &str = "res, alpha, avg, bounce, lookup, warm, steps, max, light; or `s4`";

impl FloodFillSettings {
    /// Parse the part after `floodfill` (empty, or `:key=value,…`, or `:s4`).
    pub fn parse(rest: &str) -> Result<Self, ParseError> {
        let mut s = Self::default();
        let Some(list) = rest.strip_prefix(':') else {
            return if rest.is_empty() {
                Ok(s)
            } else {
                Err(ParseError::Unknown {
                    what: "integrator",
                    given: format!("floodfill{rest}"),
                    expected: "`floodfill[:key=value,…]`".into(),
                })
            };
        };
        for item in list.split(',') {
            if item == "s4" {
                s.config = FloodFillConfig {
                    max_irradiance: 1.0,
                    ..FloodFillConfig::s4()
                };
                continue;
            }
            let (key, value) = item
                .split_once('=')
                .ok_or_else(|| ParseError::NotKeyValue {
                    what: "floodfill option",
                    item: item.to_string(),
                    keys: OPTION_KEYS,
                })?;
            let bad = |expected: String| ParseError::Value {
                what: format!("floodfill `{key}`"),
                expected,
                given: value.to_string(),
            };
            let num = |lo: f64, hi: f64| -> Result<f64, ParseError> {
                match value.parse::<f64>() {
                    Ok(v) if v >= lo && v <= hi => Ok(v),
                    _ => Err(bad(format!("a number in [{lo}, {hi}]"))),
                }
            };
            let int = |lo: u32, hi: u32| -> Result<u32, ParseError> {
                match value.parse::<u32>() {
                    Ok(v) if (lo..=hi).contains(&v) => Ok(v),
                    _ => Err(bad(format!("an integer in {lo}..={hi}"))),
                }
            };
            let choice = |options: &[&str]| -> Result<usize, ParseError> {
                options
                    .iter()
                    .position(|o| *o == value)
                    .ok_or_else(|| bad(format!("one of {}", options.join(", "))))
            };
            match key {
                "res" => s.resolution = int(2, crate::gi::voxel::MAX_RESOLUTION as u32)? as usize,
                "alpha" => s.config.alpha = num(1e-6, 1e6)? as f32,
                "avg" => {
                    s.config.averaging =
                        [Averaging::Linear, Averaging::Gamma][choice(&["linear", "gamma"])?]
                }
                "bounce" => s.config.surface_bounce = choice(&["off", "on"])? == 1,
                "lookup" => {
                    s.lookup = [Lookup::Hemisphere, Lookup::Trilinear]
                        [choice(&["hemisphere", "trilinear"])?]
                }
                "warm" => {
                    s.warm = if value == "converge" {
                        Warm::Converge
                    } else {
                        Warm::Steps(int(0, 1 << 20)?)
                    }
                }
                "steps" => s.config.steps_per_frame = int(1, 1 << 16)?,
                "max" => s.config.max_irradiance = num(1e-9, f64::from(f32::MAX))? as f32,
                "light" => s.light_samples = int(1, 1 << 16)?,
                _ => {
                    return Err(ParseError::UnknownKey {
                        what: "floodfill option",
                        key: key.to_string(),
                        keys: OPTION_KEYS,
                    })
                }
            }
        }
        s.config.validate().map_err(|error| ParseError::Settings {
            what: "floodfill",
            error,
        })?;
        Ok(s)
    }

    /// The canonical spec string (what `parse` reads back).
    pub fn name(&self) -> String {
        let c = &self.config;
        let warm = match self.warm {
            Warm::Converge => "converge".to_string(),
            Warm::Steps(n) => n.to_string(),
        };
        let mut s = format!(
            "floodfill:res={},alpha={},avg={},bounce={},lookup={},warm={warm},steps={},light={}",
            self.resolution,
            c.alpha,
            match c.averaging {
                Averaging::Linear => "linear",
                Averaging::Gamma => "gamma",
            },
            if c.surface_bounce { "on" } else { "off" },
            match self.lookup {
                Lookup::Hemisphere => "hemisphere",
                Lookup::Trilinear => "trilinear",
            },
            c.steps_per_frame,
            self.light_samples
        );
        if c.max_irradiance.is_finite() {
            s.push_str(&format!(",max={}", c.max_irradiance));
        }
        s
    }
}

/// The flood-fill render mode with its cache built for one scene.
pub struct FloodFillIntegrator {
    pub settings: FloodFillSettings,
    pub cache: FloodFill,
    path: PathTracer,
    /// Seconds spent building the cache (voxelisation and sources) and
    /// warming it up.
    pub build_s: f64,
    pub warm_s: f64,
}

/// The cache as a path's end: its light at the hit, for the path tracer.
struct CacheEnd<'a> {
    cache: &'a FloodFill,
    lookup: Lookup,
}

impl PathEnd for CacheEnd<'_> {
    fn light_at(&self, hit: &Hit, u: [f32; 3]) -> Color {
        self.cache
            .lookup(hit.point, hit.shading_normal, self.lookup, u)
    }
}

impl FloodFillIntegrator {
    /// Voxelise `scene`, set up the cache's sources and warm it up.
    pub fn build(scene: &Scene, settings: FloodFillSettings) -> Result<Self, GiError> {
        let start = Instant::now();
        let grid = VoxelGrid::from_scene(scene, &GridSpec::new(settings.resolution))?;
        let direct = wall_light(scene, &settings.config, settings.light_samples);
        let mut cache = FloodFill::new(&grid, settings.config, direct)?;
        let build_s = start.elapsed().as_secs_f64();
        let start = Instant::now();
        // Each propagation step counts as one unit of the progress a
        // watcher shows (`super::progress`): a warm-up of 2²⁰ steps on a
        // fine grid takes hours, and shows how far it is.
        match settings.warm {
            Warm::Steps(n) => {
                super::progress::announce(u64::from(n));
                for _ in 0..n {
                    cache.step(Threads::Pool);
                    super::progress::row_done();
                }
            }
            Warm::Converge => {
                super::progress::announce(u64::from(MAX_WARM_STEPS));
                for _ in 0..MAX_WARM_STEPS {
                    let r = cache.step_with_residual(Threads::Pool);
                    super::progress::row_done();
                    if r.max <= CONVERGED * f64::from(cache.max_value()) {
                        break;
                    }
                }
            }
        }
        Ok(Self {
            settings,
            cache,
            path: PathTracer::new(1),
            build_s,
            warm_s: start.elapsed().as_secs_f64(),
        })
    }

    /// One frame as S4 runs it: the frame's propagation steps, then the
    /// render.
    pub fn frame<S: RenderStats>(&mut self, scene: &Scene, threads: Option<usize>) -> (Film, S) {
        super::progress::announce(u64::from(self.settings.config.steps_per_frame));
        self.cache.frame(Threads::Pool, super::progress::row_done);
        super::render(scene, &*self, threads)
    }
}

impl Integrator for FloodFillIntegrator {
    fn radiance<S: Stats>(
        &self,
        scene: &Scene,
        ray: &Ray,
        ctx: &SampleContext,
        stats: &mut S,
    ) -> Color {
        let end = CacheEnd {
            cache: &self.cache,
            lookup: self.settings.lookup,
        };
        self.path
            .trace(scene, &RayR::from(*ray), ctx, stats, Some(&end))
            .into()
    }
}
