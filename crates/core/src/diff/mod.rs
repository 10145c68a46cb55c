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
pub mod render;
pub mod rim;
pub mod view;

pub use boundary::{BoundaryStats, Visibility};
pub use check::{
    central_difference, check_param, check_step, compare, default_step, difference_step, edge_mask,
    scene_text_with_all, Comparison, Difference,
};
pub use params::{resolve, resolve_all, Entity, Param};
pub use render::{check_supported, render_gradients, Gradients};
pub use view::DualScene;

use crate::io::scene_file::{parse_scene, Overrides, SceneFile};
use crate::scene::Scene;
use std::path::Path;

/// A scene file's text, its scene (loaded with `overrides`) and its parsed
/// structure, which parameter names resolve against.
pub fn load(path: &Path, overrides: &Overrides) -> Result<(String, Scene, SceneFile), String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| format!("{}: cannot read scene file: {e}", path.display()))?;
    let scene = parse_scene(&text, path, overrides).map_err(|e| e.to_string())?;
    // The loader has accepted the text, so this parse succeeds.
    let file: SceneFile =
        toml::from_str(&text).map_err(|e| format!("{}: {}", path.display(), e.message()))?;
    Ok((text, scene, file))
}
