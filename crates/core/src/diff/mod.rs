//! Derivatives of images with respect to scene parameters, by forward-mode
//! automatic differentiation through the renderer's own code.
//!
//! - [`params`]: parameters named by their place in the scene file
//!   (`materials.red.color[0]`, `sphere[1].radius`, `camera.fov`…).
//! - [`view`]: the scene over dual numbers ([`crate::math::Dual`]), seeded
//!   with those parameters: a [`crate::scene::View`] the integrators run on
//!   unchanged.
//! - [`render`]: the gradient render, per pixel, with sample variances.
//! - [`boundary`]: the boundary term at silhouettes and shadow edges, by
//!   edge sampling (`--visibility full`).
//! - [`check`]: central finite differences, the check, and the edge mask.
//! - [`optimize`]: inverse rendering, gradient descent on a loss against a
//!   target image (`raylab optimize`).
//!
//! **What forward mode through fixed samples computes.** Each pixel
//! estimate is a function of the parameters for fixed random numbers; the
//! dual numbers differentiate that function. Where it is smooth this is the
//! derivative of the estimate, and its expectation is the derivative of the
//! pixel (the *interior* derivative). What it misses is that a sample's
//! discrete outcome changes with the parameters: which surface a camera or
//! bounce ray sees (silhouettes), whether a shadow ray is blocked (shadow
//! edges), whether a ray refracts (total internal reflection). Those
//! changes make the pixel's expectation depend on the parameters through
//! the *boundaries* between outcomes, a term forward mode does not see: for
//! parameters that move geometry (positions, radii, transforms, the
//! camera, a light's position) the result is biased exactly at those
//! boundaries. Colours, emission, intensities, reflectance coefficients and
//! (where no silhouette moves) the index of refraction have no such term.
//! `raylab grad --check fd` measures the difference.
//!
//! **Discrete choices** (which emitter a light sample picks, Russian
//! roulette) keep their probabilities as constants: the estimator f/P of a
//! discrete choice has expectation Σ f, whose derivative is Σ f′ = E[f′/P].
//! Continuous sampling (a point on a triangle, a cosine-distributed
//! direction) is a reparameterisation: the sample moves with the
//! parameters for fixed numbers, and its density is differentiated with it.

pub mod boundary;
pub mod check;
pub mod optimize;
pub mod params;
pub mod planes;
pub mod render;
pub mod rim;
pub mod view;

pub use boundary::{BoundaryStats, Visibility};
pub use check::{
    central_difference, check_param, check_step, compare, difference_step, edge_mask, step_for,
    Comparison, Difference, Renderer,
};
pub use params::{default_step, resolve, resolve_all, MAX_PARAMS};
pub use planes::Planes;
pub use render::{check_supported, gradient_bytes, render_gradients, GradientRender, Gradients};
pub use view::DualScene;

use crate::camera::CameraError;
use crate::integrator::RenderError;
use crate::io::scene_file::{Overrides, RewriteError, SceneSource};
use crate::io::InputError;
use crate::scene::param::ParamError;
use crate::scene::Scene;
use std::path::Path;

/// Why a derivative could not be computed.
#[derive(Debug, Clone, thiserror::Error)]
pub enum DiffError {
    /// A scene file (or spec, or target image) that does not read or
    /// check.
    #[error(transparent)]
    Input(#[from] InputError),
    /// A parameter name that does not resolve.
    #[error(transparent)]
    Param(#[from] ParamError),
    #[error("parameter `{0}` is named twice")]
    NamedTwice(String),
    #[error(
        "more than {MAX_PARAMS} parameter components (the limit of one gradient render); \
         split them over several runs"
    )]
    TooManyParams,
    #[error("no parameter given (use --param, e.g. `--param materials.red.color`)")]
    NoParams,
    /// An integrator, sampler or filter the gradient render does not
    /// differentiate.
    #[error("{0}")]
    Unsupported(String),
    /// A camera whose frame degenerates at the parameters' values.
    #[error("[camera]: {0}")]
    Camera(CameraError),
    /// A finite difference's step that leaves the parameter's range, or
    /// vanishes in `f32`.
    #[error("{0}")]
    Step(String),
    /// A render that failed (a flood-fill cache that cannot be built).
    #[error(transparent)]
    Render(#[from] RenderError),
    /// The scene file's text could not be rewritten with an iterate's
    /// values.
    #[error(transparent)]
    Rewrite(#[from] RewriteError),
    /// An optimisation that cannot go on (a target of the wrong size, a
    /// scene the iterate leaves invalid, results that cannot be written).
    #[error("{0}")]
    Optimize(String),
    /// Derivative planes that would not fit in memory.
    #[error(transparent)]
    Memory(#[from] crate::film::memory::MemoryError),
}

/// Not `#[from]`: the variant's message already holds the camera's, so
/// it has no `source` for an error chain to print twice.
impl From<CameraError> for DiffError {
    fn from(e: CameraError) -> Self {
        Self::Camera(e)
    }
}

/// A scene file read (with `overrides`) and its scene: parameter names
/// resolve against the source's description.
pub fn load(path: &Path, overrides: &Overrides) -> Result<(SceneSource, Scene), InputError> {
    let source = SceneSource::load(path, overrides)?;
    let scene = source.build()?;
    Ok((source, scene))
}
