//! Checking a manifest against its study, before anything runs: every
//! parameter is one the study reads (its parameter struct's fields) or a
//! helper that a `{name}` template uses; every figure names sweeps that
//! exist and columns that the experiment writes (`x`, `y`, `series`, the
//! keys of `only`, `dashed_where`), with the columns that do exist in the
//! message; and, once the sweeps are expanded, every run's values are ones
//! the study accepts ([`run_error`] places its complaint at the value).

use super::{FigureSpec, Manifest};
use crate::experiment::params::{quoted, RunParamError};
use crate::experiment::sweep::{template_names, RunPoint, Value};
use raylab::io::InputError;
use std::ops::Range;

/// Check names: every parameter is one the study reads or one a
/// template uses, and every figure names existing columns and sweeps.
pub fn check_names(m: &Manifest) -> Result<(), InputError> {
    check_parameters(m)?;
    let columns = m.columns();
    for f in &m.figures {
        check_figure(m, f, &columns)?;
    }
    Ok(())
}

/// Every parameter written anywhere (`[fixed]`, the sweeps, `[quick]`) is
/// a field of the study's parameters or a name a template uses.
fn check_parameters(m: &Manifest) -> Result<(), InputError> {
    let known = m.study().parameter_names();
    let all_params = || {
        m.fixed
            .iter()
            .chain(m.sweeps.iter().flat_map(|s| &s.params))
            .chain(m.quick.iter().flat_map(|q| {
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
            return Err(m.error_at(
                p.span.clone(),
                format!(
                    "unknown parameter `{}` for kind `{}` (known: {}; other names \
                     are allowed only when a `{{name}}` template uses them)",
                    p.name,
                    m.kind,
                    quoted(known.iter().copied())
                ),
            ));
        }
    }
    Ok(())
}

/// A figure's sweep exists and every column it names is one of `columns`.
fn check_figure(m: &Manifest, f: &FigureSpec, columns: &[String]) -> Result<(), InputError> {
    if let (Some(s), Some(span)) = (&f.sweep, &f.spans.sweep) {
        if !m.sweeps.iter().any(|w| &w.name == s) {
            return Err(m.error_at(
                span.clone(),
                format!(
                    "figure `{}`: no sweep is named `{s}` (sweeps: {})",
                    f.file,
                    quoted(m.sweeps.iter().map(|w| w.name.as_str()))
                ),
            ));
        }
    }
    // (column, where it is written, the field that names it)
    let mut named: Vec<(&String, &Range<usize>, &str)> = vec![(&f.x, &f.spans.x, "x")];
    named.extend(f.y.iter().map(|y| (y, &f.spans.y, "y")));
    if let (Some(c), Some(span)) = (&f.series, &f.spans.series) {
        named.push((c, span, "series"));
    }
    if let (Some(c), Some(span)) = (&f.dashed_where, &f.spans.dashed_where) {
        named.push((c, span, "dashed_where"));
    }
    if let Some(span) = &f.spans.only {
        named.extend(f.only.keys().map(|c| (c, span, "only")));
    }
    for (col, span, field) in named {
        if !columns.contains(col) {
            return Err(m.error_at(
                span.clone(),
                format!(
                    "figure `{}`: `{field}` names `{col}`, which is not a column of data.csv \
                     (kind `{}` with these parameters writes: {})",
                    f.file,
                    m.kind,
                    columns.join(", ")
                ),
            ));
        }
    }
    Ok(())
}

/// An error a study found in one run, placed at the parameter's value.
pub fn run_error(m: &Manifest, run: &RunPoint, e: RunParamError) -> InputError {
    let span = e
        .param
        .as_deref()
        .and_then(|name| run.param(name))
        .map(|p| p.span.clone())
        .or_else(|| {
            m.sweeps
                .iter()
                .find(|s| s.name == run.sweep)
                .map(|s| s.span.clone())
        })
        .unwrap_or(m.kind_span.clone());
    let what = match &e.param {
        Some(p) => format!("sweep `{}`, parameter `{p}`", run.sweep),
        None => format!("sweep `{}`", run.sweep),
    };
    m.error_at(span, format!("{what}: {}", e.message))
}

/// A ratio's numerator and denominator must be values the series
/// parameter takes, or the figure would come out empty.
pub fn check_ratio_values(
    m: &Manifest,
    f: &FigureSpec,
    runs: &[RunPoint],
) -> Result<(), InputError> {
    let (Some(series), Some(num), Some(den)) = (&f.series, &f.numerator, &f.denominator) else {
        return Ok(());
    };
    let values: Vec<String> = runs
        .iter()
        .filter(|r| f.sweep.as_ref().is_none_or(|s| &r.sweep == s))
        .filter_map(|r| r.get(series).map(Value::to_string))
        .collect();
    if values.is_empty() {
        // The series is a measured column: checked when drawing.
        return Ok(());
    }
    for v in [num, den] {
        if !values.contains(v) {
            return Err(m.error_at(
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

#[cfg(test)]
mod tests {
    use super::super::parse_manifest;
    use super::super::test_util::{assert_at, error, good_with, GOOD};

    /// Replace `from` with `to` in the good manifest; the error is at the
    /// line of `at`.
    fn assert_bad(from: &str, to: &str, at: &str, expect: &[&str]) {
        let text = good_with(from, to);
        assert_at(&error(&text), &text, at, expect);
    }

    /// Plan `text` as `m.toml` in a folder holding the scene files it
    /// names; the error of the plan.
    fn plan_error(text: &str) -> String {
        let dir = tempfile::tempdir().unwrap();
        for f in ["scene.toml", "scene-1.toml", "scene-2.toml", "scene-3.toml"] {
            std::fs::write(dir.path().join(f), "").unwrap();
        }
        let path = dir.path().join("m.toml");
        parse_manifest(text, &path)
            .and_then(|m| m.plan().map(|_| ()))
            .expect_err("a bad manifest")
            .to_string()
    }

    fn assert_plan_bad(from: &str, to: &str, at: &str, expect: &[&str]) {
        let text = good_with(from, to);
        assert_at(&plan_error(&text), &text, at, expect);
    }

    #[test]
    fn the_good_manifest_plans() {
        let dir = tempfile::tempdir().unwrap();
        for f in ["scene.toml", "scene-1.toml", "scene-2.toml", "scene-3.toml"] {
            std::fs::write(dir.path().join(f), "").unwrap();
        }
        let m = parse_manifest(GOOD, &dir.path().join("m.toml")).unwrap();
        let plan = m.plan().unwrap();
        assert_eq!(plan.runs.len(), 4 + 3);
        assert_eq!(
            plan.param_columns,
            ["scene", "resolution", "sampler", "index"]
        );
        assert_eq!(plan.varying, ["resolution", "sampler", "index"]);
    }

    #[test]
    fn misspelt_parameters_are_errors_listing_the_known_ones() {
        let to = "sampelr = [\"centre\", \"ogss:2\"]";
        assert_bad(
            "sampler = [\"centre\", \"ogss:2\"]",
            to,
            to,
            &[
                "unknown parameter `sampelr` for kind `render_cost`",
                "`sampler`",
                "`max_depth`",
            ],
        );
        // Also in [quick] blocks.
        let text = good_with(
            "[quick]\nrepeats = 1\n",
            "[quick]\nrepeats = 1\n[quick.fixed]\nsede = 3\n",
        );
        assert_at(&error(&text), &text, "sede", &["unknown parameter `sede`"]);
        // A helper a template uses is fine (`index` in the good manifest);
        // one no template uses is not.
        assert_bad(
            "scene = \"scene-{index}.toml\"",
            "scene = \"scene-1.toml\"",
            "index = {",
            &["unknown parameter `index`", "template"],
        );
    }

    #[test]
    fn figures_must_name_columns_the_experiment_writes() {
        for (from, to, field) in [
            ("x = \"width\"", "x = \"widht\"", "x"),
            (
                "y = [\"render_median_s\", \"rays\"]",
                "y = [\"render_median_s\", \"rayz\"]",
                "y",
            ),
            (
                "series = \"sampler\"",
                "series = \"sampler_name\"",
                "series",
            ),
            (
                "only = { sampler = [\"centre\"] }",
                "only = { smapler = [\"centre\"] }",
                "only",
            ),
            (
                "series = \"sampler\"",
                "series = \"sampler\"\ndashed_where = \"extrapolated\"",
                "dashed_where",
            ),
        ] {
            let bad = to.lines().last().unwrap();
            let col = bad.split('"').nth(1).unwrap();
            let col = if field == "y" { "rayz" } else { col };
            let col = if field == "only" { "smapler" } else { col };
            assert_bad(
                from,
                to,
                bad,
                &[
                    "figure `time`",
                    &format!("`{field}` names `{col}`"),
                    "not a column of data.csv",
                    "sweep, scene, resolution, sampler, index, width",
                    "render_median_s",
                ],
            );
        }
        assert_bad(
            "sweep = \"sizes\"",
            "sweep = \"size\"",
            "sweep = \"size\"",
            &["figure `time`", "no sweep is named `size`", "`scenes`"],
        );
    }

    #[test]
    fn run_values_are_checked_before_anything_runs() {
        assert_plan_bad(
            "sampler = [\"centre\", \"ogss:2\"]",
            "sampler = [\"centre\", \"ogss:0\"]",
            "sampler = [",
            &["sweep `sizes`, parameter `sampler`", "ogss"],
        );
        assert_plan_bad(
            "resolution = [\"8x6\", \"16x12\"]",
            "resolution = [\"8x6\", \"16by12\"]",
            "resolution = [",
            &["parameter `resolution`", "`16by12` is not \"WxH\""],
        );
    }

    #[test]
    fn run_type_errors_and_missing_parameters_name_their_place() {
        let text = good_with(
            "sampler = [\"centre\", \"ogss:2\"]",
            "sampler = [\"centre\", \"ogss:2\"]\nmax_depth = \"deep\"",
        );
        assert_at(
            &plan_error(&text),
            &text,
            "max_depth",
            &[
                "sweep `sizes`, parameter `max_depth`",
                "must be an integer in 0..=1000",
                "deep",
            ],
        );
        let text = good_with("scene = \"scene.toml\"\n", "");
        assert_at(
            &plan_error(&text),
            &text,
            "[[sweep]]",
            &["sweep `sizes`", "`scene` is required"],
        );
        let text = good_with("scene = \"scene.toml\"", "scene = \"nope.toml\"");
        assert_at(
            &plan_error(&text),
            &text,
            "nope.toml",
            &["parameter `scene`", "no such scene file"],
        );
    }

    #[test]
    fn ratio_parts_must_be_values_of_the_series() {
        let text = good_with(
            "kind = \"line\"",
            "kind = \"ratio\"\nnumerator = \"ogss:4\"\ndenominator = \"centre\"",
        );
        assert_at(
            &plan_error(&text),
            &text,
            "[[figure]]",
            &["figure `time`", "no run has sampler = `ogss:4`"],
        );
    }
}
