//! The parameters of rendering a scene file, shared by the studies that
//! render one (`render_cost`, `aa_images`): the scene, and the overrides
//! of its sampler, accelerator, image size, depth, seed and filter, as
//! `raylab render` takes them.

use super::{
    existing_file, parsed_opt, typed_params, InRange, ParamDoc, Resolution, RunParamError,
};
use raylab::accel::AccelKind;
use raylab::film::Filter;
use raylab::io::scene_file::Overrides;
use raylab::sampler::Sampler;
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// The largest image side, as a bound of [`InRange`].
const SIDE: i64 = super::MAX_SIDE as i64;

/// The parameters of rendering a scene file, as the manifest writes them.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RenderParams {
    /// Scene file, relative to the manifest's folder.
    pub scene: String,
    /// Pixel sampler (default: the scene's).
    #[serde(default, deserialize_with = "parsed_opt")]
    pub sampler: Option<Sampler>,
    /// Accelerator (default: the scene's).
    #[serde(default, deserialize_with = "parsed_opt")]
    pub accel: Option<AccelKind>,
    /// Image size "WxH" (default: the scene's).
    #[serde(default, deserialize_with = "parsed_opt")]
    pub resolution: Option<Resolution>,
    /// Image width, instead of `resolution`.
    #[serde(default)]
    pub width: Option<InRange<1, SIDE>>,
    /// Image height, instead of `resolution`.
    #[serde(default)]
    pub height: Option<InRange<1, SIDE>>,
    /// Maximum recursion depth (default: the scene's).
    #[serde(default)]
    pub max_depth: Option<InRange<0, 1000>>,
    /// Seed of randomised samplers and integrators (default: the scene's).
    #[serde(default)]
    pub seed: Option<u64>,
    /// Reconstruction filter (default: the scene's).
    #[serde(default, deserialize_with = "parsed_opt")]
    pub filter: Option<Filter>,
}

/// The documentation of [`RenderParams`], one entry per field.
pub const RENDER_DOCS: &[ParamDoc] = &[
    ParamDoc {
        name: "scene",
        doc: "scene file (TOML), relative to the manifest's folder; required",
    },
    ParamDoc {
        name: "sampler",
        doc: "`centre` or `ogss:K` (default: the scene's)",
    },
    ParamDoc {
        name: "accel",
        doc: "accelerator name, as `raylab render --accel` (default: the scene's)",
    },
    ParamDoc {
        name: "resolution",
        doc: "image size as \"WxH\", e.g. \"800x600\" (default: the scene's)",
    },
    ParamDoc {
        name: "width",
        doc: "image width in pixels (instead of `resolution`)",
    },
    ParamDoc {
        name: "height",
        doc: "image height in pixels (instead of `resolution`)",
    },
    ParamDoc {
        name: "max_depth",
        doc: "maximum recursion depth (default: the scene's)",
    },
    ParamDoc {
        name: "seed",
        doc: "seed for randomised samplers and integrators (default: the scene's)",
    },
    ParamDoc {
        name: "filter",
        doc: "reconstruction filter: box, tent or mitchell (default: the scene's)",
    },
];

typed_params!(RenderParams, RENDER_DOCS);

/// A scene to render: the file and what the run changes in it.
#[derive(Clone, Debug)]
pub struct RenderConfig {
    /// The scene file (resolved against the manifest's folder).
    pub scene: PathBuf,
    /// The run's overrides of the scene's settings.
    pub overrides: Overrides,
}

/// The `scene` parameter: a scene file relative to the manifest's folder,
/// checked to exist.
pub fn scene_file(base_dir: &Path, rel: &str) -> Result<PathBuf, RunParamError> {
    existing_file(base_dir, "scene", rel, "scene")
}

impl RenderParams {
    /// Check the parameters together and resolve the scene file.
    pub fn config(&self, base_dir: &Path) -> Result<RenderConfig, RunParamError> {
        let scene = scene_file(base_dir, &self.scene)?;
        let side = |v: Option<InRange<1, SIDE>>| v.map(|v| v.get() as u32);
        let (mut width, mut height) = (side(self.width), side(self.height));
        if let Some(r) = self.resolution {
            if width.is_some() || height.is_some() {
                return Err(RunParamError::new(
                    "resolution",
                    "give `resolution` or `width`/`height`, not both",
                ));
            }
            (width, height) = (Some(r.width), Some(r.height));
        }
        Ok(RenderConfig {
            scene,
            overrides: Overrides {
                width,
                height,
                sampler: self.sampler,
                filter: self.filter,
                accel: self.accel,
                max_depth: self.max_depth.map(|d| d.get() as u32),
                seed: self.seed,
            },
        })
    }
}
