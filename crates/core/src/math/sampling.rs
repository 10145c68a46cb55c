//! Sampling warps: uniform numbers in [0, 1)² mapped to directions and
//! points with known densities. Each warp is written once; the renderers,
//! the light sampler, the workloads and the validator call these.

use glam::Vec3;

/// Uniform direction on the unit sphere from two uniform numbers in [0, 1)
/// (Archimedes: z is uniform in [−1, 1], the azimuth uniform in [0, 2π)).
#[inline]
pub fn uniform_sphere(u: glam::Vec2) -> Vec3 {
    let z = 2.0 * u.x - 1.0;
    let phi = std::f32::consts::TAU * u.y;
    let s = (1.0 - z * z).max(0.0).sqrt();
    Vec3::new(s * phi.cos(), s * phi.sin(), z)
}

// ANCHOR: cosine_hemisphere
/// Cosine-weighted direction about +z (Malley's method: a uniform point on
/// the unit disc, concentric map of Shirley & Chiu 1997, lifted to the
/// hemisphere); density cos θ / π per steradian.
#[inline(always)]
pub fn cosine_hemisphere(u: glam::Vec2) -> Vec3 {
    let (a, b) = (2.0 * u.x - 1.0, 2.0 * u.y - 1.0);
    // The square's point (a, b) goes to radius r = a at angle φ = π/4 · b/a
    // where |a| > |b|, else to r = b at φ = π/2 − π/4 · a/b, whose cosine
    // and sine are the sine and cosine of θ = π/4 · a/b.
    let wide = a.abs() > b.abs();
    let (r, q) = if wide { (a, b) } else { (b, a) };
    let ratio = if r == 0.0 { 0.0 } else { q / r };
    let (s, c) = sin_cos_quarter(std::f32::consts::FRAC_PI_4 * ratio);
    let (x, y) = if wide { (r * c, r * s) } else { (r * s, r * c) };
    Vec3::new(x, y, (1.0 - x * x - y * y).max(0.0).sqrt())
}
// ANCHOR_END: cosine_hemisphere

/// The sine and cosine of |θ| ≤ π/4, by their Taylor polynomials through
/// θ⁹ and θ¹⁰ (truncation below 2·10⁻⁹, under a tenth of an `f32` ulp at
/// these values). Written with selects and arithmetic only, unlike the C
/// library's `sincosf`, so that a loop of [`cosine_hemisphere`] over the
/// path tracer's lanes compiles to SIMD instructions and gives each lane
/// the bits of the one-sample call.
#[inline(always)]
fn sin_cos_quarter(t: f32) -> (f32, f32) {
    let t2 = t * t;
    let sin = t
        * (1.0
            + t2 * (-1.0 / 6.0
                + t2 * (1.0 / 120.0 + t2 * (-1.0 / 5040.0 + t2 * (1.0 / 362_880.0)))));
    let cos = 1.0
        + t2 * (-0.5
            + t2 * (1.0 / 24.0
                + t2 * (-1.0 / 720.0 + t2 * (1.0 / 40_320.0 + t2 * (-1.0 / 3_628_800.0)))));
    (sin, cos)
}

/// Barycentrics (b₁, b₂) of a uniformly distributed point in a triangle
/// (p = p₀ + b₁(p₁ − p₀) + b₂(p₂ − p₀)) by the square-root warp of
/// pbrt-v3 §13.6.5: one vertex gets weight 1 − √u₁, another u₂·√u₁, which is
/// uniform in area whichever vertices they are.
#[inline]
pub fn uniform_triangle(u: glam::Vec2) -> (f32, f32) {
    let s = u.x.sqrt();
    (u.y * s, 1.0 - s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec2;

    /// The polynomials against `f64`'s sine and cosine on a dense grid of
    /// [−π/4, π/4], zero and the ends included: within 2 ulps of the exact
    /// values (rounding in the Horner steps; the truncation is far smaller).
    #[test]
    fn quarter_sin_cos_is_within_two_ulps() {
        let ulp = |x: f64| {
            let f = x.abs() as f32;
            f64::from(f32::from_bits(f.to_bits() + 1) - f)
        };
        let n = 200_000;
        let mut worst = 0.0f64;
        for i in 0..=n {
            let t = (-1.0 + 2.0 * i as f64 / n as f64) * std::f64::consts::FRAC_PI_4;
            let t = t as f32;
            let (s, c) = sin_cos_quarter(t);
            let (es, ec) = f64::from(t).sin_cos();
            worst = worst
                .max((f64::from(s) - es).abs() / ulp(es))
                .max((f64::from(c) - ec).abs() / ulp(ec));
        }
        assert!(worst <= 2.0, "worst error {worst} ulps");
        assert_eq!(sin_cos_quarter(0.0), (0.0, 1.0));
    }

    /// The warp against the concentric map evaluated in `f64` with the
    /// library's trigonometry, over a grid of the unit square that
    /// includes its centre, corners, edges and diagonals: the same
    /// direction to 3·10⁻⁷ in x and y, and in z to that times the slope
    /// 1/z of √(1 − r²); unit length; z ≥ 0.
    #[test]
    fn cosine_hemisphere_is_the_concentric_map() {
        let n = 400;
        for i in 0..=n {
            for j in 0..=n {
                let u = Vec2::new(i as f32 / n as f32, j as f32 / n as f32);
                let w = cosine_hemisphere(u);
                let (a, b) = (2.0 * u.x as f64 - 1.0, 2.0 * u.y as f64 - 1.0);
                let (r, phi) = if a == 0.0 && b == 0.0 {
                    (0.0, 0.0)
                } else if a.abs() > b.abs() {
                    (a, std::f64::consts::FRAC_PI_4 * (b / a))
                } else {
                    (
                        b,
                        std::f64::consts::FRAC_PI_2 - std::f64::consts::FRAC_PI_4 * (a / b),
                    )
                };
                let (x, y) = (r * phi.cos(), r * phi.sin());
                let z = (1.0 - x * x - y * y).max(0.0).sqrt();
                // z = √(1 − r²) magnifies rounding in r² by r / z.
                for (got, want, tol) in
                    [(w.x, x, 3e-7), (w.y, y, 3e-7), (w.z, z, 3e-7 / z.max(6e-4))]
                {
                    assert!(
                        (got as f64 - want).abs() <= tol,
                        "u {u}: {w} vs ({x}, {y}, {z})"
                    );
                }
                assert!(w.z >= 0.0 && (w.length() - 1.0).abs() < 1e-6, "u {u}: {w}");
            }
        }
    }

    /// The directions' mean cosine is E[cos θ] = 2/3 under the cos θ / π
    /// density (a stratified grid of 10⁶ points: error far below 10⁻³).
    #[test]
    fn cosine_hemisphere_has_the_cosine_density() {
        let n = 1000;
        let mut sum = 0.0f64;
        for i in 0..n {
            for j in 0..n {
                let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                sum += cosine_hemisphere(u).z as f64;
            }
        }
        let mean = sum / (n * n) as f64;
        assert!((mean - 2.0 / 3.0).abs() < 1e-4, "mean cos θ {mean}");
    }
}
