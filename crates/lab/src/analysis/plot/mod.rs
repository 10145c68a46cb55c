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
//! - Titles, axis labels and captions always fit their space: each is
//!   measured in the bundled font ([`fit_text`]) and set smaller, down to
//!   [`MIN_TEXT_PX`], when it would be wider than the room it has (the
//!   canvas width for a title, the plot's width or height for an axis
//!   label). Text that does not fit even then is an error naming the
//!   figure and the text, never a clipped image; shorten it. As a last
//!   guard, a figure with ink in the canvas's outermost pixels (something
//!   drawn across the edge) is an error too.
//! - Timing series may carry error bars ([`Series::errors`]): a vertical
//!   bar from low to high at each point, with one legend entry saying what
//!   the bars are (`crate::experiment::figures` draws the min–max spread
//!   over a run's timed repeats this way).
//!
//! Layout: this file holds what every figure shares (the bundled font, the
//! text sizes, the series palette, the scalar colour maps and the writing
//! of both files); `axis.rs` resolves axes and ticks, `chart.rs` draws the
//! frame, markers and legend of x–y charts, and each figure kind has its
//! own file: `line.rs`, `bar.rs`, `histogram.rs`, `heatmap.rs` and
//! `image_grid.rs`. The figure types are re-exported here, so callers name
//! them `crate::analysis::plot::LineChart` and so on.

mod axis;
mod bar;
mod chart;
mod error;
mod heatmap;
mod histogram;
mod image_grid;
mod line;

pub use axis::{format_tick, AxisScale};
pub use bar::{BarChart, BarSeries};
pub use chart::{LegendPosition, SeriesStyle};
pub use error::PlotError;
pub use heatmap::Heatmap;
pub use histogram::{bin_counts, Histogram};
pub use image_grid::ImageGrid;
pub use line::{LineChart, Series};

use plotters::coord::Shift;
use plotters::element::BitMapElement;
use plotters::prelude::*;
use plotters::style::FontStyle;
use raylab::io::write_atomically;
use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// DejaVu Sans (Bitstream Vera licence, see `data/fonts/LICENSE`).
static FONT_BYTES: &[u8] = include_bytes!(concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../data/fonts/DejaVuSans.ttf"
));

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
pub(crate) const TICK_PX: f64 = 26.0;
const LEGEND_PX: f64 = 26.0;
const CAPTION_PX: f64 = 28.0;

/// The smallest size, in pixels, a title or axis label is shrunk to so
/// that it fits: two thirds of the tick labels' size, still legible when a
/// 1200 px figure is shown at the width of a book's text column.
pub const MIN_TEXT_PX: f64 = 18.0;

const LINE_WIDTH: u32 = 3;
const MARKER_RADIUS: i32 = 8;

/// Register the bundled font with plotters once per process.
fn ensure_font() -> Result<(), PlotError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let registered = *REGISTERED.get_or_init(|| {
        plotters::style::register_font(FONT_FAMILY, FontStyle::Normal, FONT_BYTES).is_ok()
    });
    if registered {
        Ok(())
    } else {
        Err(PlotError::Font)
    }
}

/// The bundled font at `px` pixels, in black.
fn font(px: f64) -> TextStyle<'static> {
    (FONT_FAMILY, px).into_font().color(&BLACK)
}

/// The width in pixels of `text` set in the bundled font at `px` (what the
/// PNG shows; an SVG viewer may substitute a font of similar width).
pub fn text_width(text: &str, px: f64) -> Result<f64, PlotError> {
    ensure_font()?;
    let (w, _) = font(px)
        .font
        .box_size(text)
        .map_err(|e| PlotError::Measure {
            text: text.to_string(),
            reason: format!("{e:?}"),
        })?;
    Ok(f64::from(w))
}

/// The size at which `text` (the figure's `what`: "title", "x axis
/// label"…) fits in `room` pixels: `px` when it fits there, otherwise the
/// largest whole size down to [`MIN_TEXT_PX`] that fits. An error when the
/// text is wider than `room` even at [`MIN_TEXT_PX`].
pub fn fit_text(what: &str, text: &str, px: f64, room: f64) -> Result<f64, PlotError> {
    let w = text_width(text, px)?;
    if w <= room {
        return Ok(px);
    }
    // Width grows with size; start from the proportional guess and step
    // down past rounding.
    let mut size = (px * room / w).floor().min(px - 1.0);
    while size >= MIN_TEXT_PX {
        if text_width(text, size)? <= room {
            return Ok(size);
        }
        size -= 1.0;
    }
    Err(PlotError::TextDoesNotFit {
        what: what.to_string(),
        text: text.to_string(),
        width: text_width(text, MIN_TEXT_PX)?,
        room,
    })
}

/// plotters' errors are generic over the backend; keep only their message.
fn plot_err<E: std::fmt::Display>(e: E) -> PlotError {
    PlotError::Backend(e.to_string())
}

/// An sRGB triple as a plotters colour.
fn rgb(c: [u8; 3]) -> RGBColor {
    RGBColor(c[0], c[1], c[2])
}

/// The colour of series number `i` (cycles through [`OKABE_ITO`]).
pub fn series_colour(i: usize) -> [u8; 3] {
    OKABE_ITO[i % OKABE_ITO.len()]
}

// ---------------------------------------------------------------------------
// Colour maps

/// A perceptually uniform colour map for scalar data.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Palette {
    /// Viridis (van der Walt and Smith, matplotlib 2.0 default).
    #[default]
    Viridis,
    /// Magma, the map ꟻLIP uses for its error maps.
    Magma,
    /// Blue (negative), white (zero), red (positive): ColorBrewer's RdBu
    /// (Brewer 2002), for signed fields such as derivatives. A heatmap
    /// with this palette centres its scale on 0, symmetric, so white is 0
    /// and equal colours on both sides are equal magnitudes.
    Diverging,
}

/// ColorBrewer RdBu at nine points, blue to red (the published order
/// reversed so that low values are blue).
const RDBU_STOPS: [[u8; 3]; 9] = [
    [0x21, 0x66, 0xAC],
    [0x43, 0x93, 0xC3],
    [0x92, 0xC5, 0xDE],
    [0xD1, 0xE5, 0xF0],
    [0xF7, 0xF7, 0xF7],
    [0xFD, 0xDB, 0xC7],
    [0xF4, 0xA5, 0x82],
    [0xD6, 0x60, 0x4D],
    [0xB2, 0x18, 0x2B],
];

/// Linear interpolation in sRGB between equally spaced stops.
fn interpolate(stops: &[[u8; 3]], t: f64) -> [u8; 3] {
    let s = t * (stops.len() - 1) as f64;
    let i = (s.floor() as usize).min(stops.len() - 2);
    let f = s - i as f64;
    let (a, b) = (stops[i], stops[i + 1]);
    std::array::from_fn(|c| {
        (f64::from(a[c]) + f * (f64::from(b[c]) - f64::from(a[c]))).round() as u8
    })
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
            Palette::Viridis => interpolate(&VIRIDIS_STOPS, t),
            Palette::Diverging => interpolate(&RDBU_STOPS, t),
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

/// Something drawable on any plotters backend; every figure kind
/// implements it and [`save_figure`] renders it to both files.
trait Figure {
    /// Canvas size in pixels (PNG) and user units (SVG).
    fn size(&self) -> (u32, u32);
    /// Draw the whole figure on `root` (already filled white).
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), PlotError>;
}

/// Render `fig` to PNG and SVG in memory, then write `stem.png` and
/// `stem.svg` atomically.
fn save_figure<F: Figure>(fig: &F, stem: &Path) -> Result<(), PlotError> {
    ensure_font()?;
    let (w, h) = fig.size();
    if !((100..=20_000).contains(&w) && (100..=20_000).contains(&h)) {
        return Err(PlotError::Invalid(format!(
            "figure size {w}×{h} is out of range (100 to 20000 pixels a side)"
        )));
    }
    let mut pixels = vec![255u8; w as usize * h as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut pixels, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        fig.draw(&root)?;
        root.present().map_err(plot_err)?;
    }
    check_edges(&pixels, w, h)?;
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
            .ok_or(PlotError::Internal("figure buffer size mismatch"))?;
        img.save_with_format(tmp, image::ImageFormat::Png)
            .map_err(|error| PlotError::Png {
                path: png_path.clone(),
                error,
            })
    })?;
    write_atomically(&svg_path, |tmp| {
        std::fs::write(tmp, svg.as_bytes()).map_err(|error| PlotError::Svg {
            path: svg_path.clone(),
            error,
        })
    })
}

/// Every figure leaves a white margin at the canvas edge; ink in the
/// outermost pixels means something drawn (a title, a rotated axis label)
/// runs off the canvas and is clipped. An error naming the edge.
fn check_edges(rgb: &[u8], w: u32, h: u32) -> Result<(), PlotError> {
    let (w, h) = (w as usize, h as usize);
    let ink = |x: usize, y: usize| {
        rgb[3 * (y * w + x)..3 * (y * w + x) + 3]
            .iter()
            .any(|&c| c < 200)
    };
    let edges = [
        ("left", (0..h).any(|y| ink(0, y))),
        ("right", (0..h).any(|y| ink(w - 1, y))),
        ("top", (0..w).any(|x| ink(x, 0))),
        ("bottom", (0..w).any(|x| ink(x, h - 1))),
    ];
    match edges.iter().find(|e| e.1) {
        Some(&(edge, _)) => Err(PlotError::Clipped { edge }),
        None => Ok(()),
    }
}

/// Draw `fig` into a throw-away bitmap: every check drawing makes (text
/// that does not fit, a log axis without positive data) without writing
/// a file.
fn check_figure<F: Figure>(fig: &F) -> Result<(), PlotError> {
    ensure_font()?;
    let (w, h) = fig.size();
    let mut pixels = vec![255u8; w as usize * h as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut pixels, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        fig.draw(&root)?;
        root.present().map_err(plot_err)?;
    }
    check_edges(&pixels, w, h)
}

/// Blit an RGB buffer at an absolute pixel position of `root` (heatmap
/// cells and colour bar, image-grid cells).
fn draw_bitmap<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    at: (i32, i32),
    size: (u32, u32),
    rgb: Vec<u8>,
) -> Result<(), PlotError> {
    if size.0 == 0 || size.1 == 0 {
        return Ok(());
    }
    let origin = root.get_base_pixel();
    let element: BitMapElement<(i32, i32)> =
        BitMapElement::with_owned_buffer((at.0 - origin.0, at.1 - origin.1), size, rgb)
            .ok_or(PlotError::Internal("bitmap buffer too small"))?;
    root.draw(&element).map_err(plot_err)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ink_at_the_canvas_edge_is_an_error() {
        let (w, h) = (20u32, 10u32);
        let mut px = vec![255u8; (w * h * 3) as usize];
        assert!(check_edges(&px, w, h).is_ok());
        // A dark pixel inside is fine; one on the left edge is clipped text.
        px[3 * (5 * w as usize + 5)] = 0;
        assert!(check_edges(&px, w, h).is_ok());
        px[3 * (5 * w as usize)] = 0;
        let err = check_edges(&px, w, h).unwrap_err().to_string();
        assert!(err.contains("left edge"), "{err}");
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
