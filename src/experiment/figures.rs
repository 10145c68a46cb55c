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
//! Reference series from the manifest (published values) are drawn beside
//! the measured ones, dashed by default. Files are written as `FILE.png`
//! and `FILE.svg` by [`crate::analysis::plot`].

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
            for ((label, points), (_, mut extra)) in measured.into_iter().zip(dashed) {
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
                    chart
                        .series
                        .push(Series::new(shown, points, SeriesStyle::LinePoints));
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
            let mut means = Vec::new();
            for (k, &y) in fig.y.iter().enumerate() {
                let points = fig.ratio_points(spec, y, param_columns)?;
                let label = match spec.series_labels.get(&spec.y[k]) {
                    Some(l) => l.clone(),
                    None if fig.y.len() == 1 => "raylab (measured)".to_string(),
                    None => spec.y[k].clone(),
                };
                means.push(SeriesMean::new(&label, &points, true));
                chart
                    .series
                    .push(Series::new(label, points, SeriesStyle::LinePoints));
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
        match (self.series.is_some(), self.y.len()) {
            (false, _) => y,
            (true, 1) => named(value),
            (true, _) => format!("{}, {y}", named(value)),
        }
    }

    fn line_chart(&self, spec: &FigureSpec, scale: impl Fn(bool) -> Scale) -> LineChart {
        let y_label = match spec.kind {
            FigureKind::Ratio => ratio_label(spec),
            _ => spec.y_label.clone().unwrap_or_else(|| spec.y.join(", ")),
        };
        let mut chart = LineChart::new(
            spec.title.clone(),
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

    /// Per y column and series: (legend text, (x, mean y) sorted by x),
    /// from the rows `keep` accepts (series without such rows get no
    /// points but keep their place).
    fn series_points(&self, keep: impl Fn(&[String]) -> bool) -> Vec<(String, Points)> {
        let mut out = Vec::new();
        for (k, &y) in self.y.iter().enumerate() {
            for value in self.series_values() {
                let mut pts: Points = self
                    .rows
                    .iter()
                    .filter(|r| self.series_of(r) == value && keep(r))
                    .map(|r| (number(&r[self.x]), number(&r[y])))
                    .collect();
                pts.sort_by(|a, b| a.0.total_cmp(&b.0));
                out.push((self.label(&value, k), average_equal_x(pts)));
            }
        }
        out
    }

    /// Ratio points: rows paired on sweep and every parameter but the
    /// series column.
    fn ratio_points(
        &self,
        spec: &FigureSpec,
        y: usize,
        param_columns: &[String],
    ) -> anyhow::Result<Points> {
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
        // key → (x, numerator ys, denominator ys), in order of appearance.
        type Pair = (Vec<String>, f64, Vec<f64>, Vec<f64>);
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
            let value = number(&r[y]);
            if which == num {
                pairs[i].2.push(value);
            } else {
                pairs[i].3.push(value);
            }
        }
        let mut points: Vec<(f64, f64)> = pairs
            .iter()
            .filter(|p| !p.2.is_empty() && !p.3.is_empty())
            .map(|p| (p.1, mean(&p.2) / mean(&p.3)))
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
        Ok(points)
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
            spec.title.clone(),
            spec.x_label.clone().unwrap_or_else(|| spec.x.clone()),
            spec.y_label.clone().unwrap_or_else(|| spec.y.join(", ")),
            cats.clone(),
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

/// Merge points with the same x (sorted input) into their mean y.
fn average_equal_x(sorted: Vec<(f64, f64)>) -> Vec<(f64, f64)> {
    let mut out: Vec<(f64, Vec<f64>)> = Vec::new();
    for (x, y) in sorted {
        match out.last_mut() {
            Some((lx, ys)) if *lx == x => ys.push(y),
            _ => out.push((x, vec![y])),
        }
    }
    out.into_iter().map(|(x, ys)| (x, mean(&ys))).collect()
}

#[cfg(test)]
mod tests {
    use super::fitted_slope;

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
