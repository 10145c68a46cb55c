//! Reconstruction filters: how a pixel's value is made from the samples
//! around it.
//!
//! - `Box`: the mean of the pixel's own samples — S1's downsample.
//! - `Tent`: weight 1 − |d| (d in pixels from the pixel centre, per axis),
//!   radius 1: samples up to one pixel away contribute, linearly less.
//! - `Mitchell`: the Mitchell–Netravali cubic (Mitchell & Netravali 1988,
//!   "Reconstruction filters in computer graphics") with B = C = 1/3, the
//!   pair the paper recommends, on a radius of 2 pixels. It has small
//!   negative lobes, which sharpen edges and can ring.
//!
//! Filters are separable, w(dx, dy) = w(dx)·w(dy), and a pixel's value is
//! the weighted mean Σ w·L / Σ w over every sample within the radius, so the
//! filters need not be normalised and a constant image stays constant.

use crate::error::ParseError;
use serde::{Deserialize, Serialize};

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Filter {
    #[default]
    Box,
    Tent,
    Mitchell,
}

/// Mitchell–Netravali's B and C (the paper's recommended B = C = 1/3).
const B: f32 = 1.0 / 3.0;
const C: f32 = 1.0 / 3.0;

impl Filter {
    /// Every filter by name, in the order `--help` lists them.
    pub const ALL: [Filter; 3] = [Filter::Box, Filter::Tent, Filter::Mitchell];

    /// How far (in pixels, per axis) from a pixel's centre samples count.
    pub fn radius(&self) -> f32 {
        match self {
            Filter::Box => 0.5,
            Filter::Tent => 1.0,
            Filter::Mitchell => 2.0,
        }
    }

    /// The 1D weight at offset `d` pixels from the centre.
    #[inline]
    pub fn weight_1d(&self, d: f32) -> f32 {
        let x = d.abs();
        match self {
            // Half-open so a sample on a pixel border counts once.
            Filter::Box => {
                if (-0.5..0.5).contains(&d) {
                    1.0
                } else {
                    0.0
                }
            }
            Filter::Tent => (1.0 - x).max(0.0),
            Filter::Mitchell => mitchell(x),
        }
    }

    /// The 2D weight of a sample `(dx, dy)` pixels from the centre.
    #[inline]
    pub fn weight(&self, dx: f32, dy: f32) -> f32 {
        self.weight_1d(dx) * self.weight_1d(dy)
    }

    pub fn name(&self) -> &'static str {
        match self {
            Filter::Box => "box",
            Filter::Tent => "tent",
            Filter::Mitchell => "mitchell",
        }
    }

    /// Parse the CLI form: `box`, `tent` or `mitchell`.
    pub fn parse(s: &str) -> Result<Self, ParseError> {
        Self::ALL
            .into_iter()
            .find(|f| f.name() == s)
            .ok_or_else(|| ParseError::Unknown {
                what: "filter",
                given: s.to_string(),
                expected: "`box`, `tent` or `mitchell`".into(),
            })
    }
}

/// The Mitchell–Netravali cubic k(x) for |x| = `x` pixels, radius 2
/// (Mitchell & Netravali 1988, eq. 8):
/// 6k = (12 − 9B − 6C)x³ + (−18 + 12B + 6C)x² + (6 − 2B)          for x < 1,
/// 6k = (−B − 6C)x³ + (6B + 30C)x² + (−12B − 48C)x + (8B + 24C)   for 1 ≤ x < 2.
fn mitchell(x: f32) -> f32 {
    let (x2, x3) = (x * x, x * x * x);
    let k = if x < 1.0 {
        (12.0 - 9.0 * B - 6.0 * C) * x3 + (-18.0 + 12.0 * B + 6.0 * C) * x2 + (6.0 - 2.0 * B)
    } else if x < 2.0 {
        (-B - 6.0 * C) * x3
            + (6.0 * B + 30.0 * C) * x2
            + (-12.0 * B - 48.0 * C) * x
            + (8.0 * B + 24.0 * C)
    } else {
        0.0
    };
    k / 6.0
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Integrate a 1D weight over its support with the midpoint rule.
    fn integral(f: Filter) -> f64 {
        let n = 200_000;
        let r = f.radius() as f64;
        let h = 2.0 * r / n as f64;
        (0..n)
            .map(|i| f.weight_1d((-r + (i as f64 + 0.5) * h) as f32) as f64 * h)
            .sum()
    }

    #[test]
    fn filters_integrate_to_one() {
        // Each 1D kernel has unit area (Mitchell–Netravali's cubic for any
        // B, C; the tent and the box by construction). 2·10⁵ midpoint
        // steps on a piecewise cubic leave an error far below 1e-6.
        for f in Filter::ALL {
            assert!((integral(f) - 1.0).abs() < 1e-5, "{f:?}: {}", integral(f));
        }
    }

    #[test]
    fn mitchell_is_continuous_and_has_known_values() {
        // k(0) = (6 − 2B)/6 = 8/9, k(1) = B/6 = 1/18 for B = C = 1/3, k(2) = 0.
        assert!((mitchell(0.0) - 8.0 / 9.0).abs() < 1e-6);
        assert!((mitchell(1.0 - 1e-6) - 1.0 / 18.0).abs() < 1e-5);
        assert!((mitchell(1.0) - 1.0 / 18.0).abs() < 1e-6);
        assert!(mitchell(2.0 - 1e-4).abs() < 1e-6);
        // The negative lobe: between 1 and 2 pixels.
        assert!(mitchell(1.5) < 0.0);
    }

    #[test]
    fn parse_round_trips_and_rejects_unknown() {
        for f in Filter::ALL {
            assert_eq!(Filter::parse(f.name()), Ok(f));
        }
        assert!(Filter::parse("gauss")
            .unwrap_err()
            .to_string()
            .contains("mitchell"));
    }
}
