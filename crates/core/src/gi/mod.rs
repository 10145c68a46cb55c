//! Global illumination caches. So far S4's voxel flood fill: a scene is
//! voxelised ([`voxel`]), light is injected from emitters and directly lit
//! surfaces and spread through the empty voxels step by step
//! ([`floodfill`]), and a secondary ray's hit reads the irradiance back
//! instead of tracing further bounces.
//!
//! Typical use from an integrator:
//!
//! ```no_run
//! # fn demo(scene: &raylab::scene::Scene) -> Result<(), String> {
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
