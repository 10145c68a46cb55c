//! The `raylab render` report: render a scene file to an image, time it,
//! and say what it cost. [`RenderReport::run`] does the work (load the
//! scene, prepare the integrator, render one frame, compare with a
//! reference, write the image and the samples-per-pixel map) and returns
//! the numbers; its [`Display`](std::fmt::Display) is the text the command
//! prints. Part of the top-layer [`crate::report`].

use crate::analysis::plot::Heatmap;
use crate::analysis::{compare, ImageMetrics};
use crate::Error;
use raylab::accel::AccelKind;
use raylab::film::memory::Bytes;
use raylab::film::Filter;
use raylab::integrator::{IntegratorKind, Prepared};
use raylab::io::image::{read_image, write_image, ImageFormat};
use raylab::io::scene_file::{Overrides, SceneSource};
use raylab::sampler::Sampler;
use raylab::scene::param::Setting;
use raylab::stats::{Counters, RayCounts};
use std::fmt;
use std::path::PathBuf;
use std::time::Instant;

/// What `raylab render` was asked to do.
#[derive(Clone, Debug)]
pub struct RenderOptions {
    /// The scene file (TOML).
    pub scene: PathBuf,
    /// The output image; its extension chooses the format (.png or .exr).
    pub output: PathBuf,
    /// Settings that override the scene file's (size, sampler, filter,
    /// accelerator, depth, seed).
    pub overrides: Overrides,
    /// Scene parameters set to new values (`--set PATH=VALUE`), in order.
    pub settings: Vec<Setting>,
    /// The integrator, with its options already applied.
    pub integrator: IntegratorKind,
    /// A reference image to report MSE, relMSE and ꟻLIP against.
    pub reference: Option<PathBuf>,
    /// Where to write each pixel's sample count as a heatmap PNG (+ SVG).
    pub spp_map: Option<PathBuf>,
    /// Render threads; `None` means all cores.
    pub threads: Option<usize>,
    /// Show a progress bar on a terminal ([`super::progress`]).
    pub progress: bool,
    /// Where to render: the CPU, or the GPU port ([`raylab_gpu`]).
    pub device: Device,
}

/// Where a render runs (`--device cpu|gpu`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Device {
    #[default]
    Cpu,
    /// The WGSL port of the Whitted integrator (the `gpu` feature).
    Gpu,
}

/// A device name that is neither `cpu` nor `gpu`.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown device `{0}` (expected `cpu` or `gpu`)")]
pub struct UnknownDevice(pub String);

impl Device {
    /// Parse `cpu` or `gpu`.
    pub fn parse(s: &str) -> Result<Self, UnknownDevice> {
        match s {
            "cpu" => Ok(Device::Cpu),
            "gpu" => Ok(Device::Gpu),
            _ => Err(UnknownDevice(s.to_string())),
        }
    }
}

/// A render on the GPU: the adapter that made it and the render.
#[cfg(feature = "gpu")]
pub struct GpuRun {
    /// The adapter's description ([`raylab_gpu::Gpu::describe`]).
    pub adapter: String,
    /// The render, with its counters when asked for.
    pub render: raylab_gpu::GpuRender,
}

/// Render `scene` on the GPU, with counters when `counters` is set: the
/// adapter's description and the render. The GPU port is Whitted's
/// integrator only.
#[cfg(feature = "gpu")]
pub fn gpu_render(
    scene: &raylab::scene::Scene,
    integrator: &IntegratorKind,
    counters: bool,
) -> Result<GpuRun, Error> {
    if *integrator != IntegratorKind::Whitted {
        return Err(Error::Argument(format!(
            "the GPU port renders the Whitted integrator only; `{}` runs with --device cpu",
            integrator.name()
        )));
    }
    let gpu = raylab_gpu::Gpu::new()?;
    let render = gpu.render(scene, counters)?;
    Ok(GpuRun {
        adapter: gpu.describe(),
        render,
    })
}

/// Without the `gpu` feature: an error saying so (there is no GPU render
/// to return).
#[cfg(not(feature = "gpu"))]
pub fn gpu_render(
    _: &raylab::scene::Scene,
    _: &IntegratorKind,
    _: bool,
) -> Result<std::convert::Infallible, Error> {
    Err(Error::Argument(
        "this raylab was built without the `gpu` feature: --device gpu is not available".into(),
    ))
}

/// The flood-fill cache of a render, as the report shows it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CacheReport {
    /// Voxels along x, y and z.
    pub dims: [usize; 3],
    /// Edge length of a voxel.
    pub voxel_size: f32,
    /// Seconds to build the cache.
    pub build_s: f64,
    /// Propagation steps taken so far.
    pub steps: u64,
    /// Seconds of warm-up propagation before the frame.
    pub warm_s: f64,
    /// Propagation steps per frame.
    pub steps_per_frame: u32,
}

/// What one `raylab render` did and measured.
#[derive(Clone, Debug)]
pub struct RenderReport {
    /// The process's peak memory and what was estimated for it, on the
    /// CPU (where /proc tells).
    pub memory: Option<MemoryUse>,
    /// The scene file.
    pub scene: PathBuf,
    /// The image written.
    pub output: PathBuf,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// The pixel sampler.
    pub sampler: Sampler,
    /// The reconstruction filter.
    pub filter: Filter,
    /// The accelerator.
    pub accel: AccelKind,
    /// Render threads.
    pub threads: usize,
    /// The integrator.
    pub integrator: IntegratorKind,
    /// Adaptive sampler only: the rays it spent per pixel.
    pub adaptive_spp: Option<AdaptiveSpp>,
    /// Primitives in the scene.
    pub primitives: usize,
    /// Triangles among them.
    pub triangles: usize,
    /// Point lights.
    pub point_lights: usize,
    /// Emitters sampled (area lights).
    pub emitters: usize,
    /// Rays traced, by kind.
    pub rays: Counters,
    /// Flood fill only: its cache.
    pub cache: Option<CacheReport>,
    /// Seconds to load the scene (and build its accelerator).
    pub load_s: f64,
    /// Seconds to render the frame.
    pub render_s: f64,
    /// The variances over pixels and channels; `None` for the adaptive
    /// sampler, which keeps no variance.
    pub variance: Option<Variances>,
    /// The reference image and the errors against it.
    pub error: Option<ReferenceMetrics>,
    /// GPU renders: the adapter, and where the time went.
    #[cfg(feature = "gpu")]
    pub gpu: Option<GpuUsed>,
}

/// The rays the adaptive sampler spent per pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdaptiveSpp {
    /// The mean over pixels.
    pub mean: f64,
    /// The largest.
    pub max: u32,
}

/// A render's variances, means over pixels and channels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Variances {
    /// The sample variance of one sample.
    pub per_sample: f64,
    /// The variance of the pixel mean.
    pub of_mean: f64,
}

/// The errors of a render against a reference image.
#[derive(Clone, Debug, PartialEq)]
pub struct ReferenceMetrics {
    /// The reference image.
    pub reference: PathBuf,
    /// The errors against it.
    pub metrics: ImageMetrics,
}

/// The GPU a render ran on, and where the time went.
#[cfg(feature = "gpu")]
#[derive(Clone, Debug, PartialEq)]
pub struct GpuUsed {
    /// The adapter's description.
    pub adapter: String,
    /// Upload, shader build, kernel and readback times.
    pub times: raylab_gpu::GpuTimes,
}

/// A render's peak resident memory against the estimate checked before it
/// (`film::memory::render_bytes` over what the process held after loading
/// the scene).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MemoryUse {
    /// Bytes estimated.
    pub estimated: u128,
    /// Bytes measured (the process's `VmHWM`).
    pub peak: u128,
}

/// What rendering `scene` as `opts` says on `threads` holds beyond the
/// loaded scene: the film and its output ([`render_bytes`]); with
/// `--reference`, the reference and the comparison with it (counted as
/// `diff` counts two images, [`DIFF_BYTES_PER_PIXEL`]); with
/// `--spp-map`, the map's data (8 bytes a pixel).
///
/// [`render_bytes`]: raylab::film::memory::render_bytes
/// [`DIFF_BYTES_PER_PIXEL`]: crate::analysis::metrics::DIFF_BYTES_PER_PIXEL
fn render_holds(scene: &raylab::scene::Scene, opts: &RenderOptions, threads: usize) -> u128 {
    use raylab::film::memory::{render_bytes, OutputFormat, RenderHolds};
    let pixels = u128::from(scene.camera.width) * u128::from(scene.camera.height);
    let mut extra = 0;
    if opts.reference.is_some() {
        extra += crate::analysis::metrics::DIFF_BYTES_PER_PIXEL;
    }
    if opts.spp_map.is_some() {
        extra += 8;
    }
    let output = &opts.output;
    pixels * extra
        + render_bytes(&RenderHolds {
            width: scene.camera.width,
            height: scene.camera.height,
            spp: scene.settings.sampler.spp(),
            keep_samples: scene.settings.filter != Filter::Box,
            output: match ImageFormat::from_path(output) {
                Some(ImageFormat::Exr) => OutputFormat::Exr,
                _ => OutputFormat::Png,
            },
            threads,
        })
}

impl RenderReport {
    /// Render as `opts` says: load the scene (timed), read the reference
    /// (before rendering, so a bad one fails fast), prepare the integrator
    /// (flood fill builds and warms up its cache here, timed apart from the
    /// frame), render one frame (timed), compare with the reference, and
    /// write the image and the samples-per-pixel map.
    pub fn run(opts: &RenderOptions) -> Result<Self, Error> {
        if ImageFormat::from_path(&opts.output).is_none() {
            return Err(Error::Argument(format!(
                "{}: unsupported output extension (expected .png or .exr)",
                opts.output.display()
            )));
        }
        crate::check_threads(opts.threads)?;
        let mut inputs = vec![("the scene", opts.scene.as_path())];
        inputs.extend(opts.reference.as_deref().map(|r| ("--reference", r)));
        let mut outputs = vec![("--output", opts.output.as_path())];
        outputs.extend(opts.spp_map.as_deref().map(|m| ("--spp-map", m)));
        raylab::io::check_outputs(&inputs, &outputs)?;
        let t0 = Instant::now();
        // The file's scene with `--set`'s values, built once.
        let mut source = SceneSource::load(&opts.scene, &opts.overrides)?;
        source.set(&opts.settings)?;
        let scene = source.build()?;
        let load_s = t0.elapsed().as_secs_f64();
        let threads = opts.threads.unwrap_or_else(rayon::current_num_threads);
        let holds = render_holds(&scene, opts, threads);
        raylab::film::memory::check(
            || {
                format!(
                    "rendering {}×{} pixels at {} samples per pixel to {}",
                    scene.camera.width,
                    scene.camera.height,
                    scene.settings.sampler.spp(),
                    opts.output.display()
                )
            },
            holds,
        )?;
        let resident_before = raylab::film::memory::resident_bytes().map(|(now, _)| now);
        let integrator = opts.integrator;
        // Read the reference before rendering, so a bad one fails fast.
        let reference = opts
            .reference
            .as_deref()
            .map(|p| read_image(p).map(|img| (p, img)))
            .transpose()?;
        // Flood fill's cache is built and warmed up here, timed apart from
        // the frame (one frame = its propagation steps and the render).
        let watch = super::progress::Watch::start("warm-up", "propagation steps", opts.progress);
        let mut prepared = integrator
            .prepare(&scene)
            .map_err(|e| Error::scene(&opts.scene, Error::Render(e)))?;
        drop(watch);
        let t1 = Instant::now();
        #[cfg(feature = "gpu")]
        let mut gpu = None;
        let (film, counts) = match opts.device {
            Device::Cpu => {
                let watch = super::progress::Watch::start(
                    "render",
                    match integrator {
                        IntegratorKind::FloodFill(_) => "propagation steps and rows",
                        _ => "rows",
                    },
                    opts.progress,
                );
                let (film, RayCounts(counts)) =
                    prepared
                        .frame::<RayCounts>(&scene, opts.threads)
                        .map_err(|e| Error::scene(&opts.scene, Error::Render(e)))?;
                drop(watch);
                (film, counts)
            }
            Device::Gpu => {
                let run = gpu_render(&scene, &integrator, true)
                    .map_err(|e| Error::scene(&opts.scene, e))?;
                #[cfg(feature = "gpu")]
                {
                    let total = run.render.total();
                    gpu = Some(GpuUsed {
                        adapter: run.adapter,
                        times: run.render.times,
                    });
                    (run.render.film, total)
                }
                #[cfg(not(feature = "gpu"))]
                match run {}
            }
        };
        let render_s = t1.elapsed().as_secs_f64();
        let image = film.image();
        let error = match &reference {
            None => None,
            Some((path, img)) => Some(ReferenceMetrics {
                reference: path.to_path_buf(),
                metrics: compare(&image, img).map_err(|error| Error::Compare {
                    test: None,
                    reference: path.to_path_buf(),
                    error,
                })?,
            }),
        };
        match ImageFormat::from_path(&opts.output) {
            Some(ImageFormat::Exr) => {
                raylab::io::image::write_film_exr(&opts.output, &film, &image)
            }
            _ => write_image(&opts.output, &image),
        }
        .map_err(|e| Error::writing(&opts.output, e))?;
        if let Some(map) = &opts.spp_map {
            let stem = map.with_extension("");
            let mut heat = Heatmap::new(
                format!("{}: samples per pixel", scene.settings.sampler.name()),
                film.count_array(),
            );
            heat.value_label = "camera rays traced".into();
            heat.save(&stem).map_err(|e| {
                let mut png = stem.clone().into_os_string();
                png.push(".png");
                Error::writing(png, e)
            })?;
        }

        let sampler = scene.settings.sampler;
        let cache = match &prepared {
            Prepared::FloodFill(ff) => Some(CacheReport {
                dims: ff.cache.dims(),
                voxel_size: ff.cache.voxel_size(),
                build_s: ff.build_s,
                steps: ff.cache.steps(),
                warm_s: ff.warm_s,
                steps_per_frame: ff.cache.config().steps_per_frame,
            }),
            _ => None,
        };
        let memory = resident_before
            .zip(raylab::film::memory::resident_bytes())
            .map(|(before, (_, peak))| MemoryUse {
                estimated: before + holds,
                peak,
            });
        Ok(Self {
            memory,
            scene: opts.scene.clone(),
            output: opts.output.clone(),
            width: scene.camera.width,
            height: scene.camera.height,
            sampler,
            filter: scene.settings.filter,
            accel: scene.accel.kind(),
            threads: opts.threads.unwrap_or_else(rayon::current_num_threads),
            integrator,
            adaptive_spp: sampler.is_adaptive().then(|| {
                let (mean, max) = film.samples_per_pixel();
                AdaptiveSpp { mean, max }
            }),
            primitives: scene.prims.len(),
            triangles: scene.triangle_count(),
            point_lights: scene.lights.len(),
            emitters: scene.area_lights.emitters.len(),
            rays: counts,
            cache,
            load_s,
            render_s,
            // The adaptive sampler's leaf values are not independent
            // samples: it keeps no variance.
            variance: (!sampler.is_adaptive()).then(|| Variances {
                per_sample: film.mean_sample_variance(),
                of_mean: film.mean_variance_of_mean(),
            }),
            error,
            #[cfg(feature = "gpu")]
            gpu,
        })
    }
}

impl RenderReport {
    /// `N threads` on the CPU, `GPU` on the GPU.
    fn device_name(&self) -> String {
        #[cfg(feature = "gpu")]
        if self.gpu.is_some() {
            return "GPU".into();
        }
        format!("{} threads", self.threads)
    }
}

impl fmt::Display for RenderReport {
    /// The lines `raylab render` prints: scene, image, sampling, geometry,
    /// rays, cache, time, variance, error and the file written.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "scene      {}", self.scene.display())?;
        writeln!(
            f,
            "image      {}×{}  {} spp ({})  accel {}  {}  integrator {}",
            self.width,
            self.height,
            self.sampler.spp(),
            self.sampler.name(),
            self.accel,
            self.device_name(),
            self.integrator
        )?;
        if let Some(AdaptiveSpp { mean, max }) = self.adaptive_spp {
            writeln!(
                f,
                "adaptive   {mean:.3} rays per pixel on average (cost T = {mean:.3} × one centre \
                 sample), {max} at most"
            )?;
        } else if self.filter != Filter::Box {
            writeln!(f, "filter     {}", self.filter.name())?;
        }
        writeln!(
            f,
            "geometry   {} primitives ({} triangles), {} point lights, {} emitters sampled",
            self.primitives, self.triangles, self.point_lights, self.emitters
        )?;
        let c = &self.rays;
        writeln!(
            f,
            "rays       {} total: {} camera, {} shadow, {} reflection, {} refraction, {} path",
            c.rays(),
            c.camera_rays,
            c.shadow_rays,
            c.reflection_rays,
            c.refraction_rays,
            c.path_rays
        )?;
        if let Some(cache) = &self.cache {
            let [nx, ny, nz] = cache.dims;
            writeln!(
                f,
                "cache      {nx}×{ny}×{nz} voxels of {:.4}, built in {:.3} s, {} steps ({:.3} s \
                 warm-up, then {} per frame)",
                cache.voxel_size, cache.build_s, cache.steps, cache.warm_s, cache.steps_per_frame
            )?;
        }
        writeln!(
            f,
            "time       load {:.3} s, render {:.3} s, {:.2} Mrays/s",
            self.load_s,
            self.render_s,
            c.rays() as f64 / self.render_s / 1e6
        )?;
        if let Some(m) = &self.memory {
            writeln!(
                f,
                "memory     peak {} (estimated {} before the render)",
                Bytes(m.peak),
                Bytes(m.estimated)
            )?;
        }
        #[cfg(feature = "gpu")]
        if let Some(GpuUsed { adapter, times: t }) = &self.gpu {
            writeln!(f, "device     GPU: {adapter}")?;
            writeln!(
                f,
                "gpu time   upload {:.4} s, shader build {:.4} s, kernel {:.4} s ({}), readback \
                 {:.4} s; {:.2} Mrays/s in the kernel (counters on)",
                t.upload,
                t.compile,
                t.kernel,
                if t.timestamped {
                    "GPU timestamps"
                } else {
                    "wall time of a synchronised submit"
                },
                t.readback,
                c.rays() as f64 / t.kernel / 1e6
            )?;
        }
        if let Some(Variances {
            per_sample,
            of_mean,
        }) = self.variance
        {
            writeln!(
                f,
                "variance   {per_sample:.6e} per sample, {of_mean:.6e} of the pixel mean (mean over \
                 pixels and channels)"
            )?;
        }
        if let Some(ReferenceMetrics {
            reference,
            metrics: m,
        }) = &self.error
        {
            writeln!(
                f,
                "error      MSE {:.6e}, relMSE {:.6e}, FLIP {:.6} against {}",
                m.mse,
                m.rel_mse,
                m.flip.mean,
                reference.display()
            )?;
        }
        writeln!(f, "wrote      {}", self.output.display())
    }
}
