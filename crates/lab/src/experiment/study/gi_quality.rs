//! `kind = "gi_quality"`: how wrong and how noisy a global-illumination
//! render is for the time it takes (S4's comparison of direct light, n spp
//! × k bounces and the flood-fill cache on a Cornell box).
//!
//! One run renders `frames` independent frames (frame f uses seed
//! `seed + f`) with one integrator, after `warmup` untimed renders, timing
//! each frame with the [`NoStats`] sink; the time per frame is the median
//! over the frames (the frames are the timed repeats, so the manifest's
//! `repeats` is not used). One more render with [`Counters`] gives the rays
//! per pixel. Every frame is compared with a reference image (MSE, relMSE,
//! ꟻLIP mean; averaged over frames).
//!
//! **Clamping.** In linear HDR values the MSE of a Cornell box is ruled by
//! the light's edge pixels (17 against 0.7 depending on where a pixel's
//! sample lands): anti-aliasing noise that every integrator shares and that
//! hides the differences in indirect light. So, by default, frames and
//! reference are clamped to [0, 1] (the range a display shows, which is
//! also what ꟻLIP compares) before MSE, relMSE, bias and variance; `clamp`
//! changes the bound, `clamp = 0` measures raw values. `reference_variance`
//! and `pixel_variance` are of the unclamped values (an upper bound on the
//! clamped ones).
//!
//! **Bias and variance.** With I_f the frames, M their mean and R the
//! reference, per pixel and channel E[(I_f − R)²] = b² + v and
//! E[(M − R)²] = b² + v/F (independent frames), where b is the bias and v
//! the variance of one frame. Averaged over pixels, with m̄ the mean MSE of
//! the frames and m_M the MSE of their mean:
//!   v̂ = (m̄ − m_M)·F/(F − 1),  b̂² = m_M − v̂/F − v_ref,
//! where v_ref is the reference's own noise (the mean of its
//! `variance.*/count` channels when it has them, else 0). v_ref is known
//! for raw values only: with clamping (the default) it is not subtracted,
//! so b̂² includes the reference's noise, which is at most the
//! `reference_variance` column (a reference of N spp has about 1/N of a
//! 1-spp frame's variance). Clamping is itself biased at low sample
//! counts (E\[min(X, 1)\] < min(E\[X\], 1) where a pixel's samples straddle 1),
//! so even an unbiased integrator shows a b̂² that shrinks as spp grows;
//! this is the error a display shows, and `clamp = 0` removes it. Both
//! estimates
//! are unbiased, so b̂² can come out slightly negative for an unbiased
//! integrator; `bias2` reports it as is. `pixel_variance` is the film's own
//! estimate of v (each pixel's sample variance / spp, averaged over frames
//! and pixels; NaN at 1 spp): it matches v̂ for estimators with independent
//! samples, where clamping changes little.
//!
//! **Reference.** `reference` names a converged EXR or PNG; without it the
//! study renders one with `reference_integrator` (default `path:64`, with
//! Russian roulette after 3 bounces, so paths end long before 64 bounces)
//! at `reference_spp` samples per pixel (default 1024, uniform random),
//! seed 2⁶², and caches it in the output folder as
//! `reference-SCENE-WxH-INTEGRATOR-Nspp.exr`, reused by later runs.
//!
//! **Images.** Each run writes `gi-LABEL-grid.{png,svg}` into the output
//! folder (S4's Fig. 12 for one configuration): frame 0, the mean of the
//! frames, the reference and frame 0's ꟻLIP error map.

use super::{median, RunContext, Study};
use crate::analysis::metrics::{compare, flip_error_map, mse};
use crate::analysis::plot::{ImageGrid, Palette};
use crate::experiment::params::render::scene_file;
use crate::experiment::params::{
    existing_file, or_default, parsed_opt, typed_params, InRange, ParamDoc, Resolution,
    RunParamError,
};
use crate::experiment::row::{Fixed, Sci, Secs};
use crate::experiment::sweep::RunPoint;
use crate::Error;
use ndarray::Array3;
use raylab::accel::AccelKind;
use raylab::integrator::IntegratorKind;
use raylab::io::image::{read_exr_channels, read_image, LinearImage};
use raylab::io::scene_file::{load_scene, Overrides};
use raylab::io::InputError;
use raylab::math::srgb_decode;
use raylab::sampler::Sampler;
use raylab::scene::Scene;
use raylab::stats::{Counters, NoStats};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The `gi_quality` study.
#[derive(Clone, Copy, Debug, Default)]
pub struct GiQuality;

/// The parameters of a run.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GiQualityParams {
    /// Scene file, relative to the manifest's folder.
    pub scene: String,
    /// The integrator measured.
    #[serde(default, deserialize_with = "parsed_opt")]
    pub integrator: Option<IntegratorKind>,
    /// Samples per pixel, uniform random.
    #[serde(default)]
    pub spp: Option<InRange<1, 4096>>,
    /// Pixel sampler, instead of `spp`.
    #[serde(default, deserialize_with = "parsed_opt")]
    pub sampler: Option<Sampler>,
    /// Image size.
    #[serde(default, deserialize_with = "parsed_opt")]
    pub resolution: Option<Resolution>,
    /// Independent frames.
    #[serde(default)]
    pub frames: Option<InRange<2, 100_000>>,
    /// Seed of the first frame.
    #[serde(default)]
    pub seed: Option<InRange<0, { 1 << 40 }>>,
    /// Upper clamp of values before the error metrics (0: none).
    #[serde(default)]
    pub clamp: Option<f64>,
    /// Accelerator.
    #[serde(default, deserialize_with = "parsed_opt")]
    pub accel: Option<AccelKind>,
    /// A converged reference image, relative to the manifest's folder.
    #[serde(default)]
    pub reference: Option<String>,
    /// Samples per pixel of a generated reference.
    #[serde(default)]
    pub reference_spp: Option<InRange<1, { 1 << 20 }>>,
    /// Integrator of a generated reference.
    #[serde(default, deserialize_with = "parsed_opt")]
    pub reference_integrator: Option<IntegratorKind>,
}

typed_params!(
    GiQualityParams,
    [
        ParamDoc {
            name: "scene",
            doc: "scene file (TOML), relative to the manifest's folder; required",
        },
        ParamDoc {
            name: "integrator",
            doc: "`direct`, `path:K` or `whitted` (default `path:4`)",
        },
        ParamDoc {
            name: "spp",
            doc: "samples per pixel, uniform random (`random:N`); or give `sampler`",
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
            name: "frames",
            doc: "independent frames (seeds seed, seed+1, …), at least 2 (default 8)",
        },
        ParamDoc {
            name: "seed",
            doc: "seed of the first frame (default 0)",
        },
        ParamDoc {
            name: "clamp",
            doc: "errors are measured on values clamped to [0, clamp] (default 1: \
                  the displayed range; 0 = no clamping)",
        },
        ParamDoc {
            name: "accel",
            doc: "accelerator name (default: the scene's)",
        },
        ParamDoc {
            name: "reference",
            doc: "converged reference image (.exr/.png), relative to the manifest; \
                  default: rendered once and cached in the output folder",
        },
        ParamDoc {
            name: "reference_spp",
            doc: "samples per pixel of a generated reference (default 1024)",
        },
        ParamDoc {
            name: "reference_integrator",
            doc: "integrator of a generated reference (default `path:64`)",
        },
    ]
);

const DEFAULT_FRAMES: u32 = 8;
const DEFAULT_REFERENCE_SPP: u32 = 1024;
const DEFAULT_REFERENCE_INTEGRATOR: &str = "path:64";
/// The generated reference's seed: far from any frame's `seed + f`.
const REFERENCE_SEED: u64 = 1 << 62;

/// A run's parameters, checked.
pub struct GiQualityConfig {
    scene: PathBuf,
    integrator: IntegratorKind,
    overrides: Overrides,
    frames: u32,
    seed: u64,
    /// Upper clamp of values before the error metrics (`None`: none).
    clamp: Option<f32>,
    reference: ReferenceSource,
}

/// Where the reference image comes from.
enum ReferenceSource {
    File(PathBuf),
    Generate {
        integrator: IntegratorKind,
        spp: u32,
    },
}

/// One row: an integrator's time and error against the reference.
#[derive(Clone, Debug, Default, Serialize)]
pub struct GiQualityRow {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Samples per pixel.
    pub spp: u32,
    /// Frames rendered.
    pub frames: usize,
    /// Worker threads rendering.
    pub threads: usize,
    /// Median time per frame.
    pub time_per_frame_s: Secs,
    /// Preparing the integrator (the flood-fill cache).
    pub setup_s: Secs,
    /// Shortest frame.
    pub time_min_s: Secs,
    /// Longest frame.
    pub time_max_s: Secs,
    /// Mean MSE of the frames.
    pub mse: Sci<6>,
    /// Mean relative MSE.
    pub rel_mse: Sci<6>,
    /// Mean ꟻLIP error.
    pub flip: Fixed<6>,
    /// MSE of the frames' mean.
    pub mse_of_mean: Sci<6>,
    /// Estimated squared bias.
    pub bias2: Sci<6>,
    /// Estimated variance of one frame.
    pub variance: Sci<6>,
    /// The film's own variance estimate.
    pub pixel_variance: Sci<6>,
    /// The reference's own noise.
    pub reference_variance: Sci<6>,
    /// Rays per pixel.
    pub rays_per_pixel: Fixed<4>,
    /// Path rays per pixel.
    pub path_rays_per_pixel: Fixed<4>,
    /// Shadow rays per pixel.
    pub shadow_rays_per_pixel: Fixed<4>,
    /// The reference image.
    pub reference: String,
}

/// A run's reference image.
struct ReferenceImage {
    /// Its file.
    path: PathBuf,
    /// The image.
    image: LinearImage,
    /// The mean variance of its pixel values (0 when unknown).
    variance: f64,
}

/// The reference image, read or rendered.
fn reference_image(
    cfg: &GiQualityConfig,
    scene: &Scene,
    out_dir: &Path,
) -> Result<ReferenceImage, Error> {
    let path = match &cfg.reference {
        ReferenceSource::File(p) => p.clone(),
        ReferenceSource::Generate { integrator, spp } => {
            let stem = cfg
                .scene
                .file_stem()
                .map_or("scene".into(), |s| s.to_string_lossy().into_owned());
            let name = format!(
                "reference-{stem}-{}x{}-{}-{spp}spp.exr",
                scene.camera.width,
                scene.camera.height,
                integrator.name().replace(':', "")
            );
            let path = out_dir.join(name);
            if !path.is_file() {
                let mut s = scene.clone();
                s.settings.sampler = Sampler::Random { n: *spp };
                s.settings.seed = REFERENCE_SEED;
                let (film, _) = integrator
                    .render::<NoStats>(&s, None)
                    .map_err(Error::Render)?;
                raylab::io::image::write_film_exr(&path, &film, &film.image())?;
            }
            path
        }
    };
    let image = read_image(&path)?;
    let variance = reference_variance(&path);
    Ok(ReferenceImage {
        path,
        image,
        variance,
    })
}

/// Mean over pixels and channels of variance/count, from an EXR written by
/// [`raylab::io::image::write_film_exr`]; 0 for other images.
fn reference_variance(path: &Path) -> f64 {
    let Ok(exr) = read_exr_channels(path) else {
        return 0.0;
    };
    let Some(count) = exr.get("count") else {
        return 0.0;
    };
    let mut sum = 0.0f64;
    let mut n = 0usize;
    for ch in ["variance.R", "variance.G", "variance.B"] {
        let Some(var) = exr.get(ch) else {
            return 0.0;
        };
        for (v, c) in var.iter().zip(count) {
            sum += f64::from(*v) / f64::from(c.max(1.0));
            n += 1;
        }
    }
    if n == 0 {
        0.0
    } else {
        sum / n as f64
    }
}

/// A ꟻLIP error map as a magma-coloured linear image (for image grids).
fn coloured_map(map: &ndarray::Array2<f32>) -> LinearImage {
    let (h, w) = map.dim();
    Array3::from_shape_fn((h, w, 3), |(y, x, c)| {
        let rgb = Palette::Magma.colour(f64::from(map[[y, x]]));
        srgb_decode(f32::from(rgb[c]) / 255.0)
    })
}

impl Study for GiQuality {
    type Params = GiQualityParams;
    type Config = GiQualityConfig;
    type Row = GiQualityRow;

    fn configure(
        &self,
        p: GiQualityParams,
        base_dir: &Path,
    ) -> Result<GiQualityConfig, RunParamError> {
        let scene = scene_file(base_dir, &p.scene)?;
        let integrator = or_default(p.integrator, "integrator", "path:4")?;
        let sampler = match (p.sampler, p.spp) {
            (Some(_), Some(_)) => {
                return Err(RunParamError::new(
                    "spp",
                    "give `spp` or `sampler`, not both",
                ));
            }
            (Some(s), None) => Some(s),
            (None, Some(n)) => Some(Sampler::Random { n: n.get() as u32 }),
            (None, None) => None,
        };
        // 0 measures raw values.
        let clamp = match p.clamp {
            None => Some(1.0),
            Some(c) if c < 0.0 => {
                return Err(RunParamError::new(
                    "clamp",
                    format!("must be a number of at least 0, got {c}"),
                ))
            }
            Some(0.0) => None,
            Some(c) => Some(c as f32),
        };
        let reference = match &p.reference {
            Some(r) => ReferenceSource::File(existing_file(base_dir, "reference", r, "image")?),
            None => ReferenceSource::Generate {
                integrator: or_default(
                    p.reference_integrator,
                    "reference_integrator",
                    DEFAULT_REFERENCE_INTEGRATOR,
                )?,
                spp: p
                    .reference_spp
                    .map_or(DEFAULT_REFERENCE_SPP, |n| n.get() as u32),
            },
        };
        Ok(GiQualityConfig {
            scene,
            integrator,
            overrides: Overrides {
                width: p.resolution.map(|r| r.width),
                height: p.resolution.map(|r| r.height),
                sampler,
                filter: None,
                accel: p.accel,
                max_depth: None,
                seed: None,
            },
            frames: p.frames.map_or(DEFAULT_FRAMES, |f| f.get() as u32),
            seed: p.seed.map_or(0, |s| s.get() as u64),
            clamp,
            reference,
        })
    }

    fn run(
        &self,
        cfg: GiQualityConfig,
        _run: &RunPoint,
        ctx: &RunContext<'_>,
    ) -> Result<GiQualityRow, Error> {
        let mut scene = load_scene(&cfg.scene, &cfg.overrides)?;
        let clamped = |img: LinearImage| match cfg.clamp {
            Some(hi) => img.mapv(|v| v.clamp(0.0, hi)),
            None => img,
        };
        let ReferenceImage {
            path: ref_path,
            image: reference,
            variance: ref_var,
        } = reference_image(&cfg, &scene, ctx.out_dir)?;
        let reference = clamped(reference);
        let (w, h) = (scene.camera.width, scene.camera.height);
        if reference.dim() != (h as usize, w as usize, 3) {
            return Err(InputError::file(
                &ref_path,
                format!(
                    "reference is {}×{}, the renders are {w}×{h}",
                    reference.dim().1,
                    reference.dim().0
                ),
            )
            .into());
        }

        // Flood fill builds and warms its cache once, before the frames
        // (reported as `setup_s`); each frame then runs its propagation
        // steps and the render.
        let setup = Instant::now();
        let mut prepared = cfg.integrator.prepare(&scene).map_err(Error::Render)?;
        let setup_s = setup.elapsed().as_secs_f64();
        for _ in 0..ctx.settings.warmup {
            scene.settings.seed = cfg.seed;
            std::hint::black_box(
                prepared
                    .frame::<NoStats>(&scene, None)
                    .map_err(Error::Render)?,
            );
        }
        let frames = cfg.frames as usize;
        let mut times = Vec::with_capacity(frames);
        let (mut sum_mse, mut sum_rel, mut sum_flip, mut sum_pixvar) = (0.0, 0.0, 0.0, 0.0);
        let mut mean_img = LinearImage::zeros(reference.dim());
        let mut first: Option<(LinearImage, ndarray::Array2<f32>)> = None;
        for f in 0..frames {
            scene.settings.seed = cfg.seed + f as u64;
            // Timed as `Timings::measure` does: the render alone.
            let start = Instant::now();
            let (film, _) = prepared
                .frame::<NoStats>(&scene, None)
                .map_err(Error::Render)?;
            times.push(start.elapsed().as_secs_f64());
            let img = clamped(film.image());
            let m = compare(&img, &reference)?;
            sum_mse += m.mse;
            sum_rel += m.rel_mse;
            sum_flip += m.flip.mean;
            sum_pixvar += if scene.settings.sampler.spp() >= 2 {
                film.mean_variance_of_mean()
            } else {
                f64::NAN // one sample has no sample variance
            };
            mean_img += &img;
            if first.is_none() {
                let map = flip_error_map(&img, &reference)?;
                first = Some((img, map));
            }
        }
        let nf = frames as f64;
        mean_img /= frames as f32;
        let mse_frames = sum_mse / nf;
        let mse_of_mean = mse(&mean_img, &reference);
        let variance = (mse_frames - mse_of_mean) * nf / (nf - 1.0);
        // The reference's own noise adds to E[(M − R)²]; its variance is
        // known for raw values only (see the module docs).
        let ref_noise = if cfg.clamp.is_none() { ref_var } else { 0.0 };
        let bias2 = mse_of_mean - variance / nf - ref_noise;

        scene.settings.seed = cfg.seed;
        let (_, counters) = prepared
            .frame::<Counters>(&scene, None)
            .map_err(Error::Render)?;
        let pixels = f64::from(w) * f64::from(h);

        if let Some((frame, map)) = first {
            let label = format!(
                "gi-{}-{}-{w}x{h}",
                cfg.integrator.name().replace(':', ""),
                scene.settings.sampler.name()
            );
            let mut grid = ImageGrid::new(
                format!(
                    "{} · {} spp · {w}×{h}",
                    cfg.integrator,
                    scene.settings.sampler.spp()
                ),
                4,
            );
            grid.cells = vec![
                (frame, "one frame".into()),
                (mean_img, format!("mean of {frames} frames")),
                (reference.clone(), "reference".into()),
                (coloured_map(&map), "ꟻLIP error, one frame".into()),
            ];
            grid.save(&ctx.out_dir.join(format!("{label}-grid")))?;
        }

        let spp = scene.settings.sampler.spp();
        // The reference column is relative to the output folder when it
        // lies there (a generated one), so data.csv does not name the
        // machine's paths.
        let ref_cell = ref_path
            .strip_prefix(ctx.out_dir)
            .unwrap_or(&ref_path)
            .display()
            .to_string();
        let times_sorted = {
            let mut t = times.clone();
            t.sort_by(f64::total_cmp);
            t
        };
        let per_pixel = |n: u64| Fixed(n as f64 / pixels);
        Ok(GiQualityRow {
            width: w,
            height: h,
            spp,
            frames,
            threads: rayon::current_num_threads(),
            time_per_frame_s: Secs(median(&times)),
            setup_s: Secs(setup_s),
            time_min_s: Secs(times_sorted[0]),
            time_max_s: Secs(times_sorted[frames - 1]),
            mse: Sci(mse_frames),
            rel_mse: Sci(sum_rel / nf),
            flip: Fixed(sum_flip / nf),
            mse_of_mean: Sci(mse_of_mean),
            bias2: Sci(bias2),
            variance: Sci(variance),
            pixel_variance: Sci(sum_pixvar / nf),
            reference_variance: Sci(ref_var),
            rays_per_pixel: per_pixel(counters.rays()),
            path_rays_per_pixel: per_pixel(counters.path_rays),
            shadow_rays_per_pixel: per_pixel(counters.shadow_rays),
            reference: ref_cell,
        })
    }
}
