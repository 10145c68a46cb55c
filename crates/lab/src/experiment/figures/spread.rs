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

use super::number;
use crate::experiment::data::Table;

/// The legend entry of the error bars of a line figure.
pub(super) const LINE_ERROR_LABEL: &str = "bars: fastest to slowest repeat";

/// The legend entry of the error bars of a ratio figure.
pub(super) const RATIO_ERROR_LABEL: &str = "bars: extreme ratios of the repeats";

/// How the timed repeats spread a timing column: column indices of the
/// table, see the module docs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Spread {
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
pub(super) fn spread(table: &Table, name: &str) -> Option<Spread> {
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
    pub(super) fn bounds(self, row: &[String], y: f64) -> (f64, f64) {
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

#[cfg(test)]
mod tests {
    use super::{spread, Spread, Table};

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
}
