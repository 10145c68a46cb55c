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
#[inline]
pub fn cosine_hemisphere(u: glam::Vec2) -> Vec3 {
    let (a, b) = (2.0 * u.x - 1.0, 2.0 * u.y - 1.0);
    let (r, phi) = if a == 0.0 && b == 0.0 {
        (0.0, 0.0)
    } else if a.abs() > b.abs() {
        (a, std::f32::consts::FRAC_PI_4 * (b / a))
    } else {
        (
            b,
            std::f32::consts::FRAC_PI_2 - std::f32::consts::FRAC_PI_4 * (a / b),
        )
    };
    let (x, y) = (r * phi.cos(), r * phi.sin());
    Vec3::new(x, y, (1.0 - x * x - y * y).max(0.0).sqrt())
}
// ANCHOR_END: cosine_hemisphere

/// Barycentrics (b₁, b₂) of a uniformly distributed point in a triangle
/// (p = p₀ + b₁(p₁ − p₀) + b₂(p₂ − p₀)) by the square-root warp of
/// pbrt-v3 §13.6.5: one vertex gets weight 1 − √u₁, another u₂·√u₁, which is
/// uniform in area whichever vertices they are.
#[inline]
pub fn uniform_triangle(u: glam::Vec2) -> (f32, f32) {
    let s = u.x.sqrt();
    (u.y * s, 1.0 - s)
}
