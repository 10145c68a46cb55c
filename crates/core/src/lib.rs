//! raylab's renderer core: everything needed to render a scene and
//! differentiate the image, and nothing to plot, tabulate or parse command
//! lines with (those are `raylab-lab` and the `raylab` binary).
//!
//! Data flows from a scene file ([`io::scene_file`]) to a [`scene::Scene`]
//! (camera, shapes, materials, lights, accelerator); a [`sampler`] places
//! samples in each pixel, the [`camera`] turns them into rays, an
//! [`integrator`] computes their colour using the [`accel`]erator's
//! intersection queries, and the [`film`] accumulates the result, which
//! [`io::image`] writes out. Every hot path reports into a [`stats`] sink.
//! [`diff`] differentiates images with respect to the scene's parameters.
//! With the `embree` feature, [`accel::embree`] puts Intel's Embree 4
//! behind the same interface as raylab's own trees.

pub mod accel;
pub mod camera;
pub mod diff;
pub mod error;
pub mod film;
pub mod gi;
pub mod integrator;
pub mod io;
pub mod light;
pub mod lighting;
pub mod material;
pub mod math;
pub mod sampler;
pub mod scene;
pub mod shading;
pub mod shape;
pub mod stats;
pub mod workload;

pub use error::{ParseError, RangeError};
