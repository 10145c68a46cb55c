//! Where the samples go inside a pixel. A sampler is a pure function of
//! (pixel, sample index, seed), so images never depend on thread count or
//! tile order.
//!
//! - `Centre`: one sample at the pixel centre (no anti-aliasing).
//! - `OrderedGrid { k }`: S1's ordered-grid supersampling (OGSS): k×k
//!   samples at the centres of a regular k×k grid of sub-pixels, later
//!   averaged by the box filter (S1's downsample).

use glam::Vec2;
use serde::{Deserialize, Serialize};

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Sampler {
    #[default]
    Centre,
    OrderedGrid {
        k: u32,
    },
}

impl Sampler {
    /// Samples per pixel.
    pub fn spp(&self) -> u32 {
        match *self {
            Sampler::Centre => 1,
            Sampler::OrderedGrid { k } => k * k,
        }
    }

    /// Offset in [0, 1)² of sample `index` of pixel (`px`, `py`).
    #[inline]
    pub fn sample(&self, _px: u32, _py: u32, index: u32, _seed: u64) -> Vec2 {
        match *self {
            Sampler::Centre => Vec2::splat(0.5),
            Sampler::OrderedGrid { k } => {
                let (i, j) = (index % k, index / k);
                (Vec2::new(i as f32, j as f32) + 0.5) / k as f32
            }
        }
    }

    /// Parse the CLI form: `centre`, `ogss:K` (or `ogss` for 2×2).
    pub fn parse(s: &str) -> Result<Self, String> {
        match s.split_once(':') {
            None if s == "centre" || s == "center" => Ok(Sampler::Centre),
            None if s == "ogss" => Ok(Sampler::OrderedGrid { k: 2 }),
            Some(("ogss", k)) => match k.parse::<u32>() {
                Ok(k) if (1..=64).contains(&k) => Ok(Sampler::OrderedGrid { k }),
                _ => Err(format!(
                    "ogss grid size must be an integer in 1..=64, got `{k}`"
                )),
            },
            _ => Err(format!(
                "unknown sampler `{s}` (expected `centre` or `ogss:K`)"
            )),
        }
    }

    /// A short name for tables and file names (`centre`, `ogss2`).
    pub fn name(&self) -> String {
        match *self {
            Sampler::Centre => "centre".into(),
            Sampler::OrderedGrid { k } => format!("ogss{k}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ordered_grid_hits_subpixel_centres() {
        let s = Sampler::OrderedGrid { k: 3 };
        let mut got: Vec<_> = (0..9).map(|i| s.sample(5, 7, i, 0)).collect();
        got.sort_by(|a, b| (a.y, a.x).partial_cmp(&(b.y, b.x)).unwrap());
        for (n, p) in got.iter().enumerate() {
            let want = Vec2::new((n % 3) as f32 + 0.5, (n / 3) as f32 + 0.5) / 3.0;
            assert!((*p - want).length() < 1e-7);
        }
        assert_eq!(Sampler::parse("ogss:4"), Ok(Sampler::OrderedGrid { k: 4 }));
        assert!(Sampler::parse("ogss:0").is_err());
        assert!(Sampler::parse("jitter").is_err());
    }
}
