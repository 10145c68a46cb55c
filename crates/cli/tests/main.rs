//! The `raylab` command's integration tests, gathered into one binary: every
//! subcommand run as a user runs it (exit codes, messages, files written),
//! experiments, shards and merges, `raylab plot`, `optimize`, `spectrum`,
//! `stats`, `--set` on `render` and `grad` (`set`), and `--device gpu`; and
//! the workspace's layering (`layers`).

use std::process::{Command, Output};

mod cli;
mod experiment;
#[cfg(feature = "gpu")]
mod gpu;
#[cfg(unix)]
mod hostile;
mod layers;
#[cfg(target_os = "linux")]
mod memory;
mod optimize;
mod redraw;
mod set;
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

/// What a finished command wrote to stderr, as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Writes `text` to `dir/name` (a test's scene or manifest); its path.
pub fn write(dir: &std::path::Path, name: &str, text: &str) -> std::path::PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// A small valid scene, 8×6 pixels: one lit grey sphere. The hostile-input
/// suite starts its cases from it, and the memory tests render it large.
pub const LIT_SPHERE: &str = r#"[image]
width = 8
height = 6
[camera]
eye = [0.0, 0.0, 5.0]
look_at = [0.0, 0.0, 0.0]
fov = 40.0
[materials.m]
color = [0.5, 0.5, 0.5]
[[sphere]]
center = [0.0, 0.0, 0.0]
radius = 1.0
material = "m"
[[light]]
position = [2.0, 2.0, 2.0]
"#;
