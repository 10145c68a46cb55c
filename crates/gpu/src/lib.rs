//! S3's GPU port, done portably: the Whitted integrator as a WGSL compute
//! shader run through wgpu (Vulkan, Metal or DX12; Mesa's lavapipe, a
//! software Vulkan, on machines with no GPU).
//!
//! What moved to the GPU: per pixel, the sampler's positions (the samplers
//! that are pure functions of pixel, index and seed: SplitMix64 is done in
//! 32-bit halves; Halton's radical inverses come from a table made by
//! [`raylab::sampler::halton_point`]), S2's camera rays, traversal of the
//! flattened tree exactly as the CPU built it (brute force, the binary
//! tree with any of S3's three volumes, the 4-wide box tree), the
//! watertight triangle test and the quadric and plane tests, and Whitted's
//! shading with one shadow ray per light, reflection and refraction with
//! the index-of-refraction stack and every cut-off. What stays on the CPU:
//! building the tree, and the film's development into image files.
//!
//! No recursion: a shader cannot recurse, and the CPU's Whitted is already
//! a loop over an explicit stack of pending rays ([`raylab::integrator::whitted`]),
//! so the shader runs the same loop with arrays sized by the scene's
//! `max_depth` (at most [`upload::GPU_MAX_DEPTH`]).
//!
//! Counting: each invocation counts its pixel's rays, node visits and
//! volume and primitive tests in private memory (no atomics) and writes
//! them once, under the CPU's conventions, so `raylab stats --device gpu`
//! gives per-pixel counts comparable one to one with the CPU's.
//!
//! Same image, within rounding: the shader follows the CPU's order of
//! operations, but a GPU may fuse a·b + c into one rounding (WGSL allows
//! it), and its division and square root are accurate to 2.5 and 3 ulp
//! rather than correctly rounded (Vulkan's precision rules), so camera
//! rays differ from the CPU's in the last bits of their directions. A
//! pixel then differs by far less than 10⁻⁴ unless a ray passes so close
//! to an edge or silhouette that the two devices pick different primitives
//! (or a shadow ray grazes an occluder): such pixels are counted and
//! located by the tests (crates/gpu/tests/gpu.rs), not hidden by the tolerance.

// No unsafe code here, and none to come: the workspace's unsafe lives in
// `raylab`, each block with its SAFETY argument.
#![forbid(unsafe_code)]

pub mod error;
pub mod upload;

pub use error::GpuError;

use raylab::film::{Film, PixelStats};
use raylab::math::Color;
use raylab::scene::Scene;
use raylab::stats::Counters;
use std::time::Instant;
use upload::{Kernel, PackedScene, ShaderParams};

/// The shader source, with `{{…}}` placeholders for the kernel constants:
/// its four parts in order (shader/common.wgsl says what each holds).
const SHADER: &str = concat!(
    include_str!("shader/common.wgsl"),
    include_str!("shader/sampling.wgsl"),
    include_str!("shader/intersect.wgsl"),
    include_str!("shader/whitted.wgsl"),
);

/// Words per pixel of the counts buffer: the 15 counters and the
/// primitive hit by the first camera ray (+1; 0 for none).
const COUNT_WORDS: usize = 16;

/// Pixels per dispatch at most (each dispatch renders one sample of a band
/// of rows): short dispatches keep clear of a display driver's watchdog.
const SAMPLES_PER_DISPATCH: u64 = 1 << 20;

/// A GPU ready to render: the adapter wgpu chose and its device.
pub struct Gpu {
    device: wgpu::Device,
    queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
    limits: wgpu::Limits,
    timestamps: bool,
}

/// Where a GPU render's time went, in seconds.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct GpuTimes {
    /// Packing the scene and copying it (and the uniforms) to the device.
    pub upload: f64,
    /// Compiling the shader for this scene's kernel constants.
    pub compile: f64,
    /// The kernel: GPU timestamps around the compute pass where the
    /// adapter has them, else the wall time of a synchronised submit.
    pub kernel: f64,
    /// Copying the results back and building the film.
    pub readback: f64,
    /// Whether `kernel` comes from GPU timestamps.
    pub timestamped: bool,
}

/// What a GPU render returns.
pub struct GpuRender {
    pub film: Film,
    /// Per-pixel counters, row-major (empty unless asked for).
    pub pixel_counters: Vec<Counters>,
    /// Per pixel, the primitive the first camera ray hit (`None`: nothing),
    /// when counters were asked for.
    pub first_hit: Vec<Option<u32>>,
    pub times: GpuTimes,
}

impl GpuRender {
    /// The counters summed over the image.
    pub fn total(&self) -> Counters {
        let mut t = Counters::default();
        for c in &self.pixel_counters {
            t += *c;
        }
        t
    }
}

impl Gpu {
    /// The first adapter wgpu finds on Vulkan, Metal or DX12 (a discrete
    /// GPU preferred). With none, an error that says how to get lavapipe.
    pub fn new() -> Result<Self, GpuError> {
        Self::open(None)
    }

    /// [`Gpu::new`] with a device that allows storage buffers of at most
    /// `bytes` (wgpu enforces it): how a test meets a scene too large for
    /// the adapter without building one of gigabytes.
    pub fn with_binding_limit(bytes: u64) -> Result<Self, GpuError> {
        Self::open(Some(bytes))
    }

    fn open(binding_limit: Option<u64>) -> Result<Self, GpuError> {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
            backends: wgpu::Backends::VULKAN | wgpu::Backends::METAL | wgpu::Backends::DX12,
            ..wgpu::InstanceDescriptor::new_without_display_handle()
        });
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: None,
            ..Default::default()
        }))
        .map_err(|e| GpuError::NoAdapter {
            reason: e.to_string(),
        })?;
        let info = adapter.get_info();
        let mut limits = adapter.limits();
        if let Some(b) = binding_limit {
            limits.max_storage_buffer_binding_size = b.min(limits.max_storage_buffer_binding_size);
        }
        let timestamps = adapter.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        let features = if timestamps {
            wgpu::Features::TIMESTAMP_QUERY
        } else {
            wgpu::Features::empty()
        };
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("raylab"),
            required_features: features,
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| GpuError::Device {
            adapter: info.name.clone(),
            reason: e.to_string(),
        })?;
        Ok(Gpu {
            device,
            queue,
            info,
            limits,
            timestamps,
        })
    }

    /// The adapter: name, back end, driver and its version, device type.
    pub fn describe(&self) -> String {
        let i = &self.info;
        let driver = [i.driver.as_str(), i.driver_info.as_str()]
            .iter()
            .filter(|s| !s.is_empty())
            .copied()
            .collect::<Vec<_>>()
            .join(" ");
        format!(
            "{} ({:?}, driver {}, {:?})",
            i.name,
            i.backend,
            if driver.is_empty() {
                "unknown"
            } else {
                &driver
            },
            i.device_type
        )
    }

    /// Whether the shader must count its loop iterations: Mesa's llvmpipe
    /// (lavapipe) ends an invocation's loops after 65535 iterations in all.
    fn loop_guard(&self) -> bool {
        self.info.name.contains("llvmpipe")
    }

    /// Whether the adapter is a CPU (lavapipe, WARP, SwiftShader): its
    /// timings are software timings.
    pub fn is_software(&self) -> bool {
        self.info.device_type == wgpu::DeviceType::Cpu
    }

    /// Render `scene` with Whitted's integrator, keeping per-pixel counters
    /// when `counters` is set.
    pub fn render(&self, scene: &Scene, counters: bool) -> Result<GpuRender, GpuError> {
        let mut times = GpuTimes::default();
        let start = Instant::now();
        let packed = upload::pack(scene)?;
        let (w, h) = (scene.camera.width as u64, scene.camera.height as u64);
        let pixels = w * h;
        let max_binding = self.limits.max_storage_buffer_binding_size;
        let sizes = [
            ("the scene", packed.words.len() as u64 * 4),
            ("the film", pixels * 32),
            (
                "the counters",
                if counters {
                    pixels * COUNT_WORDS as u64 * 4
                } else {
                    4
                },
            ),
        ];
        for (what, bytes) in sizes {
            if bytes > max_binding || bytes > self.limits.max_buffer_size {
                return Err(GpuError::TooLarge {
                    what,
                    bytes,
                    max_binding,
                    max_buffer: self.limits.max_buffer_size,
                    adapter: self.info.name.clone(),
                });
            }
        }
        let d = &self.device;
        let scene_buf = self.storage("scene", bytemuck::cast_slice(&packed.words));
        let film_bytes = pixels * 32;
        let count_bytes = if counters {
            pixels * COUNT_WORDS as u64 * 4
        } else {
            4
        };
        let film_buf = self.buffer(
            "film",
            film_bytes,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        );
        let count_buf = self.buffer(
            "counts",
            count_bytes,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        );
        // Bands of rows, and one sample of every pixel of a band per
        // dispatch (the shader continues each pixel's sums): one uniform
        // block each.
        let rows_per_band = (SAMPLES_PER_DISPATCH / w).clamp(1, h) as u32;
        let spp = packed.params.spp;
        let bands: Vec<ShaderParams> = (0..spp)
            .flat_map(|sample| {
                (0..scene.camera.height)
                    .step_by(rows_per_band as usize)
                    .map(move |row| (sample, row))
            })
            .map(|(sample, row)| ShaderParams {
                row_offset: row,
                rows: rows_per_band.min(scene.camera.height - row),
                sample_first: sample,
                sample_count: 1,
                ..packed.params
            })
            .collect();
        let uniforms: Vec<wgpu::Buffer> = bands
            .iter()
            .map(|p| self.uniform(bytemuck::bytes_of(p)))
            .collect();
        times.upload = start.elapsed().as_secs_f64();

        let t = Instant::now();
        let pipeline = self.pipeline(&packed, scene.settings.max_depth, counters)?;
        let layout = pipeline.get_bind_group_layout(0);
        let group = |u: &wgpu::Buffer| {
            d.create_bind_group(&wgpu::BindGroupDescriptor {
                label: None,
                layout: &layout,
                entries: &[
                    entry(0, u),
                    entry(1, &scene_buf),
                    entry(2, &film_buf),
                    entry(3, &count_buf),
                ],
            })
        };
        // One empty dispatch (no rows): drivers that compile a pipeline
        // at its first use (lavapipe's LLVM) do it here, in `compile`,
        // not in the kernel's time.
        let empty = self.uniform(bytemuck::bytes_of(&ShaderParams {
            rows: 0,
            sample_count: 0,
            ..packed.params
        }));
        let mut enc = d.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &group(&empty), &[]);
            pass.dispatch_workgroups(1, 1, 1);
        }
        self.queue.submit([enc.finish()]);
        self.wait()?;
        times.compile = t.elapsed().as_secs_f64();
        let groups: Vec<wgpu::BindGroup> = uniforms.iter().map(group).collect();

        let queries = self.timestamps.then(|| {
            d.create_query_set(&wgpu::QuerySetDescriptor {
                label: None,
                ty: wgpu::QueryType::Timestamp,
                count: 2,
            })
        });
        let t = Instant::now();
        let mut enc = d.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("whitted"),
                timestamp_writes: queries.as_ref().map(|q| wgpu::ComputePassTimestampWrites {
                    query_set: q,
                    beginning_of_pass_write_index: Some(0),
                    end_of_pass_write_index: Some(1),
                }),
            });
            pass.set_pipeline(&pipeline);
            for (band, group) in bands.iter().zip(&groups) {
                pass.set_bind_group(0, group, &[]);
                pass.dispatch_workgroups(band.width.div_ceil(8), band.rows.div_ceil(8), 1);
            }
        }
        let stamps = queries.as_ref().map(|q| {
            let resolve = self.buffer(
                "timestamps",
                16,
                wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            );
            enc.resolve_query_set(q, 0..2, &resolve, 0);
            resolve
        });
        self.queue.submit([enc.finish()]);
        self.wait()?;
        let wall = t.elapsed().as_secs_f64();

        let t = Instant::now();
        let film_words: Vec<f32> = self.read(&film_buf, film_bytes)?;
        let count_words: Vec<u32> = if counters {
            self.read(&count_buf, count_bytes)?
        } else {
            Vec::new()
        };
        times.kernel = match &stamps {
            Some(b) => {
                let s: Vec<u64> = self.read(b, 16)?;
                times.timestamped = true;
                s[1].saturating_sub(s[0]) as f64
                    * f64::from(self.queue.get_timestamp_period())
                    * 1e-9
            }
            None => wall,
        };
        let tripped = film_words.chunks_exact(8).filter(|p| p[7] != 0.0).count();
        if tripped > 0 {
            return Err(GpuError::LoopLimit {
                pixels: tripped,
                adapter: self.info.name.clone(),
                primitives: packed.params.n_accel,
            });
        }
        let mut film = Film::new(scene.camera.width, scene.camera.height);
        for (px, p) in film.pixels.iter_mut().zip(film_words.chunks_exact(8)) {
            *px = PixelStats {
                mean: Color::new(p[0], p[1], p[2]),
                m2: Color::new(p[4], p[5], p[6]),
                count: p[3] as u32,
            };
        }
        let (pixel_counters, first_hit) = count_words
            .chunks_exact(COUNT_WORDS)
            .map(|c| (counters_from(c), c[15].checked_sub(1)))
            .unzip();
        times.readback = t.elapsed().as_secs_f64();
        Ok(GpuRender {
            film,
            pixel_counters,
            first_hit,
            times,
        })
    }

    /// The compute pipeline for this scene's kernel constants.
    fn pipeline(
        &self,
        packed: &PackedScene,
        max_depth: u32,
        counters: bool,
    ) -> Result<wgpu::ComputePipeline, GpuError> {
        let source = shader_source(packed.kernel, max_depth, counters, self.loop_guard());
        let d = &self.device;
        let scope = d.push_error_scope(wgpu::ErrorFilter::Validation);
        let desc = wgpu::ShaderModuleDescriptor {
            label: Some("raylab whitted"),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        };
        // With wgpu's run-time checks (bounds-checked indexing, bounded
        // loops): no index computed from a scene can reach outside a buffer.
        let module = d.create_shader_module(desc);
        let pipeline = d.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("whitted"),
            layout: None,
            module: &module,
            entry_point: Some("main"),
            compilation_options: Default::default(),
            cache: None,
        });
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Shader {
                adapter: self.info.name.clone(),
                reason: e.to_string(),
            });
        }
        Ok(pipeline)
    }

    fn buffer(&self, label: &str, size: u64, usage: wgpu::BufferUsages) -> wgpu::Buffer {
        self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: size.max(4),
            usage,
            mapped_at_creation: false,
        })
    }

    fn storage(&self, label: &str, data: &[u8]) -> wgpu::Buffer {
        let b = self.buffer(
            label,
            data.len() as u64,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        );
        self.queue.write_buffer(&b, 0, data);
        b
    }

    fn uniform(&self, data: &[u8]) -> wgpu::Buffer {
        let b = self.buffer(
            "params",
            data.len() as u64,
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        self.queue.write_buffer(&b, 0, data);
        b
    }

    fn wait(&self) -> Result<(), GpuError> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map(|_| ())
            .map_err(|e| GpuError::Wait {
                adapter: self.info.name.clone(),
                reason: e.to_string(),
            })
    }

    /// Copy `bytes` of `src` back to the host as `T`s.
    fn read<T: bytemuck::Pod>(&self, src: &wgpu::Buffer, bytes: u64) -> Result<Vec<T>, GpuError> {
        let staging = self.buffer(
            "readback",
            bytes,
            wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        );
        let mut enc = self.device.create_command_encoder(&Default::default());
        enc.copy_buffer_to_buffer(src, 0, &staging, 0, bytes);
        self.queue.submit([enc.finish()]);
        let slice = staging.slice(..bytes);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.wait()?;
        let readback = |reason: String| GpuError::Readback { reason };
        rx.recv()
            .map_err(|e| readback(e.to_string()))?
            .map_err(|e| readback(e.to_string()))?;
        let data = slice
            .get_mapped_range()
            .map_err(|e| readback(e.to_string()))?;
        let out = bytemuck::cast_slice(&data).to_vec();
        drop(data);
        staging.unmap();
        Ok(out)
    }
}

fn entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: buffer.as_entire_binding(),
    }
}

/// The shader with its kernel constants filled in.
pub fn shader_source(kernel: Kernel, max_depth: u32, counters: bool, loop_guard: bool) -> String {
    let stack = if kernel.accel == 2 {
        3 * raylab::accel::bvh::MAX_DEPTH
    } else {
        raylab::accel::bvh::MAX_DEPTH
    };
    let slots = max_depth.max(1);
    SHADER
        .replace("{{ACCEL}}", &kernel.accel.to_string())
        .replace("{{VOLUME}}", &kernel.volume.to_string())
        .replace("{{DEPTH_LIMIT}}", &max_depth.to_string())
        .replace("{{MAX_DEPTH}}", &slots.to_string())
        .replace(
            "{{MEDIA}}",
            &slots
                .min(raylab::integrator::whitted::MediumStack::CAPACITY as u32)
                .to_string(),
        )
        .replace("{{TRAVERSAL_STACK}}", &stack.to_string())
        .replace("{{STATS}}", if counters { "true" } else { "false" })
        .replace("{{LOOP_GUARD}}", if loop_guard { "true" } else { "false" })
}

/// The 15 counters of one pixel, in `Counters`' field order.
fn counters_from(c: &[u32]) -> Counters {
    let g = |i: usize| u64::from(c[i]);
    Counters {
        camera_rays: g(0),
        shadow_rays: g(1),
        reflection_rays: g(2),
        refraction_rays: g(3),
        path_rays: g(4),
        random_rays: g(5),
        nodes_visited: g(6),
        box_tests: g(7),
        bounding_sphere_tests: g(8),
        bounding_ellipsoid_tests: g(9),
        triangle_tests: g(10),
        sphere_tests: g(11),
        ellipsoid_tests: g(12),
        plane_tests: g(13),
        primitive_hits: g(14),
    }
}
