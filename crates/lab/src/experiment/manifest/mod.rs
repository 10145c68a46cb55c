//! Experiment manifests: the TOML file that says what an experiment runs
//! and draws (format in the [module documentation](super)).
//!
//! [`load_manifest`] reads a manifest ([`parse`]) and checks it against
//! its study ([`validate`]): every error names the file, the line and the
//! column, like the scene loader, and a misspelt parameter or a figure
//! naming a column the study does not write is an error before anything
//! runs. [`Manifest::plan`] expands the sweeps into runs, checks every run
//! with its study, and fixes the columns of `data.csv`.

pub mod parse;
#[cfg(test)]
mod test_util;
pub mod validate;

pub use parse::{load_manifest, parse_manifest};

use super::study::{DynStudy, StudyKind, StudySettings};
use super::sweep::{expand_sweep, ManifestParam, RunPoint, Sweep, Value, MAX_RUNS};
use crate::analysis::plot::LegendPosition;
use raylab::io::InputError;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

/// Repeats of each timed measurement when the manifest does not say.
pub const DEFAULT_REPEATS: u32 = 5;
/// The most repeats a manifest may ask for: each is a column of data.csv
/// (`render_s_1` …), made before anything runs, so a typo such as
/// `repeats = 2147483647` must not get that far.
pub const MAX_REPEATS: u32 = 1000;
/// Untimed warm-up runs before the repeats when the manifest does not say.
pub const DEFAULT_WARMUP: u32 = 1;

/// What a figure draws.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FigureKind {
    /// y against x, one line per value of the `series` column.
    Line,
    /// Grouped bars: one group per x value, one bar per series value.
    Bar,
    /// The ratio y(numerator) / y(denominator) against x, pairing rows that
    /// differ only in the `series` column (e.g. T = t_OGSS / t_centre).
    Ratio,
}

/// How a reference series is drawn.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ReferenceStyle {
    /// A dashed line (published or theoretical values).
    #[default]
    Dashed,
    /// Markers only.
    Points,
    /// A solid line without markers (a bound, such as "4 × the samples").
    Line,
}

/// A series given in the manifest itself, drawn beside the measured ones
/// (a paper's published values, a theoretical curve).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Reference {
    /// Legend text.
    pub label: String,
    /// (x, y) points.
    pub points: Vec<(f64, f64)>,
    /// How it is drawn.
    pub style: ReferenceStyle,
    /// Whether a ratio figure's summary reports its mean.
    pub summary: bool,
}

/// One `[[figure]]` block, checked against the columns of `data.csv`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FigureSpec {
    /// File stem: the figure is written as `FILE.png` and `FILE.svg`.
    pub file: String,
    /// What to draw.
    pub kind: FigureKind,
    /// Only rows of this sweep (all rows when `None`).
    pub sweep: Option<String>,
    /// Column for the x axis (bar charts: the categories).
    pub x: String,
    /// Columns for the y axis: one series (per series value) for each.
    pub y: Vec<String>,
    /// Column whose values split the rows into series.
    pub series: Option<String>,
    /// For ratios: the series value on top of the fraction.
    pub numerator: Option<String>,
    /// For ratios: the series value below the fraction.
    pub denominator: Option<String>,
    /// Legend text for series values and y columns (default: the value or
    /// column name itself).
    pub series_labels: BTreeMap<String, String>,
    /// Caption.
    pub title: String,
    /// x axis label (default: the column name).
    pub x_label: Option<String>,
    /// y axis label (default: the column name).
    pub y_label: Option<String>,
    /// Logarithmic x axis.
    pub x_log: bool,
    /// Logarithmic y axis.
    pub y_log: bool,
    /// Line figures: a column whose value `true` marks estimated rows (an
    /// `extrapolated` column); those points are drawn as a separate dashed
    /// series per series value, joined to the last measured point before
    /// them.
    pub dashed_where: Option<String>,
    /// Line figures: fit a straight line to each series in the axes' own
    /// coordinates (log10 on a log axis, so on log–log axes the slope is
    /// the power-law exponent, e.g. −1 for error ∝ 1/spp) and put the slope
    /// in the legend.
    pub fit_slope: bool,
    /// Only rows whose cell in each named column is one of the listed
    /// values (e.g. `only = { accel = ["brute", "bvh:aabb:s3"] }`).
    pub only: BTreeMap<String, Vec<String>>,
    /// Where the legend goes (default: the first corner free of data).
    pub legend: LegendPosition,
    /// Series given inline in the manifest.
    pub references: Vec<Reference>,
    #[serde(skip)]
    spans: FigureSpans,
}

/// Where a figure's column names are written, to point errors at them.
#[derive(Clone, Debug, Default, PartialEq)]
struct FigureSpans {
    block: Range<usize>,
    x: Range<usize>,
    y: Range<usize>,
    series: Option<Range<usize>>,
    sweep: Option<Range<usize>>,
    only: Option<Range<usize>>,
    dashed_where: Option<Range<usize>>,
}

/// The `[quick]` block: a reduced version of the experiment for CI and the
/// book, applied by `--quick`.
#[derive(Clone, Debug, PartialEq)]
pub struct Quick {
    /// Replaces `repeats`.
    pub repeats: Option<u32>,
    /// Replaces `warmup`.
    pub warmup: Option<u32>,
    /// Replace (or add) `[fixed]` parameters.
    pub fixed: Vec<ManifestParam>,
    /// Per sweep name: parameters that replace (or are added to) the sweep's.
    pub sweeps: Vec<(String, Vec<ManifestParam>)>,
}

/// A checked experiment manifest.
#[derive(Clone, Debug)]
pub struct Manifest {
    /// The manifest file.
    pub path: PathBuf,
    /// The experiment's name (also the default output folder's name).
    pub name: String,
    /// The study kind, e.g. `render_cost`.
    pub kind: String,
    /// The study kind's entry in the registry.
    pub study: &'static StudyKind,
    /// Free text saying what the experiment asks.
    pub description: String,
    /// Timed repeats per run.
    pub repeats: u32,
    /// Untimed warm-up runs before the repeats.
    pub warmup: u32,
    /// Worker threads (default: all cores; `--threads` overrides).
    pub threads: Option<usize>,
    /// Parameters shared by every sweep (one value each).
    pub fixed: Vec<ManifestParam>,
    /// The sweeps, in order.
    pub sweeps: Vec<Sweep>,
    /// The reduced version, if the manifest declares one.
    pub quick: Option<Quick>,
    /// Whether `quick` has been applied (`--quick`).
    pub quick_applied: bool,
    /// The figures to draw from `data.csv`.
    pub figures: Vec<FigureSpec>,
    /// The manifest file as written (kept in `meta.json`, so `raylab
    /// merge` can rebuild the plan of sharded runs).
    pub text: String,
    kind_span: Range<usize>,
}

/// Everything one run of the experiment needs: the runs in order and the
/// columns of `data.csv`.
#[derive(Clone, Debug)]
pub struct Plan {
    /// Every run of every sweep, in manifest order.
    pub runs: Vec<RunPoint>,
    /// The parameter columns: with `sweep`, they are a run's key.
    pub param_columns: Vec<String>,
    /// Every column of `data.csv`: `sweep`, the parameters, then the
    /// study's measurements.
    pub columns: Vec<String>,
    /// Parameters that take more than one value somewhere (shown in
    /// progress messages).
    pub varying: Vec<String>,
}

impl Plan {
    /// The key of a run: its sweep and the text of every parameter column
    /// (empty where the run has no such parameter), as in `data.csv`.
    pub fn key(&self, run: &RunPoint) -> Vec<String> {
        let mut key = vec![run.sweep.clone()];
        key.extend(
            self.param_columns
                .iter()
                .map(|c| run.get(c).map(Value::to_string).unwrap_or_default()),
        );
        key
    }
}

impl Manifest {
    /// The study that runs this manifest's kind.
    pub fn study(&self) -> &'static dyn DynStudy {
        self.study.study
    }

    /// The folder relative paths in parameters are resolved against: the
    /// manifest's own folder.
    pub fn base_dir(&self) -> &Path {
        self.path.parent().unwrap_or(Path::new("."))
    }

    /// The settings the study sees.
    pub fn settings(&self) -> StudySettings {
        StudySettings {
            repeats: self.repeats,
            warmup: self.warmup,
        }
    }

    /// An error at a byte range of this manifest.
    pub fn error_at(&self, span: Range<usize>, msg: impl Into<String>) -> InputError {
        parse::error_at(&self.text, &self.path, span, msg.into())
    }

    /// The manifest with its `[quick]` block applied: its `repeats` and
    /// `warmup` replace the manifest's, its `[quick.fixed]` parameters
    /// replace or join `[fixed]`, and each `[quick.sweep.NAME]` parameter
    /// replaces the sweep's parameter of that name (or joins the sweep,
    /// varying fastest). Fails when the manifest has no `[quick]` block.
    pub fn with_quick(&self) -> Result<Manifest, InputError> {
        let q = self.quick.as_ref().ok_or_else(|| {
            InputError::file(
                &self.path,
                "--quick: this manifest has no [quick] block declaring its reduced version",
            )
        })?;
        let mut m = self.clone();
        m.repeats = q.repeats.unwrap_or(m.repeats);
        m.warmup = q.warmup.unwrap_or(m.warmup);
        replace_params(&mut m.fixed, &q.fixed);
        for (name, params) in &q.sweeps {
            if let Some(s) = m.sweeps.iter_mut().find(|s| &s.name == name) {
                replace_params(&mut s.params, params);
            }
        }
        m.quick_applied = true;
        validate::check_names(&m)?;
        Ok(m)
    }

    /// The parameter columns: `[fixed]` first, then each sweep's new
    /// names, in the order written.
    fn param_columns(&self) -> Vec<String> {
        let mut cols: Vec<String> = Vec::new();
        for p in self
            .fixed
            .iter()
            .chain(self.sweeps.iter().flat_map(|s| &s.params))
        {
            if !cols.contains(&p.name) {
                cols.push(p.name.clone());
            }
        }
        cols
    }

    /// The columns of `data.csv`: `sweep`, the parameters, then the study's
    /// measurements (a measurement named like a parameter is written once,
    /// as the parameter).
    pub fn columns(&self) -> Vec<String> {
        let params = self.param_columns();
        let mut cols = vec!["sweep".to_string()];
        cols.extend(params.iter().cloned());
        cols.extend(
            self.study()
                .columns(&self.settings())
                .into_iter()
                .filter(|c| !params.contains(c)),
        );
        cols
    }

    /// Expand every sweep into runs, check each run with the study (so a
    /// typo in the last run fails before the first one starts), and fix the
    /// columns of `data.csv`.
    pub fn plan(&self) -> Result<Plan, InputError> {
        let study = self.study();
        let total = super::sweep::total_runs(&self.fixed, &self.sweeps);
        if total.is_none_or(|n| n > MAX_RUNS) {
            return Err(InputError::file(
                &self.path,
                format!(
                    "the sweeps have {} runs in all, more than {MAX_RUNS}; split the manifest",
                    total.map_or("too many".to_string(), |n| n.to_string())
                ),
            ));
        }
        let mut runs = Vec::new();
        for sweep in &self.sweeps {
            let expanded =
                expand_sweep(&self.fixed, sweep).map_err(|e| self.error_at(e.span, e.message))?;
            runs.extend(expanded);
        }
        for run in &runs {
            study
                .check(run, self.base_dir())
                .map_err(|e| validate::run_error(self, run, e))?;
        }
        let mut varying: Vec<String> = Vec::new();
        for p in self
            .fixed
            .iter()
            .chain(self.sweeps.iter().flat_map(|s| &s.params))
        {
            if p.values.len() > 1 && !varying.contains(&p.name) {
                varying.push(p.name.clone());
            }
        }
        for f in &self.figures {
            validate::check_ratio_values(self, f, &runs)?;
        }
        Ok(Plan {
            runs,
            param_columns: self.param_columns(),
            columns: self.columns(),
            varying,
        })
    }

    /// The manifest as it runs (after `--quick`), as JSON for `meta.json`:
    /// every parameter with its expanded values.
    pub fn to_json(&self) -> serde_json::Value {
        let params = |ps: &[ManifestParam]| -> serde_json::Map<String, serde_json::Value> {
            ps.iter()
                .map(|p| {
                    let v = if p.values.len() == 1 {
                        serde_json::json!(p.values[0])
                    } else {
                        serde_json::json!(p.values)
                    };
                    (p.name.clone(), v)
                })
                .collect()
        };
        serde_json::json!({
            "path": self.path.display().to_string(),
            "name": self.name,
            "kind": self.kind,
            "description": self.description,
            "repeats": self.repeats,
            "warmup": self.warmup,
            "threads": self.threads,
            "fixed": params(&self.fixed),
            "sweep": self.sweeps.iter().map(|s| serde_json::json!({
                "name": s.name,
                "params": params(&s.params),
            })).collect::<Vec<_>>(),
            "quick_applied": self.quick_applied,
            "figure": self.figures,
        })
    }
}

/// Replace parameters by name, appending the ones not present.
fn replace_params(params: &mut Vec<ManifestParam>, new: &[ManifestParam]) {
    for p in new {
        match params.iter_mut().find(|q| q.name == p.name) {
            Some(q) => *q = p.clone(),
            None => params.push(p.clone()),
        }
    }
}
