//! The GPU adapter the GPU tests share, and their tolerance.
//!
//! **The tolerance.** The shader follows the CPU's order of operations,
//! but a GPU may fuse a·b + c into one rounding (WGSL allows it), and
//! Vulkan requires only 2.5 ulp for division and about 3 ulp for the
//! square root (the CPU's are correctly rounded), so rays differ from the
//! CPU's in the last bits of their directions and hit points (relative
//! 10⁻⁶ after a few operations). Colours are sums of a handful of terms of
//! size ≤ 1 with products of factors ≤ 1, so such differences move a pixel
//! by ~10⁻⁶; pow (the specular lobe) on a GPU is exp2(y·log2 x), accurate
//! to a few ulp relative to its result, i.e. ~10⁻⁶ again. 1e-4 is two
//! orders above that and far below a visible difference (one 8-bit level
//! is 4e-3). What rounding can change discretely — which primitive a ray
//! grazing an edge hits first, whether a shadow ray grazing an occluder is
//! blocked — is not a tolerance matter: such pixels are found by their
//! counters or their first hit differing between the devices, counted,
//! required to be rare and, for camera rays, shown to lie where two
//! primitives meet in the image.

use raylab_gpu::Gpu;
use std::sync::OnceLock;

/// The tolerance per pixel and channel, argued in the module docs.
pub const TOLERANCE: f32 = 1e-4;

/// The adapter, opened once for all tests; `None` only with RAYLAB_NO_GPU=1.
/// No adapter is a test failure, never a silent skip, unless
/// `RAYLAB_NO_GPU=1` says to skip on purpose.
pub fn gpu() -> Option<&'static Gpu> {
    static GPU: OnceLock<Option<Gpu>> = OnceLock::new();
    GPU.get_or_init(|| {
        if std::env::var("RAYLAB_NO_GPU").is_ok_and(|v| v == "1") {
            eprintln!("RAYLAB_NO_GPU=1: the GPU tests are skipped on purpose");
            return None;
        }
        let g = Gpu::new().unwrap_or_else(|e| {
            panic!("{e}\n(set RAYLAB_NO_GPU=1 to skip the GPU tests on purpose)")
        });
        eprintln!("GPU tests on {}", g.describe());
        Some(g)
    })
    .as_ref()
}
