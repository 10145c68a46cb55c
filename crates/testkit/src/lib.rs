//! Helpers shared by the integration tests of raylab's crates (each test
//! binary names this crate `common`): paths into the repository, the real
//! meshes as primitives and the rays traced through them, a tiny experiment.

// No unsafe code here, and none to come: the workspace's unsafe lives in
// `raylab`, each block with its SAFETY argument.
#![forbid(unsafe_code)]

pub mod experiment;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod meshes;

/// The library's generator, shared by the tests.
pub use raylab::math::SplitMix64;

use std::path::{Path, PathBuf};

/// The repository's root (the workspace's), which the tests' paths into
/// `data/`, `analysis/` and `tests/data/` are relative to: cargo runs each
/// crate's tests in that crate's own folder.
pub fn repo() -> &'static Path {
    let testkit = Path::new(env!("CARGO_MANIFEST_DIR"));
    // crates/testkit → crates → the root.
    testkit
        .parent()
        .and_then(Path::parent)
        .expect("the testkit crate lies two folders below the root")
}

/// `relative` (such as `data/scenes/cornell-box.toml`) under the repository's root.
pub fn repo_path(relative: &str) -> PathBuf {
    repo().join(relative)
}

/// A path under `data/external/`, after checking that the set-up ran.
pub fn external(relative: &str) -> PathBuf {
    let root = repo_path("data/external");
    assert!(
        root.join(".complete").is_file(),
        "{} is missing or incomplete: run scripts/fetch-data (make test does)",
        root.display()
    );
    root.join(relative)
}

/// The white furnace: a closed sphere of albedo a = 0.8 and emission
/// L_e = 0.2 seen from its centre, `size`² pixels at 64 random samples per
/// pixel. Every pixel's radiance is L_e/(1 − a) = 1.
pub fn furnace_scene(size: u32) -> String {
    format!(
        r#"
[image]
width = {size}
height = {size}
[camera]
eye = [0.0, 0.0, 0.0]
look_at = [0.0, 0.0, -1.0]
fov = 90.0
[render]
sampler = "random:64"
[materials.wall]
color = [0.8, 0.8, 0.8]
diffuse = 1.0
ambient = 0.0
emission = [0.2, 0.2, 0.2]
[[sphere]]
center = [0.0, 0.0, 0.0]
radius = 1.0
material = "wall"
"#
    )
}
