//! The rows one figure selects, as series of points with their error
//! bars, ratio pairs and bar groups.

use super::number;
use super::placeholders::fill;
use super::ratio_label;
use super::spread::spread;
use crate::analysis::plot::{AxisScale, BarChart, BarSeries, LineChart};
use crate::experiment::data::Table;
use crate::experiment::manifest::FigureKind;
use crate::experiment::manifest::FigureSpec;
use crate::Error;

/// (x, y) points of one series.
pub(super) type Points = Vec<(f64, f64)>;

/// (low, high) error bars, one per point of a series (empty for none).
pub(super) type Bars = Vec<(f64, f64)>;

/// The selected rows of one figure, as (series value, x cell, x, y).
pub(super) struct Data<'a> {
    pub(super) spec: &'a FigureSpec,
    pub(super) table: &'a Table,
    pub(super) rows: Vec<&'a Vec<String>>,
    pub(super) x: usize,
    /// One or more y columns.
    pub(super) y: Vec<usize>,
    pub(super) series: Option<usize>,
}

impl<'a> Data<'a> {
    pub(super) fn new(spec: &'a FigureSpec, table: &'a Table) -> Result<Self, Error> {
        let problem = |message: String| Error::Figure {
            file: spec.file.clone(),
            message,
        };
        let col = |name: &str| {
            table
                .column(name)
                .ok_or_else(|| problem(format!("data.csv has no column `{name}`")))
        };
        let sweep = col("sweep")?;
        let only: Vec<(usize, &Vec<String>)> = spec
            .only
            .iter()
            .map(|(c, values)| Ok((col(c)?, values)))
            .collect::<Result<_, Error>>()?;
        let rows: Vec<&Vec<String>> = table
            .rows
            .iter()
            .filter(|r| spec.sweep.as_ref().is_none_or(|s| &r[sweep] == s))
            .filter(|r| only.iter().all(|(c, values)| values.contains(&r[*c])))
            .collect();
        if rows.is_empty() {
            return Err(problem(format!(
                "no rows{} in data.csv",
                spec.sweep
                    .as_ref()
                    .map(|s| format!(" of sweep `{s}`"))
                    .unwrap_or_default()
            )));
        }
        // Check the placeholders of the title and labels once, so that
        // filling them later cannot fail.
        fill(&spec.title, table, &rows).map_err(|e| problem(e.to_string()))?;
        for label in spec.series_labels.values() {
            fill(label, table, &rows).map_err(|e| problem(e.to_string()))?;
        }
        let data = Data {
            spec,
            table,
            rows,
            x: col(&spec.x)?,
            y: spec
                .y
                .iter()
                .map(|c| col(c))
                .collect::<Result<_, Error>>()?,
            series: spec.series.as_deref().map(col).transpose()?,
        };
        // A column of text with no number to draw would make an empty
        // chart (columns left empty, as unmeasured ones are, still draw).
        let numeric = matches!(spec.kind, FigureKind::Line | FigureKind::Ratio);
        let axes = numeric
            .then_some(("x", &spec.x, data.x))
            .into_iter()
            .chain(spec.y.iter().zip(&data.y).map(|(name, &c)| ("y", name, c)));
        for (axis, name, c) in axes {
            let text = data
                .rows
                .iter()
                .map(|r| r[c].trim())
                .find(|v| !v.is_empty() && v.parse::<f64>().is_err());
            let drawn = data.rows.iter().any(|r| number(&r[c]).is_finite());
            if let (Some(example), false) = (text, drawn) {
                let hint = if axis == "x" {
                    " (for categories use kind = \"bar\")"
                } else {
                    ""
                };
                return Err(problem(format!(
                    "{axis} column `{name}` holds no number in the {} rows drawn (e.g. `{example}`){hint}",
                    data.rows.len()
                )));
            }
        }
        Ok(data)
    }

    /// Legend text of series `value` for y column number `k`: the series
    /// label, the y column's label, or both when there are several y
    /// columns and a series column.
    pub(super) fn label(&self, value: &str, k: usize) -> String {
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
    pub(super) fn title(&self) -> String {
        fill(&self.spec.title, self.table, &self.rows).unwrap_or_else(|_| self.spec.title.clone())
    }

    pub(super) fn line_chart(
        &self,
        spec: &FigureSpec,
        scale: impl Fn(bool) -> AxisScale,
    ) -> LineChart {
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
    pub(super) fn series_of(&self, row: &[String]) -> String {
        self.series.map(|s| row[s].clone()).unwrap_or_default()
    }

    /// Series values in order of first appearance.
    pub(super) fn series_values(&self) -> Vec<String> {
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
    pub(super) fn series_points(
        &self,
        keep: impl Fn(&[String]) -> bool,
    ) -> Vec<(String, Points, Bars)> {
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
    pub(super) fn ratio_points(
        &self,
        spec: &FigureSpec,
        y: usize,
        param_columns: &[String],
    ) -> Result<(Points, Bars), Error> {
        let (Some(series), Some(num), Some(den)) = (
            self.series,
            spec.numerator.as_ref(),
            spec.denominator.as_ref(),
        ) else {
            return Err(Error::Figure {
                file: spec.file.clone(),
                message: "a ratio needs `series`, `numerator` and `denominator`".into(),
            });
        };
        if series == self.x {
            return Err(Error::Figure {
                file: spec.file.clone(),
                message: "the x column cannot be the series column".into(),
            });
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
            return Err(Error::Figure {
                file: spec.file.clone(),
                message: format!(
                    "no rows pair {} = `{num}` with {} = `{den}`",
                    self.table.columns[series], self.table.columns[series]
                ),
            });
        }
        points.sort_by(|a, b| a.0.total_cmp(&b.0));
        let errors = match spread {
            Some(_) => points.iter().map(|&(_, v)| (v[1], v[2])).collect(),
            None => Vec::new(),
        };
        Ok((points.iter().map(|&(x, v)| (x, v[0])).collect(), errors))
    }

    pub(super) fn bar_chart(&self, spec: &FigureSpec, y_scale: AxisScale) -> BarChart {
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

/// Mean of the finite values; NaN when there are none.
pub(super) fn mean(v: &[f64]) -> f64 {
    let finite: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    if finite.is_empty() {
        f64::NAN
    } else {
        finite.iter().sum::<f64>() / finite.len() as f64
    }
}

/// Merge points with the same x (sorted input) into the mean of each of
/// their values (y and the ends of its error bar).
pub(super) fn average_equal_x<const N: usize>(
    sorted: Vec<(f64, [f64; N])>,
) -> Vec<(f64, [f64; N])> {
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
