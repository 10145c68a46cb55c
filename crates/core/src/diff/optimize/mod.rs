//! Inverse rendering: recover scene parameters from an image by gradient
//! descent on a loss between renders and a target, with the derivatives of
//! [`crate::diff::render_gradients`].
//!
//! # The spec
//!
//! `raylab optimize SPEC.toml` reads (paths relative to the spec's folder):
//!
//! ```toml
//! scene = "../../data/scenes/cornell-box.toml"
//! description = "The Cornell box's wall colours from one image."
//! integrator = "path:3"      # whitted (default), direct, path:K
//! visibility = "full"        # full (default) or interior: the boundary term or not
//! sampler = "random:4"       # each iteration's gradient render (default random:4)
//! image_sampler = "random:16"  # its plain render (default: `sampler`)
//! iterations = 200
//! seed = 1                   # iteration i's seeds derive from it
//! width = 64                 # optional: the scene file's size otherwise
//! height = 64
//! loss = "l2"                # l2 (default), l1, relative_l2
//! snapshots = [0, 20, 60]    # iterations drawn beside the target
//! snapshot_sampler = "random:64"
//!
//! [target]                   # exactly one of image and values
//! values = { "materials.red.color" = [0.65, 0.05, 0.05] }
//! sampler = "random:256"     # the target render (values only)
//! # image = "photo.exr"      # .exr (linear) or .png (sRGB), same size
//!
//! [optimizer]
//! kind = "adam"              # adam or gd (plain gradient descent)
//! learning_rate = 0.02       # Adam: about the step in parameter units
//! learning_rate_final = 0.002  # optional: decays geometrically to this
//! beta1 = 0.9                # Adam's moment decays and epsilon
//! beta2 = 0.999
//! epsilon = 1e-8
//! average_last = 50          # optional: the result is the mean of the last 50 iterates
//!
//! [[param]]                  # one block per scene-file field
//! name = "materials.red.color"   # as `raylab grad --param` names it
//! start = 0.5                # a number for every component, or a list
//! min = 0.0                  # bounds the iterates are projected into
//! max = 1.0
//! learning_rate = 0.05       # optional: this field's own rate
//! ```
//!
//! # One iteration
//!
//! The scene's description gets the current parameter values (through
//! the parameter table, [`crate::scene::param`]) and the scene is built
//! again; then two renders with independent seeds: the gradient render (each pixel's
//! ∂I/∂θ) and the plain render (the image I). The loss of I against the
//! target T is reported, and its gradient is
//! ∂L/∂θₖ = Σⱼ ∂ℓ/∂Iⱼ · ∂Iⱼ/∂θₖ over pixels and channels j.
//!
//! **Why two seeds.** With one seed, I and ∂I/∂θ share their noise, and
//! E\[(I − T)·∂I/∂θ\] ≠ (E\[I\] − T)·E\[∂I/∂θ\]: for L2 the product of two
//! *independent* unbiased estimates is an unbiased estimate of the gradient
//! of the loss of the expected image, ‖E\[I\] − T‖², whose minimum is the
//! true parameters (the reported loss, E‖I − T‖², is that plus the render's
//! variance). Near the optimum the gradient's noise is mostly the plain
//! render's (its residual I − T times ∂I/∂θ), which is why that render has
//! its own, cheaper and larger, sample count (`image_sampler`).
//!
//! **Losses** (means over pixels and channels): L2 (I − T)², L1 |I − T|,
//! relative L2 (I − T)² / (T² + 0.01), which weighs dark and bright regions
//! alike. Relative L2 is a weighted L2 with weights from the target: its
//! gradient is unbiased too, but when the target is itself a noisy render
//! the weights correlate with the target's noise (a pixel that came out
//! dark weighs more), which moves the optimum; the Cornell demo found its
//! light's emission 0.7 % low that way, where L2 found it within 0.1 %.
//! L1's gradient, sign(I − T)·∂I/∂θ, is not linear in I: with independent
//! estimates it is consistent (right as spp grows), not unbiased.
//!
//! **Optimisers.** Adam (Kingma and Ba 2015): each component's step is
//! about its learning rate in the parameter's own units, whatever the
//! gradient's scale; give each field a rate that suits its range (a colour
//! 0.01–0.05, an emission of 10 about 0.5). Plain gradient descent steps
//! by the rate times the gradient. Either way the rate may decay
//! geometrically over the run (`learning_rate_final`), and each iterate is
//! projected into its bounds. With noisy gradients the iterates end in a
//! cloud about the optimum whose width follows the last rate;
//! `average_last = N` reports the mean of the last N iterates instead of
//! the last one (Polyak–Ruppert averaging), which narrows it by about √N
//! where successive iterates are nearly independent.
//!
//! **What the derivatives cover.** The gradient render's derivative is the
//! *interior* one (see [`crate::diff`]): exact for colours, emission,
//! intensities and an index of refraction where no boundary moves with it;
//! for parameters that move silhouettes or shadow edges it misses the
//! boundary term, and an optimisation of those may stop short of the truth.

pub mod spec;

pub use spec::{load_spec, parse_spec, OptimizeTarget, ParamSpec, Spec};

use super::render::{render_gradients, GradientRender};
use super::DiffError;
use crate::error::ParseError;
use crate::film::LinearImage;
use crate::math::SplitMix64;
use crate::sampler::Sampler;
use crate::scene::description::SceneDescription;
use crate::scene::param::{ParamId, Target as Field};
use crate::scene::Scene;
use crate::stats::NoStats;
use std::path::Path;
use std::time::Instant;

/// The loss between a render and the target.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Loss {
    /// Mean of (I − T)².
    L2,
    /// Mean of |I − T|.
    L1,
    /// Mean of (I − T)² / (T² + [`RELATIVE_EPSILON`]).
    RelativeL2,
}

/// The constant that keeps relative L2 finite where the target is black.
pub const RELATIVE_EPSILON: f32 = 0.01;

impl Loss {
    /// `l2`, `l1` or `relative_l2`.
    pub fn parse(s: &str) -> Result<Self, ParseError> {
        match s {
            "l2" => Ok(Self::L2),
            "l1" => Ok(Self::L1),
            "relative_l2" => Ok(Self::RelativeL2),
            _ => Err(ParseError::Unknown {
                what: "loss",
                given: s.to_string(),
                expected: "`l2`, `l1` or `relative_l2`".into(),
            }),
        }
    }

    /// The name it parses from.
    pub fn name(self) -> &'static str {
        match self {
            Self::L2 => "l2",
            Self::L1 => "l1",
            Self::RelativeL2 => "relative_l2",
        }
    }

    /// The loss of `image` against `target` (same shape) and its
    /// derivative with respect to each element of `image`, in the
    /// images' row-major, RGB-interleaved order.
    pub fn evaluate(self, image: &LinearImage, target: &LinearImage) -> (f64, Vec<f64>) {
        let n = image.len().max(1) as f64;
        let mut total = 0.0f64;
        let d: Vec<f64> = image
            .iter()
            .zip(target.iter())
            .map(|(&i, &t)| {
                let r = i - t;
                let (l, dl) = match self {
                    Self::L2 => (r * r, 2.0 * r),
                    Self::L1 => (r.abs(), r.signum() * f32::from(r != 0.0)),
                    Self::RelativeL2 => {
                        let w = 1.0 / (t * t + RELATIVE_EPSILON);
                        (r * r * w, 2.0 * r * w)
                    }
                };
                total += f64::from(l);
                f64::from(dl) / n
            })
            .collect();
        (total / n, d)
    }
}

/// Which update rule.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    Adam,
    GradientDescent,
}

/// The optimiser's settings (the spec's `[optimizer]`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OptimizerSettings {
    pub method: Method,
    /// The rate of the first iteration…
    pub learning_rate: f64,
    /// …and of the last; geometric in between.
    pub learning_rate_final: f64,
    pub beta1: f64,
    pub beta2: f64,
    pub epsilon: f64,
    /// The result is the mean of this many last iterates (0 or 1: the
    /// last one).
    pub average_last: u32,
}

impl OptimizerSettings {
    /// The factor on every rate at iteration `i` of `n`.
    pub fn schedule(&self, i: u32, n: u32) -> f64 {
        if n <= 1 {
            return 1.0;
        }
        (self.learning_rate_final / self.learning_rate).powf(f64::from(i) / f64::from(n - 1))
    }

    /// A short description (`adam, rate 0.02 → 0.002`).
    pub fn describe(&self) -> String {
        let name = match self.method {
            Method::Adam => "adam",
            Method::GradientDescent => "gradient descent",
        };
        if self.learning_rate_final == self.learning_rate {
            format!("{name}, rate {}", self.learning_rate)
        } else {
            format!(
                "{name}, rate {} → {}",
                self.learning_rate, self.learning_rate_final
            )
        }
    }
}

/// The optimiser's state: Adam's moment estimates.
#[derive(Clone, Debug)]
pub struct Optimizer {
    settings: OptimizerSettings,
    m: Vec<f64>,
    v: Vec<f64>,
    steps: i32,
}

impl Optimizer {
    pub fn new(settings: OptimizerSettings, n: usize) -> Self {
        Self {
            settings,
            m: vec![0.0; n],
            v: vec![0.0; n],
            steps: 0,
        }
    }

    // ANCHOR: adam
    /// Move `theta` against `gradient` with per-component `rates` (already
    /// scheduled), then project into `[min, max]`.
    pub fn step(
        &mut self,
        theta: &mut [f64],
        gradient: &[f64],
        rates: &[f64],
        bounds: &[(f64, f64)],
    ) {
        let s = self.settings;
        self.steps += 1;
        for k in 0..theta.len() {
            let g = gradient[k];
            let delta = match s.method {
                Method::GradientDescent => rates[k] * g,
                Method::Adam => {
                    self.m[k] = s.beta1 * self.m[k] + (1.0 - s.beta1) * g;
                    self.v[k] = s.beta2 * self.v[k] + (1.0 - s.beta2) * g * g;
                    let m = self.m[k] / (1.0 - s.beta1.powi(self.steps));
                    let v = self.v[k] / (1.0 - s.beta2.powi(self.steps));
                    rates[k] * m / (v.sqrt() + s.epsilon)
                }
            };
            let (lo, hi) = bounds[k];
            theta[k] = (theta[k] - delta).clamp(lo, hi);
        }
    }
    // ANCHOR_END: adam
}

/// The mean of the last `n` of `iterates` (all of them if fewer; the last
/// one if `n` ≤ 1).
pub fn average_last(iterates: &[Vec<f64>], n: u32) -> Vec<f64> {
    let n = (n.max(1) as usize).min(iterates.len());
    let tail = &iterates[iterates.len() - n..];
    let mut mean = vec![0.0; tail.first().map_or(0, Vec::len)];
    for t in tail {
        for (m, v) in mean.iter_mut().zip(t) {
            *m += v / n as f64;
        }
    }
    mean
}

/// |θ − θ*| / |θ*|, or |θ − θ*| where θ* is (nearly) zero.
pub fn relative_error(value: f64, truth: f64) -> f64 {
    let e = (value - truth).abs();
    if truth.abs() < 1e-6 {
        e
    } else {
        e / truth.abs()
    }
}

/// What one iteration measured.
#[derive(Clone, Debug)]
pub struct Iteration {
    /// 0-based.
    pub index: u32,
    /// The parameters this iteration rendered with (before its step).
    pub theta: Vec<f64>,
    /// The loss of its plain render against the target.
    pub loss: f64,
    /// ∂L/∂θ per parameter.
    pub gradient: Vec<f64>,
    /// The factor on the learning rates.
    pub rate_factor: f64,
    /// Seconds of the iteration (both renders, the loss, the step).
    pub seconds: f64,
}

impl Iteration {
    /// The Euclidean norm of the gradient.
    pub fn gradient_norm(&self) -> f64 {
        self.gradient.iter().map(|g| g * g).sum::<f64>().sqrt()
    }
}

/// A spec made ready to run: the target image.
pub struct Problem {
    pub spec: Spec,
    /// The target image (read, or rendered from the target values).
    pub target: LinearImage,
    /// Seconds spent making the target (0 for an image).
    pub target_seconds: f64,
}

/// The seed of render `which` of iteration `i` (distinct streams for the
/// gradient and plain renders, the target and the snapshots).
fn seed_of(base: u64, i: u64, which: u64) -> u64 {
    SplitMix64::mix(base ^ SplitMix64::mix(i ^ SplitMix64::mix(which)))
}

const GRADIENT: u64 = 1;
const PRIMAL: u64 = 2;
const TARGET: u64 = 3;
const SNAPSHOT: u64 = 4;

impl Problem {
    /// Make the target (rendering it when the spec gives values; `threads`
    /// as for a render).
    pub fn new(spec: Spec, threads: Option<usize>) -> Result<Self, DiffError> {
        let mut problem = Self {
            spec,
            target: LinearImage::zeros((0, 0, 3)),
            target_seconds: 0.0,
        };
        let start = Instant::now();
        problem.target = match &problem.spec.target {
            OptimizeTarget::Image(path) => {
                let image = crate::io::image::read_image(path)?;
                let bad = image.indexed_iter().find(|(_, v)| !v.is_finite());
                if let Some(((y, x, _), v)) = bad {
                    return Err(crate::io::InputError::file(
                        path,
                        format!("pixel ({x}, {y}) is {v}: a target image must be finite"),
                    )
                    .into());
                }
                image
            }
            OptimizeTarget::Values { values, sampler } => {
                let mut desc = problem.spec.source.description.clone();
                for &(p, v) in values {
                    desc.set_value(p, v);
                }
                let seed = seed_of(problem.spec.seed, 0, TARGET);
                problem.render(desc, *sampler, seed, threads)?
            }
        };
        problem.target_seconds = start.elapsed().as_secs_f64();
        let scene = problem.scene_at(&problem.start())?.1;
        let want = (scene.camera.height as usize, scene.camera.width as usize, 3);
        if problem.target.dim() != want {
            let (h, w, _) = problem.target.dim();
            return Err(DiffError::Optimize(format!(
                "the target image is {w}×{h}, the renders {}×{}: set `width` and `height` in \
                 the spec to the image's size",
                want.1, want.0
            )));
        }
        Ok(problem)
    }

    /// The first iterate.
    pub fn start(&self) -> Vec<f64> {
        self.spec
            .params
            .iter()
            .map(|p| f64::from(p.start))
            .collect()
    }

    /// The optimised parameters' ids.
    fn ids(&self) -> Vec<ParamId> {
        self.spec.params.iter().map(|p| p.param).collect()
    }

    /// The scene's description with parameters `theta`.
    fn description_at(&self, theta: &[f64]) -> SceneDescription {
        let mut desc = self.spec.source.description.clone();
        for (p, &v) in self.spec.params.iter().zip(theta) {
            desc.set_value(p.param, v as f32);
        }
        desc
    }

    /// The scene file's text with parameters `theta` (comments dropped,
    /// mesh paths as written).
    pub fn text_at(&self, theta: &[f64]) -> Result<String, DiffError> {
        let fields: Vec<Field> = self.spec.params.iter().map(|p| p.param.target).collect();
        self.spec
            .source
            .text_with(&self.description_at(theta), &fields)
            .map_err(DiffError::from)
    }

    /// The scene with parameters `theta`, and its description.
    fn scene_at(&self, theta: &[f64]) -> Result<(SceneDescription, Scene), DiffError> {
        let desc = self.description_at(theta);
        let scene = self.spec.source.build_from(&desc).map_err(|e| {
            DiffError::Optimize(format!("the scene with the current parameters: {e}"))
        })?;
        Ok((desc, scene))
    }

    /// The image of `desc` rendered with `sampler` and `seed`.
    fn render(
        &self,
        mut desc: SceneDescription,
        sampler: Sampler,
        seed: u64,
        threads: Option<usize>,
    ) -> Result<LinearImage, DiffError> {
        desc.settings.sampler = sampler;
        desc.settings.seed = seed;
        let scene = self.spec.source.build_from(&desc)?;
        let (film, _) = self.spec.integrator.render::<NoStats>(&scene, threads)?;
        Ok(film.box_image())
    }

    /// A render with parameters `theta` and the snapshot sampler (the
    /// figures' images).
    pub fn snapshot(
        &self,
        theta: &[f64],
        threads: Option<usize>,
    ) -> Result<LinearImage, DiffError> {
        let seed = seed_of(self.spec.seed, 0, SNAPSHOT);
        self.render(
            self.description_at(theta),
            self.spec.snapshot_sampler,
            seed,
            threads,
        )
    }

    /// Iteration `i` at `theta`: the loss and its gradient, then the step
    /// (`theta` becomes the next iterate).
    pub fn iterate(
        &self,
        i: u32,
        theta: &mut [f64],
        optimizer: &mut Optimizer,
        threads: Option<usize>,
    ) -> Result<Iteration, DiffError> {
        let start = Instant::now();
        let (desc, mut scene) = self.scene_at(theta)?;
        scene.settings.seed = seed_of(self.spec.seed, u64::from(i), GRADIENT);
        let grads = render_gradients(&GradientRender {
            scene: &scene,
            desc: &desc,
            params: &self.ids(),
            integrator: self.spec.integrator,
            visibility: self.spec.visibility,
            threads,
        })?;
        scene.settings.seed = seed_of(self.spec.seed, u64::from(i), PRIMAL);
        scene.settings.sampler = self.spec.image_sampler;
        let (film, _) = self.spec.integrator.render::<NoStats>(&scene, threads)?;
        // ANCHOR: loss_gradient
        let (loss, dl) = self.spec.loss.evaluate(&film.box_image(), &self.target);
        let gradient: Vec<f64> = grads
            .planes
            .mean
            .iter()
            .map(|d| d.iter().zip(&dl).map(|(&a, &b)| f64::from(a) * b).sum())
            .collect();
        // ANCHOR_END: loss_gradient
        let record = Iteration {
            index: i,
            theta: theta.to_vec(),
            loss,
            gradient: gradient.clone(),
            rate_factor: self.spec.optimizer.schedule(i, self.spec.iterations),
            seconds: 0.0,
        };
        let rates: Vec<f64> = self
            .spec
            .params
            .iter()
            .map(|p| p.learning_rate * record.rate_factor)
            .collect();
        let bounds: Vec<(f64, f64)> = self
            .spec
            .params
            .iter()
            .map(|p| (f64::from(p.min), f64::from(p.max)))
            .collect();
        optimizer.step(theta, &gradient, &rates, &bounds);
        Ok(Iteration {
            seconds: start.elapsed().as_secs_f64(),
            ..record
        })
    }

    /// The scene file's text with parameters `theta`, for a file written
    /// in `folder`: relative mesh paths are rewritten to stay valid there.
    /// Parameters that leave the scene invalid (a radius stepped below
    /// zero within the spec's bounds, a NaN) are an error naming them, so
    /// no scene file that does not load is written.
    pub fn text_for(&self, theta: &[f64], folder: &Path) -> Result<String, DiffError> {
        self.description_at(theta).check().map_err(|e| {
            DiffError::Optimize(format!(
                "the parameters {} leave the scene invalid ({}: {}); the last valid scene \
                 was kept",
                self.spec
                    .params
                    .iter()
                    .zip(theta)
                    .map(|(p, v)| format!("{} = {v}", p.name))
                    .collect::<Vec<_>>()
                    .join(", "),
                e.entity,
                e.message
            ))
        })?;
        let text = self.text_at(theta)?;
        let bad = |e: toml::ser::Error| DiffError::Optimize(e.to_string());
        let mut table: toml::Table =
            toml::from_str(&text).map_err(|e| DiffError::Optimize(e.to_string()))?;
        let from = self.spec.source.path.parent().unwrap_or(Path::new(""));
        if let Some(meshes) = table.get_mut("mesh").and_then(|m| m.as_array_mut()) {
            for mesh in meshes {
                let Some(file) = mesh.get_mut("file") else {
                    continue;
                };
                if let Some(name) = file.as_str().map(Path::new).filter(|p| p.is_relative()) {
                    let moved = relative_path(&from.join(name), folder);
                    *file = toml::Value::String(moved.to_string_lossy().into_owned());
                }
            }
        }
        toml::to_string(&table).map_err(bad)
    }
}

/// `target` as seen from `folder` (relative where both resolve, else
/// absolute).
fn relative_path(target: &Path, folder: &Path) -> std::path::PathBuf {
    let (Ok(t), Ok(f)) = (target.canonicalize(), folder.canonicalize()) else {
        return std::path::absolute(target).unwrap_or_else(|_| target.to_path_buf());
    };
    let common = t
        .components()
        .zip(f.components())
        .take_while(|(a, b)| a == b)
        .count();
    let mut out = std::path::PathBuf::new();
    for _ in f.components().skip(common) {
        out.push("..");
    }
    for c in t.components().skip(common) {
        out.push(c);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::Array3;

    fn settings(method: Method) -> OptimizerSettings {
        OptimizerSettings {
            method,
            learning_rate: 0.1,
            learning_rate_final: 0.1,
            beta1: 0.9,
            beta2: 0.999,
            epsilon: 1e-8,
            average_last: 0,
        }
    }

    #[test]
    fn averaging_takes_the_mean_of_the_last_iterates() {
        let it = vec![vec![0.0, 10.0], vec![1.0, 20.0], vec![3.0, 40.0]];
        let close = |a: Vec<f64>, b: [f64; 2]| {
            assert!(
                a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-12),
                "{a:?} vs {b:?}"
            )
        };
        close(average_last(&it, 2), [2.0, 30.0]);
        close(average_last(&it, 0), [3.0, 40.0]);
        close(average_last(&it, 9), [4.0 / 3.0, 70.0 / 3.0]);
    }

    #[test]
    fn losses_and_their_derivatives_agree_with_differences() {
        let image = Array3::from_shape_fn((2, 3, 3), |(y, x, c)| 0.1 * (y + 2 * x + c) as f32);
        let target =
            Array3::from_shape_fn((2, 3, 3), |(y, x, c)| 0.05 * (3 * y + x + c) as f32 + 0.01);
        for loss in [Loss::L2, Loss::L1, Loss::RelativeL2] {
            let (l0, d) = loss.evaluate(&image, &target);
            for (j, &dj) in d.iter().enumerate() {
                let h = 1e-3;
                let mut up = image.clone();
                up.as_slice_mut().unwrap()[j] += h;
                let mut down = image.clone();
                down.as_slice_mut().unwrap()[j] -= h;
                let fd = (loss.evaluate(&up, &target).0 - loss.evaluate(&down, &target).0)
                    / (2.0 * f64::from(h));
                assert!((fd - dj).abs() < 1e-4, "{loss:?} element {j}: {fd} vs {dj}");
            }
            assert!(l0 > 0.0);
            assert_eq!(loss.evaluate(&image, &image).0, 0.0, "{loss:?}");
        }
    }

    #[test]
    fn adam_and_gradient_descent_find_a_quadratics_minimum_within_bounds() {
        // L = Σ (θ − c)², with the second minimum outside its bounds.
        let c = [0.3, 2.0];
        let bounds = [(0.0, 1.0), (0.0, 1.0)];
        for method in [Method::Adam, Method::GradientDescent] {
            let mut opt = Optimizer::new(settings(method), 2);
            let mut theta = vec![0.9, 0.5];
            for _ in 0..500 {
                let g: Vec<f64> = theta.iter().zip(c).map(|(t, c)| 2.0 * (t - c)).collect();
                opt.step(&mut theta, &g, &[0.01, 0.01], &bounds);
            }
            assert!((theta[0] - 0.3).abs() < 0.02, "{method:?}: {theta:?}");
            assert_eq!(theta[1], 1.0, "{method:?}: projected onto the bound");
        }
    }

    #[test]
    fn adam_steps_by_about_the_rate_whatever_the_gradient_scale() {
        for scale in [1e-6, 1.0, 1e6] {
            let mut opt = Optimizer::new(settings(Method::Adam), 1);
            let mut theta = vec![0.0];
            opt.step(&mut theta, &[scale], &[0.1], &[(-1.0, 1.0)]);
            // The first step is rate·g/(|g| + ε): ε = 1e-8 shortens it by
            // 1 % at |g| = 1e-6.
            assert!((theta[0] + 0.1).abs() < 1.1e-3, "{scale}: {theta:?}");
        }
    }

    #[test]
    fn the_schedule_decays_geometrically_from_first_to_last_rate() {
        let mut s = settings(Method::Adam);
        s.learning_rate_final = 0.001;
        assert_eq!(s.schedule(0, 3), 1.0);
        assert!((s.schedule(1, 3) - 0.1).abs() < 1e-12);
        assert!((s.schedule(2, 3) - 0.01).abs() < 1e-12);
        assert_eq!(s.schedule(0, 1), 1.0);
    }

    #[test]
    fn relative_error_falls_back_to_absolute_at_zero() {
        assert!((relative_error(1.01, 1.0) - 0.01).abs() < 1e-12);
        assert_eq!(relative_error(0.5, 0.0), 0.5);
    }
}
