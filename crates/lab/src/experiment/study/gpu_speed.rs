//! `kind = "gpu_speed"`: S3's last tables, the CPU against the GPU port
//! ([`raylab_gpu`]): basic (brute force) against basic + GPU, and a BVH
//! against BVH + GPU, on a mesh in the automatic scene of `accel_cost`
//! ([`mesh_scene`]: the mesh fitted into a 2-unit box, Phong with some
//! reflection, one point light with shadows, a camera framing the mesh).
//!
//! One run = (mesh, accelerator, device, resolution). Both devices start
//! from the same scene and the same tree: the CPU builds the accelerator
//! (`build_s`, [`Scene::set_accel`]); then
//!
//! - `device = "cpu"` renders Whitted's integrator on every thread of the
//!   experiment's pool, `warmup` times untimed and `repeats` times timed
//!   with [`NoStats`] (`render_s_N`), then once with [`Counters`] for the
//!   rays;
//! - `device = "gpu"` hands the scene to [`Gpu::render`] the same way:
//!   each timed repeat is the whole call (packing and upload, shader
//!   build, kernel, readback and the film), and the split of the repeat
//!   whose time is the median (the lower middle for an even count) is
//!   recorded as `upload_s`, `shader_s`, `kernel_s` and `readback_s`. The
//!   shader is built for each render (its constants depend on the scene),
//!   and on a JIT driver such as lavapipe that build can cost more than
//!   the kernel; `kernel_s` is from GPU timestamps where the adapter has
//!   them (`kernel_timestamped`). The rays are counted by the GPU itself
//!   (one more render with its per-pixel counters).
//!
//! `total_s` is build + the median render: what S3's tables compare.
//! `trace_s` is the tracing alone: the kernel on the GPU, the render on
//! the CPU. Every row names the experiment's GPU adapter (`gpu_adapter`,
//! also in meta.json's `device`) and whether it is a software one
//! (`gpu_software`: lavapipe and the like run the "GPU" on the CPU's
//! cores, so their times are not a GPU's), on CPU rows too: they are the
//! rows the GPU ones are compared with, and a figure's title quotes it.
//!
//! Brute force is rendered only up to `brute_max_faces` faces, on either
//! device: a brute-force run on a larger mesh is an error naming the
//! limit, and manifests list the small meshes for brute force (S3 itself
//! stopped its basic tracer at 37 986 faces).

use super::accel_cost::{mesh_scene, LabelledMesh, MeshSource, ProceduralSpec};
use super::{median, RunContext, Study, StudySettings, Timings};
use crate::experiment::params::{
    parsed, parsed_opt, typed_params, InRange, ParamDoc, Resolution, RunParamError,
};
use crate::experiment::row::{Fixed, Secs};
use crate::experiment::sweep::RunPoint;
use crate::Error;
use raylab::accel::AccelKind;
use raylab::integrator::{render, Whitted};
use raylab::scene::Scene;
use raylab::stats::{Counters, NoStats};
use raylab_gpu::{Gpu, GpuError, GpuTimes};
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::sync::OnceLock;
use std::time::Instant;

/// The `gpu_speed` study.
#[derive(Clone, Copy, Debug, Default)]
pub struct GpuSpeed;

/// Default of `brute_max_faces`: at 200×200 brute force on this many
/// faces takes some seconds per render on the 2-core test machine (about
/// 10⁵ rays × 10⁴ triangle tests × ~10 ns, shared out over two threads),
/// and as long again on lavapipe.
pub const DEFAULT_BRUTE_MAX_FACES: u64 = 10_000;

/// The parameters of a run.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GpuSpeedParams {
    /// Mesh file, relative to the manifest's folder.
    #[serde(default)]
    pub mesh: Option<String>,
    /// Generated mesh instead of `mesh`.
    #[serde(default, deserialize_with = "parsed_opt")]
    pub procedural: Option<ProceduralSpec>,
    /// The accelerator.
    #[serde(deserialize_with = "parsed")]
    pub accel: AccelKind,
    /// Where the rays are traced.
    pub device: String,
    /// Image size.
    #[serde(default, deserialize_with = "parsed_opt")]
    pub resolution: Option<Resolution>,
    /// Largest mesh brute force renders.
    #[serde(default)]
    pub brute_max_faces: Option<InRange<0, { i64::MAX }>>,
}

typed_params!(
    GpuSpeedParams,
    [
        ParamDoc {
            name: "mesh",
            doc: "mesh file (.obj .ply .off .3ds), relative to the manifest's folder; \
                  or give `procedural`",
        },
        ParamDoc {
            name: "procedural",
            doc: "generated mesh instead of `mesh`: \"icosphere:LEVEL\", \
                  \"torus_knot:P:Q:SEGMENTS:SIDES\" or \"terrain:N:SEED\"",
        },
        ParamDoc {
            name: "accel",
            doc: "accelerator, as `raylab render --accel`, of those the GPU renders: \
                  `brute`, `bvh2`, `bvh:VOLUME[:BUILDER]` or `bvh4`; required",
        },
        ParamDoc {
            name: "device",
            doc: "\"cpu\" (every thread of the experiment) or \"gpu\" (the first adapter \
                  wgpu finds); required",
        },
        ParamDoc {
            name: "resolution",
            doc: "image size \"WxH\" (default \"200x200\", S3's)",
        },
        ParamDoc {
            name: "brute_max_faces",
            doc: "largest mesh brute force renders (default 10000); a brute-force run on a \
                  larger mesh is an error",
        },
    ]
);

/// Where a run traces its rays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GpuSpeedDevice {
    /// raylab's CPU renderer, every thread of the experiment's pool.
    Cpu,
    /// The GPU port.
    Gpu,
}

/// A run's parameters, checked.
pub struct GpuSpeedConfig {
    source: MeshSource,
    /// How the mesh was named in the manifest (messages).
    label: String,
    accel: AccelKind,
    device: GpuSpeedDevice,
    width: u32,
    height: u32,
    brute_max_faces: u64,
}

/// One row: a mesh rendered with one accelerator on one device.
#[derive(Clone, Debug, Default, Serialize)]
pub struct GpuSpeedRow {
    /// Triangles of the mesh.
    pub faces: u64,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Pixels of the image.
    pub pixels: u64,
    /// CPU worker threads (the CPU render's; the GPU rows' tree build is
    /// single-threaded).
    pub threads: usize,
    /// Loading the mesh and making the scene.
    pub load_s: Secs,
    /// Building the accelerator on the CPU.
    pub build_s: Secs,
    /// GPU: packing the scene and copying it to the device.
    pub upload_s: Option<Secs>,
    /// GPU: building the shader for this scene (with its warm-up dispatch).
    pub shader_s: Option<Secs>,
    /// GPU: the kernel.
    pub kernel_s: Option<Secs>,
    /// GPU: copying the results back and making the film.
    pub readback_s: Option<Secs>,
    /// GPU: whether `kernel_s` comes from GPU timestamps.
    pub kernel_timestamped: Option<bool>,
    /// Each timed render: the CPU's render, or the GPU's whole call.
    pub render_s: Vec<Secs>,
    /// Median of the timed renders.
    pub render_median_s: Secs,
    /// Shortest timed render.
    pub render_min_s: Secs,
    /// Longest timed render.
    pub render_max_s: Secs,
    /// The tracing alone: the kernel (GPU) or the render (CPU).
    pub trace_s: Secs,
    /// Build plus median render.
    pub total_s: Secs,
    /// Rays of every kind, counted on the row's device.
    pub rays: u64,
    /// Rays over the median render.
    pub rays_per_s: Fixed<1>,
    /// Rays over `trace_s`.
    pub trace_rays_per_s: Fixed<1>,
    /// The experiment's GPU adapter: name, back end, driver, type.
    pub gpu_adapter: String,
    /// Whether that adapter is a software one (runs on the CPU).
    pub gpu_software: bool,
    /// "software GPU (runs on the CPU)" or "hardware GPU", for titles.
    pub gpu_class: String,
}

/// The one GPU of the process, made on first use (creating a device takes
/// a while, and every run of an experiment uses the same adapter).
fn gpu() -> Result<&'static Gpu, GpuError> {
    static GPU: OnceLock<Result<Gpu, GpuError>> = OnceLock::new();
    GPU.get_or_init(Gpu::new).as_ref().map_err(Clone::clone)
}

/// The experiment's GPU adapter as meta.json records it: its description
/// and whether it is a software one; the error when there is none.
pub fn adapter_note() -> String {
    match gpu() {
        Ok(g) => format!(
            "{}{}",
            g.describe(),
            if g.is_software() {
                "; a software GPU: its times are the CPU's"
            } else {
                ""
            }
        ),
        Err(e) => format!("no GPU: {e}"),
    }
}

/// `gpu_class` of a row.
fn gpu_class(software: bool) -> &'static str {
    if software {
        "software GPU (runs on the CPU)"
    } else {
        "hardware GPU"
    }
}

impl Study for GpuSpeed {
    type Params = GpuSpeedParams;
    type Config = GpuSpeedConfig;
    type Row = GpuSpeedRow;

    fn configure(
        &self,
        p: GpuSpeedParams,
        base_dir: &Path,
    ) -> Result<GpuSpeedConfig, RunParamError> {
        let LabelledMesh { source, label } =
            MeshSource::from_params(p.mesh, p.procedural, base_dir)?;
        let device = match p.device.as_str() {
            "cpu" => GpuSpeedDevice::Cpu,
            "gpu" => GpuSpeedDevice::Gpu,
            other => {
                return Err(RunParamError::new(
                    "device",
                    format!("expected \"cpu\" or \"gpu\", got \"{other}\""),
                ))
            }
        };
        if !matches!(
            p.accel,
            AccelKind::Brute | AccelKind::Bvh(_) | AccelKind::Bvh4
        ) {
            return Err(RunParamError::new(
                "accel",
                "the GPU port has no Embree and no 8-wide tree: give `brute`, `bvh2`, `bvh:VOLUME[:BUILDER]` or `bvh4` (plain `bvh` is `bvh8`)",
            ));
        }
        let res = p.resolution.unwrap_or(Resolution {
            width: 200,
            height: 200,
        });
        Ok(GpuSpeedConfig {
            source,
            label,
            accel: p.accel,
            device,
            width: res.width,
            height: res.height,
            brute_max_faces: p
                .brute_max_faces
                .map_or(DEFAULT_BRUTE_MAX_FACES, |n| n.get() as u64),
        })
    }

    fn device(&self) -> Option<String> {
        Some(adapter_note())
    }

    fn template(&self, settings: &StudySettings) -> GpuSpeedRow {
        GpuSpeedRow {
            render_s: vec![Secs::default(); settings.repeats as usize],
            ..Default::default()
        }
    }

    fn run(
        &self,
        cfg: GpuSpeedConfig,
        _run: &RunPoint,
        ctx: &RunContext<'_>,
    ) -> Result<GpuSpeedRow, Error> {
        // The adapter first: a machine without one fails before the mesh
        // is loaded, CPU rows included (they are only half a comparison).
        let gpu = gpu()?;
        let start = Instant::now();
        let mut scene =
            mesh_scene(&cfg.source, cfg.width, cfg.height).map_err(|e| Error::Mesh {
                label: cfg.label.clone(),
                error: Box::new(e),
            })?;
        let load_s = start.elapsed().as_secs_f64();
        let faces = scene.triangle_count() as u64;
        if cfg.accel == AccelKind::Brute && faces > cfg.brute_max_faces {
            return Err(Error::Study(format!(
                "brute force on `{}` ({faces} faces) is above brute_max_faces = {}: \
                 leave it out of the brute-force sweep or raise the limit",
                cfg.label, cfg.brute_max_faces
            )));
        }

        let start = Instant::now();
        scene
            .set_accel(cfg.accel)
            .map_err(Error::accel(cfg.accel))?;
        let build_s = start.elapsed().as_secs_f64();

        let settings = ctx.settings;
        let m = match cfg.device {
            GpuSpeedDevice::Cpu => measure_cpu(&scene, settings),
            GpuSpeedDevice::Gpu => measure_gpu(gpu, &scene, settings)?,
        };
        let median_s = median(&m.seconds);
        let trace_s = m.split.map_or(median_s, |t| t.kernel);
        let software = gpu.is_software();
        let per_s = |s: f64| Fixed(m.rays as f64 / s);
        let (w, h) = (cfg.width, cfg.height);
        Ok(GpuSpeedRow {
            faces,
            width: w,
            height: h,
            pixels: u64::from(w) * u64::from(h),
            threads: rayon::current_num_threads(),
            load_s: Secs(load_s),
            build_s: Secs(build_s),
            upload_s: m.split.map(|t| Secs(t.upload)),
            shader_s: m.split.map(|t| Secs(t.compile)),
            kernel_s: m.split.map(|t| Secs(t.kernel)),
            readback_s: m.split.map(|t| Secs(t.readback)),
            kernel_timestamped: m.split.map(|t| t.timestamped),
            render_s: m.seconds.iter().map(|&s| Secs(s)).collect(),
            render_median_s: Secs(median_s),
            render_min_s: Secs(m.seconds.iter().copied().fold(f64::NAN, f64::min)),
            render_max_s: Secs(m.seconds.iter().copied().fold(f64::NAN, f64::max)),
            trace_s: Secs(trace_s),
            total_s: Secs(build_s + median_s),
            rays: m.rays,
            rays_per_s: per_s(median_s),
            trace_rays_per_s: per_s(trace_s),
            gpu_adapter: gpu.describe(),
            gpu_software: software,
            gpu_class: gpu_class(software).to_string(),
        })
    }
}

/// What the timed renders of a row measured.
struct GpuSpeedMeasured {
    /// Wall-clock seconds of each timed render.
    seconds: Vec<f64>,
    /// The GPU's split of the median repeat (GPU rows).
    split: Option<GpuTimes>,
    /// Rays counted on the row's device.
    rays: u64,
}

fn measure_cpu(scene: &Scene, settings: StudySettings) -> GpuSpeedMeasured {
    let timings = Timings::measure(settings.warmup, settings.repeats, || {
        render::<_, NoStats>(scene, &Whitted, None)
    });
    let (_, counters) = render::<_, Counters>(scene, &Whitted, None);
    GpuSpeedMeasured {
        seconds: timings.seconds,
        split: None,
        rays: counters.rays(),
    }
}

fn measure_gpu(
    gpu: &Gpu,
    scene: &Scene,
    settings: StudySettings,
) -> Result<GpuSpeedMeasured, GpuError> {
    for _ in 0..settings.warmup {
        gpu.render(scene, false)?;
    }
    let mut repeats: Vec<(f64, GpuTimes)> = Vec::new();
    for _ in 0..settings.repeats {
        let start = Instant::now();
        let out = gpu.render(scene, false)?;
        repeats.push((start.elapsed().as_secs_f64(), out.times));
    }
    let seconds: Vec<f64> = repeats.iter().map(|r| r.0).collect();
    let mut order: Vec<usize> = (0..repeats.len()).collect();
    order.sort_by(|&a, &b| repeats[a].0.total_cmp(&repeats[b].0));
    let split = order
        .get(order.len().saturating_sub(1) / 2)
        .map(|&i| repeats[i].1);
    let counted = gpu.render(scene, true)?;
    Ok(GpuSpeedMeasured {
        seconds,
        split,
        rays: counted.total().rays(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(device: &str, accel: &str) -> GpuSpeedParams {
        GpuSpeedParams {
            mesh: None,
            procedural: Some(ProceduralSpec {
                text: "icosphere:1".into(),
                procedural: raylab::io::procedural::Procedural::Icosphere { level: 1 },
            }),
            accel: accel.parse().unwrap(),
            device: device.into(),
            resolution: None,
            brute_max_faces: None,
        }
    }

    #[test]
    fn configure_checks_device_and_accelerator() {
        let base = Path::new(".");
        let c = GpuSpeed
            .configure(params("gpu", "bvh2"), base)
            .ok()
            .unwrap();
        assert_eq!(
            (c.device, c.width, c.height),
            (GpuSpeedDevice::Gpu, 200, 200)
        );
        assert_eq!(c.brute_max_faces, DEFAULT_BRUTE_MAX_FACES);
        let e = GpuSpeed
            .configure(params("tpu", "bvh2"), base)
            .err()
            .unwrap();
        assert!(e.to_string().contains("\"cpu\" or \"gpu\""), "{e}");
        #[cfg(feature = "embree")]
        {
            let e = GpuSpeed
                .configure(params("cpu", "embree"), base)
                .err()
                .unwrap();
            assert!(e.to_string().contains("no Embree"), "{e}");
        }
    }
}
