//! The `raylab experiment`, `raylab merge` and `raylab plot` reports: run
//! a manifest's sweeps (or merge its shards, or redraw its figures) and say what was run and written (runs,
//! threads, time, data files, figures, and the means of the ratio
//! figures). Part of the top-layer [`crate::report`]; the experiment itself
//! is [`crate::experiment`].

use crate::experiment::merge::{merge_shards, MergeOptions, Merged};
use crate::experiment::{
    redraw, run_experiment, ExperimentOptions, ExperimentRun, RatioSummary, Redrawn,
};
use crate::Error;
use std::fmt;
use std::path::Path;

/// What one experiment run did, as `raylab experiment` prints it.
#[derive(Clone, Debug)]
pub struct ExperimentReport(pub ExperimentRun);

impl ExperimentReport {
    /// Run the experiment of the manifest at `manifest`.
    pub fn run(manifest: &Path, opts: &ExperimentOptions) -> Result<Self, Error> {
        crate::check_threads(opts.threads)?;
        run_experiment(manifest, opts).map(Self)
    }
}

impl fmt::Display for ExperimentReport {
    /// One line of totals, the files written, and the summary means.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let report = &self.0;
        writeln!(
            f,
            "experiment {}{}: {} runs ({} done now, {} kept from data.csv), {} threads, {:.1} s",
            report.name,
            report
                .shard
                .map(|s| format!(" shard {s}"))
                .unwrap_or_default(),
            report.runs_total,
            report.runs_done,
            report.runs_skipped,
            report.threads,
            report.wall_time_s
        )?;
        write_outputs(f, &report.out_dir, &report.figures, &report.summary)
    }
}

/// The files written and the ratio means, as both reports print them.
fn write_outputs(
    f: &mut fmt::Formatter<'_>,
    out_dir: &Path,
    figures: &[String],
    summary: &[RatioSummary],
) -> fmt::Result {
    let dir = out_dir.display();
    writeln!(f, "wrote      {dir}/{{data.csv, meta.json}}")?;
    for fig in figures {
        writeln!(f, "figure     {dir}/{fig}.{{png,svg}}")?;
    }
    for s in summary {
        writeln!(f, "summary    {}: mean of {}", s.figure, s.label)?;
        for m in &s.series {
            writeln!(
                f,
                "             {:.2} over {:>2} points  {}",
                m.mean, m.count, m.label
            )?;
        }
    }
    Ok(())
}

/// What `raylab merge` did.
#[derive(Clone, Debug)]
pub struct MergeReport(pub Merged);

impl MergeReport {
    /// Merge the shards named in `opts`.
    pub fn run(opts: &MergeOptions) -> Result<Self, Error> {
        merge_shards(opts).map(Self)
    }
}

impl fmt::Display for MergeReport {
    /// A line per shard (machine, threads, rows, time), the totals, any
    /// missing runs, then the files written and the summary means.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let m = &self.0;
        writeln!(
            f,
            "merge {}: {} shards, {} of {} runs, {:.1} s",
            m.name,
            m.shards.len(),
            m.rows,
            m.runs_total,
            m.wall_time_s
        )?;
        for s in &m.shards {
            writeln!(
                f,
                "shard      {:<7} {:>4} rows  {:>8.1} s  {} threads  {} ({}){}  {}",
                s.shard.to_string(),
                s.rows,
                s.wall_time_s,
                s.threads,
                s.host,
                s.cpu_model,
                if s.complete { "" } else { "  INCOMPLETE" },
                s.dir
            )?;
        }
        for missing in &m.missing {
            writeln!(f, "missing    shard {}: {}", missing.shard, missing.run)?;
        }
        write_outputs(f, &m.out_dir, &m.figures, &m.summary)
    }
}

/// What `raylab plot` did.
#[derive(Clone, Debug)]
pub struct PlotReport(pub Redrawn);

impl PlotReport {
    /// Redraw the figures of the experiment in `dir` into `out_dir`, those
    /// of `manifest` when given (else of the manifest it recorded).
    pub fn run(dir: &Path, out_dir: Option<&Path>, manifest: Option<&Path>) -> Result<Self, Error> {
        redraw(dir, out_dir, manifest).map(Self)
    }
}

impl fmt::Display for PlotReport {
    /// The experiment, its rows, then the files written and the ratio means.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let r = &self.0;
        writeln!(
            f,
            "plot {}: {} rows, {} figures",
            r.name,
            r.rows,
            r.figures.len()
        )?;
        write_outputs(f, &r.out_dir, &r.figures, &r.summary)
    }
}
