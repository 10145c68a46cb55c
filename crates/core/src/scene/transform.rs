//! A mesh's object transform, over any [`Real`]: what the builder places
//! every vertex and normal with, and what the scene's check bounds the
//! placed mesh with (before anything is built).

use crate::math::{Real, Vec3, M3, V3};

/// A mesh's object transform over `R`: `fit` (to a box of the mesh's own
/// positions), then `scale`, `rotate` (degrees) and `translate`,
/// x' = T·R·S·x. The normal map is L⁻ᵀ = R·S⁻¹ (S diagonal, R
/// orthonormal).
#[derive(Clone, Copy, Debug)]
pub struct MeshTransform<R> {
    pub linear: M3<R>,
    pub offset: V3<R>,
    pub normal: M3<R>,
}

impl<R: Real> MeshTransform<R> {
    /// The transform of `scale`, `rotate` and `translate`, after fitting
    /// to `fit` = (target size, the mesh's largest extent, its box's
    /// centre) when given.
    pub fn new(scale: V3<R>, rotate: V3<R>, translate: V3<R>, fit: Option<(R, f32, Vec3)>) -> Self {
        let (fit_scale, centre) = match fit {
            None => (R::one(), V3::zero()),
            Some((size, largest, centre)) => (size / R::from_f32(largest), V3::from_vec3(centre)),
        };
        let s = scale * fit_scale;
        let rot = M3::rotation_xyz_degrees(rotate);
        let linear = rot.mul_mat(&M3::diagonal(s));
        let one = R::one();
        let normal = rot.mul_mat(&M3::diagonal(V3::new(one / s.x, one / s.y, one / s.z)));
        Self {
            linear,
            offset: translate - linear.mul_vec(centre),
            normal,
        }
    }

    /// A point of the mesh's own coordinates, placed.
    #[inline]
    pub fn point(&self, p: V3<R>) -> V3<R> {
        self.linear.mul_vec(p) + self.offset
    }

    /// A normal of the mesh's own coordinates, placed and normalised
    /// (zero where it vanishes).
    #[inline]
    pub fn normal(&self, n: V3<R>) -> V3<R> {
        self.normal.mul_vec(n).normalize_or_zero()
    }
}
