//! The fuzzing loop: make inputs from seeds, run each under
//! `catch_unwind`, time it, measure its memory, and collect what went wrong.

use super::alloc;
use super::mutate::mutate;
use super::seeds::{seeds, Seed};
use super::targets::{allowance, bound, targets, triangles, Ctx, Target, Verdict, SCENE_TRIANGLES};
use raylab::math::SplitMix64;
use std::io::Write;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicPtr, AtomicU64, AtomicUsize, Ordering::SeqCst};
use std::sync::{Mutex, OnceLock, PoisonError};
use std::time::{Duration, Instant};

/// No input may take longer than this.
pub const SLOW: Duration = Duration::from_secs(1);

/// An input still running after this long is taken to hang: the watchdog
/// saves it and aborts the process.
const HANG: Duration = Duration::from_secs(30);

/// Failures saved per target and kind; more are counted, not saved.
const SAVED_PER_KIND: usize = 10;

/// How a run is set up.
pub struct Config {
    /// Take every real file whole (`false`: cut long seeds, see
    /// [`super::seeds::DEFAULT_SEED_BYTES`]).
    pub whole_seeds: bool,
    /// Inputs per target; `None`: each target's default budget.
    pub inputs: Option<u64>,
    /// Stop a target after this long, whatever `inputs` says.
    pub seconds: Option<f64>,
    /// The campaign's seed: the same seed gives the same inputs.
    pub seed: u64,
    /// Run only these targets (`None`: all).
    pub only: Option<Vec<String>>,
    /// Where failing inputs are saved.
    pub crash_dir: PathBuf,
}

impl Config {
    /// The budget `make test` runs; `RAYLAB_FUZZ_*` variables change it.
    pub fn from_env(campaign: bool) -> Config {
        let var = |name: &str| std::env::var(name).ok().filter(|v| !v.is_empty());
        let number = |name: &str| {
            var(name).map(|v| {
                v.replace('_', "")
                    .parse::<f64>()
                    .unwrap_or_else(|_| panic!("{name}={v}: not a number"))
            })
        };
        Config {
            whole_seeds: campaign,
            inputs: number("RAYLAB_FUZZ_INPUTS")
                .map(|n| n as u64)
                .or(campaign.then_some(1_000_000)),
            seconds: number("RAYLAB_FUZZ_SECONDS"),
            seed: number("RAYLAB_FUZZ_SEED").map_or(0x5EED_F022, |s| s as u64),
            only: var("RAYLAB_FUZZ_TARGETS")
                .map(|v| v.split(',').map(|s| s.trim().to_string()).collect()),
            crash_dir: var("RAYLAB_FUZZ_CRASHES").map_or_else(
                || PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("fuzz-crashes"),
                PathBuf::from,
            ),
        }
    }
}

/// One input that broke a rule.
pub struct Failure {
    pub kind: &'static str,
    pub what: String,
    pub saved: Option<PathBuf>,
}

/// What a target's run did.
pub struct Summary {
    pub target: &'static str,
    pub inputs: u64,
    pub accepted: u64,
    pub rejected: u64,
    pub skipped: u64,
    pub seconds: f64,
    pub slowest: (Duration, String),
    /// The highest peak as a fraction of its bound, with the input.
    pub tightest: (f64, String),
    pub failures: Vec<Failure>,
    /// Failures beyond the saved ones.
    pub unsaved: u64,
}

impl std::fmt::Display for Summary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "{:<8} {:>9} inputs ({} accepted, {} rejected, {} skipped) in {:.1} s: {:.0} inputs/s",
            self.target,
            self.inputs,
            self.accepted,
            self.rejected,
            self.skipped,
            self.seconds,
            self.inputs as f64 / self.seconds.max(1e-9)
        )?;
        writeln!(
            f,
            "         slowest {:.1} ms: {}",
            self.slowest.0.as_secs_f64() * 1e3,
            self.slowest.1
        )?;
        write!(
            f,
            "         highest memory {:.1} % of the bound: {}",
            self.tightest.0 * 100.0,
            self.tightest.1
        )
    }
}

// What the allocator and the watchdog need to save the running input.
static INPUT_PTR: AtomicPtr<u8> = AtomicPtr::new(std::ptr::null_mut());
static INPUT_LEN: AtomicUsize = AtomicUsize::new(0);
/// Held while [`run_one`] publishes or withdraws the input (`INPUT_PTR`,
/// `INPUT_LEN`), and by [`save_current_and_abort`] from its reading of
/// them until the abort: so the saver sees the pair of one input, and that
/// input's buffer stays alive while it is saved (the watchdog may fire just
/// as the input ends: its run cannot end until the lock is released, which
/// the abort never does).
static INPUT_LOCK: Mutex<()> = Mutex::new(());
static INPUT_DESC: Mutex<String> = Mutex::new(String::new());
static INPUT_EXT: Mutex<&str> = Mutex::new("bin");
static STARTED_MS: AtomicU64 = AtomicU64::new(0);
static CRASH_DIR: OnceLock<PathBuf> = OnceLock::new();
static PANIC: Mutex<Option<String>> = Mutex::new(None);

fn epoch() -> Instant {
    static EPOCH: OnceLock<Instant> = OnceLock::new();
    *EPOCH.get_or_init(Instant::now)
}

/// Save the input being run and abort: for what cannot be caught (an
/// allocation the machine should never be asked for, a hang).
pub fn save_current_and_abort(why: &str) -> ! {
    let _input = INPUT_LOCK.lock().unwrap_or_else(PoisonError::into_inner);
    let len = INPUT_LEN.load(SeqCst);
    let ptr = INPUT_PTR.load(SeqCst);
    let desc = INPUT_DESC.try_lock().map(|d| d.clone()).unwrap_or_default();
    let ext = INPUT_EXT.try_lock().map(|e| *e).unwrap_or("bin");
    let mut saved = String::from("(no input running)");
    if !ptr.is_null() {
        // SAFETY: a non-null `ptr` with `len` is the buffer of the input
        // `run_one` is running, published and withdrawn under `INPUT_LOCK`,
        // which this function holds: the pair is one input's, and its
        // `bytes: &[u8]` stays borrowed (alive, unchanged) until `run_one`
        // withdraws it, which waits for the lock this function never
        // releases.
        let bytes = unsafe { std::slice::from_raw_parts(ptr, len) };
        if let Some(dir) = CRASH_DIR.get() {
            let path = dir.join(format!("abort.{ext}"));
            let _ = std::fs::create_dir_all(dir);
            if std::fs::write(&path, bytes).is_ok() {
                let _ = std::fs::write(path.with_extension("txt"), format!("{why}\n{desc}\n"));
                saved = format!("saved as {}", path.display());
            }
        }
    }
    // Not `eprintln!`, which panics when stderr is closed: this runs inside
    // the global allocator, which must not unwind.
    let _ = writeln!(
        std::io::stderr(),
        "\nfuzz: {why}\n  input: {desc}\n  {saved}"
    );
    std::process::abort()
}

/// Run every target under `config`; returns the summaries. Failures are
/// saved under `config.crash_dir` as they happen.
pub fn run(config: &Config) -> Vec<Summary> {
    let _ = CRASH_DIR.set(config.crash_dir.clone());
    epoch();
    set_cap_from_env();
    // One thread: a scene's BVH build would otherwise use every core.
    let _ = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build_global();
    let scratch = tempfile::tempdir().expect("scratch folder");
    let ctx = context(scratch.path());
    let stop = std::sync::Arc::new(AtomicBool::new(false));
    let watchdog = {
        let stop = stop.clone();
        std::thread::spawn(move || {
            while !stop.load(SeqCst) {
                std::thread::park_timeout(Duration::from_millis(500));
                let started = STARTED_MS.load(SeqCst);
                let now = epoch().elapsed().as_millis() as u64;
                if started != 0 && now.saturating_sub(started) > HANG.as_millis() as u64 {
                    save_current_and_abort(&format!(
                        "an input has run for more than {} s",
                        HANG.as_secs()
                    ));
                }
            }
        })
    };
    let previous_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|info| {
        let backtrace = std::backtrace::Backtrace::force_capture();
        if let Ok(mut p) = PANIC.lock() {
            *p = Some(format!("{info}\n{backtrace}"));
        }
    }));
    let summaries = targets()
        .iter()
        .filter(|t| {
            config
                .only
                .as_ref()
                .is_none_or(|only| only.iter().any(|o| o == t.name))
        })
        .map(|t| {
            // Print as each reader finishes, so that a campaign cut short
            // still reports the readers it completed.
            let s = run_target(t, config, &ctx);
            println!("{s}");
            s
        })
        .collect();
    std::panic::set_hook(previous_hook);
    stop.store(true, SeqCst);
    watchdog.thread().unpark();
    watchdog.join().expect("watchdog");
    summaries
}

/// `RAYLAB_FUZZ_HARD_CAP=BYTES`: a lower cap on single allocations.
fn set_cap_from_env() {
    if let Ok(v) = std::env::var("RAYLAB_FUZZ_HARD_CAP") {
        alloc::set_cap(v.parse().expect("RAYLAB_FUZZ_HARD_CAP=BYTES"));
    }
}

/// The scratch tree: `meshes/cube.obj` beside `scenes/`, for the scenes'
/// `../meshes/cube.obj`.
fn context(dir: &Path) -> Ctx {
    let root = raylab_testkit::repo();
    for sub in ["scenes", "meshes", "analysis"] {
        std::fs::create_dir_all(dir.join(sub)).expect("scratch folder");
    }
    std::fs::copy(
        root.join("data/meshes/cube.obj"),
        dir.join("meshes/cube.obj"),
    )
    .expect("copy cube.obj");
    Ctx {
        dir: dir.to_path_buf(),
        scene_path: dir.join("scenes/fuzz.toml"),
        manifest_path: dir.join("analysis/fuzz.toml"),
    }
}

/// Seeds picked with weight 1/(1 + size/16 KiB): every file is used, the
/// megabyte meshes a hundred times less often than the small ones, so that
/// they do not take the whole time.
struct Picker {
    cumulative: Vec<f64>,
}

impl Picker {
    fn new(seeds: &[Seed]) -> Picker {
        let mut total = 0.0;
        let cumulative = seeds
            .iter()
            .map(|s| {
                total += 1.0 / (1.0 + s.bytes.len() as f64 / 16384.0);
                total
            })
            .collect();
        Picker { cumulative }
    }

    fn pick(&self, rng: &mut SplitMix64) -> usize {
        let total = *self.cumulative.last().expect("seeds");
        let u = (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64 * total;
        self.cumulative
            .partition_point(|&c| c <= u)
            .min(self.cumulative.len() - 1)
    }
}

fn run_target(t: &Target, config: &Config, ctx: &Ctx) -> Summary {
    let seeds = seeds(t.name, config.whole_seeds, &ctx.dir);
    assert!(!seeds.is_empty(), "{}: no seeds", t.name);
    let picker = Picker::new(&seeds);
    let inputs = config.inputs.unwrap_or(t.default_inputs);
    let deadline = config.seconds.map(Duration::from_secs_f64);
    *INPUT_EXT.lock().expect("ext") = t.ext;
    let mut s = Summary {
        target: t.name,
        inputs: 0,
        accepted: 0,
        rejected: 0,
        skipped: 0,
        seconds: 0.0,
        slowest: (Duration::ZERO, String::new()),
        tightest: (0.0, String::new()),
        failures: Vec::new(),
        unsaved: 0,
    };
    let target_key = t
        .name
        .bytes()
        .fold(0u64, |h, b| SplitMix64::mix(h ^ u64::from(b)));
    let start = Instant::now();
    for i in 0..inputs {
        if deadline.is_some_and(|d| start.elapsed() > d) {
            break;
        }
        let mut rng = SplitMix64(SplitMix64::mix(config.seed ^ target_key) ^ i);
        // First every seed as it is, then mutants.
        let unmodified = (i as usize) < seeds.len();
        let (bytes, desc) = if unmodified {
            let seed = &seeds[i as usize];
            (seed.bytes.clone(), format!("{} (unmodified)", seed.name))
        } else {
            let seed = &seeds[picker.pick(&mut rng)];
            let other = &seeds[picker.pick(&mut rng)];
            let m = mutate(&mut rng, &seed.bytes, &other.bytes);
            let desc = format!(
                "input {i} of target {} (seed {:#x}): {} mutated by {}{}",
                t.name,
                config.seed,
                seed.name,
                m.recipe.join("; "),
                if m.recipe.iter().any(|r| r.starts_with("splice")) {
                    format!(" (other seed: {})", other.name)
                } else {
                    String::new()
                }
            );
            (m.bytes, desc)
        };
        s.inputs += 1;
        // A scene that asks for many procedural triangles is a request for
        // work: its mutants are skipped; the seed itself runs in the
        // campaign, without the time limit (see SCENE_TRIANGLES).
        let triangles = triangles(t, &bytes);
        let heavy = triangles > SCENE_TRIANGLES;
        if heavy && !(unmodified && config.whole_seeds) {
            s.skipped += 1;
            continue;
        }
        let extra = allowance(triangles);
        let (verdict, elapsed, used) = run_one(t, ctx, &bytes, &desc);
        let mut failed: Vec<(&'static str, String)> = Vec::new();
        let mut fail = |kind: &'static str, what: String| failed.push((kind, what));
        match verdict {
            Err(panic) => fail("panic", short_backtrace(&panic)),
            Ok(Verdict::Accepted) => s.accepted += 1,
            Ok(Verdict::Rejected) => s.rejected += 1,
            Ok(Verdict::Broken(why)) => fail("broken", why),
        }
        if elapsed > SLOW && !heavy {
            // Once more, in case the machine was busy: the faster run counts.
            let (_, again, _) = run_one(t, ctx, &bytes, &desc);
            if again > SLOW {
                let ms = elapsed.min(again).as_millis();
                fail(
                    "slow",
                    format!("took {ms} ms (limit {} ms)", SLOW.as_millis()),
                );
            }
        }
        let limit = bound(t, bytes.len(), extra);
        if used as u64 > limit {
            fail(
                "memory",
                format!(
                    "allocated up to {used} bytes for a {}-byte input (bound {limit} = {}·len + {} + allowance {extra})",
                    bytes.len(),
                    t.k,
                    t.c
                ),
            );
        }
        for (kind, what) in failed {
            record(t, config, &mut s, kind, &bytes, &desc, what);
        }
        if elapsed > s.slowest.0 && !heavy {
            s.slowest = (elapsed, desc.clone());
        }
        let fraction = used as f64 / limit as f64;
        if fraction > s.tightest.0 {
            s.tightest = (
                fraction,
                format!("{used} bytes for {} bytes in: {desc}", bytes.len()),
            );
        }
    }
    s.seconds = start.elapsed().as_secs_f64();
    s
}

/// Run one input: its verdict (or the panic), its time and the bytes it
/// allocated beyond what was allocated before it.
fn run_one(
    t: &Target,
    ctx: &Ctx,
    bytes: &[u8],
    desc: &str,
) -> (Result<Verdict, String>, Duration, usize) {
    if let Ok(mut d) = INPUT_DESC.lock() {
        d.clear();
        d.push_str(desc);
    }
    {
        let _publishing = INPUT_LOCK.lock().unwrap_or_else(PoisonError::into_inner);
        INPUT_LEN.store(bytes.len(), SeqCst);
        INPUT_PTR.store(bytes.as_ptr() as *mut u8, SeqCst);
    }
    STARTED_MS.store(epoch().elapsed().as_millis() as u64 + 1, SeqCst);
    let before = alloc::reset_peak();
    let t0 = Instant::now();
    let result = catch_unwind(AssertUnwindSafe(|| (t.run)(bytes, ctx)));
    let elapsed = t0.elapsed();
    let used = alloc::peak().saturating_sub(before);
    STARTED_MS.store(0, SeqCst);
    {
        let _withdrawing = INPUT_LOCK.lock().unwrap_or_else(PoisonError::into_inner);
        INPUT_PTR.store(std::ptr::null_mut(), SeqCst);
    }
    let result = result.map_err(|_| {
        PANIC
            .lock()
            .ok()
            .and_then(|mut p| p.take())
            .unwrap_or_else(|| "panicked (no message)".into())
    });
    (result, elapsed, used)
}

/// Count a failure and save the input and its description (the first
/// [`SAVED_PER_KIND`] of each kind per target).
fn record(
    t: &Target,
    config: &Config,
    s: &mut Summary,
    kind: &'static str,
    bytes: &[u8],
    desc: &str,
    what: String,
) {
    let same = s.failures.iter().filter(|f| f.kind == kind).count();
    if same >= SAVED_PER_KIND {
        s.unsaved += 1;
        return;
    }
    let dir = &config.crash_dir;
    let stem = format!("{}-{kind}-{}", t.name, same);
    let path = dir.join(format!("{stem}.{}", t.ext));
    let saved = std::fs::create_dir_all(dir)
        .and_then(|()| std::fs::write(&path, bytes))
        .and_then(|()| {
            std::fs::write(
                dir.join(format!("{stem}.txt")),
                format!("{kind}: {what}\n\ninput: {desc}\n"),
            )
        })
        .is_ok();
    s.failures.push(Failure {
        kind,
        what: format!("{what}\n    input: {desc}"),
        saved: saved.then_some(path),
    });
}

/// Run one input through the target named `name`: what happened, and
/// whether it kept every rule (no panic, a clean verdict, within the time
/// and memory bounds).
pub fn replay(name: &str, bytes: &[u8], dir: &Path) -> (bool, String) {
    let _ = CRASH_DIR.set(dir.to_path_buf());
    set_cap_from_env();
    let targets = targets();
    let t = targets
        .iter()
        .find(|t| t.name == name)
        .unwrap_or_else(|| panic!("no target `{name}`"));
    let ctx = context(dir);
    let triangles = triangles(t, bytes);
    let (verdict, elapsed, used) = run_one(t, &ctx, bytes, "replayed input");
    let limit = bound(t, bytes.len(), allowance(triangles));
    let (clean, verdict) = match verdict {
        Err(panic) => (false, format!("panicked: {panic}")),
        Ok(Verdict::Accepted) => (true, "accepted".into()),
        Ok(Verdict::Rejected) => (true, "rejected with an error naming the file".into()),
        Ok(Verdict::Broken(why)) => (false, format!("broke a rule: {why}")),
    };
    let ok = clean && (elapsed <= SLOW || triangles > SCENE_TRIANGLES) && used as u64 <= limit;
    let text = format!(
        "{name}: {verdict}; {:.1} ms; allocated up to {used} bytes (bound {limit})",
        elapsed.as_secs_f64() * 1e3,
    );
    (ok, text)
}

/// A panic report cut down to its message and the frames between the
/// panic machinery and the harness: where in the reader it happened.
fn short_backtrace(report: &str) -> String {
    let mut lines = report.lines();
    let mut out: Vec<&str> = Vec::new();
    for line in lines.by_ref() {
        if line.trim_start().starts_with("0:") {
            break;
        }
        out.push(line);
    }
    let boring = [
        "std::",
        "core::",
        "alloc::",
        "<alloc::",
        "<core::",
        "__rustc",
        "rust_begin_unwind",
        "fuzz::harness",
        "test::",
    ];
    let mut frames = 0;
    let mut keep_location = false;
    for line in lines {
        let t = line.trim_start();
        if t.starts_with("at ") {
            if keep_location {
                out.push(line);
            }
            continue;
        }
        let function = t.split_once(": ").map_or(t, |(_, f)| f);
        if function.contains("run_one") {
            break;
        }
        keep_location = !boring.iter().any(|b| function.starts_with(b));
        if keep_location {
            out.push(line);
            frames += 1;
            if frames == 12 {
                break;
            }
        }
    }
    out.join("\n")
}
