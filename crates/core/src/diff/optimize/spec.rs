//! Reading an optimisation spec (`raylab optimize SPEC.toml`; the format is
//! in the [module documentation](super)): TOML into the file's own structs
//! (every table with `deny_unknown_fields`, every value with its place),
//! then into a [`Spec`] whose parameter names are resolved against the
//! scene file. Every error names the spec file, the line and the column.

use super::{Loss, Method, OptimizerSettings};
use crate::diff::params::resolve;
use crate::diff::{self};
use crate::error::ParseError;
use crate::integrator::IntegratorKind;
use crate::io::scene_file::{Overrides, SceneSource};
use crate::io::{line_col, InputError, Place};
use crate::sampler::Sampler;
use crate::scene::description::SceneDescription;
use crate::scene::param::{MeshField, ParamId, Target as Field};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};
use toml::Spanned;

/// The most iterations a spec may ask for (each is a row of the CSV and
/// two renders).
pub const MAX_ITERATIONS: u32 = 100_000;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SpecFile {
    scene: Spanned<String>,
    #[serde(default)]
    description: String,
    integrator: Option<Spanned<String>>,
    visibility: Option<Spanned<String>>,
    sampler: Option<Spanned<String>>,
    image_sampler: Option<Spanned<String>>,
    snapshot_sampler: Option<Spanned<String>>,
    iterations: Spanned<u32>,
    #[serde(default = "default_seed")]
    seed: u64,
    width: Option<Spanned<u32>>,
    height: Option<Spanned<u32>>,
    snapshots: Option<Spanned<Vec<u32>>>,
    loss: Option<Spanned<String>>,
    target: Spanned<TargetFile>,
    optimizer: Spanned<OptimizerFile>,
    #[serde(default)]
    param: Vec<Spanned<ParamFile>>,
}

fn default_seed() -> u64 {
    1
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TargetFile {
    image: Option<Spanned<String>>,
    values: Option<BTreeMap<Spanned<String>, Spanned<toml::Value>>>,
    sampler: Option<Spanned<String>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct OptimizerFile {
    kind: Spanned<String>,
    learning_rate: Spanned<f64>,
    learning_rate_final: Option<Spanned<f64>>,
    beta1: Option<Spanned<f64>>,
    beta2: Option<Spanned<f64>>,
    epsilon: Option<Spanned<f64>>,
    #[serde(default)]
    average_last: u32,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ParamFile {
    name: Spanned<String>,
    start: Option<Spanned<toml::Value>>,
    min: Option<Spanned<toml::Value>>,
    max: Option<Spanned<toml::Value>>,
    learning_rate: Option<Spanned<f64>>,
}

/// What the renders are compared with.
#[derive(Clone, Debug)]
pub enum OptimizeTarget {
    /// An image file (.exr or .png) of the spec's size.
    Image(PathBuf),
    /// The scene with these values, rendered with `sampler` before the
    /// first iteration: the true values are known, so the parameter error
    /// is reported.
    Values {
        values: Vec<(ParamId, f32)>,
        sampler: Sampler,
    },
}

/// One parameter component to recover.
#[derive(Clone, Debug)]
pub struct ParamSpec {
    /// Which number of the scene it is.
    pub param: ParamId,
    /// Its name, as output files and tables call it.
    pub name: String,
    /// The first iterate.
    pub start: f32,
    /// Bounds the iterates are projected into.
    pub min: f32,
    pub max: f32,
    /// Its own learning rate (the optimiser's unless the block sets one).
    pub learning_rate: f64,
}

/// A checked optimisation spec.
#[derive(Clone, Debug)]
pub struct Spec {
    /// The spec file.
    pub path: PathBuf,
    pub description: String,
    /// The scene file (resolved against the spec's folder), read with the
    /// run's overrides (size, sampler, box filter): its description is
    /// what the parameters address, its text what results are written
    /// into.
    pub source: SceneSource,
    pub integrator: IntegratorKind,
    /// The gradient's visibility term: `full` (default) or `interior`.
    pub visibility: diff::Visibility,
    /// Samples of each iteration's gradient render.
    pub sampler: Sampler,
    /// Samples of each iteration's plain render (the image whose loss is
    /// taken).
    pub image_sampler: Sampler,
    /// Samples of the snapshot images drawn after the run.
    pub snapshot_sampler: Sampler,
    pub iterations: u32,
    pub seed: u64,
    pub width: Option<u32>,
    pub height: Option<u32>,
    /// Iterations whose parameters are drawn beside the target.
    pub snapshots: Vec<u32>,
    pub loss: Loss,
    pub target: OptimizeTarget,
    pub optimizer: OptimizerSettings,
    pub params: Vec<ParamSpec>,
}

impl Spec {
    /// The true values of the optimised parameters, when the target is a
    /// render of known values (a parameter the target does not set keeps
    /// the scene file's value).
    pub fn truth(&self) -> Option<Vec<f32>> {
        let OptimizeTarget::Values { values, .. } = &self.target else {
            return None;
        };
        Some(
            self.params
                .iter()
                .map(|p| {
                    values
                        .iter()
                        .find(|(q, _)| *q == p.param)
                        .map_or(self.source.description.value(p.param), |&(_, v)| v)
                })
                .collect(),
        )
    }
}

/// The overrides of a run's renders: its size, its sampler and the box
/// filter the gradient render needs.
fn run_overrides(width: Option<u32>, height: Option<u32>, sampler: Sampler) -> Overrides {
    Overrides {
        width,
        height,
        sampler: Some(sampler),
        filter: Some(crate::film::Filter::Box),
        ..Overrides::default()
    }
}

/// Read and check the spec at `path`.
pub fn load_spec(path: &Path) -> Result<Spec, InputError> {
    let text = crate::io::input::read_to_string(path, crate::io::input::InputKind::Manifest)?;
    parse_spec(&text, path)
}

/// Check the spec `text` (read from `path`, against whose folder the scene
/// and image paths resolve).
pub fn parse_spec(text: &str, path: &Path) -> Result<Spec, InputError> {
    let at = |span: Range<usize>, msg: String| {
        let (l, c) = line_col(text, span.start);
        InputError::new(path, Place::LineCol(l, c), msg)
    };
    crate::io::toml_numbers::check_floats(text, path)?;
    let file: SpecFile = toml::from_str(text).map_err(|e| match e.span() {
        Some(span) => at(span, e.message().to_string()),
        None => InputError::file(path, e.message().to_string()),
    })?;
    let base = path.parent().unwrap_or(Path::new(""));

    let scene = base.join(file.scene.get_ref());
    let named = |s: &Spanned<String>, parse: fn(&str) -> Result<_, ParseError>| {
        parse(s.get_ref()).map_err(|e| at(s.span(), e.to_string()))
    };
    let integrator: IntegratorKind = match &file.integrator {
        Some(s) => named(s, IntegratorKind::parse)?,
        None => IntegratorKind::Whitted,
    };
    let visibility = match &file.visibility {
        Some(s) => diff::Visibility::parse(s.get_ref()).map_err(|e| at(s.span(), e.to_string()))?,
        None => diff::Visibility::Full,
    };
    let sampler_of =
        |s: &Option<Spanned<String>>, default: Sampler| -> Result<Sampler, InputError> {
            let Some(s) = s else { return Ok(default) };
            let sampler = Sampler::parse(s.get_ref()).map_err(|e| at(s.span(), e.to_string()))?;
            if let Sampler::Adaptive { .. } = sampler {
                return Err(at(
                    s.span(),
                    "the gradient render needs a fixed sampler, not `adaptive`".into(),
                ));
            }
            Ok(sampler)
        };
    let sampler = sampler_of(&file.sampler, Sampler::Random { n: 4 })?;
    let image_sampler = sampler_of(&file.image_sampler, sampler)?;
    let snapshot_sampler = sampler_of(&file.snapshot_sampler, Sampler::Random { n: 64 })?;

    let iterations = *file.iterations.get_ref();
    if !(1..=MAX_ITERATIONS).contains(&iterations) {
        return Err(at(
            file.iterations.span(),
            format!("`iterations` must be in 1..={MAX_ITERATIONS}, got {iterations}"),
        ));
    }
    let size = |s: &Option<Spanned<u32>>, what: &str| -> Result<Option<u32>, InputError> {
        match s {
            Some(v) if *v.get_ref() == 0 || *v.get_ref() > 16384 => Err(at(
                v.span(),
                format!("`{what}` must be in 1..=16384, got {}", v.get_ref()),
            )),
            Some(v) => Ok(Some(*v.get_ref())),
            None => Ok(None),
        }
    };
    let (width, height) = (size(&file.width, "width")?, size(&file.height, "height")?);
    let snapshots = match &file.snapshots {
        Some(s) => {
            if let Some(&bad) = s.get_ref().iter().find(|&&i| i >= iterations) {
                return Err(at(
                    s.span(),
                    format!("snapshot iteration {bad} is not below `iterations` ({iterations})"),
                ));
            }
            let mut v = s.get_ref().clone();
            v.sort_unstable();
            v.dedup();
            v
        }
        None => {
            let mut v = vec![0, iterations / 10, iterations / 3];
            v.dedup();
            v
        }
    };
    let loss = match &file.loss {
        Some(s) => Loss::parse(s.get_ref()).map_err(|e| at(s.span(), e.to_string()))?,
        None => Loss::L2,
    };
    let optimizer = optimizer_settings(file.optimizer.get_ref(), &at)?;

    // Parameter names resolve against the scene file.
    let overrides = run_overrides(width, height, sampler);
    let (source, scene_now) = diff::load(&scene, &overrides).map_err(|e| {
        at(
            file.scene.span(),
            format!("scene `{}`: {e}", file.scene.get_ref()),
        )
    })?;
    diff::check_supported(&scene_now, &integrator).map_err(|e| {
        at(
            file.integrator.as_ref().map_or(0..0, |s| s.span()),
            e.to_string(),
        )
    })?;
    let params = param_specs(&file.param, &source.description, &optimizer, &at)?;
    if params.is_empty() {
        return Err(InputError::file(
            path,
            "no parameter to recover: add a [[param]] block with a `name`",
        ));
    }
    if params.len() > diff::params::MAX_PARAMS {
        return Err(at(
            file.param[0].span(),
            format!(
                "{} parameter components; one gradient render takes at most {}",
                params.len(),
                diff::params::MAX_PARAMS
            ),
        ));
    }

    let target_file = file.target.get_ref();
    let target = match (&target_file.image, &target_file.values) {
        (Some(image), None) => {
            if let Some(s) = &target_file.sampler {
                return Err(at(
                    s.span(),
                    "`sampler` applies to a target rendered from `values`, not to an image".into(),
                ));
            }
            OptimizeTarget::Image(base.join(image.get_ref()))
        }
        (None, Some(values)) if values.is_empty() => {
            return Err(at(
                file.target.span(),
                "[target] values is empty: name the parameters the target differs in".into(),
            ))
        }
        (None, Some(values)) => OptimizeTarget::Values {
            values: target_values(values, &source.description, &at)?,
            sampler: sampler_of(&target_file.sampler, Sampler::Random { n: 256 })?,
        },
        _ => {
            return Err(at(
                file.target.span(),
                "[target] needs exactly one of `image` (a file) and `values` (a table of \
                 parameter values to render the scene with)"
                    .into(),
            ))
        }
    };

    Ok(Spec {
        path: path.to_path_buf(),
        description: file.description.trim().to_string(),
        source,
        integrator,
        visibility,
        sampler,
        image_sampler,
        snapshot_sampler,
        iterations,
        seed: file.seed,
        width,
        height,
        snapshots,
        loss,
        target,
        optimizer,
        params,
    })
}

fn optimizer_settings(
    o: &OptimizerFile,
    at: &impl Fn(Range<usize>, String) -> InputError,
) -> Result<OptimizerSettings, InputError> {
    let method = match o.kind.get_ref().as_str() {
        "adam" => Method::Adam,
        "gd" => Method::GradientDescent,
        other => {
            return Err(at(
                o.kind.span(),
                format!("unknown optimiser `{other}` (expected `adam` or `gd`)"),
            ))
        }
    };
    let positive = |v: &Spanned<f64>, what: &str| {
        let x = *v.get_ref();
        if x > 0.0 && x.is_finite() {
            Ok(x)
        } else {
            Err(at(
                v.span(),
                format!("`{what}` must be a positive number, got {x}"),
            ))
        }
    };
    let beta = |v: &Option<Spanned<f64>>, what: &str, default: f64| match v {
        None => Ok(default),
        Some(b) if (0.0..1.0).contains(b.get_ref()) => Ok(*b.get_ref()),
        Some(b) => Err(at(
            b.span(),
            format!("`{what}` must be in [0, 1), got {}", b.get_ref()),
        )),
    };
    let learning_rate = positive(&o.learning_rate, "learning_rate")?;
    let adam_only = [&o.beta1, &o.beta2, &o.epsilon];
    if method == Method::GradientDescent {
        if let Some(s) = adam_only.iter().find_map(|v| v.as_ref()) {
            return Err(at(
                s.span(),
                "`beta1`, `beta2` and `epsilon` are Adam's settings; `gd` has none".into(),
            ));
        }
    }
    Ok(OptimizerSettings {
        method,
        learning_rate,
        learning_rate_final: match &o.learning_rate_final {
            Some(v) => positive(v, "learning_rate_final")?,
            None => learning_rate,
        },
        beta1: beta(&o.beta1, "beta1", 0.9)?,
        beta2: beta(&o.beta2, "beta2", 0.999)?,
        epsilon: match &o.epsilon {
            Some(v) => positive(v, "epsilon")?,
            None => 1e-8,
        },
        average_last: o.average_last,
    })
}

/// A number or a list of numbers, one per component (a number stands for
/// every component).
fn per_component(
    v: &Spanned<toml::Value>,
    n: usize,
    what: &str,
    at: &impl Fn(Range<usize>, String) -> InputError,
) -> Result<Vec<f32>, InputError> {
    let num = |x: &toml::Value| match x {
        toml::Value::Float(f) => Some(*f as f32),
        toml::Value::Integer(i) => Some(*i as f32),
        _ => None,
    };
    let values: Option<Vec<f32>> = match v.get_ref() {
        toml::Value::Array(a) if a.len() == n => a.iter().map(num).collect(),
        toml::Value::Array(_) => None,
        x => num(x).map(|x| vec![x; n]),
    };
    match values {
        Some(v) if v.iter().all(|x| x.is_finite()) => Ok(v),
        _ => Err(at(
            v.span(),
            format!(
                "`{what}` must be a finite number{}",
                if n > 1 {
                    format!(" or a list of {n} (one per component)")
                } else {
                    String::new()
                }
            ),
        )),
    }
}

fn param_specs(
    blocks: &[Spanned<ParamFile>],
    scene: &SceneDescription,
    optimizer: &OptimizerSettings,
    at: &impl Fn(Range<usize>, String) -> InputError,
) -> Result<Vec<ParamSpec>, InputError> {
    let mut out: Vec<ParamSpec> = Vec::new();
    for block in blocks {
        let b = block.get_ref();
        let params =
            resolve(b.name.get_ref(), scene).map_err(|e| at(b.name.span(), e.to_string()))?;
        if params
            .iter()
            .any(|p| matches!(p.target, Field::Mesh(_, MeshField::Vertices)))
        {
            return Err(at(
                b.name.span(),
                format!(
                    "`{}`: a mesh's vertices live in its mesh file, and `raylab optimize` \
                     writes its results as scene files",
                    b.name.get_ref()
                ),
            ));
        }
        let n = params.len();
        let values = |v: &Option<Spanned<toml::Value>>, what: &str, default: f32| match v {
            Some(v) => per_component(v, n, what, at),
            None => Ok(vec![default; n]),
        };
        let min = values(&b.min, "min", f32::NEG_INFINITY)?;
        let max = values(&b.max, "max", f32::INFINITY)?;
        let start = match &b.start {
            Some(v) => per_component(v, n, "start", at)?,
            None => params.iter().map(|&p| scene.value(p)).collect(),
        };
        let learning_rate = match &b.learning_rate {
            Some(v) if *v.get_ref() > 0.0 && v.get_ref().is_finite() => *v.get_ref(),
            Some(v) => {
                return Err(at(
                    v.span(),
                    format!(
                        "`learning_rate` must be a positive number, got {}",
                        v.get_ref()
                    ),
                ))
            }
            None => optimizer.learning_rate,
        };
        for (k, param) in params.into_iter().enumerate() {
            let name = scene.param_name(param);
            if out.iter().any(|q| q.param == param) {
                return Err(at(
                    b.name.span(),
                    format!("parameter `{name}` is named twice"),
                ));
            }
            if min[k] > max[k] {
                return Err(at(
                    block.span(),
                    format!("{name}: `min` {} is above `max` {}", min[k], max[k]),
                ));
            }
            if !(min[k]..=max[k]).contains(&start[k]) {
                return Err(at(
                    b.start.as_ref().map_or(block.span(), |s| s.span()),
                    format!(
                        "{name}: the start {} is outside [{}, {}]",
                        start[k], min[k], max[k]
                    ),
                ));
            }
            out.push(ParamSpec {
                param,
                name,
                start: start[k],
                min: min[k],
                max: max[k],
                learning_rate,
            });
        }
    }
    Ok(out)
}

fn target_values(
    values: &BTreeMap<Spanned<String>, Spanned<toml::Value>>,
    scene: &SceneDescription,
    at: &impl Fn(Range<usize>, String) -> InputError,
) -> Result<Vec<(ParamId, f32)>, InputError> {
    let mut out: Vec<(ParamId, f32)> = Vec::new();
    for (name, v) in values {
        let params = resolve(name.get_ref(), scene).map_err(|e| at(name.span(), e.to_string()))?;
        let numbers = per_component(v, params.len(), name.get_ref(), at)?;
        for (p, x) in params.into_iter().zip(numbers) {
            if out.iter().any(|(q, _)| *q == p) {
                return Err(at(
                    name.span(),
                    format!("target value `{}` is given twice", scene.param_name(p)),
                ));
            }
            out.push((p, x));
        }
    }
    Ok(out)
}
