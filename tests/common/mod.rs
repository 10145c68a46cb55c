//! Helpers shared by the integration tests (each test file includes this
//! module with `mod common;`; not every file uses every item).
#![allow(dead_code, unused_imports)]

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
