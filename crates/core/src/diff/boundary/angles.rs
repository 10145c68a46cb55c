//! Curves sampled by the angle they subtend at a path vertex: the choice of
//! curve and of a point on it for the vertex terms ([`super::vertex`],
//! [`super::area`]).
//!
//! Why: a curve's contribution to a vertex's integral carries the speed of
//! its image on the sphere of directions, |dω/dt|, which grows as
//! 1/distance near the vertex. Drawn uniformly among the curves with t
//! uniform, a near edge gives rare, large samples (heavy tails). Drawn in
//! proportion to the angle each subtends, t uniform in that angle, the
//! factor cancels: a sample's weight 1/(P(curve)·p(t)) times |dω/dt| is
//! the total angle of the candidates.
//!
//! Where only the directions towards some emitters matter (the soft-shadow
//! term), each segment is restricted to the arc of its directions that
//! enters the cones round the emitters' bounding spheres: a curve outside
//! every cone contributes 0 and is never drawn, which keeps the estimate
//! unbiased and spends no sample on it.

use super::curves::Curve;
use crate::math::Vec3;

/// Chords per ellipse when its angle is measured.
const ARC_CHORDS: usize = 16;

/// The angle between two directions (not necessarily unit), accurate for
/// small and large angles alike.
fn angle_between(a: Vec3, b: Vec3) -> f32 {
    a.cross(b).length().atan2(a.dot(b))
}

/// The directions from a viewpoint into a sphere: a cone of unit `axis`
/// whose half-angle has cosine `cos` (−1: every direction).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cone {
    pub axis: Vec3,
    pub cos: f32,
}

impl Cone {
    /// The cone from `o` round the sphere (`centre`, `radius`); every
    /// direction when `o` is inside the sphere.
    pub fn towards(o: Vec3, centre: Vec3, radius: f32) -> Self {
        let d = centre - o;
        let dist = d.length();
        if dist.is_nan() || dist <= radius {
            return Cone {
                axis: Vec3::Z,
                cos: -1.0,
            };
        }
        // The half-angle's sine is radius / dist.
        let sin = radius / dist;
        Cone {
            axis: d / dist,
            cos: (1.0 - sin * sin).sqrt(),
        }
    }
}

/// The angles at which a curve is drawn: the segment p0 + t·(p1 − p0)
/// seen from `o` spans the arc φ ∈ [0, Φ] from p0's direction towards
/// p1's, of which [lo, hi] is drawn; an ellipse is drawn whole with t
/// uniform, `hi − lo` being its angle.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Span {
    lo: f32,
    hi: f32,
}

/// The curves seen from one vertex, ready to be drawn by angle.
pub struct ByAngle {
    o: Vec3,
    curves: Vec<Option<(Curve<f32>, Span)>>,
    total: f32,
}

impl ByAngle {
    /// `curves` seen from `o` (`None`: a curve not seen from there), whole
    /// or, with `cones`, the part of each segment whose directions enter
    /// one of them.
    pub fn new(
        curves: impl IntoIterator<Item = Option<Curve<f32>>>,
        o: Vec3,
        cones: Option<&[Cone]>,
    ) -> Self {
        let curves: Vec<_> = curves
            .into_iter()
            .map(|c| {
                let c = c?;
                let span = span(&c, o, cones)?;
                (span.hi > span.lo).then_some((c, span))
            })
            .collect();
        let total = curves.iter().flatten().map(|(_, s)| s.hi - s.lo).sum();
        ByAngle { o, curves, total }
    }

    /// Whether no curve can be drawn.
    pub fn is_empty(&self) -> bool {
        self.total.is_nan() || self.total <= 0.0
    }

    /// Draw a curve in proportion to its angle (`u_curve`) and t uniform in
    /// that angle (`u_t`): the curve's index, t, and the density of the
    /// pair (the curve's probability times t's density, |dω/dt| / angle
    /// for a segment, 1 for an ellipse).
    pub fn draw(&self, u_curve: f32, u_t: f32) -> Option<(usize, f32, f64)> {
        if self.is_empty() {
            return None;
        }
        let mut target = u_curve * self.total;
        let last = self.curves.iter().rposition(Option::is_some)?;
        let mut index = last;
        for (i, c) in self.curves.iter().enumerate() {
            if let Some((_, s)) = c {
                if target < s.hi - s.lo {
                    index = i;
                    break;
                }
                target -= s.hi - s.lo;
            }
        }
        let (curve, s) = self.curves[index].as_ref()?;
        let width = s.hi - s.lo;
        let chance = f64::from(width / self.total);
        let Curve::Segment { p0, p1 } = *curve else {
            return Some((index, u_t, chance));
        };
        let (a, b) = (p0.value() - self.o, p1.value() - self.o);
        let phi = angle_between(a, b);
        let at = s.lo + u_t * width;
        // The direction at angle `at` from a's meets the segment where the
        // law of sines puts it.
        let (sa, sb) = (
            a.length() * at.sin(),
            b.length() * (phi - at).max(0.0).sin(),
        );
        let t = (sa / (sa + sb)).clamp(0.0, 1.0);
        let q = a + (b - a) * t;
        let density = q.cross(b - a).length() / (q.length_squared() * width);
        (t.is_finite() && density > 0.0 && density.is_finite())
            .then(|| (index, t, chance * f64::from(density)))
    }
}

/// The span of `c` seen from `o` (module doc); `None` when nothing of it is
/// drawn.
fn span(c: &Curve<f32>, o: Vec3, cones: Option<&[Cone]>) -> Option<Span> {
    let at = |t: f32| c.point(t).value() - o;
    let Curve::Segment { .. } = c else {
        let angle = (0..ARC_CHORDS)
            .map(|j| {
                let t = |j: usize| j as f32 / ARC_CHORDS as f32;
                angle_between(at(t(j)), at(t(j + 1)))
            })
            .sum();
        return Some(Span { lo: 0.0, hi: angle });
    };
    let (a, b) = (at(0.0), at(1.0));
    let phi = angle_between(a, b);
    let whole = Span { lo: 0.0, hi: phi };
    let Some(cones) = cones else {
        return Some(whole);
    };
    // The arc is cos φ·e1 + sin φ·e2; its angle to a cone's axis c has
    // cosine R cos(φ − ψ), R and ψ the polar form of (c·e1, c·e2).
    let e1 = a.try_normalize()?;
    let e2 = a.cross(b).cross(a).try_normalize()?;
    let mut out: Option<Span> = None;
    for cone in cones {
        let (p, q) = (cone.axis.dot(e1), cone.axis.dot(e2));
        let r = p.hypot(q);
        let k = if r > 0.0 {
            cone.cos / r
        } else {
            cone.cos.signum() * f32::INFINITY
        };
        let inside = if k <= -1.0 || cone.cos <= -1.0 {
            Some(whole)
        } else if k >= 1.0 {
            None
        } else {
            let (psi, delta) = (q.atan2(p), k.acos());
            // The window [ψ − δ, ψ + δ] and its turns, clipped to [0, Φ].
            [-1.0f32, 0.0, 1.0]
                .iter()
                .filter_map(|&turn| {
                    let centre = psi + turn * std::f32::consts::TAU;
                    let (lo, hi) = ((centre - delta).max(0.0), (centre + delta).min(phi));
                    (hi > lo).then_some(Span { lo, hi })
                })
                .reduce(hull)
        };
        if let Some(s) = inside {
            out = Some(out.map_or(s, |o| hull(o, s)));
        }
    }
    out
}

/// The smallest span holding both.
fn hull(a: Span, b: Span) -> Span {
    Span {
        lo: a.lo.min(b.lo),
        hi: a.hi.max(b.hi),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::V3;

    fn segment(p0: Vec3, p1: Vec3) -> Curve<f32> {
        Curve::Segment {
            p0: V3::from_vec3(p0),
            p1: V3::from_vec3(p1),
        }
    }

    /// The density `draw` reports is the density it draws with: a
    /// histogram of t over many draws matches it, for a whole segment and
    /// for one cut to a cone; and a segment outside every cone is never
    /// drawn. (A cut bin at the cut's ends integrates to less than its
    /// width, the part of it drawn.)
    #[test]
    fn draws_follow_their_reported_density() {
        let o = Vec3::ZERO;
        let seg = segment(Vec3::new(-3.0, 0.2, 1.0), Vec3::new(4.0, 0.5, 1.5));
        let far = segment(Vec3::new(0.0, 5.0, -1.0), Vec3::new(1.0, 5.0, -1.0));
        let cone = Cone::towards(o, Vec3::new(0.5, 0.3, 1.2), 0.3);
        for cones in [None, Some(&[cone][..])] {
            let set = ByAngle::new([Some(seg), None, Some(far)], o, cones);
            let bins = 20;
            let n = 200_000;
            let mut hist = vec![0u32; bins];
            let mut mass = vec![0.0f64; bins];
            let mut rng = crate::math::SplitMix64(7);
            for _ in 0..n {
                let (i, t, pdf) = set.draw(rng.next_f32(), rng.next_f32()).unwrap();
                if cones.is_some() {
                    assert_eq!(i, 0, "the far segment lies outside the cone");
                }
                if i == 0 {
                    let k = ((t * bins as f32) as usize).min(bins - 1);
                    hist[k] += 1;
                    // Accumulate 1/pdf: its sum over a bin estimates the
                    // bin's width wherever the density is positive.
                    mass[k] += 1.0 / pdf;
                }
            }
            // Every bin with draws, away from the ends of a cone's cut,
            // integrates to its width (1/bins) within a few per cent.
            let full = |k: usize| hist[k] > 2000;
            let empty = hist.iter().filter(|&&h| h == 0).count();
            assert_eq!(empty > 0, cones.is_some(), "{hist:?}");
            for (k, &m) in mass.iter().enumerate().take(bins - 1).skip(1) {
                if full(k - 1) && full(k) && full(k + 1) {
                    let width = m / n as f64;
                    assert!(
                        (width * bins as f64 - 1.0).abs() < 0.05,
                        "{cones:?} bin {k}: {width}"
                    );
                }
            }
        }
    }

    /// Inside the cone's arc every direction is within the cone's angle;
    /// the arc's ends are on its rim or at the segment's ends.
    #[test]
    fn a_cone_cuts_the_arc_at_its_rim() {
        let o = Vec3::new(0.1, -0.2, 0.0);
        let seg = segment(Vec3::new(-3.0, 0.0, 2.0), Vec3::new(3.0, 0.0, 2.0));
        let cone = Cone::towards(o, Vec3::new(0.0, 0.0, 2.0), 0.5);
        let s = span(&seg, o, Some(&[cone])).unwrap();
        let whole = span(&seg, o, None).unwrap();
        assert!(s.lo > 0.0 && s.hi < whole.hi);
        let a = (Vec3::new(-3.0, 0.0, 2.0) - o).normalize();
        let e2 = a.cross(Vec3::new(3.0, 0.0, 2.0) - o).cross(a).normalize();
        for phi in [s.lo, s.hi] {
            let d = a * phi.cos() + e2 * phi.sin();
            assert!((d.dot(cone.axis) - cone.cos).abs() < 1e-5);
        }
    }
}
