//! Reading a manifest: TOML into the file's own structs (serde, every
//! table with `deny_unknown_fields`, every name and value with its
//! [`Spanned`] place), then into a [`Manifest`]: parameter values
//! expanded, `[quick]` and `[[figure]]` blocks checked on their own. What
//! needs the whole manifest (parameter and column names against the study)
//! is [`super::validate`]'s.

use super::validate::check_names;
use super::{
    FigureKind, FigureSpans, FigureSpec, Manifest, Quick, Reference, ReferenceStyle,
    DEFAULT_REPEATS, DEFAULT_WARMUP, MAX_REPEATS,
};
use crate::analysis::plot::LegendPosition;
use crate::experiment::params::quoted;
use crate::experiment::study::{self, KINDS};
use crate::experiment::sweep::{expand_values, ManifestParam, Sweep, ValueError};
use raylab::integrator::MAX_THREADS;
use raylab::io::{line_col, InputError, Place};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::ops::Range;
use std::path::Path;
use toml::Spanned;

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
    dashed_where: Option<Spanned<String>>,
    #[serde(default)]
    fit_slope: bool,
    only: Option<Spanned<BTreeMap<String, Vec<String>>>>,
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

/// Read and check a manifest. Errors name the file, line and column.
pub fn load_manifest(path: &Path) -> Result<Manifest, InputError> {
    let text = raylab::io::input::read_to_string(path, raylab::io::input::InputKind::Manifest)?;
    parse_manifest(&text, path)
}

/// Check a manifest given as text; `path` names it in errors and anchors
/// relative paths.
pub fn parse_manifest(text: &str, path: &Path) -> Result<Manifest, InputError> {
    let at = |span: Range<usize>, msg: String| error_at(text, path, span, msg);
    let file: ManifestFile = toml::from_str(text).map_err(|e| toml_error(text, path, &e))?;

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
    let Some(study) = study::find(&kind) else {
        return Err(at(
            file.kind.span(),
            format!(
                "unknown study kind `{kind}` (known: {})",
                quoted(KINDS.iter().map(|k| k.name))
            ),
        ));
    };
    let repeats = match &file.repeats {
        Some(r) if *r.get_ref() == 0 => {
            return Err(at(r.span(), "`repeats` must be at least 1".into()))
        }
        Some(r) if *r.get_ref() > MAX_REPEATS => {
            return Err(at(
                r.span(),
                format!(
                    "`repeats` must be at most {MAX_REPEATS}, got {}",
                    r.get_ref()
                ),
            ))
        }
        Some(r) => *r.get_ref(),
        None => DEFAULT_REPEATS,
    };
    let threads = match &file.threads {
        Some(t) if *t.get_ref() == 0 || *t.get_ref() as usize > MAX_THREADS => {
            return Err(at(
                t.span(),
                format!(
                    "`threads` must be from 1 to {MAX_THREADS}, got {}",
                    t.get_ref()
                ),
            ))
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
        study,
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
    check_names(&manifest)?;
    Ok(manifest)
}

/// A TOML syntax or type error at its place in the manifest. Type errors
/// point at the value; the message then gets the key written before it on
/// that line ("`repeats`: invalid type: string \"3\", expected …").
fn toml_error(text: &str, path: &Path, e: &toml::de::Error) -> InputError {
    let msg = raylab::io::toml_message(text, e)
        .replace("expected u32", "expected a non-negative integer");
    match e.span() {
        Some(span) => {
            let msg = match key_before(text, span.start) {
                Some(k) if !msg.contains(&format!("`{k}`")) => format!("`{k}`: {msg}"),
                _ => msg,
            };
            error_at(text, path, span, msg)
        }
        None => InputError::file(path, msg),
    }
}

/// The key of a `key = value` line when `offset` lies in the value.
fn key_before(text: &str, offset: usize) -> Option<&str> {
    let offset = offset.min(text.len());
    let start = text[..offset].rfind('\n').map_or(0, |i| i + 1);
    let eq = text[start..offset].find('=')?;
    let key = text[start..start + eq].trim();
    let bare = |c: char| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.');
    (!key.is_empty() && key.chars().all(bare)).then_some(key)
}

/// An error at a byte range of a manifest's text.
pub(super) fn error_at(text: &str, path: &Path, span: Range<usize>, msg: String) -> InputError {
    let (l, c) = line_col(text, span.start);
    InputError::new(path, Place::LineCol(l, c), msg)
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
) -> Result<Vec<ManifestParam>, InputError> {
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
        params.push(ManifestParam {
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
) -> Result<Vec<ManifestParam>, InputError> {
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
    fixed: &[ManifestParam],
    sweeps: &[Sweep],
) -> Result<Quick, InputError> {
    let at = |span: Range<usize>, msg: String| error_at(text, path, span, msg);
    let qf = q.get_ref();
    let repeats = match &qf.repeats {
        Some(r) if *r.get_ref() == 0 => {
            return Err(at(r.span(), "[quick] `repeats` must be at least 1".into()))
        }
        Some(r) if *r.get_ref() > MAX_REPEATS => {
            return Err(at(
                r.span(),
                format!(
                    "[quick] `repeats` must be at most {MAX_REPEATS}, got {}",
                    r.get_ref()
                ),
            ))
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
                            ValueError(format!("x values must be numbers, got {}", v.type_name()))
                        })
                    })
                    .collect::<Result<Vec<f64>, ValueError>>()
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
        dashed_where: d.dashed_where.as_ref().map(|s| s.get_ref().clone()),
        fit_slope: d.fit_slope,
        only: d
            .only
            .as_ref()
            .map(|o| o.get_ref().clone())
            .unwrap_or_default(),
        legend,
        references,
        spans: FigureSpans {
            block: f.span(),
            x: d.x.span(),
            y: d.y.span(),
            series: d.series.as_ref().map(|s| s.span()),
            sweep: d.sweep.as_ref().map(|s| s.span()),
            only: d.only.as_ref().map(|o| o.span()),
            dashed_where: d.dashed_where.as_ref().map(|s| s.span()),
        },
    })
}

#[cfg(test)]
mod tests {
    use super::super::test_util::{assert_at, error, good_with, GOOD};
    use super::*;

    /// Replace `from` with `to` in `GOOD`; the error is at `to`'s line.
    fn assert_bad(from: &str, to: &str, expect: &[&str]) {
        let text = good_with(from, to);
        assert_at(&error(&text), &text, to, expect);
    }

    #[test]
    fn a_good_manifest_reads_in_order() {
        let m = parse_manifest(GOOD, Path::new("dir/m.toml")).unwrap();
        assert_eq!((m.name.as_str(), m.kind.as_str()), ("t", "render_cost"));
        assert_eq!(m.study.name, "render_cost");
        assert_eq!((m.repeats, m.warmup, m.threads), (2, DEFAULT_WARMUP, None));
        assert_eq!(m.base_dir(), Path::new("dir"));
        let names: Vec<_> = m.sweeps.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(names, ["sizes", "scenes"]);
        // Parameters in the order written, not TOML's sorted order.
        let params: Vec<_> = m.sweeps[0].params.iter().map(|p| p.name.as_str()).collect();
        assert_eq!(params, ["resolution", "sampler"]);
        assert_eq!(m.sweeps[1].params[0].values.len(), 3);
        let f = &m.figures[0];
        assert_eq!((f.file.as_str(), f.kind), ("time", FigureKind::Line));
        assert_eq!(f.y, ["render_median_s", "rays"]);
        assert_eq!(f.only["sampler"], ["centre"]);
        assert_eq!(f.legend, LegendPosition::Auto);
        let cols = m.columns();
        assert_eq!(
            cols[..6],
            ["sweep", "scene", "resolution", "sampler", "index", "width"]
        );
        assert!(cols.contains(&"render_s_2".to_string()));
        let q = m.with_quick().unwrap();
        assert_eq!(q.repeats, 1);
        assert_eq!(q.sweeps[0].params[0].values.len(), 1);
        assert!(!q.columns().contains(&"render_s_2".to_string()));
    }

    #[test]
    fn unknown_fields_are_errors_at_their_line() {
        assert_bad("repeats = 2", "repeat = 2", &["unknown field `repeat`"]);
        assert_bad(
            "series = \"sampler\"",
            "colour = \"red\"",
            &["unknown field `colour`"],
        );
        let text = good_with("[quick]\nrepeats = 1", "[quick]\nrepeets = 1");
        assert_at(
            &error(&text),
            &text,
            "repeets",
            &["unknown field `repeets`"],
        );
    }

    #[test]
    fn wrong_types_name_the_field() {
        assert_bad(
            "repeats = 2",
            "repeats = \"2\"",
            &["`repeats`", "invalid type", "non-negative integer"],
        );
        assert_bad(
            "series = \"sampler\"",
            "x_log = \"yes\"",
            &["`x_log`", "invalid type"],
        );
        assert_bad(
            "kind = \"line\"",
            "kind = \"pie\"",
            &["`kind`", "pie", "ratio"],
        );
    }

    #[test]
    fn missing_fields_are_named() {
        let text = good_with("name = \"t\"\n", "");
        assert_at(&error(&text), &text, "", &["missing field `name`"]);
        let text = good_with("x = \"width\"\n", "");
        let err = error(&text);
        assert!(err.contains("dir/m.toml:"), "{err}");
        assert!(err.contains("missing field `x`"), "{err}");
        let text = good_with("name = \"scenes\"\n", "");
        assert_at(
            &error(&text),
            &text,
            "[[sweep]]\nindex",
            &["needs a `name`"],
        );
    }

    #[test]
    fn unknown_study_kinds_list_the_known_ones() {
        assert_bad(
            "kind = \"render_cost\"",
            "kind = \"render_cots\"",
            &[
                "unknown study kind `render_cots`",
                "`render_cost`",
                "`floodfill`",
            ],
        );
    }

    #[test]
    fn blocks_are_checked_on_their_own() {
        assert_bad(
            "scene = \"scene.toml\"",
            "scene = [\"a.toml\", \"b.toml\"]",
            &["[fixed], parameter `scene`", "takes one value"],
        );
        assert_bad(
            "{ from = 1, to = 3, step = 1 }",
            "{ from = 1, to = 3, step = 0 }",
            &["sweep `scenes`, parameter `index`", "step"],
        );
        let text = good_with("name = \"scenes\"", "name = \"sizes\"");
        assert_at(
            &error(&text),
            &text,
            "[[sweep]]\nname = \"sizes\"\nindex",
            &["two sweeps are named `sizes`"],
        );
        assert_bad(
            "[quick.sweep.sizes]",
            "[quick.sweep.size]",
            &["no sweep is named `size`", "`sizes`"],
        );
        assert_bad("file = \"time\"", "file = \"a/b\"", &["plain file name"]);
        assert_bad(
            "series = \"sampler\"",
            "legend = \"middle\"",
            &["legend `middle` is not one of auto"],
        );
        assert_bad(
            "repeats = 2",
            "repeats = 0",
            &["`repeats` must be at least 1"],
        );
        // Found by crates/lab/tests/fuzz.rs: a template row of 2³¹ repeats made
        // parse_manifest ask for 17 GB.
        assert_bad(
            "repeats = 2",
            "repeats = 2147483647",
            &["`repeats` must be at most 1000"],
        );
    }
}
