//! Figures of an experiment, drawn from `data.csv` after the sweep (so a
//! `--resume`d or re-run experiment redraws them from all its rows).
//!
//! Each `[[figure]]` of the manifest ([`FigureSpec`]) picks the rows of one
//! sweep (or all), an x column, one or more y columns, and optionally a
//! column whose values split the rows into series (one series per y column
//! and series value):
//!
//! - `line`: y against x, one line per series value; rows with the same
//!   series and x are averaged.
//! - `bar`: grouped bars, one group per distinct x (sorted when numeric),
//!   one bar per series value.
//! - `ratio`: y(numerator) / y(denominator) against x, pairing each row
//!   whose series column is the numerator with the row that has the same
//!   sweep and the same value of every other parameter and the denominator
//!   in the series column. S1's T = t_OGSS / t_centre is such a ratio.
//!
//! `only` keeps the rows whose cells are among listed values. A line
//! figure's `dashed_where` column splits off estimated rows (such
//! as extrapolated times) into dashed series.
//!
//! Titles and series labels quote the data instead of hard-coding what a
//! run happens to contain ([`fill`]): `{range:COLUMN}` becomes the range of
//! the column's numbers ("1–4", or "4" when all are equal), `{COLUMN}` its
//! distinct values ("1, 2, 4"), and `{COLUMN#N}` the distinct values of
//! field N of each cell split at `:` (`{sampler#1}` of `adaptive:0.2:2` is
//! `0.2`). A title reads the figure's rows, a series label that series'
//! rows, so a quick run's figure says what the quick run measured.
//!
//! Reference series from the manifest (published values) are drawn beside
//! the measured ones, dashed by default. Files are written as `FILE.png`
//! and `FILE.svg` by [`crate::analysis::plot`].
//!
//! **Error bars on timings.** A time is a median over the timed repeats,
//! and the rows also carry the fastest and slowest repeat. When a line or
//! ratio figure plots a timing column, each point gets a bar from the value
//! the fastest repeat gives to the value the slowest gives ([`spread`]):
//!
//! - `X_median_s`: from `X_min_s` to `X_max_s` (e.g. `render_median_s`);
//!   `time_per_frame_s` likewise from `time_min_s` to `time_max_s`;
//! - a column computed from `render_median_s` is recomputed with the
//!   slowest and the fastest repeat: `rays_per_s` (∝ 1/t) from
//!   rays/t_max to rays/t_min, `ns_per_sample` (∝ t) from t_min to t_max,
//!   `total_s` (build + t) from build + t_min to build + t_max;
//! - a ratio of two timed runs, num/den, spans the extremes the repeats
//!   allow: from num's fastest over den's slowest (t_min/t_max) to num's
//!   slowest over den's fastest (t_max/t_min), which contains the ratio of
//!   any pairing of the repeats.
//!
//! Where several rows share a point (averaged, as above), the bar's ends
//! are averaged the same way. With one repeat the bars have zero length and
//! are not drawn; a timing column without a recorded spread (CPU times,
//! per-step times) gets none. The legend says what the bars are.

use super::data::Table;
use super::manifest::{FigureKind, FigureSpec, ReferenceStyle};
use super::meta::{RatioSummary, SeriesMean};
use crate::analysis::plot::{BarChart, BarSeries, LineChart, Scale, Series, SeriesStyle};
use anyhow::{anyhow, bail};
use std::path::Path;

/// The least-squares slope of `points` in axis coordinates (log10 on a log
/// axis); `None` below two usable points or when every x is the same.
/// Points that cannot be drawn (≤ 0 on a log axis) are left out, as the
/// chart leaves them out.
pub fn fitted_slope(points: &[(f64, f64)], x_log: bool, y_log: bool) -> Option<f64> {
    let axis = |v: f64, log: bool| {
        if log {
            (v > 0.0 && v.is_finite()).then(|| v.log10())
        } else {
            v.is_finite().then_some(v)
        }
    };
    let uv: Vec<(f64, f64)> = points
        .iter()
        .filter_map(|&(x, y)| Some((axis(x, x_log)?, axis(y, y_log)?)))
        .collect();
    if uv.len() < 2 {
        return None;
    }
    let n = uv.len() as f64;
    let (mu, mv) = (
        uv.iter().map(|p| p.0).sum::<f64>() / n,
        uv.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxx: f64 = uv.iter().map(|p| (p.0 - mu).powi(2)).sum();
    let sxy: f64 = uv.iter().map(|p| (p.0 - mu) * (p.1 - mv)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

/// Draw one figure into `dir` from the rows of `table`. `param_columns`
/// are the parameter columns (rows are paired on them for ratios). Returns
/// the means of a ratio figure, `None` for other kinds.
pub fn draw(
    spec: &FigureSpec,
    table: &Table,
    param_columns: &[String],
    dir: &Path,
) -> anyhow::Result<Option<RatioSummary>> {
    let fig = Data::new(spec, table)?;
    let stem = dir.join(&spec.file);
    let scale = |log: bool| if log { Scale::Log10 } else { Scale::Linear };
    match spec.kind {
        FigureKind::Line => {
            let mut chart = fig.line_chart(spec, scale);
            let flag = match spec.dashed_where.as_deref() {
                None => None,
                Some(c) => Some(table.column(c).ok_or_else(|| {
                    anyhow!("figure `{}`: data.csv has no column `{c}`", spec.file)
                })?),
            };
            let estimated = |r: &[String]| flag.is_some_and(|f| r[f] == "true");
            let measured = fig.series_points(|r| !estimated(r));
            let dashed = fig.series_points(estimated);
            chart.error_label = LINE_ERROR_LABEL.to_string();
            for ((label, points, errors), (_, mut extra, _)) in measured.into_iter().zip(dashed) {
                // Join the dashed part to the last measured point before it.
                if let Some(&(first_x, _)) = extra.first() {
                    if let Some(&last) = points.iter().rev().find(|p| p.0 < first_x) {
                        extra.insert(0, last);
                    }
                }
                if !points.is_empty() || extra.is_empty() {
                    let shown = match fitted_slope(&points, spec.x_log, spec.y_log) {
                        Some(k) if spec.fit_slope => format!("{label} (slope {k:.2})"),
                        _ => label.clone(),
                    };
                    chart.series.push(
                        Series::new(shown, points, SeriesStyle::LinePoints).with_errors(errors),
                    );
                }
                if !extra.is_empty() {
                    chart.series.push(Series::new(
                        format!("{label} (extrapolated)"),
                        extra,
                        SeriesStyle::Dashed,
                    ));
                }
            }
            add_references(&mut chart, spec);
            chart.save(&stem)?;
            Ok(None)
        }
        FigureKind::Ratio => {
            let mut chart = fig.line_chart(spec, scale);
            chart.error_label = RATIO_ERROR_LABEL.to_string();
            let mut means = Vec::new();
            for (k, &y) in fig.y.iter().enumerate() {
                let (points, errors) = fig.ratio_points(spec, y, param_columns)?;
                let label = match spec.series_labels.get(&spec.y[k]) {
                    Some(l) => l.clone(),
                    None if fig.y.len() == 1 => "raylab (measured)".to_string(),
                    None => spec.y[k].clone(),
                };
                means.push(SeriesMean::new(&label, &points, true));
                chart
                    .series
                    .push(Series::new(label, points, SeriesStyle::LinePoints).with_errors(errors));
            }
            add_references(&mut chart, spec);
            chart.save(&stem)?;
            means.extend(
                spec.references
                    .iter()
                    .filter(|r| r.summary)
                    .map(|r| SeriesMean::new(&r.label, &r.points, false)),
            );
            Ok(Some(RatioSummary {
                figure: spec.file.clone(),
                label: ratio_label(spec),
                series: means,
            }))
        }
        FigureKind::Bar => {
            fig.bar_chart(spec, scale(spec.y_log)).save(&stem)?;
            Ok(None)
        }
    }
}

/// Draw the frame of figure `spec` in memory, its title and axis labels
/// as [`draw`] sets them, on two stand-in points (legend entries of real
/// data are not checked): an error when a text does not fit even at the
/// smallest text size. Lets a test check every manifest's figures without
/// running the experiments.
pub fn check_text(spec: &FigureSpec) -> anyhow::Result<()> {
    let scale = |log: bool| if log { Scale::Log10 } else { Scale::Linear };
    let x_label = spec.x_label.clone().unwrap_or_else(|| spec.x.clone());
    let y_label = match spec.kind {
        FigureKind::Ratio => ratio_label(spec),
        _ => spec.y_label.clone().unwrap_or_else(|| spec.y.join(", ")),
    };
    let points = vec![(1.0, 1.0), (2.0, 2.0)];
    let checked = match spec.kind {
        FigureKind::Line | FigureKind::Ratio => {
            let mut chart = LineChart::new(spec.title.clone(), x_label, y_label);
            chart.x_scale = scale(spec.x_log);
            chart.y_scale = scale(spec.y_log);
            chart
                .series
                .push(Series::new("data", points, SeriesStyle::LinePoints));
            chart.check()
        }
        FigureKind::Bar => {
            let mut chart = BarChart::new(
                spec.title.clone(),
                x_label,
                y_label,
                vec!["a".to_string(), "b".to_string()],
            );
            chart.y_scale = scale(spec.y_log);
            chart.series.push(BarSeries::new("data", vec![1.0, 2.0]));
            chart.check()
        }
    };
    checked.map_err(|e| anyhow!("figure `{}`: {e:#}", spec.file))
}

/// The y label of a ratio figure: the manifest's, or `y(num) / y(den)`.
fn ratio_label(spec: &FigureSpec) -> String {
    spec.y_label.clone().unwrap_or_else(|| {
        let (num, den) = (
            spec.numerator.as_deref().unwrap_or("?"),
            spec.denominator.as_deref().unwrap_or("?"),
        );
        match spec.y.as_slice() {
            [y] => format!("{y}({num}) / {y}({den})"),
            _ => format!("{num} / {den}"),
        }
    })
}

impl SeriesMean {
    /// The mean of the finite y values of `points`.
    fn new(label: &str, points: &[(f64, f64)], measured: bool) -> Self {
        let ys: Vec<f64> = points.iter().map(|p| p.1).collect();
        SeriesMean {
            label: label.to_string(),
            mean: mean(&ys),
            count: ys.iter().filter(|y| y.is_finite()).count(),
            measured,
        }
    }
}

fn add_references(chart: &mut LineChart, spec: &FigureSpec) {
    for r in &spec.references {
        let style = match r.style {
            ReferenceStyle::Dashed => SeriesStyle::Dashed,
            ReferenceStyle::Points => SeriesStyle::Points,
            ReferenceStyle::Line => SeriesStyle::Line,
        };
        chart
            .series
            .push(Series::new(r.label.clone(), r.points.clone(), style));
    }
}

/// (x, y) points of one series.
type Points = Vec<(f64, f64)>;

/// (low, high) error bars, one per point of a series (empty for none).
type Bars = Vec<(f64, f64)>;

/// The legend entry of the error bars of a line figure.
const LINE_ERROR_LABEL: &str = "bars: fastest to slowest repeat";

/// The legend entry of the error bars of a ratio figure.
const RATIO_ERROR_LABEL: &str = "bars: extreme ratios of the repeats";

/// How the timed repeats spread a timing column: column indices of the
/// table, see the module docs.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Spread {
    /// The column's own bounds: (min, max).
    Bounds(usize, usize),
    /// A column ∝ the median time: (median, min, max).
    Proportional(usize, usize, usize),
    /// A column ∝ 1 / the median time: (median, min, max).
    Inverse(usize, usize, usize),
    /// A column = something untimed + the median time: (median, min, max).
    Offset(usize, usize, usize),
}

/// The spread of the timing column `name` over the repeats, when the
/// table records one (see the module docs).
fn spread(table: &Table, name: &str) -> Option<Spread> {
    let col = |c: &str| table.column(c);
    if let Some(stem) = name.strip_suffix("_median_s") {
        return Some(Spread::Bounds(
            col(&format!("{stem}_min_s"))?,
            col(&format!("{stem}_max_s"))?,
        ));
    }
    if name == "time_per_frame_s" {
        return Some(Spread::Bounds(col("time_min_s")?, col("time_max_s")?));
    }
    let render = || {
        Some((
            col("render_median_s")?,
            col("render_min_s")?,
            col("render_max_s")?,
        ))
    };
    match name {
        "rays_per_s" => render().map(|(m, a, b)| Spread::Inverse(m, a, b)),
        "ns_per_sample" => render().map(|(m, a, b)| Spread::Proportional(m, a, b)),
        "total_s" => render().map(|(m, a, b)| Spread::Offset(m, a, b)),
        _ => None,
    }
}

impl Spread {
    /// (low, high) of the value `y` of `row`: what the fastest and the
    /// slowest repeat give, ordered low to high.
    fn bounds(self, row: &[String], y: f64) -> (f64, f64) {
        let n = |c: usize| number(&row[c]);
        let (a, b) = match self {
            Spread::Bounds(lo, hi) => (n(lo), n(hi)),
            Spread::Proportional(m, lo, hi) => (y * n(lo) / n(m), y * n(hi) / n(m)),
            Spread::Inverse(m, lo, hi) => (y * n(m) / n(hi), y * n(m) / n(lo)),
            Spread::Offset(m, lo, hi) => (y - n(m) + n(lo), y - n(m) + n(hi)),
        };
        (a.min(b), a.max(b))
    }
}

/// The selected rows of one figure, as (series value, x cell, x, y).
struct Data<'a> {
    spec: &'a FigureSpec,
    table: &'a Table,
    rows: Vec<&'a Vec<String>>,
    x: usize,
    /// One or more y columns.
    y: Vec<usize>,
    series: Option<usize>,
}

impl<'a> Data<'a> {
    fn new(spec: &'a FigureSpec, table: &'a Table) -> anyhow::Result<Self> {
        let col = |name: &str| {
            table
                .column(name)
                .ok_or_else(|| anyhow!("figure `{}`: data.csv has no column `{name}`", spec.file))
        };
        let sweep = col("sweep")?;
        let only: Vec<(usize, &Vec<String>)> = spec
            .only
            .iter()
            .map(|(c, values)| Ok((col(c)?, values)))
            .collect::<anyhow::Result<_>>()?;
        let rows: Vec<&Vec<String>> = table
            .rows
            .iter()
            .filter(|r| spec.sweep.as_ref().map_or(true, |s| &r[sweep] == s))
            .filter(|r| only.iter().all(|(c, values)| values.contains(&r[*c])))
            .collect();
        if rows.is_empty() {
            bail!(
                "figure `{}`: no rows{} in data.csv",
                spec.file,
                spec.sweep
                    .as_ref()
                    .map(|s| format!(" of sweep `{s}`"))
                    .unwrap_or_default()
            );
        }
        // Check the placeholders of the title and labels once, so that
        // filling them later cannot fail.
        fill(&spec.title, table, &rows).map_err(|e| anyhow!("figure `{}`: {e}", spec.file))?;
        for label in spec.series_labels.values() {
            fill(label, table, &rows).map_err(|e| anyhow!("figure `{}`: {e}", spec.file))?;
        }
        Ok(Data {
            spec,
            table,
            rows,
            x: col(&spec.x)?,
            y: spec
                .y
                .iter()
                .map(|c| col(c))
                .collect::<anyhow::Result<_>>()?,
            series: spec.series.as_deref().map(col).transpose()?,
        })
    }

    /// Legend text of series `value` for y column number `k`: the series
    /// label, the y column's label, or both when there are several y
    /// columns and a series column.
    fn label(&self, value: &str, k: usize) -> String {
        let named = |key: &str| {
            self.spec
                .series_labels
                .get(key)
                .cloned()
                .unwrap_or_else(|| key.to_string())
        };
        let y = named(&self.spec.y[k]);
        let text = match (self.series.is_some(), self.y.len()) {
            (false, _) => y,
            (true, 1) => named(value),
            (true, _) => format!("{}, {y}", named(value)),
        };
        let rows: Vec<&Vec<String>> = self
            .rows
            .iter()
            .copied()
            .filter(|r| self.series_of(r) == value)
            .collect();
        fill(&text, self.table, &rows).unwrap_or(text)
    }

    /// The figure's title with its placeholders filled from its rows.
    fn title(&self) -> String {
        fill(&self.spec.title, self.table, &self.rows).unwrap_or_else(|_| self.spec.title.clone())
    }

    fn line_chart(&self, spec: &FigureSpec, scale: impl Fn(bool) -> Scale) -> LineChart {
        let y_label = match spec.kind {
            FigureKind::Ratio => ratio_label(spec),
            _ => spec.y_label.clone().unwrap_or_else(|| spec.y.join(", ")),
        };
        let mut chart = LineChart::new(
            self.title(),
            spec.x_label.clone().unwrap_or_else(|| spec.x.clone()),
            y_label,
        );
        chart.x_scale = scale(spec.x_log);
        chart.y_scale = scale(spec.y_log);
        chart.legend = spec.legend;
        chart
    }

    /// The series value of a row ("" without a series column).
    fn series_of(&self, row: &[String]) -> String {
        self.series.map(|s| row[s].clone()).unwrap_or_default()
    }

    /// Series values in order of first appearance.
    fn series_values(&self) -> Vec<String> {
        let mut values: Vec<String> = Vec::new();
        for r in &self.rows {
            let v = self.series_of(r);
            if !values.contains(&v) {
                values.push(v);
            }
        }
        values
    }

    /// Per y column and series: (legend text, (x, mean y) sorted by x,
    /// the error bars of those points), from the rows `keep` accepts
    /// (series without such rows get no points but keep their place). The
    /// bars are empty when the y column has no recorded spread.
    fn series_points(&self, keep: impl Fn(&[String]) -> bool) -> Vec<(String, Points, Bars)> {
        let mut out = Vec::new();
        for (k, &y) in self.y.iter().enumerate() {
            let spread = spread(self.table, &self.table.columns[y]);
            for value in self.series_values() {
                let mut pts: Vec<(f64, [f64; 3])> = self
                    .rows
                    .iter()
                    .filter(|r| self.series_of(r) == value && keep(r))
                    .map(|r| {
                        let v = number(&r[y]);
                        let (lo, hi) = spread.map_or((v, v), |s| s.bounds(r, v));
                        (number(&r[self.x]), [v, lo, hi])
                    })
                    .collect();
                pts.sort_by(|a, b| a.0.total_cmp(&b.0));
                let merged = average_equal_x(pts);
                let points = merged.iter().map(|&(x, v)| (x, v[0])).collect();
                let errors = match spread {
                    Some(_) => merged.iter().map(|&(_, v)| (v[1], v[2])).collect(),
                    None => Vec::new(),
                };
                out.push((self.label(&value, k), points, errors));
            }
        }
        out
    }

    /// Ratio points, rows paired on sweep and every parameter but the
    /// series column, and their error bars when y has a recorded spread
    /// (from num's low over den's high to num's high over den's low).
    fn ratio_points(
        &self,
        spec: &FigureSpec,
        y: usize,
        param_columns: &[String],
    ) -> anyhow::Result<(Points, Bars)> {
        let (Some(series), Some(num), Some(den)) = (
            self.series,
            spec.numerator.as_ref(),
            spec.denominator.as_ref(),
        ) else {
            bail!(
                "figure `{}`: a ratio needs `series`, `numerator` and `denominator`",
                spec.file
            );
        };
        if series == self.x {
            bail!(
                "figure `{}`: the x column cannot be the series column",
                spec.file
            );
        }
        let key_cols: Vec<usize> = std::iter::once("sweep")
            .chain(param_columns.iter().map(String::as_str))
            .filter_map(|c| self.table.column(c))
            .filter(|&c| c != series)
            .collect();
        let spread = spread(self.table, &self.table.columns[y]);
        // key → (x, numerator [y, lo, hi]s, denominator [y, lo, hi]s), in
        // order of appearance.
        type Pair = (Vec<String>, f64, Vec<[f64; 3]>, Vec<[f64; 3]>);
        let mut pairs: Vec<Pair> = Vec::new();
        for r in &self.rows {
            let which = &r[series];
            if which != num && which != den {
                continue;
            }
            let key: Vec<String> = key_cols.iter().map(|&c| r[c].clone()).collect();
            let i = match pairs.iter().position(|p| p.0 == key) {
                Some(i) => i,
                None => {
                    pairs.push((key, number(&r[self.x]), Vec::new(), Vec::new()));
                    pairs.len() - 1
                }
            };
            let v = number(&r[y]);
            let (lo, hi) = spread.map_or((v, v), |s| s.bounds(r, v));
            let value = [v, lo, hi];
            if which == num {
                pairs[i].2.push(value);
            } else {
                pairs[i].3.push(value);
            }
        }
        let part = |v: &[[f64; 3]], i: usize| mean(&v.iter().map(|t| t[i]).collect::<Vec<_>>());
        let mut points: Vec<(f64, [f64; 3])> = pairs
            .iter()
            .filter(|p| !p.2.is_empty() && !p.3.is_empty())
            .map(|p| {
                let (n, d) = (&p.2, &p.3);
                (
                    p.1,
                    [
                        part(n, 0) / part(d, 0),
                        part(n, 1) / part(d, 2),
                        part(n, 2) / part(d, 1),
                    ],
                )
            })
            .collect();
        if points.is_empty() {
            bail!(
                "figure `{}`: no rows pair {} = `{num}` with {} = `{den}`",
                spec.file,
                self.table.columns[series],
                self.table.columns[series]
            );
        }
        points.sort_by(|a, b| a.0.total_cmp(&b.0));
        let errors = match spread {
            Some(_) => points.iter().map(|&(_, v)| (v[1], v[2])).collect(),
            None => Vec::new(),
        };
        Ok((points.iter().map(|&(x, v)| (x, v[0])).collect(), errors))
    }

    fn bar_chart(&self, spec: &FigureSpec, y_scale: Scale) -> BarChart {
        // Categories: distinct x cells, in numeric order when all are numbers.
        let mut cats: Vec<String> = Vec::new();
        for r in &self.rows {
            if !cats.contains(&r[self.x]) {
                cats.push(r[self.x].clone());
            }
        }
        if cats.iter().all(|c| number(c).is_finite()) {
            cats.sort_by(|a, b| number(a).total_cmp(&number(b)));
        }
        let mut chart = BarChart::new(
            self.title(),
            spec.x_label.clone().unwrap_or_else(|| spec.x.clone()),
            spec.y_label.clone().unwrap_or_else(|| spec.y.join(", ")),
            // `series_labels` also names a bar chart's categories.
            cats.iter()
                .map(|c| {
                    spec.series_labels
                        .get(c)
                        .cloned()
                        .unwrap_or_else(|| c.clone())
                })
                .collect(),
        );
        chart.y_scale = y_scale;
        chart.legend = spec.legend;
        for (k, &y) in self.y.iter().enumerate() {
            for value in self.series_values() {
                let values = cats
                    .iter()
                    .map(|c| {
                        let ys: Vec<f64> = self
                            .rows
                            .iter()
                            .filter(|r| self.series_of(r) == value && &r[self.x] == c)
                            .map(|r| number(&r[y]))
                            .collect();
                        mean(&ys)
                    })
                    .collect();
                chart
                    .series
                    .push(BarSeries::new(self.label(&value, k), values));
            }
        }
        for r in &spec.references {
            let values = cats
                .iter()
                .map(|c| {
                    let x = number(c);
                    r.points
                        .iter()
                        .find(|p| (p.0 - x).abs() <= 1e-9 * x.abs().max(1.0))
                        .map_or(f64::NAN, |p| p.1)
                })
                .collect();
            chart.series.push(BarSeries::new(r.label.clone(), values));
        }
        chart
    }
}

/// `text` with its placeholders (see the module docs) filled from `rows`
/// of `table`. An error names a placeholder whose column `table` lacks, or
/// a range over a column without numbers.
pub fn fill(text: &str, table: &Table, rows: &[&Vec<String>]) -> anyhow::Result<String> {
    let mut out = String::new();
    let mut rest = text;
    while let Some(open) = rest.find('{') {
        let Some(len) = rest[open..].find('}') else {
            break;
        };
        out.push_str(&rest[..open]);
        let inner = &rest[open + 1..open + len];
        rest = &rest[open + len + 1..];
        let (range, name) = match inner.strip_prefix("range:") {
            Some(n) => (true, n),
            None => (false, inner),
        };
        let (name, field) = match name.split_once('#') {
            Some((n, f)) => (
                n,
                Some(f.parse::<usize>().map_err(|_| {
                    anyhow!("placeholder `{{{inner}}}`: `{f}` is not a field number")
                })?),
            ),
            None => (name, None),
        };
        let col = table
            .column(name)
            .ok_or_else(|| anyhow!("placeholder `{{{inner}}}`: data.csv has no column `{name}`"))?;
        let cells: Vec<&str> = rows
            .iter()
            .map(|r| match field {
                Some(f) => r[col].split(':').nth(f).unwrap_or(""),
                None => r[col].as_str(),
            })
            .filter(|c| !c.trim().is_empty())
            .collect();
        if range {
            let nums: Vec<f64> = cells
                .iter()
                .map(|c| number(c))
                .filter(|v| v.is_finite())
                .collect();
            let lo = nums.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = nums.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            if nums.is_empty() {
                bail!("placeholder `{{{inner}}}`: column `{name}` has no numbers in these rows");
            }
            if lo == hi {
                out.push_str(&format!("{lo}"));
            } else {
                out.push_str(&format!("{lo}–{hi}"));
            }
        } else {
            let mut distinct: Vec<&str> = Vec::new();
            for c in cells {
                if !distinct.contains(&c) {
                    distinct.push(c);
                }
            }
            if distinct.iter().all(|c| number(c).is_finite()) {
                distinct.sort_by(|a, b| number(a).total_cmp(&number(b)));
            }
            out.push_str(&distinct.join(", "));
        }
    }
    out.push_str(rest);
    Ok(out)
}

/// A cell as a number; NaN for empty or non-numeric cells (the charts skip
/// non-finite points).
fn number(cell: &str) -> f64 {
    cell.trim().parse().unwrap_or(f64::NAN)
}

/// Mean of the finite values; NaN when there are none.
fn mean(v: &[f64]) -> f64 {
    let finite: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    if finite.is_empty() {
        f64::NAN
    } else {
        finite.iter().sum::<f64>() / finite.len() as f64
    }
}

/// Merge points with the same x (sorted input) into the mean of each of
/// their values (y and the ends of its error bar).
fn average_equal_x<const N: usize>(sorted: Vec<(f64, [f64; N])>) -> Vec<(f64, [f64; N])> {
    let mut out: Vec<(f64, Vec<[f64; N]>)> = Vec::new();
    for (x, v) in sorted {
        match out.last_mut() {
            Some((lx, vs)) if *lx == x => vs.push(v),
            _ => out.push((x, vec![v])),
        }
    }
    out.into_iter()
        .map(|(x, vs)| {
            (
                x,
                std::array::from_fn(|i| mean(&vs.iter().map(|v| v[i]).collect::<Vec<_>>())),
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::{fill, fitted_slope, spread, Spread, Table};

    #[test]
    fn titles_and_labels_quote_the_data() {
        let table = Table {
            columns: vec!["spp".to_string(), "sampler".to_string()],
            rows: [
                ["4", "adaptive:0.2:2"],
                ["1", "adaptive:0.05:2"],
                ["2", "adaptive:0.05:2"],
            ]
            .iter()
            .map(|r| r.iter().map(|c| c.to_string()).collect())
            .collect(),
        };
        let rows: Vec<&Vec<String>> = table.rows.iter().collect();
        let f = |t: &str| fill(t, &table, &rows);
        assert_eq!(f("MSE ({range:spp} spp)").unwrap(), "MSE (1–4 spp)");
        assert_eq!(f("at {spp} spp").unwrap(), "at 1, 2, 4 spp");
        assert_eq!(f("thresholds {sampler#1}").unwrap(), "thresholds 0.05, 0.2");
        assert_eq!(f("no placeholder").unwrap(), "no placeholder");
        assert_eq!(f("{range:spp}").unwrap(), "1–4");
        let one = vec![&table.rows[0]];
        assert_eq!(fill("{range:spp} spp", &table, &one).unwrap(), "4 spp");
        assert!(f("{nope}")
            .unwrap_err()
            .to_string()
            .contains("no column `nope`"));
        assert!(f("{range:sampler}").is_err());
    }

    #[test]
    fn timing_spreads_follow_the_fastest_and_slowest_repeat() {
        let columns = [
            "render_median_s",
            "render_min_s",
            "render_max_s",
            "rays_per_s",
            "ns_per_sample",
            "total_s",
            "render_cpu_median_s",
        ];
        let table = Table {
            columns: columns.iter().map(|c| c.to_string()).collect(),
            rows: Vec::new(),
        };
        // Median 2 s, fastest 1 s, slowest 4 s; 20 rays; build 1 s.
        let row: Vec<String> = ["2", "1", "4", "10", "5", "3", "7"]
            .iter()
            .map(|c| c.to_string())
            .collect();
        let bounds = |name: &str, y: f64| spread(&table, name).map(|s| s.bounds(&row, y));
        assert_eq!(
            spread(&table, "render_median_s"),
            Some(Spread::Bounds(1, 2))
        );
        assert_eq!(bounds("render_median_s", 2.0), Some((1.0, 4.0)));
        // 20 rays in 4 s … 1 s.
        assert_eq!(bounds("rays_per_s", 10.0), Some((5.0, 20.0)));
        assert_eq!(bounds("ns_per_sample", 5.0), Some((2.5, 10.0)));
        assert_eq!(bounds("total_s", 3.0), Some((2.0, 5.0)));
        // No min/max recorded for CPU time: no bars.
        assert_eq!(spread(&table, "render_cpu_median_s"), None);
        assert_eq!(spread(&table, "tests_per_ray"), None);
    }

    #[test]
    fn slope_of_a_power_law_on_log_axes_is_its_exponent() {
        // y = 3·x^−0.5 exactly: the log–log fit recovers −0.5 to rounding.
        let pts: Vec<(f64, f64)> = [1.0, 4.0, 16.0, 64.0]
            .iter()
            .map(|&x: &f64| (x, 3.0 * x.powf(-0.5)))
            .collect();
        let k = fitted_slope(&pts, true, true).unwrap();
        assert!((k + 0.5).abs() < 1e-12, "{k}");
        // Linear axes: y = 2x + 1 has slope 2.
        let lin = [(0.0, 1.0), (1.0, 3.0), (2.0, 5.0)];
        assert!((fitted_slope(&lin, false, false).unwrap() - 2.0).abs() < 1e-12);
        // Non-positive values are dropped on a log axis; one point left: none.
        assert_eq!(fitted_slope(&[(1.0, 1.0), (2.0, 0.0)], true, true), None);
        assert_eq!(fitted_slope(&[(1.0, 1.0), (1.0, 2.0)], false, false), None);
    }
}
