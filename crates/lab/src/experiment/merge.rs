//! `raylab merge OUT SHARD_DIR…`: the shards of one experiment
//! ([`super::shard`]) made into the table, record and figures of a whole
//! run.
//!
//! Checks, each an error naming the folders: every folder is a shard
//! (`meta.json` has `shard`) and appears once; all carry the same manifest
//! hash (the same manifest text and `--quick`), raylab version, git
//! revision (where known) and shard count; no two are the same shard; every
//! row is a run of the manifest's plan, dealt to the shard it sits in, and
//! appears once. Runs no shard has are listed by key; with
//! `allow_missing` the merge goes on and draws what exists (and
//! `meta.json` says `"complete": false`).
//!
//! Writes `OUT/data.csv` with the rows in plan order (so it equals an
//! unsharded run's, timings aside), `OUT/meta.json` (the manifest, and per
//! shard its host, CPU, threads, start, end, wall time and rows), copies
//! the files the studies wrote beside the tables (images, curves), and
//! draws the manifest's figures.

use super::data::{ReadTable, RowWriter, Table, DATA_FILE};
use super::meta::{Meta, ShardRecord, META_FILE};
use super::shard::{deal, host_name, manifest_hash, Shard};
use super::{draw_figures, RatioSummary};
use crate::{Error, FileOp};
use raylab::io::InputError;
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What to merge.
#[derive(Clone, Debug, Default)]
pub struct MergeOptions {
    /// The merged experiment's folder (created when missing).
    pub out_dir: PathBuf,
    /// The shards' folders.
    pub shards: Vec<PathBuf>,
    /// Merge and draw even when runs are missing.
    pub allow_missing: bool,
}

/// What a merge did.
#[derive(Clone, Debug)]
pub struct Merged {
    /// The experiment's name.
    pub name: String,
    /// Where `data.csv`, `meta.json` and the figures are.
    pub out_dir: PathBuf,
    /// The shards merged, in shard order.
    pub shards: Vec<ShardRecord>,
    /// Runs in the plan.
    pub runs_total: usize,
    /// Rows written.
    pub rows: usize,
    /// The runs no shard had.
    pub missing: Vec<MissingRun>,
    /// Stems of the figures written.
    pub figures: Vec<String>,
    /// Means of the ratio figures beside their references.
    pub summary: Vec<RatioSummary>,
    /// Seconds the merge took.
    pub wall_time_s: f64,
}

/// A run of the plan that no shard has.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MissingRun {
    /// The shard it was dealt to.
    pub shard: Shard,
    /// The run, described by its parameters that vary.
    pub run: String,
}

/// One shard folder as read.
struct ShardDir {
    dir: PathBuf,
    shard: Shard,
    meta: Meta,
    table: Table,
}

/// Merge the shards into `opts.out_dir`.
pub fn merge_shards(opts: &MergeOptions) -> Result<Merged, Error> {
    let clock = Instant::now();
    // The merged data.csv and meta.json must not replace a shard's.
    let names: Vec<_> = opts
        .shards
        .iter()
        .map(|d| (format!("the shard {}", d.display()), d.join("data.csv")))
        .collect();
    let inputs: Vec<_> = names
        .iter()
        .map(|(r, p)| (r.as_str(), p.as_path()))
        .collect();
    let merged = opts.out_dir.join("data.csv");
    raylab::io::check_outputs(&inputs, &[("the merged folder", merged.as_path())])?;
    let shards = read_shards(opts)?;
    let first = &shards[0];

    // The plan, rebuilt from the manifest text the shards ran.
    let manifest = first.meta.recorded_manifest(&first.dir)?;
    let plan = manifest.plan()?;
    let key_len = 1 + plan.param_columns.len();
    let dealt = deal(&manifest, &plan, first.shard.count);
    let position: HashMap<Vec<String>, usize> = plan
        .runs
        .iter()
        .enumerate()
        .map(|(p, r)| (plan.key(r), p))
        .collect();

    // Every row once, each in the shard it was dealt to.
    let mut rows: Vec<Option<(&Vec<String>, &Path)>> = vec![None; plan.runs.len()];
    for s in &shards {
        let data = s.dir.join(DATA_FILE);
        if s.table.columns != plan.columns {
            return Err(InputError::file(
                &data,
                format!(
                    "its columns differ from the manifest's plan\n  file:     {}\n  manifest: {}",
                    s.table.columns.join(","),
                    plan.columns.join(",")
                ),
            )
            .into());
        }
        for (i, row) in s.table.rows.iter().enumerate() {
            let line = i + 2;
            let Some(&p) = position.get(&row[..key_len]) else {
                return Err(InputError::line(
                    &data,
                    line,
                    format!(
                        "this row is not a run of the manifest ({})",
                        row[..key_len].join(",")
                    ),
                )
                .into());
            };
            let owner = dealt[p];
            if owner != s.shard {
                return Err(InputError::line(
                    &data,
                    line,
                    format!(
                        "run `{}` belongs to shard {owner}, not to this shard {}",
                        plan.runs[p].describe(&plan.varying),
                        s.shard
                    ),
                )
                .into());
            }
            if let Some((_, other)) = rows[p] {
                return Err(Error::Merge(format!(
                    "run `{}` is in {} and again in {}",
                    plan.runs[p].describe(&plan.varying),
                    other.display(),
                    s.dir.display()
                )));
            }
            rows[p] = Some((row, &s.dir));
        }
    }
    let missing: Vec<MissingRun> = rows
        .iter()
        .enumerate()
        .filter(|(_, r)| r.is_none())
        .map(|(p, _)| MissingRun {
            shard: dealt[p],
            run: plan.runs[p].describe(&plan.varying),
        })
        .collect();
    if !missing.is_empty() && !opts.allow_missing {
        let shown: Vec<String> = missing
            .iter()
            .take(20)
            .map(|m| format!("shard {}: {}", m.shard, m.run))
            .collect();
        return Err(Error::Merge(format!(
            "{} of {} runs are in no shard (--allow-missing merges and draws what exists):\n  {}{}",
            missing.len(),
            plan.runs.len(),
            shown.join("\n  "),
            if missing.len() > shown.len() {
                format!("\n  … and {} more", missing.len() - shown.len())
            } else {
                String::new()
            }
        )));
    }

    std::fs::create_dir_all(&opts.out_dir)
        .map_err(|e| Error::io(&opts.out_dir, FileOp::CreateOutputFolder, e))?;
    for s in &shards {
        copy_study_files(&s.dir, &opts.out_dir, Path::new(""))?;
    }
    let data_path = opts.out_dir.join(DATA_FILE);
    let mut writer = RowWriter::create(&data_path, &plan.columns)?;
    for (row, _) in rows.iter().flatten() {
        writer.append(row)?;
    }
    drop(writer);

    let records: Vec<ShardRecord> = shards.iter().map(record).collect();
    let mut meta = merged_meta(first, &records, &plan, &missing);
    let table = Table::read(&data_path)?.table;
    let failures = draw_figures(&manifest, &plan, &table, &opts.out_dir, &mut meta);
    meta.complete &= failures.is_empty();
    meta.write(&opts.out_dir)?;
    if !failures.is_empty() {
        return Err(Error::Figures {
            what: format!("{}: merged, but figures failed", data_path.display()),
            failures,
        });
    }
    Ok(Merged {
        name: manifest.name.clone(),
        out_dir: opts.out_dir.clone(),
        shards: records,
        runs_total: plan.runs.len(),
        rows: meta.runs_done,
        missing,
        figures: meta.figures,
        summary: meta.summary,
        wall_time_s: clock.elapsed().as_secs_f64(),
    })
}

/// Read every shard folder and check that they belong together.
fn read_shards(opts: &MergeOptions) -> Result<Vec<ShardDir>, Error> {
    if opts.shards.is_empty() {
        return Err(Error::Merge("no shard folders to merge".into()));
    }
    let out = opts.out_dir.canonicalize().ok();
    let mut seen: HashMap<PathBuf, &Path> = HashMap::new();
    let mut shards = Vec::new();
    for dir in &opts.shards {
        let canon = dir
            .canonicalize()
            .map_err(|e| Error::io(dir, FileOp::FindShard, e))?;
        if out.as_ref() == Some(&canon) {
            return Err(Error::Merge(format!(
                "{}: the output folder is one of the shards; merge into another folder",
                dir.display()
            )));
        }
        if let Some(other) = seen.insert(canon, dir) {
            return Err(Error::Merge(format!(
                "{} and {} are the same folder: each shard is merged once",
                other.display(),
                dir.display()
            )));
        }
        let meta = Meta::read(dir)?;
        let Some(shard) = meta.shard else {
            return Err(Error::Merge(format!(
                "{}: not a shard (its meta.json has no `shard`; run the experiment with --shard I/N)",
                dir.display()
            )));
        };
        let expected = manifest_hash(&meta.manifest_text, meta.quick);
        if meta.manifest_hash != expected {
            return Err(InputError::file(
                dir.join(META_FILE),
                "its manifest_hash does not match its manifest text (edited by hand?)",
            )
            .into());
        }
        let ReadTable {
            table,
            dropped_last_line,
        } = Table::read(&dir.join(DATA_FILE))?;
        if dropped_last_line {
            eprintln!(
                "warning: {}: dropped an incomplete last line (an interrupted write)",
                dir.join(DATA_FILE).display()
            );
        }
        shards.push(ShardDir {
            dir: dir.clone(),
            shard,
            meta,
            table,
        });
    }
    let first = &shards[0];
    let mut by_index: BTreeMap<usize, &Path> = BTreeMap::new();
    for s in &shards {
        let differs = |what: &str, a: &str, b: &str| {
            Error::Merge(format!(
                "{} and {} differ in {what} ({a} vs {b}): only shards of one run of one \
                 manifest are merged",
                first.dir.display(),
                s.dir.display()
            ))
        };
        if s.meta.manifest_hash != first.meta.manifest_hash {
            return Err(differs(
                "their manifest (text or --quick)",
                &first.meta.manifest_hash[..12],
                &s.meta.manifest_hash[..12],
            ));
        }
        if s.meta.raylab_version != first.meta.raylab_version {
            return Err(differs(
                "raylab version",
                &first.meta.raylab_version,
                &s.meta.raylab_version,
            ));
        }
        let known = |r: &str| r != "unknown";
        if known(&s.meta.git_revision)
            && known(&first.meta.git_revision)
            && s.meta.git_revision != first.meta.git_revision
        {
            return Err(differs(
                "git revision",
                &first.meta.git_revision,
                &s.meta.git_revision,
            ));
        }
        if s.shard.count != first.shard.count {
            return Err(differs(
                "shard count",
                &first.shard.to_string(),
                &s.shard.to_string(),
            ));
        }
        if let Some(other) = by_index.insert(s.shard.index, &s.dir) {
            return Err(Error::Merge(format!(
                "{} and {} are both shard {}: each shard is merged once",
                other.display(),
                s.dir.display(),
                s.shard
            )));
        }
    }
    shards.sort_by_key(|s| s.shard.index);
    Ok(shards)
}

/// What the merged `meta.json` says of one shard.
fn record(s: &ShardDir) -> ShardRecord {
    ShardRecord {
        shard: s.shard,
        dir: s.dir.display().to_string(),
        host: s.meta.host.clone(),
        cpu_model: s.meta.cpu_model.clone(),
        logical_cpus: s.meta.logical_cpus,
        threads: s.meta.threads,
        optimised: s.meta.optimised,
        git_revision: s.meta.git_revision.clone(),
        started_utc: s.meta.started_utc.clone(),
        finished_utc: s.meta.finished_utc.clone(),
        wall_time_s: s.meta.wall_time_s,
        rows: s.table.rows.len(),
        complete: s.meta.complete,
    }
}

/// The merged record: the first shard's manifest and revision, the
/// shards' machines; start and end span all shards, `wall_time_s` is the
/// shards' wall times summed (machine time, not elapsed time), `threads`
/// and `logical_cpus` the largest, `optimised` only when every shard was.
fn merged_meta(
    first: &ShardDir,
    records: &[ShardRecord],
    plan: &super::Plan,
    missing: &[MissingRun],
) -> Meta {
    let mut cpus: Vec<&str> = records.iter().map(|r| r.cpu_model.as_str()).collect();
    cpus.sort_unstable();
    cpus.dedup();
    let finished: Option<Vec<&String>> = records.iter().map(|r| r.finished_utc.as_ref()).collect();
    Meta {
        name: first.meta.name.clone(),
        kind: first.meta.kind.clone(),
        manifest: first.meta.manifest.clone(),
        manifest_hash: first.meta.manifest_hash.clone(),
        manifest_text: first.meta.manifest_text.clone(),
        shard: None,
        shards: records.to_vec(),
        host: host_name(),
        raylab_version: first.meta.raylab_version.clone(),
        git_revision: first.meta.git_revision.clone(),
        git_dirty: first.meta.git_dirty,
        cpu_model: cpus.join("; "),
        logical_cpus: records.iter().map(|r| r.logical_cpus).max().unwrap_or(1),
        threads: records.iter().map(|r| r.threads).max().unwrap_or(1),
        device: first.meta.device.clone(),
        optimised: records.iter().all(|r| r.optimised),
        started_utc: records
            .iter()
            .map(|r| r.started_utc.clone())
            .min()
            .unwrap_or_default(),
        finished_utc: finished.and_then(|f| f.into_iter().max().cloned()),
        wall_time_s: records.iter().map(|r| r.wall_time_s).sum(),
        quick: first.meta.quick,
        resumed: false,
        runs_total: plan.runs.len(),
        runs_skipped: 0,
        runs_done: plan.runs.len() - missing.len(),
        complete: missing.is_empty() && records.iter().all(|r| r.complete),
        figures: Vec::new(),
        summary: Vec::new(),
    }
}

/// Copy what a study wrote beside the tables (images, curves, cached
/// references) from a shard folder into the merged one; the shard's own
/// `data.csv` and `meta.json` stay behind. A file already there is kept
/// (shards that computed the same cached reference wrote the same one).
pub(super) fn copy_study_files(from: &Path, to: &Path, rel: &Path) -> Result<(), Error> {
    let dir = from.join(rel);
    let list_error = |e| Error::io(&dir, FileOp::List, e);
    let entries = std::fs::read_dir(&dir).map_err(list_error)?;
    for entry in entries {
        let entry = entry.map_err(list_error)?;
        let name = entry.file_name();
        let rel_path = rel.join(&name);
        if rel.as_os_str().is_empty() && (name == DATA_FILE || name == META_FILE) {
            continue;
        }
        let kind = entry.file_type().map_err(list_error)?;
        let target = to.join(&rel_path);
        if kind.is_dir() {
            std::fs::create_dir_all(&target).map_err(|e| Error::io(&target, FileOp::Create, e))?;
            copy_study_files(from, to, &rel_path)?;
        } else if kind.is_file() && !target.exists() {
            std::fs::copy(entry.path(), &target).map_err(|error| Error::Copy {
                from: entry.path(),
                to: target.clone(),
                error,
            })?;
        }
    }
    Ok(())
}
