//! Dual numbers: a value and its partial derivatives with respect to K
//! parameters at once (forward-mode automatic differentiation).
//!
//! `Dual<K>` implements [`Real`], so every kernel written over `Real` (the
//! shading formulas, the camera, the closed-form hit of a known primitive)
//! computes its derivatives alongside its value with no second copy of the
//! formula: each operation applies the chain rule to all K partials.
//!
//! **Why our own type and not num-dual's `DualVec`.** num-dual's vectors
//! are nalgebra vectors over a generic float, and its types implement
//! num-dual's `DualNum` trait, not ours: using them would mean a wrapper
//! implementing [`Real`] around each, for the same dozen operations written
//! here directly. A fixed-size `[f32; K]` keeps a dual `Copy`, free of heap
//! and lets the compiler unroll and vectorise the K-wide loops (K is a
//! compile-time constant: renders dispatch to K = 1, 2, 4, 8 or 16). The
//! partials are `f32` like the values: derivatives of a single-precision
//! render are no more accurate than the render itself.

use super::Real;
use std::ops::{Add, AddAssign, Div, Mul, Neg, Sub};

// ANCHOR: dual
/// A value with its partial derivatives with respect to K parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dual<const K: usize> {
    /// The value.
    pub v: f32,
    /// ∂value/∂pᵢ for each parameter i.
    pub d: [f32; K],
}

impl<const K: usize> Dual<K> {
    /// Parameter `i` itself: value `v`, ∂/∂pᵢ = 1, the others 0.
    pub fn variable(v: f32, i: usize) -> Self {
        let mut d = [0.0; K];
        d[i] = 1.0;
        Self { v, d }
    }

    /// The partials scaled and shifted: a ↦ v and ∂ ↦ ∂·s (chain rule of a
    /// map applied to the value, `s` its slope).
    #[inline(always)]
    fn chain(self, v: f32, slope: f32) -> Self {
        Self {
            v,
            d: self.d.map(|x| x * slope),
        }
    }
}
// ANCHOR_END: dual

impl<const K: usize> Default for Dual<K> {
    fn default() -> Self {
        Self::from_f32(0.0)
    }
}

impl<const K: usize> Real for Dual<K> {
    #[inline(always)]
    fn from_f32(v: f32) -> Self {
        Self { v, d: [0.0; K] }
    }
    #[inline(always)]
    fn value(self) -> f32 {
        self.v
    }
    // ANCHOR: dual_sqrt
    #[inline(always)]
    fn sqrt(self) -> Self {
        let s = self.v.sqrt();
        // d√x = dx / 2√x; at x = 0 the derivative is unbounded: keep 0 for a
        // constant, else let it be infinite, as the function is.
        if s == 0.0 && self.d.iter().all(|&x| x == 0.0) {
            return Self::from_f32(s);
        }
        self.chain(s, 0.5 / s)
    }
    // ANCHOR_END: dual_sqrt
    #[inline(always)]
    fn powf(self, e: f32) -> Self {
        let p = self.v.powf(e);
        if e == 0.0 {
            return Self::from_f32(p);
        }
        self.chain(p, e * self.v.powf(e - 1.0))
    }
    #[inline(always)]
    fn pow(self, e: Self) -> Self {
        let mut out = self.powf(e.v);
        if self.v > 0.0 {
            // ∂(x^e)/∂e = x^e·ln x.
            let k = out.v * self.v.ln();
            for (o, de) in out.d.iter_mut().zip(e.d) {
                *o += k * de;
            }
        }
        out
    }
    #[inline(always)]
    fn sin(self) -> Self {
        self.chain(self.v.sin(), self.v.cos())
    }
    #[inline(always)]
    fn cos(self) -> Self {
        self.chain(self.v.cos(), -self.v.sin())
    }
    #[inline(always)]
    fn tan(self) -> Self {
        let c = self.v.cos();
        self.chain(self.v.tan(), 1.0 / (c * c))
    }
}

impl<const K: usize> Add for Dual<K> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Self {
            v: self.v + o.v,
            d: std::array::from_fn(|i| self.d[i] + o.d[i]),
        }
    }
}

impl<const K: usize> AddAssign for Dual<K> {
    #[inline(always)]
    fn add_assign(&mut self, o: Self) {
        *self = *self + o;
    }
}

impl<const K: usize> Sub for Dual<K> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Self {
            v: self.v - o.v,
            d: std::array::from_fn(|i| self.d[i] - o.d[i]),
        }
    }
}

impl<const K: usize> Neg for Dual<K> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        Self {
            v: -self.v,
            d: self.d.map(|x| -x),
        }
    }
}

// ANCHOR: dual_mul
// The product rule adds: (uv)′ = u′v + uv′.
#[allow(clippy::suspicious_arithmetic_impl)]
impl<const K: usize> Mul for Dual<K> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        Self {
            v: self.v * o.v,
            d: std::array::from_fn(|i| self.d[i] * o.v + self.v * o.d[i]),
        }
    }
}
// ANCHOR_END: dual_mul

impl<const K: usize> Div for Dual<K> {
    type Output = Self;
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        let q = self.v / o.v;
        let inv = 1.0 / o.v;
        Self {
            v: q,
            d: std::array::from_fn(|i| (self.d[i] - q * o.d[i]) * inv),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    type D = Dual<2>;

    /// Each operation's partials against central differences of the same
    /// operation in f64.
    #[test]
    fn partials_match_central_differences() {
        let x = D::variable(0.7, 0);
        let y = D::variable(1.9, 1);
        type Case = (&'static str, D, fn(f64, f64) -> f64);
        let cases: Vec<Case> = vec![
            ("x*y", x * y, |a, b| a * b),
            ("x/y", x / y, |a, b| a / b),
            ("x-y", x - y, |a, b| a - b),
            ("sqrt(x*y)", (x * y).sqrt(), |a, b| (a * b).sqrt()),
            ("x^2.5", x.powf(2.5), |a, _| a.powf(2.5)),
            ("y^x", y.pow(x), |a, b| b.powf(a)),
            ("sin x", x.sin(), |a, _| a.sin()),
            ("cos y", y.cos(), |_, b| b.cos()),
            ("tan x", x.tan(), |a, _| a.tan()),
            ("|x-y|", (x - y).abs(), |a, b| (a - b).abs()),
        ];
        let h = 1e-6;
        for (name, got, f) in cases {
            let (a, b) = (0.7f64, 1.9f64);
            let da = (f(a + h, b) - f(a - h, b)) / (2.0 * h);
            let db = (f(a, b + h) - f(a, b - h)) / (2.0 * h);
            assert!((got.v as f64 - f(a, b)).abs() < 1e-6, "{name} value");
            for (g, want) in [(got.d[0], da), (got.d[1], db)] {
                assert!(
                    (g as f64 - want).abs() < 1e-5 * want.abs().max(1.0),
                    "{name}: {g} vs {want}"
                );
            }
        }
    }

    #[test]
    fn detach_drops_the_partials() {
        let x = D::variable(3.0, 1);
        assert_eq!(x.detach(), D::from_f32(3.0));
        assert_eq!((x * x).detach().d, [0.0, 0.0]);
    }
}
