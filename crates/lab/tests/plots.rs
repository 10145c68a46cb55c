//! Figures: every chart kind writes a PNG of the expected size and an SVG
//! holding its text, and awkward data (zeros on log axes, NaN, empty
//! series) never panics.
//!
//! Set `RAYLAB_PLOT_SAMPLES=/some/dir` to keep the figures there for a look.

use ndarray::{Array2, Array3};
use raylab_lab::analysis::plot::{
    AxisScale, BarChart, BarSeries, Heatmap, Histogram, ImageGrid, LineChart, Palette, Series,
    SeriesStyle,
};
use std::path::{Path, PathBuf};

/// Where figures go: a fresh temporary directory, or the sample folder
/// named by `RAYLAB_PLOT_SAMPLES`.
struct OutDir {
    _tmp: tempfile::TempDir,
    path: PathBuf,
}

fn out_dir() -> OutDir {
    let tmp = tempfile::tempdir().unwrap();
    let path = match std::env::var_os("RAYLAB_PLOT_SAMPLES") {
        Some(dir) => {
            std::fs::create_dir_all(&dir).unwrap();
            PathBuf::from(dir)
        }
        None => tmp.path().to_path_buf(),
    };
    OutDir { _tmp: tmp, path }
}

/// Check `stem.png` (non-empty, of the given size when known) and
/// `stem.svg` (contains every expected text); returns the PNG size.
fn check_outputs(stem: &Path, size: Option<(u32, u32)>, texts: &[&str]) -> (u32, u32) {
    let png = stem.with_extension("png");
    let svg = stem.with_extension("svg");
    assert!(std::fs::metadata(&png).unwrap().len() > 1000);
    let img = image::open(&png).unwrap();
    if let Some(size) = size {
        assert_eq!((img.width(), img.height()), size);
    }
    let svg_text = std::fs::read_to_string(&svg).unwrap();
    assert!(svg_text.starts_with("<svg") || svg_text.contains("<svg"));
    for t in texts {
        assert!(svg_text.contains(t), "{} lacks {t:?}", svg.display());
    }
    (img.width(), img.height())
}

fn cost_curves() -> LineChart {
    let mut chart = LineChart::new("BVH traversal cost", "triangles", "box tests per ray");
    chart.x_scale = AxisScale::Log10;
    chart.y_scale = AxisScale::Log10;
    let ns = [1e2, 1e3, 1e4, 1e5, 1e6];
    chart.series.push(Series::new(
        "median split",
        ns.iter().map(|&n: &f64| (n, 3.0 * n.log2())).collect(),
        SeriesStyle::LinePoints,
    ));
    chart.series.push(Series::new(
        "binned SAH",
        ns.iter().map(|&n: &f64| (n, 2.0 * n.log2())).collect(),
        SeriesStyle::LinePoints,
    ));
    chart.series.push(Series::new(
        "brute force",
        ns.iter().map(|&n| (n, n)).collect(),
        SeriesStyle::Points,
    ));
    chart.series.push(Series::new(
        "O(log n) reference",
        ns.iter().map(|&n: &f64| (n, n.log2())).collect(),
        SeriesStyle::Dashed,
    ));
    chart
}

#[test]
fn line_chart_writes_png_and_svg_with_title_and_legend() {
    let out = out_dir();
    let stem = out.path.join("line-loglog");
    cost_curves().save(&stem).unwrap();
    check_outputs(
        &stem,
        Some((1200, 800)),
        &[
            "BVH traversal cost",
            "median split",
            "binned SAH",
            "O(log n) reference",
            "triangles",
        ],
    );
}

#[test]
fn linear_line_chart_with_nan_and_empty_series() {
    let out = out_dir();
    let stem = out.path.join("line-linear");
    let mut chart = LineChart::new("Noise vs samples", "samples per pixel", "RMSE");
    chart.series.push(Series::new(
        "jittered",
        (1..=16)
            .map(|k| (k as f64, 0.3 / (k as f64).sqrt()))
            .collect(),
        SeriesStyle::Line,
    ));
    chart.series.push(Series::new(
        "with a NaN",
        vec![
            (1.0, 0.2),
            (2.0, f64::NAN),
            (f64::INFINITY, 0.1),
            (4.0, 0.1),
        ],
        SeriesStyle::LinePoints,
    ));
    chart
        .series
        .push(Series::new("empty", vec![], SeriesStyle::Line));
    chart.save(&stem).unwrap();
    check_outputs(&stem, Some((1200, 800)), &["Noise vs samples", "jittered"]);
}

#[test]
fn log_axis_with_a_zero_value_is_skipped_not_a_panic() {
    let out = out_dir();
    let stem = out.path.join("line-log-zero");
    let mut chart = LineChart::new("with a zero", "n", "cost");
    chart.y_scale = AxisScale::Log10;
    chart.series.push(Series::new(
        "s",
        vec![(0.0, 0.0), (1.0, 10.0), (2.0, 100.0), (3.0, 0.0)],
        SeriesStyle::LinePoints,
    ));
    chart.save(&stem).unwrap();
    check_outputs(&stem, Some((1200, 800)), &["with a zero"]);
}

#[test]
fn log_axis_with_only_zeros_is_a_clear_error_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let stem = dir.path().join("zeros");
    let mut chart = LineChart::new("all zero", "n", "cost");
    chart.y_scale = AxisScale::Log10;
    chart.series.push(Series::new(
        "s",
        vec![(1.0, 0.0), (2.0, 0.0)],
        SeriesStyle::Line,
    ));
    let err = format!("{:#}", chart.save(&stem).unwrap_err());
    assert!(err.contains("log") && err.contains("positive"), "{err}");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);

    let mut heat = Heatmap::new("zeros", Array2::zeros((4, 4)));
    heat.log_scale = true;
    assert!(heat.save(&stem).is_err());
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn grouped_bar_chart_has_categories_and_legend() {
    let out = out_dir();
    let stem = out.path.join("bars");
    let mut chart = BarChart::new(
        "Rays per second by accelerator",
        "scene",
        "Mrays/s",
        vec![
            "spheres".into(),
            "bunny".into(),
            "dragon".into(),
            "camel".into(),
        ],
    );
    chart
        .series
        .push(BarSeries::new("brute", vec![0.8, 0.01, 0.002, 0.02]));
    chart
        .series
        .push(BarSeries::new("bvh:aabb:sah", vec![4.1, 3.2, 2.5, 3.0]));
    chart
        .series
        .push(BarSeries::new("embree", vec![9.5, 8.7, f64::NAN, 8.1]));
    chart.save(&stem).unwrap();
    check_outputs(
        &stem,
        Some((1200, 800)),
        &[
            "Rays per second by accelerator",
            "bvh:aabb:sah",
            "embree",
            "dragon",
        ],
    );
    // The same on a log axis, where the brute-force bars are visible.
    chart.y_scale = AxisScale::Log10;
    chart.series[0].values[1] = 0.0;
    let stem = out.path.join("bars-log");
    chart.save(&stem).unwrap();
    check_outputs(&stem, Some((1200, 800)), &["brute"]);
}

#[test]
fn histogram_writes_both_files() {
    let out = out_dir();
    let stem = out.path.join("histogram");
    // A deterministic long-tailed sample: squares of an even spread.
    let values: Vec<f64> = (0..2000)
        .map(|i| (i as f64 / 2000.0).powi(3) * 50.0)
        .collect();
    let mut h = Histogram::new("Box tests per ray", "box tests", values, 25);
    h.y_label = "rays".into();
    h.y_scale = AxisScale::Log10;
    h.save(&stem).unwrap();
    check_outputs(&stem, Some((1200, 800)), &["Box tests per ray", "rays"]);
    assert_eq!(
        raylab_lab::analysis::plot::bin_counts(&[0.0, 0.5, 1.0, 2.0, f64::NAN], 2, (0.0, 1.0)),
        [1, 2]
    );
}

#[test]
fn heatmap_has_colour_bar_and_keeps_square_cells() {
    let out = out_dir();
    let stem = out.path.join("heatmap");
    // A 48×64 "cost" field spanning three decades, with a NaN and a zero.
    let mut data = Array2::from_shape_fn((48, 64), |(r, c)| {
        let (x, y) = (c as f64 / 63.0 - 0.5, r as f64 / 47.0 - 0.5);
        10f64.powf(1.0 + 3.0 * (-(x * x + y * y) * 8.0).exp())
    });
    data[[0, 0]] = f64::NAN;
    data[[0, 1]] = 0.0;
    let mut h = Heatmap::new("Box tests per pixel", data);
    h.log_scale = true;
    h.value_label = "box tests".into();
    h.save(&stem).unwrap();
    let (w, ht) = check_outputs(&stem, None, &["Box tests per pixel", "box tests"]);
    assert!(w >= 1000 && ht >= 700, "{w}×{ht}");

    let mut lin = Heatmap::new("Linear magma", Array2::from_elem((3, 5), 2.0));
    lin.palette = Palette::Magma;
    let stem = out.path.join("heatmap-constant");
    lin.save(&stem).unwrap();
    check_outputs(&stem, None, &["Linear magma"]);
}

#[test]
fn image_grid_captions_every_cell() {
    let out = out_dir();
    let stem = out.path.join("grid");
    let gradient = |h: usize, w: usize, tint: [f32; 3]| {
        Array3::from_shape_fn((h, w, 3), |(y, x, c)| {
            tint[c] * (x as f32 / w as f32) * (1.0 - 0.5 * y as f32 / h as f32)
        })
    };
    let mut grid = ImageGrid::new("Samples per pixel", 3);
    grid.cells
        .push((gradient(48, 64, [1.0, 0.4, 0.1]), "1 spp".into()));
    grid.cells
        .push((gradient(48, 64, [0.2, 0.8, 0.3]), "4 spp".into()));
    grid.cells
        .push((gradient(48, 64, [0.1, 0.3, 1.0]), "16 spp".into()));
    grid.cells
        .push((gradient(24, 32, [1.0, 1.0, 1.0]), "half size".into()));
    grid.save(&stem).unwrap();
    check_outputs(
        &stem,
        None,
        &["Samples per pixel", "1 spp", "16 spp", "half size"],
    );

    let empty = ImageGrid::new("empty", 2);
    assert!(empty.save(&out.path.join("empty-grid")).is_err());
}

#[test]
fn long_titles_shrink_to_fit_and_impossible_ones_are_errors() {
    use raylab_lab::analysis::plot::{fit_text, text_width, MIN_TEXT_PX};
    // A title that fits is kept at its size.
    assert_eq!(fit_text("title", "Short", 40.0, 1000.0).unwrap(), 40.0);
    // One too wide at 40 px is set smaller, and then fits.
    let long = "Mean luminance against the gain α, S4's scheme, both averagings";
    assert!(text_width(long, 40.0).unwrap() > 1000.0);
    let px = fit_text("title", long, 40.0, 1000.0).unwrap();
    assert!((MIN_TEXT_PX..40.0).contains(&px), "{px}");
    assert!(text_width(long, px).unwrap() <= 1000.0);
    // One that cannot fit even at the smallest size is an error naming it.
    let err = fit_text("title", &long.repeat(4), 40.0, 1000.0).unwrap_err();
    assert!(err.to_string().contains("does not fit"), "{err}");
    // Through a chart: saving fails, naming the chart, and writes nothing.
    let dir = out_dir();
    let mut chart = cost_curves();
    chart.title = long.repeat(3);
    let stem = dir.path.join("too-long-title");
    let err = format!("{:#}", chart.save(&stem).unwrap_err());
    assert!(
        err.contains("line chart") && err.contains("does not fit"),
        "{err}"
    );
    assert!(!stem.with_extension("png").exists());
}

#[test]
fn every_manifest_figure_title_and_label_fits() {
    let root = raylab_testkit::repo().join("analysis");
    let mut checked = 0;
    let mut manifests: Vec<PathBuf> = std::fs::read_dir(&root)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    manifests.sort();
    assert!(!manifests.is_empty(), "no manifests in {}", root.display());
    let mut failures = Vec::new();
    for path in &manifests {
        let m = raylab_lab::experiment::load_manifest(path).unwrap();
        let quick = m.with_quick().unwrap();
        for spec in m.figures.iter().chain(&quick.figures) {
            if let Err(e) = raylab_lab::experiment::figures::check_text(spec) {
                failures.push(format!("{}: {e:#}", path.display()));
            }
            checked += 1;
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    assert!(checked > 20, "only {checked} figures checked");
}

#[test]
fn error_bars_widen_the_axis_and_get_a_legend_entry() {
    let dir = out_dir();
    let mut chart = LineChart::new("Timing with spread", "pixels", "seconds");
    chart.series.push(
        Series::new(
            "median",
            vec![(1.0, 1.0), (2.0, 2.0), (3.0, 3.0)],
            SeriesStyle::LinePoints,
        )
        .with_errors(vec![(0.5, 1.5), (2.0, 2.0), (2.5, 9.0)]),
    );
    chart.error_label = "bars: fastest to slowest repeat".to_string();
    let stem = dir.path.join("error-bars");
    chart.save(&stem).unwrap();
    let svg = std::fs::read_to_string(stem.with_extension("svg")).unwrap();
    assert!(svg.contains("bars: fastest to slowest repeat"));
    // The top bar end (9) is inside the y axis: a tick label of 8 exists.
    let texts: Vec<&str> = svg
        .split("<text")
        .skip(1)
        .filter_map(|t| t.split_once('>').and_then(|(_, r)| r.split('<').next()))
        .map(str::trim)
        .collect();
    assert!(texts.contains(&"8"), "y axis ignores the bars: {texts:?}");
    // Without any bar of non-zero length, no legend entry.
    chart.series[0].errors = vec![(1.0, 1.0), (2.0, 2.0), (3.0, 3.0)];
    chart.save(&stem).unwrap();
    let svg = std::fs::read_to_string(stem.with_extension("svg")).unwrap();
    assert!(!svg.contains("bars: fastest"));
}
