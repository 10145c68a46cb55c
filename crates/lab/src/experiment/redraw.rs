//! `raylab plot DIR`: an experiment's figures drawn again from its
//! `data.csv` and `meta.json`, without re-running anything.
//!
//! The manifest comes from the text `meta.json` recorded (`manifest_text`),
//! so the figures are the manifest's as it was run, drawn by the plotting
//! code of this raylab. This is how the book draws the figures of the
//! committed full runs in `analysis/results/`, and how a researcher redraws
//! after changing the plotting code or copying a run from another machine.
//! With an output folder other than `DIR`, the table, the record and the
//! files the study wrote beside them are copied there first and `DIR` is
//! left as it was.
//!
//! With `--manifest FILE`, the figures are those of the manifest as it is
//! now (after its `[[figure]]` blocks were edited, say), drawn from the old
//! data: the manifest must have the recorded experiment's name and the
//! table's columns, and every row of the table must be one of its runs.

use super::data::{ReadTable, Table, DATA_FILE};
use super::merge::copy_study_files;
use super::meta::Meta;
use super::{draw_figures, load_manifest, RatioSummary};
use crate::{Error, FileOp};
use raylab::io::InputError;
use std::path::{Path, PathBuf};

/// What a redraw did.
#[derive(Clone, Debug)]
pub struct Redrawn {
    /// The experiment's name.
    pub name: String,
    /// Where the figures were written.
    pub out_dir: PathBuf,
    /// Rows of the table.
    pub rows: usize,
    /// The figures written (file stems).
    pub figures: Vec<String>,
    /// Means of the ratio figures.
    pub summary: Vec<RatioSummary>,
}

/// Draw the figures of the experiment in `dir` into `out_dir` (`dir` when
/// `None`), updating the figure list and ratio means of its `meta.json`;
/// the figures of `manifest` when given, else of the recorded manifest.
pub fn redraw(
    dir: &Path,
    out_dir: Option<&Path>,
    manifest: Option<&Path>,
) -> Result<Redrawn, Error> {
    let mut meta = Meta::read(dir)?;
    let manifest_path = manifest;
    let manifest = match manifest {
        None => meta.recorded_manifest(dir)?,
        Some(path) => {
            let m = load_manifest(path)?;
            let m = if meta.quick { m.with_quick()? } else { m };
            if m.name != meta.name {
                return Err(InputError::file(
                    path,
                    format!(
                        "the manifest of experiment `{}`, but {} holds a run of `{}`",
                        m.name,
                        dir.display(),
                        meta.name
                    ),
                )
                .into());
            }
            m
        }
    };
    let plan = manifest.plan()?;
    let data = dir.join(DATA_FILE);
    let ReadTable {
        table,
        dropped_last_line,
    } = Table::read(&data)?;
    if dropped_last_line {
        return Err(InputError::file(
            &data,
            "its last row is incomplete (an interrupted run?); finish it with --resume first",
        )
        .into());
    }
    if table.columns != plan.columns {
        return Err(InputError::file(
            &data,
            format!(
                "its columns differ from the recorded manifest's plan\n  file:     {}\n  manifest: {}",
                table.columns.join(","),
                plan.columns.join(",")
            ),
        )
        .into());
    }
    // A row belongs to a run when their keys agree wherever the plan has a
    // value (a study may fill a parameter column as it runs: the gradient
    // study's finite-difference step).
    let keys: Vec<Vec<String>> = plan.runs.iter().map(|r| plan.key(r)).collect();
    let key_len = 1 + plan.param_columns.len();
    for (i, row) in table.rows.iter().enumerate() {
        let known = keys.iter().any(|k| {
            k.iter()
                .zip(&row[..key_len])
                .all(|(p, r)| p.is_empty() || p == r)
        });
        if !known {
            return Err(InputError::line(
                &data,
                i + 2,
                format!(
                    "this row is not a run of the manifest ({}); was a sweep changed?",
                    row[..key_len].join(",")
                ),
            )
            .into());
        }
    }
    let out = out_dir.unwrap_or(dir);
    // The same folder however it is written (`DIR/./`, a link to it):
    // copying its data onto itself would be a write over an input.
    let same = match (std::fs::canonicalize(out), std::fs::canonicalize(dir)) {
        (Ok(a), Ok(b)) => a == b,
        _ => out == dir,
    };
    let figures: Vec<std::path::PathBuf> = manifest
        .figures
        .iter()
        .flat_map(|f| ["png", "svg"].map(|ext| out.join(format!("{}.{ext}", f.file))))
        .collect();
    let outputs: Vec<(&str, &Path)> = figures.iter().map(|f| ("a figure", f.as_path())).collect();
    let inputs: Vec<(&str, &Path)> = manifest_path.iter().map(|m| ("--manifest", *m)).collect();
    raylab::io::check_outputs(&inputs, &outputs)?;
    if !same {
        std::fs::create_dir_all(out).map_err(|e| Error::io(out, FileOp::CreateOutputFolder, e))?;
        copy_study_files(dir, out, Path::new(""))?;
        std::fs::copy(&data, out.join(DATA_FILE)).map_err(|error| Error::Copy {
            from: data.clone(),
            to: out.to_path_buf(),
            error,
        })?;
    }
    meta.figures.clear();
    meta.summary.clear();
    let failures = draw_figures(&manifest, &plan, &table, out, &mut meta);
    meta.write(out)?;
    if !failures.is_empty() {
        return Err(Error::Figures {
            what: format!("{}: figures failed", out.display()),
            failures,
        });
    }
    Ok(Redrawn {
        name: meta.name.clone(),
        out_dir: out.to_path_buf(),
        rows: table.rows.len(),
        figures: meta.figures,
        summary: meta.summary,
    })
}
