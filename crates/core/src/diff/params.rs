//! The parameters of one forward-mode gradient render: names resolved
//! through the scene's parameter table ([`crate::scene::param`]) into
//! typed ids, one per component, at most [`MAX_PARAMS`] of them; and what
//! each kind of parameter moves (geometry, the camera, what a camera ray
//! meets), which the boundary term and the rim sampler ask.

use super::DiffError;
use crate::scene::description::SceneDescription;
use crate::scene::param::{Entity, LightField, MaterialField, ParamError, ParamId, Target};

/// The most parameter components one gradient render takes (16 passes of
/// 16): each costs about a render and 28 bytes per pixel of output.
pub const MAX_PARAMS: usize = 256;

/// Resolve a parameter name against a scene: one id per component it
/// names (a vector field without an index is its three components).
pub fn resolve(path: &str, desc: &SceneDescription) -> Result<Vec<ParamId>, ParamError> {
    Ok(desc.select(path)?.ids().collect())
}

/// Resolve several names; a component named twice is an error, and so are
/// more than [`MAX_PARAMS`] components.
pub fn resolve_all(paths: &[String], desc: &SceneDescription) -> Result<Vec<ParamId>, DiffError> {
    let mut out: Vec<ParamId> = Vec::new();
    for p in paths {
        let selection = desc.select(p)?;
        if out.len() + selection.len() > MAX_PARAMS {
            return Err(DiffError::TooManyParams);
        }
        for id in selection.ids() {
            if out.contains(&id) {
                return Err(DiffError::NamedTwice(desc.param_name(id)));
            }
            out.push(id);
        }
    }
    if out.is_empty() {
        return Err(DiffError::NoParams);
    }
    Ok(out)
}

/// The default step of the central difference for a parameter of value
/// `value`: h = ε^⅓ · max(|p|, 1) (argued in [`super::check`]).
pub fn default_step(value: f32) -> f32 {
    f32::EPSILON.cbrt() * value.abs().max(1.0)
}

/// Whether parameter `p` moves boundaries: geometry, the camera, a
/// light's position, an index of refraction (what refraction shows).
pub fn is_geometric(p: &ParamId) -> bool {
    match p.target {
        Target::Light(_, f) => f == LightField::Position,
        _ => moves_hits(p),
    }
}

/// Whether parameter `p` moves what a camera ray meets at a fixed film
/// point (an object, a plane, the camera, an index of refraction): only
/// then has the interior integrand the rim singularity ([`super::rim`]).
/// A light's position or a colour changes the shading smoothly there, and
/// for them the gradient render stays the derivative of the render's own
/// samples.
pub fn moves_hits(p: &ParamId) -> bool {
    match p.target {
        Target::Material(_, f) => f == MaterialField::Ior,
        t => match t.entity() {
            Entity::Sphere(_)
            | Entity::Ellipsoid(_)
            | Entity::Triangle(_)
            | Entity::Mesh(_)
            | Entity::Camera
            | Entity::Plane(_) => true,
            Entity::Light(_) | Entity::Render | Entity::Material(_) => false,
        },
    }
}

/// Whether parameter `p` is one of the camera's.
pub fn is_camera(p: &ParamId) -> bool {
    p.target.entity() == Entity::Camera
}
