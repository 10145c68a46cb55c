//! Global illumination caches. So far S4's voxel flood fill: a scene is
//! voxelised ([`voxel`]), light is injected from emitters and directly lit
//! surfaces and spread through the empty voxels step by step
//! ([`floodfill`]), and a secondary ray's hit reads the irradiance back
//! instead of tracing further bounces.
//!
//! Typical use from an integrator:
//!
//! ```no_run
//! # fn demo(scene: &raylab::scene::Scene) -> Result<(), raylab::gi::GiError> {
//! use raylab::gi::{FloodFill, FloodFillConfig, GridSpec, Lookup, Threads};
//! use raylab::gi::DEFAULT_WALL_LIGHT_SAMPLES;
//! let (spec, config) = (GridSpec::new(64), FloodFillConfig::default());
//! let mut cache = FloodFill::from_scene(scene, &spec, config, DEFAULT_WALL_LIGHT_SAMPLES)?;
//! for _ in 0..200 {
//!     cache.step(Threads::Pool);
//! }
//! # let (p, n, albedo) = (glam::Vec3::ZERO, glam::Vec3::Y, glam::Vec3::ONE);
//! // At the first bounce's hit (p, n): outgoing = albedo × cached light.
//! let radiance = albedo * cache.lookup(p, n, Lookup::Hemisphere, [0.3, 0.7, 0.5]);
//! # let _ = radiance; Ok(()) }
//! ```

pub mod floodfill;
pub mod voxel;

pub use floodfill::{
    wall_light, Averaging, FloodFill, FloodFillConfig, Lookup, Residual, Threads,
    DEFAULT_WALL_LIGHT_SAMPLES, GAMMA, S4_ALPHA,
};
pub use voxel::{GridSpec, VoxelGrid, VoxelKind};

use crate::error::RangeError;

/// Why a flood-fill cache could not be built: a grid that cannot be laid
/// over the scene, or settings out of range.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum GiError {
    /// A grid resolution of 0 or above [`voxel::MAX_RESOLUTION`].
    #[error("grid resolution must be in 1..={max}, got {given}")]
    Resolution {
        /// The resolution asked for.
        given: usize,
        /// The largest accepted.
        max: usize,
    },
    /// No box to lay the grid over: no bounded primitive and no box given.
    #[error("the scene has no bounded primitive: give the grid a box")]
    NoBounds,
    /// A grid box of zero size.
    #[error("the grid box has zero size")]
    EmptyBox,
    /// A setting of [`FloodFillConfig`] out of range.
    #[error(transparent)]
    Config(#[from] RangeError),
    /// A grid larger than this machine's memory.
    #[error(transparent)]
    Memory(#[from] crate::film::memory::MemoryError),
}
