//! `kind = "gradient_estimators"`: estimators of an image's derivative
//! side by side — forward mode alone (`interior`), forward mode plus the
//! boundary term (`full`, [`raylab::diff::boundary`]) and central finite
//! differences (`fd`) — by their bias, their standard error against
//! samples per pixel, their cost per sample, and where in the image their
//! variance sits.
//!
//! A run takes one estimator, one parameter component and one sampler,
//! and computes the image mean's derivative `seeds` times with independent
//! seeds (for `fd`: the two renders at p ± h share each seed). Its row
//! holds the mean over the seeds, the standard deviation of one estimate,
//! and the bias against a reference: the mean of `reference_seeds`
//! central differences of renders with `reference_sampler` (many samples)
//! and step `reference_step`, with its own standard error, computed once
//! per scene, parameter and size and shared by the runs. The bias is also
//! given in standard errors (`bias_z`, the run's and the reference's
//! combined): |bias_z| < 3 is what an unbiased estimator shows. Cost is
//! the median wall time of one estimate and its time per camera sample;
//! `efficiency` = 1 / (variance × time) compares estimators at equal time
//! (its ratio is how many times longer the worse one must run to reach the
//! better one's error). With `images`, a run writes the per-pixel standard
//! deviation of its derivative over the seeds.

use super::gradient::{differentiable_integrator, positive_step, run_overrides};
use super::{RunContext, Study};
use crate::analysis::plot::{Heatmap, Palette};
use crate::experiment::params::render::scene_file;
use crate::experiment::params::{
    parsed_opt, typed_params, InRange, ParamDoc, ParamError, Resolution,
};
use crate::experiment::row::{Fixed, Sci, Secs};
use crate::experiment::sweep::RunPoint;
use ndarray::Array2;
use raylab::accel::AccelKind;
use raylab::diff::{self, GradientRender, Renderer, Visibility};
use raylab::integrator::IntegratorKind;
use raylab::io::scene_file::Overrides;
use raylab::math::Moments;
use raylab::sampler::Sampler;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};
use std::time::Instant;

/// The `gradient_estimators` study.
#[derive(Clone, Copy, Debug, Default)]
pub struct GradientEstimators;

/// The parameters of a run.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EstimatorParams {
    pub scene: String,
    #[serde(default, deserialize_with = "parsed_opt")]
    pub integrator: Option<IntegratorKind>,
    #[serde(default, deserialize_with = "parsed_opt")]
    pub sampler: Option<Sampler>,
    #[serde(default, deserialize_with = "parsed_opt")]
    pub resolution: Option<Resolution>,
    #[serde(default, deserialize_with = "parsed_opt")]
    pub accel: Option<AccelKind>,
    #[serde(default)]
    pub roulette: Option<bool>,
    pub param: String,
    pub estimator: String,
    #[serde(default)]
    pub seeds: Option<InRange<2, 10000>>,
    #[serde(default)]
    pub step: Option<f64>,
    #[serde(default, deserialize_with = "parsed_opt")]
    pub reference_sampler: Option<Sampler>,
    #[serde(default)]
    pub reference_step: Option<f64>,
    #[serde(default)]
    pub reference_seeds: Option<InRange<2, 1000>>,
    #[serde(default)]
    pub images: Option<bool>,
}

typed_params!(
    EstimatorParams,
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
            doc: "pixel sampler of each estimate (default: the scene's)",
        },
        ParamDoc {
            name: "resolution",
            doc: "image size as \"WxH\" (default: the scene's)",
        },
        ParamDoc {
            name: "accel",
            doc: "accelerator name (default: the scene's)",
        },
        ParamDoc {
            name: "roulette",
            doc: "Russian roulette in the path tracer (default true)",
        },
        ParamDoc {
            name: "param",
            doc: "one parameter component, named as `raylab grad --param`; required",
        },
        ParamDoc {
            name: "estimator",
            doc: "`interior` (forward mode alone), `full` (plus the boundary term) or `fd` \
                  (central difference of two renders with a shared seed); required",
        },
        ParamDoc {
            name: "seeds",
            doc: "independent estimates per run (2–10000, default 8)",
        },
        ParamDoc {
            name: "step",
            doc: "the `fd` estimator's step (default: ε^(1/3)·max(|p|, 1))",
        },
        ParamDoc {
            name: "reference_sampler",
            doc: "sampler of the reference central difference (default jitter:32)",
        },
        ParamDoc {
            name: "reference_step",
            doc: "the reference's step (default: `step`, else the rule)",
        },
        ParamDoc {
            name: "reference_seeds",
            doc: "independent central differences averaged for the reference (2–1000, \
                  default 4)",
        },
        ParamDoc {
            name: "images",
            doc: "write the per-pixel standard deviation over the seeds as \
                  images/<sweep>-<param>-<estimator>-<N>spp-sd.png (default false)",
        },
    ]
);

/// Which estimator a run measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Estimator {
    Ad(Visibility),
    Fd,
}

/// A run's parameters, checked.
pub struct Config {
    scene: PathBuf,
    integrator: IntegratorKind,
    overrides: Overrides,
    param: String,
    estimator: Estimator,
    seeds: u32,
    step: Option<f32>,
    reference_sampler: Sampler,
    reference_step: Option<f32>,
    reference_seeds: u32,
    images: bool,
}

/// One row.
#[derive(Clone, Debug, Default, Serialize)]
pub struct EstimatorRow {
    /// The parameter component.
    pub param: String,
    /// `interior`, `full` or `fd`.
    pub estimator: String,
    pub integrator: String,
    pub width: u32,
    pub height: u32,
    /// Samples per pixel of one estimate.
    pub spp: u32,
    /// Independent estimates.
    pub seeds: u32,
    /// Their mean.
    pub mean: Sci<6>,
    /// The standard deviation of one estimate.
    pub sd: Sci<4>,
    /// The standard error of `mean` (sd / √seeds).
    pub std_error: Sci<4>,
    /// The reference: a converged central difference, and its standard
    /// error.
    pub reference: Sci<6>,
    pub reference_se: Sci<3>,
    /// mean − reference, and in standard errors (of the mean and the
    /// reference combined).
    pub bias: Sci<4>,
    pub bias_z: Fixed<2>,
    /// |bias| / |reference|.
    pub rel_bias: Sci<3>,
    /// Median wall time of one estimate.
    pub seconds: Secs,
    /// That time per camera sample (pixels × spp; for `fd` both renders'
    /// samples), nanoseconds.
    pub ns_per_sample: Fixed<1>,
    /// 1 / (sd² × seconds): error at equal time (∞ for an estimator
    /// without variance).
    pub efficiency: Sci<3>,
    /// `full`: mean time of the boundary term per estimate, and its curve
    /// samples.
    pub boundary_s: Secs,
    pub boundary_samples: u64,
    /// The standard-deviation map written, if any.
    pub image: String,
}

/// The mean of `values` and its standard error.
fn mean_and_se(values: &[f64]) -> (f64, f64) {
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    (mean, (var / n).sqrt())
}

/// References computed in this process, by scene, size, integrator,
/// parameter, sampler and step.
fn references() -> &'static Mutex<HashMap<String, (f64, f64)>> {
    static CACHE: OnceLock<Mutex<HashMap<String, (f64, f64)>>> = OnceLock::new();
    CACHE.get_or_init(|| Mutex::new(HashMap::new()))
}

impl Study for GradientEstimators {
    type Params = EstimatorParams;
    type Config = Config;
    type Row = EstimatorRow;

    fn configure(&self, p: EstimatorParams, base_dir: &Path) -> Result<Config, ParamError> {
        let scene = scene_file(base_dir, &p.scene)?;
        let integrator = differentiable_integrator(p.integrator, p.roulette)?;
        let estimator = match p.estimator.as_str() {
            "interior" => Estimator::Ad(Visibility::Interior),
            "full" => Estimator::Ad(Visibility::Full),
            "fd" => Estimator::Fd,
            other => {
                return Err(ParamError::new(
                    "estimator",
                    format!("unknown estimator `{other}` (expected interior, full or fd)"),
                ))
            }
        };
        if let Some(Sampler::Adaptive { .. }) = p.sampler {
            return Err(ParamError::new(
                "sampler",
                "the estimators need a fixed sampler",
            ));
        }
        let step = positive_step("step", p.step)?;
        Ok(Config {
            scene,
            integrator,
            overrides: run_overrides(p.resolution, p.sampler, p.accel, None),
            param: p.param,
            estimator,
            seeds: p.seeds.map_or(8, |s| s.get() as u32),
            step,
            reference_sampler: p.reference_sampler.unwrap_or(Sampler::Jittered { k: 32 }),
            reference_step: positive_step("reference_step", p.reference_step)?.or(step),
            reference_seeds: p.reference_seeds.map_or(4, |s| s.get() as u32),
            images: p.images.unwrap_or(false),
        })
    }

    fn run(
        &self,
        cfg: Config,
        run: &RunPoint,
        ctx: &RunContext<'_>,
    ) -> anyhow::Result<EstimatorRow> {
        let err = |e: String| anyhow::anyhow!("{}: {e}", cfg.scene.display());
        let (source, scene) = diff::load(&cfg.scene, &cfg.overrides)?;
        let desc = &source.description;
        let params = diff::resolve(&cfg.param, desc).map_err(|e| err(e.to_string()))?;
        anyhow::ensure!(
            params.len() == 1,
            "`param = \"{}\"` names {} components: name one (e.g. `{}`)",
            cfg.param,
            params.len(),
            desc.param_name(params[0])
        );
        let p = params[0];
        let param_name = desc.param_name(p);
        diff::check_supported(&scene, &cfg.integrator).map_err(|e| err(e.to_string()))?;
        let (w, h) = (scene.camera.width, scene.camera.height);
        let spp = scene.settings.sampler.spp();
        let fd_step = |s: Option<f32>| diff::step_for(&source, p, s);
        let renderer = Renderer {
            integrator: cfg.integrator,
            threads: None,
        };

        // One central difference: two renders sharing `seed`, with
        // `sampler` (None: the run's).
        let difference = |sampler: Option<Sampler>, seed: u64, step: f32| {
            let mut moved = source.clone();
            let settings = &mut moved.description.settings;
            settings.sampler = sampler.unwrap_or(settings.sampler);
            settings.seed = seed;
            diff::difference_step(&moved, p, step, renderer).map_err(|e| err(e.to_string()))
        };

        // The reference, once per scene, size, parameter and step.
        let ref_step = fd_step(cfg.reference_step);
        let key = format!(
            "{}|{w}x{h}|{}|{}|{}|{ref_step}|{}",
            cfg.scene.display(),
            cfg.integrator,
            param_name,
            cfg.reference_sampler.name(),
            cfg.reference_seeds
        );
        let cached = references()
            .lock()
            .expect("not poisoned")
            .get(&key)
            .copied();
        let (reference, reference_se) = match cached {
            Some(r) => r,
            None => {
                let mut values = Vec::new();
                for k in 0..u64::from(cfg.reference_seeds) {
                    let seed = scene.settings.seed.wrapping_add(0x5EED_0000 + k);
                    let d = difference(Some(cfg.reference_sampler), seed, ref_step)?;
                    values.push(d.image_mean);
                }
                let r = mean_and_se(&values);
                references().lock().expect("not poisoned").insert(key, r);
                r
            }
        };

        // The estimates, one per seed, with per-pixel sums for the map.
        let n = (w * h) as usize;
        let mut per_pixel = vec![Moments::default(); n];
        let mut estimates = Vec::new();
        let mut seconds = Vec::new();
        let (mut boundary_s, mut boundary_samples) = (0.0, 0u64);
        let base_seed = scene.settings.seed;
        for k in 0..u64::from(cfg.seeds) {
            let seed = base_seed.wrapping_add(1 + k);
            let start = Instant::now();
            let (mean, grey) = match cfg.estimator {
                Estimator::Ad(visibility) => {
                    let mut s = scene.clone();
                    s.settings.seed = seed;
                    let g = diff::render_gradients(&GradientRender {
                        scene: &s,
                        desc,
                        params: &params,
                        integrator: cfg.integrator,
                        visibility,
                        threads: None,
                    })
                    .map_err(|e| err(e.to_string()))?;
                    boundary_s += g.boundary.stats.seconds;
                    boundary_samples += g.boundary.stats.samples;
                    (g.image_mean(0).0, g.grey(0))
                }
                Estimator::Fd => {
                    let d = difference(None, seed, fd_step(cfg.step))?;
                    let grey = d
                        .per_pixel
                        .chunks_exact(3)
                        .map(|c| (c[0] + c[1] + c[2]) / 3.0)
                        .collect();
                    (d.image_mean, grey)
                }
            };
            seconds.push(start.elapsed().as_secs_f64());
            estimates.push(mean);
            for (i, &v) in grey.iter().enumerate() {
                let v = f64::from(v);
                per_pixel[i].add(v);
            }
        }
        let m = f64::from(cfg.seeds);
        let (mean, se) = mean_and_se(&estimates);
        let sd = se * m.sqrt();
        let bias_se = (se * se + reference_se * reference_se).sqrt();
        seconds.sort_by(f64::total_cmp);
        let median = seconds[seconds.len() / 2];
        let samples =
            u64::from(w * h) * u64::from(spp) * if cfg.estimator == Estimator::Fd { 2 } else { 1 };
        let name = match cfg.estimator {
            Estimator::Ad(v) => v.name(),
            Estimator::Fd => "fd",
        };
        let mut row = EstimatorRow {
            param: param_name.clone(),
            estimator: name.into(),
            integrator: cfg.integrator.name(),
            width: w,
            height: h,
            spp,
            seeds: cfg.seeds,
            mean: Sci(mean),
            sd: Sci(sd),
            std_error: Sci(se),
            reference: Sci(reference),
            reference_se: Sci(reference_se),
            bias: Sci(mean - reference),
            bias_z: Fixed(if bias_se > 0.0 {
                (mean - reference) / bias_se
            } else {
                0.0
            }),
            rel_bias: Sci((mean - reference).abs() / reference.abs().max(f64::MIN_POSITIVE)),
            seconds: Secs(median),
            ns_per_sample: Fixed(median * 1e9 / samples.max(1) as f64),
            efficiency: Sci(if sd > 0.0 {
                1.0 / (sd * sd * median.max(f64::MIN_POSITIVE))
            } else {
                f64::INFINITY
            }),
            boundary_s: Secs(boundary_s / m),
            boundary_samples: boundary_samples / u64::from(cfg.seeds),
            image: String::new(),
        };
        if cfg.images {
            let dir = ctx.out_dir.join("images");
            std::fs::create_dir_all(&dir)?;
            let stem = format!("{}-{}-{}-{}spp-sd", run.sweep, param_name, name, spp);
            let data = Array2::from_shape_fn((h as usize, w as usize), |(y, x)| {
                let i = y * w as usize + x;
                per_pixel[i].variance(m).sqrt()
            });
            let mut map = Heatmap::new(
                format!("sd of ∂I/∂{param_name} per pixel: {name}, {spp} spp"),
                data,
            );
            map.palette = Palette::Viridis;
            map.value_label = format!("standard deviation over {} seeds", cfg.seeds);
            map.save(&dir.join(&stem))?;
            row.image = format!("images/{stem}.png");
        }
        Ok(row)
    }
}
