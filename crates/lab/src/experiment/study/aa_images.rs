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
//!
//! Where the error sits in frequency tells aliasing from noise and blur:
//! each run takes the power spectrum of its luminance error image (test −
//! reference, via [`crate::analysis::spectrum::power_spectrum`]) and its
//! radial profile, writes the profile to `spectra/` and reports the mean
//! error power below and above a quarter cycle per pixel. Aliasing folds
//! high image frequencies down to low ones (false rings, moiré): low-band
//! error; white noise spreads evenly; a blurring filter's error sits where
//! the image has detail. After the sweep the study overlays the profiles of
//! the runs that share a sweep, scene and sample count
//! (`aa-error-spectrum-…`).

use super::{RunContext, Study, Timings};
use crate::analysis::metrics::{compare, flip_error_map, write_flip_map};
use crate::analysis::plot::{AxisScale, Heatmap, LineChart, Palette, Series, SeriesStyle};
use crate::analysis::spectrum::{power_spectrum, radial_profile};
use crate::experiment::data::Table;
use crate::experiment::params::render::{RenderConfig, RenderParams};
use crate::experiment::params::{or_default, parsed_opt, typed_params, ParamDoc, RunParamError};
use crate::experiment::row::{Fixed, Sci, Secs};
use crate::experiment::sweep::RunPoint;
use crate::{Error, FileOp};
use ndarray::Array2;
use raylab::film::Filter;
use raylab::integrator::{render, Whitted};
use raylab::io::image::{read_image, write_image, LinearImage};
use raylab::io::scene_file::load_scene;
use raylab::io::InputError;
use raylab::math::{luminance, Color};
use raylab::sampler::Sampler;
use raylab::stats::{NoStats, RayCounts};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The `aa_images` study.
pub struct AaImages;

/// The reference sampler when the manifest names none: 64×64 stratified.
const DEFAULT_REFERENCE: &str = "jitter:64";

/// The study's own parameters, beside those of [`RenderParams`].
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AaParams {
    /// Sampler of the converged reference.
    #[serde(default, deserialize_with = "parsed_opt")]
    pub reference: Option<Sampler>,
    /// Also write each run's image and error map.
    #[serde(default)]
    pub images: bool,
}

typed_params!(
    AaParams,
    [
        ParamDoc {
            name: "reference",
            doc: "sampler of the converged reference (default jitter:64; box filter)",
        },
        ParamDoc {
            name: "images",
            doc: "true: also write each run's image and ꟻLIP error map to images/",
        },
    ]
);

/// A run's parameters, checked.
pub struct AaConfig {
    render: RenderConfig,
    reference: Sampler,
    images: bool,
}

/// One row: a render's error against the reference, and its cost.
#[derive(Clone, Debug, Default, Serialize)]
pub struct AaImagesRow {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Pixels of the image.
    pub pixels: u64,
    /// The sampler's short name (`ogss4`).
    pub sampler_name: String,
    /// Its family (`ogss`, `jitter`, …).
    pub sampler_family: String,
    /// Its series in cost–quality plots (`adaptive d2`).
    pub sampler_series: String,
    /// The scene file's stem.
    pub scene_name: String,
    /// The reconstruction filter.
    pub filter_name: String,
    /// Nominal samples per pixel.
    pub spp: u32,
    /// Camera rays traced per pixel.
    pub rays_per_pixel: Fixed<6>,
    /// Most camera rays any pixel got.
    pub max_rays_per_pixel: u32,
    /// Median of the timed renders.
    pub render_median_s: Secs,
    /// Median process CPU time of the timed renders.
    pub render_cpu_median_s: Secs,
    /// Mean squared error against the reference.
    pub mse: Sci<6>,
    /// Relative MSE.
    pub rel_mse: Sci<6>,
    /// Peak signal-to-noise ratio, dB.
    pub psnr: Fixed<3>,
    /// Mean ꟻLIP error.
    pub flip_mean: Fixed<6>,
    /// Mean error power below a quarter cycle per pixel.
    pub error_power_low: Sci<6>,
    /// Mean error power above it.
    pub error_power_high: Sci<6>,
    /// The error's radial spectrum, relative to the output folder.
    pub error_spectrum_csv: String,
    /// The reference's sampler.
    pub reference_sampler: String,
    /// The reference image.
    pub reference_file: String,
}

impl Study for AaImages {
    type Params = (RenderParams, AaParams);
    type Config = AaConfig;
    type Row = AaImagesRow;

    fn configure(
        &self,
        (render, own): (RenderParams, AaParams),
        base_dir: &Path,
    ) -> Result<AaConfig, RunParamError> {
        let render = render.config(base_dir)?;
        let reference = or_default(own.reference, "reference", DEFAULT_REFERENCE)?;
        if reference.is_adaptive() {
            return Err(RunParamError::new(
                "reference",
                "the reference needs a fixed sample count, not the adaptive sampler",
            ));
        }
        Ok(AaConfig {
            render,
            reference,
            images: own.images,
        })
    }

    /// Overlay the error spectra of the runs that share a sweep, a scene
    /// and a nominal sample count (adaptive runs, whose counts differ per
    /// pixel, are left to the cost–quality figures).
    fn figures(&self, table: &Table, out_dir: &Path) -> Result<Vec<String>, Error> {
        let col = |name: &str| {
            table.column(name).ok_or_else(|| Error::MissingColumn {
                column: name.to_string(),
            })
        };
        let (sweep, scene, spp, sampler, filter, family, csv) = (
            col("sweep")?,
            col("scene_name")?,
            col("spp")?,
            col("sampler_name")?,
            col("filter_name")?,
            col("sampler_family")?,
            col("error_spectrum_csv")?,
        );
        let mut groups: BTreeMap<(String, String, u32), Vec<&Vec<String>>> = BTreeMap::new();
        for row in &table.rows {
            if row[family] == "adaptive" {
                continue;
            }
            let n: u32 = row[spp].parse().unwrap_or(0);
            groups
                .entry((row[sweep].clone(), row[scene].clone(), n))
                .or_default()
                .push(row);
        }
        let mut written = Vec::new();
        for ((sweep_name, scene_name, n), rows) in groups {
            if rows.len() < 2 {
                continue;
            }
            let mut chart = LineChart::new(
                format!("{scene_name}: error spectrum at {n} samples per pixel ({sweep_name})"),
                "frequency (cycles per pixel; Nyquist 0.5)".to_string(),
                "radial mean of |DFT(luminance error)|² / pixels".to_string(),
            );
            chart.y_scale = AxisScale::Log10;
            for row in rows {
                let label = match row[filter].as_str() {
                    "box" => row[sampler].clone(),
                    f => format!("{} + {f}", row[sampler]),
                };
                let profile = read_profile(&out_dir.join(&row[csv]))?;
                chart
                    .series
                    .push(Series::new(label, profile, SeriesStyle::Line));
            }
            let stem = format!("aa-error-spectrum-{sweep_name}-{scene_name}-{n}spp");
            chart.save(&out_dir.join(&stem))?;
            written.push(stem);
        }
        Ok(written)
    }

    fn run(
        &self,
        cfg: AaConfig,
        _run: &RunPoint,
        ctx: &RunContext<'_>,
    ) -> Result<AaImagesRow, Error> {
        let scene = load_scene(&cfg.render.scene, &cfg.render.overrides)?;
        let (w, h) = (scene.camera.width, scene.camera.height);
        let reference_path = reference_file(ctx.out_dir, &cfg.render.scene, w, h, &cfg.reference);
        let reference = reference_image(&cfg, &reference_path)?;

        let timings = Timings::measure(ctx.settings.warmup, ctx.settings.repeats, || {
            render::<_, NoStats>(&scene, &Whitted, None)
        });
        let (film, RayCounts(counts)) = render::<_, RayCounts>(&scene, &Whitted, None);
        let image = film.image();
        let m = compare(&image, &reference).map_err(|error| Error::Compare {
            test: None,
            reference: reference_path.clone(),
            error,
        })?;
        let pixels = u64::from(w) * u64::from(h);
        let (_, max_rays) = film.samples_per_pixel();
        let settings = &scene.settings;
        let stem = format!(
            "{}-{}x{h}-{}-{}",
            file_stem(&cfg.render.scene),
            w,
            settings.sampler.name(),
            settings.filter.name()
        );
        let spectrum = power_spectrum(&luminance_error(&image, &reference));
        let profile = radial_profile(&spectrum);
        let band_mean = |keep: &dyn Fn(f64) -> bool| {
            let v: Vec<f64> = profile.iter().filter(|p| keep(p.0)).map(|p| p.1).collect();
            v.iter().sum::<f64>() / v.len().max(1) as f64
        };
        let (low, high) = (band_mean(&|f| f < SPLIT), band_mean(&|f| f >= SPLIT));
        let spectrum_csv = format!("spectra/{stem}-error-radial.csv");
        write_profile(&ctx.out_dir.join(&spectrum_csv), &profile)?;
        if cfg.images {
            let dir = ctx.out_dir.join("images");
            std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, FileOp::CreateFolder, e))?;
            write_image(&dir.join(format!("{stem}.png")), &image)?;
            let map = flip_error_map(&image, &reference)?;
            write_flip_map(&dir.join(format!("{stem}-flip.png")), &map)?;
            let mut heat = Heatmap::new(
                format!("{stem}: power spectrum of the luminance error"),
                spectrum,
            );
            heat.log_scale = true;
            heat.palette = Palette::Magma;
            heat.value_label = "|DFT(error)|² / pixels".into();
            heat.x_label = "horizontal frequency (cycles per pixel, DC at the centre)".into();
            heat.y_label = "vertical frequency".into();
            heat.extent = Some([-0.5, 0.5, -0.5, 0.5]);
            heat.save(&dir.join(format!("{stem}-error-spectrum")))?;
        }
        Ok(AaImagesRow {
            width: w,
            height: h,
            pixels,
            sampler_name: settings.sampler.name(),
            sampler_family: settings.sampler.family().into(),
            sampler_series: sampler_series(&settings.sampler),
            scene_name: file_stem(&cfg.render.scene),
            filter_name: settings.filter.name().into(),
            spp: settings.sampler.spp(),
            rays_per_pixel: Fixed(counts.camera_rays as f64 / pixels as f64),
            max_rays_per_pixel: max_rays,
            render_median_s: Secs(timings.median()),
            render_cpu_median_s: Secs(timings.cpu_median()),
            mse: Sci(m.mse),
            rel_mse: Sci(m.rel_mse),
            psnr: Fixed(m.psnr),
            flip_mean: Fixed(m.flip.mean),
            error_power_low: Sci(low),
            error_power_high: Sci(high),
            error_spectrum_csv: spectrum_csv,
            reference_sampler: cfg.reference.name(),
            reference_file: reference_path.display().to_string(),
        })
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

/// Rings below this many cycles per pixel are the low band (where aliased
/// energy lands), the rest the high band; Nyquist is 0.5.
const SPLIT: f64 = 0.25;

/// Luminance of `test` − `reference`, per pixel.
fn luminance_error(test: &LinearImage, reference: &LinearImage) -> Array2<f64> {
    let (h, w, _) = test.dim();
    let lum = |img: &LinearImage, y: usize, x: usize| {
        f64::from(luminance(Color::new(
            img[[y, x, 0]],
            img[[y, x, 1]],
            img[[y, x, 2]],
        )))
    };
    Array2::from_shape_fn((h, w), |(y, x)| lum(test, y, x) - lum(reference, y, x))
}

/// Write a radial profile as CSV: `cycles_per_pixel,power`.
fn write_profile(path: &Path, profile: &[(f64, f64)]) -> Result<(), Error> {
    let dir = path.parent().expect("profiles live in a folder");
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, FileOp::CreateFolder, e))?;
    let mut text = String::from("cycles_per_pixel,power\n");
    for (f, p) in profile {
        text.push_str(&format!("{f:.6},{p:.6e}\n"));
    }
    std::fs::write(path, text).map_err(|e| Error::io(path, FileOp::Write, e))
}

/// Read a profile written by [`write_profile`].
fn read_profile(path: &Path) -> Result<Vec<(f64, f64)>, Error> {
    let text = raylab::io::input::read_to_string(path, raylab::io::input::InputKind::Table)?;
    text.lines()
        .enumerate()
        .skip(1)
        .map(|(i, line)| {
            let parse = |v: Option<&str>| v.and_then(|v| v.trim().parse::<f64>().ok());
            let mut cells = line.split(',');
            match (parse(cells.next()), parse(cells.next())) {
                (Some(f), Some(p)) => Ok((f, p)),
                _ => Err(InputError::line(
                    path,
                    i + 1,
                    format!("expected `cycles_per_pixel,power`, got `{line}`"),
                )
                .into()),
            }
        })
        .collect()
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
fn reference_image(cfg: &AaConfig, path: &Path) -> Result<LinearImage, Error> {
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
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, FileOp::CreateFolder, e))?;
    write_image(path, &image).map_err(|e| Error::writing(path, e))?;
    Ok(image)
}
