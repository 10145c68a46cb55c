//! [`GpuError`]: why the GPU port could not render, the one error type of
//! this crate. The bottom layer of the crate: [`crate::upload`] refuses
//! scenes with it and [`crate::Gpu`] reports the device's failures with it.
//!
//! Each message is whole: it names the adapter or the setting at fault and
//! says what to do instead (usually `--device cpu`), since the command
//! line prints it as it is. wgpu's own errors are kept as their text, so
//! that the error stays `Clone` (an experiment keeps the one failed attempt
//! to open the GPU and reports it for every run).

/// Why the GPU port could not open a device or render a scene.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum GpuError {
    /// wgpu found no adapter on Vulkan, Metal or DX12.
    #[error(
        "no GPU adapter found ({reason}); on Linux without a GPU, Mesa's software Vulkan \
         (lavapipe: Debian packages mesa-vulkan-drivers and libvulkan1, which \
         `make deps` installs) provides one"
    )]
    NoAdapter {
        /// wgpu's message.
        reason: String,
    },
    /// The adapter would not create a device.
    #[error("the GPU adapter {adapter} refused a device: {reason}")]
    Device {
        /// The adapter's name.
        adapter: String,
        /// wgpu's message.
        reason: String,
    },
    /// The scene's `max_depth` is above what the shader's stacks hold.
    #[error(
        "the GPU renders max_depth ≤ {limit} (its ray stacks are sized by it), and \
         this scene has max_depth {max_depth}; lower it or use --device cpu"
    )]
    MaxDepth {
        /// The scene's depth limit.
        max_depth: u32,
        /// The deepest the GPU takes ([`crate::upload::GPU_MAX_DEPTH`]).
        limit: u32,
    },
    /// The scene asks for a reconstruction filter other than the box.
    #[error(
        "the GPU film is the box filter (each pixel's own mean); the scene asks for the {filter} \
         filter: use --filter box or --device cpu"
    )]
    Filter {
        /// The filter's name.
        filter: String,
    },
    /// The adaptive sampler, which needs the image as it goes.
    #[error(
        "the adaptive sampler chooses its rays from the image as it goes, \
         which the GPU port does not do: use another sampler or --device cpu"
    )]
    AdaptiveSampler,
    /// The 8-wide tree, which the shader has no traversal for.
    #[error(
        "the GPU port has no 8-wide tree (`bvh` and `bvh8` name it); on the GPU \
         use --accel brute, bvh2, bvh:<volume>… or bvh4"
    )]
    Bvh8,
    /// A tree that lives inside another library (Embree, obvhs).
    #[error(
        "`{accel}` is a tree inside another library (Embree or obvhs) and cannot be \
         uploaded: the GPU port runs raylab's own trees; on the GPU use \
         --accel brute, bvh2, bvh:<volume>… or bvh4"
    )]
    ForeignTree {
        /// The accelerator's name.
        accel: String,
    },
    /// A buffer larger than the adapter allows.
    #[error(
        "{what} needs {bytes} bytes on the GPU, beyond the adapter's limit \
         (max_storage_buffer_binding_size {max_binding}, max_buffer_size {max_buffer}) on \
         {adapter}; render it with --device cpu"
    )]
    TooLarge {
        /// "the scene", "the film" or "the counters".
        what: &'static str,
        /// Bytes it needs.
        bytes: u64,
        /// The adapter's `max_storage_buffer_binding_size`.
        max_binding: u64,
        /// The adapter's `max_buffer_size`.
        max_buffer: u64,
        /// The adapter's name.
        adapter: String,
    },
    /// The shader did not pass validation or compile on the adapter.
    #[error("the GPU shader failed to build on {adapter}: {reason}")]
    Shader {
        /// The adapter's name.
        adapter: String,
        /// wgpu's message.
        reason: String,
    },
    /// Waiting for submitted work failed (a lost device, a timeout).
    #[error("waiting for the GPU ({adapter}): {reason}")]
    Wait {
        /// The adapter's name.
        adapter: String,
        /// wgpu's message.
        reason: String,
    },
    /// Copying results back to the host failed.
    #[error("reading back from the GPU: {reason}")]
    Readback {
        /// wgpu's message.
        reason: String,
    },
    /// Pixels whose shader invocation hit lavapipe's loop limit: their
    /// values would be wrong.
    #[error(
        "{pixels} pixels needed more than 65 000 loop iterations in one shader \
         invocation, and {adapter} ends an invocation's loops after 65 535 (its guard against \
         endless shaders), which would leave them wrong: use a BVH rather than brute \
         force over {primitives} primitives, a lower max_depth, or a hardware GPU"
    )]
    LoopLimit {
        /// Pixels that tripped the guard.
        pixels: usize,
        /// The adapter's name.
        adapter: String,
        /// Primitives the tree holds.
        primitives: u32,
    },
}
