//! Build script: with the `embree` feature on, point the linker at the
//! Embree 4 that `scripts/install-embree` (run by `make deps`) unpacked into
//! `.deps/embree/lib`, and record that folder as an rpath so binaries, tests
//! and benchmarks find `libembree4` at run time without `LD_LIBRARY_PATH`.
//!
//! `embree4-sys` itself only asks for `-lembree4` and generates its bindings
//! from the Embree headers it bundles; where the library lives is ours to
//! say. `RAYLAB_EMBREE_LIB_DIR` overrides the folder (any folder holding a
//! `libembree4.so` of Embree 4, e.g. a system install).
//!
//! The link search path reaches every crate that links against this one;
//! the rpath (a link argument) reaches only this crate's own tests and
//! benchmarks. So the folder is also handed on as `lib_dir` (this package's
//! `links` key makes it `DEP_RAYLAB_EMBREE_LIB_DIR` in the build scripts of
//! the crates that depend on it), and `crates/rpath.rs`, their build
//! script, records it as their binaries' rpath.

use std::env;
use std::path::PathBuf;

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-env-changed=RAYLAB_EMBREE_LIB_DIR");
    if env::var_os("CARGO_FEATURE_EMBREE").is_none() {
        return;
    }

    // crates/core → the repository's root, where `make deps` installs.
    let manifest_dir = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").unwrap_or_default());
    let root = manifest_dir.join("../..");
    let (lib_dir, from_env) = match env::var_os("RAYLAB_EMBREE_LIB_DIR") {
        Some(dir) if !dir.is_empty() => (PathBuf::from(dir), true),
        _ => (root.join(".deps/embree/lib"), false),
    };
    // Rerun when the install changes (the stamp is rewritten by every
    // install; a missing path makes Cargo rerun us on every build, which is
    // what we want until it exists).
    let watched = if from_env {
        lib_dir.join("libembree4.so")
    } else {
        root.join(".deps/embree/.complete")
    };
    println!("cargo:rerun-if-changed={}", watched.display());

    let library = lib_dir.join("libembree4.so");
    if !library.exists() {
        let how = if from_env {
            format!(
                "RAYLAB_EMBREE_LIB_DIR is set to {} but it holds no libembree4.so",
                lib_dir.display()
            )
        } else {
            format!(
                "Embree 4 is not installed in {}",
                root.join(".deps/embree")
                    .canonicalize()
                    .unwrap_or(root.join(".deps/embree"))
                    .display()
            )
        };
        // A build script reports errors on stderr and by its exit status;
        // Cargo shows both. No panic: this is a set-up problem, not a bug.
        eprintln!(
            "\nerror: {how}.\n\
             The `embree` feature (on by default) links Embree 4. Install it with\n\
             \n    make deps          (or: scripts/install-embree)\n\
             \nor build without Embree: cargo build --no-default-features\n"
        );
        std::process::exit(1);
    }

    // Absolute, so it stays valid wherever the binary is run from (but not
    // if the checkout moves: then rebuild).
    let lib_dir = lib_dir.canonicalize().unwrap_or(lib_dir);
    println!("cargo:rustc-link-search=native={}", lib_dir.display());
    println!("cargo:rustc-link-arg=-Wl,-rpath,{}", lib_dir.display());
    println!("cargo:lib_dir={}", lib_dir.display());
}
