//! Radial curves of sampling patterns: the rings of a periodogram with its
//! N and M, as written to and read back from the per-ring CSV, and the
//! figures drawn from them (the periodogram heatmap, the radial power and
//! the anisotropy charts). Part of [`crate::analysis::spectrum`].

use super::periodogram::{white_noise_anisotropy_db, Periodogram, Ring};
use crate::analysis::plot::{Heatmap, LineChart, Palette, Series, SeriesStyle};
use crate::{Error, FileOp};
use ndarray::Array2;
use raylab::io::{InputError, Place};
use std::path::Path;

/// The radial data of one pattern, as plotted and as written to CSV.
#[derive(Clone, Debug, PartialEq)]
pub struct RadialCurve {
    /// Legend text (a sampler name).
    pub label: String,
    /// Points per set, N.
    pub points: usize,
    /// Sets averaged, M.
    pub sets: usize,
    /// The rings.
    pub rings: Vec<Ring>,
}

impl RadialCurve {
    /// The rings of `p`, labelled.
    pub fn new(label: impl Into<String>, p: &Periodogram) -> Self {
        Self {
            label: label.into(),
            points: p.points,
            sets: p.sets,
            rings: p.rings(),
        }
    }
}

/// Header of the per-ring CSV written by [`write_rings_csv`].
const RINGS_HEADER: [&str; 8] = [
    "sampler",
    "spp",
    "sets",
    "radius",
    "count",
    "mean_power",
    "variance",
    "anisotropy_db",
];

/// Write the rings of every curve to `path` in long format (one row per
/// curve and ring; columns `RINGS_HEADER`: sampler, spp, sets, radius,
/// count, mean_power, variance, anisotropy_db), atomically.
pub fn write_rings_csv(path: &Path, curves: &[RadialCurve]) -> Result<(), Error> {
    let csv_error = |op, e| Error::csv(path, Place::File, op, e);
    raylab::io::write_atomically(path, |tmp| {
        let mut w = csv::Writer::from_path(tmp).map_err(|e| csv_error(FileOp::Create, e))?;
        w.write_record(RINGS_HEADER)
            .map_err(|e| csv_error(FileOp::Write, e))?;
        for c in curves {
            for r in &c.rings {
                w.write_record([
                    c.label.clone(),
                    c.points.to_string(),
                    c.sets.to_string(),
                    r.radius.to_string(),
                    r.count.to_string(),
                    format!("{:.9e}", r.mean),
                    format!("{:.9e}", r.variance),
                    format!("{:.6}", r.anisotropy_db),
                ])
                .map_err(|e| csv_error(FileOp::Write, e))?;
            }
        }
        w.flush().map_err(|e| Error::io(path, FileOp::Write, e))?;
        Ok(())
    })
}

/// Read a CSV written by [`write_rings_csv`] back into curves, in the
/// order their labels first appear.
pub fn read_rings_csv(path: &Path) -> Result<Vec<RadialCurve>, Error> {
    let mut reader =
        csv::Reader::from_path(path).map_err(|e| Error::csv(path, Place::File, FileOp::Read, e))?;
    let header: Vec<String> = reader
        .headers()
        .map_err(|e| Error::csv(path, Place::Line(1), FileOp::ReadHeader, e))?
        .iter()
        .map(str::to_string)
        .collect();
    if header != RINGS_HEADER {
        return Err(InputError::line(
            path,
            1,
            format!(
                "expected the columns {}, found {}",
                RINGS_HEADER.join(","),
                header.join(",")
            ),
        )
        .into());
    }
    let mut curves: Vec<RadialCurve> = Vec::new();
    for (i, record) in reader.records().enumerate() {
        let line = i + 2;
        let record = record.map_err(|e| Error::csv(path, Place::Line(line), FileOp::Read, e))?;
        let num = |col: usize| -> Result<f64, InputError> {
            record[col].parse::<f64>().map_err(|e| {
                InputError::line(
                    path,
                    line,
                    format!(
                        "`{}` is not a number ({}): {e}",
                        &record[col], RINGS_HEADER[col]
                    ),
                )
            })
        };
        let int = |col: usize| -> Result<usize, InputError> {
            record[col].parse::<usize>().map_err(|e| {
                InputError::line(
                    path,
                    line,
                    format!(
                        "`{}` is not a count ({}): {e}",
                        &record[col], RINGS_HEADER[col]
                    ),
                )
            })
        };
        let ring = Ring {
            radius: int(3)?,
            count: int(4)?,
            mean: num(5)?,
            variance: num(6)?,
            anisotropy_db: num(7)?,
        };
        let label = &record[0];
        match curves.iter_mut().find(|c| c.label == label) {
            Some(c) => c.rings.push(ring),
            None => curves.push(RadialCurve {
                label: label.to_string(),
                points: int(1)?,
                sets: int(2)?,
                rings: vec![ring],
            }),
        }
    }
    Ok(curves)
}

/// The periodogram as a log-scale heatmap with k_y up and DC (always
/// P(0) = N) in the middle, drawn grey so that the colours span the rest;
/// values below 10⁻² are drawn as 10⁻² (the colour bar says so): an
/// ordered grid's zeros are rounding noise of ~10⁻³⁰.
pub fn periodogram_heatmap(p: &Periodogram, title: impl Into<String>) -> Heatmap {
    const FLOOR: f64 = 1e-2;
    let f = p.freq as f64;
    let side = p.power.nrows();
    // Row 0 of a heatmap is drawn at the top: flip so k_y grows upwards.
    let data = Array2::from_shape_fn(p.power.dim(), |(r, c)| {
        if r == p.freq && c == p.freq {
            f64::NAN
        } else {
            p.power[[side - 1 - r, c]].max(FLOOR)
        }
    });
    let mut map = Heatmap::new(title, data);
    map.log_scale = true;
    map.palette = Palette::Magma;
    map.value_label = "P(k), log scale (< 10⁻² shown as 10⁻²; DC grey)".into();
    map.x_label = "kₓ (cycles per pixel)".into();
    map.y_label = "k_y".into();
    map.extent = Some([-f - 0.5, f + 0.5, -f - 0.5, f + 0.5]);
    map
}

/// The distinct N of `curves`, in order of appearance.
fn sample_counts(curves: &[RadialCurve]) -> Vec<usize> {
    let mut ns: Vec<usize> = Vec::new();
    for c in curves {
        if !ns.contains(&c.points) {
            ns.push(c.points);
        }
    }
    ns
}

/// Radial power against |k| for each curve (linear axes, as Heck et al.
/// draw it), with the white-noise line at 1 and a vertical line at each
/// pattern's sampling rate √N.
pub fn radial_chart(curves: &[RadialCurve], title: impl Into<String>) -> LineChart {
    let mut chart = LineChart::new(title, "|k| (cycles per pixel)", "radially averaged power P");
    let mut top: f64 = 1.0;
    let mut right: f64 = 1.0;
    for c in curves {
        let pts: Vec<(f64, f64)> = c.rings.iter().map(|r| (r.radius as f64, r.mean)).collect();
        top = pts.iter().map(|p| p.1).fold(top, f64::max);
        right = pts.iter().map(|p| p.0).fold(right, f64::max);
        chart
            .series
            .push(Series::new(c.label.clone(), pts, SeriesStyle::LinePoints));
    }
    chart.series.push(Series::new(
        "white noise (P = 1)",
        vec![(0.0, 1.0), (right, 1.0)],
        SeriesStyle::Dashed,
    ));
    for n in sample_counts(curves) {
        let s = (n as f64).sqrt();
        chart.series.push(Series::new(
            format!(
                "sampling rate √N = {} (N = {n})",
                crate::analysis::plot::format_tick(s)
            ),
            vec![(s, 0.0), (s, top)],
            SeriesStyle::Dashed,
        ));
    }
    chart
}

/// Anisotropy per ring for each curve, with the white-noise reference
/// 10·log10(1/M) for each distinct M.
pub fn anisotropy_chart(curves: &[RadialCurve], title: impl Into<String>) -> LineChart {
    let mut chart = LineChart::new(title, "|k| (cycles per pixel)", "anisotropy (dB)");
    let mut right: f64 = 1.0;
    for c in curves {
        let pts: Vec<(f64, f64)> = c
            .rings
            .iter()
            .map(|r| (r.radius as f64, r.anisotropy_db))
            .collect();
        right = pts.iter().map(|p| p.0).fold(right, f64::max);
        chart
            .series
            .push(Series::new(c.label.clone(), pts, SeriesStyle::LinePoints));
    }
    let mut ms: Vec<usize> = curves.iter().map(|c| c.sets).collect();
    ms.sort_unstable();
    ms.dedup();
    for m in ms {
        let a = white_noise_anisotropy_db(m);
        chart.series.push(Series::new(
            format!("white noise, 10·log10(1/M) = {a:.1} dB (M = {m})"),
            vec![(0.0, a), (right, a)],
            SeriesStyle::Dashed,
        ));
    }
    chart
}
