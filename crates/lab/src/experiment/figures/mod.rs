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
//! Titles and series labels quote the data through placeholders
//! ([`fill`]: `{range:COLUMN}`, `{COLUMN}`, `{COLUMN#N}`); a line or ratio
//! figure of a timing column draws error bars from the fastest to the
//! slowest timed repeat (the private module `spread` has the rules, also in
//! the book's manifest reference).
//!
//! Reference series from the manifest (published values) are drawn beside
//! the measured ones, dashed by default. Files are written as `FILE.png`
//! and `FILE.svg` by [`crate::analysis::plot`].

mod data;
mod placeholders;
mod spread;

pub use placeholders::fill;

use super::data::Table;
use super::manifest::{FigureKind, FigureSpec, ReferenceStyle};
use super::meta::{RatioSummary, SeriesMean};
use crate::analysis::plot::{AxisScale, BarChart, BarSeries, LineChart, Series, SeriesStyle};
use crate::Error;
use data::{mean, Data};
use spread::{LINE_ERROR_LABEL, RATIO_ERROR_LABEL};
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
) -> Result<Option<RatioSummary>, Error> {
    let fig = Data::new(spec, table)?;
    let stem = dir.join(&spec.file);
    let scale = |log: bool| {
        if log {
            AxisScale::Log10
        } else {
            AxisScale::Linear
        }
    };
    match spec.kind {
        FigureKind::Line => {
            let mut chart = fig.line_chart(spec, scale);
            let flag = match spec.dashed_where.as_deref() {
                None => None,
                Some(c) => Some(table.column(c).ok_or_else(|| Error::Figure {
                    file: spec.file.clone(),
                    message: format!("data.csv has no column `{c}`"),
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
pub fn check_text(spec: &FigureSpec) -> Result<(), Error> {
    let scale = |log: bool| {
        if log {
            AxisScale::Log10
        } else {
            AxisScale::Linear
        }
    };
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
    checked.map_err(|e| Error::Figure {
        file: spec.file.clone(),
        message: e.to_string(),
    })
}

/// The y label of a ratio figure: the manifest's, or `y(num) / y(den)`.
pub(super) fn ratio_label(spec: &FigureSpec) -> String {
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

/// A cell as a number; NaN for empty or non-numeric cells (the charts skip
/// non-finite points).
pub(super) fn number(cell: &str) -> f64 {
    cell.trim().parse().unwrap_or(f64::NAN)
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
