//! The boundary term (`raylab::diff::boundary`, `--visibility full`)
//! against the closed form of a disc's pixel coverage, against central
//! differences of converged renders at silhouettes and shadow edges, and
//! against itself on different thread counts.
//!
//! Tolerances. Each pixel's estimate is a mean of independent samples
//! (the pixel's own, and the curve samples that land in it), so
//! |estimate − truth| ≤ 4 standard errors should hold for all but about
//! 6·10⁻⁵ of the pixels if the estimated errors were exact; they are
//! estimated from the same samples, and a pixel that a curve crosses only
//! at a corner may get no sample at all (estimate 0, error estimate 0),
//! so the checks ask for 99 % of pixels, the criterion. The
//! closed forms are exact; the central differences are taken with 64×
//! the samples of the derivative render and a step that moves edges by
//! about 0.1 pixel, so their own error is small beside its standard
//! errors (a further 10⁻³ of the mean |FD| is allowed for it). Where a
//! step that short still moves edges into neighbouring pixels, the
//! derivative is averaged over the step's interval instead, which the
//! central difference equals exactly (`averaged_checks`).

mod closed_form;
mod effects;
mod reference;
mod s1;

use raylab::diff::{self, GradientRender, Gradients, Renderer, Visibility};
use raylab::integrator::IntegratorKind;
use raylab::io::scene_file::{Overrides, SceneSource};
use raylab::math::SplitMix64;
use raylab::sampler::Sampler;
use raylab::scene::description::SceneDescription;
use raylab::scene::param::ParamId;
use raylab::scene::Scene;
use std::path::Path;

pub(crate) fn load(text: &str, sampler: &str) -> (Scene, SceneSource) {
    let overrides = Overrides {
        sampler: Some(Sampler::parse(sampler).unwrap()),
        ..Overrides::default()
    };
    let source = SceneSource::parse(text, Path::new("test.toml"), &overrides).unwrap();
    (source.build().unwrap(), source)
}

pub(crate) fn params(names: &[&str], desc: &SceneDescription) -> Vec<ParamId> {
    let names: Vec<String> = names.iter().map(|s| s.to_string()).collect();
    diff::resolve_all(&names, desc).unwrap()
}

/// The derivatives of `scene` (described by `desc`) for `p`.
pub(crate) fn gradients(
    scene: &Scene,
    desc: &SceneDescription,
    p: &[ParamId],
    integrator: IntegratorKind,
    visibility: Visibility,
) -> Gradients {
    diff::render_gradients(&GradientRender {
        scene,
        desc,
        params: p,
        integrator,
        visibility,
        threads: None,
    })
    .unwrap()
}

/// The renders of the finite differences.
pub(crate) fn renderer(integrator: IntegratorKind) -> Renderer {
    Renderer {
        integrator,
        threads: None,
    }
}
