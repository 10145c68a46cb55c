//! The one accumulator of a sample mean and its variance by running sums,
//! S₁ = Σxᵢ and S₂ = Σxᵢ² (in `f64`, where the cancellation in
//! S₂ − S₁²/n costs nothing that matters at the sample sizes of a pixel):
//! the derivative code's per-pixel estimates (the gradient render, the
//! boundary and rim terms) and the studies' spreads over seeds use it.
//! The film's colours keep their own streaming form (Welford's update in
//! `f32`, [`crate::film::PixelStats`]), which renders depend on bit for
//! bit.
//!
//! The count is the caller's: an estimate over n samples of which only
//! some landed here (the others count as zeros) divides by n, not by the
//! number added.

/// Running sums of a sample's values.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Moments {
    /// Σxᵢ.
    pub sum: f64,
    /// Σxᵢ².
    pub sum_squares: f64,
}

impl Moments {
    /// One more value.
    #[inline]
    pub fn add(&mut self, x: f64) {
        self.sum += x;
        self.sum_squares += x * x;
    }

    /// Another sample's values added in.
    #[inline]
    pub fn merge(&mut self, o: &Moments) {
        self.sum += o.sum;
        self.sum_squares += o.sum_squares;
    }

    /// The mean over `n` samples, S₁/n.
    #[inline]
    pub fn mean(&self, n: f64) -> f64 {
        self.sum / n
    }

    /// The unbiased sample variance over `n` samples,
    /// (S₂ − S₁²/n)/(n − 1), never below zero; zero below two samples.
    #[inline]
    pub fn variance(&self, n: f64) -> f64 {
        if n > 1.0 {
            ((self.sum_squares - self.sum * self.sum / n) / (n - 1.0)).max(0.0)
        } else {
            0.0
        }
    }

    /// The variance of the mean over `n` samples,
    /// (S₂ − S₁²/n)/(n(n − 1)), never below zero; zero below two samples.
    #[inline]
    pub fn variance_of_mean(&self, n: f64) -> f64 {
        if n > 1.0 {
            ((self.sum_squares - self.sum * self.sum / n) / (n * (n - 1.0))).max(0.0)
        } else {
            0.0
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against the two-pass formulas, and the variance of the mean is the
    /// variance over n (to rounding).
    #[test]
    fn matches_two_pass_formulas() {
        let xs = [0.25, -1.5, 3.0, 0.125, 2.0];
        let mut m = Moments::default();
        for x in xs {
            m.add(x);
        }
        let n = xs.len() as f64;
        let mean = xs.iter().sum::<f64>() / n;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
        assert!((m.mean(n) - mean).abs() < 1e-15);
        assert!((m.variance(n) - var).abs() < 1e-12);
        assert!((m.variance_of_mean(n) - var / n).abs() < 1e-12);
        // Values counted as zeros beyond those added.
        assert!((m.mean(2.0 * n) - mean / 2.0).abs() < 1e-15);
        let (mut a, mut b) = (Moments::default(), Moments::default());
        for (i, x) in xs.into_iter().enumerate() {
            if i % 2 == 0 {
                a.add(x)
            } else {
                b.add(x)
            }
        }
        a.merge(&b);
        assert!((a.variance(n) - var).abs() < 1e-12);
        assert_eq!(Moments::default().variance(1.0), 0.0);
    }
}
