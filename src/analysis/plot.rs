//! Paper-quality figures: line charts, grouped bar charts, histograms,
//! heatmaps with a colour bar, and captioned image grids, each saved as both
//! PNG (for quick looks and the book) and SVG (for papers).
//!
//! These are the last step of the data flow: experiments, `raylab stats`
//! and `raylab diff` hand their numbers or images to one of the figure types
//! below and call `save(stem)`, which writes `stem.png` and `stem.svg`.
//! Each figure is a plain struct with public fields; build it, then save it.
//!
//! Conventions, so figures from different commands look alike:
//! - Text is DejaVu Sans, bundled in `data/fonts/` and compiled in, so the
//!   output never depends on the fonts of the machine (plotters is built
//!   without system-font lookup). PNG text is 26–40 px on a 1200×800 canvas.
//! - Series colours are the Okabe–Ito palette (safe for the common forms of
//!   colour blindness), and each series also gets its own marker shape, so
//!   a grey-scale print still tells them apart.
//! - Log axes place major ticks at powers of ten, labelled `10ᵏ` as
//!   matplotlib does, with light grid lines at 2·10ᵏ … 9·10ᵏ.
//! - Non-finite values are skipped, as are values ≤ 0 on a log axis; a log
//!   axis with no positive value at all is an error, never a panic.
//! - Files are rendered fully in memory and then written atomically, so a
//!   failure never leaves half a figure behind.

use crate::io::image::LinearImage;
use crate::io::write_atomically;
use crate::math::srgb_encode;
use anyhow::{anyhow, ensure, Context};
use ndarray::Array2;
use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, Ranged};
use plotters::coord::Shift;
use plotters::element::BitMapElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::FontStyle;
use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// DejaVu Sans (Bitstream Vera licence, see `data/fonts/LICENSE`).
static FONT_BYTES: &[u8] = include_bytes!("../../data/fonts/DejaVuSans.ttf");

/// The family name the bundled font is registered under.
const FONT_FAMILY: &str = "sans-serif";

/// The Okabe–Ito colour-blind-safe palette (Okabe & Ito, "Color Universal
/// Design", 2002), reordered so the first colours are the most distinct on
/// white; yellow comes last because it is faint on a white background.
pub const OKABE_ITO: [[u8; 3]; 8] = [
    [0, 114, 178],   // blue
    [213, 94, 0],    // vermillion
    [0, 158, 115],   // bluish green
    [204, 121, 167], // reddish purple
    [230, 159, 0],   // orange
    [86, 180, 233],  // sky blue
    [0, 0, 0],       // black
    [240, 228, 66],  // yellow
];

/// Default canvas size of charts in pixels (PNG) and user units (SVG).
pub const CHART_SIZE: (u32, u32) = (1200, 800);

// Text sizes in pixels, chosen so labels stay legible when a 1200 px wide
// figure is shrunk to a single column of a paper (about a third).
const TITLE_PX: f64 = 40.0;
const AXIS_DESC_PX: f64 = 32.0;
const TICK_PX: f64 = 26.0;
const LEGEND_PX: f64 = 26.0;
const CAPTION_PX: f64 = 28.0;

const LINE_WIDTH: u32 = 3;
const MARKER_RADIUS: i32 = 8;

/// Register the bundled font with plotters once per process.
fn ensure_font() -> anyhow::Result<()> {
    static REGISTERED: OnceLock<Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            plotters::style::register_font(FONT_FAMILY, FontStyle::Normal, FONT_BYTES)
                .map_err(|_| "the bundled DejaVu Sans font could not be parsed".to_string())
        })
        .clone()
        .map_err(|e| anyhow!(e))
}

fn font(px: f64) -> TextStyle<'static> {
    (FONT_FAMILY, px).into_font().color(&BLACK)
}

/// plotters' errors are generic over the backend; keep only their message.
fn plot_err<E: std::fmt::Display>(e: E) -> anyhow::Error {
    anyhow!("plotting failed: {e}")
}

fn rgb(c: [u8; 3]) -> RGBColor {
    RGBColor(c[0], c[1], c[2])
}

/// The colour of series number `i` (cycles through [`OKABE_ITO`]).
pub fn series_colour(i: usize) -> [u8; 3] {
    OKABE_ITO[i % OKABE_ITO.len()]
}

// ---------------------------------------------------------------------------
// Axes and ticks

/// How an axis maps values to positions.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Scale {
    /// Equal distances for equal differences.
    #[default]
    Linear,
    /// Equal distances for equal ratios (base-10 logarithm); values ≤ 0
    /// cannot be shown and are skipped.
    Log10,
}

/// One axis, resolved from the data: everything is drawn in "plot space",
/// which is the value itself on a linear axis and its log10 on a log axis,
/// so a single plotters coordinate type serves every combination of scales.
#[derive(Clone, Debug)]
struct Axis {
    scale: Scale,
    lo: f64,
    hi: f64,
    major: Vec<f64>,
    minor: Vec<f64>,
    /// Log axis whose majors include 2·10ᵏ or 5·10ᵏ: label every tick as a
    /// plain number, so "50, 100, 200" is not mixed with "10²".
    plain: bool,
}

impl Axis {
    /// An axis over [lo, hi] in plot space, with ticks chosen for it.
    fn new(scale: Scale, lo: f64, hi: f64) -> Axis {
        let (major, minor, plain) = match scale {
            Scale::Linear => {
                let (major, minor) = linear_ticks(lo, hi);
                (major, minor, true)
            }
            Scale::Log10 => log_ticks(lo, hi),
        };
        Axis {
            scale,
            lo,
            hi,
            major,
            minor,
            plain,
        }
    }

    /// The tick label for a plot-space position.
    fn label(&self, u: f64) -> String {
        match self.scale {
            Scale::Linear => format_tick(u),
            Scale::Log10 => {
                let k = u.round();
                if (u - k).abs() < 1e-9 && !self.plain {
                    format!("10{}", superscript(k as i64))
                } else {
                    format_tick(10f64.powf(u))
                }
            }
        }
    }

    /// The plotters coordinate for this axis, with our ticks as key points.
    fn coord(&self) -> AxisCoord {
        AxisCoord {
            lo: self.lo,
            hi: self.hi,
            major: self.major.clone(),
            minor: self.minor.clone(),
        }
    }

    /// Where plot-space `u` falls along the axis, 0 at `lo` and 1 at `hi`.
    fn fraction(&self, u: f64) -> f64 {
        (u - self.lo) / (self.hi - self.lo)
    }

    /// The same axis with its top moved up so that the old range fills only
    /// the lower `1 − top` of it (room for a legend above the data).
    fn with_headroom(&self, top: f64) -> Axis {
        let hi = self.lo + (self.hi - self.lo) / (1.0 - top);
        Axis::new(self.scale, self.lo, hi)
    }

    /// An axis spanning the finite plot-space values `us` (already mapped),
    /// padded by `pad` of the span on each side. With `from_base` the axis
    /// is meant for bars: a linear one includes 0 without padding past it,
    /// a log one starts at the decade below the smallest value. With no
    /// values the axis is [0, 1] (1 to 10 on a log axis).
    fn fit(scale: Scale, us: &[f64], pad: f64, from_base: bool) -> Axis {
        let mut lo = us.iter().copied().fold(f64::INFINITY, f64::min);
        let mut hi = us.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if !(lo.is_finite() && hi.is_finite()) {
            return Axis::new(scale, 0.0, 1.0);
        }
        let bars_linear = from_base && scale == Scale::Linear;
        let bars_log = from_base && scale == Scale::Log10;
        if bars_linear {
            lo = lo.min(0.0);
            hi = hi.max(0.0);
        }
        if hi - lo <= f64::EPSILON * lo.abs().max(1.0) * 4.0 {
            // A single value: centre it in a window of sensible width.
            let half = match scale {
                Scale::Linear => (lo.abs() * 0.1).max(0.5),
                Scale::Log10 => 0.5,
            };
            (lo, hi) = (lo - half, hi + half);
        } else {
            let span = hi - lo;
            // Bars start at 0 (linear) or a decade (log): no padding below.
            let bars_from_zero = bars_linear && lo == 0.0;
            if !(bars_log || bars_from_zero) {
                lo -= pad * span;
            }
            if !(bars_linear && hi == 0.0) {
                hi += pad * span;
            }
        }
        if bars_log {
            // Bars on a log axis rise from the decade below the data; where
            // they start is arbitrary, a round number at least reads well.
            lo = (lo + 1e-9).floor().min(hi - 1.0);
        }
        Axis::new(scale, lo, hi)
    }
}

/// A plotters coordinate in plot space whose ticks are ours: bold grid
/// lines and labels at `major`, light grid lines at `minor`. (plotters'
/// own `WithKeyPoints` would do, but it lacks a label formatter for f64.)
struct AxisCoord {
    lo: f64,
    hi: f64,
    major: Vec<f64>,
    minor: Vec<f64>,
}

impl Ranged for AxisCoord {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        let t = (value - self.lo) / (self.hi - self.lo);
        let px = f64::from(limit.0) + t * f64::from(limit.1 - limit.0);
        // Far-off values (a point outside a fixed range) must not overflow.
        px.round().clamp(-1e6, 1e6) as i32
    }

    fn key_points<H: KeyPointHint>(&self, hint: H) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            self.minor.clone()
        } else {
            self.major.clone()
        }
    }

    fn range(&self) -> std::ops::Range<f64> {
        self.lo..self.hi
    }
}

fn to_plot(scale: Scale, v: f64) -> Option<f64> {
    match scale {
        Scale::Linear => v.is_finite().then_some(v),
        Scale::Log10 => (v.is_finite() && v > 0.0).then(|| v.log10()),
    }
}

/// Major ticks at 1, 2 or 5 × 10ᵏ steps, about six of them, and a light
/// line half-way between majors.
fn linear_ticks(lo: f64, hi: f64) -> (Vec<f64>, Vec<f64>) {
    let raw = (hi - lo) / 6.0;
    if !(raw.is_finite() && raw > 0.0) {
        return (vec![], vec![]);
    }
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|&s| s >= raw)
        .unwrap_or(10.0 * mag);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    let major: Vec<f64> = (first..=last).map(|k| k as f64 * step).collect();
    let minor: Vec<f64> = (first - 1..=last)
        .map(|k| (k as f64 + 0.5) * step)
        .filter(|&u| u >= lo && u <= hi)
        .collect();
    (major, minor)
}

/// Log-axis ticks in log10 space: majors at powers of ten (every n-th
/// decade when there are more than eight), and when the range holds fewer
/// than three powers, the 2·10ᵏ and 5·10ᵏ values as well (then every
/// m·10ᵏ), so an axis spanning a decade or less still has labelled ticks.
/// Minor ticks at m·10ᵏ give the familiar log-paper grid. The flag says
/// whether the majors are not all powers of ten.
fn log_ticks(lo: f64, hi: f64) -> (Vec<f64>, Vec<f64>, bool) {
    let (k0, k1) = (lo.floor() as i64, hi.ceil() as i64);
    let decades = (k1 - k0).max(1);
    let every = (decades + 7) / 8;
    let inside = |u: &f64| *u >= lo - 1e-12 && *u <= hi + 1e-12;
    let mut major: Vec<f64> = (k0..=k1)
        .filter(|k| k.rem_euclid(every) == 0)
        .map(|k| k as f64)
        .filter(inside)
        .collect();
    let mantissas = |ms: &[f64]| -> Vec<f64> {
        (k0..=k1)
            .flat_map(|k| ms.iter().map(move |m| k as f64 + m.log10()))
            .filter(inside)
            .collect()
    };
    let mut plain = false;
    if major.len() < 3 {
        major = mantissas(&[1.0, 2.0, 5.0]);
        plain = true;
    }
    if major.len() < 3 {
        major = mantissas(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0]);
    }
    let minor = if every == 1 {
        mantissas(&[2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0])
    } else {
        vec![]
    };
    (major, minor, plain)
}

/// A short, exact-looking label for a tick value: plain decimals between
/// 0.001 and 100 000 (at most six significant digits, trailing zeros
/// removed, so 0.30000000000000004 prints as 0.3), otherwise `m×10ᵏ`.
pub fn format_tick(v: f64) -> String {
    if !v.is_finite() {
        return v.to_string();
    }
    let a = v.abs();
    if a < 1e-12 {
        return "0".to_string();
    }
    if (1e-3..1e5).contains(&a) {
        let decimals = (5 - a.log10().floor() as i64).clamp(0, 12) as usize;
        return trim_zeros(format!("{v:.decimals$}"));
    }
    let mut k = a.log10().floor() as i64;
    let mut m = v / 10f64.powi(k as i32);
    // Round the mantissa to three significant digits; 9.9996 becomes 10.
    m = (m * 100.0).round() / 100.0;
    if m.abs() >= 10.0 {
        m /= 10.0;
        k += 1;
    }
    let sign = if m < 0.0 { "−" } else { "" };
    let m = m.abs();
    if (m - 1.0).abs() < 1e-9 {
        format!("{sign}10{}", superscript(k))
    } else {
        format!(
            "{sign}{}×10{}",
            trim_zeros(format!("{m:.2}")),
            superscript(k)
        )
    }
}

fn trim_zeros(s: String) -> String {
    if s.contains('.') {
        let t = s.trim_end_matches('0').trim_end_matches('.');
        if t == "-0" {
            "0".to_string()
        } else {
            t.to_string()
        }
    } else {
        s
    }
}

/// An integer written in Unicode superscript digits (DejaVu Sans has them).
fn superscript(k: i64) -> String {
    const DIGITS: [char; 10] = ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'];
    let mut s = String::new();
    if k < 0 {
        s.push('⁻');
    }
    for c in k.unsigned_abs().to_string().chars() {
        s.push(DIGITS[c.to_digit(10).unwrap_or(0) as usize]);
    }
    s
}

// ---------------------------------------------------------------------------
// Rendering to both files

/// `stem` with `.ext` appended (not replacing a dot already in the name, so
/// `fig.v2` becomes `fig.v2.png`).
fn with_suffix(stem: &Path, ext: &str) -> PathBuf {
    let mut s: OsString = stem.as_os_str().to_owned();
    s.push(".");
    s.push(ext);
    PathBuf::from(s)
}

/// Something drawable on any plotters backend.
trait Figure {
    fn size(&self) -> (u32, u32);
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> anyhow::Result<()>;
}

/// Render `fig` to PNG and SVG in memory, then write `stem.png` and
/// `stem.svg` atomically.
fn save_figure<F: Figure>(fig: &F, stem: &Path) -> anyhow::Result<()> {
    ensure_font()?;
    let (w, h) = fig.size();
    ensure!(
        (100..=20_000).contains(&w) && (100..=20_000).contains(&h),
        "figure size {w}×{h} is out of range (100 to 20000 pixels a side)"
    );
    let mut pixels = vec![255u8; w as usize * h as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut pixels, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        fig.draw(&root)?;
        root.present().map_err(plot_err)?;
    }
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        fig.draw(&root)?;
        root.present().map_err(plot_err)?;
    }
    let png_path = with_suffix(stem, "png");
    let svg_path = with_suffix(stem, "svg");
    write_atomically(&png_path, |tmp| {
        let img = image::RgbImage::from_raw(w, h, pixels)
            .ok_or_else(|| anyhow!("figure buffer size mismatch"))?;
        img.save_with_format(tmp, image::ImageFormat::Png)
            .map_err(|e| anyhow!("{}: cannot write PNG: {e}", png_path.display()))
    })?;
    write_atomically(&svg_path, |tmp| {
        std::fs::write(tmp, svg.as_bytes())
            .with_context(|| format!("{}: cannot write SVG", svg_path.display()))
    })
}

// ---------------------------------------------------------------------------
// Markers and legends

/// Marker shapes, assigned per series in this order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Marker {
    Circle,
    Square,
    TriangleUp,
    Diamond,
    TriangleDown,
}

const MARKERS: [Marker; 5] = [
    Marker::Circle,
    Marker::Square,
    Marker::TriangleUp,
    Marker::Diamond,
    Marker::TriangleDown,
];

/// Vertices of a marker centred on (0, 0), in pixels (y down). Every shape
/// is a polygon so all markers share one element type.
fn marker_polygon(m: Marker, r: i32) -> Vec<(i32, i32)> {
    let rf = f64::from(r);
    let ring = |n: usize, start_deg: f64, scale: f64| -> Vec<(i32, i32)> {
        (0..n)
            .map(|i| {
                let a = (start_deg + 360.0 * i as f64 / n as f64).to_radians();
                (
                    (scale * rf * a.cos()).round() as i32,
                    (scale * rf * a.sin()).round() as i32,
                )
            })
            .collect()
    };
    match m {
        Marker::Circle => ring(20, 0.0, 1.0),
        Marker::Square => vec![
            (-r + 1, -r + 1),
            (r - 1, -r + 1),
            (r - 1, r - 1),
            (-r + 1, r - 1),
        ],
        Marker::TriangleUp => ring(3, -90.0, 1.2),
        Marker::TriangleDown => ring(3, 90.0, 1.2),
        Marker::Diamond => ring(4, -90.0, 1.15),
    }
}

/// How a series is drawn.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SeriesStyle {
    /// A solid line through the points.
    Line,
    /// Markers only (scatter).
    Points,
    /// A solid line with a marker at each point.
    #[default]
    LinePoints,
    /// A dashed line without markers, for reference or theoretical data
    /// (an O(n log n) curve, a published result).
    Dashed,
}

/// The parts of a series' legend glyph, in pixels relative to the legend
/// entry: three line segments (contiguous for a solid line, with gaps for a
/// dashed one) and the marker polygon. Invisible parts get a transparent
/// style, so every style builds the same element type.
struct LegendGlyph {
    segments: [Vec<(i32, i32)>; 3],
    line: ShapeStyle,
    marker: Vec<(i32, i32)>,
    marker_style: ShapeStyle,
}

impl LegendGlyph {
    fn new(style: SeriesStyle, marker: Marker, colour: RGBColor) -> Self {
        let seg = |a: i32, b: i32| vec![(a, 0), (b, 0)];
        let segments = match style {
            SeriesStyle::Dashed => [seg(0, 11), seg(17, 28), seg(34, 44)],
            _ => [seg(0, 15), seg(15, 30), seg(30, 44)],
        };
        let line = match style {
            SeriesStyle::Points => TRANSPARENT.stroke_width(1),
            _ => colour.stroke_width(LINE_WIDTH),
        };
        let (marker, marker_style) = match style {
            SeriesStyle::Points | SeriesStyle::LinePoints => {
                (marker_polygon(marker, MARKER_RADIUS), colour.filled())
            }
            _ => (vec![(0, 0), (1, 0), (0, 1)], TRANSPARENT.filled()),
        };
        let marker = marker.into_iter().map(|(x, y)| (x + 22, y)).collect();
        Self {
            segments,
            line,
            marker,
            marker_style,
        }
    }
}

/// Where the legend box goes inside the plot (named in kebab case in
/// experiment manifests and their `meta.json`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum LegendPosition {
    /// The first corner (upper right, upper left, lower right, lower left)
    /// where the box covers no data; if every corner has data, the y axis
    /// is extended upwards to make room in the upper right.
    #[default]
    Auto,
    /// Top left corner of the plot area.
    UpperLeft,
    /// Top right corner of the plot area.
    UpperRight,
    /// Bottom left corner of the plot area.
    LowerLeft,
    /// Bottom right corner of the plot area.
    LowerRight,
    /// No legend.
    Hidden,
}

fn draw_legend<'a, DB: DrawingBackend + 'a>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<AxisCoord, AxisCoord>>,
    position: LegendPosition,
) -> anyhow::Result<()> {
    let pos = match position {
        LegendPosition::UpperLeft => SeriesLabelPosition::UpperLeft,
        LegendPosition::UpperRight => SeriesLabelPosition::UpperRight,
        LegendPosition::LowerLeft => SeriesLabelPosition::LowerLeft,
        LegendPosition::LowerRight => SeriesLabelPosition::LowerRight,
        // `place_legend` resolves Auto before drawing.
        LegendPosition::Hidden | LegendPosition::Auto => return Ok(()),
    };
    chart
        .configure_series_labels()
        .position(pos)
        .margin(16)
        .legend_area_size(56)
        .label_font(font(LEGEND_PX))
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(120, 120, 120))
        .draw()
        .map_err(plot_err)
}

type Chart2d<'a, DB> = ChartContext<'a, DB, Cartesian2d<AxisCoord, AxisCoord>>;

/// The common frame of every x–y chart: caption, axes, ticks, grid.
fn build_chart<'a, DB: DrawingBackend>(
    root: &'a DrawingArea<DB, Shift>,
    title: &str,
    x: &Axis,
    y: &Axis,
    x_label: &str,
    y_label: &str,
    x_fmt: &dyn Fn(&f64) -> String,
) -> anyhow::Result<Chart2d<'a, DB>> {
    let mut chart = ChartBuilder::on(root)
        .caption(title, font(TITLE_PX))
        .margin(28)
        .x_label_area_size(96)
        .y_label_area_size(150)
        .build_cartesian_2d(x.coord(), y.coord())
        .map_err(plot_err)?;
    let y_fmt = |u: &f64| y.label(*u);
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(y_label)
        .label_style(font(TICK_PX))
        .axis_desc_style(font(AXIS_DESC_PX))
        .x_label_formatter(x_fmt)
        .y_label_formatter(&y_fmt)
        .bold_line_style(RGBColor(205, 205, 205).stroke_width(1))
        .light_line_style(RGBColor(238, 238, 238).stroke_width(1))
        .axis_style(BLACK.stroke_width(2))
        .set_all_tick_mark_size(8)
        .draw()
        .map_err(plot_err)?;
    Ok(chart)
}

/// Choose the legend corner for `LegendPosition::Auto`.
///
/// `occupied` holds samples of where the data is drawn, as fractions of the
/// plot area (x right, y up). The legend box size is estimated from the
/// labels (DejaVu Sans averages about 0.6 em per character). Returns the
/// corner and, when no corner is free, the fraction of the plot height to
/// add above the data for the legend (0 otherwise).
fn place_legend(
    requested: LegendPosition,
    labels: &[&str],
    occupied: &[(f64, f64)],
    size: (u32, u32),
) -> (LegendPosition, f64) {
    if labels.is_empty() {
        return (LegendPosition::Hidden, 0.0);
    }
    if requested != LegendPosition::Auto {
        return (requested, 0.0);
    }
    // Plot area of `build_chart`: canvas less margins, label areas, caption.
    let plot_w = (f64::from(size.0) - 2.0 * 28.0 - 150.0).max(1.0);
    let plot_h = (f64::from(size.1) - 2.0 * 28.0 - 96.0 - 1.5 * TITLE_PX).max(1.0);
    let chars = labels.iter().map(|l| l.chars().count()).max().unwrap_or(0) as f64;
    // Box plus its 16 px margin from the plot edge, plus 12 px of air.
    let box_w = (56.0 + 0.6 * LEGEND_PX * chars + 40.0 + 28.0) / plot_w;
    let box_h = (labels.len() as f64 * (LEGEND_PX + 8.0) + 30.0 + 28.0) / plot_h;
    let corners = [
        (
            LegendPosition::UpperRight,
            (1.0 - box_w, 1.0),
            (1.0 - box_h, 1.0),
        ),
        (LegendPosition::UpperLeft, (0.0, box_w), (1.0 - box_h, 1.0)),
        (LegendPosition::LowerRight, (1.0 - box_w, 1.0), (0.0, box_h)),
        (LegendPosition::LowerLeft, (0.0, box_w), (0.0, box_h)),
    ];
    for (pos, (x0, x1), (y0, y1)) in corners {
        let hit = occupied
            .iter()
            .any(|&(x, y)| x >= x0 && x <= x1 && y >= y0 && y <= y1);
        if !hit {
            return (pos, 0.0);
        }
    }
    // No free corner: make one, unless the legend is taller than half the
    // plot (then extending the axis would squash the data; overlap instead).
    if box_h < 0.5 {
        (LegendPosition::UpperRight, box_h)
    } else {
        (LegendPosition::UpperRight, 0.0)
    }
}

/// Samples along a polyline (plot space) as plot-area fractions, for
/// [`place_legend`].
fn sample_polyline(x: &Axis, y: &Axis, pts: &[(f64, f64)], out: &mut Vec<(f64, f64)>) {
    let frac = |p: (f64, f64)| (x.fraction(p.0), y.fraction(p.1));
    if let [only] = pts {
        out.push(frac(*only));
    }
    for w in pts.windows(2) {
        let (a, b) = (frac(w[0]), frac(w[1]));
        // 32 samples per segment: finer than any legend box is narrow.
        for i in 0..=32 {
            let t = f64::from(i) / 32.0;
            out.push((a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1)));
        }
    }
}

// ---------------------------------------------------------------------------
// Line chart

/// One named curve of a [`LineChart`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Series {
    /// Legend text.
    pub label: String,
    /// (x, y) points, drawn in the given order; non-finite points (and
    /// points ≤ 0 on a log axis) are skipped.
    pub points: Vec<(f64, f64)>,
    /// Line, markers, both, or dashed.
    pub style: SeriesStyle,
}

impl Series {
    /// A series with the given label, points and style.
    pub fn new(label: impl Into<String>, points: Vec<(f64, f64)>, style: SeriesStyle) -> Self {
        Self {
            label: label.into(),
            points,
            style,
        }
    }
}

/// An x–y chart of one or more series, on linear or log axes.
#[derive(Clone, Debug, PartialEq)]
pub struct LineChart {
    /// Caption above the plot.
    pub title: String,
    /// x axis description (include the unit).
    pub x_label: String,
    /// y axis description (include the unit).
    pub y_label: String,
    /// x axis scale.
    pub x_scale: Scale,
    /// y axis scale.
    pub y_scale: Scale,
    /// The curves, coloured and marked in order.
    pub series: Vec<Series>,
    /// Legend placement.
    pub legend: LegendPosition,
    /// Canvas size in pixels, [`CHART_SIZE`] by default.
    pub size: (u32, u32),
}

impl LineChart {
    /// An empty chart with linear axes; push series into `series`.
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
    ) -> Self {
        Self {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            x_scale: Scale::Linear,
            y_scale: Scale::Linear,
            series: Vec::new(),
            legend: LegendPosition::Auto,
            size: CHART_SIZE,
        }
    }

    /// Write `stem.png` and `stem.svg`. Fails (writing nothing) when a log
    /// axis has data but none of it is positive.
    pub fn save(&self, stem: &Path) -> anyhow::Result<()> {
        save_figure(self, stem).with_context(|| format!("line chart \"{}\"", self.title))
    }

    /// The drawable points of each series in plot space, split into runs:
    /// a point that cannot be drawn (NaN, infinite, ≤ 0 on a log axis) is
    /// missing data, so the line breaks there instead of bridging the gap.
    fn plot_runs(&self) -> Vec<Vec<Vec<(f64, f64)>>> {
        self.series
            .iter()
            .map(|s| {
                let mut runs = vec![Vec::new()];
                for &(x, y) in &s.points {
                    match (to_plot(self.x_scale, x), to_plot(self.y_scale, y)) {
                        (Some(u), Some(v)) => runs.last_mut().map_or((), |r| r.push((u, v))),
                        _ => runs.push(Vec::new()),
                    }
                }
                runs.retain(|r| !r.is_empty());
                runs
            })
            .collect()
    }

    fn axes(&self, runs: &[Vec<Vec<(f64, f64)>>]) -> anyhow::Result<(Axis, Axis)> {
        let all = || runs.iter().flatten().flatten();
        let xs: Vec<f64> = all().map(|p| p.0).collect();
        let ys: Vec<f64> = all().map(|p| p.1).collect();
        let any_finite = self
            .series
            .iter()
            .flat_map(|s| &s.points)
            .any(|(x, y)| x.is_finite() && y.is_finite());
        if any_finite && xs.is_empty() {
            let which: Vec<&str> = [("x", self.x_scale), ("y", self.y_scale)]
                .iter()
                .filter(|(_, s)| *s == Scale::Log10)
                .map(|(n, _)| *n)
                .collect();
            return Err(anyhow!(
                "no point has a positive value on the log {} axis; \
                 use a linear scale for data that is all zero or negative",
                which.join(" and ")
            ));
        }
        Ok((
            Axis::fit(self.x_scale, &xs, 0.03, false),
            Axis::fit(self.y_scale, &ys, 0.06, false),
        ))
    }
}

impl Figure for LineChart {
    fn size(&self) -> (u32, u32) {
        self.size
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> anyhow::Result<()> {
        let runs = self.plot_runs();
        let (x, y) = self.axes(&runs)?;
        let shown: Vec<usize> = (0..self.series.len())
            .filter(|&i| !runs[i].is_empty())
            .collect();
        let labels: Vec<&str> = shown
            .iter()
            .map(|&i| self.series[i].label.as_str())
            .collect();
        let mut occupied = Vec::new();
        for &i in &shown {
            for run in &runs[i] {
                sample_polyline(&x, &y, run, &mut occupied);
            }
        }
        let (legend, headroom) = place_legend(self.legend, &labels, &occupied, self.size);
        let y = if headroom > 0.0 {
            y.with_headroom(headroom)
        } else {
            y
        };
        let x_fmt = |u: &f64| x.label(*u);
        let mut chart = build_chart(
            root,
            &self.title,
            &x,
            &y,
            &self.x_label,
            &self.y_label,
            &x_fmt,
        )?;
        for &i in &shown {
            let s = &self.series[i];
            let colour = rgb(series_colour(i));
            let marker = MARKERS[i % MARKERS.len()];
            let line = colour.stroke_width(LINE_WIDTH);
            let style = s.style;
            // An empty series carries the legend entry; the runs follow.
            chart
                .draw_series(Vec::<PathElement<(f64, f64)>>::new())
                .map_err(plot_err)?
                .label(s.label.clone())
                .legend(move |at| {
                    let g = LegendGlyph::new(style, marker, colour);
                    let [a, b, c] = g.segments;
                    EmptyElement::at(at)
                        + PathElement::new(a, g.line)
                        + PathElement::new(b, g.line)
                        + PathElement::new(c, g.line)
                        + Polygon::new(g.marker, g.marker_style)
                });
            for run in &runs[i] {
                match style {
                    SeriesStyle::Line | SeriesStyle::LinePoints => {
                        chart
                            .draw_series(LineSeries::new(run.iter().copied(), line))
                            .map_err(plot_err)?;
                    }
                    SeriesStyle::Dashed => {
                        chart
                            .draw_series(DashedLineSeries::new(run.iter().copied(), 14, 8, line))
                            .map_err(plot_err)?;
                    }
                    SeriesStyle::Points => {}
                }
                if matches!(style, SeriesStyle::Points | SeriesStyle::LinePoints) {
                    chart
                        .draw_series(run.iter().map(|&c| {
                            EmptyElement::at(c)
                                + Polygon::new(
                                    marker_polygon(marker, MARKER_RADIUS),
                                    colour.filled(),
                                )
                        }))
                        .map_err(plot_err)?;
                }
            }
        }
        draw_legend(&mut chart, legend)
    }
}

// ---------------------------------------------------------------------------
// Bar chart

/// One series of a [`BarChart`]: a value per category.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BarSeries {
    /// Legend text.
    pub label: String,
    /// `values[i]` is the bar for category `i`; missing or non-finite
    /// values (and values ≤ 0 on a log axis) leave a gap.
    pub values: Vec<f64>,
}

impl BarSeries {
    /// A series with the given label and values.
    pub fn new(label: impl Into<String>, values: Vec<f64>) -> Self {
        Self {
            label: label.into(),
            values,
        }
    }
}

/// Grouped bars: for each category along x, one bar per series side by side.
#[derive(Clone, Debug, PartialEq)]
pub struct BarChart {
    /// Caption above the plot.
    pub title: String,
    /// x axis description.
    pub x_label: String,
    /// y axis description (include the unit).
    pub y_label: String,
    /// Category names along x, in order.
    pub categories: Vec<String>,
    /// The series, coloured in order.
    pub series: Vec<BarSeries>,
    /// y axis scale; on a log axis bars rise from the bottom of the axis.
    pub y_scale: Scale,
    /// Legend placement.
    pub legend: LegendPosition,
    /// Canvas size in pixels, [`CHART_SIZE`] by default.
    pub size: (u32, u32),
}

impl BarChart {
    /// An empty chart over the given categories; push series into `series`.
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
        categories: Vec<String>,
    ) -> Self {
        Self {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            categories,
            series: Vec::new(),
            y_scale: Scale::Linear,
            legend: LegendPosition::Auto,
            size: CHART_SIZE,
        }
    }

    /// Write `stem.png` and `stem.svg`.
    pub fn save(&self, stem: &Path) -> anyhow::Result<()> {
        save_figure(self, stem).with_context(|| format!("bar chart \"{}\"", self.title))
    }
}

impl BarChart {
    /// The bars as plot-space rectangles `(series, x0, x1, top)`; bars
    /// fill 80 % of each category slot, the rest separates the groups.
    fn bars(&self) -> Vec<(usize, f64, f64, f64)> {
        let n_cat = self.categories.len();
        let width = 0.8 / self.series.len().max(1) as f64;
        let mut out = Vec::new();
        for (j, s) in self.series.iter().enumerate() {
            for (i, &v) in s.values.iter().take(n_cat).enumerate() {
                if let Some(top) = to_plot(self.y_scale, v) {
                    let x0 = i as f64 + 0.1 + j as f64 * width;
                    out.push((j, x0, x0 + width, top));
                }
            }
        }
        out
    }
}

impl Figure for BarChart {
    fn size(&self) -> (u32, u32) {
        self.size
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> anyhow::Result<()> {
        let n_cat = self.categories.len();
        let bars = self.bars();
        let ys: Vec<f64> = bars.iter().map(|b| b.3).collect();
        let any_finite = self
            .series
            .iter()
            .flat_map(|s| s.values.iter().take(n_cat))
            .any(|v| v.is_finite());
        ensure!(
            !(any_finite && ys.is_empty()),
            "no bar has a positive value for the log y axis"
        );
        let y = Axis::fit(self.y_scale, &ys, 0.08, true);
        let x = Axis {
            major: (0..n_cat).map(|i| i as f64 + 0.5).collect(),
            minor: vec![],
            ..Axis::new(Scale::Linear, 0.0, n_cat.max(1) as f64)
        };
        let base = match self.y_scale {
            Scale::Linear => 0.0f64.clamp(y.lo, y.hi),
            Scale::Log10 => y.lo,
        };
        // Where the bars are, sampled on a grid inside each, for the legend.
        let mut occupied = Vec::new();
        for &(_, x0, x1, top) in &bars {
            for a in 0..=8 {
                for b in 0..=16 {
                    let u = x0 + (x1 - x0) * f64::from(a) / 8.0;
                    let v = base + (top - base) * f64::from(b) / 16.0;
                    occupied.push((x.fraction(u), y.fraction(v)));
                }
            }
        }
        let labels: Vec<&str> = self.series.iter().map(|s| s.label.as_str()).collect();
        let (legend, headroom) = place_legend(self.legend, &labels, &occupied, self.size);
        let y = if headroom > 0.0 {
            y.with_headroom(headroom)
        } else {
            y
        };
        let x_fmt = |u: &f64| {
            let i = (u - 0.5).round();
            if i >= 0.0 && (i as usize) < n_cat {
                self.categories[i as usize].clone()
            } else {
                String::new()
            }
        };
        let mut chart = build_chart(
            root,
            &self.title,
            &x,
            &y,
            &self.x_label,
            &self.y_label,
            &x_fmt,
        )?;
        for (j, s) in self.series.iter().enumerate() {
            let colour = rgb(series_colour(j));
            let rects: Vec<_> = bars
                .iter()
                .filter(|b| b.0 == j)
                .map(|&(_, x0, x1, top)| Rectangle::new([(x0, base), (x1, top)], colour.filled()))
                .collect();
            chart
                .draw_series(rects)
                .map_err(plot_err)?
                .label(s.label.clone())
                .legend(move |(lx, ly)| {
                    Rectangle::new([(lx, ly - 10), (lx + 36, ly + 10)], colour.filled())
                });
        }
        draw_legend(&mut chart, legend)
    }
}

// ---------------------------------------------------------------------------
// Histogram

/// Counts of `values` in `bins` equal-width bins over `range` = (lo, hi).
/// The last bin includes `hi`; values outside the range and non-finite
/// values are not counted. Returns an empty vector when `bins` is 0 or the
/// range is empty or not finite.
pub fn bin_counts(values: &[f64], bins: usize, range: (f64, f64)) -> Vec<u64> {
    let (lo, hi) = range;
    if bins == 0 || !(lo.is_finite() && hi.is_finite() && hi > lo) {
        return Vec::new();
    }
    let mut counts = vec![0u64; bins];
    for &v in values {
        if v.is_finite() && v >= lo && v <= hi {
            let i = (((v - lo) / (hi - lo)) * bins as f64) as usize;
            counts[i.min(bins - 1)] += 1;
        }
    }
    counts
}

/// A histogram of a sample: equal-width bins drawn as touching bars.
#[derive(Clone, Debug, PartialEq)]
pub struct Histogram {
    /// Caption above the plot.
    pub title: String,
    /// x axis description (what was measured, with unit).
    pub x_label: String,
    /// y axis description ("pixels", "runs", …).
    pub y_label: String,
    /// The sample; non-finite values are ignored.
    pub values: Vec<f64>,
    /// Number of bins (at least 1).
    pub bins: usize,
    /// Binning range; `None` means from the sample's minimum to maximum.
    pub range: Option<(f64, f64)>,
    /// y axis scale; `Log10` suits long-tailed data, empty bins are skipped.
    pub y_scale: Scale,
    /// Canvas size in pixels, [`CHART_SIZE`] by default.
    pub size: (u32, u32),
}

impl Histogram {
    /// A histogram of `values` in `bins` bins over the data range.
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        values: Vec<f64>,
        bins: usize,
    ) -> Self {
        Self {
            title: title.into(),
            x_label: x_label.into(),
            y_label: "count".into(),
            values,
            bins,
            range: None,
            y_scale: Scale::Linear,
            size: CHART_SIZE,
        }
    }

    /// The binning range actually used: `range`, or the data's extent
    /// (widened by ±0.5 when all values are equal). None without data.
    pub fn bin_range(&self) -> Option<(f64, f64)> {
        if let Some(r) = self.range {
            return Some(r);
        }
        let finite = self.values.iter().copied().filter(|v| v.is_finite());
        let lo = finite.clone().fold(f64::INFINITY, f64::min);
        let hi = finite.fold(f64::NEG_INFINITY, f64::max);
        if !lo.is_finite() {
            None
        } else if hi > lo {
            Some((lo, hi))
        } else {
            Some((lo - 0.5, hi + 0.5))
        }
    }

    /// Write `stem.png` and `stem.svg`.
    pub fn save(&self, stem: &Path) -> anyhow::Result<()> {
        save_figure(self, stem).with_context(|| format!("histogram \"{}\"", self.title))
    }
}

impl Figure for Histogram {
    fn size(&self) -> (u32, u32) {
        self.size
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> anyhow::Result<()> {
        ensure!(self.bins >= 1, "a histogram needs at least one bin");
        let (lo, hi) = self.bin_range().unwrap_or((0.0, 1.0));
        ensure!(
            lo.is_finite() && hi.is_finite() && hi > lo,
            "histogram range ({lo}, {hi}) is empty or not finite"
        );
        let counts = bin_counts(&self.values, self.bins, (lo, hi));
        let ys: Vec<f64> = counts
            .iter()
            .filter_map(|&c| to_plot(self.y_scale, c as f64))
            .collect();
        let x = Axis::fit(Scale::Linear, &[lo, hi], 0.0, false);
        let y = Axis::fit(self.y_scale, &ys, 0.08, true);
        let x_fmt = |u: &f64| x.label(*u);
        let mut chart = build_chart(
            root,
            &self.title,
            &x,
            &y,
            &self.x_label,
            &self.y_label,
            &x_fmt,
        )?;
        let base = match self.y_scale {
            Scale::Linear => 0.0,
            Scale::Log10 => y.lo,
        };
        let step = (hi - lo) / self.bins as f64;
        let colour = rgb(OKABE_ITO[0]);
        let bars = counts.iter().enumerate().filter_map(|(i, &c)| {
            let top = to_plot(self.y_scale, c as f64)?;
            let x0 = lo + i as f64 * step;
            Some(Rectangle::new(
                [(x0, base), (x0 + step, top)],
                colour.filled(),
            ))
        });
        chart.draw_series(bars).map_err(plot_err)?;
        let outlines = counts.iter().enumerate().filter_map(|(i, &c)| {
            let top = to_plot(self.y_scale, c as f64)?;
            let x0 = lo + i as f64 * step;
            Some(Rectangle::new(
                [(x0, base), (x0 + step, top)],
                WHITE.stroke_width(1),
            ))
        });
        chart.draw_series(outlines).map_err(plot_err)?;
        Ok(())
    }
}

// ---------------------------------------------------------------------------
// Colour maps and heatmaps

/// A perceptually uniform colour map for scalar data.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Palette {
    /// Viridis (van der Walt and Smith, matplotlib 2.0 default).
    #[default]
    Viridis,
    /// Magma, the map ꟻLIP uses for its error maps.
    Magma,
}

/// Viridis at nine equally spaced points, as published by the viridisLite R
/// package (`viridis(9)`); values in between are interpolated linearly in
/// sRGB, which stays within a few code values of the full 256-entry map.
const VIRIDIS_STOPS: [[u8; 3]; 9] = [
    [0x44, 0x01, 0x54],
    [0x47, 0x2D, 0x7B],
    [0x3B, 0x52, 0x8B],
    [0x2C, 0x72, 0x8E],
    [0x21, 0x90, 0x8C],
    [0x27, 0xAD, 0x81],
    [0x5D, 0xC8, 0x63],
    [0xAA, 0xDC, 0x32],
    [0xFD, 0xE7, 0x25],
];

/// ꟻLIP's own 256-entry magma table (from the `nv-flip` crate).
fn magma_table() -> &'static [u8] {
    static TABLE: OnceLock<Vec<u8>> = OnceLock::new();
    TABLE.get_or_init(|| nv_flip::magma_lut().to_vec())
}

impl Palette {
    /// The colour for `t` in [0, 1] (clamped; NaN gives the lowest colour).
    pub fn colour(self, t: f64) -> [u8; 3] {
        let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
        match self {
            Palette::Viridis => {
                let s = t * (VIRIDIS_STOPS.len() - 1) as f64;
                let i = (s.floor() as usize).min(VIRIDIS_STOPS.len() - 2);
                let f = s - i as f64;
                let (a, b) = (VIRIDIS_STOPS[i], VIRIDIS_STOPS[i + 1]);
                std::array::from_fn(|c| {
                    (f64::from(a[c]) + f * (f64::from(b[c]) - f64::from(a[c]))).round() as u8
                })
            }
            Palette::Magma => {
                let table = magma_table();
                let n = table.len() / 3;
                if n == 0 {
                    return [0, 0, 0];
                }
                let i = ((t * (n - 1) as f64).round() as usize).min(n - 1);
                [table[3 * i], table[3 * i + 1], table[3 * i + 2]]
            }
        }
    }
}

/// Colour of cells whose value cannot be shown (NaN, or ≤ 0 on a log scale).
const NO_DATA: [u8; 3] = [160, 160, 160];

/// A scalar field shown as colours, with a labelled colour bar; used for
/// per-pixel cost maps (rows are image rows, row 0 at the top).
#[derive(Clone, Debug, PartialEq)]
pub struct Heatmap {
    /// Caption above the map.
    pub title: String,
    /// The values, shape (rows, columns).
    pub data: Array2<f64>,
    /// Map colours by log10 of the value (for costs spanning decades);
    /// values ≤ 0 are then drawn grey, like NaN.
    pub log_scale: bool,
    /// Colour map.
    pub palette: Palette,
    /// What the colours mean, written beside the colour bar.
    pub value_label: String,
    /// x axis description ("pixel x" by default).
    pub x_label: String,
    /// y axis description ("pixel y" by default).
    pub y_label: String,
    /// Axis values at the map's edges, [left, right, bottom, top] (e.g.
    /// frequencies for a spectrum); `None` numbers cells from 0 at the
    /// left and top edges.
    pub extent: Option<[f64; 4]>,
}

impl Heatmap {
    /// A heatmap of `data` with a linear viridis scale.
    pub fn new(title: impl Into<String>, data: Array2<f64>) -> Self {
        Self {
            title: title.into(),
            data,
            log_scale: false,
            palette: Palette::Viridis,
            value_label: String::new(),
            x_label: "pixel x".into(),
            y_label: "pixel y".into(),
            extent: None,
        }
    }

    /// Write `stem.png` and `stem.svg`. Fails when the data is empty, or
    /// when `log_scale` is set and no value is positive.
    pub fn save(&self, stem: &Path) -> anyhow::Result<()> {
        save_figure(self, stem).with_context(|| format!("heatmap \"{}\"", self.title))
    }

    fn scale(&self) -> Scale {
        if self.log_scale {
            Scale::Log10
        } else {
            Scale::Linear
        }
    }

    /// Pixel size of the map area: fit 1000×800, keep square cells.
    fn map_pixels(&self) -> (u32, u32) {
        let (rows, cols) = self.data.dim();
        let (rows, cols) = (rows.max(1) as f64, cols.max(1) as f64);
        let s = (1000.0 / cols).min(800.0 / rows);
        (
            ((cols * s).round() as u32).max(1),
            ((rows * s).round() as u32).max(1),
        )
    }
}

// Layout of a heatmap figure around the map, in pixels.
const HM_LEFT: u32 = 150;
const HM_TOP: u32 = 90;
const HM_BOTTOM: u32 = 100;
const HM_BAR_AREA: u32 = 300;
/// Room right of the colour bar for tick labels and the value label.
const HM_BAR_LABELS: u32 = 200;
const HM_MARGIN: u32 = 20;

impl Figure for Heatmap {
    fn size(&self) -> (u32, u32) {
        let (w, h) = self.map_pixels();
        (
            HM_LEFT + w + HM_BAR_AREA + HM_MARGIN,
            HM_TOP + h + HM_BOTTOM,
        )
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> anyhow::Result<()> {
        let (rows, cols) = self.data.dim();
        ensure!(
            rows > 0 && cols > 0,
            "heatmap data is empty ({rows}×{cols})"
        );
        let scale = self.scale();
        let us: Vec<f64> = self
            .data
            .iter()
            .filter_map(|&v| to_plot(scale, v))
            .collect();
        ensure!(
            !us.is_empty(),
            "no value can be shown{}",
            if self.log_scale {
                " on a log scale (none is positive); use a linear scale"
            } else {
                " (all are NaN or infinite)"
            }
        );
        let vmin = us.iter().copied().fold(f64::INFINITY, f64::min);
        let vmax = us.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        // The colour bar spans exactly the data (full contrast); a constant
        // field gets a unit-wide window around its value.
        let bar_axis = Axis::fit(scale, &[vmin, vmax], 0.0, false);
        let (lo, hi) = (bar_axis.lo, bar_axis.hi);

        let (map_w, _) = self.map_pixels();
        root.draw_text(
            &self.title,
            &font(TITLE_PX).pos(Pos::new(HPos::Center, VPos::Top)),
            ((HM_LEFT + map_w / 2) as i32, 20),
        )
        .map_err(plot_err)?;

        // The map: axes in cell units, the cells drawn as one bitmap.
        let (map_area, bar_area) = root.split_horizontally(HM_LEFT + map_w);
        let map_area = map_area.margin(HM_TOP, 0, 0, 0);
        // Row 0 at the top: by default the y axis runs from `rows` (bottom)
        // to 0 (top).
        let [left, right, bottom, top] =
            self.extent.unwrap_or([0.0, cols as f64, rows as f64, 0.0]);
        let x = Axis::fit(Scale::Linear, &[left, right], 0.0, false);
        let mut y = Axis::fit(Scale::Linear, &[bottom, top], 0.0, false);
        if bottom > top {
            std::mem::swap(&mut y.lo, &mut y.hi);
        }
        let mut chart = ChartBuilder::on(&map_area)
            .x_label_area_size(HM_BOTTOM)
            .y_label_area_size(HM_LEFT)
            .build_cartesian_2d(x.coord(), y.coord())
            .map_err(plot_err)?;
        let x_fmt = |u: &f64| x.label(*u);
        let y_fmt = |u: &f64| y.label(*u);
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc(&self.x_label)
            .y_desc(&self.y_label)
            .label_style(font(TICK_PX))
            .axis_desc_style(font(AXIS_DESC_PX))
            .x_label_formatter(&x_fmt)
            .y_label_formatter(&y_fmt)
            .axis_style(BLACK.stroke_width(2))
            .set_all_tick_mark_size(8)
            .draw()
            .map_err(plot_err)?;
        let (pw, ph) = chart.plotting_area().dim_in_pixel();
        let mut buf = Vec::with_capacity(pw as usize * ph as usize * 3);
        for py in 0..ph as usize {
            let r = (py * rows / ph.max(1) as usize).min(rows - 1);
            for px in 0..pw as usize {
                let c = (px * cols / pw.max(1) as usize).min(cols - 1);
                let colour = match to_plot(scale, self.data[[r, c]]) {
                    Some(u) => self.palette.colour((u - lo) / (hi - lo)),
                    None => NO_DATA,
                };
                buf.extend_from_slice(&colour);
            }
        }
        let base = chart.plotting_area().get_base_pixel();
        draw_bitmap(root, base, (pw, ph), buf)?;

        // The colour bar: a narrow chart whose y axis is the value scale.
        let bar_area = bar_area.margin(HM_TOP, HM_BOTTOM, 60, 0);
        let bar_x = Axis::new(Scale::Linear, 0.0, 1.0);
        let mut bar = ChartBuilder::on(&bar_area)
            .right_y_label_area_size(HM_BAR_LABELS)
            .build_cartesian_2d(bar_x.coord(), bar_axis.coord())
            .map_err(plot_err)?;
        let bar_fmt = |u: &f64| bar_axis.label(*u);
        let no_fmt = |_: &f64| String::new();
        bar.configure_mesh()
            .disable_mesh()
            .disable_x_axis()
            .label_style(font(TICK_PX))
            .axis_desc_style(font(AXIS_DESC_PX))
            .x_label_formatter(&no_fmt)
            .y_label_formatter(&bar_fmt)
            .axis_style(BLACK.stroke_width(2))
            .set_all_tick_mark_size(8)
            .draw()
            .map_err(plot_err)?;
        let (bw, bh) = bar.plotting_area().dim_in_pixel();
        let mut bbuf = Vec::with_capacity(bw as usize * bh as usize * 3);
        for py in 0..bh {
            // Top of the bar is the highest value.
            let t = 1.0 - (f64::from(py) + 0.5) / f64::from(bh.max(1));
            let colour = self.palette.colour(t);
            for _ in 0..bw {
                bbuf.extend_from_slice(&colour);
            }
        }
        let bbase = bar.plotting_area().get_base_pixel();
        draw_bitmap(root, bbase, (bw, bh), bbuf)?;
        bar.plotting_area()
            .draw(&Rectangle::new(
                [(0.0, lo), (1.0, hi)],
                BLACK.stroke_width(2),
            ))
            .map_err(plot_err)?;
        // The value label, rotated along the bar beyond its tick labels.
        // (plotters' own y_desc lands outside the canvas in a right-hand
        // label area.)
        if !self.value_label.is_empty() {
            let x = bbase.0 + bw as i32 + HM_BAR_LABELS as i32 - 30;
            let y = bbase.1 + bh as i32 / 2;
            root.draw_text(
                &self.value_label,
                &font(AXIS_DESC_PX)
                    .transform(FontTransform::Rotate270)
                    .pos(Pos::new(HPos::Center, VPos::Center)),
                (x, y),
            )
            .map_err(plot_err)?;
        }
        Ok(())
    }
}

/// Blit an RGB buffer at an absolute pixel position of `root`.
fn draw_bitmap<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    at: (i32, i32),
    size: (u32, u32),
    rgb: Vec<u8>,
) -> anyhow::Result<()> {
    if size.0 == 0 || size.1 == 0 {
        return Ok(());
    }
    let origin = root.get_base_pixel();
    let element: BitMapElement<(i32, i32)> =
        BitMapElement::with_owned_buffer((at.0 - origin.0, at.1 - origin.1), size, rgb)
            .ok_or_else(|| anyhow!("bitmap buffer too small"))?;
    root.draw(&element).map_err(plot_err)
}

// ---------------------------------------------------------------------------
// Image grid

/// Images side by side with a caption under each, e.g. the same scene at
/// 1, 4 and 16 samples per pixel, or render / reference / ꟻLIP map.
#[derive(Clone, Debug, PartialEq)]
pub struct ImageGrid {
    /// Caption above the grid.
    pub title: String,
    /// Images per row (at least 1).
    pub columns: usize,
    /// The images (linear RGB, shown as 8-bit sRGB with values clamped to
    /// [0, 1]) and their captions, filled row by row.
    pub cells: Vec<(LinearImage, String)>,
}

// Layout of an image grid, in pixels.
const GRID_PAD: u32 = 24;
const GRID_TITLE: u32 = 80;
const GRID_CAPTION: u32 = 52;

impl ImageGrid {
    /// An empty grid; push `(image, caption)` pairs into `cells`.
    pub fn new(title: impl Into<String>, columns: usize) -> Self {
        Self {
            title: title.into(),
            columns,
            cells: Vec::new(),
        }
    }

    /// Write `stem.png` and `stem.svg` (the SVG embeds the images as PNG).
    /// Fails when there is no cell, an image is empty or not RGB, or
    /// `columns` is 0.
    pub fn save(&self, stem: &Path) -> anyhow::Result<()> {
        ensure!(
            self.columns >= 1,
            "image grid \"{}\": columns must be at least 1",
            self.title
        );
        ensure!(
            !self.cells.is_empty(),
            "image grid \"{}\" has no images",
            self.title
        );
        for (i, (img, caption)) in self.cells.iter().enumerate() {
            let (h, w, c) = img.dim();
            ensure!(
                h > 0 && w > 0 && c == 3,
                "image grid \"{}\": image {i} (\"{caption}\") is {w}×{h} with {c} channels; \
                 expected a non-empty RGB image",
                self.title
            );
        }
        save_figure(self, stem).with_context(|| format!("image grid \"{}\"", self.title))
    }

    /// The box every image is fitted into: the largest image, scaled by an
    /// integer factor (nearest neighbour, so pixels stay visible) when it is
    /// small, or shrunk when it is wider than 600 px.
    fn cell_box(&self) -> (u32, u32, f64) {
        let max_w = self
            .cells
            .iter()
            .map(|c| c.0.dim().1)
            .max()
            .unwrap_or(1)
            .max(1) as f64;
        let max_h = self
            .cells
            .iter()
            .map(|c| c.0.dim().0)
            .max()
            .unwrap_or(1)
            .max(1) as f64;
        let s = if max_w < 300.0 {
            (300.0 / max_w).floor().max(1.0)
        } else {
            (600.0 / max_w).min(1.0)
        };
        (
            ((max_w * s).round() as u32).max(1),
            ((max_h * s).round() as u32).max(1),
            s,
        )
    }

    fn rows(&self) -> usize {
        self.cells.len().div_ceil(self.columns.max(1))
    }
}

impl Figure for ImageGrid {
    fn size(&self) -> (u32, u32) {
        let (bw, bh, _) = self.cell_box();
        let cols = self.columns.clamp(1, self.cells.len().max(1)) as u32;
        let rows = self.rows() as u32;
        let w = GRID_PAD + cols * (bw + GRID_PAD);
        // Room for the title even when the grid is narrow.
        let title_w = (self.title.chars().count() as f64 * TITLE_PX * 0.6) as u32 + 2 * GRID_PAD;
        (
            w.max(title_w).max(400),
            GRID_TITLE + rows * (bh + GRID_CAPTION + GRID_PAD),
        )
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> anyhow::Result<()> {
        let (total_w, _) = self.size();
        let (bw, bh, s) = self.cell_box();
        let cols = self.columns.clamp(1, self.cells.len().max(1)) as u32;
        let grid_w = GRID_PAD + cols * (bw + GRID_PAD);
        let x_off = (total_w.saturating_sub(grid_w)) / 2;
        root.draw_text(
            &self.title,
            &font(TITLE_PX).pos(Pos::new(HPos::Center, VPos::Top)),
            ((total_w / 2) as i32, 20),
        )
        .map_err(plot_err)?;
        for (i, (img, caption)) in self.cells.iter().enumerate() {
            let (col, row) = ((i % cols as usize) as u32, (i / cols as usize) as u32);
            let (h, w, _) = img.dim();
            let iw = ((w as f64 * s).round() as u32).clamp(1, bw);
            let ih = ((h as f64 * s).round() as u32).clamp(1, bh);
            let cell_x = x_off + GRID_PAD + col * (bw + GRID_PAD);
            let cell_y = GRID_TITLE + row * (bh + GRID_CAPTION + GRID_PAD);
            // Centre the image horizontally; sit it on its caption.
            let ix = cell_x + (bw - iw) / 2;
            let iy = cell_y + (bh - ih);
            draw_bitmap(
                root,
                (ix as i32, iy as i32),
                (iw, ih),
                resample_srgb8(img, iw, ih),
            )?;
            root.draw(&Rectangle::new(
                [
                    (ix as i32 - 1, iy as i32 - 1),
                    ((ix + iw) as i32, (iy + ih) as i32),
                ],
                RGBColor(120, 120, 120).stroke_width(1),
            ))
            .map_err(plot_err)?;
            root.draw_text(
                caption,
                &font(CAPTION_PX).pos(Pos::new(HPos::Center, VPos::Top)),
                ((cell_x + bw / 2) as i32, (cell_y + bh + 12) as i32),
            )
            .map_err(plot_err)?;
        }
        Ok(())
    }
}

/// Resize a linear image to `w`×`h` and encode it as 8-bit sRGB. Each output
/// pixel averages (in linear light, where averaging is physically right)
/// the input pixels its footprint covers, which is a box filter when
/// shrinking and nearest neighbour when enlarging.
fn resample_srgb8(img: &LinearImage, w: u32, h: u32) -> Vec<u8> {
    let (ih, iw, _) = img.dim();
    let (w, h) = (w as usize, h as usize);
    let mut out = Vec::with_capacity(w * h * 3);
    for y in 0..h {
        let y0 = y * ih / h;
        let y1 = ((y + 1) * ih).div_ceil(h).clamp(y0 + 1, ih);
        for x in 0..w {
            let x0 = x * iw / w;
            let x1 = ((x + 1) * iw).div_ceil(w).clamp(x0 + 1, iw);
            let n = ((y1 - y0) * (x1 - x0)) as f32;
            for c in 0..3 {
                let mut sum = 0.0f32;
                for sy in y0..y1 {
                    for sx in x0..x1 {
                        let v = img[[sy, sx, c]];
                        sum += if v.is_finite() { v } else { 0.0 };
                    }
                }
                let v = srgb_encode((sum / n).clamp(0.0, 1.0));
                out.push((v * 255.0 + 0.5).floor() as u8);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels_are_short_and_exact_looking() {
        assert_eq!(format_tick(0.0), "0");
        assert_eq!(format_tick(0.1 + 0.2), "0.3");
        assert_eq!(format_tick(2.5), "2.5");
        assert_eq!(format_tick(-40.0), "-40");
        assert_eq!(format_tick(1e-3), "0.001");
        assert_eq!(format_tick(1e5), "10⁵");
        assert_eq!(format_tick(2.5e-7), "2.5×10⁻⁷");
        assert_eq!(format_tick(9.9996e6), "10⁷");
        assert_eq!(format_tick(f64::NAN), "NaN");
    }

    #[test]
    fn log_axes_get_power_of_ten_ticks() {
        // Five decades: majors at each power, labelled 10ᵏ.
        let axis = Axis::new(Scale::Log10, -0.2, 4.3);
        assert_eq!(axis.major, [0.0, 1.0, 2.0, 3.0, 4.0]);
        assert_eq!(axis.label(2.0), "10²");
        assert_eq!(axis.label(-3.0), "10⁻³");
        // Under a decade: 1-2-5 ticks, all labelled as plain numbers.
        let axis = Axis::new(Scale::Log10, 10f64.log10(), 60f64.log10());
        let labels: Vec<String> = axis.major.iter().map(|&u| axis.label(u)).collect();
        assert_eq!(labels, ["10", "20", "50"]);
        // Forty decades: every fifth power, never more than nine labels.
        let axis = Axis::new(Scale::Log10, -20.0, 20.0);
        assert!(
            axis.major.len() <= 9 && axis.major.len() >= 2,
            "{:?}",
            axis.major
        );
    }

    #[test]
    fn linear_ticks_use_one_two_five_steps() {
        let (major, _) = linear_ticks(0.0, 1.0);
        assert_eq!(major.len(), 6);
        assert!((major[1] - 0.2).abs() < 1e-12);
        assert_eq!(linear_ticks(1.0, 1.0), (vec![], vec![]));
    }

    #[test]
    fn palettes_hit_their_published_ends() {
        assert_eq!(Palette::Viridis.colour(0.0), [0x44, 0x01, 0x54]);
        assert_eq!(Palette::Viridis.colour(1.0), [0xFD, 0xE7, 0x25]);
        assert_eq!(Palette::Viridis.colour(f64::NAN), [0x44, 0x01, 0x54]);
        // Magma runs from near black to a light yellow.
        let (lo, hi) = (Palette::Magma.colour(0.0), Palette::Magma.colour(1.0));
        assert!(lo.iter().all(|&c| c < 10), "{lo:?}");
        assert!(hi[0] > 240 && hi[1] > 230, "{hi:?}");
    }
}
