//! raylab's laboratory: what turns renders into findings. Image metrics,
//! spectra and plots ([`analysis`]), raylab's intersections against Embree
//! 4's ([`validate`], with the `embree` feature), experiments and their
//! studies, sweeps, shards and figures ([`experiment`]), and what each
//! `raylab` command prints and writes ([`report`], the top layer: the
//! binary only parses arguments and dispatches to it).
//!
//! It builds on the renderer core, the crate `raylab`, and with the `gpu`
//! feature on `raylab-gpu`.

pub mod analysis;
pub mod experiment;
pub mod report;
#[cfg(feature = "embree")]
pub mod validate;
