//! The `raylab experiment` report: run a manifest's sweeps and say what was
//! run and written (runs, threads, time, data files, figures, and the means
//! of the ratio figures). Part of the top-layer [`crate::report`]; the
//! experiment itself is [`crate::experiment`].

use crate::experiment::{run_experiment, Options, Report};
use anyhow::Result;
use std::fmt;
use std::path::Path;

/// What one experiment run did, as `raylab experiment` prints it.
#[derive(Clone, Debug)]
pub struct ExperimentReport(pub Report);

impl ExperimentReport {
    /// Run the experiment of the manifest at `manifest`.
    pub fn run(manifest: &Path, opts: &Options) -> Result<Self> {
        if opts.threads == Some(0) {
            anyhow::bail!("--threads must be at least 1");
        }
        run_experiment(manifest, opts).map(Self)
    }
}

impl fmt::Display for ExperimentReport {
    /// One line of totals, the files written, and the summary means.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let report = &self.0;
        let dir = report.out_dir.display();
        writeln!(
            f,
            "experiment {}: {} runs ({} done now, {} kept from data.csv), {} threads, {:.1} s",
            report.name,
            report.runs_total,
            report.runs_done,
            report.runs_skipped,
            report.threads,
            report.wall_time_s
        )?;
        writeln!(f, "wrote      {dir}/{{data.csv, meta.json}}")?;
        for fig in &report.figures {
            writeln!(f, "figure     {dir}/{fig}.{{png,svg}}")?;
        }
        for s in &report.summary {
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
}
