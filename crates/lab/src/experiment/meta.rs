//! `meta.json`: what an experiment ran and where, so its numbers can be
//! traced and repeated (ARCHITECTURE.md, "Determinism").
//!
//! It records the manifest as run (after `--quick`), the raylab version,
//! the git revision and whether the work tree had changes, the CPU model,
//! the thread count, whether the binary was optimised, the UTC start and
//! end times, the wall time, and what the runs and figures came to. It is
//! written when the experiment starts (`"complete": false`) and again when
//! it ends.

use super::{parse_manifest, Manifest};
use crate::{Error, FileOp};
use raylab::io::{write_atomically, InputError};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{SystemTime, UNIX_EPOCH};

/// The file name of the record inside an experiment's output folder.
pub const META_FILE: &str = "meta.json";

/// The mean of one series of a ratio figure.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SeriesMean {
    /// The series' legend text.
    pub label: String,
    /// Mean of its finite values.
    pub mean: f64,
    /// How many values were averaged.
    pub count: usize,
    /// Measured (true) or a reference given in the manifest (false).
    pub measured: bool,
}

/// The means of a ratio figure's series: the measured ones beside the
/// references (e.g. raylab's mean T beside S1's published 3.32).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RatioSummary {
    /// The figure's file stem.
    pub figure: String,
    /// What the ratio is (the figure's y label).
    pub label: String,
    /// Measured series first, then the references.
    pub series: Vec<SeriesMean>,
}

/// Everything `meta.json` holds.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Meta {
    /// The experiment's name.
    pub name: String,
    /// The study kind.
    pub kind: String,
    /// The manifest as run, parameters expanded.
    pub manifest: serde_json::Value,
    /// [`super::shard::manifest_hash`] of the manifest's text and `--quick`:
    /// equal for every shard of one experiment.
    #[serde(default)]
    pub manifest_hash: String,
    /// The manifest file as written, from which `raylab merge` rebuilds the
    /// plan and draws the figures.
    #[serde(default)]
    pub manifest_text: String,
    /// The shard this folder holds (`--shard I/N`), or null for a whole run
    /// or a merge.
    #[serde(default)]
    pub shard: Option<super::shard::Shard>,
    /// A merge's shards: where each ran and what it did (empty otherwise).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub shards: Vec<ShardRecord>,
    /// The machine's host name.
    #[serde(default)]
    pub host: String,
    /// `CARGO_PKG_VERSION` of the raylab that ran it.
    pub raylab_version: String,
    /// `git rev-parse HEAD` in the manifest's folder, or "unknown".
    pub git_revision: String,
    /// Whether `git status --porcelain` listed changes (null when git
    /// could not tell).
    pub git_dirty: Option<bool>,
    /// `model name` from /proc/cpuinfo, or "unknown".
    pub cpu_model: String,
    /// Logical CPUs the operating system offers.
    pub logical_cpus: usize,
    /// Worker threads the renders used.
    pub threads: usize,
    /// The device the runs traced on besides the CPU (a GPU adapter:
    /// name, back end, driver, type, and whether it is a software one);
    /// absent for CPU-only studies.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub device: Option<String>,
    /// False for a build with debug assertions: its timings mean little.
    pub optimised: bool,
    /// UTC start, ISO 8601.
    pub started_utc: String,
    /// UTC end, ISO 8601 (null while running or after a failure).
    pub finished_utc: Option<String>,
    /// Seconds from start to end of this invocation.
    pub wall_time_s: f64,
    /// Whether `--quick` was given.
    pub quick: bool,
    /// Whether `--resume` was given.
    pub resumed: bool,
    /// Runs in the plan.
    pub runs_total: usize,
    /// Runs found finished in `data.csv` and skipped (`--resume`).
    pub runs_skipped: usize,
    /// Runs performed by this invocation.
    pub runs_done: usize,
    /// Whether every run finished and every figure was drawn.
    pub complete: bool,
    /// The figures written (file stems).
    pub figures: Vec<String>,
    /// Means of the ratio figures.
    pub summary: Vec<RatioSummary>,
}

/// One shard of a merged experiment, as its own `meta.json` recorded it.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ShardRecord {
    /// Which shard.
    pub shard: super::shard::Shard,
    /// The folder it was merged from.
    pub dir: String,
    /// Its machine: host name and CPU model.
    pub host: String,
    /// CPU model.
    pub cpu_model: String,
    /// Logical CPUs of its machine.
    pub logical_cpus: usize,
    /// Worker threads it used.
    pub threads: usize,
    /// Whether its binary was optimised.
    pub optimised: bool,
    /// Its git revision.
    pub git_revision: String,
    /// UTC start, ISO 8601.
    pub started_utc: String,
    /// UTC end (null when it did not finish).
    pub finished_utc: Option<String>,
    /// Its wall time in seconds.
    pub wall_time_s: f64,
    /// Rows it contributed.
    pub rows: usize,
    /// Whether it finished every run it was dealt.
    pub complete: bool,
}

impl Meta {
    /// Read `dir/meta.json`.
    pub fn read(dir: &Path) -> Result<Meta, Error> {
        let path = dir.join(META_FILE);
        let text =
            raylab::io::input::read_to_string(&path, raylab::io::input::InputKind::Manifest)?;
        serde_json::from_str(&text).map_err(|error| Error::Meta { path, error })
    }

    /// Write `dir/meta.json` (pretty-printed, atomically).
    pub fn write(&self, dir: &Path) -> Result<(), Error> {
        let path = dir.join(META_FILE);
        let text = serde_json::to_string_pretty(self).map_err(|error| Error::Json {
            what: META_FILE,
            error,
        })?;
        write_atomically(&path, |tmp| {
            std::fs::write(tmp, text + "\n").map_err(|e| Error::io(&path, FileOp::Write, e))
        })
    }
}

/// A git revision and whether the work tree had changes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GitRevision {
    /// The commit hash, or "unknown".
    pub revision: String,
    /// Whether the work tree had changes (`None`: unknown).
    pub dirty: Option<bool>,
}

/// The git revision of the repository holding `dir`, and whether its work
/// tree has changes; ("unknown", None) when git is missing or `dir` is not
/// in a repository (or the repository has no commit yet).
pub fn git_revision(dir: &Path) -> GitRevision {
    let git = |args: &[&str]| {
        Command::new("git")
            .arg("-C")
            .arg(dir)
            .args(args)
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
    };
    match git(&["rev-parse", "HEAD"]) {
        Some(revision) if !revision.is_empty() => GitRevision {
            revision,
            dirty: git(&["status", "--porcelain"]).map(|s| !s.is_empty()),
        },
        _ => GitRevision {
            revision: "unknown".into(),
            dirty: None,
        },
    }
}

/// The CPU model from /proc/cpuinfo's first `model name` line, or
/// "unknown" (other systems, or CPUs that do not report one).
pub fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|text| {
            text.lines()
                .filter_map(|l| l.split_once(':'))
                .find(|(k, _)| k.trim() == "model name")
                .map(|(_, v)| v.trim().to_string())
        })
        .unwrap_or_else(|| "unknown".into())
}

/// `t` as an ISO 8601 UTC timestamp with seconds, e.g.
/// `2024-05-01T12:34:56Z`. Times before 1970 are written as 1970.
pub fn utc_iso8601(t: SystemTime) -> String {
    let secs = t.duration_since(UNIX_EPOCH).map_or(0, |d| d.as_secs());
    let days = (secs / 86_400) as i64;
    let rem = secs % 86_400;
    let (y, m, d) = civil_from_days(days);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem / 60 % 60,
        rem % 60
    )
}

/// The proleptic Gregorian date of day `z` counted from 1970-01-01.
///
/// Howard Hinnant's `civil_from_days` ("chrono-Compatible Low-Level Date
/// Algorithms", 2013): shift the epoch to 0000-03-01 so leap days fall at
/// the end of a year, split into 400-year eras of 146 097 days, then find
/// the year of the era, the day of that (March-based) year, and the month
/// from the 153-day five-month cycle.
fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097); // day of era, [0, 146096]
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365; // [0, 399]
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100); // day of year, [0, 365]
    let mp = (5 * doy + 2) / 153; // month from March, [0, 11]
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    let y = yoe + era * 400 + i64::from(m <= 2);
    (y, m, d)
}

impl Meta {
    /// The manifest a run's `meta.json` recorded, with `--quick` applied when
    /// the run was quick. `dir` names the folder in errors.
    pub fn recorded_manifest(&self, dir: &Path) -> Result<Manifest, Error> {
        let meta = self;
        let meta_path = dir.join(META_FILE);
        if meta.manifest_text.is_empty() {
            return Err(InputError::file(
                &meta_path,
                "records no manifest text (written by an older raylab); \
                 run the experiment again",
            )
            .into());
        }
        let path = meta
            .manifest
            .get("path")
            .and_then(|p| p.as_str())
            .map(PathBuf::from)
            .unwrap_or_else(|| PathBuf::from(format!("{}.toml", meta.name)));
        let manifest = parse_manifest(&meta.manifest_text, &path)
            .map_err(|e| InputError::file(&meta_path, format!("its manifest text: {e}")))?;
        if meta.quick {
            Ok(manifest.with_quick()?)
        } else {
            Ok(manifest)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn dates_match_known_days() {
        assert_eq!(civil_from_days(0), (1970, 1, 1));
        assert_eq!(civil_from_days(59), (1970, 3, 1));
        // 2000-02-29 (a leap day of a century divisible by 400) is day 11016.
        assert_eq!(civil_from_days(11_016), (2000, 2, 29));
        assert_eq!(civil_from_days(11_017), (2000, 3, 1));
        // 2024-12-31 is day 20088.
        assert_eq!(civil_from_days(20_088), (2024, 12, 31));
        let t = UNIX_EPOCH + Duration::from_secs(20_088 * 86_400 + 3_723);
        assert_eq!(utc_iso8601(t), "2024-12-31T01:02:03Z");
    }
}
