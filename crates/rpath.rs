//! Build script of the crates that link binaries (tests, benchmarks, the
//! `raylab` command) against the core crate `raylab`: with its `embree`
//! feature on, that crate's build script hands on the folder holding
//! `libembree4` (`DEP_RAYLAB_EMBREE_LIB_DIR`, from its `links` key), and
//! this records it as the binaries' rpath, so they find Embree at run time
//! without `LD_LIBRARY_PATH`. A link argument of a dependency's build script
//! reaches only that dependency's own binaries, hence this second script.

fn main() {
    println!("cargo:rerun-if-env-changed=DEP_RAYLAB_EMBREE_LIB_DIR");
    if let Some(dir) = std::env::var_os("DEP_RAYLAB_EMBREE_LIB_DIR") {
        println!("cargo:rustc-link-arg=-Wl,-rpath,{}", dir.to_string_lossy());
    }
}
