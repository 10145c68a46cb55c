//! Study kinds: what one run of an experiment measures.
//!
//! The runner ([`super::run_experiment`]) knows nothing about rendering: it
//! expands the manifest's sweeps into runs and hands each run to the
//! [`Study`] named by the manifest's `kind`, which returns one row of
//! `data.csv`. A new kind of experiment (a BVH ladder, an anti-aliasing
//! error study, flood-fill convergence) is a new module here implementing
//! [`Study`], plus one line in [`find`] and [`KINDS`].

pub mod aa_images;
pub mod aa_patterns;
pub mod accel_cost;
pub mod accel_speed;
#[cfg(feature = "embree")]
pub mod embree_oracle;
pub mod floodfill;
pub mod gi_quality;
pub mod render_cost;

use super::data::Table;
use super::sweep::{RunPoint, Value};
use std::hint::black_box;
use std::path::Path;
use std::time::Instant;

/// Every study kind a manifest may name, in the order `--help` lists them.
pub const KINDS: &[&str] = &[
    "render_cost",
    "aa_images",
    "accel_cost",
    "accel_speed",
    #[cfg(feature = "embree")]
    "embree_oracle",
    "aa_patterns",
    "gi_quality",
    "floodfill",
];

/// The study for a manifest `kind`.
pub fn find(kind: &str) -> Option<&'static dyn Study> {
    match kind {
        "render_cost" => Some(&render_cost::RenderCost),
        "aa_images" => Some(&aa_images::AaImages),
        "accel_cost" => Some(&accel_cost::AccelCost),
        "accel_speed" => Some(&accel_speed::AccelSpeed),
        #[cfg(feature = "embree")]
        "embree_oracle" => Some(&embree_oracle::EmbreeOracle),
        "aa_patterns" => Some(&aa_patterns::AaPatterns),
        "gi_quality" => Some(&gi_quality::GiQuality),
        "floodfill" => Some(&floodfill::FloodFillStudy),
        _ => None,
    }
}

/// A parameter a study reads, with its one-line documentation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ParamDoc {
    /// The name used in `[fixed]` and `[[sweep]]` blocks.
    pub name: &'static str,
    /// What it means and what values it takes.
    pub doc: &'static str,
}

/// The experiment-wide settings a study sees.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StudySettings {
    /// Timed repeats of each measurement.
    pub repeats: u32,
    /// Untimed warm-up runs before the repeats.
    pub warmup: u32,
}

/// A run's parameters are wrong: which one (if one) and why. The runner
/// turns it into an error naming the manifest, line and column.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ParamError {
    /// The offending parameter, when the problem is one parameter.
    pub param: Option<String>,
    /// What is wrong.
    pub message: String,
}

impl ParamError {
    /// As an error for [`Study::run`]: "parameter `name`: message".
    pub fn into_error(self) -> anyhow::Error {
        match self.param {
            Some(p) => anyhow::anyhow!("parameter `{p}`: {}", self.message),
            None => anyhow::anyhow!("{}", self.message),
        }
    }

    /// A problem with parameter `name`.
    pub fn new(name: &str, message: impl Into<String>) -> Self {
        Self {
            param: Some(name.to_string()),
            message: message.into(),
        }
    }
}

/// What a run needs besides its parameters.
#[derive(Clone, Copy, Debug)]
pub struct RunContext<'a> {
    /// Relative paths in parameters are resolved against this folder (the
    /// manifest's).
    pub base_dir: &'a Path,
    /// The experiment's output folder, for studies that write per-run
    /// figures beside data.csv.
    pub out_dir: &'a Path,
    /// Repeats and warm-up.
    pub settings: StudySettings,
}

/// One row of `data.csv`: (column, value) pairs; the runner places them by
/// column name and leaves the parameter columns to itself.
pub type Row = Vec<(String, String)>;

/// One kind of experiment.
///
/// `run` is called inside the experiment's rayon thread pool, built once
/// with the experiment's thread count, so a study renders with
/// `threads = None` (the current pool) and thread start-up is not part of
/// its timings.
pub trait Study: Sync {
    /// The `kind` a manifest names it by.
    fn kind(&self) -> &'static str;

    /// The parameters it reads.
    fn parameters(&self) -> &'static [ParamDoc];

    /// The columns its rows fill, in order.
    fn columns(&self, settings: &StudySettings) -> Vec<String>;

    /// Check one run's parameters without running it (values parse, files
    /// exist), so that every run is checked before the first one starts.
    fn check(&self, run: &RunPoint, base_dir: &Path) -> Result<(), ParamError>;

    /// Perform one run and return its row.
    fn run(&self, run: &RunPoint, ctx: &RunContext<'_>) -> anyhow::Result<Row>;

    /// Figures the study draws itself after the sweep, beside the
    /// manifest's `[[figure]]`s, from `data.csv` (`table`, every row, so a
    /// resumed experiment redraws them all) and the per-run files its rows
    /// name in `out_dir`: for data a row cannot hold, such as a curve per
    /// run. Returns the stems written (each as PNG and SVG). None by
    /// default.
    fn figures(&self, _table: &Table, _out_dir: &Path) -> anyhow::Result<Vec<String>> {
        Ok(Vec::new())
    }
}

/// Times of repeated runs of one measurement: wall-clock time, which is
/// what a user waits (and what S1 reported), and the CPU time of the whole
/// process (every thread), which other programs on a shared machine
/// disturb far less: they can delay our threads but not add to their CPU
/// time. CPU time includes the few microseconds rayon's idle workers spin
/// before they sleep.
#[derive(Clone, Debug, PartialEq)]
pub struct Timings {
    /// Wall-clock seconds, one per repeat, in the order run.
    pub seconds: Vec<f64>,
    /// Process CPU seconds, one per repeat (NaN where the system cannot
    /// tell).
    pub cpu_seconds: Vec<f64>,
}

impl Timings {
    /// Call `f` `warmup` times untimed (to fill caches, fault in memory and
    /// let the CPU clock settle), then `repeats` times timed. Whatever `f`
    /// returns is dropped after its clock stops, so freeing a result is
    /// not part of the time.
    pub fn measure<T>(warmup: u32, repeats: u32, mut f: impl FnMut() -> T) -> Timings {
        for _ in 0..warmup {
            black_box(f());
        }
        let mut t = Timings {
            seconds: Vec::new(),
            cpu_seconds: Vec::new(),
        };
        for _ in 0..repeats {
            let cpu = process_cpu_seconds();
            let start = Instant::now();
            let out = f();
            t.seconds.push(start.elapsed().as_secs_f64());
            t.cpu_seconds.push(process_cpu_seconds() - cpu);
            drop(black_box(out));
        }
        t
    }

    /// The median wall-clock time; see [`median`].
    pub fn median(&self) -> f64 {
        median(&self.seconds)
    }

    /// The median CPU time; see [`median`].
    pub fn cpu_median(&self) -> f64 {
        median(&self.cpu_seconds)
    }

    /// The shortest repeat (NaN when there are none).
    pub fn min(&self) -> f64 {
        self.seconds
            .iter()
            .copied()
            .reduce(f64::min)
            .unwrap_or(f64::NAN)
    }

    /// The longest repeat (NaN when there are none).
    pub fn max(&self) -> f64 {
        self.seconds
            .iter()
            .copied()
            .reduce(f64::max)
            .unwrap_or(f64::NAN)
    }
}

/// The median (mean of the middle two for an even count); NaN when there
/// are no values. Medians are what raylab reports: one disturbed repeat
/// (another process, a page-fault storm) does not move them.
pub fn median(values: &[f64]) -> f64 {
    let mut s = values.to_vec();
    s.sort_by(f64::total_cmp);
    match s.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => s[n / 2],
        n => 0.5 * (s[n / 2 - 1] + s[n / 2]),
    }
}

/// CPU time used so far by every thread of this process, in seconds
/// (`CLOCK_PROCESS_CPUTIME_ID`, nanosecond resolution on Linux); NaN where
/// the system cannot tell.
pub fn process_cpu_seconds() -> f64 {
    #[cfg(unix)]
    {
        let mut ts = libc::timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        // SAFETY: clock_gettime only writes the timespec it is given, which
        // lives for the whole call.
        if unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut ts) } == 0 {
            return ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9;
        }
    }
    f64::NAN
}

/// Seconds as written to `data.csv`: nanosecond resolution, the resolution
/// of [`Instant`] on Linux.
pub fn seconds_cell(s: f64) -> String {
    format!("{s:.9}")
}

/// The string parameter `name` of a run, if it has one.
pub fn str_param<'a>(run: &'a RunPoint, name: &str) -> Result<Option<&'a str>, ParamError> {
    match run.get(name) {
        None => Ok(None),
        Some(Value::Str(s)) => Ok(Some(s)),
        Some(v) => Err(ParamError::new(
            name,
            format!("must be a string, got {} ({v})", v.type_name()),
        )),
    }
}

/// The integer parameter `name` of a run, if it has one, checked to lie in
/// `lo..=hi`.
pub fn int_param(run: &RunPoint, name: &str, lo: i64, hi: i64) -> Result<Option<i64>, ParamError> {
    match run.get(name) {
        None => Ok(None),
        Some(Value::Int(i)) if (lo..=hi).contains(i) => Ok(Some(*i)),
        Some(Value::Int(i)) => Err(ParamError::new(
            name,
            format!("must be in {lo}..={hi}, got {i}"),
        )),
        Some(v) => Err(ParamError::new(
            name,
            format!("must be an integer, got {} ({v})", v.type_name()),
        )),
    }
}

/// The numeric parameter `name` of a run (an integer or a float), if it
/// has one, checked to be finite and to lie in `lo..=hi`.
pub fn float_param(
    run: &RunPoint,
    name: &str,
    lo: f64,
    hi: f64,
) -> Result<Option<f64>, ParamError> {
    let Some(v) = run.get(name) else {
        return Ok(None);
    };
    match v.as_f64() {
        Some(x) if x.is_finite() && (lo..=hi).contains(&x) => Ok(Some(x)),
        _ if lo == f64::MIN && hi == f64::MAX => Err(ParamError::new(
            name,
            format!("must be a finite number, got {} ({v})", v.type_name()),
        )),
        _ => Err(ParamError::new(
            name,
            format!(
                "must be a number in [{lo}, {hi}], got {} ({v})",
                v.type_name()
            ),
        )),
    }
}

/// The boolean parameter `name` of a run, if it has one.
pub fn bool_param(run: &RunPoint, name: &str) -> Result<Option<bool>, ParamError> {
    match run.get(name) {
        None => Ok(None),
        Some(Value::Bool(b)) => Ok(Some(*b)),
        Some(v) => Err(ParamError::new(
            name,
            format!("must be true or false, got {} ({v})", v.type_name()),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cpu_time_advances_with_work() {
        let t0 = process_cpu_seconds();
        let mut x = 0u64;
        let start = Instant::now();
        while start.elapsed().as_millis() < 20 {
            x = black_box(x.wrapping_add(1));
        }
        // 20 ms of busy looping must show as some CPU time; how much depends
        // on how often a loaded machine kept this thread off the CPU.
        assert!(process_cpu_seconds() - t0 > 0.0, "{x}");
    }

    #[test]
    fn median_of_odd_and_even_counts() {
        let t = Timings {
            seconds: vec![3.0, 1.0, 2.0],
            cpu_seconds: vec![4.0, 1.0, 2.0, 3.0],
        };
        assert_eq!((t.median(), t.min(), t.max()), (2.0, 1.0, 3.0));
        assert_eq!(t.cpu_median(), 2.5);
        assert!(median(&[]).is_nan());
    }
}
