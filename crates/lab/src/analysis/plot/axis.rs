//! Axes of the x–y charts and heatmaps: the linear or log scale, the range
//! fitted to the data, and the tick positions and labels (1-2-5 steps on a
//! linear axis, powers of ten labelled `10ᵏ` on a log axis). Part of
//! [`crate::analysis::plot`]; every figure kind resolves its axes here and
//! draws them through the plotters coordinate [`AxisCoord`].

use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, Ranged};

/// How an axis maps values to positions.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum AxisScale {
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
pub(super) struct Axis {
    pub(super) scale: AxisScale,
    pub(super) lo: f64,
    pub(super) hi: f64,
    pub(super) major: Vec<f64>,
    pub(super) minor: Vec<f64>,
    /// Log axis whose majors include 2·10ᵏ or 5·10ᵏ: label every tick as a
    /// plain number, so "50, 100, 200" is not mixed with "10²".
    pub(super) plain: bool,
}

impl Axis {
    /// An axis over [lo, hi] in plot space, with ticks chosen for it.
    pub(super) fn new(scale: AxisScale, lo: f64, hi: f64) -> Axis {
        let (major, minor, plain) = match scale {
            AxisScale::Linear => {
                let (major, minor) = linear_ticks(lo, hi);
                (major, minor, true)
            }
            AxisScale::Log10 => log_ticks(lo, hi),
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
    pub(super) fn label(&self, u: f64) -> String {
        match self.scale {
            AxisScale::Linear => format_tick(u),
            AxisScale::Log10 => {
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
    pub(super) fn coord(&self) -> AxisCoord {
        AxisCoord {
            lo: self.lo,
            hi: self.hi,
            major: self.major.clone(),
            minor: self.minor.clone(),
        }
    }

    /// Where plot-space `u` falls along the axis, 0 at `lo` and 1 at `hi`.
    pub(super) fn fraction(&self, u: f64) -> f64 {
        (u - self.lo) / (self.hi - self.lo)
    }

    /// The same axis with its top moved up so that the old range fills only
    /// the lower `1 − top` of it (room for a legend above the data).
    pub(super) fn with_headroom(&self, top: f64) -> Axis {
        let hi = self.lo + (self.hi - self.lo) / (1.0 - top);
        Axis::new(self.scale, self.lo, hi)
    }

    /// An axis spanning the finite plot-space values `us` (already mapped),
    /// padded by `pad` of the span on each side. With `from_base` the axis
    /// is meant for bars: a linear one includes 0 without padding past it,
    /// a log one starts at the decade below the smallest value. With no
    /// values the axis is [0, 1] (1 to 10 on a log axis).
    pub(super) fn fit(scale: AxisScale, us: &[f64], pad: f64, from_base: bool) -> Axis {
        let mut lo = us.iter().copied().fold(f64::INFINITY, f64::min);
        let mut hi = us.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if !(lo.is_finite() && hi.is_finite()) {
            return Axis::new(scale, 0.0, 1.0);
        }
        let bars_linear = from_base && scale == AxisScale::Linear;
        let bars_log = from_base && scale == AxisScale::Log10;
        if bars_linear {
            lo = lo.min(0.0);
            hi = hi.max(0.0);
        }
        if hi - lo <= f64::EPSILON * lo.abs().max(1.0) * 4.0 {
            // A single value: centre it in a window of sensible width.
            let half = match scale {
                AxisScale::Linear => (lo.abs() * 0.1).max(0.5),
                AxisScale::Log10 => 0.5,
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
pub(super) struct AxisCoord {
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

/// `v` in plot space: itself on a linear axis, its log10 on a log axis;
/// `None` when it cannot be drawn (not finite, or ≤ 0 on a log axis).
pub(super) fn to_plot(scale: AxisScale, v: f64) -> Option<f64> {
    match scale {
        AxisScale::Linear => v.is_finite().then_some(v),
        AxisScale::Log10 => (v.is_finite() && v > 0.0).then(|| v.log10()),
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
/// than three powers, the 2·10ᵏ and 5·10ᵏ values as well (then 3·10ᵏ and
/// 7·10ᵏ, then every m·10ᵏ), so an axis spanning a decade or less still has
/// labelled ticks.
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
    // Then 1, 2, 3, 5, 7 before every mantissa: on a log axis 7, 8, 9 and
    // 10 sit so close that their labels run into each other.
    if major.len() < 3 {
        major = mantissas(&[1.0, 2.0, 3.0, 5.0, 7.0]);
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
        let axis = Axis::new(AxisScale::Log10, -0.2, 4.3);
        assert_eq!(axis.major, [0.0, 1.0, 2.0, 3.0, 4.0]);
        assert_eq!(axis.label(2.0), "10²");
        assert_eq!(axis.label(-3.0), "10⁻³");
        // Under a decade: 1-2-5 ticks, all labelled as plain numbers.
        let axis = Axis::new(AxisScale::Log10, 10f64.log10(), 60f64.log10());
        let labels: Vec<String> = axis.major.iter().map(|&u| axis.label(u)).collect();
        assert_eq!(labels, ["10", "20", "50"]);
        // Forty decades: every fifth power, never more than nine labels.
        let axis = Axis::new(AxisScale::Log10, -20.0, 20.0);
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
}
