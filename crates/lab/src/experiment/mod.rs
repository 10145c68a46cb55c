//! Experiments: a manifest (`analysis/NAME.toml`) names a study kind, the
//! parameters to sweep and the figures to draw; [`run_experiment`] runs
//! every point of every sweep with a progress bar, appends one row per run
//! to `data.csv`, records `meta.json` and draws the figures. It sits on top
//! of the data flow: it loads scenes and renders them through the ordinary
//! pipeline (`io::scene_file`, `integrator::render`, `stats`), then hands
//! the numbers to `analysis::plot`.
//!
//! # Manifest format
//!
//! ```toml
//! name = "s1-ogss-cost"       # required: names the output folder
//! kind = "render_cost"        # required: the study kind (see below)
//! description = "What it asks."
//! repeats = 5                 # timed repeats per run (default 5, 1 to 1000)
//! warmup = 1                  # untimed runs before them (default 1)
//! threads = 2                 # worker threads (default: all cores; --threads wins)
//!
//! [fixed]                     # parameters of every run, one value each
//! scene = "../data/scenes/s1-spheres.toml"
//!
//! [[sweep]]                   # one or more sweeps, each with a unique name
//! name = "resolutions"
//! resolution = ["300x225", "550x412", "800x600"]  # a list of values
//! sampler = ["centre", "ogss:2"]
//!
//! [[sweep]]
//! name = "scenes"
//! scene_index = { from = 1, to = 20, step = 1 }   # a range, both ends included
//! scene = "../data/scenes/s1-family/s1-{scene_index:02}.toml"  # a template
//! resolution = "640x480"                            # one value
//! sampler = ["centre", "ogss:2"]
//!
//! [quick]                     # the reduced version run by --quick
//! repeats = 1
//! warmup = 0
//! [quick.fixed]               # replaces or adds [fixed] parameters
//! seed = 1
//! [quick.sweep.resolutions]   # replaces parameters of sweep `resolutions`
//! resolution = ["300x225", "400x300"]
//!
//! [[figure]]                  # any number of figures, drawn from data.csv
//! file = "ratio-resolution"   # writes ratio-resolution.png and .svg
//! kind = "ratio"              # "line", "bar" or "ratio"
//! sweep = "resolutions"       # only this sweep's rows (default: all rows)
//! x = "width"                 # any column of data.csv
//! y = "render_median_s"       # a column, or a list: one series per column
//! series = "sampler"          # column whose values make the series
//! numerator = "ogss:2"        # ratio only: y(numerator) / y(denominator)
//! denominator = "centre"
//! series_labels = { centre = "centre (1 spp)" }   # legend text per value or y column
//! title = "T = t_OGSS / t_centre"
//! x_label = "image width (px)"  # default: the column name
//! y_label = "T"                 # default: the column name
//! x_log = false               # log10 axes
//! y_log = false
//! only = { accel = ["brute", "bvh"] }  # only rows with these values in these columns
//! dashed_where = "extrapolated" # line: rows with `true` here drawn as dashed series
//! legend = "auto"             # or upper-left, upper-right, lower-left, lower-right, hidden
//! [[figure.reference]]        # series given inline (published values)
//! label = "S1 (published)"
//! x = { from = 300, to = 800, step = 25 }   # a list or a range
//! y = [4.00, 3.00, 2.50]                    # as many values as x
//! style = "dashed"            # "dashed" (default), "points" or "line"
//! summary = true              # ratio figures: report its mean (default true)
//! ```
//!
//! Every table rejects unknown fields, and every error names the manifest,
//! the line and the column. Parameter values are integers, floats, booleans
//! or strings. In a `[[sweep]]` a parameter is one value, a list, or a range
//! `{ from, to, step }` (to included when a whole number of steps away;
//! a negative step counts down) or `{ from, to, count }` (`count` evenly
//! spaced values from `from` to `to`); integers stay integers when every
//! value is one. A sweep's runs are the cartesian product of its parameters,
//! the first one written varying slowest, merged over `[fixed]` (a sweep's
//! value of a parameter replaces the fixed one). A string may name other
//! parameters of its run as `{name}` or `{name:0W}` (an integer zero-padded
//! to W digits; `{{` and `}}` are literal braces). A parameter the study
//! does not read is an error unless a template uses it; such helper
//! parameters (`scene_index` above) become columns too, handy as x axes.
//! Relative paths are relative to the manifest's folder.
//!
//! `[quick]` declares the reduced version of the experiment that `--quick`
//! runs (for CI and the book): its `repeats` and `warmup` replace the
//! manifest's, `[quick.fixed]` replaces or adds fixed parameters, and
//! `[quick.sweep.NAME]` replaces parameters of sweep NAME (a parameter
//! that the sweep lacks but `[fixed]` has is added to the sweep).
//!
//! # Outputs
//!
//! In `analysis/out/NAME/` (the manifest's folder, `out/`, the name), or
//! the folder given by `--out`:
//!
//! - `data.csv`: one row per run: `sweep`, every parameter (fixed and
//!   swept), then the study's columns. Rows are appended and flushed as
//!   each run finishes, so an interrupted experiment keeps its finished
//!   rows. Without `--resume` the file is started afresh (the new header
//!   replaces the old file atomically); with `--resume` the rows already
//!   there are kept and runs whose key (sweep and every parameter value)
//!   is present are skipped. The columns must match the manifest's.
//! - `meta.json`: the manifest as run (after `--quick`, ranges expanded),
//!   raylab version, git revision and dirty flag, CPU model, thread count,
//!   the GPU adapter of a study that uses one (`device`, see
//!   [`study::Study::device`]), whether the build was optimised, UTC start
//!   and end (ISO 8601), wall
//!   time, the run counts, the figures and the means of ratio figures.
//!   Written at the start with `"complete": false` and again at the end.
//! - one `FILE.png` and `FILE.svg` per `[[figure]]`, drawn from `data.csv`
//!   after the runs, so `--resume` redraws them from every row. The mean of
//!   each series of a ratio figure (and of its references) is returned in
//!   the [`ExperimentRun`], printed by `raylab experiment` and kept in `meta.json`.
//!
//! # Shards and merging
//!
//! `--shard I/N` runs a deterministic 1/N of the runs into its own folder
//! (default `out/NAME.shards/I-of-N`), with the manifest's text and hash in
//! `meta.json` and no figures ([`shard`] says how the runs are dealt);
//! `raylab merge OUT SHARD_DIR…` ([`merge`]) checks that the shards belong
//! together, writes one `data.csv` in plan order and one `meta.json`
//! listing every shard's machine and times, and draws the figures. The
//! rows are those an unsharded run writes: the same keys, and the same
//! counters (timings are measured on whichever machine ran the shard).
//! `scripts/slurm/` and `scripts/parallel/` run the shards on a Slurm
//! cluster and with GNU parallel.
//!
//! # Study kinds
//!
//! The kinds are listed once, in [`study::KINDS`] (the registry that the
//! manifest reader and `raylab experiment --help` use); each kind's module
//! documents what a run does. A kind's parameters are the fields of its
//! parameter struct ([`params`]: typed, each documented, a misspelt one an
//! error naming the manifest's line), and its columns are the fields of its
//! row struct ([`row`]), so `data.csv`'s header and cells come from the same
//! code. For example `render_cost` ([`study::render_cost`]) reads `scene`
//! (required), `sampler`, `accel`, `resolution` ("WxH") or
//! `width`/`height`, `max_depth`, `seed` and `filter`
//! ([`params::render::RenderParams`]) and writes
//! [`study::render_cost::RenderCostRow`]: `width`, `height`, `pixels`,
//! `spp`, `samples`, `threads`, `load_s`, `render_s_1` … `render_s_N` (one
//! per timed repeat), `render_median_s`, `render_min_s`, `render_max_s`,
//! `render_cpu_median_s`, `counted_render_s`, every counter of
//! [`raylab::stats::Counters::named`], `rays`, `rays_per_s` and
//! `ns_per_sample`.
//!
//! Timing: a warning is printed when the binary was built without
//! optimisations; each run does `warmup` untimed renders and `repeats`
//! timed ones, and reports each time and their median, minimum and
//! maximum. The timed renders use the `NoStats` sink, so they are not slowed
//! by counting; the counters come from one extra render with `Counters`.
//! All renders of an experiment share one thread pool, built once.

pub mod data;
pub mod figures;
pub mod manifest;
pub mod merge;
pub mod meta;
pub mod params;
pub mod redraw;
pub mod row;
pub mod shard;
pub mod study;
pub mod sweep;

pub use manifest::{load_manifest, parse_manifest, Manifest, Plan};
pub use merge::{merge_shards, MergeOptions};
pub use meta::RatioSummary;
pub use redraw::{redraw, Redrawn};
pub use shard::{Shard, ShardError};

use crate::{Error, FileOp};
use data::{ReadTable, RowWriter, Table, DATA_FILE};
use indicatif::{ProgressBar, ProgressStyle};
use meta::{GitRevision, Meta, META_FILE};
use raylab::io::InputError;
use std::collections::HashSet;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::{Instant, SystemTime};
use study::RunContext;

/// How to run an experiment (the `raylab experiment` options).
#[derive(Clone, Debug, Default)]
pub struct ExperimentOptions {
    /// Apply the manifest's `[quick]` block.
    pub quick: bool,
    /// Keep the rows of an existing `data.csv` and skip their runs.
    pub resume: bool,
    /// Output folder (default: `out/NAME` beside the manifest).
    pub out_dir: Option<PathBuf>,
    /// Worker threads (default: the manifest's, else all cores).
    pub threads: Option<usize>,
    /// Print status lines and a progress bar on stderr (the bar only when
    /// stderr is a terminal).
    pub progress: bool,
    /// Run only this shard's runs ([`shard`]), into its own folder, and
    /// draw no figures.
    pub shard: Option<Shard>,
}

/// What an experiment run did.
#[derive(Clone, Debug)]
pub struct ExperimentRun {
    /// The experiment's name.
    pub name: String,
    /// Where `data.csv`, `meta.json` and the figures are.
    pub out_dir: PathBuf,
    /// Runs in the plan.
    pub runs_total: usize,
    /// Runs skipped because `data.csv` had them (`--resume`).
    pub runs_skipped: usize,
    /// Runs performed.
    pub runs_done: usize,
    /// Worker threads used.
    pub threads: usize,
    /// Seconds from start to end.
    pub wall_time_s: f64,
    /// Stems of the figures written (each as PNG and SVG).
    pub figures: Vec<String>,
    /// Means of the ratio figures beside their references.
    pub summary: Vec<RatioSummary>,
    /// The shard run, if one was.
    pub shard: Option<Shard>,
}

/// Run the experiment described by the manifest at `path`.
pub fn run_experiment(path: &Path, opts: &ExperimentOptions) -> Result<ExperimentRun, Error> {
    let clock = Instant::now();
    let started = SystemTime::now();
    let mut manifest = load_manifest(path)?;
    if opts.quick {
        manifest = manifest.with_quick()?;
    }
    let threads = opts
        .threads
        .or(manifest.threads)
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    if threads < 1 {
        return Err(Error::Argument(
            "the thread count must be at least 1".into(),
        ));
    }
    let plan = manifest.plan()?;
    let study = manifest.study();
    let out_dir = opts.out_dir.clone().unwrap_or_else(|| {
        let out = manifest.base_dir().join("out");
        match opts.shard {
            Some(s) => out
                .join(format!("{}.shards", manifest.name))
                .join(s.dir_name()),
            None => out.join(&manifest.name),
        }
    });
    let mut outputs = vec![
        ("data.csv", out_dir.join(DATA_FILE)),
        ("meta.json", out_dir.join(META_FILE)),
    ];
    for f in &manifest.figures {
        for ext in ["png", "svg"] {
            outputs.push(("a figure", out_dir.join(format!("{}.{ext}", f.file))));
        }
    }
    let outputs: Vec<(&str, &Path)> = outputs.iter().map(|(r, p)| (*r, p.as_path())).collect();
    raylab::io::check_outputs(&[("the manifest", path)], &outputs)?;
    std::fs::create_dir_all(&out_dir)
        .map_err(|e| Error::io(&out_dir, FileOp::CreateOutputFolder, e))?;

    if cfg!(debug_assertions) {
        eprintln!(
            "warning: ********************************************************************\n\
             warning: raylab was built WITHOUT optimisations (debug assertions are on):\n\
             warning: these timings say little about the renderer. For real numbers run\n\
             warning:     cargo build --release && target/release/raylab experiment …\n\
             warning: ********************************************************************"
        );
    }

    // data.csv: fresh, or resumed with the keys of the rows already there.
    let data_path = out_dir.join(DATA_FILE);
    let (mut writer, done) = if opts.resume && data_path.exists() {
        let ReadTable {
            table,
            dropped_last_line,
        } = Table::read(&data_path)?;
        if dropped_last_line {
            eprintln!(
                "warning: {}: dropped an incomplete last line (an interrupted write); \
                 that run will be done again",
                data_path.display()
            );
        }
        if table.columns != plan.columns {
            return Err(InputError::file(
                &data_path,
                format!(
                    "its columns differ from what {} now produces (was the manifest, \
                     `repeats` or --quick changed?); run without --resume to start afresh\n  \
                     file:     {}\n  manifest: {}",
                    manifest.path.display(),
                    table.columns.join(","),
                    plan.columns.join(",")
                ),
            )
            .into());
        }
        let key_len = 1 + plan.param_columns.len();
        let done: HashSet<Vec<String>> = table.rows.iter().map(|r| r[..key_len].to_vec()).collect();
        (RowWriter::resume(&data_path, &table)?, done)
    } else {
        (
            RowWriter::create(&data_path, &plan.columns)?,
            HashSet::new(),
        )
    };
    let dealt = opts.shard.map(|s| shard::deal(&manifest, &plan, s.count));
    let mine: Vec<_> = plan
        .runs
        .iter()
        .enumerate()
        .filter(|(p, _)| dealt.as_ref().is_none_or(|d| Some(d[*p]) == opts.shard))
        .map(|(_, r)| r)
        .collect();
    let todo: Vec<_> = mine
        .iter()
        .copied()
        .filter(|r| !done.contains(&plan.key(r)))
        .collect();
    let skipped = mine.len() - todo.len();

    let GitRevision {
        revision: git_revision,
        dirty: git_dirty,
    } = meta::git_revision(manifest.base_dir());
    if !opts.quick && git_dirty != Some(false) {
        eprintln!(
            "warning: this full run is made {}: its meta.json records that, and the book \
             refuses such a run as a committed full run (analysis/results/README.md); \
             commit first to make one that can be committed",
            if git_dirty.is_some() {
                "from a work tree with local changes"
            } else {
                "outside a git work tree"
            }
        );
    }
    let mut meta = Meta {
        name: manifest.name.clone(),
        kind: manifest.kind.clone(),
        manifest: manifest.to_json(),
        manifest_hash: shard::manifest_hash(&manifest.text, opts.quick),
        manifest_text: manifest.text.clone(),
        shard: opts.shard,
        shards: Vec::new(),
        host: shard::host_name(),
        raylab_version: env!("CARGO_PKG_VERSION").to_string(),
        git_revision,
        git_dirty,
        cpu_model: meta::cpu_model(),
        logical_cpus: std::thread::available_parallelism().map_or(1, |n| n.get()),
        threads,
        device: study.device(),
        optimised: !cfg!(debug_assertions),
        started_utc: meta::utc_iso8601(started),
        finished_utc: None,
        wall_time_s: 0.0,
        quick: opts.quick,
        resumed: opts.resume,
        runs_total: mine.len(),
        runs_skipped: skipped,
        runs_done: 0,
        complete: false,
        figures: Vec::new(),
        summary: Vec::new(),
    };
    meta.write(&out_dir)?;

    if opts.progress {
        eprintln!(
            "experiment {} ({}{}{}): {} runs{}, {} repeats + {} warm-up, {} threads → {}",
            manifest.name,
            manifest.kind,
            if opts.quick { ", quick" } else { "" },
            opts.shard
                .map(|s| format!(", shard {s} of {} runs", plan.runs.len()))
                .unwrap_or_default(),
            mine.len(),
            if skipped > 0 {
                format!(" ({skipped} already in data.csv)")
            } else {
                String::new()
            },
            manifest.repeats,
            manifest.warmup,
            threads,
            out_dir.display()
        );
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(Error::Threads)?;
    let bar = if opts.progress && std::io::stderr().is_terminal() {
        let bar = ProgressBar::new(todo.len() as u64);
        if let Ok(style) =
            ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} eta {eta} {msg}")
        {
            bar.set_style(style.progress_chars("=> "));
        }
        bar
    } else {
        ProgressBar::hidden()
    };
    let ctx = RunContext {
        base_dir: manifest.base_dir(),
        out_dir: &out_dir,
        settings: manifest.settings(),
    };
    for run in &todo {
        let what = run.describe(&plan.varying);
        bar.set_message(what.clone());
        let record = match pool.install(|| study.run(run, &ctx)) {
            Ok(record) => record,
            Err(e) => {
                bar.abandon();
                meta.wall_time_s = clock.elapsed().as_secs_f64();
                let _ = meta.write(&out_dir);
                return Err(Error::Run {
                    manifest: manifest.path.clone(),
                    run: what,
                    done: meta.runs_done + skipped,
                    total: mine.len(),
                    data: data_path,
                    error: Box::new(e),
                });
            }
        };
        // A parameter's column holds the parameter (also where the study
        // writes a column of that name); the others are the study's.
        let cells = plan
            .columns
            .iter()
            .map(|c| {
                if c == "sweep" {
                    Ok(run.sweep.clone())
                } else if let Some(v) = run.get(c) {
                    Ok(v.to_string())
                } else if let Some(cell) = record.get(c) {
                    Ok(cell.to_string())
                } else if plan.param_columns.contains(c) {
                    Ok(String::new()) // a parameter this run does not set
                } else {
                    Err(Error::Internal(format!(
                        "internal error: study `{}` wrote no column `{c}`",
                        manifest.kind
                    )))
                }
            })
            .collect::<Result<Vec<String>, Error>>()?;
        writer.append(&cells)?;
        meta.runs_done += 1;
        bar.inc(1);
    }
    bar.finish_and_clear();
    drop(writer);

    // Figures, from everything data.csv now holds (a shard draws none:
    // `raylab merge` draws them from all the rows).
    let failures = if opts.shard.is_some() {
        Vec::new()
    } else {
        let table = Table::read(&data_path)?.table;
        draw_figures(&manifest, &plan, &table, &out_dir, &mut meta)
    };
    meta.wall_time_s = clock.elapsed().as_secs_f64();
    meta.finished_utc = Some(meta::utc_iso8601(SystemTime::now()));
    meta.complete = failures.is_empty();
    meta.write(&out_dir)?;
    if !failures.is_empty() {
        return Err(Error::Figures {
            what: format!(
                "{}: the runs finished ({}), but figures failed",
                manifest.path.display(),
                data_path.display()
            ),
            failures,
        });
    }
    Ok(ExperimentRun {
        name: manifest.name.clone(),
        out_dir,
        runs_total: mine.len(),
        runs_skipped: skipped,
        runs_done: meta.runs_done,
        threads,
        wall_time_s: meta.wall_time_s,
        figures: meta.figures.clone(),
        summary: meta.summary.clone(),
        shard: opts.shard,
    })
}

/// Draw the manifest's figures and the study's own from `table` into
/// `out_dir`, recording them (and the ratio means) in `meta`; returns the
/// failures, one message each.
fn draw_figures(
    manifest: &Manifest,
    plan: &Plan,
    table: &Table,
    out_dir: &Path,
    meta: &mut Meta,
) -> Vec<String> {
    let mut failures = Vec::new();
    for spec in &manifest.figures {
        match figures::draw(spec, table, &plan.param_columns, out_dir) {
            Ok(summary) => {
                meta.figures.push(spec.file.clone());
                meta.summary.extend(summary);
            }
            Err(e) => failures.push(e.to_string()),
        }
    }
    match manifest.study().figures(table, out_dir) {
        Ok(stems) => meta.figures.extend(stems),
        Err(e) => failures.push(format!("{} figures: {e}", manifest.kind)),
    }
    failures
}
