//! raylab: a toolkit for studying ray tracing. It renders, and it counts,
//! measures and plots what rendering costs and how noisy or wrong the
//! result is.
//!
//! Data flows from a scene file ([`io::scene_file`]) to a [`scene::Scene`]
//! (camera, shapes, materials, lights, accelerator); a [`sampler`] places
//! samples in each pixel, the [`camera`] turns them into rays, an
//! [`integrator`] computes their colour using the [`accel`]erator's
//! intersection queries, and the [`film`] accumulates the result, which
//! [`io::image`] writes out. Every hot path reports into a [`stats`] sink.
//! [`report`], the top layer, turns all this into what each `raylab`
//! command prints and writes; `src/main.rs` only parses arguments and
//! dispatches to it.
//! `validate` (with the `embree` feature) checks the intersection code
//! against Embree 4.

pub mod accel;
pub mod analysis;
pub mod camera;
pub mod diff;
pub mod experiment;
pub mod film;
pub mod gi;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod integrator;
pub mod io;
pub mod light;
pub mod lighting;
pub mod material;
pub mod math;
pub mod report;
pub mod sampler;
pub mod scene;
pub mod shading;
pub mod shape;
pub mod stats;
#[cfg(feature = "embree")]
pub mod validate;
pub mod workload;
