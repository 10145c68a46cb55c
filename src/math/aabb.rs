//! The axis-aligned box: bounds of primitives and scenes, the BVH's box
//! volume, the voxel grid's extent. One type, and one slab test in two
//! forms: [`Aabb::slab`] for one box and [`slab4`], its 4-lane SIMD form,
//! for four boxes at once (the BVH's packed sibling pairs and 4-wide
//! nodes). The two do the same operations in the same order, so they give
//! bit-identical distances (tested below).

use glam::{BVec4A, Vec3, Vec4};

/// An axis-aligned box [min, max]. Empty when some min exceeds its max
/// ([`Aabb::EMPTY`] is the identity of [`Aabb::union`]).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

/// ε = 2⁻²⁴, the largest relative error of one rounded f32 operation.
const UNIT_ROUNDOFF: f32 = f32::EPSILON * 0.5;

/// Ize's bound for the slab test ("Robust BVH Ray Traversal", JCGT 2(2),
/// 2013, §3): scaling the exit distance by 1 + 2γ₃, γₙ = nε/(1 − nε), makes
/// the computed interval overlap the exact one whenever the exact one is not
/// empty, so rays through edges and corners of a box are never lost.
pub const SLAB_EXIT_SCALE: f32 = 1.0 + 2.0 * (3.0 * UNIT_ROUNDOFF / (1.0 - 3.0 * UNIT_ROUNDOFF));

impl Aabb {
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    pub fn union(self, o: Aabb) -> Aabb {
        Aabb {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    pub fn include(self, p: Vec3) -> Aabb {
        Aabb {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    pub fn centre(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    pub fn extent(&self) -> Vec3 {
        self.max - self.min
    }

    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }

    /// Surface area (0 for an empty box).
    pub fn surface_area(&self) -> f32 {
        let e = (self.max - self.min).max(Vec3::ZERO);
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }

    /// Enclosed volume (0 for an empty box).
    pub fn volume(&self) -> f32 {
        let e = (self.max - self.min).max(Vec3::ZERO);
        e.x * e.y * e.z
    }

    // ANCHOR: slab
    /// Slab test (Kay & Kajiya 1986) of the ray `origin + t·d`, given
    /// `inv_dir` = 1/d: per axis the ray is inside the slab for t between
    /// (min − o)/d and (max − o)/d; the box is hit where the three intervals
    /// overlap. Returns the entry distance clamped to 0 (a ray starting
    /// inside enters at 0) when the box is met somewhere in [0, `t_max`].
    /// The exit is scaled by [`SLAB_EXIT_SCALE`], so the test is
    /// conservative.
    #[inline]
    pub fn slab(&self, origin: Vec3, inv_dir: Vec3, t_max: f32) -> Option<f32> {
        let t0 = (self.min - origin) * inv_dir;
        let t1 = (self.max - origin) * inv_dir;
        // 0·∞ = NaN arises only when the ray is parallel to an axis (1/d =
        // ±∞) and starts exactly on one of that slab's planes: it then stays
        // in the closed slab for every t, so that axis must not constrain
        // the interval. Replace its bounds by (−∞, +∞) explicitly rather
        // than relying on how min/max treat NaN.
        let free = t0.is_nan_mask() | t1.is_nan_mask();
        let near = Vec3::select(free, Vec3::NEG_INFINITY, t0.min(t1));
        let far = Vec3::select(free, Vec3::INFINITY, t0.max(t1));
        let t_enter = near.max_element();
        let t_exit = far.min_element() * SLAB_EXIT_SCALE;
        (t_enter <= t_exit && t_exit >= 0.0 && t_enter <= t_max).then_some(t_enter.max(0.0))
    }
    // ANCHOR_END: slab
}

/// [`Aabb::slab`] for four boxes at once, lane i being box i: `lo[a]` and
/// `hi[a]` hold the boxes' two planes along axis a (either may be the min:
/// the test takes the smaller distance as the entry). Returns the entry
/// distances clamped to 0 and a bit mask of the lanes whose box is hit in
/// [0, `t_max`]; each lane's result is bit-identical to [`Aabb::slab`].
#[inline(always)]
pub fn slab4(
    lo: &[Vec4; 3],
    hi: &[Vec4; 3],
    origin: Vec3,
    inv_dir: Vec3,
    t_max: f32,
) -> (Vec4, u32) {
    let o = origin.to_array();
    let inv = inv_dir.to_array();
    let dist = |planes: &[Vec4; 3]| -> [Vec4; 3] {
        std::array::from_fn(|a| (planes[a] - Vec4::splat(o[a])) * Vec4::splat(inv[a]))
    };
    slab4_distances(&dist(lo), &dist(hi), t_max)
}

/// The interval logic of [`slab4`] from the plane distances themselves,
/// t0 = (lo − o)/d and t1 = (hi − o)/d per axis: a caller that gets both
/// planes of a pair of boxes from one set of lanes (the binary BVH's packed
/// siblings) computes the distances once and swizzles them.
#[inline(always)]
pub fn slab4_distances(t0: &[Vec4; 3], t1: &[Vec4; 3], t_max: f32) -> (Vec4, u32) {
    let mut enter = Vec4::NEG_INFINITY;
    let mut exit = Vec4::INFINITY;
    for a in 0..3 {
        // As in `Aabb::slab`: a NaN (parallel ray starting on a plane)
        // frees the axis.
        let free: BVec4A = t0[a].is_nan_mask() | t1[a].is_nan_mask();
        enter = enter.max(Vec4::select(free, Vec4::NEG_INFINITY, t0[a].min(t1[a])));
        exit = exit.min(Vec4::select(free, Vec4::INFINITY, t0[a].max(t1[a])));
    }
    let exit = exit * SLAB_EXIT_SCALE;
    let ok = enter.cmple(exit) & exit.cmpge(Vec4::ZERO) & enter.cmple(Vec4::splat(t_max));
    (enter.max(Vec4::ZERO), ok.bitmask())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::SplitMix64;

    /// The SIMD form must agree with the scalar one bit for bit, whatever
    /// the ray: random boxes, random rays, axis-parallel rays (infinite
    /// 1/d) and rays starting exactly on a box's plane (the NaN case).
    #[test]
    fn slab4_is_bit_identical_to_the_scalar_slab() {
        let mut rng = SplitMix64(5);
        let v = |rng: &mut SplitMix64| {
            Vec3::new(
                rng.range(-2.0, 2.0),
                rng.range(-2.0, 2.0),
                rng.range(-2.0, 2.0),
            )
        };
        let mut hits = 0;
        for i in 0..20_000 {
            let boxes: [Aabb; 4] = std::array::from_fn(|_| {
                let (a, b) = (v(&mut rng), v(&mut rng));
                Aabb {
                    min: a.min(b),
                    max: a.max(b),
                }
            });
            let mut origin = v(&mut rng);
            let mut dir = v(&mut rng);
            match i % 4 {
                1 => dir.y = 0.0,
                2 => {
                    dir.x = 0.0;
                    origin.x = boxes[0].min.x;
                }
                _ => {}
            }
            let inv = dir.recip();
            let t_max = rng.range(0.0, 4.0);
            let lane = |f: fn(&Aabb) -> Vec3, a: usize| {
                Vec4::from_array(std::array::from_fn(|k| f(&boxes[k])[a]))
            };
            let lo = [0, 1, 2].map(|a| lane(|b| b.min, a));
            let hi = [0, 1, 2].map(|a| lane(|b| b.max, a));
            let (enter, mask) = slab4(&lo, &hi, origin, inv, t_max);
            for (k, b) in boxes.iter().enumerate() {
                let scalar = b.slab(origin, inv, t_max);
                assert_eq!(mask & (1 << k) != 0, scalar.is_some(), "ray {i} box {k}");
                if let Some(t) = scalar {
                    assert_eq!(enter[k].to_bits(), t.to_bits(), "ray {i} box {k}");
                    hits += 1;
                }
            }
        }
        assert!(hits > 5_000, "too few hits ({hits}) to test anything");
    }
}
