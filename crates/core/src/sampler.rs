//! Where the samples go inside a pixel. A sampler is a pure function of
//! (pixel, sample index, seed), so images never depend on thread count or
//! tile order.
//!
//! - `Centre`: one sample at the pixel centre (no anti-aliasing).
//! - `OrderedGrid { k }`: S1's ordered-grid supersampling (OGSS): k×k
//!   samples at the centres of a regular k×k grid of sub-pixels, later
//!   averaged by the box filter (S1's downsample).
//! - `RotatedGrid`: RGSS, 4 samples on a 4×4 grid rotated by atan(1/2)
//!   (≈ 26.6°), one in every row and every column of the grid, so near-
//!   horizontal and near-vertical edges see four distinct sample heights
//!   where a 2×2 ordered grid sees two.
//! - `Jittered { k }`: stratified sampling, one uniformly random sample in
//!   each cell of a k×k grid.
//! - `Random { n }`: n independent uniform samples.
//! - `Halton { n }`: the 2D Halton sequence (radical inverses in bases 2 and
//!   3 of the sample index + 1), randomised per pixel by a Cranley–Patterson
//!   rotation: one uniformly random offset per pixel added modulo 1, which
//!   keeps the sequence's low discrepancy and makes each pixel's estimate
//!   unbiased and independent of its neighbours'.
//! - `Sobol { n }`: the first two dimensions of the Sobol sequence (the van
//!   der Corput sequence and the Pascal-matrix dimension: a (0,2)-sequence
//!   in base 2), randomised per pixel by a random digital shift (each
//!   coordinate's bits XORed with one random 32-bit word per pixel). A
//!   digital shift maps every elementary base-2 interval onto another, so
//!   the first 2^m samples still form a (0,m,2)-net: exactly one sample in
//!   each of the 2^m boxes of every shape 2^-a × 2^-(m-a).
//!
//! - `Adaptive { threshold, depth }`: adaptive supersampling after Whitted
//!   (1980): rays through the pixel corners (each shared by four pixels, so
//!   about one ray per pixel), and wherever a square's four corner values
//!   differ in contrast by more than `threshold` it is split in four (five
//!   new rays: the edge midpoints and the centre), down to `depth` levels
//!   (depth 2 = a 4×4 grid of cells, the resolution of OGSS 4×4). Contrast
//!   is Mitchell's (1987) per channel, (max − min)/(max + min). The pixel is
//!   the area-weighted mean of its leaf squares' corner means (the
//!   trapezoid rule). It is not a pure function of the sample index — which
//!   samples exist depends on the image — so [`crate::integrator::render`]
//!   runs it as its own pass; `sample` only gives its first point, the
//!   pixel's top-left corner, and `spp` that one ray. The rays actually
//!   spent are each pixel's count in the film.
//!
//! Random numbers come from a SplitMix64 stream keyed by (seed, pixel,
//! index) — or (seed, pixel) for the per-pixel randomisations — so any
//! sample can be computed alone.

use crate::error::ParseError;
use crate::math::SplitMix64;
use glam::Vec2;
use serde::{Deserialize, Serialize};

#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Sampler {
    #[default]
    Centre,
    OrderedGrid {
        k: u32,
    },
    RotatedGrid,
    Jittered {
        k: u32,
    },
    Random {
        n: u32,
    },
    Halton {
        n: u32,
    },
    Sobol {
        n: u32,
    },
    Adaptive {
        threshold: f32,
        depth: u32,
    },
}

/// The adaptive sampler's defaults: a contrast of 0.1 and two levels (a
/// 4×4 grid of cells where an edge crosses, as OGSS 4×4 everywhere).
pub const ADAPTIVE_THRESHOLD: f32 = 0.1;
pub const ADAPTIVE_DEPTH: u32 = 2;
/// Deepest subdivision accepted (8 levels = a 256×256 grid of cells).
const MAX_DEPTH: u32 = 8;

/// RGSS: sample i sits in column `RGSS[i].0` and row `RGSS[i].1` of a 4×4
/// grid (cell centres), one per row and per column; each is the previous
/// one turned by 90° about the pixel centre.
const RGSS: [(u32, u32); 4] = [(1, 0), (3, 1), (2, 3), (0, 2)];

/// The largest grid side (`ogss:K`, `jitter:K`) and sample count
/// (`random:N`, `halton:N`, `sobol:N`) accepted: typo guards.
const MAX_K: u32 = 256;
const MAX_N: u32 = 65536;

/// 2⁻³², turning a 32-bit fraction into [0, 1).
const INV_2_32: f32 = 1.0 / 4_294_967_296.0;

/// A random stream for pixel (`px`, `py`) and `key` (a sample index, or a
/// constant for per-pixel values).
fn stream(px: u32, py: u32, key: u64, seed: u64) -> SplitMix64 {
    let pixel = (u64::from(py) << 32) | u64::from(px);
    SplitMix64(SplitMix64::keyed(seed, pixel, key))
}

/// Per-pixel randomisations use this key, which no sample index reaches.
const PIXEL_KEY: u64 = u64::MAX;

/// The radical inverse of `i` in `base`: its digits mirrored about the
/// radix point (0.d₁d₂d₃… for i = …d₃d₂d₁).
fn radical_inverse(mut i: u32, base: u32) -> f32 {
    let inv = 1.0 / base as f64;
    let (mut r, mut f) = (0.0f64, inv);
    while i > 0 {
        r += f64::from(i % base) * f;
        i /= base;
        f *= inv;
    }
    r as f32
}

/// Sobol's second dimension as 32 bits of fraction: the generator matrix is
/// the Pascal matrix mod 2, whose columns are obtained by v ← v ⊕ (v ≫ 1).
fn sobol_second(mut i: u32) -> u32 {
    let (mut r, mut v) = (0u32, 1u32 << 31);
    while i != 0 {
        if i & 1 != 0 {
            r ^= v;
        }
        i >>= 1;
        v ^= v >> 1;
    }
    r
}

/// A 32-bit fraction as an f32 in [0, 1): rounding to nearest could give
/// exactly 1.0 for fractions within 2⁻²⁵ of it, so keep the top 24 bits.
fn fraction(bits: u32) -> f32 {
    (bits >> 8) as f32 * (INV_2_32 * 256.0)
}

/// x + y modulo 1, in [0, 1).
fn wrap(x: f32) -> f32 {
    let w = x - x.floor();
    if w >= 1.0 {
        0.0
    } else {
        w
    }
}

/// Point `index` of the 2D Halton sequence before its per-pixel rotation:
/// the radical inverses of `index + 1` in bases 2 and 3. The GPU port
/// reads these from a table made here, so both devices use the same bits.
pub fn halton_point(index: u32) -> Vec2 {
    Vec2::new(radical_inverse(index + 1, 2), radical_inverse(index + 1, 3))
}

impl Sampler {
    /// Samples per pixel.
    pub fn spp(&self) -> u32 {
        match *self {
            Sampler::Centre => 1,
            Sampler::OrderedGrid { k } | Sampler::Jittered { k } => k * k,
            Sampler::RotatedGrid => 4,
            Sampler::Random { n } | Sampler::Halton { n } | Sampler::Sobol { n } => n,
            // Its first ray (the pixel's top-left corner); the rest depend on
            // the image.
            Sampler::Adaptive { .. } => 1,
        }
    }

    /// The sampler's kind without its count (`ogss`, `jitter`, …): the
    /// series of an error-against-samples plot.
    pub fn family(&self) -> &'static str {
        match self {
            Sampler::Centre => "centre",
            Sampler::OrderedGrid { .. } => "ogss",
            Sampler::RotatedGrid => "rgss",
            Sampler::Jittered { .. } => "jitter",
            Sampler::Random { .. } => "random",
            Sampler::Halton { .. } => "halton",
            Sampler::Sobol { .. } => "sobol",
            Sampler::Adaptive { .. } => "adaptive",
        }
    }

    /// Whether this is the adaptive sampler (rendered by its own pass).
    pub fn is_adaptive(&self) -> bool {
        matches!(self, Sampler::Adaptive { .. })
    }

    /// Offset in [0, 1)² of sample `index` of pixel (`px`, `py`).
    #[inline]
    pub fn sample(&self, px: u32, py: u32, index: u32, seed: u64) -> Vec2 {
        match *self {
            Sampler::Centre => Vec2::splat(0.5),
            Sampler::OrderedGrid { k } => {
                let (i, j) = (index % k, index / k);
                (Vec2::new(i as f32, j as f32) + 0.5) / k as f32
            }
            Sampler::RotatedGrid => {
                let (i, j) = RGSS[(index % 4) as usize];
                (Vec2::new(i as f32, j as f32) + 0.5) / 4.0
            }
            Sampler::Jittered { k } => {
                let (i, j) = (index % k, index / k);
                let mut r = stream(px, py, u64::from(index), seed);
                let u = Vec2::new(r.next_f32(), r.next_f32());
                // (i + u)/k rounds below 1 for u < 1 and k ≤ 64: the sum is
                // exact in f32 and the division rounds to at most (k − 2⁻²⁴k)/k.
                (Vec2::new(i as f32, j as f32) + u) / k as f32
            }
            Sampler::Random { .. } => {
                let mut r = stream(px, py, u64::from(index), seed);
                Vec2::new(r.next_f32(), r.next_f32())
            }
            Sampler::Halton { .. } => {
                let mut r = stream(px, py, PIXEL_KEY, seed);
                let shift = Vec2::new(r.next_f32(), r.next_f32());
                let h = halton_point(index);
                Vec2::new(wrap(h.x + shift.x), wrap(h.y + shift.y))
            }
            Sampler::Sobol { .. } => {
                let mut r = stream(px, py, PIXEL_KEY, seed);
                let (sx, sy) = (r.next_u64() as u32, r.next_u64() as u32);
                Vec2::new(
                    fraction(index.reverse_bits() ^ sx),
                    fraction(sobol_second(index) ^ sy),
                )
            }
            // The pixel's first lattice point; see the module docs.
            Sampler::Adaptive { .. } => Vec2::ZERO,
        }
    }

    /// Parse the CLI form: `centre`, `ogss:K` (or `ogss` for 2×2), `rgss`,
    /// `jitter:K`, `random:N`, `halton:N`, `sobol:N`, `adaptive[:T[:D]]`
    /// (contrast threshold T, default 0.1; depth D, default 2).
    pub fn parse(s: &str) -> Result<Self, ParseError> {
        if let Some(rest) = s.strip_prefix("adaptive") {
            return parse_adaptive(rest);
        }
        let count = |what: &str, v: &str, max: u32| match v.parse::<u32>() {
            Ok(k) if (1..=max).contains(&k) => Ok(k),
            _ => Err(ParseError::Value {
                what: what.to_string(),
                expected: format!("an integer in 1..={max}"),
                given: v.to_string(),
            }),
        };
        match s.split_once(':') {
            None if s == "centre" || s == "center" => Ok(Sampler::Centre),
            None if s == "ogss" => Ok(Sampler::OrderedGrid { k: 2 }),
            None if s == "rgss" => Ok(Sampler::RotatedGrid),
            Some(("ogss", k)) => Ok(Sampler::OrderedGrid {
                k: count("ogss grid size", k, MAX_K)?,
            }),
            Some(("jitter", k)) => Ok(Sampler::Jittered {
                k: count("jitter grid size", k, MAX_K)?,
            }),
            Some(("random", n)) => Ok(Sampler::Random {
                n: count("random sample count", n, MAX_N)?,
            }),
            Some(("halton", n)) => Ok(Sampler::Halton {
                n: count("halton sample count", n, MAX_N)?,
            }),
            Some(("sobol", n)) => Ok(Sampler::Sobol {
                n: count("sobol sample count", n, MAX_N)?,
            }),
            _ => Err(ParseError::Unknown {
                what: "sampler",
                given: s.to_string(),
                expected: "`centre`, `ogss:K`, `rgss`, `jitter:K`, `random:N`, `halton:N`, \
                           `sobol:N` or `adaptive[:T[:D]]`"
                    .into(),
            }),
        }
    }

    /// A short name for tables and file names (`centre`, `ogss2`).
    pub fn name(&self) -> String {
        match *self {
            Sampler::Centre => "centre".into(),
            Sampler::OrderedGrid { k } => format!("ogss{k}"),
            Sampler::RotatedGrid => "rgss".into(),
            Sampler::Jittered { k } => format!("jitter{k}"),
            Sampler::Random { n } => format!("random{n}"),
            Sampler::Halton { n } => format!("halton{n}"),
            Sampler::Sobol { n } => format!("sobol{n}"),
            Sampler::Adaptive { threshold, depth } => format!("adaptive{threshold}d{depth}"),
        }
    }
}

/// The part after `adaptive`: empty, `:T` or `:T:D`.
fn parse_adaptive(rest: &str) -> Result<Sampler, ParseError> {
    let mut parts = rest.split(':');
    if parts.next() != Some("") {
        return Err(ParseError::Unknown {
            what: "sampler",
            given: format!("adaptive{rest}"),
            expected: "`adaptive[:T[:D]]`".into(),
        });
    }
    let threshold = match parts.next() {
        None => ADAPTIVE_THRESHOLD,
        Some(t) => match t.parse::<f32>() {
            Ok(v) if v >= 0.0 && v.is_finite() => v,
            _ => {
                return Err(ParseError::Value {
                    what: "adaptive contrast threshold".into(),
                    expected: "a non-negative number".into(),
                    given: t.to_string(),
                })
            }
        },
    };
    let depth = match parts.next() {
        None => ADAPTIVE_DEPTH,
        Some(d) => match d.parse::<u32>() {
            Ok(v) if v <= MAX_DEPTH => v,
            _ => {
                return Err(ParseError::Value {
                    what: "adaptive depth".into(),
                    expected: format!("an integer in 0..={MAX_DEPTH}"),
                    given: d.to_string(),
                })
            }
        },
    };
    if let Some(extra) = parts.next() {
        return Err(ParseError::Extra {
            what: "adaptive",
            expected: "a threshold and a depth (`adaptive:T:D`)",
            extra: extra.to_string(),
        });
    }
    Ok(Sampler::Adaptive { threshold, depth })
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

    fn all() -> Vec<Sampler> {
        [
            "centre",
            "ogss:3",
            "rgss",
            "jitter:4",
            "random:16",
            "halton:16",
            "sobol:16",
        ]
        .iter()
        .map(|s| Sampler::parse(s).unwrap())
        .collect()
    }

    /// Every sample lies in its pixel, [0, 1)², for many pixels and seeds,
    /// and is a pure function of (pixel, index, seed).
    #[test]
    fn samples_lie_in_the_pixel_and_are_deterministic() {
        for s in all() {
            for (px, py, seed) in [(0, 0, 0), (7, 3, 1), (1919, 1079, 42), (u32::MAX, 5, 9)] {
                for i in 0..s.spp() {
                    let p = s.sample(px, py, i, seed);
                    assert!(
                        (0.0..1.0).contains(&p.x) && (0.0..1.0).contains(&p.y),
                        "{} pixel ({px}, {py}) sample {i}: {p}",
                        s.name()
                    );
                    assert_eq!(p, s.sample(px, py, i, seed));
                }
            }
        }
    }

    /// Jittered: exactly one sample in each of the k×k strata.
    #[test]
    fn jitter_puts_one_sample_in_every_stratum() {
        let k = 5;
        let s = Sampler::Jittered { k };
        for seed in 0..20 {
            let mut seen = vec![0; (k * k) as usize];
            for i in 0..s.spp() {
                let p = s.sample(3, 4, i, seed) * k as f32;
                seen[(p.y as u32 * k + p.x as u32) as usize] += 1;
            }
            assert!(seen.iter().all(|&c| c == 1), "{seen:?}");
        }
    }

    /// RGSS: one sample in every row and every column of the 4×4 grid.
    #[test]
    fn rgss_is_a_rotated_rook_pattern() {
        let s = Sampler::RotatedGrid;
        let cells: Vec<(u32, u32)> = (0..4)
            .map(|i| {
                let p = s.sample(0, 0, i, 0) * 4.0;
                (p.x as u32, p.y as u32)
            })
            .collect();
        for k in 0..4 {
            assert_eq!(cells.iter().filter(|c| c.0 == k).count(), 1);
            assert_eq!(cells.iter().filter(|c| c.1 == k).count(), 1);
        }
        // The pattern is the 2×2 grid rotated by atan(1/2): every sample is
        // the previous one turned by 90° about the centre.
        for i in 0..4 {
            let a = s.sample(0, 0, i, 0) - 0.5;
            let b = s.sample(0, 0, (i + 1) % 4, 0) - 0.5;
            assert!((Vec2::new(-a.y, a.x) - b).length() < 1e-6, "{a} {b}");
        }
    }

    /// Sobol with a random digital shift: the first 2^m samples of every
    /// pixel form a (0, m, 2)-net — one sample in each elementary interval
    /// of every shape 2^-a × 2^-(m-a).
    #[test]
    fn sobol_samples_form_nets_in_every_pixel() {
        let m = 6u32;
        let n = 1u32 << m;
        let s = Sampler::Sobol { n };
        for (px, py, seed) in [(0, 0, 0), (11, 2, 5), (640, 480, 77)] {
            let pts: Vec<Vec2> = (0..n).map(|i| s.sample(px, py, i, seed)).collect();
            for a in 0..=m {
                let (cols, rows) = (1u32 << a, 1u32 << (m - a));
                let mut seen = vec![0; n as usize];
                for p in &pts {
                    let (c, r) = ((p.x * cols as f32) as u32, (p.y * rows as f32) as u32);
                    seen[(r * cols + c) as usize] += 1;
                }
                assert!(
                    seen.iter().all(|&c| c == 1),
                    "pixel ({px}, {py}) shape {cols}×{rows}"
                );
            }
        }
    }

    /// Halton: the unshifted sequence is the radical inverse (1/2, 1/3),
    /// (1/4, 2/3), (3/4, 1/9), …; the shift moves every sample of a pixel by
    /// the same amount modulo 1.
    #[test]
    fn halton_is_a_shifted_radical_inverse() {
        assert_eq!(radical_inverse(1, 2), 0.5);
        assert!((radical_inverse(3, 3) - 1.0 / 9.0).abs() < 1e-7);
        assert!((radical_inverse(6, 2) - 0.375).abs() < 1e-7);
        let s = Sampler::Halton { n: 8 };
        let d0 = s.sample(2, 9, 0, 3) - Vec2::new(0.5, 1.0 / 3.0);
        for i in 1..8 {
            let d = s.sample(2, 9, i, 3)
                - Vec2::new(radical_inverse(i + 1, 2), radical_inverse(i + 1, 3));
            let diff = d - d0;
            // Equal modulo 1, up to f32 rounding of the sums.
            let off = diff - diff.round();
            assert!(off.length() < 1e-6, "sample {i}: {diff}");
        }
    }

    /// Random samples: uniform, so the mean of 10⁴ is within 0.01 of
    /// (½, ½) (standard error 1/√(12·10⁴) ≈ 0.003 per coordinate).
    #[test]
    fn random_samples_are_uniform_on_average() {
        let s = Sampler::Random { n: 100 };
        let mut sum = Vec2::ZERO;
        for p in 0..100u32 {
            for i in 0..100 {
                sum += s.sample(p, 1, i, 4);
            }
        }
        let mean = sum / 10_000.0;
        assert!(
            (mean - Vec2::splat(0.5)).abs().max_element() < 0.01,
            "{mean}"
        );
    }

    #[test]
    fn names_parse_and_spp() {
        for (text, spp, name) in [
            ("rgss", 4, "rgss"),
            ("jitter:3", 9, "jitter3"),
            ("jitter:256", 65536, "jitter256"),
            ("random:65536", 65536, "random65536"),
            ("random:7", 7, "random7"),
            ("halton:16", 16, "halton16"),
            ("sobol:32", 32, "sobol32"),
            ("adaptive", 1, "adaptive0.1d2"),
            ("adaptive:0.25:3", 1, "adaptive0.25d3"),
        ] {
            let s = Sampler::parse(text).unwrap();
            assert_eq!((s.spp(), s.name().as_str()), (spp, name));
        }
        for bad in [
            "sobol:0",
            "halton:x",
            "random:99999",
            "jitter:257",
            "rgss:4",
            "poisson:4",
            "adaptive:-1",
            "adaptive:0.1:9",
            "adaptive:0.1:2:3",
            "adaptivex",
        ] {
            assert!(Sampler::parse(bad).is_err(), "{bad}");
        }
    }
}
