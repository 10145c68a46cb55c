//! `kind = "gradient"`: derivatives of images by forward-mode AD
//! ([`raylab::diff`]) — what they cost, how noisy they are, and how they
//! compare with central finite differences.
//!
//! A run either differentiates by one parameter component (`param`), and
//! then reports the image mean's derivative with its standard error and,
//! with `check`, the central difference with step `step` (default: the rule
//! of [`diff::default_step`]), the relative error between the two and the
//! per-pixel error away from edges; or (`cost_params = K`) differentiates
//! by the first K of the scene's material colours, light intensities and
//! light positions, to measure what a pass with K partials costs. Both
//! time the plain render and the gradient render (median of `repeats`,
//! after `warmup`) on the same integrator, sampler and threads, and report
//! their ratio. With `images`, a run writes its derivative map beside
//! `data.csv` (`images/<sweep>-<param>-<integrator>-<spp>spp.png`).

use super::{RunContext, Study, StudySettings, Timings};
use crate::analysis::plot::Heatmap;
use crate::experiment::params::render::scene_file;
use crate::experiment::params::{
    parsed_opt, typed_params, InRange, ParamDoc, ParamError, Resolution,
};
use crate::experiment::row::{Fixed, Sci, Secs};
use crate::experiment::sweep::RunPoint;
use raylab::accel::AccelKind;
use raylab::diff::{self, GradientRender, Renderer};
use raylab::integrator::IntegratorKind;
use raylab::io::scene_file::Overrides;
use raylab::sampler::Sampler;
use raylab::scene::description::SceneDescription;
use raylab::scene::param::ParamId;
use raylab::stats::NoStats;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The `gradient` study.
#[derive(Clone, Copy, Debug, Default)]
pub struct Gradient;

/// The parameters of a run.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GradientParams {
    /// Scene file, relative to the manifest's folder.
    pub scene: String,
    /// `whitted`, `direct` or `path:K`.
    #[serde(default, deserialize_with = "parsed_opt")]
    pub integrator: Option<IntegratorKind>,
    /// Pixel sampler.
    #[serde(default, deserialize_with = "parsed_opt")]
    pub sampler: Option<Sampler>,
    /// Image size.
    #[serde(default, deserialize_with = "parsed_opt")]
    pub resolution: Option<Resolution>,
    /// Seed.
    #[serde(default)]
    pub seed: Option<u64>,
    /// Accelerator.
    #[serde(default, deserialize_with = "parsed_opt")]
    pub accel: Option<AccelKind>,
    /// Russian roulette on (path tracer).
    #[serde(default)]
    pub roulette: Option<bool>,
    /// The parameter component differentiated by.
    #[serde(default)]
    pub param: Option<String>,
    /// Instead of `param`: how many parameters one pass carries.
    #[serde(default)]
    pub cost_params: Option<InRange<1, 64>>,
    /// Compare with central differences.
    #[serde(default)]
    pub check: Option<bool>,
    /// The central difference's step.
    #[serde(default)]
    pub step: Option<f64>,
    /// Write the derivative map.
    #[serde(default)]
    pub images: Option<bool>,
}

typed_params!(
    GradientParams,
    [
        ParamDoc {
            name: "scene",
            doc: "scene file (TOML), relative to the manifest's folder; required",
        },
        ParamDoc {
            name: "integrator",
            doc: "`whitted` (default), `direct` or `path:K`",
        },
        ParamDoc {
            name: "sampler",
            doc: "pixel sampler as `raylab render --sampler` (default: the scene's)",
        },
        ParamDoc {
            name: "resolution",
            doc: "image size as \"WxH\" (default: the scene's)",
        },
        ParamDoc {
            name: "seed",
            doc: "seed of randomised samplers and integrators (default: the scene's)",
        },
        ParamDoc {
            name: "accel",
            doc: "accelerator name (default: the scene's)",
        },
        ParamDoc {
            name: "roulette",
            doc: "Russian roulette in the path tracer (default true; false traces every \
                  path to K bounces, which makes the estimator smooth in colours)",
        },
        ParamDoc {
            name: "param",
            doc: "one parameter component, named as `raylab grad --param` \
                  (e.g. `materials.red.color[0]`); or give `cost_params`",
        },
        ParamDoc {
            name: "cost_params",
            doc: "differentiate by the first K of the scene's material colours, light \
                  intensities and light positions (1–64), to time a pass with K partials",
        },
        ParamDoc {
            name: "check",
            doc: "compare with central finite differences (default false; needs `param`)",
        },
        ParamDoc {
            name: "step",
            doc: "the central difference's step (default: ε^(1/3)·max(|p|, 1))",
        },
        ParamDoc {
            name: "images",
            doc: "write the derivative map as images/<sweep>-<param>-<integrator>-<N>spp.png \\
                  (default false)",
        },
    ]
);

/// What a run differentiates by.
#[derive(Clone, Debug)]
enum What {
    One(String),
    Count(usize),
}

/// A run's parameters, checked.
pub struct Config {
    scene: PathBuf,
    integrator: IntegratorKind,
    overrides: Overrides,
    what: What,
    check: bool,
    step: Option<f32>,
    images: bool,
}

/// One row.
#[derive(Clone, Debug, Default, Serialize)]
pub struct GradientRow {
    /// The parameter (or `K parameters`).
    pub param: String,
    /// Its value in the scene file.
    pub value: Fixed<6>,
    /// Parameters in the pass.
    pub k: usize,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Samples per pixel.
    pub spp: u32,
    /// Worker threads.
    pub threads: usize,
    /// Median time of the plain render.
    pub render_s: Secs,
    /// Median time of the gradient render.
    pub gradient_s: Secs,
    /// gradient_s / render_s.
    pub cost_ratio: Fixed<3>,
    /// ∂(image mean)/∂p by AD (first parameter).
    pub ad_mean: Sci<6>,
    /// Its standard error.
    pub std_error: Sci<4>,
    /// The central difference's step.
    pub step: Sci<4>,
    /// ∂(image mean)/∂p by the central difference.
    pub fd_mean: Sci<6>,
    /// |AD − FD| / |FD| of the image mean.
    pub rel_error: Sci<4>,
    /// Share of pixels near an edge.
    pub edge_fraction: Fixed<4>,
    /// Per-pixel |AD − FD| over the mean |FD|, away from edges: 50th,
    /// 90th and 99th percentiles.
    pub interior_p50: Sci<3>,
    pub interior_p90: Sci<3>,
    pub interior_p99: Sci<3>,
    /// The derivative map written, if any.
    pub image: String,
}

/// The integrator of a derivative study: `whitted` by default, any but
/// flood fill, without Russian roulette when `roulette` is false.
pub(super) fn differentiable_integrator(
    integrator: Option<IntegratorKind>,
    roulette: Option<bool>,
) -> Result<IntegratorKind, ParamError> {
    let integrator = integrator.unwrap_or(IntegratorKind::Whitted);
    if let IntegratorKind::FloodFill(_) = integrator {
        return Err(ParamError::new(
            "integrator",
            "derivatives are rendered for `whitted`, `direct` or `path:K`",
        ));
    }
    Ok(if roulette == Some(false) {
        integrator.with_rr_start(None)
    } else {
        integrator
    })
}

/// A finite-difference step parameter `name`: absent, or positive.
pub(super) fn positive_step(name: &'static str, v: Option<f64>) -> Result<Option<f32>, ParamError> {
    match v {
        None => Ok(None),
        Some(h) if h > 0.0 && h.is_finite() => Ok(Some(h as f32)),
        Some(h) => Err(ParamError::new(
            name,
            format!("must be a positive number, got {h}"),
        )),
    }
}

/// The scene overrides of a derivative study's run.
pub(super) fn run_overrides(
    resolution: Option<Resolution>,
    sampler: Option<Sampler>,
    accel: Option<AccelKind>,
    seed: Option<u64>,
) -> Overrides {
    Overrides {
        width: resolution.map(|r| r.width),
        height: resolution.map(|r| r.height),
        sampler,
        filter: None,
        accel,
        max_depth: None,
        seed,
    }
}

/// The first `k` components of the scene's material colours, then light
/// intensities, then light positions: a pool for cost measurements.
fn pool(desc: &SceneDescription, k: usize) -> Result<Vec<ParamId>, String> {
    let mut names: Vec<String> = desc
        .materials
        .iter()
        .map(|m| format!("materials.{}.color", m.name))
        .collect();
    names.extend((0..desc.lights.len()).map(|i| format!("light[{i}].intensity")));
    names.extend((0..desc.lights.len()).map(|i| format!("light[{i}].position")));
    let all = diff::resolve_all(&names, desc).map_err(|e| e.to_string())?;
    if all.len() < k {
        return Err(format!(
            "the scene has {} material colour, light intensity and position components, \
             fewer than cost_params = {k}",
            all.len()
        ));
    }
    Ok(all.into_iter().take(k).collect())
}

impl Study for Gradient {
    type Params = GradientParams;
    type Config = Config;
    type Row = GradientRow;

    fn configure(&self, p: GradientParams, base_dir: &Path) -> Result<Config, ParamError> {
        let scene = scene_file(base_dir, &p.scene)?;
        let integrator = differentiable_integrator(p.integrator, p.roulette)?;
        let what = match (p.param, p.cost_params) {
            (Some(name), None) => What::One(name),
            (None, Some(k)) => What::Count(k.get() as usize),
            _ => {
                return Err(ParamError::new(
                    "param",
                    "give exactly one of `param` and `cost_params`",
                ))
            }
        };
        let check = p.check.unwrap_or(false);
        if check && matches!(what, What::Count(_)) {
            return Err(ParamError::new("check", "`check` needs `param`"));
        }
        let step = positive_step("step", p.step)?;
        Ok(Config {
            scene,
            integrator,
            overrides: run_overrides(p.resolution, p.sampler, p.accel, p.seed),
            what,
            check,
            step,
            images: p.images.unwrap_or(false),
        })
    }

    fn run(
        &self,
        cfg: Config,
        run: &RunPoint,
        ctx: &RunContext<'_>,
    ) -> anyhow::Result<GradientRow> {
        let err = |e: String| anyhow::anyhow!("{}: {e}", cfg.scene.display());
        let (source, scene) = diff::load(&cfg.scene, &cfg.overrides)?;
        let desc = &source.description;
        let params = match &cfg.what {
            What::One(name) => {
                let p = diff::resolve(name, desc).map_err(|e| err(e.to_string()))?;
                anyhow::ensure!(
                    p.len() == 1,
                    "`param = \"{name}\"` names {} components: name one (e.g. `{}`)",
                    p.len(),
                    desc.param_name(p[0])
                );
                p
            }
            What::Count(k) => pool(desc, *k).map_err(err)?,
        };
        diff::check_supported(&scene, &cfg.integrator).map_err(|e| err(e.to_string()))?;
        let set: &StudySettings = &ctx.settings;
        let primal = Timings::measure(set.warmup, set.repeats, || {
            cfg.integrator.render::<NoStats>(&scene, None)
        });
        let mut grads = None;
        let timed = Timings::measure(set.warmup, set.repeats, || {
            grads = Some(diff::render_gradients(&GradientRender {
                scene: &scene,
                desc,
                params: &params,
                integrator: cfg.integrator,
                visibility: diff::Visibility::Interior,
                threads: None,
            }));
        });
        let g = grads
            .expect("at least one repeat")
            .map_err(|e| err(e.to_string()))?;
        let name = desc.param_name(params[0]);
        let (ad_mean, std_error) = g.image_mean(0);
        let mut row = GradientRow {
            param: match &cfg.what {
                What::One(_) => name.clone(),
                What::Count(k) => format!("{k} parameters"),
            },
            value: Fixed(f64::from(desc.value(params[0]))),
            k: params.len(),
            width: g.width,
            height: g.height,
            spp: g.count,
            threads: rayon::current_num_threads(),
            render_s: Secs(primal.median()),
            gradient_s: Secs(timed.median()),
            cost_ratio: Fixed(timed.median() / primal.median().max(1e-12)),
            ad_mean: Sci(ad_mean),
            std_error: Sci(std_error),
            ..GradientRow::default()
        };
        if cfg.check {
            let h = diff::step_for(&source, params[0], cfg.step);
            let renderer = Renderer {
                integrator: cfg.integrator,
                threads: None,
            };
            let c = diff::check_param(&source, &scene, &g, 0, h, renderer)
                .map_err(|e| err(e.to_string()))?;
            row.step = Sci(f64::from(c.h));
            row.fd_mean = Sci(c.fd_mean);
            row.rel_error = Sci(c.mean_rel_error);
            row.edge_fraction = Fixed(c.edge_fraction);
            row.interior_p50 = Sci(c.interior_error[0]);
            row.interior_p90 = Sci(c.interior_error[1]);
            row.interior_p99 = Sci(c.interior_error[2]);
        }
        if cfg.images {
            let dir = ctx.out_dir.join("images");
            std::fs::create_dir_all(&dir)?;
            let stem = format!(
                "{}-{}-{}-{}spp",
                run.sweep,
                name,
                cfg.integrator.name().replace(':', ""),
                g.count
            );
            let mut map = Heatmap::signed(
                format!("∂I/∂{name} ({}, {} spp)", cfg.integrator, g.count),
                &g.grey(0),
                g.width,
                g.height,
            );
            map.value_label = "∂(R+G+B)/3 / ∂p per pixel".into();
            map.save(&dir.join(&stem))?;
            row.image = format!("images/{stem}.png");
        }
        Ok(row)
    }
}
