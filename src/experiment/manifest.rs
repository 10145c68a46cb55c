//! Experiment manifests: the TOML file that says what an experiment runs
//! and draws (format in the [module documentation](super)).
//!
//! [`load_manifest`] parses and checks a manifest; every error names the
//! file, the line and the column, like the scene loader. [`Manifest::plan`]
//! expands the sweeps into runs, checks every run with its study, and fixes
//! the columns of `data.csv`.

use super::study::{self, ParamError, Study, StudySettings};
use super::sweep::{expand_sweep, expand_values, template_names, Param, RunPoint, Sweep, Value};
use crate::analysis::plot::LegendPosition;
use crate::io::{line_col, InputError, Place};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};
use toml::Spanned;

/// Repeats of each timed measurement when the manifest does not say.
pub const DEFAULT_REPEATS: u32 = 5;
/// Untimed warm-up runs before the repeats when the manifest does not say.
pub const DEFAULT_WARMUP: u32 = 1;

/// A parameter block as written: parameter name → value (scalar, list or
/// range table), each with its place in the file.
type ParamTable = BTreeMap<String, Spanned<toml::Value>>;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ManifestFile {
    name: Spanned<String>,
    kind: Spanned<String>,
    #[serde(default)]
    description: String,
    repeats: Option<Spanned<u32>>,
    warmup: Option<u32>,
    threads: Option<Spanned<u32>>,
    #[serde(default)]
    fixed: ParamTable,
    #[serde(default)]
    sweep: Vec<Spanned<ParamTable>>,
    quick: Option<Spanned<QuickFile>>,
    #[serde(default)]
    figure: Vec<Spanned<FigureFile>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct QuickFile {
    repeats: Option<Spanned<u32>>,
    warmup: Option<u32>,
    #[serde(default)]
    fixed: ParamTable,
    #[serde(default)]
    sweep: BTreeMap<String, Spanned<ParamTable>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FigureFile {
    file: Spanned<String>,
    kind: FigureKind,
    sweep: Option<Spanned<String>>,
    x: Spanned<String>,
    y: Spanned<toml::Value>,
    series: Option<Spanned<String>>,
    numerator: Option<String>,
    denominator: Option<String>,
    #[serde(default)]
    series_labels: BTreeMap<String, String>,
    #[serde(default)]
    title: String,
    x_label: Option<String>,
    y_label: Option<String>,
    #[serde(default)]
    x_log: bool,
    #[serde(default)]
    y_log: bool,
    dashed_where: Option<String>,
    #[serde(default)]
    fit_slope: bool,
    #[serde(default)]
    only: BTreeMap<String, Vec<String>>,
    legend: Option<Spanned<String>>,
    #[serde(default)]
    reference: Vec<Spanned<ReferenceFile>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ReferenceFile {
    label: String,
    x: toml::Value,
    y: Vec<f64>,
    #[serde(default)]
    style: ReferenceStyle,
    #[serde(default = "yes")]
    summary: bool,
}

fn yes() -> bool {
    true
}

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
    pub fixed: Vec<Param>,
    /// Per sweep name: parameters that replace (or are added to) the sweep's.
    pub sweeps: Vec<(String, Vec<Param>)>,
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
    /// Free text saying what the experiment asks.
    pub description: String,
    /// Timed repeats per run.
    pub repeats: u32,
    /// Untimed warm-up runs before the repeats.
    pub warmup: u32,
    /// Worker threads (default: all cores; `--threads` overrides).
    pub threads: Option<usize>,
    /// Parameters shared by every sweep (one value each).
    pub fixed: Vec<Param>,
    /// The sweeps, in order.
    pub sweeps: Vec<Sweep>,
    /// The reduced version, if the manifest declares one.
    pub quick: Option<Quick>,
    /// Whether `quick` has been applied (`--quick`).
    pub quick_applied: bool,
    /// The figures to draw from `data.csv`.
    pub figures: Vec<FigureSpec>,
    text: String,
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

/// Read and check a manifest. Errors name the file, line and column.
pub fn load_manifest(path: &Path) -> Result<Manifest, InputError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| InputError::file(path, format!("cannot read manifest: {e}")))?;
    parse_manifest(&text, path)
}

/// Check a manifest given as text; `path` names it in errors and anchors
/// relative paths.
pub fn parse_manifest(text: &str, path: &Path) -> Result<Manifest, InputError> {
    let at = |span: Range<usize>, msg: String| error_at(text, path, span, msg);
    let file: ManifestFile = toml::from_str(text).map_err(|e| match e.span() {
        Some(span) => at(span, e.message().trim().to_string()),
        None => InputError::file(path, e.message().trim().to_string()),
    })?;

    let name = file.name.get_ref().clone();
    if !is_file_name(&name) {
        return Err(at(
            file.name.span(),
            format!(
                "`name` = {name:?} must be a plain file name (letters, digits, `-`, `_`, `.`): \
                 it names the output folder"
            ),
        ));
    }
    let kind = file.kind.get_ref().clone();
    if study::find(&kind).is_none() {
        return Err(at(
            file.kind.span(),
            format!(
                "unknown study kind `{kind}` (known: {})",
                quoted(study::KINDS.iter().copied())
            ),
        ));
    }
    let repeats = match &file.repeats {
        Some(r) if *r.get_ref() == 0 => {
            return Err(at(r.span(), "`repeats` must be at least 1".into()))
        }
        Some(r) => *r.get_ref(),
        None => DEFAULT_REPEATS,
    };
    let threads = match &file.threads {
        Some(t) if *t.get_ref() == 0 => {
            return Err(at(t.span(), "`threads` must be at least 1".into()))
        }
        Some(t) => Some(*t.get_ref() as usize),
        None => None,
    };
    let fixed = single_values(text, path, "[fixed]", &file.fixed)?;

    if file.sweep.is_empty() {
        return Err(InputError::file(
            path,
            "no [[sweep]] block: an experiment needs at least one sweep",
        ));
    }
    let mut sweeps: Vec<Sweep> = Vec::new();
    for block in &file.sweep {
        let span = block.span();
        let mut table = block.get_ref().clone();
        let name = match table.remove("name") {
            Some(n) => match n.get_ref() {
                toml::Value::String(s) if !s.trim().is_empty() => s.clone(),
                _ => {
                    return Err(at(
                        n.span(),
                        "sweep `name` must be a non-empty string".into(),
                    ))
                }
            },
            None => return Err(at(span, "a [[sweep]] block needs a `name`".into())),
        };
        if sweeps.iter().any(|s| s.name == name) {
            return Err(at(span, format!("two sweeps are named `{name}`")));
        }
        let params = param_list(text, path, &format!("sweep `{name}`"), &table)?;
        sweeps.push(Sweep { name, params, span });
    }

    let quick = match &file.quick {
        None => None,
        Some(q) => Some(quick_block(text, path, q, &fixed, &sweeps)?),
    };

    let mut figures = Vec::new();
    for f in &file.figure {
        let spec = figure_spec(text, path, f)?;
        if figures.iter().any(|g: &FigureSpec| g.file == spec.file) {
            return Err(at(
                f.get_ref().file.span(),
                format!("two figures write `{}`", spec.file),
            ));
        }
        figures.push(spec);
    }

    let manifest = Manifest {
        path: path.to_path_buf(),
        name,
        kind,
        description: file.description,
        repeats,
        warmup: file.warmup.unwrap_or(DEFAULT_WARMUP),
        threads,
        fixed,
        sweeps,
        quick,
        quick_applied: false,
        figures,
        text: text.to_string(),
        kind_span: file.kind.span(),
    };
    manifest.check_names()?;
    Ok(manifest)
}

fn error_at(text: &str, path: &Path, span: Range<usize>, msg: String) -> InputError {
    let (l, c) = line_col(text, span.start);
    InputError::new(path, Place::LineCol(l, c), msg)
}

fn quoted<'a>(names: impl Iterator<Item = &'a str>) -> String {
    names
        .map(|n| format!("`{n}`"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Names used for files and folders: no separators, no leading dot.
fn is_file_name(s: &str) -> bool {
    !s.is_empty()
        && !s.starts_with('.')
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'))
}

/// Parameters of a block, each expanded to its values, in the order they
/// are written (TOML tables come back sorted by key; the spans restore the
/// order of the file).
fn param_list(
    text: &str,
    path: &Path,
    block: &str,
    table: &ParamTable,
) -> Result<Vec<Param>, InputError> {
    let mut params = Vec::new();
    for (name, value) in table {
        if name == "sweep" {
            return Err(error_at(
                text,
                path,
                value.span(),
                format!("{block}: `sweep` is the name of a column, not a parameter"),
            ));
        }
        let values = expand_values(value.get_ref()).map_err(|msg| {
            error_at(
                text,
                path,
                value.span(),
                format!("{block}, parameter `{name}`: {msg}"),
            )
        })?;
        params.push(Param {
            name: name.clone(),
            values,
            span: value.span(),
        });
    }
    params.sort_by_key(|p| p.span.start);
    Ok(params)
}

/// A block whose parameters take one value each (`[fixed]`).
fn single_values(
    text: &str,
    path: &Path,
    block: &str,
    table: &ParamTable,
) -> Result<Vec<Param>, InputError> {
    let params = param_list(text, path, block, table)?;
    for p in &params {
        if p.values.len() != 1 {
            return Err(error_at(
                text,
                path,
                p.span.clone(),
                format!(
                    "{block}, parameter `{}`: takes one value; put lists and ranges in a [[sweep]]",
                    p.name
                ),
            ));
        }
    }
    Ok(params)
}

fn quick_block(
    text: &str,
    path: &Path,
    q: &Spanned<QuickFile>,
    fixed: &[Param],
    sweeps: &[Sweep],
) -> Result<Quick, InputError> {
    let at = |span: Range<usize>, msg: String| error_at(text, path, span, msg);
    let qf = q.get_ref();
    let repeats = match &qf.repeats {
        Some(r) if *r.get_ref() == 0 => {
            return Err(at(r.span(), "[quick] `repeats` must be at least 1".into()))
        }
        r => r.as_ref().map(|r| *r.get_ref()),
    };
    let quick_fixed = single_values(text, path, "[quick.fixed]", &qf.fixed)?;
    let mut quick_sweeps = Vec::new();
    for (name, table) in &qf.sweep {
        let Some(sweep) = sweeps.iter().find(|s| &s.name == name) else {
            return Err(at(
                table.span(),
                format!(
                    "[quick.sweep.{name}]: no sweep is named `{name}` (sweeps: {})",
                    quoted(sweeps.iter().map(|s| s.name.as_str()))
                ),
            ));
        };
        let block = format!("[quick.sweep.{name}]");
        let params = param_list(text, path, &block, table.get_ref())?;
        for p in &params {
            let known = sweep.params.iter().any(|s| s.name == p.name)
                || fixed.iter().any(|f| f.name == p.name);
            if !known {
                return Err(at(
                    p.span.clone(),
                    format!(
                        "{block}: parameter `{}` is neither in sweep `{name}` nor in [fixed]",
                        p.name
                    ),
                ));
            }
        }
        quick_sweeps.push((name.clone(), params));
    }
    Ok(Quick {
        repeats,
        warmup: qf.warmup,
        fixed: quick_fixed,
        sweeps: quick_sweeps,
    })
}

fn figure_spec(text: &str, path: &Path, f: &Spanned<FigureFile>) -> Result<FigureSpec, InputError> {
    let at = |span: Range<usize>, msg: String| error_at(text, path, span, msg);
    let d = f.get_ref();
    let file = d.file.get_ref().clone();
    if !is_file_name(&file) {
        return Err(at(
            d.file.span(),
            format!("figure `file` = {file:?} must be a plain file name without extension"),
        ));
    }
    let ys: Vec<String> = match d.y.get_ref() {
        toml::Value::String(c) => vec![c.clone()],
        toml::Value::Array(cols) if !cols.is_empty() => cols
            .iter()
            .map(|c| c.as_str().map(str::to_string))
            .collect::<Option<Vec<_>>>()
            .unwrap_or_default(),
        _ => Vec::new(),
    };
    if ys.is_empty() {
        return Err(at(
            d.y.span(),
            format!("figure `{file}`: `y` must be a column name or a list of column names"),
        ));
    }
    let ratio_parts = d.numerator.is_some() || d.denominator.is_some();
    let is_ratio = d.kind == FigureKind::Ratio;
    if is_ratio && (d.series.is_none() || d.numerator.is_none() || d.denominator.is_none()) {
        return Err(at(
            f.span(),
            format!(
                "figure `{file}`: a ratio needs `series`, `numerator` and `denominator` \
                 (e.g. series = \"sampler\", numerator = \"ogss:2\", denominator = \"centre\")"
            ),
        ));
    }
    if !is_ratio && ratio_parts {
        return Err(at(
            f.span(),
            format!("figure `{file}`: `numerator` and `denominator` belong to kind = \"ratio\""),
        ));
    }
    let legend = match &d.legend {
        None => LegendPosition::Auto,
        Some(l) => match l.get_ref().as_str() {
            "auto" => LegendPosition::Auto,
            "upper-left" => LegendPosition::UpperLeft,
            "upper-right" => LegendPosition::UpperRight,
            "lower-left" => LegendPosition::LowerLeft,
            "lower-right" => LegendPosition::LowerRight,
            "hidden" => LegendPosition::Hidden,
            other => {
                return Err(at(
                    l.span(),
                    format!(
                        "figure `{file}`: legend `{other}` is not one of auto, upper-left, \
                         upper-right, lower-left, lower-right, hidden"
                    ),
                ))
            }
        },
    };
    let mut references = Vec::new();
    for r in &d.reference {
        let rd = r.get_ref();
        let xs = expand_values(&rd.x)
            .and_then(|vs| {
                vs.iter()
                    .map(|v| {
                        v.as_f64().ok_or_else(|| {
                            format!("x values must be numbers, got {}", v.type_name())
                        })
                    })
                    .collect::<Result<Vec<f64>, String>>()
            })
            .map_err(|msg| {
                at(
                    r.span(),
                    format!("figure `{file}`, reference `{}`: {msg}", rd.label),
                )
            })?;
        if xs.len() != rd.y.len() {
            return Err(at(
                r.span(),
                format!(
                    "figure `{file}`, reference `{}`: {} x values but {} y values",
                    rd.label,
                    xs.len(),
                    rd.y.len()
                ),
            ));
        }
        references.push(Reference {
            label: rd.label.clone(),
            points: xs.into_iter().zip(rd.y.iter().copied()).collect(),
            style: rd.style,
            summary: rd.summary,
        });
    }
    Ok(FigureSpec {
        file,
        kind: d.kind,
        sweep: d.sweep.as_ref().map(|s| s.get_ref().clone()),
        x: d.x.get_ref().clone(),
        y: ys,
        series: d.series.as_ref().map(|s| s.get_ref().clone()),
        numerator: d.numerator.clone(),
        denominator: d.denominator.clone(),
        series_labels: d.series_labels.clone(),
        title: d.title.clone(),
        x_label: d.x_label.clone(),
        y_label: d.y_label.clone(),
        x_log: d.x_log,
        y_log: d.y_log,
        dashed_where: d.dashed_where.clone(),
        fit_slope: d.fit_slope,
        only: d.only.clone(),
        legend,
        references,
        spans: FigureSpans {
            block: f.span(),
            x: d.x.span(),
            y: d.y.span(),
            series: d.series.as_ref().map(|s| s.span()),
            sweep: d.sweep.as_ref().map(|s| s.span()),
        },
    })
}

impl Manifest {
    /// The study that runs this manifest's kind.
    pub fn study(&self) -> &'static dyn Study {
        // The kind was checked when the manifest was loaded.
        study::find(&self.kind).unwrap_or(&study::render_cost::RenderCost)
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
        error_at(&self.text, &self.path, span, msg.into())
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
        m.check_names()?;
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

    /// Check names: every parameter is one the study reads or one a
    /// template uses, and every figure names existing columns and sweeps.
    fn check_names(&self) -> Result<(), InputError> {
        let study = self.study();
        let known: Vec<&str> = study.parameters().iter().map(|p| p.name).collect();
        let all_params = || {
            self.fixed
                .iter()
                .chain(self.sweeps.iter().flat_map(|s| &s.params))
                .chain(self.quick.iter().flat_map(|q| {
                    q.fixed
                        .iter()
                        .chain(q.sweeps.iter().flat_map(|(_, ps)| ps.iter()))
                }))
        };
        let mut in_templates: Vec<String> = Vec::new();
        for p in all_params() {
            for v in &p.values {
                if let Value::Str(s) = v {
                    in_templates.extend(template_names(s));
                }
            }
        }
        for p in all_params() {
            if !known.contains(&p.name.as_str()) && !in_templates.contains(&p.name) {
                return Err(self.error_at(
                    p.span.clone(),
                    format!(
                        "unknown parameter `{}` for kind `{}` (known: {}; other names \
                         are allowed only when a `{{name}}` template uses them)",
                        p.name,
                        self.kind,
                        quoted(known.iter().copied())
                    ),
                ));
            }
        }
        let columns = self.columns();
        for f in &self.figures {
            if let (Some(s), Some(span)) = (&f.sweep, &f.spans.sweep) {
                if !self.sweeps.iter().any(|w| &w.name == s) {
                    return Err(self.error_at(
                        span.clone(),
                        format!(
                            "figure `{}`: no sweep is named `{s}` (sweeps: {})",
                            f.file,
                            quoted(self.sweeps.iter().map(|w| w.name.as_str()))
                        ),
                    ));
                }
            }
            let named = std::iter::once((Some(&f.x), Some(&f.spans.x), "x"))
                .chain(f.y.iter().map(|y| (Some(y), Some(&f.spans.y), "y")))
                .chain(std::iter::once((
                    f.series.as_ref(),
                    f.spans.series.as_ref(),
                    "series",
                )));
            for (col, span, field) in named {
                if let (Some(col), Some(span)) = (col, span) {
                    if !columns.contains(col) {
                        return Err(self.error_at(
                            span.clone(),
                            format!(
                                "figure `{}`: `{field}` = `{col}` is not a column of data.csv \
                                 (columns: {})",
                                f.file,
                                columns.join(", ")
                            ),
                        ));
                    }
                }
            }
        }
        Ok(())
    }

    /// Expand every sweep into runs, check each run with the study (so a
    /// typo in the last run fails before the first one starts), and fix the
    /// columns of `data.csv`.
    pub fn plan(&self) -> Result<Plan, InputError> {
        let study = self.study();
        let mut runs = Vec::new();
        for sweep in &self.sweeps {
            let expanded =
                expand_sweep(&self.fixed, sweep).map_err(|(span, msg)| self.error_at(span, msg))?;
            runs.extend(expanded);
        }
        for run in &runs {
            study
                .check(run, self.base_dir())
                .map_err(|e| self.run_error(run, e))?;
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
            self.check_ratio_values(f, &runs)?;
        }
        Ok(Plan {
            runs,
            param_columns: self.param_columns(),
            columns: self.columns(),
            varying,
        })
    }

    /// An error a study found in one run, placed at the parameter's value.
    fn run_error(&self, run: &RunPoint, e: ParamError) -> InputError {
        let span = e
            .param
            .as_deref()
            .and_then(|name| run.param(name))
            .map(|p| p.span.clone())
            .or_else(|| {
                self.sweeps
                    .iter()
                    .find(|s| s.name == run.sweep)
                    .map(|s| s.span.clone())
            })
            .unwrap_or(self.kind_span.clone());
        let what = match &e.param {
            Some(p) => format!("sweep `{}`, parameter `{p}`", run.sweep),
            None => format!("sweep `{}`", run.sweep),
        };
        self.error_at(span, format!("{what}: {}", e.message))
    }

    /// A ratio's numerator and denominator must be values the series
    /// parameter takes, or the figure would come out empty.
    fn check_ratio_values(&self, f: &FigureSpec, runs: &[RunPoint]) -> Result<(), InputError> {
        let (Some(series), Some(num), Some(den)) = (&f.series, &f.numerator, &f.denominator) else {
            return Ok(());
        };
        let values: Vec<String> = runs
            .iter()
            .filter(|r| f.sweep.as_ref().map_or(true, |s| &r.sweep == s))
            .filter_map(|r| r.get(series).map(Value::to_string))
            .collect();
        if values.is_empty() {
            // The series is a measured column: checked when drawing.
            return Ok(());
        }
        for v in [num, den] {
            if !values.contains(v) {
                return Err(self.error_at(
                    f.spans.block.clone(),
                    format!(
                        "figure `{}`: no run has {series} = `{v}` (values: {})",
                        f.file,
                        quoted({
                            let mut u: Vec<&str> = values.iter().map(String::as_str).collect();
                            u.dedup();
                            u.into_iter()
                        })
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The manifest as it runs (after `--quick`), as JSON for `meta.json`:
    /// every parameter with its expanded values.
    pub fn to_json(&self) -> serde_json::Value {
        let params = |ps: &[Param]| -> serde_json::Map<String, serde_json::Value> {
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
fn replace_params(params: &mut Vec<Param>, new: &[Param]) {
    for p in new {
        match params.iter_mut().find(|q| q.name == p.name) {
            Some(q) => *q = p.clone(),
            None => params.push(p.clone()),
        }
    }
}
