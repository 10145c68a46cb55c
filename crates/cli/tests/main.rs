//! The `raylab` command's integration tests, gathered into one binary: every
//! subcommand run as a user runs it (exit codes, messages, files written),
//! experiments, shards and merges, `raylab plot`, `optimize`, `spectrum`,
//! `stats`, and `--device gpu`; and the workspace's layering (`layers`).

use std::process::{Command, Output};

mod cli;
mod experiment;
#[cfg(feature = "gpu")]
mod gpu;
mod layers;
mod optimize;
mod redraw;
mod shard;
mod spectrum;
mod stats;

/// The `raylab` binary, run in the repository's root, which the tests'
/// paths (`data/scenes/…`, `analysis/…`) are relative to.
pub fn raylab_command() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_raylab"));
    c.current_dir(raylab_testkit::repo());
    c
}

/// `raylab ARGS…`, run to the end.
pub fn raylab(args: &[&str]) -> Output {
    raylab_command()
        .args(args)
        .output()
        .expect("running raylab")
}
