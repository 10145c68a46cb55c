//! Rays, frames and colour helpers: the small vocabulary every other module
//! speaks. Geometry is single precision (`glam::Vec3`), as in Embree, so the
//! two can be compared on equal terms; the few places that need more
//! precision (the watertight triangle fallback) widen locally.

pub mod aabb;
pub mod dual;
pub mod isa;
pub mod moments;
pub mod real;
pub mod rng;
pub mod sampling;

#[cfg(target_arch = "x86_64")]
pub use aabb::slab8_avx2;
pub use aabb::{slab4, slab4_distances, slab8, slab8_with, Aabb, Planes8, SLAB_EXIT_SCALE};
pub use dual::Dual;
pub use isa::{Avx2, Baseline, Isa};
pub use moments::Moments;
pub use real::{RayR, Real, M3, V3};
pub use rng::{SplitMix64, Words};
pub use sampling::{cosine_hemisphere, uniform_sphere, uniform_triangle};

pub use glam::{Mat3, Vec3};

/// The largest magnitude a coordinate of the scene's geometry may have
/// (vertices, centres, the camera, lights; radii count from the centre),
/// checked when a scene or mesh is read. Single precision holds numbers up
/// to 3.4·10³⁸, but the ray tests and the tree builders multiply
/// coordinates: the triangle test's `t` is a triple product of differences
/// of coordinates, at most (2·10¹²)³ = 8·10³⁶ here, and the SAH multiplies
/// a box's surface area, at most 6·(2·10¹²)² = 2.4·10²⁵, by primitive
/// counts below 2³². Beyond this bound those products overflow to ∞ and
/// the trees' costs become ∞ or NaN; a million kilometres in metres is
/// far beyond any scene single precision can resolve anyway.
pub const MAX_COORDINATE: f32 = 1.0e12;

/// A vector for messages, `[x, y, z]` with each component as Rust prints
/// it, in scientific notation from 10⁶ up and below 10⁻⁴: `[-1e38, 0, 0]`,
/// not 39 digits.
#[derive(Clone, Copy, Debug)]
pub struct ShowVec(pub Vec3);

impl std::fmt::Display for ShowVec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let one = |x: f32| {
            if x.abs() >= 1e6 || (x != 0.0 && x.abs() < 1e-4) {
                format!("{x:e}")
            } else {
                format!("{x}")
            }
        };
        let v = self.0;
        write!(f, "[{}, {}, {}]", one(v.x), one(v.y), one(v.z))
    }
}

/// Linear RGB radiance or reflectance.
pub type Color = Vec3;

/// A ray `r(t) = origin + t·dir` (S2: "S + tD"). `dir` need not be unit
/// length: intersection routines work for any non-zero direction and report
/// `t` in units of `dir`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
}

impl Ray {
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Self { origin, dir }
    }

    /// The point at parameter `t`.
    #[inline(always)]
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + t * self.dir
    }
}

// ANCHOR: reflect
/// Mirror direction of `d` about the normal `n` (S2: P = 2(N·(−D))N + D).
/// `n` must be unit length; `d` may have any length and the result keeps it.
#[inline]
pub fn reflect(d: Vec3, n: Vec3) -> Vec3 {
    d + 2.0 * n.dot(-d) * n
}
// ANCHOR_END: reflect

// ANCHOR: refract
/// Refracted direction by Snell's law (S2's formula). `i` points *away* from
/// the surface towards where the ray came from (I = −D, unit), `n` is the unit
/// normal on the incident side (n·i > 0), `eta = n1/n2`. Returns `None` on
/// total internal reflection, where the square root's argument is negative:
/// T = (η(N·I) − sqrt(1 − η²(1 − (N·I)²)))·N − η·I.
#[inline]
pub fn refract(i: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let cos_i = n.dot(i);
    let k = 1.0 - eta * eta * (1.0 - cos_i * cos_i);
    if k < 0.0 {
        None
    } else {
        Some((eta * cos_i - k.sqrt()) * n - eta * i)
    }
}
// ANCHOR_END: refract

/// Orthonormal frame (right-handed) around a unit vector `n`, after Duff et
/// al. 2017, "Building an Orthonormal Basis, Revisited" (branch-free).
pub fn orthonormal_basis(n: Vec3) -> (Vec3, Vec3) {
    let (t, b) = orthonormal_basis_r(V3::from(n));
    (t.into(), b.into())
}

/// [`orthonormal_basis`] over [`Real`]: the frame turns with `n` (the
/// branch on the sign of n.z is taken on its value).
#[inline]
pub fn orthonormal_basis_r<R: Real>(n: V3<R>) -> (V3<R>, V3<R>) {
    let sign = R::from_f32(1.0f32.copysign(n.z.value()));
    let one = R::one();
    let a = -one / (sign + n.z);
    let b = n.x * n.y * a;
    (
        V3::new(one + sign * n.x * n.x * a, sign * b, -sign * n.x),
        V3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// Rotation from Euler angles in degrees, applied about x, then y, then z
/// (R = Rz·Ry·Rx): the convention of the scene files.
/// The formula is [`M3::rotation_xyz_degrees`], written once over [`Real`]
/// so that rotations can be differentiated.
pub fn rotation_xyz_degrees(deg: Vec3) -> Mat3 {
    let m = M3::<f32>::rotation_xyz_degrees(deg.into());
    Mat3::from_cols(m.rows[0].into(), m.rows[1].into(), m.rows[2].into()).transpose()
}

/// Percentiles (given in [0, 100]) of `values`, by nearest rank.
pub fn percentiles(values: &mut [f64], which: &[f64]) -> Vec<f64> {
    values.sort_by(f64::total_cmp);
    which
        .iter()
        .map(|&q| {
            if values.is_empty() {
                f64::NAN
            } else {
                let k = ((q / 100.0) * (values.len() - 1) as f64).round() as usize;
                values[k.min(values.len() - 1)]
            }
        })
        .collect()
}

/// The sRGB transfer function (IEC 61966-2-1) for one linear value in [0, 1].
pub fn srgb_encode(linear: f32) -> f32 {
    let c = linear.clamp(0.0, 1.0);
    if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// Inverse of [`srgb_encode`].
pub fn srgb_decode(encoded: f32) -> f32 {
    let c = encoded.clamp(0.0, 1.0);
    if c <= 0.040_45 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Relative luminance of linear Rec.709/sRGB primaries.
pub fn luminance(c: Color) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// Largest absolute coordinate: the scale used for self-intersection offsets.
#[inline]
pub fn max_abs(p: Vec3) -> f32 {
    p.abs().max_element()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_round_trip() {
        for i in 0..=100 {
            let x = i as f32 / 100.0;
            assert!((srgb_decode(srgb_encode(x)) - x).abs() < 1e-6);
        }
    }

    #[test]
    fn basis_is_orthonormal() {
        for n in [
            Vec3::X,
            Vec3::Y,
            Vec3::Z,
            -Vec3::Z,
            Vec3::new(1.0, 2.0, -3.0).normalize(),
        ] {
            let (t, b) = orthonormal_basis(n);
            assert!(t.dot(b).abs() < 1e-6 && t.dot(n).abs() < 1e-6 && b.dot(n).abs() < 1e-6);
            assert!((t.length() - 1.0).abs() < 1e-6 && (b.length() - 1.0).abs() < 1e-6);
            assert!((t.cross(b) - n).length() < 1e-5);
        }
    }
}
