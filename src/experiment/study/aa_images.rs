//! Study `aa_images`: image-space aliasing. Each run renders a scene with
//! one sampler and reconstruction filter and measures the image against a
//! converged reference of the same scene: MSE, relMSE, PSNR and ꟻLIP, the
//! camera rays actually spent per pixel (what the adaptive sampler decides)
//! and the render time, so one table gives error at equal samples and, with
//! the times, error at equal time.
//!
//! The reference is the box-filtered pixel average — the integral of the
//! image over each pixel's square — estimated with a high-count sampler
//! (`reference`, default `jitter:64`, 4096 stratified samples per pixel).
//! It is rendered once per (scene, resolution, reference sampler) and kept
//! as EXR in `references/` of the experiment's folder, so re-runs and other
//! samplers reuse it. A wider filter (tent, Mitchell) is judged against the
//! same box reference: what it trades is aliasing for blur, and both count
//! as error against the pixel's true average.

use super::render_cost::{config, Config, PARAMETERS as RENDER_PARAMETERS};
use super::{
    bool_param, seconds_cell, str_param, ParamDoc, ParamError, Row, RunContext, Study,
    StudySettings, Timings,
};
use crate::analysis::metrics::{compare, flip_error_map, write_flip_map};
use crate::experiment::sweep::RunPoint;
use crate::film::Filter;
use crate::integrator::{render, Whitted};
use crate::io::image::{read_image, write_image, LinearImage};
use crate::io::scene_file::load_scene;
use crate::sampler::Sampler;
use crate::stats::{NoStats, RayCounts};
use anyhow::Context;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The `aa_images` study.
pub struct AaImages;

/// The reference sampler when the manifest names none: 64×64 stratified.
const DEFAULT_REFERENCE: &str = "jitter:64";

const OWN_PARAMETERS: &[ParamDoc] = &[
    ParamDoc {
        name: "reference",
        doc: "sampler of the converged reference (default jitter:64; box filter)",
    },
    ParamDoc {
        name: "images",
        doc: "true: also write each run's image and ꟻLIP error map to images/",
    },
];

fn parameters() -> &'static [ParamDoc] {
    static ALL: OnceLock<Vec<ParamDoc>> = OnceLock::new();
    ALL.get_or_init(|| {
        RENDER_PARAMETERS
            .iter()
            .chain(OWN_PARAMETERS)
            .copied()
            .collect()
    })
}

struct AaConfig {
    render: Config,
    reference: Sampler,
    images: bool,
}

fn aa_config(run: &RunPoint, base_dir: &Path) -> Result<AaConfig, ParamError> {
    let render = config(run, base_dir)?;
    let reference = Sampler::parse(str_param(run, "reference")?.unwrap_or(DEFAULT_REFERENCE))
        .map_err(|e| ParamError::new("reference", e))?;
    if reference.is_adaptive() {
        return Err(ParamError::new(
            "reference",
            "the reference needs a fixed sample count, not the adaptive sampler",
        ));
    }
    let images = bool_param(run, "images")?.unwrap_or(false);
    Ok(AaConfig {
        render,
        reference,
        images,
    })
}

impl Study for AaImages {
    fn kind(&self) -> &'static str {
        "aa_images"
    }

    fn parameters(&self) -> &'static [ParamDoc] {
        parameters()
    }

    fn columns(&self, _settings: &StudySettings) -> Vec<String> {
        [
            "width",
            "height",
            "pixels",
            "sampler_name",
            "sampler_family",
            "sampler_series",
            "scene_name",
            "filter_name",
            "spp",
            "rays_per_pixel",
            "max_rays_per_pixel",
            "render_median_s",
            "render_cpu_median_s",
            "mse",
            "rel_mse",
            "psnr",
            "flip_mean",
            "reference_sampler",
            "reference_file",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect()
    }

    fn check(&self, run: &RunPoint, base_dir: &Path) -> Result<(), ParamError> {
        aa_config(run, base_dir).map(|_| ())
    }

    fn run(&self, run: &RunPoint, ctx: &RunContext<'_>) -> anyhow::Result<Row> {
        let cfg = aa_config(run, ctx.base_dir).map_err(ParamError::into_error)?;
        let scene = load_scene(&cfg.render.scene, &cfg.render.overrides)?;
        let (w, h) = (scene.camera.width, scene.camera.height);
        let reference_path = reference_file(ctx.out_dir, &cfg.render.scene, w, h, &cfg.reference);
        let reference = reference_image(&cfg, &reference_path)?;

        let timings = Timings::measure(ctx.settings.warmup, ctx.settings.repeats, || {
            render::<_, NoStats>(&scene, &Whitted, None)
        });
        let (film, RayCounts(counts)) = render::<_, RayCounts>(&scene, &Whitted, None);
        let image = film.image();
        let m = compare(&image, &reference)
            .with_context(|| format!("comparing with {}", reference_path.display()))?;
        let pixels = u64::from(w) * u64::from(h);
        let (_, max_rays) = film.samples_per_pixel();
        let settings = &scene.settings;
        if cfg.images {
            let stem = format!(
                "{}-{}x{h}-{}-{}",
                file_stem(&cfg.render.scene),
                w,
                settings.sampler.name(),
                settings.filter.name()
            );
            let dir = ctx.out_dir.join("images");
            std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
            write_image(&dir.join(format!("{stem}.png")), &image)?;
            let map = flip_error_map(&image, &reference)?;
            write_flip_map(&dir.join(format!("{stem}-flip.png")), &map)?;
        }
        Ok(vec![
            ("width".into(), w.to_string()),
            ("height".into(), h.to_string()),
            ("pixels".into(), pixels.to_string()),
            ("sampler_name".into(), settings.sampler.name()),
            ("sampler_family".into(), settings.sampler.family().into()),
            ("sampler_series".into(), sampler_series(&settings.sampler)),
            ("scene_name".into(), file_stem(&cfg.render.scene)),
            ("filter_name".into(), settings.filter.name().into()),
            ("spp".into(), settings.sampler.spp().to_string()),
            (
                "rays_per_pixel".into(),
                format!("{:.6}", counts.camera_rays as f64 / pixels as f64),
            ),
            ("max_rays_per_pixel".into(), max_rays.to_string()),
            ("render_median_s".into(), seconds_cell(timings.median())),
            (
                "render_cpu_median_s".into(),
                seconds_cell(timings.cpu_median()),
            ),
            ("mse".into(), format!("{:.6e}", m.mse)),
            ("rel_mse".into(), format!("{:.6e}", m.rel_mse)),
            ("psnr".into(), format!("{:.3}", m.psnr)),
            ("flip_mean".into(), format!("{:.6}", m.flip.mean)),
            ("reference_sampler".into(), cfg.reference.name()),
            (
                "reference_file".into(),
                reference_path.display().to_string(),
            ),
        ])
    }
}

/// The series a sampler belongs to in cost–quality plots: its family, with
/// the adaptive sampler split by depth (`adaptive d2`).
fn sampler_series(s: &Sampler) -> String {
    match s {
        Sampler::Adaptive { depth, .. } => format!("adaptive d{depth}"),
        other => other.family().into(),
    }
}

fn file_stem(path: &Path) -> String {
    path.file_stem()
        .map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned())
}

/// Where the reference of a scene at a resolution with a sampler lives.
fn reference_file(out_dir: &Path, scene: &Path, w: u32, h: u32, sampler: &Sampler) -> PathBuf {
    out_dir.join("references").join(format!(
        "{}-{w}x{h}-{}.exr",
        file_stem(scene),
        sampler.name()
    ))
}

/// Read the reference, or render and keep it when it is not there yet. It
/// is the run's scene with the reference sampler, the box filter and the
/// run's seed (other overrides as the run's, so the geometry matches).
fn reference_image(cfg: &AaConfig, path: &Path) -> anyhow::Result<LinearImage> {
    if path.is_file() {
        return Ok(read_image(path)?);
    }
    let mut overrides = cfg.render.overrides.clone();
    overrides.sampler = Some(cfg.reference);
    overrides.filter = Some(Filter::Box);
    let scene = load_scene(&cfg.render.scene, &overrides)?;
    let (film, _) = render::<_, NoStats>(&scene, &Whitted, None);
    let image = film.image();
    let dir = path.parent().expect("reference files live in a folder");
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    write_image(path, &image).with_context(|| format!("writing {}", path.display()))?;
    Ok(image)
}
