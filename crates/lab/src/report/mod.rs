//! Reports: what the `raylab` commands print and write, built from the
//! library's results. Each command has a module here that does the
//! command's orchestration (load, run, measure, write the files) and
//! returns a report value that displays as the command's text output, so
//! that `crates/cli/src/main.rs` only parses arguments and dispatches:
//! [`render`] (`raylab render`), [`stats`] (`raylab stats`), [`diff`]
//! (`raylab diff`), [`grad`] (`raylab grad`), [`optimize`] (`raylab
//! optimize`), [`spectrum`] (`raylab spectrum`), [`experiment`]
//! (`raylab experiment`) and, with the `embree` feature, [`validate`]
//! (`raylab validate`).
//!
//! This is the top layer of the library: it may use every other module
//! (math → shape, stats → accel → scene → film, integrator, gi → io →
//! analysis → experiment, validate → report), and none of them uses it;
//! only the binary sits above it.

pub mod diff;
pub mod experiment;
pub mod grad;
pub mod optimize;
pub mod progress;
pub mod render;
pub mod spectrum;
pub mod stats;
#[cfg(feature = "embree")]
pub mod validate;

pub use diff::DiffReport;
pub use experiment::{ExperimentReport, MergeReport, PlotReport};
pub use render::{RenderOptions, RenderReport};
pub use spectrum::{SpectrumOptions, SpectrumReport};
pub use stats::StatsOptions;
#[cfg(feature = "embree")]
pub use validate::{ValidateOptions, ValidateReport};

use crate::Error;
use std::io::Write as _;

/// Write `text` to stdout; a reader that went away (`raylab diff … | head`)
/// is not an error.
pub fn print_stdout(text: &str) -> Result<(), Error> {
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(Error::Print(e)),
        _ => Ok(()),
    }
}
