//! A mutation fuzzer for every reader of untrusted files: the OBJ, PLY, OFF
//! and 3DS mesh readers, the scene parser, the experiment-manifest parser
//! and the PNG and EXR readers that `raylab diff` uses. Plain `std` and the
//! library's own SplitMix64: no nightly compiler, no cargo-fuzz.
//!
//! Seeds are every real file of each format (the CGAL meshes, assimp's test
//! models including its deliberately broken ones, `tests/data/broken/`,
//! the shipped scenes and manifests, the PNGs in `tests/data/png/`) and small PNG and
//! EXR images made here in every pixel type and compression (`seeds`).
//! Each input is a seed, first as it is and then with one to four
//! mutations (`mutate`): bit flips, random bytes, truncation, duplicated
//! and deleted chunks, integers inflated to 4294967295, 10¹² or −1,
//! binary counts and 3DS chunk lengths set to huge values, splices of two
//! seeds, and numbers replaced by `nan`, `inf` or `1e39`.
//!
//! Every input must:
//!
//! - not panic (each runs under `catch_unwind`) and not abort;
//! - take at most 1 s (a slower one is run again, and fails if it is slow
//!   twice; one still running after 30 s is saved and the process aborts);
//! - allocate at most `k·len + c` bytes beyond what was allocated before
//!   it, measured by the counting global allocator installed below (`k`
//!   and `c` per reader, argued in `targets`); a single request over 1 GiB
//!   is not passed on at all: the input is saved and the process aborts;
//! - end in a result that passes the reader's checks (a mesh with indices
//!   in range and finite vertices) or an error that names the file.
//!
//! Failing inputs are saved, with their seed and mutations, under
//! `target/tmp/fuzz-crashes/` (or `$RAYLAB_FUZZ_CRASHES`), and the test
//! fails listing them. Replay one with
//! `RAYLAB_FUZZ_REPLAY=TARGET:FILE cargo test --test fuzz replay -- --ignored --nocapture`.
//!
//! # Running it
//!
//! ```sh
//! # the default budget (make test): ~10⁴ inputs, fixed seed, long seeds cut to 64 KiB
//! cargo test --test fuzz -- --nocapture
//! # the campaign: every real file whole, 10⁶ inputs per reader, one thread
//! cargo test --release --test fuzz -- --ignored campaign --nocapture --test-threads=1
//! # bounded in time, for some readers, another seed
//! RAYLAB_FUZZ_SECONDS=300 RAYLAB_FUZZ_TARGETS=ply,off RAYLAB_FUZZ_SEED=7 \
//!     cargo test --release --test fuzz -- --ignored campaign --nocapture
//! ```
//!
//! `RAYLAB_FUZZ_INPUTS=N` sets the inputs per reader (default budget or
//! campaign alike), `RAYLAB_FUZZ_SECONDS=T` stops each reader after T
//! seconds, `RAYLAB_FUZZ_TARGETS=obj,ply,off,3ds,scene,manifest,png,exr`
//! picks readers, `RAYLAB_FUZZ_SEED=S` changes the inputs.

mod fuzz {
    pub mod alloc;
    pub mod harness;
    pub mod mutate;
    pub mod seeds;
    pub mod targets;
}

use fuzz::{alloc, harness};
use harness::{run, Config, Summary};

#[global_allocator]
static ALLOCATOR: alloc::Counting = alloc::Counting;

/// The tests of this file run one at a time: the allocator's counters and
/// the panic hook are the process's.
static SERIAL: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn serial() -> std::sync::MutexGuard<'static, ()> {
    SERIAL.lock().unwrap_or_else(|e| e.into_inner())
}

/// Fail listing every failure (the summaries are printed as they come).
fn check(summaries: &[Summary]) {
    let inputs: u64 = summaries.iter().map(|s| s.inputs).sum();
    println!("fuzz: {inputs} inputs to {} readers", summaries.len());
    let failures: Vec<String> = summaries
        .iter()
        .flat_map(|s| {
            let more =
                (s.unsaved > 0).then(|| format!("{}: {} more failures", s.target, s.unsaved));
            s.failures
                .iter()
                .map(move |f| {
                    format!(
                        "{} {}: {}\n    saved as {}",
                        s.target,
                        f.kind,
                        f.what,
                        f.saved
                            .as_ref()
                            .map_or("(not saved)".into(), |p| p.display().to_string())
                    )
                })
                .chain(more)
        })
        .collect();
    assert!(
        failures.is_empty(),
        "{} failing inputs:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

/// The counting allocator sees what the test allocates. Other threads
/// (the test harness's, a finished input's watchdog) may free memory at
/// any moment, so the check is on totals, not on a delta from a reset:
/// after a 1 MiB allocation the count holds at least that, and the peak
/// at least the count.
fn allocator_counts() {
    alloc::reset_peak();
    let v = vec![1u8; 1 << 20];
    let now = alloc::current();
    assert!(now >= 1 << 20, "{now} bytes counted");
    assert!(alloc::peak() >= now);
    drop(v);
}

/// The default budget: about 10⁴ inputs in all, fixed seed.
#[test]
fn readers_survive_mutated_inputs() {
    let _serial = serial();
    allocator_counts();
    check(&run(&Config::from_env(false)));
}

/// The long campaign: every real file whole, 10⁶ inputs per reader (or
/// `RAYLAB_FUZZ_INPUTS`, `RAYLAB_FUZZ_SECONDS`).
#[test]
#[ignore = "long: run with --release -- --ignored campaign"]
fn campaign() {
    let _serial = serial();
    allocator_counts();
    check(&run(&Config::from_env(true)));
}

/// The inputs the fuzzer found problems with, minimised and committed in
/// `tests/data/fuzz/` (named `TARGET-what.EXT`), are handled now. They are
/// seeds of the fuzzer too.
#[test]
fn saved_inputs_are_handled() {
    let _serial = serial();
    let dir = raylab_testkit::repo().join("tests/data/fuzz");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .expect("tests/data/fuzz")
        .map(|e| e.expect("entry").path())
        .collect();
    files.sort();
    assert!(!files.is_empty());
    let scratch = tempfile::tempdir().expect("scratch folder");
    let mut failed = Vec::new();
    for file in files {
        let name = file
            .file_name()
            .expect("name")
            .to_string_lossy()
            .into_owned();
        let target = name.split('-').next().expect("TARGET-what.EXT");
        let bytes = std::fs::read(&file).expect("saved input");
        let (ok, text) = harness::replay(target, &bytes, scratch.path());
        println!("{name}: {text}");
        if !ok {
            failed.push(format!("{name}: {text}"));
        }
    }
    assert!(failed.is_empty(), "{}", failed.join("\n"));
}

/// Run one saved input: `RAYLAB_FUZZ_REPLAY=TARGET:FILE`.
#[test]
#[ignore = "replays RAYLAB_FUZZ_REPLAY=TARGET:FILE"]
fn replay() {
    let _serial = serial();
    let spec = std::env::var("RAYLAB_FUZZ_REPLAY").expect("set RAYLAB_FUZZ_REPLAY=TARGET:FILE");
    let (target, file) = spec
        .split_once(':')
        .expect("RAYLAB_FUZZ_REPLAY=TARGET:FILE");
    let bytes = std::fs::read(file).unwrap_or_else(|e| panic!("{file}: {e}"));
    let dir = tempfile::tempdir().expect("scratch folder");
    let (ok, text) = harness::replay(target, &bytes, dir.path());
    println!("{text}");
    assert!(ok, "{text}");
}
