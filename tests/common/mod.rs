//! Helpers shared by the integration tests (each test file includes this
//! module with `mod common;`; not every file uses every item).
#![allow(dead_code, unused_imports)]

pub mod experiment;
pub mod meshes;

/// The library's generator, shared by the tests.
pub use raylab::math::SplitMix64;

/// A path under `data/external/`, after checking that the set-up ran.
pub fn external(relative: &str) -> std::path::PathBuf {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("data/external");
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
